//! Voxel feature vectors (paper §3.3): what the classifier sees of a voxel.
//!
//! [`FeatureSet::Paper5`] is the paper's 5-D set, in this order:
//! 0. intensity (the physical value, e.g. HU);
//! 1. 3-D gradient magnitude (eq. 2) from central differences divided by the voxel spacing, so
//!    it is in value units per millimetre and anisotropic volumes are measured correctly;
//! 2. the mean of the 8 neighbours in the xy plane through the voxel (z fixed);
//! 3. the mean of the 8 neighbours in the xz plane (y fixed);
//! 4. the mean of the 8 neighbours in the yz plane (x fixed).
//!
//! Borders clamp to the edge: a neighbour outside the volume reads the nearest voxel inside.
//! The central difference divides by the distance actually spanned, so a border voxel gets the
//! one-sided difference (a linear ramp has its exact gradient everywhere) and an axis one
//! voxel thick contributes 0. (The authors' code used -1 for border voxels, which makes every
//! border voxel look like an edge.)
//!
//! Features are computed on demand, never stored for the whole volume: [`features_of_voxels`]
//! for training voxels, [`FeatureSlabReader`] (a rolling 3-plane buffer) or [`par_map_slabs`]
//! for whole-volume prediction, both giving row-major `n x dim` `f32` blocks in voxel order.
//! Both paths share one arithmetic, so they agree bit for bit. [`Standardiser`] maps features to
//! zero mean and unit deviation, fitted on the training vectors.
//!
//! [`FeatureSet::Paper5Gap`] (the default) appends a sixth, the gap depth (`gap`,
//! [`gap_depth_of_voxels`]): how far a voxel lies below the bright structures around it, which
//! tells a thin dark layer between two of them (a joint space) from the blurred edge of one.
//!
//! [`FeatureSet::Multiscale`] adds smoothed intensity, gradients, Hessian eigenvalues
//! and differences of Gaussians at four scales, computed blockwise (see [`multiscale`]).
//!
//! Never: keeps a feature copy of the volume, knows about classes, or trains anything.

mod eigen;
mod gap;
pub mod multiscale;
mod slab;
mod standardise;
#[cfg(test)]
mod tests;

pub use gap::{GAP_RADIUS, GapPlanes, gap_depth_of_voxels};
pub use multiscale::Scales;
pub use slab::{FeatureSlabReader, par_map_slabs, slab_ranges};
pub use standardise::{Scaling, Standardiser};

use crate::volume::Volume;
use rayon::prelude::*;
use std::ops::Range;

/// Features per voxel of [`FeatureSet::Paper5`] (a constant, so that per-voxel writes of the
/// hot paths are fixed-size stores rather than `memcpy` calls).
const PAPER5_DIM: usize = 5;

/// A choice of per-voxel features.
/// (No `Default`: the product's default set is `segmentation::SegmentationOptions`'s.)
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FeatureSet {
    /// Intensity, gradient magnitude, and the xy, xz, yz 8-neighbour means (§3.3).
    Paper5,
    /// Intensity, smoothed intensity, gradient magnitude, Hessian eigenvalues and differences
    /// of Gaussians at scales 0.8-3.2 voxels (17-D, [`multiscale`]).
    Multiscale,
    /// The same at the two finest scales, 0.8 and 1.15 voxels (9-D; a third of the work).
    MultiscaleFine,
    /// The paper's five and the gap depth ([`gap_depth_of_voxels`]): 6-D.
    Paper5Gap,
}

/// The gradient magnitude's weight in the SN-SVM's distance between paper5 vectors, against 1
/// for each of the other four. Every border in a scan has a high gradient, so at full weight a
/// thin class, whose lassoed voxels are all near its borders, claims the borders of every
/// other structure (the foot phantom's joint space takes 60 % of the bone). Of 1, 1/2, 1/4, 1/8
/// and 0, 1/4 has the best mean with leaky lassos on the accuracy harness's tuning cases
/// (`docs/decisions/0004-gradient-weight.md`).
pub const PAPER5_GRADIENT_WEIGHT: f64 = 0.25;

