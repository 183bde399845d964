//! An MRI scan's shading (the receive coils' bias field): a slow multiplicative field that
//! makes one tissue brighter on one side of the scan than on the other, so that a loop drawn
//! where the field is high teaches the classifier a brightness the same tissue has nowhere else
//! (a cell's body as bright as another cell's nucleus, the white matter of the top of a head as
//! dark as the grey matter of its base).
//!
//! The field is estimated from a first classification, as the EM methods of MRI segmentation
//! do (Wells et al. 1996; FSL's FAST): inside each class (a voxel whose face neighbours share
//! its label, so no partial volume), a voxel's intensity over its class's median is the field
//! there times its noise; averaged over cells of the scan and smoothed over [`SHADING_SCALE`]
//! of its longest side, that leaves the field. A ratio beyond [`SHADING_LIMITS`] is a mislabelled
//! voxel, not the coil, and is left out. The scan
//! divided by it ([`Shading::corrected`]) is classified again (`crate::pipeline`).
//!
//! Never: runs on CT (its numbers are calibrated; a field estimated there would take the
//! anatomy's own variation, a bone's marrow for one, as shading), changes the scan shown, or
//! corrects a field flatter than [`MIN_SHADING`].

use super::{Volume, VolumeError};
use rayon::prelude::*;

/// The smoothing's Gaussian deviation, as a share of the scan's longest side (in millimetres,
/// the same along every axis): a coil's field varies over a sixth or so of a head
/// (`docs/decisions/0019-mri-shading.md`).
pub const SHADING_SCALE: f64 = 0.15;

/// Cells per axis at most: the field is estimated and smoothed on this coarse grid and
/// interpolated between cell centres, so its cost does not grow with the scan.
pub const GRID_CELLS: usize = 32;

/// A field whose every cell lies within this share of 1 is left alone: the scan is as flat as
/// its noise lets the estimate tell.
pub const MIN_SHADING: f64 = 0.02;

/// The field is kept within these factors: where a class's voxels were mislabelled the ratio
/// says nothing of the coil.
pub const SHADING_LIMITS: (f64, f64) = (0.5, 2.0);

/// Voxels read per class for its median at most (evenly spaced over its labelled voxels).
const MEDIAN_SAMPLE: usize = 200_000;

/// A multiplicative field on a coarse grid of cells.
#[derive(Clone, Debug, PartialEq)]
pub struct Shading {
    /// The volume's dimensions.
    dims: [usize; 3],
    /// Voxels per cell along each axis.
    cell: [usize; 3],
    /// Cells along each axis.
    grid: [usize; 3],
    /// The field at each cell's centre, x fastest.
    field: Vec<f32>,
}

