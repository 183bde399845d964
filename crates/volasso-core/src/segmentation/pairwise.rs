//! One-vs-one SN-SVM with each pair of classes z-scored on its own two classes, as the paper's
//! code trains it (snsvm.md §11), so close classes stay apart beside a far one
//! (`docs/decisions/0002-per-pair-standardisation.md`). Each pair's automatic RBF width comes
//! from its own distances ([`super::median_heuristic_width`]); the vote is
//! [`crate::classify::Model`]'s. The [`IntensityGate`] decides first: a voxel that one class's
//! band alone allows is that class, and only the pairs of allowed classes vote on the rest.
//!
//! Never: chooses the training voxels, or the background.

use super::gate::{Band, ClassSet, IntensityGate};
use super::{KernelWidth, SegmentationError, median_heuristic_width};
use crate::classify::{self, Kernel, Model, SampleMatrix, SnSvmParams, TrainReport};
use crate::features::{Scaling, Standardiser};
use rayon::prelude::*;

/// One pair's SN-SVM on its own standardisation.
pub struct PairSnSvm {
    /// The pair's classes; a positive decision value votes for the first.
    pub classes: (u8, u8),
    /// Mean and spread of the pair's training features, applied before the model.
    pub standardiser: Standardiser,
    /// The trained SN-SVM.
    pub model: Model,
    /// The pair's parameters as trained (its RBF width filled in).
    pub params: SnSvmParams,
}

/// SN-SVMs for every pair of classes.
pub struct PairwiseSnSvm {
    /// One model per pair of classes.
    pub pairs: Vec<PairSnSvm>,
    /// Sorted class ids.
    pub class_ids: Vec<u8>,
    /// Every pair's training report, in pair order; `expansion_points` sums over the pairs.
    pub report: TrainReport,
    /// The classes each intensity allows (bands in `class_ids` order).
    pub gate: IntensityGate,
    /// Which features are intensities (not gradients): those a voxel beyond every band has moved
    /// into the drawn range.
    pub intensity_features: Vec<bool>,
}

impl PairwiseSnSvm {
    /// Trains an SN-SVM per pair of `class_ids` (sorted, each in `labels`) on finite `raw` rows
    /// (intensity first), standardised per pair with `scaling`, pruned at `prune_relative`
    /// (`docs/decisions/0015-pruning.md`); `gate` holds a band per class, or is open.
    #[allow(clippy::too_many_arguments)]
    pub fn train(
        raw: &[f32],
        scaling: &Scaling,
        labels: &[u8],
        class_ids: &[u8],
        gate: IntensityGate,
        params: &SnSvmParams,
        kernel_width: KernelWidth,
        prune_relative: f64,
    ) -> Result<PairwiseSnSvm, SegmentationError> {
        if class_ids.len() < 2 {
            let found = class_ids.to_vec();
            return Err(classify::ClassifyError::TooFewClasses { found: found.len(), class_ids: found }.into());
        }
        let mut pair_classes = Vec::new();
        for (position, &first) in class_ids.iter().enumerate() {
            for &second in &class_ids[position + 1..] {
                pair_classes.push((first, second));
            }
        }
        let dim = scaling.dim();
        let pairs = pair_classes
            .par_iter()
            .map(|&(first, second)| {
                let rows: Vec<usize> =
                    (0..labels.len()).filter(|&i| labels[i] == first || labels[i] == second).collect();
                let pair_raw: Vec<f32> =
                    rows.iter().flat_map(|&i| raw[i * dim..(i + 1) * dim].iter().copied()).collect();
                let pair_labels: Vec<u8> = rows.iter().map(|&i| labels[i]).collect();
                let standardiser = scaling.fit(&pair_raw)?;
                let values = standardiser.apply(&pair_raw)?;
                let mut params = *params;
                if kernel_width == KernelWidth::Automatic {
                    params.kernel = Kernel::Rbf { width: median_heuristic_width(&values, dim) };
                }
                let checked = params.check()?;
                let model = classify::train_with_classes(
                    &SampleMatrix { dim, values },
                    &pair_labels,
                    &[first, second],
                    &checked,
                )?
                .pruned(prune_relative);
                Ok(PairSnSvm { classes: (first, second), standardiser, model, params })
            })
            .collect::<Result<Vec<PairSnSvm>, SegmentationError>>()?;
        let report = TrainReport {
            pairs: pairs.iter().flat_map(|pair| pair.model.report().pairs.iter().cloned()).collect(),
            samples: labels.len(),
            expansion_points: pairs.iter().map(|pair| pair.model.report().expansion_points).sum(),
        };
        let gate = if gate.classes() == class_ids.len() { gate } else { IntensityGate::open(class_ids.len()) };
        let intensity_features = (0..dim).map(|feature| feature == 0).collect();
        Ok(PairwiseSnSvm { pairs, class_ids: class_ids.to_vec(), report, gate, intensity_features })
    }

