//! Empty-space skipping: the volume cut into bricks of [`BRICK_SIZE_VOXELS`]^3 voxels, each
//! marked occupied when a sample inside it could be visible. The shader jumps over
//! unoccupied bricks to the next sample position past them (`raycast.wgsl`, the ray loop).
//!
//! A sample inside brick b interpolates voxels 8b - 1 ..= 8b + 8 along each axis (trilinear
//! filtering, or the eight labels around it), so each brick looks at its voxels plus a
//! one-voxel apron; skipping is then exact: it never changes a pixel.
//!
//! Pre-classified data: occupied when any voxel of the brick and apron has alpha > 0.
//! Post-classified data: each brick keeps the set of labels in it and its apron (256 bits), so
//! changing class visibility only re-derives occupancy from the sets, without reading the
//! labels again.
//!
//! Never: reads a volume twice, or runs on the GPU.

use super::uniforms::CLASS_TABLE_SIZE;

/// Voxels along each edge of a brick. WGSL twin: `BRICK_SIZE_VOXELS`.
pub const BRICK_SIZE_VOXELS: usize = 8;

/// Bricks along x, y, z for a volume of `dims` voxels (partial bricks at the far faces).
pub fn brick_dims(dims: [usize; 3]) -> [usize; 3] {
    dims.map(|d| d.div_ceil(BRICK_SIZE_VOXELS).max(1))
}

/// The bricks along one axis whose region-plus-apron holds voxel `v`.
fn bricks_touching(v: usize, brick_count: usize) -> std::ops::RangeInclusive<usize> {
    let first = v.saturating_sub(1) / BRICK_SIZE_VOXELS;
    let last = ((v + 1) / BRICK_SIZE_VOXELS).min(brick_count - 1);
    first..=last
}

/// Calls `mark(brick_index)` for every brick whose region or apron holds voxel (x, y, z).
fn for_each_touched_brick(voxel: [usize; 3], bricks: [usize; 3], mut mark: impl FnMut(usize)) {
    for bz in bricks_touching(voxel[2], bricks[2]) {
        for by in bricks_touching(voxel[1], bricks[1]) {
            for bx in bricks_touching(voxel[0], bricks[0]) {
                mark(bx + bricks[0] * (by + bricks[1] * bz));
            }
        }
    }
}

/// Visits every voxel (x fastest) whose value, read by `value_at(index)`, is content.
fn for_each_content_voxel<T: Copy>(
    dims: [usize; 3],
    value_at: impl Fn(usize) -> T,
    is_content: impl Fn(T) -> bool,
    mut visit: impl FnMut([usize; 3], T),
) {
    let mut index = 0;
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let value = value_at(index);
                if is_content(value) {
                    visit([x, y, z], value);
                }
                index += 1;
            }
        }
    }
}

/// Occupancy (1 or 0 per brick, x fastest) of a straight-alpha RGBA8 volume.
pub fn rgba_occupancy(dims: [usize; 3], rgba: &[u8]) -> Vec<u8> {
    let bricks = brick_dims(dims);
    let mut occupied = vec![0u8; bricks.iter().product()];
    for_each_content_voxel(
        dims,
        |index| rgba[4 * index + 3],
        |alpha| alpha > 0,
        |voxel, _| for_each_touched_brick(voxel, bricks, |b| occupied[b] = 1),
    );
    occupied
}

/// For each brick, the set of labels found in it or its apron.
#[derive(Clone, Debug, PartialEq)]
pub struct LabelBricks {
    /// Bricks along x, y and z (see [`brick_dims`]).
    pub brick_dims: [usize; 3],
    /// 256 bits per brick: bit k of word k / 32 is set when label k occurs.
    label_sets: Vec<[u32; CLASS_TABLE_SIZE / 32]>,
}

