//! Touch input: from a touchscreen's evdev events to gestures, and a simulated touchscreen that
//! drives the real UI from readable scripts.
//!
//! **How touch reaches the appliance.** The kiosk reads the touchscreen itself, with this
//! module: [`device`] opens `/dev/input/event*` through the `evdev` crate and delivers
//! [`RawEvent`]s, [`ContactTracker`] turns them into finger events in screen pixels
//! ([`ScreenMapping`]: rotation and flips from configuration), and [`GestureRecognizer`]
//! computes taps, drags, pinches, pans and rotations in Rust. No libinput, no compositor: it
//! works with Slint's software renderer on our own DRM output. The replay tests use the very
//! same path: a [`script`] compiles to raw events, which go through the same tracker and
//! recogniser as a real device's, so a replay test exercises the code the finger does.
//!
//! ```text
//! touchscreen (device, evdev) ──┐
//! volasso-events/1 (format) ────┤
//! evemu-record text (evemu) ────┼─> RawEvent ─> ContactTracker ─> FingerEvent ─> GestureRecognizer ─> Gesture
//! replay script (script) ───────┘                (contacts)                       (gestures)
//! ```
//!
//! Files: [`event`] (the kernel's event codes, [`DeviceInfo`]), [`format`](mod@format) (our
//! `volasso-events/1` recordings), [`evemu`] (evemu-record's text), [`contacts`] (protocol B
//! state machine, `SYN_DROPPED` recovery), [`mapping`], [`gestures`], [`script`] (the replay
//! language), [`device`] (Linux only). `volasso record` (`cli/record.rs`) writes recordings.
//!
//! Never: imports Slint or knows what a gesture does to the view; the UI decides that.

pub mod contacts;
#[cfg(target_os = "linux")]
pub mod device;
pub mod evemu;
pub mod event;
pub mod format;
pub mod gestures;
pub mod mapping;
pub mod script;

#[cfg(test)]
mod abuse_tests;

pub use contacts::{ContactTracker, FingerEvent, FingerPhase};
pub use event::{AxisRange, DeviceInfo, RawEvent};
pub use format::Recording;
pub use gestures::{Gesture, GestureRecognizer};
pub use mapping::{OffScreen, Rotation, ScreenMapping};
pub use script::{ElementLocator, Rect, ScriptError, ScriptStep, TouchCommand};

use std::path::PathBuf;

/// Everything reading recordings and touch devices can fail with.
#[derive(Debug, thiserror::Error)]
pub enum TouchError {
    #[error("{format} line {line_number}: {problem}")]
    Parse { format: &'static str, line_number: usize, problem: String },
    #[error("{format}: {problem}")]
    Incomplete { format: &'static str, problem: String },
    #[error("a recording may have at most {limit} events")]
    TooManyEvents { limit: usize },
    /// The recording is not a regular file, too large, or cannot be read.
    #[error(transparent)]
    Read(#[from] crate::input_file::InputFileError),
    #[error("cannot open input device {}: {source}", path.display())]
    OpenDevice { source: std::io::Error, path: PathBuf },
    #[error("not a touchscreen (no ABS_MT_POSITION_X/Y, nor ABS_X/Y with BTN_TOUCH or BTN_LEFT): {}", path.display())]
    NotATouchscreen { path: PathBuf },
    #[error("no touchscreen among the {checked} input devices found (is /dev/input readable?)")]
    NoTouchscreen { checked: usize },
    #[error("reading input device failed: {source}: {}", path.display())]
    ReadDevice { source: std::io::Error, path: PathBuf },
}

/// Reads a recording, telling the format by its first line: `volasso-events/1` or evemu's.
pub fn read_recording(path: &std::path::Path) -> Result<Recording, TouchError> {
    let bytes = crate::input_file::read_bytes(path, "event recording", format::MAX_FILE_BYTES)?;
    let text = String::from_utf8_lossy(&bytes);
    if text.trim_start().starts_with(format::MAGIC) { format::parse(&text) } else { evemu::parse(&text) }
}
