//! volasso's pipeline: image-centric direct volume rendering (Khan, Ksantini & Guan) as plain
//! data types and functions, one module per stage of the paper (`docs/paper.md`):
//!
//! ```text
//! volume (load, mmap) -> slices (entropy, §3.1) -> strokes (lassos, §3.2) -> features (§3.3)
//!   -> classify (SN-SVM, §3.4) -> segmentation (the whole volume) -> transfer (harmonic colour,
//!   §3.5) -> render (wgpu)
//! ```
//!
//! [`pipeline`] runs it in one call, the one the command line, the kiosk and the accuracy
//! harness share; `phantom` draws scans with known truth and `accuracy` scores the pipeline on
//! them; `uncertainty` finds where a trained segmenter is unsure, for the next loop. The `volasso`
//! crate re-exports every module and documents the tour.
//!
//! Never: knows about a UI, touch input, a display or the network. This crate has none of
//! those among its dependencies, so cargo refuses an import of them here.

#![warn(missing_docs)]

pub mod accuracy;
pub mod atomic_file;
pub mod calendar;
pub mod classify;
pub mod cpu;
pub mod features;
pub mod input_file;
pub mod phantom;
pub mod pipeline;
pub mod preset;
pub mod render;
pub mod rng;
pub mod segmentation;
pub mod slices;
pub mod strokes;
pub mod transfer;
pub mod uncertainty;
pub mod volume;

pub use volume::{Volume, VolumeError, VoxelType};
