//! The face region, the air around a body: the voxels below a level and outside the body's
//! outline ([`Volume::body_at`]), each joined to a face within its axial slice. What the body
//! rings in a slice (lungs, sinuses) is not in it, even at a face
//! (`docs/decisions/0008-background.md`).
//!
//! Never: decides what is background (that is `super::background`'s rule), or reads files.

use crate::volume::Volume;

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
    /// The face region of `volume` below `level`: the outside of its body at that level.
    pub fn find(volume: &Volume, level: f64) -> FaceRegion {
        let body = volume.body_at(level);
        FaceRegion { dims: volume.dims, level, voxels: VoxelBits { words: body.outside_words() } }
    }

    /// Whether voxel `index` (x fastest) is in the region.
    pub fn contains(&self, index: usize) -> bool {
        self.voxels.contains(index)
    }
}

/// For each of `voxels`: whether it is in the face region at `level` (below it, outside the body).
pub fn reaches_face(volume: &Volume, level: f64, voxels: &[usize]) -> Vec<bool> {
    let body = volume.body_at(level);
    voxels.iter().map(|&index| !body.contains(index)).collect()
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
