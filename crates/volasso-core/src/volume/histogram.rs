//! The volume's value histogram and Otsu's threshold over it: the split between air and
//! everything else that the background rule of `segmentation` starts from. A property of the
//! volume alone, so [`Volume::otsu_threshold`] computes it once, on first use, and keeps it.
//! [`Volume::split_below`] splits the values below a level the same way, with how well the
//! split separates them, for where the whole-volume split cuts through a tissue.
//!
//! 8- and 16-bit volumes count their stored values (no per-voxel conversion to float, the
//! cost of the pass) and bin the distinct values; wider types convert plane by plane.

use super::{ByteOrder, Volume, VoxelType};
use rayon::prelude::*;

/// Bins of every histogram here.
const BINS: usize = 256;

/// The z planes both splits read: every second to fourth plane, at least 16 planes. The split
/// between air and everything else is a property of the histogram's shape, which a sample of
/// the planes shows as well.
fn sampled_planes(volume: &Volume) -> Vec<usize> {
    (0..volume.dims[2]).step_by((volume.dims[2] / 16).clamp(1, 4)).collect()
}

/// Otsu's threshold (the split that maximises the between-class variance) over a 256-bin
/// histogram of the finite values (of every second to fourth z plane, keeping at least 16
/// planes); the lower edge of the first bin above the split.
pub(super) fn otsu_threshold(volume: &Volume) -> f64 {
    let range = volume.value_range();
    if range.max <= range.min {
        return range.min;
    }
    let width = (range.max - range.min) / BINS as f64;
    let plane = volume.dims[0] * volume.dims[1];
    let bin_of = |value: f64| (((value - range.min) / width) as usize).min(BINS - 1);
    let planes = sampled_planes(volume);
    let histogram = match stored_value_counts(volume, &planes) {
        // 8- and 16-bit integers: count each stored value, then bin the distinct values.
        Some(counts) => {
            let mut histogram = vec![0u64; BINS];
            for (raw, &count) in counts.iter().enumerate().filter(|(_, c)| **c > 0) {
                histogram
                    [bin_of(stored_value(volume.voxel_type, raw) * volume.scale.slope + volume.scale.intercept)] +=
                    count;
            }
            histogram
        }
        None => planes
            .par_iter()
            .fold(
                || (vec![0u64; BINS], vec![0f32; plane]),
                |(mut histogram, mut buffer), &z| {
                    volume.read_z_slice_f32(z, &mut buffer);
                    for &value in &buffer {
                        if value.is_finite() {
                            histogram[bin_of(value as f64)] += 1;
                        }
                    }
                    (histogram, buffer)
                },
            )
            .map(|(histogram, _)| histogram)
            .reduce(|| vec![0u64; BINS], |a, b| a.iter().zip(&b).map(|(x, y)| x + y).collect()),
    };
    // The lowest and the highest value fall in the first and the last bin: two non-empty bins.
    let (bin, _) = otsu_split(&histogram).unwrap_or((0.0, 0.0));
    range.min + (bin + 1.0) * width
}

/// Otsu's split of the finite values below `ceiling`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Split {
    /// The level: values below it are the darker population.
    pub level: f64,
    /// Otsu's separability (0..=1): 2/pi for one normal population, near 1 for two far apart
    /// populations.
    pub separability: f64,
}

/// Otsu's split of the finite values below `ceiling` (256 bins from the volume's lowest value,
/// on the planes [`otsu_threshold`] samples); `None` without two distinct ones. Where the
/// volume's threshold cuts through a tissue, the split below it can be the air's edge.
pub(super) fn split_below(volume: &Volume, ceiling: f64) -> Option<Split> {
    let low = volume.value_range().min;
    // Also refuses a NaN ceiling.
    if ceiling.partial_cmp(&low) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let width = (ceiling - low) / BINS as f64;
    let mut histogram = [0u64; BINS];
    let mut buffer = vec![0f32; volume.dims[0] * volume.dims[1]];
    for z in sampled_planes(volume) {
        volume.read_z_slice_f32(z, &mut buffer);
        for value in buffer.iter().map(|&value| f64::from(value)).filter(|&value| value.is_finite() && value < ceiling)
        {
            histogram[(((value - low) / width) as usize).min(BINS - 1)] += 1;
        }
    }
    let (bin, separability) = otsu_split(&histogram)?;
    Some(Split { level: low + (bin + 1.0) * width, separability })
}

