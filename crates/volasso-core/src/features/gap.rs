//! Gap depth: how far a voxel lies below the brighter structures that enclose it, the grey
//! closing of the volume minus the volume (a black top-hat, Serra's morphology) over a cube of
//! `2 GAP_RADIUS + 1` voxels a side.
//!
//! The paper's five features (§3.3) see a voxel and its 3 x 3 x 3 neighbourhood; a thin dark
//! layer held between two bright structures (a joint space between two bones, a fissure, a
//! sulcus between two gyri) and the blurred edge of a bright structure that faces a dark one
//! look the same to them: an intermediate value on a steep gradient. The closing fills a dark
//! layer up to `2 GAP_RADIUS` voxels thin with its bright surroundings and leaves a convex edge
//! as it is, so the gap depth of the first is large and of the second near 0. (In a flat noisy
//! region it is the noise's local spread; smoothing the volume first loses with leaky
//! lassos, `docs/decisions/0011-gap-depth.md`.)
//!
//! Windows are cut at the volume's faces (a voxel outside counts as no voxel, which is what
//! clamping to the edge gives for a maximum or a minimum). Both paths, [`gap_depth_of_voxels`]
//! for training voxels and [`GapPlanes`] for whole planes, take maxima and minima of the same
//! values and so agree to the bit.
//!
//! Never: keeps a copy of the whole volume (a whole-volume pass holds about `10 GAP_RADIUS + 6`
//! planes of its rectangle per worker: raw and dilated planes `2 GAP_RADIUS` either side, closed
//! ones `GAP_RADIUS` either side, three buffers), or knows about classes.

use crate::volume::Volume;
use std::collections::BTreeMap;

/// Half the side of the closing's cube, in voxels: a dark layer up to 4 voxels thin is filled.
pub const GAP_RADIUS: usize = 2;

/// The closing's window `p - GAP_RADIUS ..= p + GAP_RADIUS` cut to `0..size`.
#[inline]
fn window(p: usize, size: usize) -> std::ops::RangeInclusive<usize> {
    p.saturating_sub(GAP_RADIUS)..=(p + GAP_RADIUS).min(size - 1)
}

/// The gap depth of each voxel of `indices` (x-fastest indices inside the volume).
pub fn gap_depth_of_voxels(volume: &Volume, indices: &[usize]) -> Vec<f32> {
    use rayon::prelude::*;
    indices.par_iter().with_min_len(64).map(|&index| gap_depth_at(volume, index)).collect()
}

/// The gap depth of voxel `index`, from the block of voxels within `2 GAP_RADIUS` of it (cut
/// to the volume): dilated in x and y plane by plane, then across planes where the closing's
/// erosion reads them, and that erosion's minimum at the centre.
fn gap_depth_at(volume: &Volume, index: usize) -> f32 {
    let [size_x, size_y, size_z] = volume.dims;
    let centre = [index % size_x, (index / size_x) % size_y, index / (size_x * size_y)];
    let reach = 2 * GAP_RADIUS;
    let start: [usize; 3] = std::array::from_fn(|a| centre[a].saturating_sub(reach));
    let end: [usize; 3] = std::array::from_fn(|a| (centre[a] + reach).min(volume.dims[a] - 1) + 1);
    let [nx, ny, nz] = std::array::from_fn(|a| end[a] - start[a]);
    let plane = nx * ny;
    let mut raw = vec![0f32; plane * nz];
    for z in 0..nz {
        for y in 0..ny {
            let row = &mut raw[(z * ny + y) * nx..][..nx];
            volume.read_f32(volume.index(start[0], start[1] + y, start[2] + z), row);
        }
    }
    // Within the block every window the centre's closing reads is the volume's own: the
    // block reaches as far as the dilation's windows around the erosion's.
    let mut dilated_xy = vec![0f32; raw.len()];
    let mut scratch = vec![0f32; plane];
    for (plane_in, plane_out) in raw.chunks_exact(plane).zip(dilated_xy.chunks_exact_mut(plane)) {
        extreme_in_plane(plane_in, &mut scratch, plane_out, nx, f32::max);
    }
    let local = |x: usize, y: usize, z: usize| ((z - start[2]) * ny + y - start[1]) * nx + x - start[0];
    let mut closing = f32::INFINITY;
    for z in window(centre[2], size_z) {
        for y in window(centre[1], size_y) {
            for x in window(centre[0], size_x) {
                let dilated = window(z, size_z).map(|w| dilated_xy[local(x, y, w)]).fold(f32::NEG_INFINITY, f32::max);
                closing = closing.min(dilated);
            }
        }
    }
    closing - raw[local(centre[0], centre[1], centre[2])]
}

