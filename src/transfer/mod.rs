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
    #[error("the label volume has {labels} voxels but the volume has {voxels}")]
    LabelCount { labels: usize, voxels: usize },
    #[error("voxel {voxel} has label {label}, but there are only {class_count} classes")]
    LabelOutOfRange { voxel: usize, label: u8, class_count: usize },
    #[error("{class_count} classes: a label volume holds at most 255")]
    TooManyClasses { class_count: usize },
    #[error("there are {styles} class styles for {class_count} classes")]
    StyleCount { styles: usize, class_count: usize },
    #[error("clip box {lo:?}..={hi:?} is empty or outside the volume of {dims:?} voxels")]
    ClipBox { lo: [usize; 3], hi: [usize; 3], dims: [usize; 3] },
    #[error(transparent)]
    Slice(#[from] crate::slices::SliceError),
    #[error("class table is not {expected}: found format {found:?}: {path}")]
    TableFormat { expected: &'static str, found: String, path: PathBuf },
    #[error("class table is not valid JSON ({source}): {path}")]
    TableJson { source: serde_json::Error, path: PathBuf },
    #[error("could not encode the PNG ({source}): {path}")]
    Png { source: image::ImageError, path: PathBuf },
    #[error("an RGBA volume of {dims:?} voxels needs {expected} bytes, not {found}")]
    RgbaSize { dims: [usize; 3], expected: usize, found: usize },
    #[error(transparent)]
    Features(#[from] crate::features::FeatureError),
    #[error("{source}: {path}")]
    Io { source: std::io::Error, path: PathBuf },
}

#[cfg(test)]
mod pictures_tests;
