//! The leaves of a group of vectors in every small tree at once, without walking the trees
//! (QuickScorer: Lucchese et al., SIGIR 2015).
//!
//! Number a tree's leaves left to right. A vector that goes right at a split cannot reach any
//! leaf of that split's left subtree, so each split clears those bits of a mask; after every
//! split has been tested, the lowest set bit is the vector's leaf (the leftmost leaf whose
//! path contradicts no test). The tests are independent of each other, so [`LANES`] vectors
//! are tested side by side, four per SSE2 instruction. A walk, by contrast, branches on every
//! node, unpredictably: on the small trees of the forests here (about 10 to 25 nodes) the
//! masks take less than half a walk's time (`docs/decisions/0016-random-forest.md`).
//!
//! The leaves' class frequencies are then added tree by tree, eight vectors side by side so
//! that their sums do not wait on each other. Trees with more leaves than a mask holds are
//! walked node by node, and a forest with any of them adds its votes one vector and tree at a
//! time.

use super::tree::{SplitMask, Tree};

/// Vectors tested side by side.
pub(super) const LANES: usize = 16;
/// Vectors whose leaf sums [`LeafMasks::sum_leaves`] adds side by side (8 sums of 4 or 8 classes
/// fill 8 or 16 SSE registers).
const SUM_GROUP: usize = 8;

/// A split of tree `tree` as a mask ([`SplitMask`]).
#[derive(Clone, Copy, Debug)]
struct TreeSplit {
    threshold: f32,
    feature: u32,
    tree: u32,
    mask: u32,
}

/// The forest's small trees as masked splits, and their leaves' frequencies.
#[derive(Clone, Debug)]
pub(super) struct LeafMasks {
    /// Every split of every masked tree, grouped by tree.
    splits: Vec<TreeSplit>,
    /// Per tree: where its first leaf's frequencies start in `frequencies`, or `None` when the
    /// tree is walked.
    first_leaf: Vec<Option<usize>>,
    /// `first_leaf` when every tree is masked.
    every_first_leaf: Option<Vec<usize>>,
    /// Leaf frequencies of the masked trees, left to right, `stride` values per leaf (the
    /// classes' then zeros).
    frequencies: Vec<f32>,
    class_count: usize,
    /// `class_count` rounded up to a whole number of 4-lane vectors.
    stride: usize,
}

/// Per-call scratch of [`LeafMasks::add_votes`].
#[derive(Default)]
pub(super) struct Scratch {
    /// Feature-major copy of the group: `columns[feature][lane]`.
    columns: Vec<[f32; LANES]>,
    /// The leaves still possible per tree and lane.
    alive: Vec<[u32; LANES]>,
}

impl LeafMasks {
    pub(super) fn new(trees: &[Tree], class_count: usize) -> LeafMasks {
        let stride = class_count.next_multiple_of(4);
        let mut masks = LeafMasks {
            splits: Vec::new(),
            first_leaf: Vec::new(),
            every_first_leaf: None,
            frequencies: Vec::new(),
            class_count,
            stride,
        };
        for (index, tree) in trees.iter().enumerate() {
            let Some((splits, leaves)) = tree.split_masks() else {
                masks.first_leaf.push(None);
                continue;
            };
            masks.first_leaf.push(Some(masks.frequencies.len()));
            masks.splits.extend(splits.iter().map(|&SplitMask { feature, threshold, mask }| TreeSplit {
                threshold,
                feature,
                tree: index as u32,
                mask,
            }));
            for leaf in leaves {
                masks.frequencies.extend_from_slice(leaf);
                masks.frequencies.resize(masks.frequencies.len() + stride - leaf.len(), 0.0);
            }
        }
        masks.every_first_leaf = masks.first_leaf.iter().copied().collect();
        masks
    }

    /// Adds every tree's leaf frequencies, tree by tree in order, to the `class_count` votes of
    /// each of `vectors` (row-major, `dim` values each, 1 to [`LANES`] vectors) in `votes`.
    pub(super) fn add_votes(
        &self,
        trees: &[Tree],
        vectors: &[f32],
        dim: usize,
        votes: &mut [f32],
        scratch: &mut Scratch,
    ) {
        let count = (vectors.len() / dim).clamp(1, LANES);
        // Missing lanes repeat the last vector; their leaves are not used.
        scratch.columns.clear();
        scratch
            .columns
            .extend((0..dim).map(|feature| std::array::from_fn(|lane| vectors[lane.min(count - 1) * dim + feature])));
        scratch.alive.clear();
        scratch.alive.resize(trees.len(), [u32::MAX; LANES]);
        for split in &self.splits {
            let values = &scratch.columns[split.feature as usize];
            let alive = &mut scratch.alive[split.tree as usize];
            clear_unreachable(alive, values, split.threshold, split.mask);
        }
        match (&self.every_first_leaf, self.stride) {
            (Some(first_leaves), 4) => self.sum_leaves::<4>(first_leaves, votes, &scratch.alive),
            (Some(first_leaves), 8) => self.sum_leaves::<8>(first_leaves, votes, &scratch.alive),
            _ => self.sum_leaves_any(trees, vectors, dim, votes, &scratch.alive),
        }
    }

