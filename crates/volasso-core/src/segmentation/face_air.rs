//! The dark region connected to the volume's faces: the air around a body in CT and MRI alike.
//!
//! A voxel is *dark* when it lies outside the scanned body at a level (the volume's Otsu
//! threshold, see `super::background`; [`Volume::body_at`]): below the level, and not ringed
//! by the body in its own slice along any axis. The face region is every dark voxel that a path
//! of dark voxels (6-neighbours) joins to a voxel on one of the volume's six faces. Dark voxels
//! inside a body (lungs, sinuses, bowel gas) are not in it, also where they reach a face: a
//! chest CT's lungs leave the volume through its top face by the trachea and their apices, and
//! a windowed scan makes them as dark as the air, but the chest wall rings them in every axial
//! slice.
//!
//! Both searches fill whole runs along x at a time (a scanline flood fill), so their stacks hold
//! row segments, not voxels:
//! * [`FaceRegion::find`] fills the whole face region from every dark face voxel (one pass that
//!   first marks the dark voxels plane by plane in parallel);
//! * [`reaches_face`] answers for a few voxels (a lasso's dark ones) by filling from them only
//!   until a face is touched, so that a lasso in the air around a body costs a small
//!   neighbourhood, not the whole volume.
//!
//! Never: decides what is background (that is `super::background`'s rule), or reads files.

use crate::volume::Volume;
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// A set of voxels as one bit per voxel (x fastest).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct VoxelBits {
    words: Vec<u64>,
}

impl VoxelBits {
    /// The empty set over `voxel_count` voxels.
    pub fn new(voxel_count: usize) -> VoxelBits {
        VoxelBits { words: vec![0; voxel_count.div_ceil(64)] }
    }

    /// Whether voxel `index` is in the set.
    #[inline]
    pub fn contains(&self, index: usize) -> bool {
        self.words[index / 64] >> (index % 64) & 1 == 1
    }

    /// Adds voxel `index`.
    #[inline]
    pub fn insert(&mut self, index: usize) {
        self.words[index / 64] |= 1 << (index % 64);
    }

    /// The voxels in the set, ascending.
    pub fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        self.words.iter().enumerate().flat_map(|(word_index, &word)| {
            let mut rest = word;
            std::iter::from_fn(move || {
                (rest != 0).then(|| {
                    let bit = rest.trailing_zeros() as usize;
                    rest &= rest - 1;
                    word_index * 64 + bit
                })
            })
        })
    }

    /// Voxels in the set.
    pub fn count(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }
}

/// The dark voxels connected to the volume's faces.
#[derive(Clone, Debug)]
pub struct FaceRegion {
    /// The volume's size in voxels.
    pub dims: [usize; 3],
    /// The level: voxels below it are dark.
    pub level: f64,
    /// The region's voxels.
    pub voxels: VoxelBits,
}

impl FaceRegion {
    /// Fills the face region of `volume` below `level`.
    pub fn find(volume: &Volume, level: f64) -> FaceRegion {
        let dims = volume.dims;
        let body = volume.body_at(level);
        let mut fill = Fill::new(dims, |index| !body.contains(index));
        let [size_x, size_y, size_z] = dims;
        // Seeds: every voxel of the six faces (a filled run is skipped when met again).
        for z in 0..size_z {
            for y in 0..size_y {
                if z == 0 || y == 0 || z + 1 == size_z || y + 1 == size_y {
                    for x in 0..size_x {
                        fill.fill_from(x, y, z);
                    }
                } else {
                    fill.fill_from(0, y, z);
                    fill.fill_from(size_x - 1, y, z);
                }
            }
        }
        FaceRegion { dims, level, voxels: fill.visited }
    }

    /// Whether voxel `index` (x fastest) is in the region.
    pub fn contains(&self, index: usize) -> bool {
        self.voxels.contains(index)
    }
}

