//! Slice entropy (paper §3.1, eq. 1): H = -sum p_i ln p_i over a slice's intensity histogram.
//!
//! Every slice of every axis uses the same [`ENTROPY_BINS`] bins spread evenly over the whole
//! volume's finite value range ([`EntropyBinning`]), so 8-bit data gets one bin per value and
//! 16-bit or float data is binned coarser, and slices of one volume are comparable. Entropy is
//! in nats (natural log): a slice of two equally large flat regions has H = ln 2. Non-finite
//! voxels are not counted; a slice without finite voxels has H = 0.
//!
//! One parallel pass over z-slabs fills the histograms of all three axes at once: each worker
//! keeps per-x and per-y histograms for the slices it has seen (merged at the end) and finishes
//! each z slice's histogram on the spot. The same pass, counting only voxels at or above a
//! threshold, serves the foreground ranking (`foreground.rs`).

use super::Axis;
use crate::volume::{Volume, VoxelType};
use rayon::prelude::*;
use std::ops::RangeInclusive;

/// Number of histogram bins per slice.
pub const ENTROPY_BINS: usize = 256;

/// Maps values to one of [`ENTROPY_BINS`] equal bins over `[min, max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EntropyBinning {
    /// The value at the low edge of the first bin.
    pub min: f64,
    /// The value at the high edge of the last bin.
    pub max: f64,
    bins_per_unit: f64,
}

impl EntropyBinning {
    /// Bins over `[min, max]`; a flat range puts every value in bin 0.
    pub fn new(min: f64, max: f64) -> EntropyBinning {
        let span = max - min;
        let bins_per_unit = if span > 0.0 && span.is_finite() { ENTROPY_BINS as f64 / span } else { 0.0 };
        EntropyBinning { min, max, bins_per_unit }
    }

    /// The bins of `volume`'s value range.
    pub fn for_volume(volume: &Volume) -> EntropyBinning {
        let range = volume.value_range();
        EntropyBinning::new(range.min, range.max)
    }

    /// The bin of `value`, `None` for NaN and infinities. Values outside the range clamp to
    /// the first or last bin; `max` itself falls in the last bin.
    #[inline]
    pub fn bin(&self, value: f64) -> Option<usize> {
        if !value.is_finite() {
            return None;
        }
        let position = (value - self.min) * self.bins_per_unit;
        // `as` saturates negative values to 0.
        Some((position as usize).min(ENTROPY_BINS - 1))
    }
}

/// Entropy in nats of a histogram (`counts` of any length); 0 for an empty histogram.
pub fn entropy_nats(counts: &[u32]) -> f64 {
    let total: u64 = counts.iter().map(|&c| c as u64).sum();
    if total == 0 {
        return 0.0;
    }
    let total = total as f64;
    // H = -sum (c/N) ln(c/N) = ln N - (1/N) sum c ln c
    let sum_c_ln_c: f64 = counts.iter().filter(|&&c| c > 0).map(|&c| c as f64 * (c as f64).ln()).sum();
    (total.ln() - sum_c_ln_c / total).max(0.0)
}

/// The slices of one axis with their entropies, ranked.
#[derive(Clone, Debug, PartialEq)]
pub struct RankedSlices {
    /// The axis normal to the ranked slices.
    pub axis: Axis,
    /// Entropy of slice `k` in nats, indexed by slice.
    pub entropies_nats: Vec<f64>,
    /// Every slice index once: first the `preferred_count` preferred slices by descending
    /// entropy, then the others by descending entropy; ties keep the lower index first.
    pub order: Vec<usize>,
    /// How many slices lead `order` as preferred: every slice for the plain ranking, those in
    /// the central 80 % of the foreground's extent for the foreground ranking.
    pub preferred_count: usize,
}

impl RankedSlices {
    /// Ranks `entropies_nats` (one per slice, by index), every slice alike.
    pub fn new(axis: Axis, entropies_nats: Vec<f64>) -> RankedSlices {
        let every = 0..=entropies_nats.len().saturating_sub(1);
        RankedSlices::preferring(axis, entropies_nats, every)
    }