/// Otsu's split of a histogram (the split that maximises the between-class variance): the bin
/// after which it splits and the separability (that variance over the total); `None` with fewer
/// than two non-empty bins. Empty bins between two populations give a plateau of equal variance:
/// the split is its middle, not its start, so noise on either side matters least.
fn otsu_split(histogram: &[u64]) -> Option<(f64, f64)> {
    let total: f64 = histogram.iter().map(|&c| c as f64).sum();
    let sum: f64 = histogram.iter().enumerate().map(|(i, &c)| i as f64 * c as f64).sum();
    let mean = sum / total;
    let total_variance =
        histogram.iter().enumerate().map(|(i, &c)| c as f64 * (i as f64 - mean).powi(2)).sum::<f64>() / total;
    if histogram.iter().filter(|&&c| c > 0).count() < 2 || total_variance <= 0.0 {
        return None;
    }
    let (mut below_count, mut below_sum) = (0f64, 0f64);
    let mut variances = vec![-1f64; histogram.len() - 1];
    for (bin, &count) in histogram.iter().enumerate().take(histogram.len() - 1) {
        below_count += count as f64;
        below_sum += bin as f64 * count as f64;
        let above_count = total - below_count;
        if below_count == 0.0 || above_count == 0.0 {
            continue;
        }
        let mean_below = below_sum / below_count;
        let mean_above = (sum - below_sum) / above_count;
        variances[bin] = below_count / total * above_count / total * (mean_below - mean_above).powi(2);
    }
    let best = variances.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let first = variances.iter().position(|&v| v >= best * (1.0 - 1e-12))?;
    let last = first + variances[first..].iter().take_while(|&&v| v >= best * (1.0 - 1e-12)).count() - 1;
    Some(((first + last) as f64 / 2.0, best / total_variance))
}

/// How often each stored value occurs in z planes `planes`, indexed by the value's bits as
/// an unsigned integer (two's complement for signed types); `None` for types wider than 16
/// bits. Counting the raw bytes skips the per-voxel conversion to float, the cost of the pass.
fn stored_value_counts(volume: &Volume, planes: &[usize]) -> Option<Vec<u64>> {
    let size = volume.voxel_type.size_bytes();
    if !matches!(volume.voxel_type, VoxelType::U8 | VoxelType::I8 | VoxelType::U16 | VoxelType::I16) {
        return None;
    }
    let plane_bytes = volume.dims[0] * volume.dims[1] * size;
    let bytes = volume.raw_bytes();
    let table = 1usize << (8 * size);
    let big_endian = volume.byte_order == ByteOrder::Big;
    let counts = planes
        .par_iter()
        .fold(
            || vec![0u64; table],
            |mut counts, &z| {
                let plane = &bytes[z * plane_bytes..(z + 1) * plane_bytes];
                if size == 1 {
                    // Four interleaved tables: runs of one value (air) would otherwise make
                    // every increment wait for the previous one.
                    let mut lanes = [[0u32; 256]; 4];
                    for quad in plane.chunks(4) {
                        for (lane, &byte) in lanes.iter_mut().zip(quad) {
                            lane[byte as usize] += 1;
                        }
                    }
                    for lane in &lanes {
                        for (count, &n) in counts.iter_mut().zip(lane) {
                            *count += n as u64;
                        }
                    }
                } else {
                    for pair in plane.chunks_exact(2) {
                        let raw = if big_endian { [pair[1], pair[0]] } else { [pair[0], pair[1]] };
                        counts[u16::from_le_bytes(raw) as usize] += 1;
                    }
                }
                counts
            },
        )
        .reduce(|| vec![0u64; table], |a, b| a.iter().zip(&b).map(|(x, y)| x + y).collect());
    Some(counts)
}

