//! A random forest of classification trees (Breiman 2001), the second classifier beside the
//! SN-SVM: it extrapolates in intensity as a constant (a voxel brighter than every
//! lassoed voxel goes with the brightest training voxels, not with whichever class the RBF
//! kernel happens to decay towards), needs no kernel width, and is cheap to train.
//!
//! Each tree grows on a class-balanced bootstrap of the training vectors (every class drawn
//! equally often, so a class with few lassoed voxels is not outvoted), splits on the best Gini
//! threshold among `features_per_split` randomly chosen features, and stores the class
//! frequencies of its leaves. The forest averages the leaves' frequencies over trees (soft
//! voting) and takes the largest; ties go to the smaller class id.
//!
//! Prediction tests every split of a small tree at once, for 16 vectors side by side, as masks
//! over its leaves (`leaf_masks`; trees of the default depth on lasso-sized training sets have
//! 10 to 25 nodes); a tree with more than 32 leaves is walked.
//!
//! Entry points: [`ForestParams::check`], [`Forest::train`], [`Forest::predict_block`].
//! Deterministic: tree t draws from `SplitMix64::new(hash64(seed, t))`, so the thread schedule
//! cannot change a bit. Trees train in parallel (rayon).
//!
//! Never: reads volumes, computes or standardises features, or decides which voxels to
//! classify.

mod leaf_masks;
#[cfg(test)]
mod tests;
mod tree;

use super::ClassifyError;
use crate::rng::{SplitMix64, hash64};
use leaf_masks::{LANES, LeafMasks};
use rayon::prelude::*;
use tree::{Tree, TreeBuilder};

/// Hyper-parameters of a random forest. `Default` is the setting chosen by the accuracy
/// harness (`volasso accuracy`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ForestParams {
    /// Number of trees grown.
    pub tree_count: usize,
    /// Nodes deeper than this become leaves (the root is depth 0).
    pub max_depth: usize,
    /// A node with fewer bootstrap samples than this becomes a leaf.
    pub min_samples_split: usize,
    /// Features tried at each split; `None` is round(sqrt(dim)) (Breiman's default).
    pub features_per_split: Option<usize>,
    /// Draw every class equally often in the bootstraps.
    pub class_balanced: bool,
    /// Seed of the bootstrap and feature draws; the same seed grows the same forest.
    pub seed: u64,
}

impl Default for ForestParams {
    fn default() -> Self {
        ForestParams {
            // 16 trees of depth 10 score as more and deeper trees on the accuracy harness's
            // tuning cases and predict faster (docs/decisions/0016-random-forest.md).
            tree_count: 16,
            max_depth: 10,
            min_samples_split: 2,
            features_per_split: None,
            class_balanced: true,
            seed: 0xF0_2E57,
        }
    }
}

impl ForestParams {
    /// Checks every value once, before any work, and names the first bad one.
    pub fn check(self) -> Result<ForestParams, ClassifyError> {
        let invalid = |name, value: usize, requirement| {
            Err(ClassifyError::InvalidParameter { name, value: value as f64, requirement })
        };
        if self.tree_count == 0 || self.tree_count > 4096 {
            return invalid("tree count", self.tree_count, "an integer from 1 to 4096");
        }
        if self.max_depth > 64 {
            return invalid("max depth", self.max_depth, "an integer from 0 to 64");
        }
        if self.min_samples_split < 2 {
            return invalid("min samples per split", self.min_samples_split, "an integer >= 2");
        }
        if self.features_per_split == Some(0) {
            return invalid("features per split", 0, "an integer >= 1");
        }
        Ok(self)
    }
}

/// A trained random forest. `Send + Sync`: prediction only reads it.
#[derive(Clone, Debug)]
pub struct Forest {
    dim: usize,
    /// Sorted class ids; leaf frequencies index into this.
    class_ids: Vec<u8>,
    trees: Vec<Tree>,
    /// The same trees as split masks, for prediction.
    leaf_masks: LeafMasks,
}

