//! Strokes: the user's lassos on slices, and the training voxels they select (paper §3.2).
//!
//! A [`Lasso`] is a closed polygon drawn on one slice; it selects the voxels of that slice whose
//! centres lie inside it by the even-odd rule ([`Lasso::selected_voxels`]). A [`StrokesFile`] is
//! the `volasso-strokes/1` JSON file of `interfaces.md`: named classes, each with its lassos;
//! class ids are 1-based positions. [`TrainingSet::from_strokes`] turns it into voxel indices
//! per class, and [`TrainingSet::capped`] bounds their number.
//!
//! Reading checks the format string, axis names, slice indices and point coordinates, and says
//! which class and stroke is wrong; writing goes to a temporary file in the same folder that is
//! then renamed over the target, so a reader never sees half a file.
//!
//! Never: computes features, knows about the classifier, or draws.

mod file;
mod lasso;
mod nesting;
mod training;

pub use file::{FORMAT, MAX_FILE_BYTES, StrokesFile};
pub use lasso::{polygon_rows, row_crossings};
pub use nesting::{NESTED_SHARE, NESTED_SIZE_RATIO};
pub use training::{CAP_SIZE_EXPONENT, ClassSamples, MAX_ROW_CROSSINGS, TrainingSet};

use crate::slices::Axis;
use serde::Serialize;
use std::path::PathBuf;

/// A closed polygon on one slice (closed implicitly: the last point joins the first).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Lasso {
    /// The axis normal to the slice.
    pub axis: Axis,
    /// The slice index along `axis`, 0-based.
    pub slice: usize,
    /// Continuous slice-image coordinates; pixel (i, j) has its centre at (i, j). For axis z a
    /// point is [x, y]; for y, [x, z]; for x, [y, z].
    pub points: Vec<[f64; 2]>,
}

/// One class of a strokes file: its name and lassos.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClassStrokes {
    /// The class's name as the user gave it (for example "bone").
    pub name: String,
    /// The lassos drawn for this class.
    pub strokes: Vec<Lasso>,
}

/// The one error type of the strokes stage. Where a problem sits in the file, the class name
/// and the stroke's 0-based position in that class say so.
#[derive(Debug, thiserror::Error)]
pub enum StrokesError {
    /// The strokes file cannot be read: not a regular file, too large, not UTF-8, or an I/O
    /// error (the message names the file).
    #[error(transparent)]
    Read(#[from] crate::input_file::InputFileError),
    /// The strokes file cannot be written.
    #[error("cannot write the strokes file: {source}, in {}", path.display())]
    Io {
        /// The underlying I/O error.
        source: std::io::Error,
        /// The strokes file.
        path: PathBuf,
    },
    /// The file is not JSON of the strokes file's shape.
    #[error("not a valid strokes file: {source}")]
    Json {
        /// The parser's error, with line and column.
        source: serde_json::Error,
    },
    /// The `format` field names another format or version.
    #[error("the format is '{found}' but '{}' was expected", FORMAT)]
    WrongFormat {
        /// The `format` the file declares.
        found: String,
    },
    /// A stroke's axis is not "x", "y" or "z".
    #[error("stroke {stroke} of class '{class}' has axis '{found}'; it must be \"x\", \"y\" or \"z\"")]
    BadAxis {
        /// Name of the stroke's class.
        class: String,
        /// 0-based position of the stroke in its class.
        stroke: usize,
        /// The axis the file gives.
        found: String,
    },
    /// A stroke's slice index is negative.
    #[error("stroke {stroke} of class '{class}' has the negative slice index {slice}")]
    NegativeSlice {
        /// Name of the stroke's class.
        class: String,
        /// 0-based position of the stroke in its class.
        stroke: usize,
        /// The slice index the file gives.
        slice: i64,
    },
    /// A stroke lies on a slice past the volume's last along its axis.
    #[error(
        "stroke {stroke} of class '{class}' is on slice {slice} along {axis}, but the volume has {slice_count} slices along {axis}"
    )]
    SliceOutOfRange {
        /// Name of the stroke's class.
        class: String,
        /// 0-based position of the stroke in its class.
        stroke: usize,
        /// The axis normal to the stroke's slice.
        axis: Axis,
        /// The stroke's slice index.
        slice: usize,
        /// Slices along that axis in the volume.
        slice_count: usize,
    },
    /// A lasso point has a NaN or infinite coordinate.
    #[error("point {point} of stroke {stroke} of class '{class}' is not a finite number")]
    NonFinitePoint {
        /// Name of the stroke's class.
        class: String,
        /// 0-based position of the stroke in its class.
        stroke: usize,
        /// 0-based position of the point in the stroke.
        point: usize,
    },
    /// A class's lassos enclose no voxel of the volume.
    #[error("the lassos of class {class_id} '{class}' select no voxel inside the volume")]
    EmptyClass {
        /// The class's name.
        class: String,
        /// The class's id (1-based).
        class_id: usize,
    },
    /// Every voxel a class's lassos select is also selected by another class.
    #[error(
        "the lassos of class {class_id} '{class}' select only voxels that class {other_id} '{other}' also selects (voxels of two classes are left out of training)"
    )]
    Overlapped {
        /// The class's name.
        class: String,
        /// The class's id (1-based).
        class_id: usize,
        /// The other class's name.
        other: String,
        /// The other class's id.
        other_id: usize,
    },
    /// The lassos would cost more than [`MAX_ROW_CROSSINGS`] to rasterise.
    #[error(
        "stroke {stroke} of class '{class}' brings the lassos to {crossings} crossings of slice rows, more than the {limit} a strokes file may have (a loop of very many points running across many rows)"
    )]
    TooManyCrossings {
        /// Name of the stroke's class.
        class: String,
        /// 0-based position of the stroke in its class.
        stroke: usize,
        /// Crossings of the lassos up to and including this stroke.
        crossings: u64,
        /// The bound.
        limit: u64,
    },
    /// The file defines no class.
    #[error("the strokes file defines no class")]
    NoClasses,
    /// The file defines more classes than a `u8` label volume can number.
    #[error("{count} classes is more than the 255 a label volume can hold")]
    TooManyClasses {
        /// Number of classes defined.
        count: usize,
    },
    /// An error found in a named strokes file.
    #[error("{source}, in {}", path.display())]
    WithPath {
        /// The strokes file.
        path: PathBuf,
        /// What is wrong with it.
        source: Box<StrokesError>,
    },
}

impl StrokesError {
    /// Adds the file the problem was found in.
    pub fn with_path(self, path: impl Into<PathBuf>) -> StrokesError {
        match self {
            // These already name their path.
            StrokesError::Read(_) | StrokesError::Io { .. } | StrokesError::WithPath { .. } => self,
            other => StrokesError::WithPath { path: path.into(), source: Box::new(other) },
        }
    }

    /// The error without the path context.
    pub fn innermost(&self) -> &StrokesError {
        match self {
            StrokesError::WithPath { source, .. } => source.innermost(),
            other => other,
        }
    }
}
