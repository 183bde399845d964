//! `volasso receive`: a DICOM storage SCP that a PACS or a modality pushes series to
//! (`interfaces.md`, "receive"; `docs/conformance.md`, its conformance statement; DICOM PS3.4
//! Annex B Storage and Annex A Verification service classes, PS3.8 upper layer through
//! dicom-ul, PS3.15 Annex B.9 BCP 195 TLS).
//!
//! It answers C-ECHO and stores CT and MR images (single-frame, enhanced and legacy-converted
//! enhanced) in every transfer syntax the DICOM reader decodes ([`accepted_transfer_syntaxes`]).
//! Other SOP classes are refused at negotiation (their presentation contexts get "abstract
//! syntax not supported") and, should a C-STORE name one anyway, with status 0122H; a data
//! partition more than [`ReceiveOptions::max_disk_use_fraction`] full answers A700H (out of
//! resources); a data set the kiosk could not read answers C000H or A900H with an Error
//! Comment (`association.rs`). Only the called AE title [`ReceiveOptions::ae_title`] and the
//! calling AE titles in [`ReceiveOptions::allowed_calling_ae`] (any, when empty) are accepted.
//!
//! Success is answered only for an image that is durably stored and readable; a series
//! becomes a volume in the data folder only when it is *stable* (`stable.rs`: quiet for
//! [`ReceiveOptions::stable_after`], or all the images the data announce are there) and
//! imports cleanly, published crash-safely (`store.rs`). One JSON line per published or
//! held-back series goes to stdout ([`store::SeriesReport`]).
//!
//! Each connection is served on its own thread, within [`admission::Limits`] (over them: an
//! A-ASSOCIATE-RJ "local limit exceeded", `admission.rs`) and [`Timeouts`] (`watchdog.rs`);
//! with [`ReceiveOptions::tls`], over TLS only (`tls.rs`).
//!
//! Never: prints or logs a patient's name or ID, names a file after DICOM text, or opens a
//! volume for display.

mod admission;
mod association;
pub(crate) mod dimse;
mod stable;
pub(crate) mod store;
pub mod tls;
mod watchdog;

pub use admission::{Limits, MOST_REJECTING, REJECT_PATIENCE};
pub use dimse::STORAGE_SOP_CLASSES;
pub use store::{KILL_AT_STEP_VARIABLE, STAGING_FOLDER, SeriesReport, series_name};
pub use tls::{TlsError, TlsFiles};

use std::io::Write;
use std::net::TcpListener;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// How long the receiver waits for a peer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timeouts {
    /// From the connection to the negotiated association (TLS handshake and
    /// A-ASSOCIATE-RQ): PS3.8's ARTIM timer.
    pub acse: Duration,
    /// Between two PDUs of an association.
    pub idle: Duration,
    /// From the connection to the end of the association, whatever the peer does.
    pub association: Duration,
}

impl Default for Timeouts {
    fn default() -> Timeouts {
        Timeouts {
            acse: Duration::from_secs(30),
            idle: Duration::from_secs(60),
            association: Duration::from_secs(3600),
        }
    }
}

/// What `volasso receive` was told.
#[derive(Clone, Debug)]
pub struct ReceiveOptions {
    /// This SCP's AE title; associations calling another are refused.
    pub ae_title: String,
    /// Calling AE titles allowed to store; empty allows any.
    pub allowed_calling_ae: Vec<String>,
    /// Where series are published.
    pub data_dir: PathBuf,
    /// Above this fraction of the data partition in use, images are refused (A700H).
    pub max_disk_use_fraction: f64,
    /// A series is published when no image of it has arrived for this long (or sooner, when
    /// all the images the data announce are there).
    pub stable_after: Duration,
    /// Connections served at once, in all and from one peer address.
    pub limits: Limits,
    /// How long peers are waited for.
    pub timeouts: Timeouts,
    /// The port speaks DICOM over TLS only, with these files.
    pub tls: Option<TlsFiles>,
}

