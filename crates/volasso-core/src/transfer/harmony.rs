//! Eq. 5-9 of the paper (§3.5; `docs/colour.md`): per-class gradient maximum, saturation, value
//! and opacity, from one parallel pass over the label volume, folded into [`ClassStyle`]s.
//!
//! Positions are normalised to the unit cube: voxel `i` of an axis with `n` voxels of spacing
//! `s` sits at `(i + 0.5) s / (n s) = (i + 0.5) / n`, i.e. each axis is divided by its own
//! physical extent, so the spacing cancels and every axis spans [0, 1] whatever its length in
//! mm. Then `sigma_i^2` (the trace of the class's position covariance) is 0.25 for a class that
//! fills the volume uniformly, and `D_i` (its centroid's distance from (0.5, 0.5, 0.5)) is at
//! most 0.87: S (eq. 7) lies in about [0.8, 1] and V (eq. 8) in about [0.53, 1].
//!
//! Eq. 9, `O_v = a_i (1 + F_v)` with `a_i = 1 - sigma_i^2 / max_j sigma_j^2`, is rescaled
//! linearly so that the smallest raw opacity of any voxel maps to 0.2 and the largest to 1.
//! The smallest is 0 (the class with the largest variance has `a = 0`), the largest
//! `max_i a_i (1 + max F)` with max F = 1 in every class whose gradients are not all 0; so each
//! class's opacity line has two numbers, at `F_v = 0` and `F_v = 1`. When every class has the
//! same variance (one class, say) every raw opacity is 0, and every class gets the floor 0.2.
//!
//! A [`ClipBox`] restricts the statistics to the voxels in view (§3.5, last paragraphs); the
//! box then plays the volume's part in the normalisation (its centre is the centre of eq. 8).
//! A class with no voxels (in the volume or the box) keeps its hue range and gets S = V = 1,
//! opacity 0.2 and gradient maximum 0; [`class_styles`] marks it `visible: false` (nothing to
//! show), [`class_styles_in_box`] keeps the caller's emphasis and visibility for every class.
//!
//! Never: classifies, changes labels, or keeps per-voxel results.

use super::templates::HueTemplate;
use super::{ClassStyle, TransferError};
use crate::features::{FeatureSet, FeatureSlabReader, slab_ranges};
use crate::volume::Volume;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Opacity that eq. 9's smallest value is rescaled to (paper §3.5).
pub const OPACITY_FLOOR: f32 = 0.2;
/// Opacity that eq. 9's largest value is rescaled to.
pub const OPACITY_CEILING: f32 = 1.0;

/// z slices per parallel task of the statistics pass.
const SLAB_DEPTH_Z: usize = 4;

/// A box of voxels, `lo..=hi` on every axis (voxel coordinates, inclusive).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClipBox {
    /// The box's lowest voxel coordinate along x, y, z.
    pub lo: [usize; 3],
    /// The box's highest voxel coordinate along x, y, z (included).
    pub hi: [usize; 3],
}

impl ClipBox {
    /// The box holding every voxel of a volume of `dims` (`None` for an empty volume).
    pub fn whole(dims: [usize; 3]) -> Option<ClipBox> {
        dims.iter().all(|&n| n > 0).then(|| ClipBox { lo: [0; 3], hi: dims.map(|n| n - 1) })
    }

    /// Checks that the box is non-empty and inside a volume of `dims`.
    pub fn check(self, dims: [usize; 3]) -> Result<ClipBox, TransferError> {
        let fits = (0..3).all(|a| self.lo[a] <= self.hi[a] && self.hi[a] < dims[a]);
        if fits { Ok(self) } else { Err(TransferError::ClipBox { lo: self.lo, hi: self.hi, dims }) }
    }

    /// Voxels along each axis.
    pub fn extent_voxels(&self) -> [usize; 3] {
        [0, 1, 2].map(|a| self.hi[a] - self.lo[a] + 1)
    }
}

/// What eq. 5-9 need of one class: sums of its normalised voxel positions and its largest
/// gradient magnitude.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ClassStatistics {
    /// Voxels labelled with the class.
    pub voxel_count: u64,
    /// Sum of the voxels' normalised x, y, z positions (each axis in [0, 1]).
    pub position_sum: [f64; 3],
    /// Sum of the squares of those positions, per axis.
    pub position_square_sum: [f64; 3],
    /// The largest gradient magnitude (value units per mm); 0 for an empty class.
    pub gradient_max: f32,
}

impl ClassStatistics {
    fn merge(&mut self, other: &ClassStatistics) {
        self.voxel_count += other.voxel_count;
        for a in 0..3 {
            self.position_sum[a] += other.position_sum[a];
            self.position_square_sum[a] += other.position_square_sum[a];
        }
        self.gradient_max = self.gradient_max.max(other.gradient_max);
    }

