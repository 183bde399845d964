//! Whole-volume feature passes, a z slab at a time.
//!
//! A [`FeatureSlabReader`] keeps the three z planes a slice's features need (z-1, z, z+1) as
//! `f32` buffers and rolls them forward, so a slab reads each plane of the volume once through
//! [`Volume::read_f32`]. [`par_map_slabs`] runs one reader per worker over consecutive slabs.
//! A dropped reader leaves its plane buffers to the next reader made on the same thread:
//! rayon makes a reader per split of a parallel pass, often dozens per classification, and
//! fresh buffers cost a zero fill and a page fault per 4 KiB page each time.

use super::gap::GapPlanes;
use super::multiscale::{MultiscaleSlabReader, foreground_box};
use super::{FeatureError, FeatureSet, Neighbourhood, PAPER5_DIM, check_slab, inverse_span_mm};
use crate::volume::{ForegroundRows, Volume};
use rayon::prelude::*;
use std::ops::Range;

thread_local! {
    /// Plane buffers of this thread's last dropped reader (at most three planes of the largest
    /// volume read; their contents are stale and always overwritten before use).
    static SPARE_PLANES: std::cell::RefCell<Option<[Vec<f32>; 3]>> = const { std::cell::RefCell::new(None) };
}

/// Computes features for z slabs of one volume, reusing its plane buffers between calls.
pub struct FeatureSlabReader<'v> {
    volume: &'v Volume,
    /// The multi-scale set's block reader (`None` for the paper's set).
    multiscale: Option<MultiscaleSlabReader<'v>>,
    /// The closing's planes for [`FeatureSet::Paper5Gap`] (`None` for the other sets).
    gap: Option<GapPlanes>,
    feature_set: FeatureSet,
    /// Where the foreground is, when the caller promised to ask only for it: then only the
    /// rows near foreground are decoded.
    foreground_rows: Option<&'v ForegroundRows>,
    /// Three plane buffers and the z plane each holds (`None`: not loaded).
    planes: [Vec<f32>; 3],
    plane_z: [Option<usize>; 3],
    /// Clamped neighbours x-1, x+1 and y-1, y+1 of each column and row.
    x_neighbours: Vec<[usize; 2]>,
    y_neighbours: Vec<[usize; 2]>,
    x_gradient_scale: Vec<f32>,
    y_gradient_scale: Vec<f32>,
}

