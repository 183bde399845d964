//! The TLS configurations of `volasso receive --tls-cert --tls-key [--tls-ca]` (the server) and
//! of the PACS client (`volasso pacs --tls-ca [--tls-cert --tls-key]`, [`client_config`]): DICOM's BCP 195
//! TLS profile (PS3.15 Annex B.9): TLS 1.2 or 1.3 only, and only cipher suites with forward
//! secrecy and authenticated encryption, as BCP 195 (RFC 9325 §4.2) recommends: for TLS 1.2
//! ECDHE with AES-GCM (ECDSA or RSA certificates), for TLS 1.3 AES-GCM. rustls offers no
//! DHE suites, no CBC suites and no compression; its session tickets and renegotiation rules
//! are BCP 195's. With `--tls-ca`, every peer must present a certificate that chains to one
//! of its certificates (checked by rustls' WebPKI verifier); without it, any peer may connect
//! and AE titles (`--allow-ae`) are the only check.
//!
//! The client verifies the PACS's certificate against the CA certificates given (and its name
//! or address against the certificate's), and presents its own certificate when given one.
//!
//! Never: accepts TLS 1.1 or older, a NULL, export or CBC cipher suite, a client certificate
//! that does not verify when a CA is given, or a PACS whose certificate does not verify.

use rustls::crypto::ring::cipher_suite;
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};
use rustls::server::WebPkiClientVerifier;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Why the TLS configuration cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum TlsError {
    /// A PEM file cannot be read or holds no such item.
    #[error("cannot read the {what} ({source}), in {}", path.display())]
    Pem {
        /// What the file should hold.
        what: &'static str,
        /// The PEM reader's error.
        source: rustls::pki_types::pem::Error,
        /// The file.
        path: PathBuf,
    },
    /// The CA file's certificates cannot be used to verify peers.
    #[error("cannot verify peers with these CA certificates ({source}), in {}", path.display())]
    Verifier {
        /// rustls' reason.
        source: rustls::server::VerifierBuilderError,
        /// The CA file.
        path: PathBuf,
    },
    /// A CA certificate is not one rustls can use as a trust anchor.
    #[error("a CA certificate cannot be trusted ({source}), in {}", path.display())]
    Anchor {
        /// rustls' reason.
        source: rustls::Error,
        /// The CA file.
        path: PathBuf,
    },
    /// The certificate and key do not make a server (a key that does not match, an
    /// unsupported key type).
    #[error("the certificate and key cannot serve TLS ({source}), in {}", path.display())]
    Config {
        /// rustls' reason.
        source: rustls::Error,
        /// The certificate file.
        path: PathBuf,
    },
}

/// The files a TLS server is made from.
#[derive(Clone, Debug)]
pub struct TlsFiles {
    /// The server's certificate chain (PEM), its own certificate first.
    pub cert: PathBuf,
    /// The server's private key (PEM: PKCS#8, PKCS#1 or SEC1).
    pub key: PathBuf,
    /// CA certificates (PEM) that peers' certificates must chain to; `None`: no client
    /// certificates asked for.
    pub ca: Option<PathBuf>,
}

/// The TLS 1.2 and 1.3 cipher suites offered (see the module doc), preferred first, with
/// ring's key exchange groups (X25519, P-256, P-384). rustls marks ring's provider deprecated
/// for lacking its post-quantum key exchange, which neither BCP 195 nor DICOM peers (dcmtk,
/// OpenSSL's defaults before 3.5) use; aws-lc-rs, which has it, would add a C build of its own.
#[allow(deprecated)]
fn bcp195_provider() -> rustls::crypto::CryptoProvider {
    rustls::crypto::CryptoProvider {
        cipher_suites: vec![
            cipher_suite::TLS13_AES_256_GCM_SHA384,
            cipher_suite::TLS13_AES_128_GCM_SHA256,
            cipher_suite::TLS_ECDHE_ECDSA_WITH_AES_256_GCM_SHA384,
            cipher_suite::TLS_ECDHE_ECDSA_WITH_AES_128_GCM_SHA256,
            cipher_suite::TLS_ECDHE_RSA_WITH_AES_256_GCM_SHA384,
            cipher_suite::TLS_ECDHE_RSA_WITH_AES_128_GCM_SHA256,
        ],
        ..rustls::crypto::ring::default_provider()
    }
}

/// The error for a PEM file that cannot be read.
fn pem(what: &'static str, path: &Path) -> impl FnOnce(rustls::pki_types::pem::Error) -> TlsError {
    let path = path.to_path_buf();
    move |source| TlsError::Pem { what, source, path }
}

