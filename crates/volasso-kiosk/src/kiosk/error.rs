//! What the kiosk can fail with, outside a script's expectations (those are report lines, not
//! errors): the display, the Slint platform, the UI, reading scripts and writing their
//! outputs. Each variant carries the facts, the path last.
//!
//! Never: carries a failed expectation (a replay goes on after one and reports it).

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum KioskError {
    #[error(transparent)]
    Display(#[from] crate::display::DisplayError),
    #[error("a window of {width}x{height} pixels cannot be drawn")]
    WindowSize { width: u32, height: u32 },
    #[error("cannot install the kiosk platform: {reason}")]
    Platform { reason: String },
    #[error("cannot start the UI: {0}")]
    StartUi(#[source] slint::PlatformError),
    #[error("cannot show the UI: {0}")]
    ShowUi(#[source] slint::PlatformError),
    #[error("the UI was still busy after {seconds} s")]
    StillBusy { seconds: u64 },
    /// A script or recording is not a regular file, too large, not UTF-8, or unreadable.
    #[error(transparent)]
    ReadScript(#[from] crate::input_file::InputFileError),
    #[error("{source}, in {}", path.display())]
    Script { source: crate::touch::ScriptError, path: PathBuf },
    #[error("{source}, in {}", path.display())]
    Recording { source: crate::touch::TouchError, path: PathBuf },
    #[error("cannot write: {source}, in {}", path.display())]
    Write { source: std::io::Error, path: PathBuf },
    #[error(transparent)]
    Screenshot(#[from] crate::transfer::TransferError),
}
