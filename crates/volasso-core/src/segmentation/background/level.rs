//! Otsu's split of the values below the volume's dark level, and its separability, for where the
//! whole-volume split cuts through a lassoed tissue (`docs/decisions/0008-background.md`).
//!
//! Never: decides which level the background uses (that is `super`'s rule), or reads files.

use crate::volume::Volume;

/// Histogram bins of the values below the level.
const BINS: usize = 256;

/// Otsu's split of the values of `volume` below `ceiling`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Split {
    /// The level: values below it are the darker population.
    pub level: f64,
    /// Otsu's separability (0..=1): 2/pi for one normal population, near 1 for two far apart
    /// populations.
    pub separability: f64,
}

/// Otsu's split of the finite values below `ceiling` on sampled z planes; `None` without two
/// distinct ones.
pub fn split_below(volume: &Volume, ceiling: f64) -> Option<Split> {
    let low = volume.value_range().min;
    // Also refuses a NaN ceiling.
    if ceiling.partial_cmp(&low) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let width = (ceiling - low) / BINS as f64;
    let plane = volume.dims[0] * volume.dims[1];
    let stride = (volume.dims[2] / 16).clamp(1, 4);
    let mut histogram = [0u64; BINS];
    let mut buffer = vec![0f32; plane];
    for z in (0..volume.dims[2]).step_by(stride) {
        volume.read_z_slice_f32(z, &mut buffer);
        for &value in &buffer {
            let value = f64::from(value);
            if value.is_finite() && value < ceiling {
                histogram[(((value - low) / width) as usize).min(BINS - 1)] += 1;
            }
        }
    }
    let (bin, separability) = otsu_bins(&histogram)?;
    Some(Split { level: low + (bin + 1.0) * width, separability })
}

/// Otsu's split of a histogram: the bin after which it splits (a best plateau's middle) and the
/// separability; `None` with fewer than two non-empty bins.
fn otsu_bins(histogram: &[u64]) -> Option<(f64, f64)> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{gaussian_from_bits, hash64};
    use std::path::Path;

    fn volume(values: &[f32]) -> Volume {
        Volume::from_f32([values.len() / 16, 4, 4], [1.0; 3], values, Path::new("values")).unwrap()
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
}