/// Why the receiver could not start.
#[derive(Debug, thiserror::Error)]
pub enum ReceiveError {
    /// The data folder cannot be created or written.
    #[error("cannot prepare the data folder: {source}, in {}", path.display())]
    DataDir {
        /// The underlying I/O error.
        source: std::io::Error,
        /// The data folder.
        path: PathBuf,
    },
    /// An AE title breaks DICOM's rules for one.
    #[error("AE title {title:?} {problem}")]
    AeTitle {
        /// The title as given.
        title: String,
        /// The rule it breaks.
        problem: &'static str,
    },
    /// The TLS certificate, key or CA cannot be used.
    #[error(transparent)]
    Tls(#[from] TlsError),
    /// A limit or timeout that cannot work.
    #[error("{setting} {problem}")]
    Setting {
        /// The setting's name.
        setting: &'static str,
        /// What is wrong with its value.
        problem: &'static str,
    },
    /// A thread of the receiver cannot be started.
    #[error("cannot start the receiver's {what} thread: {source}")]
    Thread {
        /// Which thread.
        what: &'static str,
        /// The system's error.
        source: std::io::Error,
    },
}

/// The transfer syntaxes offered to senders, preferred first: the uncompressed ones, then
/// every compressed one whose pixel data this build decodes (JPEG Extended's 12-bit form, as CT
/// and MR use it, through libjpeg-turbo).
pub fn accepted_transfer_syntaxes() -> Vec<&'static str> {
    const CANDIDATES: [&str; 13] = [
        "1.2.840.10008.1.2.1",    // Explicit VR Little Endian
        "1.2.840.10008.1.2",      // Implicit VR Little Endian
        "1.2.840.10008.1.2.2",    // Explicit VR Big Endian
        "1.2.840.10008.1.2.1.99", // Deflated Explicit VR Little Endian
        "1.2.840.10008.1.2.4.70", // JPEG Lossless SV1
        "1.2.840.10008.1.2.4.57", // JPEG Lossless
        "1.2.840.10008.1.2.4.80", // JPEG-LS Lossless
        "1.2.840.10008.1.2.4.81", // JPEG-LS Near-Lossless
        "1.2.840.10008.1.2.4.90", // JPEG 2000 Lossless
        "1.2.840.10008.1.2.4.91", // JPEG 2000
        "1.2.840.10008.1.2.5",    // RLE Lossless
        "1.2.840.10008.1.2.4.50", // JPEG Baseline
        "1.2.840.10008.1.2.4.51", // JPEG Extended
    ];
    CANDIDATES.into_iter().filter(|uid| volasso_core::volume::dicom::readable_transfer_syntax(uid)).collect()
}

/// Checks an AE title: 1 to 16 characters of printable ASCII, not only spaces, no backslash.
pub fn check_ae_title(title: &str) -> Result<(), ReceiveError> {
    let problem = if title.trim().is_empty() || title.len() > 16 {
        Some("must be 1 to 16 characters")
    } else if !title.bytes().all(|byte| (0x20..0x7F).contains(&byte) && byte != b'\\') {
        Some("may hold printable ASCII only, without a backslash")
    } else {
        None
    };
    match problem {
        Some(problem) => Err(ReceiveError::AeTitle { title: title.to_string(), problem }),
        None => Ok(()),
    }
}

