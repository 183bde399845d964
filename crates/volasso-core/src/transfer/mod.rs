//! Transfer functions from classes: harmonic hue templates and per-class colour and opacity
//! (paper §3.5, eq. 4-9; `docs/colour.md`).
//!
//! The output of this stage is a small table, one [`ClassStyle`] per class, from which any
//! voxel's RGBA follows given its class and gradient factor. The renderer evaluates the table
//! after interpolation (post-classification); [`ClassStyle::rgba`] evaluates it on the CPU for
//! the paper's pre-classified RGBA volume ([`rgba_volume`]) and for slice overlays
//! ([`slice_overlay`]).
//!
//! * [`templates`]: hue templates and the per-class hue ranges of eq. 4.
//! * [`opacity`]: the default opacities (see-through: every class visible), eq. 9 kept as an
//!   [`OpacityRule`].
//! * [`harmony`]: eq. 5-9 from one parallel pass of per-class statistics -> `Vec<ClassStyle>`,
//!   for the whole volume or for a clip box; [`ClassTable`] keeps the styles beside a label
//!   volume as JSON.
//! * [`rgba`]: the pre-classified RGBA volume, its NRRD file, and a CPU compositing preview.
//! * [`overlay`]: class colours over grey slices, as PNG.
//!
//! Never: classifies, or touches the GPU.

pub mod harmony;
pub mod opacity;
pub mod overlay;
pub mod rgba;
pub mod style;
mod table;
pub mod templates;

pub use harmony::{
    ClassStatistics, ClipBox, apply_template, class_statistics, class_styles, class_styles_in_box,
    styles_from_statistics,
};
pub use opacity::{ClassSurface, OpacityRule, class_surfaces, see_through_opacities};
pub use overlay::{DEFAULT_OVERLAY_ALPHA, RgbImage, slice_overlay, write_png};
pub use rgba::{composite_along_z, for_each_rgba_group, rgba_volume, stage_rgba_nrrd, write_rgba_nrrd};
pub use style::{ClassStyle, hsv_to_rgb};
pub use table::{CLASS_TABLE_FORMAT, ClassTable, class_table_path};
pub use templates::{HueTemplate, TemplateType};

use std::path::PathBuf;

/// The one error type of the transfer stage.
#[derive(Debug, thiserror::Error)]
pub enum TransferError {
    /// The label volume's length differs from the volume's voxel count.
    #[error("the label volume has {labels} voxels but the volume has {voxels}")]
    LabelCount {
        /// Labels given.
        labels: usize,
        /// Voxels in the volume.
        voxels: usize,
    },
    /// A voxel's label names a class that does not exist.
    #[error("voxel {voxel} has label {label}, but there are only {class_count} classes")]
    LabelOutOfRange {
        /// The voxel's index (x fastest).
        voxel: usize,
        /// Its label.
        label: u8,
        /// Classes there are (labels 1 to `class_count`).
        class_count: usize,
    },
    /// More classes than an 8-bit label volume can name.
    #[error("{class_count} classes: a label volume holds at most 255")]
    TooManyClasses {
        /// Classes asked for.
        class_count: usize,
    },
    /// The number of styles differs from the number of classes.
    #[error("there are {styles} class styles for {class_count} classes")]
    StyleCount {
        /// Styles given.
        styles: usize,
        /// Classes there are.
        class_count: usize,
    },
    /// A clip box is empty or reaches outside the volume.
    #[error("clip box {lo:?}..={hi:?} is empty or outside the volume of {dims:?} voxels")]
    ClipBox {
        /// The box's lowest voxel coordinate, (x, y, z).
        lo: [usize; 3],
        /// The box's highest voxel coordinate, (x, y, z), included.
        hi: [usize; 3],
        /// The volume's size in voxels.
        dims: [usize; 3],
    },
    /// Reading a slice for an overlay failed.
    #[error(transparent)]
    Slice(#[from] crate::slices::SliceError),
    /// A class table file has another `format` than [`CLASS_TABLE_FORMAT`].
    #[error("class table is not {expected}: found format {found:?}: {path}")]
    TableFormat {
        /// The format this build reads.
        expected: &'static str,
        /// The file's `format` field.
        found: String,
        /// The file.
        path: PathBuf,
    },
    /// A class table file is not valid JSON for a [`ClassTable`].
    #[error("class table is not valid JSON ({source}): {path}")]
    TableJson {
        /// The parser's error, with line and column.
        source: serde_json::Error,
        /// The file.
        path: PathBuf,
    },
    /// Encoding a PNG failed.
    #[error("could not encode the PNG ({source}): {path}")]
    Png {
        /// The encoder's error.
        source: image::ImageError,
        /// The image file.
        path: PathBuf,
    },
    /// An RGBA buffer's length does not match its dimensions.
    #[error("an RGBA volume of {dims:?} voxels needs {expected} bytes, not {found}")]
    RgbaSize {
        /// The volume's size in voxels.
        dims: [usize; 3],
        /// Bytes the dimensions call for (4 per voxel).
        expected: usize,
        /// Bytes given.
        found: usize,
    },
    /// Computing the voxels' features (gradient magnitudes) the styles need failed.
    #[error(transparent)]
    Features(#[from] crate::features::FeatureError),
    /// Reading or writing a file failed.
    #[error("{source}: {path}")]
    Io {
        /// The underlying I/O error.
        source: std::io::Error,
        /// The file.
        path: PathBuf,
    },
}

#[cfg(test)]
mod pictures_tests;