impl Forest {
    /// Trains on `samples` (row-major, `labels.len() x dim`) with labels from `class_ids`.
    /// Fails on ragged or empty samples, a label outside `class_ids`, or a class without
    /// samples.
    pub fn train(
        samples: &[f32],
        dim: usize,
        labels: &[u8],
        class_ids: &[u8],
        params: &ForestParams,
    ) -> Result<Forest, ClassifyError> {
        let params = params.check()?;
        if dim == 0 {
            return Err(ClassifyError::ZeroDimension);
        }
        if samples.len() % dim != 0 {
            return Err(ClassifyError::RaggedSamples { values: samples.len(), dim });
        }
        if samples.len() / dim != labels.len() {
            return Err(ClassifyError::LabelCount { labels: labels.len(), samples: samples.len() / dim });
        }
        if let Some(position) = samples.iter().position(|v| !v.is_finite()) {
            return Err(ClassifyError::NonFiniteSample {
                sample: position / dim,
                feature: position % dim,
                value: samples[position] as f64,
            });
        }
        let mut class_ids = class_ids.to_vec();
        class_ids.sort_unstable();
        class_ids.dedup();
        if class_ids.contains(&0) {
            return Err(ClassifyError::BackgroundClass);
        }
        let mut positions = Vec::with_capacity(labels.len());
        for (sample, &label) in labels.iter().enumerate() {
            match class_ids.binary_search(&label) {
                Ok(position) => positions.push(position as u8),
                Err(_) => return Err(ClassifyError::UnknownLabel { sample, label, class_ids }),
            }
        }
        let mut by_class: Vec<Vec<u32>> = vec![Vec::new(); class_ids.len()];
        for (sample, &position) in positions.iter().enumerate() {
            by_class[position as usize].push(sample as u32);
        }
        if let Some(position) = by_class.iter().position(Vec::is_empty) {
            return Err(ClassifyError::EmptyClass { class_id: class_ids[position] });
        }
        if class_ids.len() < 2 {
            return Err(ClassifyError::TooFewClasses { found: class_ids.len(), class_ids });
        }
        let features_per_split =
            params.features_per_split.unwrap_or(((dim as f64).sqrt().round() as usize).max(1)).min(dim);
        let builder = TreeBuilder {
            samples,
            dim,
            classes: &positions,
            class_count: class_ids.len(),
            max_depth: params.max_depth,
            min_samples_split: params.min_samples_split,
            features_per_split,
        };
        let trees: Vec<Tree> = (0..params.tree_count)
            .into_par_iter()
            .map(|t| {
                let mut rng = SplitMix64::new(hash64(params.seed, t as u64));
                let bootstrap = draw_bootstrap(&by_class, labels.len(), params.class_balanced, &mut rng);
                builder.grow(bootstrap, &mut rng)
            })
            .collect();
        let leaf_masks = LeafMasks::new(&trees, class_ids.len());
        Ok(Forest { dim, class_ids, trees, leaf_masks })
    }

    /// Feature dimension the forest was trained on.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The same forest for inputs in other units: every split's threshold `t` on feature `f`
    /// becomes `map(f, t)`. With `map` the exact preimage of a non-decreasing map of the inputs
    /// (`Standardiser::raw_threshold`), the new forest labels raw vectors as this one labels
    /// mapped vectors, bit for bit.
    pub fn with_thresholds(&self, map: impl Fn(usize, f32) -> f32) -> Forest {
        let trees: Vec<Tree> = self.trees.iter().map(|tree| tree.with_thresholds(&map)).collect();
        let leaf_masks = LeafMasks::new(&trees, self.class_ids.len());
        Forest { dim: self.dim, class_ids: self.class_ids.clone(), trees, leaf_masks }
    }

    /// The classes it votes among, sorted ascending.
    pub fn class_ids(&self) -> &[u8] {
        &self.class_ids
    }