impl Shading {
    /// The field of `volume` that `labels` (its label volume: 0 background, k class k) show, or
    /// `None` where it is flatter than [`MIN_SHADING`] or no class has a positive median.
    pub fn estimate(volume: &Volume, labels: &[u8]) -> Option<Shading> {
        if labels.len() != volume.voxel_count() {
            return None;
        }
        let medians = class_medians(volume, labels);
        let dims = volume.dims;
        let cell = dims.map(|n| n.div_ceil(GRID_CELLS).max(1));
        let grid = [0, 1, 2].map(|axis| dims[axis].div_ceil(cell[axis]).max(1));
        let cells = grid[0] * grid[1] * grid[2];
        let plane = dims[0] * dims[1];
        // Every second row and plane is enough for a field this smooth.
        let (mut sums, mut counts) = (0..dims[2])
            .into_par_iter()
            .step_by(2)
            .fold(
                || (vec![0f64; cells], vec![0f64; cells], vec![0f32; plane]),
                |(mut sums, mut counts, mut values), z| {
                    volume.read_z_slice_f32(z, &mut values);
                    for y in (0..dims[1]).step_by(2) {
                        for x in 0..dims[0] {
                            let index = x + dims[0] * y;
                            let label = usize::from(labels[z * plane + index]);
                            let median = medians.get(label).copied().unwrap_or(0.0);
                            let value = f64::from(values[index]);
                            if label == 0
                                || median <= 0.0
                                || !value.is_finite()
                                || !inside_its_class(labels, dims, [x, y, z])
                            {
                                continue;
                            }
                            let ratio = value / median;
                            if !(SHADING_LIMITS.0..=SHADING_LIMITS.1).contains(&ratio) {
                                continue;
                            }
                            let at = x / cell[0] + grid[0] * (y / cell[1] + grid[1] * (z / cell[2]));
                            sums[at] += ratio;
                            counts[at] += 1.0;
                        }
                    }
                    (sums, counts, values)
                },
            )
            .map(|(sums, counts, _)| (sums, counts))
            .reduce(
                || (vec![0f64; cells], vec![0f64; cells]),
                |(mut sums, mut counts), (more_sums, more_counts)| {
                    sums.iter_mut().zip(&more_sums).for_each(|(a, b)| *a += b);
                    counts.iter_mut().zip(&more_counts).for_each(|(a, b)| *a += b);
                    (sums, counts)
                },
            );
        if counts.iter().all(|&count| count == 0.0) {
            return None;
        }
        // One deviation in millimetres along every axis (a coil's field knows nothing of the
        // scan's box): the share of the scan's longest side.
        let spacing = volume.spacing_mm;
        let longest_mm = (0..3).map(|axis| dims[axis] as f64 * spacing[axis]).fold(0.0, f64::max);
        let deviations = [0, 1, 2].map(|axis| SHADING_SCALE * longest_mm / (spacing[axis] * cell[axis] as f64));
        smooth(&mut sums, grid, deviations);
        smooth(&mut counts, grid, deviations);
        let total: f64 = counts.iter().sum();
        let weight_floor = 1e-3 * total / cells as f64;
        let field: Vec<f32> = sums
            .iter()
            .zip(&counts)
            .map(
                |(&sum, &count)| {
                    if count > weight_floor { (sum / count).clamp(SHADING_LIMITS.0, SHADING_LIMITS.1) } else { 1.0 }
                },
            )
            .map(|factor| factor as f32)
            .collect();
        let shading = Shading { dims, cell, grid, field };
        (shading.largest_departure() >= MIN_SHADING).then_some(shading)
    }

    /// The largest departure of the field from 1 (0.1: ten per cent brighter or darker).
    pub fn largest_departure(&self) -> f64 {
        self.field.iter().map(|&factor| (f64::from(factor) - 1.0).abs()).fold(0.0, f64::max)
    }

    /// The field at voxel (x, y, z), interpolated between the cell centres.
    pub fn at(&self, x: usize, y: usize, z: usize) -> f32 {
        let [(x0, fx), along_y, along_z] = [0, 1, 2].map(|axis| self.weights(axis, [x, y, z][axis]));
        let right = (x0 + 1).min(self.grid[0] - 1);
        lerp(self.column(x0, along_y, along_z), self.column(right, along_y, along_z), fx)
    }

    /// Along `axis`, the first of the two cells whose centres `position` lies between, and its
    /// distance from the first's centre as a share of the way to the second's (held at the ends).
    fn weights(&self, axis: usize, position: usize) -> (usize, f32) {
        if self.grid[axis] < 2 {
            return (0, 0.0);
        }
        let centred = (position as f32 + 0.5) / self.cell[axis] as f32 - 0.5;
        let clamped = centred.clamp(0.0, (self.grid[axis] - 1) as f32);
        let first = (clamped.floor() as usize).min(self.grid[axis] - 2);
        (first, clamped - first as f32)
    }

    /// The field in cell column `cx` (interpolated between cells along y and z).
    fn column(&self, cx: usize, (y0, fy): (usize, f32), (z0, fz): (usize, f32)) -> f32 {
        let [gx, gy, gz] = self.grid;
        let cell = |cy: usize, cz: usize| self.field[cx + gx * (cy.min(gy - 1) + gy * cz.min(gz - 1))];
        let near = lerp(cell(y0, z0), cell(y0 + 1, z0), fy);
        let far = lerp(cell(y0, z0 + 1), cell(y0 + 1, z0 + 1), fy);
        lerp(near, far, fz)
    }