/// The stored value whose bits, read as an unsigned integer, are `raw` (see
/// [`stored_value_counts`]).
fn stored_value(voxel_type: VoxelType, raw: usize) -> f64 {
    match voxel_type {
        VoxelType::I8 => raw as u8 as i8 as f64,
        VoxelType::I16 => raw as u16 as i16 as f64,
        _ => raw as f64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{gaussian_from_bits, hash64};
    use crate::volume::{ValueScale, VoxelBytes};
    use std::path::Path;

    fn volume(values: &[f32]) -> Volume {
        Volume::from_f32([values.len() / 16, 4, 4], [1.0; 3], values, Path::new("values")).unwrap()
    }

    #[test]
    fn otsu_splits_two_populations_between_them() {
        // 70% air around -1000, 30% tissue around 40.
        let values: Vec<f32> =
            (0..1000).map(|i| if i % 10 < 7 { -1000.0 + (i % 7) as f32 } else { 40.0 + (i % 3) as f32 }).collect();
        let volume = Volume::from_f32([10, 10, 10], [1.0; 3], &values, Path::new("t")).unwrap();
        let threshold = otsu_threshold(&volume);
        assert!(threshold > -990.0 && threshold <= 40.0, "{threshold}");
    }

    #[test]
    fn counting_stored_values_gives_the_threshold_of_the_float_path() {
        // The same values stored as i16 (big-endian, scaled) and as f32 split identically.
        let stored: Vec<i16> = (0..4096).map(|i| if i % 5 < 3 { -20 + (i % 11) } else { 600 + (i % 97) }).collect();
        let values: Vec<f32> = stored.iter().map(|&v| v as f32 * 2.0 - 1024.0).collect();
        let floats = Volume::from_f32([16, 16, 16], [1.0; 3], &values, Path::new("f")).unwrap();
        let stored: Vec<u8> = stored.iter().flat_map(|v| v.to_be_bytes()).collect();
        let scale = ValueScale { slope: 2.0, intercept: -1024.0 };
        let shorts = Volume::new(
            [16; 3],
            [1.0; 3],
            VoxelType::I16,
            ByteOrder::Big,
            scale,
            VoxelBytes::Owned(stored),
            Path::new("s"),
        )
        .unwrap();
        assert!(stored_value_counts(&floats, &[0]).is_none());
        assert_eq!(stored_value_counts(&shorts, &[0, 1]).map(|c| c.iter().sum::<u64>()), Some(512));
        assert_eq!(otsu_threshold(&shorts), otsu_threshold(&floats));
    }

    #[test]
    fn two_populations_split_between_them_and_are_well_separated() {
        // Air 0..5 (most), a tissue at 100, and a bright structure at 400 above the ceiling.
        let values: Vec<f32> = (0..16 * 64)
            .map(|i| match i % 16 {
                0..=11 => (i % 6) as f32,
                12..=14 => 100.0 + (i % 5) as f32,
                _ => 400.0,
            })
            .collect();
        let split = split_below(&volume(&values), 250.0).unwrap();
        assert!((5.0..100.0).contains(&split.level), "{split:?}");
        assert!(split.separability > 0.9, "{split:?}");
    }

    #[test]
    fn one_normal_population_is_split_near_its_mean_and_poorly_separated() {
        let values: Vec<f32> =
            (0..16 * 256).map(|i| -1000.0 + 10.0 * gaussian_from_bits(hash64(5, i as u64))).collect();
        let split = split_below(&volume(&values), 0.0).unwrap();
        assert!((-1010.0..-990.0).contains(&split.level), "{split:?}");
        assert!((0.55..0.75).contains(&split.separability), "{split:?}");
    }

    #[test]
    fn nothing_or_one_value_below_the_ceiling_has_no_split() {
        let values = vec![3.0f32; 64];
        assert_eq!(split_below(&volume(&values), 3.0), None);
        assert_eq!(split_below(&volume(&values), 10.0), None);
    }

    #[test]
    fn a_constant_volume_has_its_value_as_threshold() {
        let volume = Volume::from_f32([2, 2, 2], [1.0; 3], &[5.0; 8], Path::new("t")).unwrap();
        assert_eq!(otsu_threshold(&volume), 5.0);
    }
}
