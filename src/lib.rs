//! volasso: image-centric direct volume rendering (Khan, Ksantini & Guan), on a touch kiosk.
//!
//! The pipeline is a chain of plain data types and functions, one module per stage of the
//! paper (`docs/paper.md`):
//!
//! ```text
//! volume (load, mmap) -> slices (entropy, §3.1) -> strokes (lassos, §3.2) -> features (§3.3)
//!   -> classify (SN-SVM, §3.4) -> segmentation (the whole volume) -> transfer (harmonic colour,
//!   §3.5) -> render (wgpu)
//! ```
//!
//! [`pipeline`] runs it in one call, the one the command line, the kiosk and the accuracy
//! harness share. A tour: the built-in demo foot, the lassos drawn on it for the benchmarks,
//! classified and coloured, and one slice with its class colours written as a PNG.
//!
//! ```
//! use volasso::{pipeline, phantom, slices, strokes::StrokesFile, transfer};
//! use volasso::segmentation::SegmentationOptions;
//!
//! let volume = phantom::demo_foot().volume;
//! let strokes = StrokesFile::read_for_volume("benches/strokes/demo-foot.strokes.json".as_ref(), volume.dims)?;
//! let classified = pipeline::classify_strokes(
//!     &volume,
//!     &strokes,
//!     &SegmentationOptions::default(), // the paper's SN-SVM
//!     None,                            // the default hue template for the number of classes
//!     pipeline::RunControl::batch(),
//! )?;
//! assert_eq!(classified.table.styles.len(), strokes.classes.len());
//!
//! let z = volume.dims[2] / 2;
//! let window = slices::DisplayWindow::automatic(&volume);
//! let picture = transfer::slice_overlay(
//!     &volume, &classified.labels.labels, &classified.table.styles, slices::Axis::Z, z, window, 0.5,
//! )?;
//! let out = std::env::temp_dir().join("volasso-tour.png");
//! transfer::write_png(&out, &picture)?;
//! # std::fs::remove_file(&out)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Programs that hold their scan as an array use [`pipeline::classify_array`] and
//! [`Volume::stored_view`] (see `examples/classify_array.rs`). The command line and the kiosk
//! (`cli`, `app`, `kiosk`, `touch`, `display`, `ui/*.slint`; the app is `crates/volasso-app`) call the pipeline and are not part
//! of the library's documented surface. The pipeline is a crate of its own,
//! `crates/volasso-core`, re-exported here module by module: it depends on no UI, input or
//! network crate, so cargo refuses any import from it into the app. The DICOM network code
//! (`receive`, `pacs`) and the DICOM objects volasso writes (`dicom_out`) are
//! `crates/volasso-dicom`, which knows the pipeline's volumes and no UI. `accuracy` measures the
//! pipeline against phantoms with known truth.

#![warn(missing_docs)]

/// The appliance's settings file and audit log.
pub use volasso_appliance as appliance;
pub use volasso_core::{
    Volume, VolumeError, VoxelType, accuracy, atomic_file, calendar, classify, cpu, features, input_file, phantom,
    pipeline, preset, render, rng, segmentation, slices, strokes, transfer, uncertainty, volume,
};
pub use volasso_dicom::{dicom_out, pacs, receive};

#[doc(hidden)]
pub use volasso_app as app;
#[doc(hidden)]
pub mod cli;
#[doc(hidden)]
pub use volasso_kiosk::{display, touch};
/// The kiosk's platform (`volasso-kiosk`) and its replay harness (`volasso-replay`), under one
/// name as the command line and the tests use them.
#[doc(hidden)]
pub mod kiosk {
    pub use volasso_kiosk::kiosk::*;
    pub use volasso_replay::{harness, layout, replay};
}
