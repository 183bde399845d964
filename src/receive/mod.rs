//! `volasso receive`: a DICOM storage SCP that a PACS or a modality pushes series to
//! (`interfaces.md`, "receive"; DICOM PS3.4 Annex B Storage and Annex A Verification service
//! classes, PS3.8 upper layer through dicom-ul).
//!
//! It answers C-ECHO and stores CT and MR images (single-frame, enhanced and legacy-converted
//! enhanced) in every transfer syntax the DICOM reader decodes ([`accepted_transfer_syntaxes`]).
//! Other SOP classes are refused at negotiation (their presentation contexts get "abstract
//! syntax not supported") and, should a C-STORE name one anyway, with status 0122H; a data
//! partition more than [`ReceiveOptions::max_disk_use_fraction`] full answers 0xA700 (out of
//! resources). Only the called AE title [`ReceiveOptions::ae_title`] and the calling AE titles
//! in [`ReceiveOptions::allowed_calling_ae`] (any, when empty) are accepted.
//!
//! A series becomes a volume in the data folder only when it is *complete*: its association
//! was released normally, and the series (with what earlier associations sent of it) imports
//! cleanly, exactly as the kiosk would read it (`store.rs`). Each association's files are
//! streamed to a hidden staging folder on the same filesystem (`association.rs`) and renamed
//! into place; an aborted association leaves nothing. One JSON line per series goes to stdout
//! ([`store::SeriesReport`]).
//!
//! Associations are served on their own threads, at most [`MOST_ASSOCIATIONS`] at once.
//!
//! Never: prints or logs a patient's name or ID, names a file after DICOM text, or opens a
//! volume for display.

mod association;
mod dimse;
mod store;

pub use dimse::STORAGE_SOP_CLASSES;
pub use store::{STAGING_FOLDER, SeriesReport, series_name};

use std::io::Write;
use std::net::TcpListener;
use std::path::PathBuf;
use std::sync::{Arc, Condvar, Mutex};

/// Associations served at once; more wait in the listen queue.
pub const MOST_ASSOCIATIONS: usize = 4;

/// What `volasso receive` was told.
#[derive(Clone, Debug)]
pub struct ReceiveOptions {
    /// This SCP's AE title; associations calling another are refused.
    pub ae_title: String,
    /// Calling AE titles allowed to store; empty allows any.
    pub allowed_calling_ae: Vec<String>,
    /// Where series are published.
    pub data_dir: PathBuf,
    /// Above this fraction of the data partition in use, images are refused (0xA700).
    pub max_disk_use_fraction: f64,
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
}

/// The transfer syntaxes offered to senders, preferred first: the uncompressed ones, then
/// every compressed one whose pixel data this build decodes. JPEG Extended (4.51) is left out:
/// CT and MR use its 12-bit form, which jpeg-decoder does not decode, and a sender that is
/// refused it sends another syntax instead.
pub fn accepted_transfer_syntaxes() -> Vec<&'static str> {
    const CANDIDATES: [&str; 12] = [
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
    ];
    CANDIDATES.into_iter().filter(|uid| crate::volume::dicom::readable_transfer_syntax(uid)).collect()
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

/// Serves associations on `listener` until the process ends, printing one JSON line per
/// series to `output`.
pub fn serve(
    listener: TcpListener,
    options: ReceiveOptions,
    output: Arc<Mutex<dyn Write + Send>>,
) -> Result<(), ReceiveError> {
    check_ae_title(&options.ae_title)?;
    for title in &options.allowed_calling_ae {
        check_ae_title(title)?;
    }
    let store = store::Store::open(&options.data_dir)
        .map_err(|source| ReceiveError::DataDir { source, path: options.data_dir.clone() })?;
    let shared = Arc::new((options, store));
    let active = Arc::new((Mutex::new(0usize), Condvar::new()));
    for stream in listener.incoming() {
        let stream = match stream {
            Ok(stream) => stream,
            Err(error) => {
                log::warn!("cannot accept a connection: {error}");
                continue;
            }
        };
        {
            let (count, freed) = &*active;
            let mut count = count.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
            while *count >= MOST_ASSOCIATIONS {
                count = freed.wait(count).unwrap_or_else(|poisoned| poisoned.into_inner());
            }
            *count += 1;
        }
        let (shared, slot, output) = (Arc::clone(&shared), Arc::clone(&active), Arc::clone(&output));
        let peer = stream.peer_addr().map(|address| address.to_string()).unwrap_or_default();
        std::thread::spawn(move || {
            let _slot = Slot(slot);
            let (options, store) = &*shared;
            match association::serve(stream, options, store) {
                association::Outcome::Released(reports) => {
                    let mut output = output.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
                    for report in reports {
                        if let Ok(line) = serde_json::to_string(&report) {
                            let _ = writeln!(output, "{line}");
                        }
                    }
                    let _ = output.flush();
                    log::info!("association from {peer} released");
                }
                association::Outcome::Refused(reason) => log::warn!("association from {peer} refused: {reason}"),
                association::Outcome::Dropped(reason) => {
                    log::warn!("association from {peer} dropped, its images removed: {reason}")
                }
            }
        });
    }
    Ok(())
}

/// One association's place among [`MOST_ASSOCIATIONS`], given back when its thread ends
/// (panicking included).
struct Slot(Arc<(Mutex<usize>, Condvar)>);

impl Drop for Slot {
    fn drop(&mut self) {
        let (count, freed) = &*self.0;
        let mut count = count.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        *count = count.saturating_sub(1);
        freed.notify_one();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_offered_syntax_is_decoded_by_this_build() {
        // A codec feature lost from Cargo.toml would drop its syntaxes here.
        assert_eq!(accepted_transfer_syntaxes().len(), 12, "{:?}", accepted_transfer_syntaxes());
    }

    #[test]
    fn ae_titles_are_checked() {
        assert!(check_ae_title("VOLASSO").is_ok());
        for bad in ["", "   ", "SEVENTEEN_CHARS_X", "A\\B", "Ä"] {
            assert!(check_ae_title(bad).is_err(), "{bad:?}");
        }
    }
}