/// Serves connections on `listener` until the process ends, printing one JSON line per
/// published or held-back series to `output`.
pub fn serve(
    listener: TcpListener,
    options: ReceiveOptions,
    output: Arc<Mutex<dyn Write + Send>>,
) -> Result<(), ReceiveError> {
    check_ae_title(&options.ae_title)?;
    for title in &options.allowed_calling_ae {
        check_ae_title(title)?;
    }
    if options.limits.total == 0 || options.limits.per_peer == 0 {
        return Err(ReceiveError::Setting { setting: "the association limits", problem: "must be at least 1" });
    }
    let timeouts = options.timeouts;
    if [timeouts.acse, timeouts.idle, timeouts.association].contains(&Duration::ZERO) {
        return Err(ReceiveError::Setting { setting: "the timeouts", problem: "must be longer than 0 seconds" });
    }
    let tls = options.tls.as_ref().map(tls::server_config).transpose()?;
    let data_dir_error = |source| ReceiveError::DataDir { source, path: options.data_dir.clone() };
    std::fs::create_dir_all(&options.data_dir).map_err(data_dir_error)?;
    let (store, pending) = store::Store::open(&options.data_dir).map_err(data_dir_error)?;
    // Each pending series' UID, from one of its files (all were read before they were kept).
    let limits = volasso_core::volume::limits::ReadLimits::default();
    let pending: Vec<(String, String)> = pending
        .into_iter()
        .filter_map(|name| {
            let files = store.pending_files(&name);
            let identity = files.iter().find_map(|file| volasso_core::volume::dicom::read_identity(file, &limits).ok());
            if identity.is_none() {
                log::warn!("series {name}: none of its received images can be read back; it is left unpublished");
            }
            identity.map(|identity| (name, identity.series_uid))
        })
        .collect();
    if !pending.is_empty() {
        log::info!("{} received series not yet published: each is published once stable", pending.len());
    }
    let store = Arc::new(store);
    let tracker = stable::Tracker::start(Arc::clone(&store), pending, options.stable_after, Arc::clone(&output))
        .map_err(|source| ReceiveError::Thread { what: "publishing", source })?;
    let watchdog = watchdog::Watchdog::start().map_err(|source| ReceiveError::Thread { what: "watchdog", source })?;
    let admission = admission::Admission::new(options.limits);
    let context = Arc::new(association::Context::new(options, store, tracker, watchdog, output, tls));
    for stream in listener.incoming() {
        let stream = match stream {
            Ok(stream) => stream,
            Err(error) => {
                log::warn!("cannot accept a connection: {error}");
                continue;
            }
        };
        let Ok(peer) = stream.peer_addr() else { continue };
        let slot = match admission.admit(peer.ip()) {
            Ok(slot) => slot,
            Err(over) => {
                let which = match over {
                    admission::OverLimit::Total => "the receiver's",
                    admission::OverLimit::PerPeer => "its address'",
                };
                log::warn!("connection from {peer} rejected: {which} association limit is reached");
                match &context.tls {
                    None => admission.reject(stream, Some),
                    Some(config) => {
                        let config = Arc::clone(config);
                        admission.reject(stream, move |socket| {
                            let connection = rustls::ServerConnection::new(config).ok()?;
                            Some(rustls::StreamOwned::new(connection, socket))
                        })
                    }
                }
                continue;
            }
        };
        let context = Arc::clone(&context);
        let spawned = std::thread::Builder::new().name("receive-association".into()).spawn(move || {
            let _slot = slot;
            match association::serve(stream, &context) {
                association::Outcome::Released => log::info!("association from {peer} released"),
                association::Outcome::Refused(reason) => log::warn!("association from {peer} refused: {reason}"),
                association::Outcome::Dropped(reason) => {
                    log::warn!("association from {peer} dropped: {reason}; what it stored is kept unpublished")
                }
            }
        });
        if let Err(error) = spawned {
            log::error!("cannot serve a connection from {peer}: {error}");
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_offered_syntax_is_decoded_by_this_build() {
        // A codec feature lost from Cargo.toml would drop its syntaxes here.
        assert_eq!(accepted_transfer_syntaxes().len(), 13, "{:?}", accepted_transfer_syntaxes());
    }

    #[test]
    fn ae_titles_are_checked() {
        assert!(check_ae_title("VOLASSO").is_ok());
        for bad in ["", "   ", "SEVENTEEN_CHARS_X", "A\\B", "Ä"] {
            assert!(check_ae_title(bad).is_err(), "{bad:?}");
        }
    }
}