/// The gap depth's weight in the distance between [`FeatureSet::Paper5Gap`] vectors, against
/// 1 for the intensity. The gap depth is a difference of intensities and is scaled by the
/// intensity's deviation ([`FeatureSet::scaling`]), not its own, so at weight 1 a gap of 100 HU
/// counts as much as 100 HU of intensity. On its own deviation a gap that is only noise (a scan
/// without joints or clefts) is as loud as the intensity, and a weight high enough for a
/// knee's joint space lets a leaky loop around a thin vessel take a whole organ with it. With
/// the cap's class sizes ([`crate::strokes::CAP_SIZE_EXPONENT`]) weight 1 tells a knee's joint
/// space from the bones' blurred edges with leaky loops and 1/2 does not
/// (`docs/decisions/0011-gap-depth.md`).
pub const GAP_WEIGHT: f64 = 1.0;

impl FeatureSet {
    /// How the classifier's distance treats each feature ([`Scaling`]): paper5 counts its
    /// gradient magnitude at [`PAPER5_GRADIENT_WEIGHT`]; the gap depth is measured on the
    /// intensity's scale at [`GAP_WEIGHT`]; the multi-scale sets weigh every feature alike,
    /// each on its own scale.
    pub fn scaling(self) -> Scaling {
        match self {
            FeatureSet::Paper5 => Scaling::weighted(vec![1.0, PAPER5_GRADIENT_WEIGHT, 1.0, 1.0, 1.0]),
            FeatureSet::Paper5Gap => Scaling {
                weights: vec![1.0, PAPER5_GRADIENT_WEIGHT, 1.0, 1.0, 1.0, GAP_WEIGHT],
                unit_of: vec![0, 1, 2, 3, 4, 0],
            },
            FeatureSet::Multiscale | FeatureSet::MultiscaleFine => Scaling::weighted(vec![1.0; self.dim()]),
        }
    }

    /// One flag per feature: whether it is an intensity (the voxel's, or an average or a
    /// smoothing of intensities) rather than a gradient, a curvature or a difference.
    pub fn intensity_features(self) -> Vec<bool> {
        self.names()
            .iter()
            .map(|name| *name == "intensity" || name.starts_with("mean ") || name.starts_with("smoothed "))
            .collect()
    }

    /// Features per voxel.
    pub fn dim(self) -> usize {
        match self {
            FeatureSet::Paper5 => PAPER5_DIM,
            FeatureSet::Paper5Gap => PAPER5_DIM + 1,
            FeatureSet::Multiscale | FeatureSet::MultiscaleFine => self.scales().map_or(PAPER5_DIM, Scales::dim),
        }
    }

    /// A short name for each feature, in order.
    pub fn names(self) -> &'static [&'static str] {
        match self {
            FeatureSet::Paper5 => &["intensity", "gradient magnitude", "mean xy", "mean xz", "mean yz"],
            FeatureSet::Paper5Gap => &["intensity", "gradient magnitude", "mean xy", "mean xz", "mean yz", "gap depth"],
            FeatureSet::Multiscale | FeatureSet::MultiscaleFine => self.scales().map_or(&[], Scales::names),
        }
    }

    /// The command-line name (`--features`).
    pub fn name(self) -> &'static str {
        match self {
            FeatureSet::Paper5 => "paper5",
            FeatureSet::Paper5Gap => "paper5-gap",
            FeatureSet::Multiscale => "multiscale",
            FeatureSet::MultiscaleFine => "multiscale-fine",
        }
    }

    /// The multi-scale cascade this set reads (`None` for the paper's set).
    pub fn scales(self) -> Option<Scales> {
        match self {
            FeatureSet::Paper5 | FeatureSet::Paper5Gap => None,
            FeatureSet::Multiscale => Some(Scales::Full),
            FeatureSet::MultiscaleFine => Some(Scales::Fine),
        }
    }

    /// Z planes a whole-volume pass should give one worker at a time: the multi-scale blocks
    /// smooth a halo around their planes, so longer runs of planes waste less.
    pub fn preferred_slab_depth(self, dims: [usize; 3]) -> usize {
        match self {
            FeatureSet::Paper5 => 4,
            // The closing's planes around a slab are computed again for the next one.
            FeatureSet::Paper5Gap => 16,
            FeatureSet::Multiscale | FeatureSet::MultiscaleFine => multiscale::block_depth(dims),
        }
    }
}