/// The rustls server configuration for `files` (see the module doc).
pub fn server_config(files: &TlsFiles) -> Result<Arc<rustls::ServerConfig>, TlsError> {
    let chain: Vec<CertificateDer<'static>> = CertificateDer::pem_file_iter(&files.cert)
        .and_then(|certificates| certificates.collect::<Result<Vec<_>, _>>())
        .map_err(pem("certificate", &files.cert))?;
    if chain.is_empty() {
        return Err(pem("certificate", &files.cert)(rustls::pki_types::pem::Error::NoItemsFound));
    }
    let key = PrivateKeyDer::from_pem_file(&files.key).map_err(pem("private key", &files.key))?;
    let provider = Arc::new(bcp195_provider());
    let builder = rustls::ServerConfig::builder_with_provider(Arc::clone(&provider))
        .with_protocol_versions(&[&rustls::version::TLS13, &rustls::version::TLS12])
        .map_err(|source| TlsError::Config { source, path: files.cert.clone() })?;
    let builder = match &files.ca {
        None => builder.with_no_client_auth(),
        Some(ca) => {
            let mut roots = rustls::RootCertStore::empty();
            let anchors = CertificateDer::pem_file_iter(ca)
                .and_then(|certificates| certificates.collect::<Result<Vec<_>, _>>())
                .map_err(pem("CA certificates", ca))?;
            if anchors.is_empty() {
                return Err(pem("CA certificates", ca)(rustls::pki_types::pem::Error::NoItemsFound));
            }
            for anchor in anchors {
                roots.add(anchor).map_err(|source| TlsError::Anchor { source, path: ca.clone() })?;
            }
            let verifier = WebPkiClientVerifier::builder_with_provider(Arc::new(roots), provider)
                .build()
                .map_err(|source| TlsError::Verifier { source, path: ca.clone() })?;
            builder.with_client_cert_verifier(verifier)
        }
    };
    let config =
        builder.with_single_cert(chain, key).map_err(|source| TlsError::Config { source, path: files.cert.clone() })?;
    Ok(Arc::new(config))
}

/// The certificates of a PEM file, at least one.
fn certificates(what: &'static str, path: &Path) -> Result<Vec<CertificateDer<'static>>, TlsError> {
    let found = CertificateDer::pem_file_iter(path)
        .and_then(|certificates| certificates.collect::<Result<Vec<_>, _>>())
        .map_err(pem(what, path))?;
    if found.is_empty() {
        return Err(pem(what, path)(rustls::pki_types::pem::Error::NoItemsFound));
    }
    Ok(found)
}

/// The rustls client configuration for a PACS: its certificate must chain to one in `ca`;
/// `identity` (certificate chain and key files) is presented when the PACS asks for one.
pub fn client_config(ca: &Path, identity: Option<(&Path, &Path)>) -> Result<Arc<rustls::ClientConfig>, TlsError> {
    let mut roots = rustls::RootCertStore::empty();
    for anchor in certificates("CA certificates", ca)? {
        roots.add(anchor).map_err(|source| TlsError::Anchor { source, path: ca.to_path_buf() })?;
    }
    let builder = rustls::ClientConfig::builder_with_provider(Arc::new(bcp195_provider()))
        .with_protocol_versions(&[&rustls::version::TLS13, &rustls::version::TLS12])
        .map_err(|source| TlsError::Config { source, path: ca.to_path_buf() })?
        .with_root_certificates(roots);
    let config = match identity {
        None => builder.with_no_client_auth(),
        Some((cert, key)) => {
            let chain = certificates("certificate", cert)?;
            let key = PrivateKeyDer::from_pem_file(key).map_err(pem("private key", key))?;
            builder
                .with_client_auth_cert(chain, key)
                .map_err(|source| TlsError::Config { source, path: cert.to_path_buf() })?
        }
    };
    Ok(Arc::new(config))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_bcp195_suites_and_tls_1_2_or_later_are_offered() {
        let provider = bcp195_provider();
        for suite in &provider.cipher_suites {
            let name = format!("{:?}", suite.suite());
            assert!(name.contains("GCM"), "{name}");
            assert!(name.starts_with("TLS13_") || name.starts_with("TLS_ECDHE_"), "{name}");
        }
        assert_eq!(provider.cipher_suites.len(), 6);
    }

    #[test]
    fn missing_or_empty_pem_files_are_one_clear_error_naming_the_file() {
        let folder = tempfile::tempdir().unwrap();
        let empty = folder.path().join("empty.pem");
        std::fs::write(&empty, "not a PEM file\n").unwrap();
        let files = TlsFiles { cert: empty.clone(), key: empty.clone(), ca: None };
        let error = server_config(&files).unwrap_err().to_string();
        assert!(error.starts_with("cannot read the certificate") && error.ends_with("empty.pem"), "{error}");
        let missing = TlsFiles { cert: folder.path().join("absent.pem"), key: empty, ca: None };
        let error = server_config(&missing).unwrap_err().to_string();
        assert!(error.contains("certificate") && error.ends_with("absent.pem"), "{error}");
    }
}