    /// The centroid in normalised coordinates (the box centre for an empty class).
    pub fn centroid(&self) -> [f64; 3] {
        if self.voxel_count == 0 {
            return [0.5; 3];
        }
        self.position_sum.map(|s| s / self.voxel_count as f64)
    }

    /// `sigma^2`: the summed variance of the normalised positions along x, y and z.
    pub fn spatial_variance(&self) -> f64 {
        if self.voxel_count == 0 {
            return 0.0;
        }
        let n = self.voxel_count as f64;
        (0..3).map(|a| (self.position_square_sum[a] / n - (self.position_sum[a] / n).powi(2)).max(0.0)).sum()
    }

    /// `D`: the centroid's distance from the centre of the unit cube.
    pub fn centre_distance(&self) -> f64 {
        self.centroid().iter().map(|c| (c - 0.5).powi(2)).sum::<f64>().sqrt()
    }
}

/// Per-class statistics (class `k` at index `k - 1`) of the voxels inside `clip`, positions
/// normalised to the box; one parallel pass over z slabs.
pub fn class_statistics(
    volume: &Volume,
    labels: &[u8],
    class_count: usize,
    clip: ClipBox,
) -> Result<Vec<ClassStatistics>, TransferError> {
    check_labels(volume, labels, class_count)?;
    let clip = clip.check(volume.dims)?;
    let [size_x, size_y, _] = volume.dims;
    let plane = size_x * size_y;
    let extent = clip.extent_voxels().map(|n| n as f64);
    // Normalised coordinate of each voxel index along each axis inside the box.
    let coordinates: [Vec<f64>; 3] =
        [0, 1, 2].map(|a| (0..extent[a] as usize).map(|i| (i as f64 + 0.5) / extent[a]).collect());
    let z_slabs: Vec<_> = slab_ranges(clip.extent_voxels()[2], SLAB_DEPTH_Z)
        .into_iter()
        .map(|r| r.start + clip.lo[2]..r.end + clip.lo[2])
        .collect();
    let per_slab: Vec<Result<Vec<ClassStatistics>, TransferError>> = z_slabs
        .into_par_iter()
        .map_init(
            || (FeatureSlabReader::new(volume, FeatureSet::Paper5), Vec::new(), Vec::new()),
            |(reader, selected, features), z_range| {
                let mut statistics = vec![ClassStatistics::default(); class_count];
                let dim = reader.feature_set().dim();
                for z in z_range {
                    let zc = coordinates[2][z - clip.lo[2]];
                    // Only labelled voxels count, and most of a scan is background: their
                    // gradients (feature 1) are computed alone.
                    selected.clear();
                    for y in clip.lo[1]..=clip.hi[1] {
                        let row = z * plane + y * size_x;
                        let in_row = (clip.lo[0]..=clip.hi[0]).filter(|&x| labels[row + x] != 0);
                        selected.extend(in_row.map(|x| y * size_x + x));
                    }
                    reader.compute_selected(z, selected, features)?;
                    for (&index, voxel_features) in selected.iter().zip(features.chunks_exact(dim)) {
                        let (x, y) = (index % size_x, index / size_x);
                        // check_labels guarantees label <= class_count.
                        let class = &mut statistics[labels[z * plane + index] as usize - 1];
                        let position = [coordinates[0][x - clip.lo[0]], coordinates[1][y - clip.lo[1]], zc];
                        class.voxel_count += 1;
                        for (a, p) in position.into_iter().enumerate() {
                            class.position_sum[a] += p;
                            class.position_square_sum[a] += p * p;
                        }
                        let gradient = voxel_features[1];
                        if gradient > class.gradient_max {
                            class.gradient_max = gradient;
                        }
                    }
                }
                Ok(statistics)
            },
        )
        .collect();
    let mut total = vec![ClassStatistics::default(); class_count];
    for slab in per_slab {
        for (sum, part) in total.iter_mut().zip(&slab?) {
            sum.merge(part);
        }
    }
    Ok(total)
}

/// The styles of eq. 4-9 for the whole volume: class `k` at index `k - 1`. A class with no
/// voxels is `visible: false`; every other class has emphasis 1 and is visible.
pub fn class_styles(
    volume: &Volume,
    labels: &[u8],
    class_count: usize,
    template: &HueTemplate,
) -> Result<Vec<ClassStyle>, TransferError> {
    let whole =
        ClipBox::whole(volume.dims).ok_or(TransferError::ClipBox { lo: [0; 3], hi: [0; 3], dims: volume.dims })?;
    let statistics = class_statistics(volume, labels, class_count, whole)?;
    let mut styles = styles_from_statistics(&statistics, template);
    for (style, class) in styles.iter_mut().zip(&statistics) {
        style.visible = class.voxel_count > 0;
    }
    Ok(styles)
}