    /// The same model with `intensity_features` (a flag per feature) marking the intensities.
    pub fn with_intensity_features(self, intensity_features: Vec<bool>) -> PairwiseSnSvm {
        PairwiseSnSvm { intensity_features, ..self }
    }

    /// The one class the gate allows at `intensity` (finite); `None` when the vote decides.
    pub fn class_by_intensity(&self, intensity: f32) -> Option<u8> {
        self.only_class(self.gate.allowed(intensity))
    }

    /// The drawn intensity band of class `class_id`; `None` for an open gate or an unknown id.
    pub fn band(&self, class_id: u8) -> Option<Band> {
        let position = self.class_ids.iter().position(|&id| id == class_id)?;
        self.gate.bands().get(position).copied()
    }

    /// The class id of a set that holds one class; `None` for an empty set or several.
    fn only_class(&self, allowed: ClassSet) -> Option<u8> {
        (allowed.count_ones() == 1).then(|| self.class_ids[allowed.trailing_zeros() as usize])
    }

    /// Class ids of the raw rows of `features` (scratch) into `out`; 0 for a non-finite value.
    pub fn classify_block(&self, features: &mut [f32], out: &mut [u8]) -> Result<(), SegmentationError> {
        let dim = features.len() / out.len().max(1);
        // The gate first: most voxels' intensity allows one class only.
        let mut undecided = Vec::new();
        let mut allowed_sets = Vec::new();
        for (voxel, (&allowed, label)) in self.allowed_sets(features, dim).iter().zip(out.iter_mut()).enumerate() {
            if allowed == 0 {
                *label = 0;
            } else if let Some(class) = self.only_class(allowed) {
                *label = class;
            } else {
                undecided.push(voxel);
                allowed_sets.push(allowed);
            }
        }
        if undecided.is_empty() {
            return Ok(());
        }
        let mut gathered: Vec<f32> =
            undecided.iter().flat_map(|&v| features[v * dim..(v + 1) * dim].iter().copied()).collect();
        self.move_into_drawn_range(&mut gathered, dim);
        let mut decided = vec![0u8; undecided.len()];
        self.vote_block(&mut gathered, &allowed_sets, &mut decided)?;
        for (&voxel, &label) in undecided.iter().zip(&decided) {
            out[voxel] = label;
        }
        Ok(())
    }

    /// Moves the intensity features of each row beyond every band to the drawn range's nearer
    /// end, where the kernels see training voxels (`docs/decisions/0005-intensity-gate.md`).
    fn move_into_drawn_range(&self, features: &mut [f32], dim: usize) {
        let Some(range) = self.gate.drawn_range() else { return };
        for row in features.chunks_exact_mut(dim.max(1)) {
            if range.holds(row[0]) {
                continue;
            }
            for (value, &is_intensity) in row.iter_mut().zip(&self.intensity_features) {
                if is_intensity {
                    *value = range.clamp(*value);
                }
            }
        }
    }