/// The one error type of the feature stage.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum FeatureError {
    /// A voxel index is at or past the number of voxels.
    #[error("voxel index {index} is outside the volume of {voxel_count} voxels")]
    VoxelOutOfRange {
        /// The index asked for.
        index: usize,
        /// Voxels in the volume.
        voxel_count: usize,
    },
    /// A z slab reaches past the volume's last plane, or is reversed.
    #[error("slab z {z_start}..{z_end} is outside the volume's {size_z} z slices")]
    SlabOutOfRange {
        /// First plane of the slab.
        z_start: usize,
        /// One past its last plane.
        z_end: usize,
        /// Planes in the volume.
        size_z: usize,
    },
    /// A standardiser was to be fitted on no vectors.
    #[error("no training vectors to fit a standardiser on")]
    NoVectors,
    /// The values do not divide into whole feature vectors.
    #[error("{length} values are not a whole number of {dim}-feature vectors")]
    Ragged {
        /// Number of values given.
        length: usize,
        /// Features per vector.
        dim: usize,
    },
    /// A training feature is NaN or infinite.
    #[error("feature {feature} of training vector {vector} is not a finite number ({value})")]
    NonFinite {
        /// Index of the vector.
        vector: usize,
        /// Index of the feature within it.
        feature: usize,
        /// The value found.
        value: f32,
    },
    /// Vectors of another dimension than the standardiser was fitted on.
    #[error("the standardiser was fitted on {fitted}-feature vectors but got {found}-feature ones")]
    DimensionMismatch {
        /// Features per vector at fitting.
        fitted: usize,
        /// Features per vector given now.
        found: usize,
    },
}

/// Paper5 features of voxel `index` (x-fastest). Panics when `index >= volume.voxel_count()`,
/// like slice indexing; [`features_of_voxels`] checks instead.
pub fn features_at(volume: &Volume, index: usize) -> [f32; 5] {
    let [size_x, size_y, _] = volume.dims;
    let x = index % size_x;
    let y = (index / size_x) % size_y;
    let z = index / (size_x * size_y);
    let [xs, ys, zs] = [[x, 0], [y, 1], [z, 2]].map(|[p, axis]| {
        let size = volume.dims[axis];
        [p.saturating_sub(1), p, (p + 1).min(size - 1)]
    });
    let at = |i: usize, j: usize, k: usize| volume.value_at(xs[i], ys[j], zs[k]) as f32;
    let neighbourhood = Neighbourhood {
        centre: at(1, 1, 1),
        xy: [at(0, 0, 1), at(1, 0, 1), at(2, 0, 1), at(0, 1, 1), at(2, 1, 1), at(0, 2, 1), at(1, 2, 1), at(2, 2, 1)],
        xz: [at(0, 1, 0), at(1, 1, 0), at(2, 1, 0), at(0, 1, 1), at(2, 1, 1), at(0, 1, 2), at(1, 1, 2), at(2, 1, 2)],
        yz: [at(1, 0, 0), at(1, 1, 0), at(1, 2, 0), at(1, 0, 1), at(1, 2, 1), at(1, 0, 2), at(1, 1, 2), at(1, 2, 2)],
        gradient_scale: [
            inverse_span_mm(x, volume.dims[0], volume.spacing_mm[0]),
            inverse_span_mm(y, volume.dims[1], volume.spacing_mm[1]),
            inverse_span_mm(z, volume.dims[2], volume.spacing_mm[2]),
        ],
    };
    neighbourhood.paper5()
}