/// `plane_out` the extreme (`pick`: max or min) of `plane_in` over each voxel's window in x,
/// into `scratch`, then in y (rows of `nx`). The interior of each row and each whole row are
/// taken as shifted slices, which the compiler turns into vector instructions.
#[inline]
fn extreme_in_plane<F: Fn(f32, f32) -> f32 + Copy>(
    plane_in: &[f32],
    scratch: &mut [f32],
    plane_out: &mut [f32],
    nx: usize,
    pick: F,
) {
    let ny = plane_in.len() / nx;
    // Columns whose whole window lies in the row.
    let interior = GAP_RADIUS.min(nx)..nx.saturating_sub(GAP_RADIUS).max(GAP_RADIUS.min(nx));
    for y in 0..ny {
        let row_in = &plane_in[y * nx..][..nx];
        let row_out = &mut scratch[y * nx..][..nx];
        if !interior.is_empty() {
            let span = interior.len();
            row_out[interior.clone()].copy_from_slice(&row_in[interior.clone()]);
            for shift in 1..=GAP_RADIUS {
                pick_into(&mut row_out[interior.clone()], &row_in[interior.start - shift..][..span], pick);
                pick_into(&mut row_out[interior.clone()], &row_in[interior.start + shift..][..span], pick);
            }
        }
        for x in (0..interior.start).chain(interior.end..nx) {
            row_out[x] = row_in[window(x, nx)].iter().copied().fold(row_in[x], pick);
        }
    }
    for y in 0..ny {
        let row_out = &mut plane_out[y * nx..][..nx];
        row_out.copy_from_slice(&scratch[y * nx..][..nx]);
        for w in window(y, ny) {
            pick_into(row_out, &scratch[w * nx..][..nx], pick);
        }
    }
}

/// `values[i] = pick(values[i], other[i])` for every `i` (`other` as long as `values`), as a
/// plain indexed loop always inlined into its caller: the tests' build (opt-level 1) does not
/// inline iterator adapters, and a call per voxel made the gap depth there many times slower.
#[inline(always)]
fn pick_into<F: Fn(f32, f32) -> f32>(values: &mut [f32], other: &[f32], pick: F) {
    let count = values.len().min(other.len());
    let (values, other) = (&mut values[..count], &other[..count]);
    let mut i = 0;
    while i < count {
        values[i] = pick(values[i], other[i]);
        i += 1;
    }
}

/// `out` the voxel-wise extreme of `planes` (at least one).
#[inline]
fn extreme_of_planes<F: Fn(f32, f32) -> f32>(planes: &[&[f32]], out: &mut [f32], pick: F) {
    out.copy_from_slice(planes[0]);
    for plane in &planes[1..] {
        pick_into(out, plane, &pick);
    }
}

/// Gap depths a z plane at a time, for whole-volume passes, within a rectangle of each plane
/// (the whole plane, or the foreground's box grown by the closing's reach: every depth inside
/// the foreground box is then the whole volume's). Planes asked for in rising order cost one
/// new plane of each stage (the dilation in the plane, the dilation across planes and the
/// erosion in the plane); planes asked for out of order are recomputed.
pub struct GapPlanes {
    /// The x and y ranges computed.
    region: [std::ops::Range<usize>; 2],
    /// Raw planes, by z: read once for the dilation and kept for the depth's subtraction.
    raw: BTreeMap<usize, Vec<f32>>,
    /// Raw planes dilated in x and y, by z.
    dilated_xy: BTreeMap<usize, Vec<f32>>,
    /// Planes dilated in x, y and z, then eroded in x and y, by z.
    closed_xy: BTreeMap<usize, Vec<f32>>,
    scratch: Vec<f32>,
    across: Vec<f32>,
    /// The last plane given.
    out: Vec<f32>,
}

