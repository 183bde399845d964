//! DICOM over TLS with dcmtk's OpenSSL clients (`echoscu +tls`, `storescu +tls`, their
//! default profile: BCP 195 non-downgrading): echo and the Philips series with a client
//! certificate from the CA given to `--tls-ca`; refused without one, with one from another CA,
//! and for a plain (not TLS) association, after which the receiver still serves. The
//! certificates are made for the test with the `openssl` command.

use super::{Scp, dcmtk_available, series_files, text};
use std::path::{Path, PathBuf};
use std::process::Command;

/// Runs `openssl` with `args` in `folder`.
fn openssl(folder: &Path, args: &[&str]) {
    let output = Command::new("openssl").args(args).current_dir(folder).output().expect("openssl runs");
    assert!(output.status.success(), "openssl {args:?}: {}", String::from_utf8_lossy(&output.stderr));
}

/// A CA (`NAME-ca.pem`, `NAME-ca.key`) in `folder`.
fn make_ca(folder: &Path, name: &str) {
    let (cert, key) = (format!("{name}-ca.pem"), format!("{name}-ca.key"));
    let subject = format!("/CN=volasso test {name} CA");
    let args = ["req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", &key, "-out", &cert, "-days", "2", "-subj"];
    openssl(folder, &[&args[..], &[subject.as_str()]].concat());
}

/// A certificate `NAME.pem` with key `NAME.key` in `folder`, signed by CA `ca`, with the
/// extensions `extensions` (an OpenSSL extension file's lines).
fn make_certificate(folder: &Path, name: &str, ca: &str, extensions: &str) -> (PathBuf, PathBuf) {
    let (cert, key, request, extfile) =
        (format!("{name}.pem"), format!("{name}.key"), format!("{name}.csr"), format!("{name}.ext"));
    std::fs::write(folder.join(&extfile), extensions).unwrap();
    let subject = format!("/CN={name}");
    openssl(folder, &["req", "-newkey", "rsa:2048", "-nodes", "-keyout", &key, "-out", &request, "-subj", &subject]);
    let (ca_cert, ca_key) = (format!("{ca}-ca.pem"), format!("{ca}-ca.key"));
    openssl(
        folder,
        &[
            "x509",
            "-req",
            "-in",
            &request,
            "-CA",
            &ca_cert,
            "-CAkey",
            &ca_key,
            "-CAcreateserial",
            "-out",
            &cert,
            "-days",
            "2",
            "-extfile",
            &extfile,
        ],
    );
    (folder.join(cert), folder.join(key))
}

/// The certificates of a test, made in `dir`: a trusted and a foreign CA, the receiver's
/// certificate (for 127.0.0.1 and localhost) and a client's, both from the trusted CA.
struct Certificates {
    server: (PathBuf, PathBuf),
    client: (PathBuf, PathBuf),
    ca: PathBuf,
    foreign_ca: PathBuf,
}

/// The extensions of a client certificate.
const CLIENT_EXTENSIONS: &str = "basicConstraints=CA:FALSE\nextendedKeyUsage=clientAuth\n";

fn certificates(dir: &Path) -> Certificates {
    make_ca(dir, "trusted");
    make_ca(dir, "foreign");
    let server_extensions =
        "basicConstraints=CA:FALSE\nsubjectAltName=IP:127.0.0.1,DNS:localhost\nextendedKeyUsage=serverAuth\n";
    Certificates {
        server: make_certificate(dir, "server", "trusted", server_extensions),
        client: make_certificate(dir, "client", "trusted", CLIENT_EXTENSIONS),
        ca: dir.join("trusted-ca.pem"),
        foreign_ca: dir.join("foreign-ca.pem"),
    }
}

fn openssl_available() -> bool {
    let found = Command::new("openssl").arg("version").output().is_ok_and(|output| output.status.success());
    if !found {
        eprintln!("SKIPPED: openssl is not installed (.ci/run installs it)");
    }
    found
}

