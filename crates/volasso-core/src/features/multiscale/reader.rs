//! Reading multi-scale features out of a volume: for scattered voxels (training, in
//! 16^3 tiles, each one block) and plane by plane for whole-volume labelling (a block of z planes
//! moved forward as the planes asked for move on). The features themselves are [`super`]'s.

use super::super::{FeatureError, check_voxels};
use super::{MultiscaleBlock, Scales, block_depth};
use crate::volume::{ForegroundRows, Volume};
use rayon::prelude::*;
use std::ops::Range;

/// Training voxels are grouped into tiles of this many voxels per side.
const TILE: usize = 16;

/// Multiscale features of the voxels at `indices` (any order), row-major; parallel over 16^3
/// tiles, each one block over the bounding box of its voxels.
pub fn multiscale_features_of_voxels(
    volume: &Volume,
    scales: Scales,
    indices: &[usize],
) -> Result<Vec<f32>, FeatureError> {
    check_voxels(volume, indices)?;
    let dim = scales.dim();
    let [size_x, size_y, _] = volume.dims;
    let position = |index: usize| [index % size_x, (index / size_x) % size_y, index / (size_x * size_y)];
    let mut order: Vec<(usize, usize)> = indices
        .iter()
        .enumerate()
        .map(|(k, &index)| {
            let [x, y, z] = position(index);
            let tile = (z / TILE) * (size_x.div_ceil(TILE) * size_y.div_ceil(TILE))
                + (y / TILE) * size_x.div_ceil(TILE)
                + x / TILE;
            (tile, k)
        })
        .collect();
    order.sort_unstable();
    let groups: Vec<&[(usize, usize)]> = order.chunk_by(|a, b| a.0 == b.0).collect();
    // Each tile's (tile, position in `indices`) pairs and its voxels' features.
    type TileFeatures<'a> = (&'a [(usize, usize)], Vec<f32>);
    let rows: Vec<TileFeatures> = groups
        .par_iter()
        .map_init(
            || MultiscaleBlock::new(volume, scales),
            |block, &group| {
                let voxels: Vec<[usize; 3]> = group.iter().map(|&(_, k)| position(indices[k])).collect();
                let core = std::array::from_fn(|a| {
                    let low = voxels.iter().map(|v| v[a]).min().unwrap_or(0);
                    let high = voxels.iter().map(|v| v[a]).max().unwrap_or(0);
                    low..high + 1
                });
                block.compute(volume, core);
                let mut features = vec![0f32; voxels.len() * dim];
                block.features_of(&voxels, &mut features);
                (group, features)
            },
        )
        .collect();
    let mut out = vec![0f32; indices.len() * dim];
    for (group, features) in rows {
        for (&(_, k), row) in group.iter().zip(features.chunks_exact(dim)) {
            out[k * dim..(k + 1) * dim].copy_from_slice(row);
        }
    }
    Ok(out)
}

/// Whole-volume reader: keeps one block of full z planes and moves it forward when asked for
/// a plane outside it. With foreground rows, a block covers only the xy bounding box of its
/// planes' foreground (plus the halo), since only that is ever classified; a voxel outside
/// that box reloads the block with whole planes.
pub struct MultiscaleSlabReader<'v> {
    volume: &'v Volume,
    block: MultiscaleBlock,
    depth: usize,
    foreground_rows: Option<&'v ForegroundRows>,
    /// The z planes loaded, and whether the block covers them whole.
    loaded: Option<(Range<usize>, bool)>,
    /// The voxels asked for, as positions.
    voxels: Vec<[usize; 3]>,
}