/// Features of the voxels at `indices` (any order), as a row-major `indices.len() x dim` block;
/// parallel. Fails on an index outside the volume.
pub fn features_of_voxels(
    volume: &Volume,
    feature_set: FeatureSet,
    indices: &[usize],
) -> Result<Vec<f32>, FeatureError> {
    if let Some(scales) = feature_set.scales() {
        return multiscale::multiscale_features_of_voxels(volume, scales, indices);
    }
    check_voxels(volume, indices)?;
    let dim = feature_set.dim();
    let mut out = vec![0f32; indices.len() * dim];
    out.par_chunks_exact_mut(dim)
        .zip(indices.par_iter())
        .with_min_len(256)
        .for_each(|(row, &index)| row[..PAPER5_DIM].copy_from_slice(&features_at(volume, index)));
    if feature_set == FeatureSet::Paper5Gap {
        for (row, depth) in out.chunks_exact_mut(dim).zip(gap_depth_of_voxels(volume, indices)) {
            row[PAPER5_DIM] = depth;
        }
    }
    Ok(out)
}

/// The values a Paper5 feature vector is made of, in the order the means are summed (the same
/// order in every path, so results agree to the bit).
struct Neighbourhood {
    centre: f32,
    /// Rows of the 3x3 plane minus the centre: (-1,-1) (0,-1) (1,-1) (-1,0) (1,0) (-1,1) ...
    xy: [f32; 8],
    xz: [f32; 8],
    yz: [f32; 8],
    /// 1 / (distance spanned by the central difference in mm) along x, y, z; 0 on a flat axis.
    gradient_scale: [f32; 3],
}

impl Neighbourhood {
    #[inline(always)]
    fn paper5(&self) -> [f32; PAPER5_DIM] {
        let mean = |values: &[f32; 8]| values.iter().sum::<f32>() * 0.125;
        let gradient_x = (self.xy[4] - self.xy[3]) * self.gradient_scale[0];
        let gradient_y = (self.xy[6] - self.xy[1]) * self.gradient_scale[1];
        let gradient_z = (self.xz[6] - self.xz[1]) * self.gradient_scale[2];
        [
            self.centre,
            (gradient_x * gradient_x + gradient_y * gradient_y + gradient_z * gradient_z).sqrt(),
            mean(&self.xy),
            mean(&self.xz),
            mean(&self.yz),
        ]
    }
}

/// 1 / (millimetres between the clamped neighbours of `position` along an axis of `size`).
#[inline]
fn inverse_span_mm(position: usize, size: usize, spacing_mm: f64) -> f32 {
    let span = (position + 1).min(size - 1) - position.saturating_sub(1);
    if span == 0 { 0.0 } else { (1.0 / (span as f64 * spacing_mm)) as f32 }
}

/// Voxel indices, checked against the volume.
fn check_voxels(volume: &Volume, indices: &[usize]) -> Result<(), FeatureError> {
    let voxel_count = volume.voxel_count();
    match indices.iter().find(|&&i| i >= voxel_count) {
        Some(&index) => Err(FeatureError::VoxelOutOfRange { index, voxel_count }),
        None => Ok(()),
    }
}

/// The z range of a slab, checked against the volume.
fn check_slab(volume: &Volume, z_range: &Range<usize>) -> Result<(), FeatureError> {
    if z_range.start > z_range.end || z_range.end > volume.dims[2] {
        return Err(FeatureError::SlabOutOfRange {
            z_start: z_range.start,
            z_end: z_range.end,
            size_z: volume.dims[2],
        });
    }
    Ok(())
}