    /// `volume` divided by the field: a new scan of `f32` values with the same dimensions and
    /// spacing (4 bytes a voxel, held in memory), and `volume`'s body outline.
    pub fn corrected(&self, volume: &Volume) -> Result<Volume, VolumeError> {
        let dims = volume.dims;
        let plane = dims[0] * dims[1];
        let along_x: Vec<(usize, f32)> = (0..dims[0]).map(|x| self.weights(0, x)).collect();
        let mut values = vec![0f32; volume.voxel_count()];
        values.par_chunks_mut(plane.max(1)).enumerate().for_each(|(z, out)| {
            volume.read_z_slice_f32(z, out);
            let along_z = self.weights(2, z);
            let mut columns = vec![0f32; self.grid[0]];
            for (y, row) in out.chunks_exact_mut(dims[0].max(1)).enumerate() {
                let along_y = self.weights(1, y);
                for (cx, column) in columns.iter_mut().enumerate() {
                    *column = self.column(cx, along_y, along_z);
                }
                for (value, &(x0, fx)) in row.iter_mut().zip(&along_x) {
                    *value /= lerp(columns[x0], columns[(x0 + 1).min(columns.len() - 1)], fx);
                }
            }
        });
        debug_assert_eq!(self.dims, dims);
        Ok(Volume::from_f32(dims, volume.spacing_mm, &values, &volume.source)?.sharing_body_of(volume))
    }
}

/// `a` moved `f` of the way to `b`.
fn lerp(a: f32, b: f32, f: f32) -> f32 {
    a * (1.0 - f) + b * f
}

/// Whether voxel `p` and its six face neighbours (those inside the volume) have one label: a
/// voxel at a border between classes holds both, and its ratio to its class says nothing of
/// the field.
fn inside_its_class(labels: &[u8], dims: [usize; 3], p: [usize; 3]) -> bool {
    let index = |q: [usize; 3]| q[0] + dims[0] * (q[1] + dims[1] * q[2]);
    let own = labels[index(p)];
    (0..3).all(|axis| {
        let mut before = p;
        let mut after = p;
        before[axis] = p[axis].saturating_sub(1);
        after[axis] = (p[axis] + 1).min(dims[axis] - 1);
        labels[index(before)] == own && labels[index(after)] == own
    })
}

/// Each class's median intensity (index = label; 0 for the background and for a class without
/// a voxel), from at most [`MEDIAN_SAMPLE`] of its voxels.
fn class_medians(volume: &Volume, labels: &[u8]) -> Vec<f64> {
    let classes = usize::from(labels.iter().copied().max().unwrap_or(0)) + 1;
    let mut counts = vec![0usize; classes];
    for &label in labels {
        counts[usize::from(label)] += 1;
    }
    let strides: Vec<usize> = counts.iter().map(|&count| count.div_ceil(MEDIAN_SAMPLE).max(1)).collect();
    let mut seen = vec![0usize; classes];
    let mut samples: Vec<Vec<f64>> = vec![Vec::new(); classes];
    for (index, &label) in labels.iter().enumerate() {
        let label = usize::from(label);
        if label == 0 {
            continue;
        }
        if seen[label] % strides[label] == 0 {
            let value = volume.value(index);
            if value.is_finite() {
                samples[label].push(value);
            }
        }
        seen[label] += 1;
    }
    samples
        .iter_mut()
        .map(|values| {
            if values.is_empty() {
                return 0.0;
            }
            let middle = values.len() / 2;
            *values.select_nth_unstable_by(middle, f64::total_cmp).1
        })
        .collect()
}