    /// The vote of the pairs `allowed_sets` allows, per row of raw finite `features` (scratch).
    fn vote_block(
        &self,
        features: &mut [f32],
        allowed_sets: &[ClassSet],
        out: &mut [u8],
    ) -> Result<(), SegmentationError> {
        if let [pair] = self.pairs.as_slice() {
            pair.standardiser.apply_in_place(features)?;
            pair.model.predict_block(features, out)?;
            return Ok(());
        }
        let classes = self.class_ids.len();
        let pairs = self.pairs.len();
        let pair_positions = self.pair_positions();
        let mut values = vec![0f32; out.len() * pairs];
        self.pair_values_block(features, allowed_sets, &mut values)?;
        let (mut votes, mut strength) = (vec![0u32; classes], vec![0f32; classes]);
        for ((label, values), &allowed) in out.iter_mut().zip(values.chunks_exact(pairs)).zip(allowed_sets) {
            classify::tally_votes_among(&pair_positions, values, allowed, &mut votes, &mut strength);
            *label = if strength.iter().any(|s| s.is_nan()) {
                0
            } else {
                self.class_ids[classify::vote_winner(&votes, &strength)]
            };
        }
        Ok(())
    }

    /// Each pair's decision value per row of raw `features` into `values` (row-major, pair
    /// order); a pair is evaluated only on rows whose set in `allowed_sets` holds both its
    /// classes, 0 elsewhere (`docs/decisions/0005-intensity-gate.md`).
    pub fn pair_values_block(
        &self,
        features: &[f32],
        allowed_sets: &[ClassSet],
        values: &mut [f32],
    ) -> Result<(), SegmentationError> {
        let pairs = self.pairs.len();
        let dim = self.pairs.first().map_or(1, |pair| pair.model.dim());
        if features.len() != allowed_sets.len() * dim {
            return Err(classify::ClassifyError::FeatureBlockShape { values: features.len(), dim }.into());
        }
        if values.len() != allowed_sets.len() * pairs {
            let expected = allowed_sets.len() * pairs;
            return Err(classify::ClassifyError::OutputBlockShape { expected, found: values.len() }.into());
        }
        values.fill(0.0);
        let (mut rows, mut gathered, mut pair_values) = (Vec::new(), Vec::new(), Vec::new());
        for (p, (pair, (first, second))) in self.pairs.iter().zip(self.pair_positions()).enumerate() {
            rows.clear();
            rows.extend(allowed_sets.iter().enumerate().filter_map(|(row, &allowed)| {
                (classify::class_set_contains(allowed, first) && classify::class_set_contains(allowed, second))
                    .then_some(row)
            }));
            if rows.is_empty() {
                continue;
            }
            gathered.clear();
            for &row in &rows {
                gathered.extend_from_slice(&features[row * dim..(row + 1) * dim]);
            }
            pair.standardiser.apply_in_place(&mut gathered)?;
            pair_values.clear();
            pair_values.resize(rows.len(), 0.0);
            pair.model.decision_values_block(&gathered, &mut pair_values)?;
            for (&row, &f) in rows.iter().zip(&pair_values) {
                values[row * pairs + p] = f;
            }
        }
        Ok(())
    }

    /// For each pair, the positions of its two classes in `class_ids`.
    fn pair_positions(&self) -> Vec<(usize, usize)> {
        let position = |id: u8| self.class_ids.iter().position(|&c| c == id).unwrap_or(0);
        self.pairs.iter().map(|pair| (position(pair.classes.0), position(pair.classes.1))).collect()
    }

    /// The classes the gate allows per row of raw `features` (`dim` a row); none if not finite.
    pub fn allowed_sets(&self, features: &[f32], dim: usize) -> Vec<ClassSet> {
        features
            .chunks_exact(dim.max(1))
            .map(|row| if row.iter().all(|v| v.is_finite()) { self.gate.allowed(row[0]) } else { 0 })
            .collect()
    }
}

#[cfg(test)]
mod tests;
