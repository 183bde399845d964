//! Resampling an irregular slice stack (gantry tilt, uneven gaps) onto a regular grid.
//!
//! The output grid's axes are the row direction r, the column direction c and the normal n of
//! the acquired slices ([`super::geometry`]), so its planes are parallel to them and in-plane
//! spacing is kept. For an output voxel at p = (u, v, w) on (r, c, n): the two acquired slices
//! k, k+1 whose normal positions bracket w are sampled at p's in-plane coordinates, column
//! `(u - u_k) / dx` and row `(v - v_k) / dy`, bilinearly, and the two samples are blended
//! linearly in w. That one rule undoes tilt (the per-slice in-plane shift (u_k, v_k)) and
//! uneven gaps together, and reproduces any field linear in space exactly.
//!
//! The in-plane extent is the union of the slices' footprints; output voxels outside a
//! slice's footprint take the pad value (the series minimum, i.e. air) for that slice.
//!
//! Never: extrapolates beyond the first or last slice along the normal.

use super::geometry::StackGeometry;
use super::pixels::DecodedSlice;
use crate::volume::VolumeError;
use rayon::prelude::*;
use std::path::Path;

/// Blend weights below this are treated as 0 so that on-slice planes copy the slice exactly.
const WEIGHT_EPSILON: f64 = 1e-6;

/// The regular output grid, in the (r, c, n) frame of the series.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ResampleGrid {
    pub dims: [usize; 3],
    pub spacing_mm: [f64; 3],
    /// (u, v, w) of voxel (0, 0, 0).
    pub origin_mm: [f64; 3],
}

/// Plans the grid: in-plane the union of footprints at the acquired pixel spacing; along the
/// normal from the first to the last slice. With `exact_span`, the spacing is shrunk a little
/// so that the last plane falls on the last slice; otherwise it is kept and the span is cut
/// at the last whole step.
pub(super) fn plan_grid(
    geometry: &StackGeometry,
    slice_spacing_mm: f64,
    exact_span: bool,
    source: &Path,
) -> Result<ResampleGrid, VolumeError> {
    let [dx, dy] = geometry.pixel_spacing_mm;
    let positions = &geometry.first_pixel_mm;
    let fold = |axis: usize, start: f64, pick: fn(f64, f64) -> f64| positions.iter().map(|p| p[axis]).fold(start, pick);
    let (u_min, u_max) = (fold(0, f64::INFINITY, f64::min), fold(0, f64::NEG_INFINITY, f64::max));
    let (v_min, v_max) = (fold(1, f64::INFINITY, f64::min), fold(1, f64::NEG_INFINITY, f64::max));
    let w_first = positions[0][2];
    let span_mm = positions[positions.len() - 1][2] - w_first;
    if !(slice_spacing_mm.is_finite() && slice_spacing_mm > 0.0) {
        return Err(VolumeError::BadSpacing { axis: 2, value: slice_spacing_mm, path: source.to_path_buf() });
    }
    let steps_along_normal = if exact_span {
        (span_mm / slice_spacing_mm).round().max(1.0)
    } else {
        (span_mm / slice_spacing_mm + 1e-6).floor()
    };
    let extra_columns = ((u_max - u_min) / dx).round();
    let extra_rows = ((v_max - v_min) / dy).round();
    // Checked in floating point first: absurd positions in a damaged file must give an error,
    // not an overflowing cast.
    const MOST_STEPS: f64 = 1e6;
    if ![extra_columns, extra_rows, steps_along_normal].iter().all(|steps| steps.is_finite() && *steps < MOST_STEPS) {
        return Err(VolumeError::Dicom {
            problem: format!(
                "the slice positions span {:.0} x {:.0} x {:.0} mm, which no grid of {slice_spacing_mm} mm slices can hold",
                u_max - u_min,
                v_max - v_min,
                span_mm
            ),
            path: source.to_path_buf(),
        });
    }
    let nx = extra_columns as usize + geometry.columns;
    let ny = extra_rows as usize + geometry.rows;
    let nz = steps_along_normal as usize + 1;
    let dz = if exact_span { span_mm / steps_along_normal } else { slice_spacing_mm };
    Ok(ResampleGrid { dims: [nx, ny, nz], spacing_mm: [dx, dy, dz], origin_mm: [u_min, v_min, w_first] })
}