/// For each of `voxels`: true when it is dark (below `level`) and joined to a face through
/// dark voxels. Fills from the dark ones only, each fill stopping at the first face it touches.
pub fn reaches_face(volume: &Volume, level: f64, voxels: &[usize]) -> Vec<bool> {
    let dims = volume.dims;
    let body = volume.body_at(level);
    let dark = |index: usize| !body.contains(index);
    let mut fill = Fill::new(dims, dark);
    // Voxels whose fill touched a face, and voxels whose fill was exhausted without one.
    let mut face = VoxelBits::new(volume.voxel_count());
    let mut inside = VoxelBits::new(volume.voxel_count());
    voxels
        .iter()
        .map(|&index| {
            if !(fill.dark)(index) {
                return false;
            }
            if face.contains(index) {
                return true;
            }
            if inside.contains(index) {
                return false;
            }
            let [x, y, z] = coordinates(index, dims);
            let touched = fill.fill_from_until_face(x, y, z, &face);
            let verdict = if touched { &mut face } else { &mut inside };
            for &(start, length) in &fill.runs {
                for index in start..start + length {
                    verdict.insert(index);
                }
            }
            touched
        })
        .collect()
}

fn coordinates(index: usize, dims: [usize; 3]) -> [usize; 3] {
    [index % dims[0], index / dims[0] % dims[1], index / (dims[0] * dims[1])]
}

/// A scanline flood fill over the voxels where `dark` holds.
struct Fill<D: Fn(usize) -> bool> {
    dims: [usize; 3],
    dark: D,
    visited: VoxelBits,
    /// Row segments still to extend: (x, y, z) of a dark voxel, nearest a face first (a
    /// search that stops at the first face goes straight for it; a whole fill visits every
    /// segment anyway).
    stack: BinaryHeap<(Reverse<usize>, [usize; 3])>,
    /// Runs filled by the latest fill: (first index, length).
    runs: Vec<(usize, usize)>,
}

impl<D: Fn(usize) -> bool> Fill<D> {
    fn new(dims: [usize; 3], dark: D) -> Fill<D> {
        Fill {
            dims,
            dark,
            visited: VoxelBits::new(dims[0] * dims[1] * dims[2]),
            stack: BinaryHeap::new(),
            runs: Vec::new(),
        }
    }

    fn index(&self, [x, y, z]: [usize; 3]) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// Fills the dark region around (x, y, z), if that voxel is dark and not yet filled.
    fn fill_from(&mut self, x: usize, y: usize, z: usize) {
        let never = VoxelBits { words: Vec::new() };
        self.fill(x, y, z, &never, false);
    }

    /// Fills from (x, y, z) until a run touches a face or a voxel of `face`; true when one did.
    /// The runs filled are left in `runs`.
    fn fill_from_until_face(&mut self, x: usize, y: usize, z: usize, face: &VoxelBits) -> bool {
        self.fill(x, y, z, face, true)
    }

