//! volasso: image-centric direct volume rendering (Khan, Ksantini & Guan), on a touch kiosk.
//!
//! The pipeline is a chain of plain data types and pure functions, one module per stage of the
//! paper:
//!
//! ```text
//! volume (load, mmap) -> slices (entropy, §3.1) -> strokes (lassos, §3.2) -> features (§3.3)
//!   -> classify (SN-SVM, §3.4) -> transfer (harmonic colour, §3.5) -> render (wgpu)
//! ```
//!
//! The command line (`cli`), the kiosk UI (`app`, `ui/*.slint`) and its platform and input
//! layers (`kiosk`, `touch`) call the pipeline; the pipeline never knows about them.
//! `accuracy` measures the pipeline against phantoms with known truth.

#![warn(missing_docs)]

pub mod accuracy;
#[doc(hidden)]
pub mod app;
pub mod atomic_file;
pub mod classify;
#[doc(hidden)]
pub mod cli;
pub mod cpu;
#[doc(hidden)]
pub mod display;
pub mod features;
#[doc(hidden)]
pub mod kiosk;
pub mod phantom;
pub mod receive;
pub mod render;
pub mod rng;
pub mod segmentation;
pub mod slices;
pub mod strokes;
#[doc(hidden)]
pub mod touch;
pub mod transfer;
pub mod volume;

pub use volume::{Volume, VolumeError, VoxelType};
