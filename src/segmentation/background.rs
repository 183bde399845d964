//! The background threshold: voxels below it are air (label 0) and are never evaluated.
//!
//! Automatic rule: Otsu's threshold of the volume's 256-bin histogram (it splits air from
//! everything else in CT and MRI alike), lowered to the lowest training intensity so that
//! nothing the user marked as a class can fall into the background. A user who lassoes air
//! as a class therefore gets every voxel classified.

use crate::volume::Volume;
use rayon::prelude::*;

/// How the background is chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Background {
    /// Otsu's threshold, at most the lowest training intensity.
    Automatic,
    /// Voxels below this physical value are background.
    Below(f64),
    /// Every voxel is classified.
    None,
}

impl Background {
    /// The threshold for `volume`, given the lowest intensity among the training voxels.
    pub fn threshold(self, volume: &Volume, lowest_training_value: f64) -> Option<f64> {
        match self {
            Background::Automatic => Some(otsu_threshold(volume).min(lowest_training_value)),
            Background::Below(value) => Some(value),
            Background::None => None,
        }
    }
}

/// Otsu's threshold (the split that maximises the between-class variance) over a 256-bin
/// histogram of the finite values (of every fourth z plane in volumes of 64 planes or more);
/// the lower edge of the first bin above the split.
pub fn otsu_threshold(volume: &Volume) -> f64 {
    const BINS: usize = 256;
    let range = volume.value_range();
    if range.max <= range.min {
        return range.min;
    }
    let width = (range.max - range.min) / BINS as f64;
    let plane = volume.dims[0] * volume.dims[1];
    // Every fourth z plane (at least 16 planes): the split between air and everything else is
    // a property of the histogram's shape, which a quarter of the planes shows as well.
    let stride = if volume.dims[2] >= 64 { 4 } else { 1 };
    let histogram = (0..volume.dims[2])
        .into_par_iter()
        .step_by(stride)
        .fold(
            || (vec![0u64; BINS], vec![0f32; plane]),
            |(mut histogram, mut buffer), z| {
                volume.read_z_slice_f32(z, &mut buffer);
                for &value in &buffer {
                    if value.is_finite() {
                        let bin = ((value as f64 - range.min) / width) as usize;
                        histogram[bin.min(BINS - 1)] += 1;
                    }
                }
                (histogram, buffer)
            },
        )
        .map(|(histogram, _)| histogram)
        .reduce(|| vec![0u64; BINS], |a, b| a.iter().zip(&b).map(|(x, y)| x + y).collect());
    let total: u64 = histogram.iter().sum();
    let total_sum: f64 = histogram.iter().enumerate().map(|(i, &c)| i as f64 * c as f64).sum();
    let (mut below_count, mut below_sum) = (0f64, 0f64);
    let mut variances = vec![-1f64; BINS - 1];
    for (bin, &count) in histogram.iter().enumerate().take(BINS - 1) {
        below_count += count as f64;
        below_sum += bin as f64 * count as f64;
        let above_count = total as f64 - below_count;
        if below_count == 0.0 || above_count == 0.0 {
            continue;
        }
        let mean_below = below_sum / below_count;
        let mean_above = (total_sum - below_sum) / above_count;
        variances[bin] = below_count * above_count * (mean_below - mean_above).powi(2);
    }
    // Empty bins between two populations give a plateau of equal variance; split in its middle,
    // not at its start, so noise on either side matters least.
    let best = variances.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let first = variances.iter().position(|&v| v >= best * (1.0 - 1e-12)).unwrap_or(0);
    let last = first + variances[first..].iter().take_while(|&&v| v >= best * (1.0 - 1e-12)).count() - 1;
    range.min + ((first + last) as f64 / 2.0 + 1.0) * width
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn otsu_splits_two_populations_between_them() {
        // 70% air around -1000, 30% tissue around 40.
        let values: Vec<f32> =
            (0..1000).map(|i| if i % 10 < 7 { -1000.0 + (i % 7) as f32 } else { 40.0 + (i % 3) as f32 }).collect();
        let volume = Volume::from_f32([10, 10, 10], [1.0; 3], &values, Path::new("t")).unwrap();
        let threshold = otsu_threshold(&volume);
        assert!(threshold > -990.0 && threshold <= 40.0, "{threshold}");
        assert_eq!(Background::Automatic.threshold(&volume, -995.0), Some(-995.0), "training voxels stay classified");
        assert_eq!(Background::None.threshold(&volume, 0.0), None);
    }

    #[test]
    fn a_constant_volume_has_its_value_as_threshold() {
        let volume = Volume::from_f32([2, 2, 2], [1.0; 3], &[5.0; 8], Path::new("t")).unwrap();
        assert_eq!(otsu_threshold(&volume), 5.0);
    }
}