/// Smooths `values` (a grid of `grid` cells, x fastest) with a Gaussian of `deviations` cells
/// along each axis, separably; the grid's edges are not padded (the weights that fall outside
/// are lost, as they are for the counts the sums are divided by).
fn smooth(values: &mut [f64], grid: [usize; 3], deviations: [f64; 3]) {
    let strides = [1, grid[0], grid[0] * grid[1]];
    for axis in 0..3 {
        let deviation = deviations[axis];
        if deviation <= 0.0 || grid[axis] < 2 {
            continue;
        }
        let reach = (3.0 * deviation).ceil() as isize;
        let kernel: Vec<f64> =
            (-reach..=reach).map(|offset| (-0.5 * (offset as f64 / deviation).powi(2)).exp()).collect();
        let before = values.to_vec();
        let length = grid[axis] as isize;
        for (index, out) in values.iter_mut().enumerate() {
            let position = (index / strides[axis] % grid[axis]) as isize;
            let base = index - position as usize * strides[axis];
            let mut sum = 0.0;
            for (k, weight) in kernel.iter().enumerate() {
                let at = position + k as isize - reach;
                if (0..length).contains(&at) {
                    sum += weight * before[base + at as usize * strides[axis]];
                }
            }
            *out = sum;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// Two tissues (100 and 200, in halves along y) under a field rising from 0.8 to 1.2
    /// along x, and their true labels.
    fn shaded(dims: [usize; 3]) -> (Volume, Vec<u8>, Vec<f32>) {
        let mut values = Vec::new();
        let mut labels = Vec::new();
        let mut field = Vec::new();
        for _z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    let factor = 0.8 + 0.4 * x as f32 / (dims[0] - 1) as f32;
                    let (tissue, label) = if y < dims[1] / 2 { (100.0, 1) } else { (200.0, 2) };
                    values.push(tissue * factor);
                    labels.push(label);
                    field.push(factor);
                }
            }
        }
        (Volume::from_f32(dims, [1.0; 3], &values, Path::new("shaded")).unwrap(), labels, field)
    }

    #[test]
    fn a_field_across_the_scan_is_found_and_divided_out() {
        let dims = [64, 16, 8];
        let (volume, labels, _) = shaded(dims);
        let shading = Shading::estimate(&volume, &labels).expect("a 20 % field is found");
        assert!(shading.largest_departure() > 0.1);
        let corrected = shading.corrected(&volume).unwrap();
        // The copy rings the scan's body: found once, when the scan opened.
        assert!(std::sync::Arc::ptr_eq(&corrected.body(), &volume.body()));
        assert_eq!(corrected.otsu_threshold(), volume.otsu_threshold());
        // Each tissue's spread across the scan shrinks from 40 % to a few per cent (the
        // smoothing flattens the field's ends a little).
        for (tissue, rows) in [(100.0, 0..dims[1] / 2), (200.0, dims[1] / 2..dims[1])] {
            let values: Vec<f64> = rows
                .flat_map(|y| (0..dims[0]).map(move |x| (x, y)))
                .map(|(x, y)| corrected.value_at(x, y, 4))
                .collect();
            let (low, high) = values.iter().fold((f64::MAX, f64::MIN), |(l, h), &v| (l.min(v), h.max(v)));
            assert!((high - low) / tissue < 0.12, "tissue {tissue}: {low}..{high}");
        }
    }

    #[test]
    fn a_flat_scan_is_left_alone() {
        let dims = [32, 16, 8];
        let values: Vec<f32> =
            (0..dims[0] * dims[1] * dims[2]).map(|i| if i % 32 < 16 { 100.0 } else { 300.0 }).collect();
        let labels: Vec<u8> = (0..values.len()).map(|i| if i % 32 < 16 { 1 } else { 2 }).collect();
        let volume = Volume::from_f32(dims, [1.0; 3], &values, Path::new("flat")).unwrap();
        assert_eq!(Shading::estimate(&volume, &labels), None);
        // Nor is a scan without a labelled voxel.
        assert_eq!(Shading::estimate(&volume, &vec![0; values.len()]), None);
    }

    #[test]
    fn the_field_is_interpolated_between_cell_centres_and_held_at_the_edges() {
        let shading = Shading { dims: [8, 1, 1], cell: [4, 1, 1], grid: [2, 1, 1], field: vec![1.0, 2.0] };
        // Cell centres at x = 1.5 and 5.5.
        assert_eq!(shading.at(0, 0, 0), 1.0);
        assert!((shading.at(3, 0, 0) - 1.375).abs() < 1e-6);
        assert_eq!(shading.at(7, 0, 0), 2.0);
    }
}