    /// Number of trees.
    pub fn tree_count(&self) -> usize {
        self.trees.len()
    }

    /// Nodes over all trees (leaves included).
    pub fn node_count(&self) -> usize {
        self.trees.iter().map(Tree::node_count).sum()
    }

    /// Class ids of `features` (row-major, `out.len() x dim`), into `out`.
    pub fn predict_block(&self, features: &[f32], out: &mut [u8]) -> Result<(), ClassifyError> {
        check_block(features, self.dim, out.len())?;
        let class_count = self.class_ids.len();
        // A group of lanes at a time through every tree (see `leaf_masks`).
        const CHUNK: usize = 256;
        let mut votes = vec![0f32; CHUNK * class_count];
        let mut scratch = leaf_masks::Scratch::default();
        for (chunk_features, chunk_out) in features.chunks(CHUNK * self.dim).zip(out.chunks_mut(CHUNK)) {
            let votes = &mut votes[..chunk_out.len() * class_count];
            self.add_votes(chunk_features, votes, &mut scratch);
            for (label, voxel_votes) in chunk_out.iter_mut().zip(votes.chunks_exact(class_count)) {
                let mut best = 0;
                for (k, &vote) in voxel_votes.iter().enumerate() {
                    if vote > voxel_votes[best] {
                        best = k;
                    }
                }
                *label = self.class_ids[best];
            }
        }
        Ok(())
    }

    /// Each vector's votes (row-major, `votes.len() / class_ids().len()` vectors, one value
    /// per class in [`class_ids`](Self::class_ids) order): the trees' leaf frequencies summed,
    /// so a vector's votes add up to the number of trees.
    pub fn votes_block(&self, features: &[f32], votes: &mut [f32]) -> Result<(), ClassifyError> {
        let class_count = self.class_ids.len();
        check_block(features, self.dim, votes.len() / class_count.max(1))?;
        self.add_votes(features, votes, &mut leaf_masks::Scratch::default());
        Ok(())
    }

    fn add_votes(&self, features: &[f32], votes: &mut [f32], scratch: &mut leaf_masks::Scratch) {
        let class_count = self.class_ids.len();
        votes.fill(0.0);
        for (vectors, group_votes) in features.chunks(LANES * self.dim).zip(votes.chunks_mut(LANES * class_count)) {
            self.leaf_masks.add_votes(&self.trees, vectors, self.dim, group_votes, scratch);
        }
    }

    /// [`predict_block`](Self::predict_block) split over threads.
    pub fn predict_block_parallel(&self, features: &[f32], out: &mut [u8]) -> Result<(), ClassifyError> {
        check_block(features, self.dim, out.len())?;
        out.par_chunks_mut(4096)
            .zip(features.par_chunks(4096 * self.dim))
            .try_for_each(|(out, features)| self.predict_block(features, out))
    }
}

fn check_block(features: &[f32], dim: usize, out_len: usize) -> Result<(), ClassifyError> {
    if features.len() % dim != 0 {
        return Err(ClassifyError::FeatureBlockShape { values: features.len(), dim });
    }
    if features.len() / dim != out_len {
        return Err(ClassifyError::OutputBlockShape { expected: features.len() / dim, found: out_len });
    }
    Ok(())
}

/// Sample indices of one tree's bootstrap: `count` draws with replacement, each from a
/// uniformly chosen class when `class_balanced`, else uniformly from all samples.
fn draw_bootstrap(by_class: &[Vec<u32>], count: usize, class_balanced: bool, rng: &mut SplitMix64) -> Vec<u32> {
    (0..count)
        .map(|_| {
            if class_balanced {
                let class = &by_class[rng.below(by_class.len() as u64) as usize];
                class[rng.below(class.len() as u64) as usize]
            } else {
                rng.below(count as u64) as u32
            }
        })
        .collect()
}