    /// Ranks `entropies_nats` with the slices in `preferred` ahead of all others.
    pub fn preferring(axis: Axis, entropies_nats: Vec<f64>, preferred: RangeInclusive<usize>) -> RankedSlices {
        let scores = entropies_nats.clone();
        RankedSlices::preferring_by_score(axis, entropies_nats, &scores, preferred)
    }

    /// Ranks the slices by descending `scores` (one per slice), with the slices in `preferred`
    /// ahead of all others; `entropies_nats` is kept as each slice's entropy.
    pub fn preferring_by_score(
        axis: Axis,
        entropies_nats: Vec<f64>,
        scores: &[f64],
        preferred: RangeInclusive<usize>,
    ) -> RankedSlices {
        let score = |slice: usize| scores.get(slice).copied().unwrap_or(f64::NEG_INFINITY);
        let mut order: Vec<usize> = (0..entropies_nats.len()).collect();
        order.sort_by(|&a, &b| {
            preferred.contains(&b).cmp(&preferred.contains(&a)).then(score(b).total_cmp(&score(a))).then(a.cmp(&b))
        });
        let preferred_count = order.iter().filter(|slice| preferred.contains(slice)).count();
        RankedSlices { axis, entropies_nats, order, preferred_count }
    }

    /// The preferred slices (a run of consecutive indices); `None` when there are none.
    pub fn preferred_slices(&self) -> Option<RangeInclusive<usize>> {
        let preferred = &self.order[..self.preferred_count.min(self.order.len())];
        Some(*preferred.iter().min()?..=*preferred.iter().max()?)
    }

    /// The most informative slice (every volume has at least one slice per axis).
    pub fn top(&self) -> usize {
        self.order.first().copied().unwrap_or(0)
    }

    /// The `count` most informative slices, best first.
    pub fn top_slices(&self, count: usize) -> &[usize] {
        &self.order[..count.min(self.order.len())]
    }
}

/// Ranked slices of all three axes.
#[derive(Clone, Debug, PartialEq)]
pub struct SliceEntropies {
    /// Slices normal to x.
    pub x: RankedSlices,
    /// Slices normal to y.
    pub y: RankedSlices,
    /// Slices normal to z.
    pub z: RankedSlices,
    /// The value bins shared by every slice's histogram.
    pub binning: EntropyBinning,
}

impl SliceEntropies {
    /// The ranked slices normal to `axis`.
    pub fn axis(&self, axis: Axis) -> &RankedSlices {
        match axis {
            Axis::X => &self.x,
            Axis::Y => &self.y,
            Axis::Z => &self.z,
        }
    }

    /// The top slice of x, y and z: what the lasso screen shows first.
    pub fn top_slices(&self) -> [usize; 3] {
        [self.x.top(), self.y.top(), self.z.top()]
    }
}

/// The histogram slot of voxels that are not counted (non-finite, or below the foreground
/// threshold): one past the last bin, so the counting loop needs no branch.
const NOT_COUNTED: usize = ENTROPY_BINS;
/// Histogram slots per slice: the bins and [`NOT_COUNTED`].
const SLOTS: usize = ENTROPY_BINS + 1;

/// One worker's share of the pass: histograms of every x and y slice over the z slices it
/// has seen, and the finished entropies and counts of those z slices.
struct Partial {
    x_counts: Vec<u32>,
    y_counts: Vec<u32>,
    z_slices: Vec<(usize, f64, u64)>,
    values: Vec<f32>,
    slots: Vec<u16>,
}

/// What one pass found along one axis: per slice, the entropy of its counted voxels and how
/// many voxels were counted.
pub(super) struct AxisPass {
    pub entropies_nats: Vec<f64>,
    pub counted_voxels: Vec<u64>,
}