impl GapPlanes {
    /// Whole planes of a volume of `dims`.
    pub fn whole(dims: [usize; 3]) -> GapPlanes {
        GapPlanes::within([0..dims[0], 0..dims[1]], dims)
    }

    /// The rectangle `foreground` (x and y ranges) grown by the closing's reach, cut to a
    /// volume of `dims`.
    pub fn within(foreground: [std::ops::Range<usize>; 2], dims: [usize; 3]) -> GapPlanes {
        let reach = 2 * GAP_RADIUS;
        let region = [0, 1].map(|a| {
            let range = &foreground[a];
            let end = (range.end + reach).min(dims[a]);
            range.start.saturating_sub(reach).min(end.saturating_sub(1))..end
        });
        GapPlanes {
            region,
            raw: BTreeMap::new(),
            dilated_xy: BTreeMap::new(),
            closed_xy: BTreeMap::new(),
            scratch: Vec::new(),
            across: Vec::new(),
            out: Vec::new(),
        }
    }

    /// Writes the gap depth of each voxel of z plane `z`, given by its index within the plane
    /// (`x + size_x y`), into `rows[k][column]`, the row of the k-th index; 0 for a voxel
    /// outside the rectangle (outside the foreground, whose features a reader restricted to
    /// it does not give either).
    pub fn write_depths<'r>(
        &mut self,
        volume: &Volume,
        z: usize,
        indices: impl Iterator<Item = usize>,
        rows: impl Iterator<Item = &'r mut [f32]>,
        column: usize,
    ) {
        self.plane(volume, z);
        let size_x = volume.dims[0];
        let [columns, lines] = &self.region;
        for (index, row) in indices.zip(rows) {
            let (x, y) = (index % size_x, index / size_x);
            row[column] = if columns.contains(&x) && lines.contains(&y) {
                self.out[(y - lines.start) * columns.len() + x - columns.start]
            } else {
                0.0
            };
        }
    }

    /// The gap depths of z plane `z` of `volume` within the rectangle (x fastest, rows of the
    /// rectangle's width).
    pub fn plane(&mut self, volume: &Volume, z: usize) -> &[f32] {
        let nz = volume.dims[2];
        let [nx, ny] = [self.region[0].len(), self.region[1].len()];
        let plane = nx * ny;
        self.raw.retain(|&held, _| held + 2 * GAP_RADIUS >= z);
        self.dilated_xy.retain(|&held, _| held + 2 * GAP_RADIUS >= z);
        self.closed_xy.retain(|&held, _| held + GAP_RADIUS >= z);
        self.scratch.resize(plane, 0.0);
        self.across.resize(plane, 0.0);
        for closed_z in window(z, nz) {
            if self.closed_xy.contains_key(&closed_z) {
                continue;
            }
            for raw_z in window(closed_z, nz) {
                if self.dilated_xy.contains_key(&raw_z) {
                    continue;
                }
                let raw = self.raw.entry(raw_z).or_insert_with(|| read_rectangle(volume, &self.region, raw_z));
                let mut dilated = vec![0f32; plane];
                extreme_in_plane(raw, &mut self.scratch, &mut dilated, nx, f32::max);
                self.dilated_xy.insert(raw_z, dilated);
            }
            let planes: Vec<&[f32]> = window(closed_z, nz).map(|w| &self.dilated_xy[&w][..]).collect();
            extreme_of_planes(&planes, &mut self.across, f32::max);
            let mut closed = vec![0f32; plane];
            extreme_in_plane(&self.across, &mut self.scratch, &mut closed, nx, f32::min);
            self.closed_xy.insert(closed_z, closed);
        }
        let planes: Vec<&[f32]> = window(z, nz).map(|w| &self.closed_xy[&w][..]).collect();
        self.out.resize(plane, 0.0);
        extreme_of_planes(&planes, &mut self.out, f32::min);
        // Plane z was read for the dilation of closed plane z (in its own window) and is kept
        // as long as that dilation is.
        let raw = self.raw.entry(z).or_insert_with(|| read_rectangle(volume, &self.region, z));
        for (depth, &value) in self.out.iter_mut().zip(raw.iter()) {
            *depth -= value;
        }
        &self.out
    }
}

