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
mod training;

pub use file::{FORMAT, StrokesFile};
pub use lasso::polygon_rows;
pub use training::{ClassSamples, TrainingSet};

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
    pub name: String,
    pub strokes: Vec<Lasso>,
}

/// The one error type of the strokes stage. Where a problem sits in the file, the class name
/// and the stroke's 0-based position in that class say so.
#[derive(Debug, thiserror::Error)]
pub enum StrokesError {
    #[error("cannot access the strokes file: {source}, in {}", path.display())]
    Io { source: std::io::Error, path: PathBuf },
    #[error("not a valid strokes file: {source}")]
    Json { source: serde_json::Error },
    #[error("the format is '{found}' but '{}' was expected", FORMAT)]
    WrongFormat { found: String },
    #[error("stroke {stroke} of class '{class}' has axis '{found}'; it must be \"x\", \"y\" or \"z\"")]
    BadAxis { class: String, stroke: usize, found: String },
    #[error("stroke {stroke} of class '{class}' has the negative slice index {slice}")]
    NegativeSlice { class: String, stroke: usize, slice: i64 },
    #[error(
        "stroke {stroke} of class '{class}' is on slice {slice} along {axis}, but the volume has {slice_count} slices along {axis}"
    )]
    SliceOutOfRange { class: String, stroke: usize, axis: Axis, slice: usize, slice_count: usize },
    #[error("point {point} of stroke {stroke} of class '{class}' is not a finite number")]
    NonFinitePoint { class: String, stroke: usize, point: usize },
    #[error("the lassos of class {class_id} '{class}' select no voxel inside the volume")]
    EmptyClass { class: String, class_id: usize },
    #[error(
        "the lassos of class {class_id} '{class}' select only voxels that class {other_id} '{other}' also selects (voxels of two classes are left out of training)"
    )]
    Overlapped { class: String, class_id: usize, other: String, other_id: usize },
    #[error("the strokes file defines no class")]
    NoClasses,
    #[error("{count} classes is more than the 255 a label volume can hold")]
    TooManyClasses { count: usize },
    #[error("{source}, in {}", path.display())]
    WithPath { path: PathBuf, source: Box<StrokesError> },
}

impl StrokesError {
    /// Adds the file the problem was found in.
    pub fn with_path(self, path: impl Into<PathBuf>) -> StrokesError {
        match self {
            // These already name their path.
            StrokesError::Io { .. } | StrokesError::WithPath { .. } => self,
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