    /// Adds each vector's leaf frequencies over the trees, in tree order, into sums held in
    /// registers, for forests whose trees are all masked. [`SUM_GROUP`] vectors go through the
    /// trees together: one vector's sum would wait for its previous addition at every tree,
    /// independent sums overlap. A group always adds all its lanes (missing vectors repeat the
    /// last one) and calls nothing, so that its loops unroll and its sums stay in registers.
    fn sum_leaves<const STRIDE: usize>(&self, first_leaves: &[usize], votes: &mut [f32], alive: &[[u32; LANES]]) {
        let class_count = self.class_count;
        let count = votes.len() / class_count;
        for first_lane in (0..count).step_by(SUM_GROUP) {
            let mut sums = [[0f32; STRIDE]; SUM_GROUP];
            for (&first, alive) in first_leaves.iter().zip(alive) {
                let Some(alive) = alive[first_lane..].first_chunk::<SUM_GROUP>() else { continue };
                for (sums, &leaves) in sums.iter_mut().zip(alive) {
                    // Always found (the lowest bit left is a leaf of the tree, see the module
                    // doc); a miss would add nothing rather than fail.
                    let frequencies = match self.leaf(first, leaves).and_then(<[f32]>::first_chunk::<STRIDE>) {
                        Some(chunk) => *chunk,
                        None => [0.0; STRIDE],
                    };
                    for (sum, frequency) in sums.iter_mut().zip(frequencies) {
                        *sum += frequency;
                    }
                }
            }
            let group_votes = votes[first_lane * class_count..].chunks_exact_mut(class_count);
            for (voxel_votes, sums) in group_votes.zip(&sums) {
                for (vote, sum) in voxel_votes.iter_mut().zip(sums) {
                    *vote += sum;
                }
            }
        }
    }

    /// [`Self::sum_leaves`] for any number of classes.
    fn sum_leaves_any(&self, trees: &[Tree], vectors: &[f32], dim: usize, votes: &mut [f32], alive: &[[u32; LANES]]) {
        let class_count = self.class_count;
        for ((tree, first_leaf), alive) in trees.iter().zip(&self.first_leaf).zip(alive) {
            let lanes = vectors.chunks_exact(dim).zip(votes.chunks_exact_mut(class_count)).zip(alive);
            for ((vector, voxel_votes), &leaves) in lanes {
                // A masked tree's leaf is always found; the walk would give the same one.
                let frequencies = match first_leaf.and_then(|first| self.leaf(first, leaves)) {
                    Some(frequencies) => &frequencies[..class_count],
                    None => tree.leaf_frequencies(vector),
                };
                for (vote, &frequency) in voxel_votes.iter_mut().zip(frequencies) {
                    *vote += frequency;
                }
            }
        }
    }

    /// The frequencies (padded to `stride`) of the leaf left in `leaves` of the tree whose
    /// first leaf starts at `first` (`None` only for a mask that names no leaf, which the
    /// split tests never leave).
    #[inline(always)]
    fn leaf(&self, first: usize, leaves: u32) -> Option<&[f32]> {
        let start = first + leaves.trailing_zeros() as usize * self.stride;
        self.frequencies.get(start..start + self.stride)
    }
}

/// `alive &= mask` in the lanes whose value goes right at a split of `threshold` (not
/// `value <= threshold`: NaN goes right), in SSE2 instructions, which every x86-64 CPU has
/// (the compiler leaves this loop scalar and branching).
#[cfg(target_arch = "x86_64")]
#[inline]
fn clear_unreachable(alive: &mut [u32; LANES], values: &[f32; LANES], threshold: f32, mask: u32) {
    use std::arch::x86_64::{
        __m128i, _mm_and_si128, _mm_castps_si128, _mm_cmple_ps, _mm_loadu_ps, _mm_loadu_si128, _mm_or_si128,
        _mm_set1_epi32, _mm_set1_ps, _mm_storeu_si128,
    };
    // SAFETY: SSE2 is part of the x86-64 baseline, so these instructions exist on every CPU
    // this code is compiled for; each chunk holds exactly four 4-byte values, what the
    // unaligned 128-bit load and store read and write.
    unsafe {
        let threshold = _mm_set1_ps(threshold);
        let mask = _mm_set1_epi32(mask as i32);
        for (alive, values) in alive.chunks_exact_mut(4).zip(values.chunks_exact(4)) {
            let goes_left = _mm_castps_si128(_mm_cmple_ps(_mm_loadu_ps(values.as_ptr()), threshold));
            let kept = _mm_or_si128(mask, goes_left);
            let pointer = alive.as_mut_ptr().cast::<__m128i>();
            _mm_storeu_si128(pointer, _mm_and_si128(_mm_loadu_si128(pointer), kept));
        }
    }
}

/// The portable form of the SSE2 loop.
#[cfg(any(test, not(target_arch = "x86_64")))]
fn clear_unreachable_portable(alive: &mut [u32; LANES], values: &[f32; LANES], threshold: f32, mask: u32) {
    for (alive, &value) in alive.iter_mut().zip(values) {
        // Left where value <= threshold; NaN compares as neither, and goes right.
        if value > threshold || value.is_nan() {
            *alive &= mask;
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
use clear_unreachable_portable as clear_unreachable;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sse2_loop_clears_what_the_portable_one_clears() {
        let values: [f32; LANES] = std::array::from_fn(|lane| match lane {
            3 => f32::NAN,
            5 => f32::INFINITY,
            6 => f32::NEG_INFINITY,
            7 => 0.5,
            _ => lane as f32 * 0.25 - 1.0,
        });
        for threshold in [-1.0, 0.0, 0.5, 2.0] {
            let (mut fast, mut portable) = ([0xFFFF_FFF0u32; LANES], [0xFFFF_FFF0u32; LANES]);
            clear_unreachable(&mut fast, &values, threshold, 0x0000_FF0F);
            clear_unreachable_portable(&mut portable, &values, threshold, 0x0000_FF0F);
            assert_eq!(fast, portable, "threshold {threshold}");
            assert_eq!(portable[3], 0x0000_FF00, "NaN goes right");
            assert_eq!(portable[7] == 0xFFFF_FFF0, threshold >= 0.5, "equal goes left");
        }
    }
}
