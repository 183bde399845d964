//! Informative slices inside the body: the paper's eq. 1 (§3.1) over foreground voxels only,
//! and ranked so that slices well inside the foreground come first.
//!
//! Plain entropy favours a volume's edges: where a scan cuts through the neck, or grazes the
//! face, noise and partial anatomy make a busy histogram, and that slice tops the ranking
//! while showing little a user can lasso. Here
//! * the *foreground* is every voxel at or above the volume's background level
//!   ([`Volume::otsu_threshold`], the split between air and everything else that segmentation
//!   also starts from), and only foreground voxels enter a slice's histogram, binned over
//!   `[threshold, max]`;
//! * the foreground's *extent* along an axis is the run of slices from the first to the last
//!   that holds at least [`EXTENT_MIN_FRACTION`] of the foreground voxels of that axis's
//!   fullest slice (so a few noisy voxels in the air do not stretch it);
//! * the *central band* is the middle 80 % of that extent: the slices whose centre lies at
//!   least [`EDGE_FRACTION`] (10 %) of the extent's length from either end;
//! * slices in the band are ranked first, by descending *information*: the slice's foreground
//!   entropy (eq. 1) times its number of foreground voxels, the Shannon information of what
//!   the slice shows of the body. Entropy alone still favours slices grazing the body's surface
//!   (a thin rim of partial-volume voxels has a busy histogram); weighting by the foreground
//!   they hold prefers slices through the body's bulk, where a user has structures to lasso.
//!   The rest follow, in the same order, so every slice stays reachable by rank.
//!
//! Entry point: [`foreground_slice_entropies`] (what `info` reports and the work screen opens
//! on); [`super::slice_entropies`] is the plain ranking of every finite voxel. Both are one
//! parallel pass over the volume (the background level is a sampled pass of its own, computed
//! once per volume and kept).
//!
//! Never: looks at the patient orientation, or changes which voxels exist: the extent and band
//! are per axis of the stored grid.

use super::entropy::{EntropyBinning, RankedSlices, SliceEntropies, slice_histograms};
use super::{Axis, slice_entropies};
use crate::volume::Volume;
use std::ops::RangeInclusive;

/// A slice is in the foreground's extent when it holds at least this fraction of the
/// foreground voxels of the fullest slice along its axis.
pub const EXTENT_MIN_FRACTION: f64 = 0.01;
/// The share of the foreground's extent left out at each end: the central 80 % is ranked first.
pub const EDGE_FRACTION: f64 = 0.1;

/// Ranks the slices of every axis by foreground entropy, central band first (module doc),
/// with the volume's own background level.
pub fn foreground_slice_entropies(volume: &Volume) -> SliceEntropies {
    foreground_slice_entropies_above(volume, volume.otsu_threshold())
}

/// As [`foreground_slice_entropies`], with voxels at or above `threshold` as the foreground. A
/// volume without foreground voxels (all below, or a NaN threshold) gets the plain ranking.
pub fn foreground_slice_entropies_above(volume: &Volume, threshold: f64) -> SliceEntropies {
    let range = volume.value_range();
    let binning = EntropyBinning::new(threshold.max(range.min), range.max);
    let [x, y, z] = slice_histograms(volume, binning, Some(threshold));
    if z.counted_voxels.iter().all(|&count| count == 0) {
        return slice_entropies(volume);
    }
    let rank = |axis: Axis, pass: super::entropy::AxisPass| {
        let every = 0..=pass.counted_voxels.len().saturating_sub(1);
        let band = foreground_extent(&pass.counted_voxels).map_or(every, central_band);
        let information: Vec<f64> = (pass.entropies_nats.iter().zip(&pass.counted_voxels))
            .map(|(&entropy, &voxels)| entropy * voxels as f64)
            .collect();
        RankedSlices::preferring_by_score(axis, pass.entropies_nats, &information, band)
    };
    SliceEntropies { x: rank(Axis::X, x), y: rank(Axis::Y, y), z: rank(Axis::Z, z), binning }
}

/// The first to the last slice holding at least [`EXTENT_MIN_FRACTION`] of the largest count
/// in `foreground_voxels` (one count per slice); `None` when every count is 0.
pub fn foreground_extent(foreground_voxels: &[u64]) -> Option<RangeInclusive<usize>> {
    let fullest = foreground_voxels.iter().copied().max().filter(|&count| count > 0)?;
    let enough = ((fullest as f64 * EXTENT_MIN_FRACTION).ceil() as u64).max(1);
    let first = foreground_voxels.iter().position(|&count| count >= enough)?;
    let last = foreground_voxels.iter().rposition(|&count| count >= enough)?;
    Some(first..=last)
}

/// The slices of `extent` whose centre lies in its central 80 %: slice k covers k - 0.5 ..
/// k + 0.5, so the extent covers `first - 0.5 .. last + 0.5` and the band starts
/// [`EDGE_FRACTION`] of that length in from each end. Never empty (a one-slice extent is its
/// own band).
pub fn central_band(extent: RangeInclusive<usize>) -> RangeInclusive<usize> {
    let (first, last) = (*extent.start(), *extent.end());
    let length = (last - first + 1) as f64;
    let margin = EDGE_FRACTION * length;
    let band_first = (first as f64 - 0.5 + margin).ceil().max(first as f64) as usize;
    let band_last = (last as f64 + 0.5 - margin).floor().min(last as f64) as usize;
    if band_first > band_last {
        let middle = first + (last - first) / 2;
        return middle..=middle;
    }
    band_first..=band_last
}

#[cfg(test)]
mod tests;