impl<'v> FeatureSlabReader<'v> {
    /// A reader of `volume`'s `feature_set` features, reusing this thread's spare plane buffers.
    pub fn new(volume: &'v Volume, feature_set: FeatureSet) -> FeatureSlabReader<'v> {
        let [size_x, size_y, _] = volume.dims;
        let neighbours = |size: usize| -> Vec<[usize; 2]> {
            (0..size).map(|p| [p.saturating_sub(1), (p + 1).min(size - 1)]).collect()
        };
        FeatureSlabReader {
            volume,
            multiscale: feature_set.scales().map(|scales| MultiscaleSlabReader::new(volume, scales)),
            gap: (feature_set == FeatureSet::Paper5Gap).then(|| GapPlanes::whole(volume.dims)),
            feature_set,
            foreground_rows: None,
            planes: SPARE_PLANES.with(|spare| spare.borrow_mut().take()).unwrap_or_default(),
            plane_z: [None; 3],
            x_neighbours: neighbours(size_x),
            y_neighbours: neighbours(size_y),
            x_gradient_scale: (0..size_x).map(|x| inverse_span_mm(x, size_x, volume.spacing_mm[0])).collect(),
            y_gradient_scale: (0..size_y).map(|y| inverse_span_mm(y, size_y, volume.spacing_mm[1])).collect(),
        }
    }

    /// Promises that only the voxels of `rows` will be asked for (their features, and the
    /// values of their rows from [`plane`](Self::plane)): the other rows of a plane, which
    /// most of a scan's are, are then neither decoded nor valid.
    /// The multi-scale set also skips the rest of each block.
    pub fn with_foreground_rows(mut self, rows: &'v ForegroundRows) -> Self {
        self.foreground_rows = Some(rows);
        self.multiscale = self.multiscale.take().map(|reader| reader.with_foreground_rows(rows));
        if self.gap.is_some() {
            let region = foreground_box(rows, 0..self.volume.dims[2]);
            self.gap = Some(GapPlanes::within(region, self.volume.dims));
        }
        self
    }

    /// The feature set it computes.
    pub fn feature_set(&self) -> FeatureSet {
        self.feature_set
    }

    /// Features of every voxel of z slices `z_range`, in voxel order, into `out` (cleared and
    /// resized to `voxels x dim`, row-major).
    pub fn compute(&mut self, z_range: Range<usize>, out: &mut Vec<f32>) -> Result<(), FeatureError> {
        check_slab(self.volume, &z_range)?;
        self.fill(z_range, out);
        Ok(())
    }

    /// [`compute`](Self::compute) for a range known to be inside the volume.
    fn fill(&mut self, z_range: Range<usize>, out: &mut Vec<f32>) {
        let [size_x, size_y, _] = self.volume.dims;
        let plane = size_x * size_y;
        if let Some(multiscale) = &mut self.multiscale {
            let every: Vec<usize> = (0..plane).collect();
            let mut block = Vec::new();
            out.clear();
            for z in z_range {
                multiscale.compute_selected(z, &every, &mut block);
                out.extend_from_slice(&block);
            }
            return;
        }
        let dim = self.feature_set.dim();
        out.clear();
        out.resize(z_range.len() * plane * dim, 0.0);
        for (z, slice_out) in z_range.clone().zip(out.chunks_exact_mut(plane * dim)) {
            if let Some(gap) = &mut self.gap {
                gap.write_depths(self.volume, z, 0..plane, slice_out.chunks_exact_mut(dim), PAPER5_DIM);
            }
            let [previous, current, next] = self.load_planes_around(z);
            let previous = &self.planes[previous];
            let current = &self.planes[current];
            let next = &self.planes[next];
            let z_gradient_scale = inverse_span_mm(z, self.volume.dims[2], self.volume.spacing_mm[2]);
            for (y, row_out) in slice_out.chunks_exact_mut(size_x * dim).enumerate() {
                let y_gradient_scale = self.y_gradient_scale[y];
                let rows = NineRows::around(y, [previous, current, next], size_x, self.y_neighbours[y]);
                let mut emit = |x: usize, x_minus: usize, x_plus: usize, x_scale: f32| {
                    let neighbourhood =
                        rows.neighbourhood([x_minus, x, x_plus], [x_scale, y_gradient_scale, z_gradient_scale]);
                    let voxel_out = &mut row_out[x * dim..x * dim + PAPER5_DIM];
                    voxel_out.copy_from_slice(&neighbourhood.paper5());
                };
                // The first and last columns clamp; the columns between need no table.
                for x in [0, size_x - 1] {
                    let [x_minus, x_plus] = self.x_neighbours[x];
                    emit(x, x_minus, x_plus, self.x_gradient_scale[x]);
                }
                if size_x > 2 {
                    let interior_scale = self.x_gradient_scale[1];
                    for x in 1..size_x - 1 {
                        emit(x, x - 1, x + 1, interior_scale);
                    }
                }
            }
        }
    }

    /// Features of selected voxels of z slice `z`, given by their index within the slice
    /// (`x + size_x * y`), into `out` (cleared and resized to `selected.len() x dim`). This is
    /// the path for sparse work (foreground voxels only, coarse-to-fine refinement); it gives
    /// the same values as [`compute`](Self::compute) for the same voxels.
    pub fn compute_selected(&mut self, z: usize, selected: &[usize], out: &mut Vec<f32>) -> Result<(), FeatureError> {
        check_slab(self.volume, &(z..z + 1))?;
        let [size_x, size_y, _] = self.volume.dims;
        if let Some(&index) = selected.iter().find(|&&i| i >= size_x * size_y) {
            return Err(FeatureError::VoxelOutOfRange { index, voxel_count: size_x * size_y });
        }
        if let Some(multiscale) = &mut self.multiscale {
            multiscale.compute_selected(z, selected, out);
            return Ok(());
        }
        // Every value is written below: no need to zero them first.
        let dim = self.feature_set.dim();
        out.resize(selected.len() * dim, 0.0);
        out.truncate(selected.len() * dim);
        if selected.is_empty() {
            return Ok(());
        }
        if let Some(gap) = &mut self.gap {
            gap.write_depths(self.volume, z, selected.iter().copied(), out.chunks_exact_mut(dim), PAPER5_DIM);
        }
        let [previous, current, next] = self.load_planes_around(z);
        let planes = [&self.planes[previous][..], &self.planes[current][..], &self.planes[next][..]];
        let z_gradient_scale = inverse_span_mm(z, self.volume.dims[2], self.volume.spacing_mm[2]);
        // Selections come a row at a time: the nine rows are cut once per row, not per voxel.
        let mut row: Option<(usize, NineRows)> = None;
        for (&index, voxel_out) in selected.iter().zip(out.chunks_exact_mut(dim)) {
            let (x, y) = (index % size_x, index / size_x);
            let rows = match row {
                Some((row_y, rows)) if row_y == y => rows,
                _ => {
                    let rows = NineRows::around(y, planes, size_x, self.y_neighbours[y]);
                    row = Some((y, rows));
                    rows
                }
            };
            let [x_minus, x_plus] = self.x_neighbours[x];
            let gradient_scale = [self.x_gradient_scale[x], self.y_gradient_scale[y], z_gradient_scale];
            let neighbourhood = rows.neighbourhood([x_minus, x, x_plus], gradient_scale);
            voxel_out[..PAPER5_DIM].copy_from_slice(&neighbourhood.paper5());
        }
        Ok(())
    }

    /// The physical values of z plane `z` (x fastest). For the paper's set this is the plane
    /// buffer that [`compute_selected`](Self::compute_selected) for the same `z` then uses, so a
    /// caller that selects voxels by value reads each plane once.
    pub fn plane(&mut self, z: usize) -> Result<&[f32], FeatureError> {
        check_slab(self.volume, &(z..z + 1))?;
        if self.multiscale.is_some() {
            // The multi-scale reader keeps blocks, not planes; the plane buffers are free.
            self.decode(z, 0);
            return Ok(&self.planes[0]);
        }
        let [_, current, _] = self.load_planes_around(z);
        Ok(&self.planes[current])
    }

    /// Makes the buffers hold planes z-1, z, z+1 (clamped) and returns which buffer holds each.
    /// Moving forward one plane reads one new plane.
    fn load_planes_around(&mut self, z: usize) -> [usize; 3] {
        let size_z = self.volume.dims[2];
        let wanted = [z.saturating_sub(1), z, (z + 1).min(size_z - 1)];
        let mut slots = [usize::MAX; 3];
        for (k, &wanted_z) in wanted.iter().enumerate() {
            if let Some(slot) = self.plane_z.iter().position(|&held| held == Some(wanted_z)) {
                slots[k] = slot;
            }
        }
        for k in 0..3 {
            if slots[k] != usize::MAX {
                continue;
            }
            // A buffer holding no wanted plane is free (there always is one: 3 buffers, at
            // most 3 distinct wanted planes, and this one is not held).
            let free = (0..3).find(|slot| !slots.contains(slot)).unwrap_or(k);
            self.decode(wanted[k], free);
            self.plane_z[free] = Some(wanted[k]);
            slots[k] = free;
            // Clamping can ask for the same plane twice (z = 0 or the last slice).
            for later in k + 1..3 {
                if wanted[later] == wanted[k] {
                    slots[later] = free;
                }
            }
        }
        slots
    }

    /// Decodes plane `z` into buffer `slot`: every row, or with foreground rows only those
    /// near foreground (the others keep stale values nobody reads).
    fn decode(&mut self, z: usize, slot: usize) {
        let [size_x, size_y, _] = self.volume.dims;
        let buffer = &mut self.planes[slot];
        buffer.resize(size_x * size_y, 0.0);
        let Some(rows) = self.foreground_rows else {
            self.volume.read_z_slice_f32(z, buffer);
            return;
        };
        for (y, row) in buffer.chunks_exact_mut(size_x).enumerate() {
            if rows.near_foreground(y, z) {
                self.volume.read_f32(size_x * (y + size_y * z), row);
            }
        }
    }
}

impl Drop for FeatureSlabReader<'_> {
    fn drop(&mut self) {
        let planes = std::mem::take(&mut self.planes);
        SPARE_PLANES.with(|spare| *spare.borrow_mut() = Some(planes));
    }
}

