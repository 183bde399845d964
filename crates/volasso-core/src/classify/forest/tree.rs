//! One classification tree of the forest: growth by Gini splits on a bootstrap, the flat node
//! array a walk follows, and the same tree as split masks over its leaves (see `leaf_masks`).

use crate::rng::SplitMix64;
use std::ops::Range;

/// A split as a mask over its tree's leaves numbered left to right: the bits of the leaves of
/// its left subtree are clear, since a vector that goes right cannot reach them.
#[derive(Clone, Copy, Debug)]
pub(super) struct SplitMask {
    pub feature: u32,
    /// Vectors with `vector[feature] <= threshold` go left.
    pub threshold: f32,
    pub mask: u32,
}

impl SplitMask {
    pub const MAX_LEAVES: usize = 32;
}

/// `Node::feature` of a leaf.
const LEAF: u32 = u32::MAX;

/// A split node, or a leaf whose class frequencies start at `left` in `Tree::frequencies`.
#[derive(Clone, Copy, Debug)]
struct Node {
    feature: u32,
    /// Vectors with `vector[feature] <= threshold` go left.
    threshold: f32,
    left: u32,
    right: u32,
}

/// A grown tree: nodes in creation order (the root first) and the leaves' class frequencies
/// (each leaf `class_count` values summing to 1).
#[derive(Clone, Debug)]
pub(super) struct Tree {
    nodes: Vec<Node>,
    frequencies: Vec<f32>,
    class_count: usize,
}

impl Tree {
    pub(super) fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The tree's splits as masks over its leaves numbered left to right, and those leaves'
    /// class frequencies in that order; `None` when it has more leaves than a mask has bits.
    pub(super) fn split_masks(&self) -> Option<(Vec<SplitMask>, Vec<&[f32]>)> {
        let mut leaves = Vec::new();
        let mut masks = Vec::new();
        self.number_leaves(0, &mut leaves, &mut masks);
        if leaves.len() > SplitMask::MAX_LEAVES {
            return None;
        }
        let frequencies = leaves.iter().map(|&node| self.leaf_frequencies_of(node)).collect();
        Some((masks, frequencies))
    }

    /// Appends the leaves under `node` to `leaves` (left to right) and a mask for each split
    /// under it (bits of leaves past [`SplitMask::MAX_LEAVES`] are dropped, and the caller
    /// then discards the masks); returns the range of leaf numbers under `node`.
    fn number_leaves(&self, node: usize, leaves: &mut Vec<usize>, masks: &mut Vec<SplitMask>) -> Range<usize> {
        let Node { feature, threshold, left, right } = self.nodes[node];
        if feature == LEAF {
            leaves.push(node);
            return leaves.len() - 1..leaves.len();
        }
        let left_leaves = self.number_leaves(left as usize, leaves, masks);
        let right_leaves = self.number_leaves(right as usize, leaves, masks);
        let left_bits = left_leaves.clone().filter(|&k| k < SplitMask::MAX_LEAVES).fold(0u32, |bits, k| bits | 1 << k);
        masks.push(SplitMask { feature, threshold, mask: !left_bits });
        left_leaves.start..right_leaves.end
    }

    /// The same tree with each split's threshold `t` on feature `f` replaced by `map(f, t)`.
    pub(super) fn with_thresholds(&self, map: &impl Fn(usize, f32) -> f32) -> Tree {
        let mut tree = self.clone();
        for node in tree.nodes.iter_mut().filter(|node| node.feature != LEAF) {
            node.threshold = map(node.feature as usize, node.threshold);
        }
        tree
    }

    /// The class frequencies of leaf `node`.
    fn leaf_frequencies_of(&self, node: usize) -> &[f32] {
        let start = self.nodes[node].left as usize;
        &self.frequencies[start..start + self.class_count]
    }

    /// The class frequencies of the leaf `vector` falls into (a walk; see `leaf_masks` for
    /// the way small trees are evaluated).
    #[inline]
    pub(super) fn leaf_frequencies(&self, vector: &[f32]) -> &[f32] {
        let mut index = 0;
        while let Node { feature, threshold, left, right } = self.nodes[index]
            && feature != LEAF
        {
            index = if vector[feature as usize] <= threshold { left } else { right } as usize;
        }
        self.leaf_frequencies_of(index)
    }
}

/// What every tree of one forest grows from.
pub(super) struct TreeBuilder<'a> {
    /// Row-major training vectors.
    pub samples: &'a [f32],
    pub dim: usize,
    /// Class position (index into the forest's class ids) of each sample.
    pub classes: &'a [u8],
    pub class_count: usize,
    pub max_depth: usize,
    pub min_samples_split: usize,
    pub features_per_split: usize,
}

/// A node waiting to be split: its slot in `nodes`, its samples' range in the index array,
/// and its depth.
struct Pending {
    node: usize,
    range: std::ops::Range<usize>,
    depth: usize,
}