#[test]
fn echo_and_store_over_tls_with_client_certificates_and_plain_or_foreign_peers_refused() {
    if !dcmtk_available() || !openssl_available() {
        return;
    }
    let folder = tempfile::tempdir().unwrap();
    let dir = folder.path();
    let Certificates { server: (server_cert, server_key), client: (client_cert, client_key), ca, .. } =
        certificates(dir);
    let (stranger_cert, stranger_key) = make_certificate(dir, "stranger", "foreign", CLIENT_EXTENSIONS);
    let path = |path: &Path| path.to_str().unwrap().to_string();
    let scp = Scp::start(&["--tls-cert", &path(&server_cert), "--tls-key", &path(&server_key), "--tls-ca", &path(&ca)]);
    let tls_with = |cert: &Path, key: &Path| -> Vec<String> {
        vec!["+tls".into(), path(key), path(cert), "+cf".into(), path(&ca)]
    };
    let trusted = tls_with(&client_cert, &client_key);
    let trusted: Vec<&str> = trusted.iter().map(String::as_str).collect();
    let echo = scp.client("echoscu", &trusted, &[]);
    assert!(echo.status.success(), "echoscu +tls: {}", text(&echo));
    let files = series_files("philips_phantom_5mm");
    let store = scp.client("storescu", &trusted, &files);
    assert!(store.status.success(), "storescu +tls: {}", text(&store));
    let report = scp.next_report();
    assert_eq!((report["event"].as_str(), report["images"].as_u64()), (Some("stored"), Some(28)), "{report}");
    // A plain association on the TLS port: rejected, not left hanging.
    let plain = scp.client("echoscu", &[], &[]);
    assert!(!plain.status.success());
    assert!(text(&plain).contains("Association Rejected"), "plain echoscu: {}", text(&plain));
    // A client certificate from another CA, and none at all: the handshake fails.
    let foreign = tls_with(&stranger_cert, &stranger_key);
    let foreign: Vec<&str> = foreign.iter().map(String::as_str).collect();
    let stranger = scp.client("echoscu", &foreign, &[]);
    assert!(!stranger.status.success(), "a foreign client certificate was accepted: {}", text(&stranger));
    let anonymous = scp.client("echoscu", &["+tla", "+cf", &path(&ca)], &[]);
    assert!(!anonymous.status.success(), "a peer without a certificate was accepted: {}", text(&anonymous));
    // The receiver serves on.
    let again = scp.client("echoscu", &trusted, &[]);
    assert!(again.status.success(), "echoscu +tls after the refusals: {}", text(&again));
    let log = scp.stderr_so_far();
    assert!(log.contains("a plain (not TLS) association request on the TLS port"), "{log}");
}

/// The PACS client over TLS (`volasso pacs send --tls-ca --tls-cert --tls-key`), against the
/// receiver as the TLS peer: stored with the kiosk's certificate; refused by the client when the
/// peer's certificate does not chain to the CA given, and by the peer without a client
/// certificate or without TLS.
#[test]
fn the_pacs_client_stores_over_tls_and_refuses_a_peer_it_cannot_verify() {
    if !dcmtk_available() || !openssl_available() {
        return;
    }
    let folder = tempfile::tempdir().unwrap();
    let Certificates { server: (server_cert, server_key), client: (client_cert, client_key), ca, foreign_ca } =
        certificates(folder.path());
    let path = |path: &Path| path.to_str().unwrap().to_string();
    let scp = Scp::start(&["--tls-cert", &path(&server_cert), "--tls-key", &path(&server_key), "--tls-ca", &path(&ca)]);
    let file = path(&series_files("philips_phantom_5mm")[0]);
    let address = format!("VOLASSO@127.0.0.1:{}", scp.port);
    let send = |extra: &[&str]| {
        let mut command = Command::new(env!("CARGO_BIN_EXE_volasso"));
        command.args(["pacs", "send", "--pacs", &address, "--timeout", "10"]).args(extra).arg(&file);
        command.env_remove("VOLASSO_PACS_TLS_CA").env_remove("VOLASSO_PACS").output().expect("volasso runs")
    };
    let identity = ["--tls-cert", &path(&client_cert), "--tls-key", &path(&client_key)];
    let stored = send(&[&["--tls-ca", &path(&ca)][..], &identity[..]].concat());
    assert!(stored.status.success(), "send over TLS: {}", text(&stored));
    let line: serde_json::Value = serde_json::from_slice(&stored.stdout).expect("one JSON line");
    assert_eq!(line["stored"], true, "{line}");
    for (case, extra) in [
        (
            "a peer whose certificate is not from the CA given",
            [&["--tls-ca", &path(&foreign_ca)][..], &identity[..]].concat(),
        ),
        ("no client certificate", vec!["--tls-ca", &path(&ca)]),
        ("no TLS", vec![]),
    ] {
        let refused = send(&extra.iter().map(|s| s.as_ref()).collect::<Vec<&str>>());
        assert!(!refused.status.success(), "{case}: stored anyway: {}", text(&refused));
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(stderr.contains("volasso: error:") && !stderr.contains("panicked"), "{case}: {stderr}");
    }
}