/// The styles of eq. 4-9 for the voxels inside `clip` only ("for what is in view"), keeping
/// each class's emphasis and visibility from `previous` (one style per class).
pub fn class_styles_in_box(
    volume: &Volume,
    labels: &[u8],
    template: &HueTemplate,
    clip: ClipBox,
    previous: &[ClassStyle],
) -> Result<Vec<ClassStyle>, TransferError> {
    let statistics = class_statistics(volume, labels, previous.len(), clip)?;
    let mut styles = styles_from_statistics(&statistics, template);
    for (style, old) in styles.iter_mut().zip(previous) {
        style.emphasis = old.emphasis;
        style.visible = old.visible;
    }
    Ok(styles)
}

/// Eq. 4-9 from per-class statistics: hue ranges from `template`, S, V and the rescaled
/// opacity line; emphasis 1 and visible for every class.
pub fn styles_from_statistics(statistics: &[ClassStatistics], template: &HueTemplate) -> Vec<ClassStyle> {
    let variances: Vec<f64> = statistics.iter().map(ClassStatistics::spatial_variance).collect();
    let largest_variance =
        statistics.iter().zip(&variances).filter(|(s, _)| s.voxel_count > 0).map(|(_, &v)| v).fold(0.0, f64::max);
    // a_i of eq. 9; 0 when every class has the largest variance (or is empty).
    let weights: Vec<f64> = statistics
        .iter()
        .zip(&variances)
        .map(|(s, &v)| if s.voxel_count > 0 && largest_variance > 0.0 { 1.0 - v / largest_variance } else { 0.0 })
        .collect();
    let largest_raw_opacity = statistics
        .iter()
        .zip(&weights)
        .map(|(s, &a)| if s.gradient_max > 0.0 { 2.0 * a } else { a })
        .fold(0.0, f64::max);
    let rescale = |raw: f64| -> f32 {
        if largest_raw_opacity > 0.0 {
            OPACITY_FLOOR + (OPACITY_CEILING - OPACITY_FLOOR) * (raw / largest_raw_opacity) as f32
        } else {
            OPACITY_FLOOR
        }
    };
    let hue_ranges = template.hue_ranges(statistics.len());
    statistics
        .iter()
        .zip(&variances)
        .zip(&weights)
        .zip(hue_ranges)
        .map(|(((class, &variance), &weight), hue_degrees)| ClassStyle {
            hue_degrees,
            saturation: (1.0 / (1.0 + variance)) as f32,
            value: (1.0 / (1.0 + class.centre_distance())) as f32,
            opacity: [rescale(weight), rescale(2.0 * weight)],
            gradient_max: class.gradient_max,
            emphasis: 1.0,
            visible: true,
        })
        .collect()
}

/// Replaces the hue ranges of `styles` with those of `template` (a template change needs no
/// statistics: the other fields stay).
pub fn apply_template(styles: &mut [ClassStyle], template: &HueTemplate) {
    let hue_ranges = template.hue_ranges(styles.len());
    for (style, hue_degrees) in styles.iter_mut().zip(hue_ranges) {
        style.hue_degrees = hue_degrees;
    }
}

/// Checks that `labels` match the volume and name no class past `class_count`.
pub(super) fn check_labels(volume: &Volume, labels: &[u8], class_count: usize) -> Result<(), TransferError> {
    if class_count > u8::MAX as usize {
        return Err(TransferError::TooManyClasses { class_count });
    }
    if labels.len() != volume.voxel_count() {
        return Err(TransferError::LabelCount { labels: labels.len(), voxels: volume.voxel_count() });
    }
    // A cheap parallel max first; the offending voxel is looked for only when there is one.
    let largest = labels.par_chunks(1 << 16).map(largest_of).max().unwrap_or(0);
    if largest as usize > class_count {
        let voxel = labels.iter().position(|&l| l as usize > class_count).unwrap_or(0);
        return Err(TransferError::LabelOutOfRange { voxel, label: labels[voxel], class_count });
    }
    Ok(())
}

/// The largest of `labels` (0 for none), as a plain indexed loop: the tests' build (opt-level 1)
/// does not inline iterator adapters, and a call per voxel made this check a twentieth of a
/// replay's time there.
fn largest_of(labels: &[u8]) -> u8 {
    let mut largest = 0;
    let mut i = 0;
    while i < labels.len() {
        if labels[i] > largest {
            largest = labels[i];
        }
        i += 1;
    }
    largest
}

#[cfg(test)]
#[path = "harmony_tests.rs"]
mod tests;