impl LabelBricks {
    /// One pass over `labels` (x fastest, `dims` voxels); background (0) is not recorded.
    pub fn new(dims: [usize; 3], labels: &[u8]) -> LabelBricks {
        let brick_dims = brick_dims(dims);
        let mut label_sets = vec![[0u32; CLASS_TABLE_SIZE / 32]; brick_dims.iter().product()];
        for_each_content_voxel(
            dims,
            |index| labels[index],
            |label| label != 0,
            |voxel, label| {
                let (word, bit) = (label as usize / 32, label as u32 % 32);
                for_each_touched_brick(voxel, brick_dims, |b| label_sets[b][word] |= 1 << bit);
            },
        );
        LabelBricks { brick_dims, label_sets }
    }

    /// Occupancy (1 or 0 per brick) when the labels marked in `visible` can be seen.
    pub fn occupancy(&self, visible: &[bool; CLASS_TABLE_SIZE]) -> Vec<u8> {
        let mut mask = [0u32; CLASS_TABLE_SIZE / 32];
        for (label, _) in visible.iter().enumerate().filter(|(_, v)| **v) {
            mask[label / 32] |= 1 << (label % 32);
        }
        self.label_sets.iter().map(|set| set.iter().zip(&mask).any(|(s, m)| s & m != 0) as u8).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The definition, brute force: every brick's voxels and apron, scanned.
    fn occupied_by_scanning(dims: [usize; 3], content: &dyn Fn(usize) -> bool) -> Vec<u8> {
        let bricks = brick_dims(dims);
        let mut out = Vec::new();
        for bz in 0..bricks[2] {
            for by in 0..bricks[1] {
                for bx in 0..bricks[0] {
                    let range = |b: usize, axis: usize| {
                        (b * BRICK_SIZE_VOXELS).saturating_sub(1)..((b + 1) * BRICK_SIZE_VOXELS + 1).min(dims[axis])
                    };
                    let mut any = false;
                    for z in range(bz, 2) {
                        for y in range(by, 1) {
                            for x in range(bx, 0) {
                                any |= content(x + dims[0] * (y + dims[1] * z));
                            }
                        }
                    }
                    out.push(any as u8);
                }
            }
        }
        out
    }

    #[test]
    fn brick_counts_round_up() {
        assert_eq!(brick_dims([64, 65, 1]), [8, 9, 1]);
    }

    #[test]
    fn single_voxels_mark_their_brick_and_the_neighbours_whose_apron_they_are() {
        let dims = [20, 17, 9];
        for voxel in [[0, 0, 0], [7, 8, 3], [8, 7, 0], [15, 16, 8], [19, 0, 4], [5, 9, 7]] {
            let mut labels = vec![0u8; dims.iter().product()];
            let index = voxel[0] + dims[0] * (voxel[1] + dims[1] * voxel[2]);
            labels[index] = 3;
            let expected = occupied_by_scanning(dims, &|i| labels[i] != 0);
            let bricks = LabelBricks::new(dims, &labels);
            let mut visible = [false; CLASS_TABLE_SIZE];
            visible[3] = true;
            assert_eq!(bricks.occupancy(&visible), expected, "voxel {voxel:?}");
            visible[3] = false;
            assert!(bricks.occupancy(&visible).iter().all(|o| *o == 0), "label 3 hidden");
            let mut rgba = vec![0u8; 4 * labels.len()];
            rgba[4 * index + 3] = 1;
            assert_eq!(rgba_occupancy(dims, &rgba), expected, "voxel {voxel:?}");
        }
    }

    #[test]
    fn occupancy_follows_visibility_per_label() {
        let dims = [32, 8, 8];
        let labels: Vec<u8> = (0..dims.iter().product::<usize>()).map(|i| if i % 32 < 8 { 1 } else { 200 }).collect();
        let bricks = LabelBricks::new(dims, &labels);
        let mut visible = [false; CLASS_TABLE_SIZE];
        visible[1] = true;
        assert_eq!(bricks.occupancy(&visible), vec![1, 1, 0, 0], "label 1 fills x 0..8 and the apron of brick 1");
        visible[200] = true;
        assert_eq!(bricks.occupancy(&visible), vec![1, 1, 1, 1]);
    }
}