/// The rectangle `region` (x and y ranges) of z plane `z`.
fn read_rectangle(volume: &Volume, region: &[std::ops::Range<usize>; 2], z: usize) -> Vec<f32> {
    let width = region[0].len();
    let mut values = vec![0f32; width * region[1].len()];
    for (row, y) in values.chunks_exact_mut(width).zip(region[1].clone()) {
        volume.read_f32(volume.index(region[0].start, y, z), row);
    }
    values
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::Volume;

    fn volume_of(dims: [usize; 3], mut value: impl FnMut(usize, usize, usize) -> f32) -> Volume {
        let mut values = Vec::with_capacity(dims[0] * dims[1] * dims[2]);
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    values.push(value(x, y, z));
                }
            }
        }
        Volume::from_f32(dims, [1.0; 3], &values, std::path::Path::new("test")).unwrap()
    }

    #[test]
    fn a_dark_layer_between_bright_slabs_is_deep_and_an_edge_is_not() {
        // A bright column x 4..16, cut by a dark layer z 8..=11 (4 thin); the column's sides
        // face dark space.
        let volume = volume_of([20, 12, 20], |x, _, z| {
            let column = (4..16).contains(&x);
            if column && !(8..=11).contains(&z) { 1000.0 } else { 100.0 }
        });
        let at = |x: usize, y: usize, z: usize| volume.index(x, y, z);
        let depths =
            gap_depth_of_voxels(&volume, &[at(10, 6, 9), at(10, 6, 10), at(2, 6, 4), at(3, 6, 4), at(10, 6, 4)]);
        assert_eq!(depths[..2], [900.0, 900.0], "inside the layer");
        for (depth, what) in depths[2..].iter().zip(["beside the column's edge", "at its edge", "inside the column"]) {
            assert_eq!(*depth, 0.0, "{what}");
        }
    }

    #[test]
    fn planes_agree_with_voxels_to_the_bit_in_any_order() {
        let mut state = 7u64;
        let volume = volume_of([13, 9, 11], |_, _, _| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 40) as f32 * 0.37 - 9000.0
        });
        let [nx, ny, nz] = volume.dims;
        let mut planes = GapPlanes::whole(volume.dims);
        for z in [0, 1, 2, 3, 7, 8, 10, 4, 0, 10, 5] {
            let plane = planes.plane(&volume, z).to_vec();
            let indices: Vec<usize> = (0..nx * ny).map(|i| i + z * nx * ny).collect();
            assert_eq!(plane, gap_depth_of_voxels(&volume, &indices), "plane {z}");
        }
        assert!(nz > 2 * GAP_RADIUS);
    }

    #[test]
    fn a_brute_force_closing_gives_the_same_depths() {
        for dims in [[9, 8, 7], [1, 1, 1], [1, 3, 2], [4, 1, 6], [2, 5, 1], [6, 6, 5]] {
            brute_force_check(dims);
        }
    }

    fn brute_force_check(dims: [usize; 3]) {
        let mut state = 3u64;
        let volume = volume_of(dims, |_, _, _| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 33) % 1000) as f32
        });
        let [nx, ny, nz] = volume.dims;
        let mut planes = GapPlanes::whole(volume.dims);
        let by_planes: Vec<f32> = (0..nz).flat_map(|z| planes.plane(&volume, z).to_vec()).collect();
        let value = |x: usize, y: usize, z: usize| volume.value_at(x, y, z) as f32;
        let dilated = |x: usize, y: usize, z: usize| {
            let mut best = f32::MIN;
            for zz in window(z, nz) {
                for yy in window(y, ny) {
                    for xx in window(x, nx) {
                        best = best.max(value(xx, yy, zz));
                    }
                }
            }
            best
        };
        let all: Vec<usize> = (0..nx * ny * nz).collect();
        let depths = gap_depth_of_voxels(&volume, &all);
        for (index, depth) in depths.into_iter().enumerate() {
            let (x, y, z) = (index % nx, (index / nx) % ny, index / (nx * ny));
            let mut closing = f32::MAX;
            for zz in window(z, nz) {
                for yy in window(y, ny) {
                    for xx in window(x, nx) {
                        closing = closing.min(dilated(xx, yy, zz));
                    }
                }
            }
            assert_eq!(depth, closing - value(x, y, z), "{dims:?} voxel {index}");
            assert_eq!(by_planes[index], depth, "{dims:?} voxel {index} by planes");
        }
    }
}
