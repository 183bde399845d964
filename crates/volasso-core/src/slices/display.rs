//! Grey-level slice images for the lasso screen: a linear [`DisplayWindow`] (centre, width) maps
//! physical values to 0..=255, as a CT viewer's window/level does.
//!
//! [`DisplayWindow::automatic`] chooses the window from the data with robust percentiles, so one
//! rule serves CT in Hounsfield units and 8-bit scans alike (see its doc for the rule);
//! [`DisplayWindow::between_percentiles`] gives any other percentile window (the work screen's
//! foreground windows for MRI), and [`looks_like_ct`] is the one test for Hounsfield units.
//!
//! Never: changes stored values; a window is for display only (classification reads the
//! stored values).

use super::{Axis, SliceError, SliceGeometry};
use crate::volume::Volume;
use rayon::prelude::*;

/// A linear grey mapping: `center - width/2` is black, `center + width/2` white.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DisplayWindow {
    /// The value shown as mid grey, in the volume's physical unit (HU for CT).
    pub center: f64,
    /// The range of values from black to white, in the same unit.
    pub width: f64,
}

/// Bins of the value histogram used to find percentiles.
const PERCENTILE_BINS: usize = 4096;
/// Volumes whose values reach this low and this high are taken to be CT in Hounsfield units.
const CT_AIR_AT_MOST_HU: f64 = -900.0;
const CT_DENSE_AT_LEAST_HU: f64 = 200.0;
/// In CT, voxels below this are air (or lung) and do not choose the window.
const CT_TISSUE_ABOVE_HU: f64 = -500.0;
/// Percentiles (of the voxels that count) mapped to black and white.
const LOW_PERCENTILE: f64 = 0.01;
const HIGH_PERCENTILE: f64 = 0.99;

impl DisplayWindow {
    /// A window from its black and white values; a flat or reversed range gets width 1.
    pub fn from_range(black: f64, white: f64) -> DisplayWindow {
        let width = white - black;
        if width > 0.0 && width.is_finite() {
            DisplayWindow { center: black + width / 2.0, width }
        } else {
            DisplayWindow { center: if black.is_finite() { black } else { 0.0 }, width: 1.0 }
        }
    }

    /// The window chosen from the data: the 1st and 99th percentiles of the voxels that count.
    /// For CT ([`looks_like_ct`]) only voxels above -500 HU count, so air does not crush soft
    /// tissue to black; the result spans fat and soft tissue to dense bone. For other data
    /// (8-bit scans, MRI) every finite voxel counts. One parallel pass over the volume.
    pub fn automatic(volume: &Volume) -> DisplayWindow {
        let range = volume.value_range();
        let floor = if looks_like_ct(volume) { CT_TISSUE_ABOVE_HU } else { range.min };
        DisplayWindow::between_percentiles(volume, floor, LOW_PERCENTILE, HIGH_PERCENTILE)
            .unwrap_or_else(|| DisplayWindow::from_range(range.min, range.max))
    }