/// Ranks the slices of all three axes of `volume` by entropy (eq. 1) over all finite voxels,
/// in one parallel pass. The work screen opens on [`super::foreground_slice_entropies`]
/// instead, which ranks inside the body first.
pub fn slice_entropies(volume: &Volume) -> SliceEntropies {
    let binning = EntropyBinning::for_volume(volume);
    let [x, y, z] = slice_histograms(volume, binning, None);
    SliceEntropies {
        x: RankedSlices::new(Axis::X, x.entropies_nats),
        y: RankedSlices::new(Axis::Y, y.entropies_nats),
        z: RankedSlices::new(Axis::Z, z.entropies_nats),
        binning,
    }
}

/// The entropy and counted voxels of every slice of every axis, counting finite voxels (at or
/// above `threshold` when one is given) into `binning`'s bins, in one parallel pass over z.
pub(super) fn slice_histograms(volume: &Volume, binning: EntropyBinning, threshold: Option<f64>) -> [AxisPass; 3] {
    let [size_x, size_y, size_z] = volume.dims;
    let plane = size_x * size_y;
    let threshold = threshold.unwrap_or(f64::NEG_INFINITY);
    let slot = |value: f64| if value >= threshold { binning.bin(value).unwrap_or(NOT_COUNTED) } else { NOT_COUNTED };
    // 8-bit data without scaling bins through a table straight from the stored bytes.
    let byte_table: Option<[u16; 256]> = (volume.voxel_type == VoxelType::U8 && volume.scale.is_identity())
        .then(|| std::array::from_fn(|value| slot(value as f64) as u16));
    let new_partial = || Partial {
        x_counts: vec![0; size_x * SLOTS],
        y_counts: vec![0; size_y * SLOTS],
        z_slices: Vec::new(),
        values: Vec::new(),
        slots: vec![0; plane],
    };
    let merged = (0..size_z)
        .into_par_iter()
        .with_min_len(4)
        .fold(new_partial, |mut partial, z| {
            match &byte_table {
                Some(table) => {
                    let bytes = &volume.raw_bytes()[z * plane..(z + 1) * plane];
                    for (slot, &byte) in partial.slots.iter_mut().zip(bytes) {
                        *slot = table[byte as usize];
                    }
                }
                None => {
                    partial.values.resize(plane, 0.0);
                    volume.read_z_slice_f32(z, &mut partial.values);
                    for (out, &value) in partial.slots.iter_mut().zip(&partial.values) {
                        *out = slot(value as f64) as u16;
                    }
                }
            }
            let mut z_counts = [0u32; SLOTS];
            for y in 0..size_y {
                let row = y * size_x..(y + 1) * size_x;
                let y_counts = &mut partial.y_counts[y * SLOTS..(y + 1) * SLOTS];
                for (x, &slot) in partial.slots[row].iter().enumerate() {
                    let slot = slot as usize;
                    partial.x_counts[x * SLOTS + slot] += 1;
                    y_counts[slot] += 1;
                    z_counts[slot] += 1;
                }
            }
            let bins = &z_counts[..ENTROPY_BINS];
            partial.z_slices.push((z, entropy_nats(bins), bins.iter().map(|&c| c as u64).sum()));
            partial
        })
        .reduce_with(|mut a, b| {
            for (sum, add) in a.x_counts.iter_mut().zip(&b.x_counts) {
                *sum += add;
            }
            for (sum, add) in a.y_counts.iter_mut().zip(&b.y_counts) {
                *sum += add;
            }
            a.z_slices.extend(b.z_slices);
            a
        });
    let summarise = |counts: &[u32]| AxisPass {
        entropies_nats: counts.chunks_exact(SLOTS).map(|slice| entropy_nats(&slice[..ENTROPY_BINS])).collect(),
        counted_voxels: counts
            .chunks_exact(SLOTS)
            .map(|slice| slice[..ENTROPY_BINS].iter().map(|&c| c as u64).sum())
            .collect(),
    };
    let mut z = AxisPass { entropies_nats: vec![0.0; size_z], counted_voxels: vec![0; size_z] };
    let (x, y) = match merged {
        Some(partial) => {
            for (slice, entropy, counted) in partial.z_slices {
                z.entropies_nats[slice] = entropy;
                z.counted_voxels[slice] = counted;
            }
            (summarise(&partial.x_counts), summarise(&partial.y_counts))
        }
        None => (summarise(&vec![0; size_x * SLOTS]), summarise(&vec![0; size_y * SLOTS])),
    };
    [x, y, z]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;
    use crate::slices::SliceGeometry;
    use crate::volume::{ByteOrder, ValueScale, VoxelBytes};
    use std::path::Path;

    fn volume_of(dims: [usize; 3], voxel_type: VoxelType, bytes: Vec<u8>) -> Volume {
        Volume::new(
            dims,
            [1.0; 3],
            voxel_type,
            ByteOrder::Little,
            ValueScale::IDENTITY,
            VoxelBytes::Owned(bytes),
            Path::new("test"),
        )
        .unwrap()
    }

    /// Entropy of one slice, the slow and obvious way.
    fn slice_entropy_by_hand(volume: &Volume, axis: Axis, slice: usize) -> f64 {
        let binning = EntropyBinning::for_volume(volume);
        let geometry = SliceGeometry::new(volume.dims, axis, slice).unwrap();
        let mut counts = [0u32; ENTROPY_BINS];
        for j in 0..geometry.height {
            for i in 0..geometry.width {
                if let Some(bin) = binning.bin(volume.value(geometry.voxel_index(i, j))) {
                    counts[bin] += 1;
                }
            }
        }
        entropy_nats(&counts)
    }

    #[test]
    fn a_constant_slice_has_zero_entropy_and_two_equal_halves_have_ln_2() {
        // z = 0: constant; z = 1: left half 0, right half 200; z = 2: four values.
        let dims = [4, 2, 3];
        let mut values = vec![7.0f32; 8];
        values.extend([0.0, 0.0, 200.0, 200.0, 0.0, 0.0, 200.0, 200.0]);
        values.extend([0.0, 50.0, 100.0, 200.0, 0.0, 50.0, 100.0, 200.0]);
        let volume = Volume::from_f32(dims, [1.0; 3], &values, Path::new("t")).unwrap();
        let entropies = slice_entropies(&volume);
        assert_eq!(entropies.z.entropies_nats[0], 0.0);
        assert!((entropies.z.entropies_nats[1] - 2f64.ln()).abs() < 1e-12);
        assert!((entropies.z.entropies_nats[2] - 4f64.ln()).abs() < 1e-12);
        assert_eq!(entropies.z.order, vec![2, 1, 0]);
        assert_eq!(entropies.z.top(), 2);
        // Along x, columns 0-1 hold {7, 0, 0 / 50} and columns 2-3 {7, 200, 100 / 200}.
        for axis in Axis::ALL {
            for slice in 0..volume.dims[axis.position()] {
                let expected = slice_entropy_by_hand(&volume, axis, slice);
                let found = entropies.axis(axis).entropies_nats[slice];
                assert!((found - expected).abs() < 1e-12, "{axis} {slice}");
            }
        }
    }

    #[test]
    fn ranking_is_by_descending_entropy_with_ties_by_index() {
        let ranked = RankedSlices::new(Axis::Y, vec![0.5, 2.0, 0.5, 1.0, 2.0]);
        assert_eq!(ranked.order, vec![1, 4, 3, 0, 2]);
        assert_eq!(ranked.top_slices(2), &[1, 4]);
        assert_eq!(ranked.top_slices(99).len(), 5);
    }

    #[test]
    fn the_one_pass_equals_slice_by_slice_on_random_8_and_16_bit_volumes() {
        let mut rng = SplitMix64::new(42);
        let dims = [13, 7, 9];
        let count = dims.iter().product::<usize>();
        // Smooth-ish data so slices differ in entropy.
        let bytes: Vec<u8> = (0..count).map(|i| ((i % 13) * 9 + rng.below(40) as usize) as u8).collect();
        let words: Vec<u8> =
            (0..count).flat_map(|i| ((i as i16 % 91) * 30 - 1024 + rng.below(300) as i16).to_le_bytes()).collect();
        for volume in [volume_of(dims, VoxelType::U8, bytes), volume_of(dims, VoxelType::I16, words)] {
            let entropies = slice_entropies(&volume);
            for axis in Axis::ALL {
                let ranked = entropies.axis(axis);
                assert_eq!(ranked.entropies_nats.len(), volume.dims[axis.position()]);
                for (slice, &found) in ranked.entropies_nats.iter().enumerate() {
                    let expected = slice_entropy_by_hand(&volume, axis, slice);
                    assert!((found - expected).abs() < 1e-9, "{axis} {slice}");
                }
                for pair in ranked.order.windows(2) {
                    assert!(ranked.entropies_nats[pair[0]] >= ranked.entropies_nats[pair[1]]);
                }
            }
        }
    }

    #[test]
    fn sixteen_bit_values_share_256_bins_over_the_volume_range() {
        let binning = EntropyBinning::new(-1024.0, 3072.0); // 16 HU per bin
        assert_eq!(binning.bin(-1024.0), Some(0));
        assert_eq!(binning.bin(-1009.0), Some(0));
        assert_eq!(binning.bin(-1008.0), Some(1));
        assert_eq!(binning.bin(3071.0), Some(255));
        assert_eq!(binning.bin(3072.0), Some(255));
        assert_eq!(binning.bin(f64::NAN), None);
        // 8-bit 0..=255: one bin per value.
        let bytes = EntropyBinning::new(0.0, 255.0);
        for value in 0..=255 {
            assert_eq!(bytes.bin(value as f64), Some(value));
        }
        // Values 0..1000 step 1 in one int16 slice: 1000 values over 256 bins.
        let dims = [1000, 1, 1];
        let words: Vec<u8> = (0..1000i16).flat_map(|v| v.to_le_bytes()).collect();
        let volume = volume_of(dims, VoxelType::I16, words);
        let entropy = slice_entropies(&volume).z.entropies_nats[0];
        // 1000 values in 256 bins of width 999/256: nearly uniform, just under ln 256.
        assert!(entropy > 256f64.ln() - 0.01 && entropy < 256f64.ln(), "{entropy}");
    }

    #[test]
    fn non_finite_voxels_are_not_counted() {
        let values = [1.0f32, f32::NAN, 1.0, 5.0, f32::INFINITY, 5.0];
        let volume = Volume::from_f32([3, 1, 2], [1.0; 3], &values, Path::new("t")).unwrap();
        let entropies = slice_entropies(&volume);
        assert_eq!(entropies.z.entropies_nats, vec![0.0, 0.0]);
        assert!((entropies.x.entropies_nats[0] - 2f64.ln()).abs() < 1e-12);
        assert_eq!(entropies.x.entropies_nats[1], 0.0);
    }

    #[test]
    fn engine_volume_is_ranked_in_one_pass_and_agrees_with_slice_by_slice() {
        let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/engine_256x256x256_uint8.raw"));
        let length = 256 * 256 * 256;
        let bytes = VoxelBytes::map_region(path, 0, length).unwrap();
        let volume =
            Volume::new([256; 3], [1.0; 3], VoxelType::U8, ByteOrder::Little, ValueScale::IDENTITY, bytes, path)
                .unwrap();
        let started = std::time::Instant::now();
        let entropies = slice_entropies(&volume);
        let seconds = started.elapsed().as_secs_f64();
        println!(
            "entropy of 256^3 engine: {seconds:.3} s on {} threads; top slices x,y,z {:?}",
            rayon::current_num_threads(),
            entropies.top_slices()
        );
        for axis in Axis::ALL {
            let ranked = entropies.axis(axis);
            for slice in [ranked.top(), 0, 128, 255] {
                let expected = slice_entropy_by_hand(&volume, axis, slice);
                assert!((ranked.entropies_nats[slice] - expected).abs() < 1e-9);
            }
            // The engine fills the middle of the volume; its best slice is not at the border.
            assert!((32..224).contains(&ranked.top()), "{axis}: {}", ranked.top());
            assert!(ranked.entropies_nats[ranked.top()] > 1.0);
        }
    }
}