/// Resamples `slices` (in the order of `geometry`) onto `grid`, as little-endian `f32`
/// bytes, x fastest, then y, then z (written plane by plane, so that no second full-size
/// copy is made).
pub(super) fn resample(
    slices: &[DecodedSlice],
    geometry: &StackGeometry,
    grid: &ResampleGrid,
    pad: f32,
    source: &Path,
) -> Result<Vec<u8>, VolumeError> {
    let [nx, ny, nz] = grid.dims;
    let plane = nx * ny;
    let too_large = |problem: &'static str| VolumeError::BadDimensions {
        dims: grid.dims.map(|d| d as u64),
        problem,
        path: source.to_path_buf(),
    };
    let total_bytes = plane
        .checked_mul(nz)
        .and_then(|voxels| voxels.checked_mul(4))
        .ok_or_else(|| too_large("the resampled grid is too large to address"))?;
    let mut output: Vec<u8> = Vec::new();
    output
        .try_reserve_exact(total_bytes)
        .map_err(|_| too_large("the resampled grid does not fit in memory (choose a larger slice spacing)"))?;
    output.resize(total_bytes, 0);
    let normal_positions: Vec<f64> = geometry.first_pixel_mm.iter().map(|p| p[2]).collect();
    let last_w = normal_positions[normal_positions.len() - 1];
    output.par_chunks_mut(plane * 4).enumerate().for_each_init(
        || vec![0f32; plane],
        |out_plane, (z, out_bytes)| {
            // Each slice adds weight * (sample - pad): voxels outside every footprint stay
            // exactly pad.
            out_plane.fill(pad);
            let w = (grid.origin_mm[2] + z as f64 * grid.spacing_mm[2]).min(last_w);
            for (slice_index, weight) in bracketing_slices(&normal_positions, w) {
                let shift = slice_shift_pixels(geometry, grid, slice_index);
                accumulate_slice(&slices[slice_index].values, geometry, shift, weight as f32, pad, [nx, ny], out_plane);
            }
            for (quad, value) in out_bytes.chunks_exact_mut(4).zip(out_plane.iter()) {
                quad.copy_from_slice(&value.to_le_bytes());
            }
        },
    );
    Ok(output)
}

/// The one or two slices that bracket normal position `w`, with their linear weights.
fn bracketing_slices(normal_positions: &[f64], w: f64) -> Vec<(usize, f64)> {
    let count = normal_positions.len();
    if count == 1 {
        return vec![(0, 1.0)];
    }
    let above = normal_positions.partition_point(|position| *position <= w);
    let lower = above.saturating_sub(1).min(count - 2);
    let gap = normal_positions[lower + 1] - normal_positions[lower];
    let t = ((w - normal_positions[lower]) / gap).clamp(0.0, 1.0);
    if t < WEIGHT_EPSILON {
        vec![(lower, 1.0)]
    } else if t > 1.0 - WEIGHT_EPSILON {
        vec![(lower + 1, 1.0)]
    } else {
        vec![(lower, 1.0 - t), (lower + 1, t)]
    }
}

/// Where output voxel (0, 0) falls in slice `slice_index`, in (column, row) pixels.
fn slice_shift_pixels(geometry: &StackGeometry, grid: &ResampleGrid, slice_index: usize) -> [f64; 2] {
    let first_pixel = geometry.first_pixel_mm[slice_index];
    [
        (grid.origin_mm[0] - first_pixel[0]) / grid.spacing_mm[0],
        (grid.origin_mm[1] - first_pixel[1]) / grid.spacing_mm[1],
    ]
}

/// Adds `weight` times (slice `values`, sampled bilinearly at output (x, y) + `shift`, minus
/// `pad`) to `out_plane`; outside the slice's footprint (half a pixel around its pixel
/// centres) the sample is `pad`, so it adds nothing.
fn accumulate_slice(
    values: &[f32],
    geometry: &StackGeometry,
    shift: [f64; 2],
    weight: f32,
    pad: f32,
    [nx, ny]: [usize; 2],
    out_plane: &mut [f32],
) {
    let (columns, rows) = (geometry.columns, geometry.rows);
    // Per output column: the two source columns, the blend fraction, and whether inside.
    let column_taps: Vec<Option<(usize, usize, f32)>> = (0..nx).map(|x| taps(x as f64 + shift[0], columns)).collect();
    for y in 0..ny {
        let out_row = &mut out_plane[y * nx..(y + 1) * nx];
        let Some((row_0, row_1, fy)) = taps(y as f64 + shift[1], rows) else {
            continue;
        };
        let upper = &values[row_0 * columns..(row_0 + 1) * columns];
        let lower = &values[row_1 * columns..(row_1 + 1) * columns];
        for (out, column_tap) in out_row.iter_mut().zip(&column_taps) {
            if let Some((column_0, column_1, fx)) = *column_tap {
                let top = upper[column_0] + fx * (upper[column_1] - upper[column_0]);
                let bottom = lower[column_0] + fx * (lower[column_1] - lower[column_0]);
                *out += weight * (top + fy * (bottom - top) - pad);
            }
        }
    }
}