impl TreeBuilder<'_> {
    /// Grows a tree on the samples `bootstrap` (indices, repeats allowed).
    pub(super) fn grow(&self, mut bootstrap: Vec<u32>, rng: &mut SplitMix64) -> Tree {
        let mut tree = Tree { nodes: Vec::new(), frequencies: Vec::new(), class_count: self.class_count };
        let mut features: Vec<usize> = (0..self.dim).collect();
        let mut sorted: Vec<(f32, u8)> = Vec::with_capacity(bootstrap.len());
        tree.nodes.push(Node { feature: LEAF, threshold: 0.0, left: 0, right: 0 });
        let mut stack = vec![Pending { node: 0, range: 0..bootstrap.len(), depth: 0 }];
        while let Some(Pending { node, range, depth }) = stack.pop() {
            let counts = self.class_counts(&bootstrap[range.clone()]);
            let pure = counts.iter().filter(|&&c| c > 0).count() <= 1;
            let split = if pure || depth >= self.max_depth || range.len() < self.min_samples_split {
                None
            } else {
                rng.partial_shuffle(&mut features, self.features_per_split);
                self.best_split(&bootstrap[range.clone()], &features[..self.features_per_split], &counts, &mut sorted)
            };
            let Some((feature, threshold)) = split else {
                tree.nodes[node] =
                    Node { feature: LEAF, threshold: 0.0, left: tree.frequencies.len() as u32, right: 0 };
                let total = range.len().max(1) as f32;
                tree.frequencies.extend(counts.iter().map(|&c| c as f32 / total));
                continue;
            };
            // Partition the node's samples in place: left part first.
            let slice = &mut bootstrap[range.clone()];
            let mut boundary = 0;
            for k in 0..slice.len() {
                if self.value(slice[k], feature) <= threshold {
                    slice.swap(k, boundary);
                    boundary += 1;
                }
            }
            let (left, right) = (tree.nodes.len(), tree.nodes.len() + 1);
            tree.nodes[node] = Node { feature: feature as u32, threshold, left: left as u32, right: right as u32 };
            tree.nodes.push(Node { feature: LEAF, threshold: 0.0, left: 0, right: 0 });
            tree.nodes.push(Node { feature: LEAF, threshold: 0.0, left: 0, right: 0 });
            let middle = range.start + boundary;
            stack.push(Pending { node: right, range: middle..range.end, depth: depth + 1 });
            stack.push(Pending { node: left, range: range.start..middle, depth: depth + 1 });
        }
        tree
    }

    #[inline]
    fn value(&self, sample: u32, feature: usize) -> f32 {
        self.samples[sample as usize * self.dim + feature]
    }

    fn class_counts(&self, samples: &[u32]) -> Vec<usize> {
        let mut counts = vec![0; self.class_count];
        for &sample in samples {
            counts[self.classes[sample as usize] as usize] += 1;
        }
        counts
    }

    /// The (feature, threshold) among `features` whose split of `samples` leaves the smallest
    /// weighted Gini impurity; `None` when no feature takes two distinct values here.
    /// Thresholds lie halfway between neighbouring distinct values.
    fn best_split(
        &self,
        samples: &[u32],
        features: &[usize],
        counts: &[usize],
        sorted: &mut Vec<(f32, u8)>,
    ) -> Option<(usize, f32)> {
        let total = samples.len() as f64;
        // Maximising sum over children of sum_k n_k^2 / n minimises the weighted Gini.
        let mut best: Option<(f64, usize, f32)> = None;
        let mut left_counts = vec![0usize; self.class_count];
        for &feature in features {
            sorted.clear();
            sorted.extend(samples.iter().map(|&s| (self.value(s, feature), self.classes[s as usize])));
            sorted.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
            if sorted[0].0 == sorted[sorted.len() - 1].0 {
                continue;
            }
            left_counts.fill(0);
            let (mut left_squares, mut right_squares) = (0f64, counts.iter().map(|&c| (c * c) as f64).sum::<f64>());
            for k in 0..sorted.len() - 1 {
                let class = sorted[k].1 as usize;
                // Moving one sample of `class` from right to left changes the squares by
                // (l+1)^2 - l^2 and (r-1)^2 - r^2.
                let left_before = left_counts[class] as f64;
                let right_before = (counts[class] - left_counts[class]) as f64;
                left_squares += 2.0 * left_before + 1.0;
                right_squares -= 2.0 * right_before - 1.0;
                left_counts[class] += 1;
                if sorted[k].0 == sorted[k + 1].0 {
                    continue;
                }
                let left_size = (k + 1) as f64;
                let score = left_squares / left_size + right_squares / (total - left_size);
                if best.is_none_or(|(b, _, _)| score > b) {
                    let threshold = sorted[k].0 + 0.5 * (sorted[k + 1].0 - sorted[k].0);
                    // Halfway can round up to the larger value; the smaller one then splits.
                    let threshold = if threshold < sorted[k + 1].0 { threshold } else { sorted[k].0 };
                    best = Some((score, feature, threshold));
                }
            }
        }
        best.map(|(_, feature, threshold)| (feature, threshold))
    }
}