    /// The window from the `low` to the `high` quantile (fractions, 0..=1) of the finite voxels
    /// at or above `floor` (e.g. the background level, for the foreground's percentiles);
    /// `None` when no voxel counts. One parallel pass over the volume, histogram of 4096 bins
    /// over `floor..max` (so the quantiles are exact to 1/4096 of that range).
    pub fn between_percentiles(volume: &Volume, floor: f64, low: f64, high: f64) -> Option<DisplayWindow> {
        let range = volume.value_range();
        let floor = if floor.is_nan() { range.min } else { floor.max(range.min) };
        let span = range.max - floor;
        if span.is_nan() || span < 0.0 {
            return None;
        }
        if span == 0.0 {
            return Some(DisplayWindow::from_range(floor, floor));
        }
        let bins_per_unit = PERCENTILE_BINS as f64 / span;
        let plane = volume.dims[0] * volume.dims[1];
        let counts = (0..volume.dims[2])
            .into_par_iter()
            .with_min_len(4)
            .fold(
                || (vec![0u64; PERCENTILE_BINS], vec![0f32; plane]),
                |(mut counts, mut values), z| {
                    volume.read_z_slice_f32(z, &mut values);
                    for &value in &values {
                        let value = value as f64;
                        if value.is_finite() && value >= floor {
                            let bin = ((value - floor) * bins_per_unit) as usize;
                            counts[bin.min(PERCENTILE_BINS - 1)] += 1;
                        }
                    }
                    (counts, values)
                },
            )
            .map(|(counts, _)| counts)
            .reduce_with(|mut a, b| {
                for (sum, add) in a.iter_mut().zip(&b) {
                    *sum += add;
                }
                a
            })
            .unwrap_or_default();
        let total: u64 = counts.iter().sum();
        if total == 0 {
            return None;
        }
        let value_at = |fraction: f64| {
            let wanted = (fraction.clamp(0.0, 1.0) * total as f64).ceil().max(1.0) as u64;
            let mut seen = 0;
            for (bin, &count) in counts.iter().enumerate() {
                seen += count;
                if seen >= wanted {
                    return floor + (bin as f64 + 0.5) / bins_per_unit;
                }
            }
            range.max
        };
        Some(DisplayWindow::from_range(value_at(low), value_at(high)))
    }

    /// The grey level of `value`: 0 at or below the window, 255 at or above, NaN black.
    #[inline]
    pub fn grey(&self, value: f64) -> u8 {
        let black = self.center - self.width / 2.0;
        let level = (value - black) / self.width * 255.0;
        // `as` maps NaN to 0 and saturates; +0.5 rounds to nearest.
        (level + 0.5).clamp(0.0, 255.0) as u8
    }
}

/// True when the volume's values are Hounsfield units: they reach air (-900 or below) and
/// dense tissue (200 or above), as every CT does and MRI (arbitrary, non-negative units) and
/// 8-bit scans do not. The one rule for "is this CT" (display windows and their presets).
pub fn looks_like_ct(volume: &Volume) -> bool {
    let range = volume.value_range();
    range.min <= CT_AIR_AT_MOST_HU && range.max >= CT_DENSE_AT_LEAST_HU
}

/// An 8-bit grey image, row-major (`pixels[j * width + i]`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GreyImage {
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// `width × height` grey levels, 0 black to 255 white, row by row.
    pub pixels: Vec<u8>,
}