impl<'v> MultiscaleSlabReader<'v> {
    /// A reader of `volume`'s features at `scales`, with blocks of [`super::block_depth`] planes.
    pub fn new(volume: &'v Volume, scales: Scales) -> MultiscaleSlabReader<'v> {
        MultiscaleSlabReader {
            volume,
            block: MultiscaleBlock::new(volume, scales),
            depth: block_depth(volume.dims),
            foreground_rows: None,
            loaded: None,
            voxels: Vec::new(),
        }
    }

    /// Only the voxels of `rows` will be asked for (see the type's doc).
    pub fn with_foreground_rows(mut self, rows: &'v ForegroundRows) -> Self {
        self.foreground_rows = Some(rows);
        self
    }

    /// Features of the voxels `selected` (indices within z plane `z`) into `out` (cleared and
    /// resized to `selected.len() x dim`). `z` and `selected` must be inside the volume (the
    /// caller checks).
    pub fn compute_selected(&mut self, z: usize, selected: &[usize], out: &mut Vec<f32>) {
        let dim = self.block.scales.dim();
        // `features_of` writes every value: no need to zero them first.
        out.resize(selected.len() * dim, 0.0);
        out.truncate(selected.len() * dim);
        if selected.is_empty() {
            return;
        }
        let [size_x, size_y, size_z] = self.volume.dims;
        self.voxels.clear();
        self.voxels.extend(PlanePositions::new(size_x).of(selected, z));
        // Blocks start on multiples of the depth, so that workers asked for neighbouring planes
        // in any order load each block once, and hold the next block's first plane too (the
        // coarse plane a slab of coarse-to-fine labelling needs beyond its own).
        let start = z - z % self.depth;
        let planes = start..(start + self.depth + 1).min(size_z);
        let inside = |core: &[Range<usize>; 3], voxels: &[[usize; 3]]| {
            voxels.iter().all(|v| core[0].contains(&v[0]) && core[1].contains(&v[1]))
        };
        let current = self.loaded.as_ref().filter(|(range, _)| range.contains(&z));
        match current {
            Some(_) if inside(self.block.core(), &self.voxels) => {}
            Some(_) => {
                self.block.compute(self.volume, [0..size_x, 0..size_y, planes.clone()]);
                self.loaded = Some((planes, true));
            }
            None => {
                let [xs, ys] = match self.foreground_rows {
                    Some(rows) => foreground_box(rows, planes.clone()),
                    None => [0..size_x, 0..size_y],
                };
                let whole = xs.len() == size_x && ys.len() == size_y;
                self.block.compute(self.volume, [xs, ys, planes.clone()]);
                self.loaded = Some((planes.clone(), whole));
                if !inside(self.block.core(), &self.voxels) {
                    self.block.compute(self.volume, [0..size_x, 0..size_y, planes.clone()]);
                    self.loaded = Some((planes, true));
                }
            }
        }
        self.block.features_of(&self.voxels, out);
    }

    /// Z planes per block.
    pub fn depth(&self) -> usize {
        self.depth
    }
}

/// The x and y ranges of the foreground `rows` in z planes `planes` (a single voxel when there
/// is none).
pub(in crate::features) fn foreground_box(rows: &ForegroundRows, planes: Range<usize>) -> [Range<usize>; 2] {
    let (mut low, mut high) = ([usize::MAX; 2], [0usize; 2]);
    for z in planes {
        for y in 0..rows.size_y() {
            if let Some(span) = rows.span(y, z) {
                low = [low[0].min(*span.start()), low[1].min(y)];
                high = [high[0].max(*span.end()), high[1].max(y)];
            }
        }
    }
    if low[0] == usize::MAX { [0..1, 0..1] } else { [low[0]..high[0] + 1, low[1]..high[1] + 1] }
}

/// Plane indices (`x + size_x * y`) to positions without a division per voxel: selections
/// come in ascending order, mostly a few voxels apart, so the row is tracked and divided for
/// only when an index leaves it (an integer division costs tens of cycles, as much as the
/// rest of the bookkeeping of a voxel).
struct PlanePositions {
    size_x: usize,
    row_start: usize,
    y: usize,
}

impl PlanePositions {
    fn new(size_x: usize) -> PlanePositions {
        PlanePositions { size_x, row_start: 0, y: 0 }
    }

    /// The positions of plane indices `indices` in z plane `z`, in any order.
    fn of<'a>(mut self, indices: &'a [usize], z: usize) -> impl Iterator<Item = [usize; 3]> + 'a {
        indices.iter().map(move |&index| {
            if index.wrapping_sub(self.row_start) >= self.size_x {
                self.y = index / self.size_x;
                self.row_start = self.y * self.size_x;
            }
            [index - self.row_start, self.y, z]
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_positions_match_division_in_any_order() {
        let size_x = 7;
        let mut indices: Vec<usize> = vec![0, 1, 6, 7, 8, 13, 14, 40, 41, 48, 3, 0, 69, 70, 62, 63, 64];
        let mut state = 12345u64;
        for _ in 0..200 {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            indices.push((state >> 33) as usize % 500);
        }
        let positions: Vec<[usize; 3]> = PlanePositions::new(size_x).of(&indices, 5).collect();
        for (&index, position) in indices.iter().zip(&positions) {
            assert_eq!(*position, [index % size_x, index / size_x, 5], "index {index}");
        }
    }
}