/// The two neighbouring pixel indices around `coordinate` and the fraction towards the
/// second, or `None` when `coordinate` lies outside the footprint [-0.5, count - 0.5].
fn taps(coordinate: f64, count: usize) -> Option<(usize, usize, f32)> {
    // A hair of tolerance: grid and slice coordinates come from independent float sums.
    const EDGE: f64 = 0.5 + 1e-6;
    if coordinate < -EDGE || coordinate > count as f64 - 1.0 + EDGE {
        return None;
    }
    let clamped = coordinate.clamp(0.0, (count - 1) as f64);
    let index_0 = (clamped.floor() as usize).min(count.saturating_sub(2));
    let index_1 = (index_0 + 1).min(count - 1);
    let fraction = (clamped - index_0 as f64) as f32;
    Some((index_0, index_1, fraction))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn taps_cover_the_footprint_and_clamp_at_its_edges() {
        assert_eq!(taps(-0.6, 4), None);
        assert_eq!(taps(3.6, 4), None);
        assert_eq!(taps(-0.4, 4), Some((0, 1, 0.0)));
        assert_eq!(taps(1.25, 4), Some((1, 2, 0.25)));
        assert_eq!(taps(3.4, 4), Some((2, 3, 1.0)));
        // A one-pixel-wide image still samples its one pixel.
        assert_eq!(taps(0.3, 1), Some((0, 0, 0.0)));
    }

    #[test]
    fn bracketing_weights_interpolate_linearly_and_snap_onto_slices() {
        let positions = [0.0, 1.0, 4.0];
        assert_eq!(bracketing_slices(&positions, 0.0), vec![(0, 1.0)]);
        assert_eq!(bracketing_slices(&positions, 1.0), vec![(1, 1.0)]);
        assert_eq!(bracketing_slices(&positions, 4.0), vec![(2, 1.0)]);
        let between = bracketing_slices(&positions, 2.0);
        assert_eq!((between[0].0, between[1].0), (1, 2));
        assert!((between[0].1 - 2.0 / 3.0).abs() < 1e-12 && (between[1].1 - 1.0 / 3.0).abs() < 1e-12);
    }

    fn two_by_two_slices_at(first_pixel_mm: Vec<[f64; 3]>) -> StackGeometry {
        StackGeometry {
            rows: 2,
            columns: 2,
            pixel_spacing_mm: [1.0, 1.0],
            first_pixel_mm,
            single_slice_spacing_mm: 1.0,
            unplaced: false,
        }
    }

    #[test]
    fn grids_cover_the_span_and_absurd_ones_are_errors() {
        let source = Path::new("series");
        let stack = two_by_two_slices_at(vec![[0.0, 0.0, 0.0], [0.0, 3.0, 1.0]]);
        let kept_spacing = plan_grid(&stack, 0.3, false, source).unwrap();
        assert_eq!(kept_spacing.dims, [2, 5, 4]);
        assert_eq!(kept_spacing.spacing_mm[2], 0.3);
        let exact_span = plan_grid(&stack, 0.3, true, source).unwrap();
        assert_eq!(exact_span.dims, [2, 5, 4]);
        assert!((exact_span.spacing_mm[2] - 1.0 / 3.0).abs() < 1e-12);
        assert!(matches!(plan_grid(&stack, 0.0, false, source), Err(VolumeError::BadSpacing { .. })));
        assert!(plan_grid(&stack, 1e-9, false, source).is_err());
        let damaged = two_by_two_slices_at(vec![[0.0, 0.0, 0.0], [1e300, 0.0, 1.0]]);
        assert!(plan_grid(&damaged, 1.0, true, source).is_err());
    }
}