    fn fill(&mut self, x: usize, y: usize, z: usize, face: &VoxelBits, stop_at_face: bool) -> bool {
        self.runs.clear();
        self.stack.clear();
        self.stack.push((Reverse(0), [x, y, z]));
        let [size_x, size_y, size_z] = self.dims;
        while let Some((_, [x, y, z])) = self.stack.pop() {
            let row_start = self.index([0, y, z]);
            if self.visited.contains(row_start + x) || !(self.dark)(row_start + x) {
                continue;
            }
            let mut first = x;
            while first > 0 && !self.visited.contains(row_start + first - 1) && (self.dark)(row_start + first - 1) {
                first -= 1;
            }
            let mut last = x;
            while last + 1 < size_x && !self.visited.contains(row_start + last + 1) && (self.dark)(row_start + last + 1)
            {
                last += 1;
            }
            for index in row_start + first..=row_start + last {
                self.visited.insert(index);
            }
            if stop_at_face {
                self.runs.push((row_start + first, last - first + 1));
                let on_face =
                    first == 0 || last + 1 == size_x || y == 0 || y + 1 == size_y || z == 0 || z + 1 == size_z;
                let meets_face = !face.words.is_empty()
                    && (first > 0 && face.contains(row_start + first - 1)
                        || last + 1 < size_x && face.contains(row_start + last + 1));
                if on_face || meets_face {
                    return true;
                }
            }
            let neighbours = [(y.wrapping_sub(1), z), (y + 1, z), (y, z.wrapping_sub(1)), (y, z + 1)];
            for (ny, nz) in neighbours {
                if ny >= size_y || nz >= size_z {
                    continue;
                }
                let neighbour_row = self.index([0, ny, nz]);
                // One seed per dark, unfilled segment of the neighbour row under this run.
                let mut in_segment = false;
                for nx in first..=last {
                    let index = neighbour_row + nx;
                    if stop_at_face && !face.words.is_empty() && face.contains(index) {
                        return true;
                    }
                    let open = !self.visited.contains(index) && (self.dark)(index);
                    if open && !in_segment {
                        let to_face = [nx, size_x - 1 - nx, ny, size_y - 1 - ny, nz, size_z - 1 - nz];
                        let priority = if stop_at_face { to_face.into_iter().min().unwrap_or(0) } else { 0 };
                        self.stack.push((Reverse(priority), [nx, ny, nz]));
                    }
                    in_segment = open;
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// A 12 x 10 x 8 volume of air (0) with a box of tissue (100) holding a closed cavity of air
    /// (an enclosed lung) and, when `open`, a channel from the cavity to the air outside.
    fn body(open: bool) -> Volume {
        let dims = [12, 10, 8];
        let mut values = vec![0f32; 12 * 10 * 8];
        for z in 1..7 {
            for y in 1..9 {
                for x in 1..11 {
                    let cavity = (4..8).contains(&x) && (3..7).contains(&y) && (2..6).contains(&z);
                    let channel = open && (1..4).contains(&x) && y == 5 && z == 3;
                    if !cavity && !channel {
                        values[x + 12 * (y + 10 * z)] = 100.0;
                    }
                }
            }
        }
        Volume::from_f32(dims, [1.0; 3], &values, Path::new("body")).unwrap()
    }

    #[test]
    fn the_face_region_is_the_outside_air_and_not_an_enclosed_cavity() {
        let volume = body(false);
        let region = FaceRegion::find(&volume, 50.0);
        let cavity = 4 * 4 * 4;
        let tissue = 10 * 8 * 6 - cavity;
        assert_eq!(region.voxels.count(), volume.voxel_count() - tissue - cavity);
        assert!(!region.contains(volume.index(5, 4, 3)), "the enclosed cavity is not face air");
        assert!(region.contains(volume.index(0, 0, 0)) && region.contains(volume.index(11, 9, 7)));
        assert!(!region.contains(volume.index(2, 2, 2)), "tissue is not dark");
        // A channel joins the cavity to the outside in its axial plane: that plane of the cavity
        // is face air; the planes above and below it, ringed by the tissue, stay inside.
        let open = FaceRegion::find(&body(true), 50.0);
        assert!(open.contains(volume.index(5, 4, 3)));
        assert!(!open.contains(volume.index(5, 4, 2)) && !open.contains(volume.index(5, 4, 4)));
        assert_eq!(open.voxels.count(), region.voxels.count() + 4 * 4 + 3);
    }

    #[test]
    fn reaching_a_face_agrees_with_the_whole_region() {
        for open in [false, true] {
            let volume = body(open);
            let region = FaceRegion::find(&volume, 50.0);
            let every: Vec<usize> = (0..volume.voxel_count()).rev().collect();
            let reached = reaches_face(&volume, 50.0, &every);
            for (&index, &reached) in every.iter().zip(&reached) {
                assert_eq!(reached, region.contains(index), "voxel {index}, open {open}");
            }
        }
    }

    #[test]
    fn a_volume_without_dark_voxels_has_no_face_region() {
        let volume = Volume::from_f32([5, 4, 3], [1.0; 3], &[7.0; 60], Path::new("flat")).unwrap();
        assert_eq!(FaceRegion::find(&volume, 7.0).voxels.count(), 0);
        assert_eq!(FaceRegion::find(&volume, 7.5).voxels.count(), 60);
        assert_eq!(reaches_face(&volume, 7.0, &[0, 30, 59]), vec![false; 3]);
    }
}
