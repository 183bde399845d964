//! Voxel classification by the SN-SVM of Khan, Ksantini, Ahmad & Guan (paper §3.4;
//! `docs/snsvm.md`, whose section numbers the modules here cite as `snsvm.md §N`): a kernel
//! SVM whose regulariser adds a kernel nonparametric discriminant (KND) term, trained
//! one-vs-one over the painted classes.
//!
//! The pipeline inside this module, as in snsvm.md §7:
//!
//! ```text
//! SampleMatrix + labels ──ovo::train──> per pair: scatter (kappa-NN, §2) ─> snsvm (K̃, §4)
//!   ─> smo (dual QP, §8) ─> γ ──model──> Model { X, Γ, w0 } ──predict──> labels per voxel
//! ```
//!
//! Entry points: [`SnSvmParams::check`], then [`train`] (or [`train_with_classes`]), then
//! [`Model::predict_block`] / [`Model::predict_block_parallel`] on blocks of f32 feature
//! vectors. [`SnSvmParams::plain_svm`] (η = 0) is the plain RBF SVM and skips the scatter work.
//!
//! Numerics: training is f64 and never inverts K (only LU of βI + KQ and of I + ηKR);
//! prediction is f32. Never: reads volumes, computes features, standardises or subsamples
//! samples, or decides which voxels to classify; those are the caller's.

mod error;
mod forest;
mod kernel;
mod model;
mod ovo;
mod params;
mod predict;
mod scatter;
pub mod separable;
mod smo;
mod snsvm;
mod spectrum;
#[cfg(test)]
mod test_support;

pub use error::ClassifyError;
pub use forest::{Forest, ForestParams};
pub use kernel::Kernel;
pub use model::Model;
pub use ovo::{
    CLASS_SET_CAPACITY, ClassPair, ClassSet, MAX_POINTS_PER_PAIR, PairReport, TrainReport, class_set_contains,
    ranks_above, tally_votes, tally_votes_among, train, train_with_classes, vote_winner,
};
pub use params::{ScaleMode, SnSvmParams, SnSvmValidParams};
pub use separable::{Inseparable, find_inseparable};
pub use smo::SolveReport;
pub use snsvm::PenaltySpectra;

/// Training feature vectors: n rows of `dim` values, row-major, already standardised.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleMatrix {
    /// Feature dimension (values per row).
    pub dim: usize,
    /// The n × `dim` values, one sample after another.
    pub values: Vec<f64>,
}

impl SampleMatrix {
    /// Number of rows (0 when `dim` is 0).
    pub fn count(&self) -> usize {
        self.values.len().checked_div(self.dim).unwrap_or(0)
    }
}