/// Rows y-1, y, y+1 of planes z-1, z, z+1.
#[derive(Clone, Copy)]
struct NineRows<'a> {
    previous: [&'a [f32]; 3],
    current: [&'a [f32]; 3],
    next: [&'a [f32]; 3],
}

impl<'a> NineRows<'a> {
    /// Rows `y_minus`, `y`, `y_plus` (`y`'s clamped neighbours) of the three planes, each
    /// `size_x` long.
    fn around(y: usize, planes: [&'a [f32]; 3], size_x: usize, [y_minus, y_plus]: [usize; 2]) -> NineRows<'a> {
        let rows = |plane: &'a [f32]| [y_minus, y, y_plus].map(|y| &plane[y * size_x..(y + 1) * size_x]);
        let [previous, current, next] = planes;
        NineRows { previous: rows(previous), current: rows(current), next: rows(next) }.cut_to(size_x)
    }

    /// Every row cut to exactly `length`, so that the optimiser can drop bounds checks.
    fn cut_to(self, length: usize) -> NineRows<'a> {
        let cut = |rows: [&'a [f32]; 3]| rows.map(|row| &row[..length]);
        NineRows { previous: cut(self.previous), current: cut(self.current), next: cut(self.next) }
    }

    /// The neighbourhood of column `x[1]` with clamped neighbours `x[0]`, `x[2]` (the same
    /// order of values as `features_at`).
    #[inline(always)]
    fn neighbourhood(&self, x: [usize; 3], gradient_scale: [f32; 3]) -> Neighbourhood {
        let [previous_minus, previous_0, previous_plus] = self.previous;
        let [current_minus, current_0, current_plus] = self.current;
        let [next_minus, next_0, next_plus] = self.next;
        let [x_minus, x, x_plus] = x;
        Neighbourhood {
            centre: current_0[x],
            xy: [
                current_minus[x_minus],
                current_minus[x],
                current_minus[x_plus],
                current_0[x_minus],
                current_0[x_plus],
                current_plus[x_minus],
                current_plus[x],
                current_plus[x_plus],
            ],
            xz: [
                previous_0[x_minus],
                previous_0[x],
                previous_0[x_plus],
                current_0[x_minus],
                current_0[x_plus],
                next_0[x_minus],
                next_0[x],
                next_0[x_plus],
            ],
            yz: [
                previous_minus[x],
                previous_0[x],
                previous_plus[x],
                current_minus[x],
                current_plus[x],
                next_minus[x],
                next_0[x],
                next_plus[x],
            ],
            gradient_scale,
        }
    }
}

/// Consecutive z ranges of at most `depth_z` slices covering `0..size_z` (`depth_z` 0 counts as 1).
pub fn slab_ranges(size_z: usize, depth_z: usize) -> Vec<Range<usize>> {
    let depth_z = depth_z.max(1);
    (0..size_z).step_by(depth_z).map(|start| start..(start + depth_z).min(size_z)).collect()
}

/// Computes the features of the whole volume slab by slab in parallel and calls `work` with
/// each slab's z range and its `voxels x dim` feature block; returns the results in slab order.
pub fn par_map_slabs<T, F>(volume: &Volume, feature_set: FeatureSet, depth_z: usize, work: F) -> Vec<T>
where
    T: Send,
    F: Fn(Range<usize>, &[f32]) -> T + Sync,
{
    slab_ranges(volume.dims[2], depth_z)
        .into_par_iter()
        .map_init(
            || (FeatureSlabReader::new(volume, feature_set), Vec::new()),
            |(reader, block), z_range| {
                // slab_ranges stays inside the volume.
                reader.fill(z_range.clone(), block);
                work(z_range, block)
            },
        )
        .collect()
}