/// The grey image of slice `slice` along `axis` through `window` (image axes as in the module
/// doc: z -> (x, y), y -> (x, z), x -> (y, z)).
pub fn slice_image(volume: &Volume, axis: Axis, slice: usize, window: DisplayWindow) -> Result<GreyImage, SliceError> {
    let geometry = SliceGeometry::new(volume.dims, axis, slice).ok_or(SliceError::SliceOutOfRange {
        axis,
        slice,
        slice_count: volume.dims[axis.position()],
    })?;
    let mut pixels = vec![0u8; geometry.width * geometry.height];
    match axis {
        // Rows of z and y slices are contiguous runs of x in the volume.
        Axis::Z | Axis::Y => {
            let mut values = vec![0f32; geometry.width];
            for (j, row) in pixels.chunks_exact_mut(geometry.width).enumerate() {
                volume.read_f32(geometry.voxel_index(0, j), &mut values);
                for (pixel, &value) in row.iter_mut().zip(&values) {
                    *pixel = window.grey(value as f64);
                }
            }
        }
        Axis::X => {
            for (j, row) in pixels.chunks_exact_mut(geometry.width).enumerate() {
                for (i, pixel) in row.iter_mut().enumerate() {
                    *pixel = window.grey(volume.value(geometry.voxel_index(i, j)));
                }
            }
        }
    }
    Ok(GreyImage { width: geometry.width, height: geometry.height, pixels })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::{ByteOrder, ValueScale, VoxelBytes, VoxelType};
    use std::path::Path;

    #[test]
    fn grey_levels_are_linear_inside_the_window_and_clamped_outside() {
        let window = DisplayWindow::from_range(0.0, 255.0);
        assert_eq!(window.center, 127.5);
        assert_eq!(window.grey(-5.0), 0);
        assert_eq!(window.grey(0.0), 0);
        assert_eq!(window.grey(100.0), 100);
        assert_eq!(window.grey(255.0), 255);
        assert_eq!(window.grey(1e9), 255);
        assert_eq!(window.grey(f64::NAN), 0);
        assert_eq!(DisplayWindow::from_range(3.0, 3.0).width, 1.0);
    }

    #[test]
    fn slice_images_follow_the_axis_conventions() {
        // value = 100 z + 10 y + x, dims 3 x 4 x 5.
        let dims = [3, 4, 5];
        let values: Vec<f32> = (0..60).map(|i| (100 * (i / 12) + 10 * ((i / 3) % 4) + i % 3) as f32).collect();
        let volume = Volume::from_f32(dims, [1.0; 3], &values, Path::new("t")).unwrap();
        let window = DisplayWindow::from_range(0.0, 255.0);
        let z = slice_image(&volume, Axis::Z, 2, window).unwrap();
        assert_eq!((z.width, z.height), (3, 4));
        assert_eq!(z.pixels[3 * 3 + 1], 231); // x 1, y 3, z 2
        let y = slice_image(&volume, Axis::Y, 1, window).unwrap();
        assert_eq!((y.width, y.height), (3, 5));
        assert_eq!(y.pixels[3 + 2], 112); // x 2, z 1, y 1
        let x = slice_image(&volume, Axis::X, 2, window).unwrap();
        assert_eq!((x.width, x.height), (4, 5));
        assert_eq!(x.pixels[4 * 2 + 3], 232); // y 3, z 2, x 2
        assert!(matches!(
            slice_image(&volume, Axis::X, 3, window),
            Err(SliceError::SliceOutOfRange { axis: Axis::X, slice: 3, slice_count: 3 })
        ));
    }

    #[test]
    fn automatic_window_ignores_ct_air_and_spans_tissue_to_bone() {
        // 60% air, 30% soft tissue at 40 HU, 10% bone at 1200 HU.
        let count = 1000;
        let words: Vec<u8> = (0..count)
            .map(|i| match i % 10 {
                0..=5 => -1000i16,
                6..=8 => 40,
                _ => 1200,
            })
            .flat_map(|v: i16| v.to_le_bytes())
            .collect();
        let volume = Volume::new(
            [10, 10, 10],
            [1.0; 3],
            VoxelType::I16,
            ByteOrder::Little,
            ValueScale::IDENTITY,
            VoxelBytes::Owned(words),
            Path::new("t"),
        )
        .unwrap();
        let window = DisplayWindow::automatic(&volume);
        let black = window.center - window.width / 2.0;
        let white = window.center + window.width / 2.0;
        assert!((black - 40.0).abs() < 2.0, "black {black}");
        assert!((white - 1200.0).abs() < 2.0, "white {white}");
        // 8-bit data: every voxel counts, so background sets black.
        let bytes: Vec<u8> = (0..1000).map(|i| if i % 2 == 0 { 0 } else { 200 }).collect();
        let volume = Volume::new(
            [10, 10, 10],
            [1.0; 3],
            VoxelType::U8,
            ByteOrder::Little,
            ValueScale::IDENTITY,
            VoxelBytes::Owned(bytes),
            Path::new("t"),
        )
        .unwrap();
        let window = DisplayWindow::automatic(&volume);
        assert!((window.center - window.width / 2.0).abs() < 0.1);
        assert!((window.center + window.width / 2.0 - 200.0).abs() < 0.1);
    }
}
