//! One-vs-one SN-SVM with each pair of classes on its own standardisation, as the paper's
//! code trains it (snsvm.md §11: MATLAB's `svmtrain` autoscales each pair's training data).
//!
//! One standardisation for all classes fails on scans with a wide range of values: in a CT
//! with air (-1000 HU) and bone (1000 HU) lassoed, the 50 HU between muscle and liver shrink to
//! a twentieth of a deviation, and one RBF width cannot tell them apart (Dice 0.4 for both on
//! the torso phantom). Each pair z-scored on its own two classes sees them at their own scale;
//! the automatic RBF width then comes from the pair's own distances
//! ([`super::median_heuristic_width`]).
//!
//! Two classes are one pair: the model is exactly the single SN-SVM on the two classes'
//! standardisation. With more, a voxel's features are standardised once per pair, each pair's
//! decision value votes, and the vote is [`crate::classify::Model`]'s: most votes, then the
//! larger summed |f| of the winning votes, then the smaller class id.
//!
//! The [`IntensityGate`] comes first: a voxel whose intensity only one class's drawn band
//! allows is that class without a vote, and only the pairs of allowed classes vote on the rest.
//!
//! Never: chooses the training voxels, or the background.

use super::gate::{Band, ClassSet, IntensityGate};
use super::{KernelWidth, SegmentationError, median_heuristic_width};
use crate::classify::{self, Kernel, Model, SampleMatrix, SnSvmParams, TrainReport};
use crate::features::Standardiser;
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
    /// Every pair's training report, in pair order; `expansion_points` is the sum over pairs
    /// (the kernel terms a voxel costs).
    pub report: TrainReport,
    /// The classes each intensity allows (bands in `class_ids` order).
    pub gate: IntensityGate,
    /// Which features are intensities (the voxel's or averages of them, as opposed to
    /// gradients): a voxel beyond every band is voted on with them moved into the drawn range.
    pub intensity_features: Vec<bool>,
}

impl PairwiseSnSvm {
    /// Trains on `raw` feature vectors (one value per weight in a row, finite; the first is
    /// the intensity) with class `labels` from `class_ids` (sorted, each present); each pair's
    /// standardisation weighs its features by `weights` ([`Standardiser::weighted`]). `gate`
    /// holds a band per class in `class_ids` order (or is open).
    #[allow(clippy::too_many_arguments)]
    pub fn train(
        raw: &[f32],
        weights: &[f64],
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
        let dim = weights.len();
        let pairs = pair_classes
            .par_iter()
            .map(|&(first, second)| {
                let rows: Vec<usize> =
                    (0..labels.len()).filter(|&i| labels[i] == first || labels[i] == second).collect();
                let pair_raw: Vec<f32> =
                    rows.iter().flat_map(|&i| raw[i * dim..(i + 1) * dim].iter().copied()).collect();
                let pair_labels: Vec<u8> = rows.iter().map(|&i| labels[i]).collect();
                let standardiser = Standardiser::fit(&pair_raw, dim)?.weighted(weights);
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

    /// The same model, with `intensity_features` (one flag per feature) marking the features
    /// that are intensities; [`train`](Self::train) marks the first alone.
    pub fn with_intensity_features(self, intensity_features: Vec<bool>) -> PairwiseSnSvm {
        PairwiseSnSvm { intensity_features, ..self }
    }

    /// The class a voxel of `intensity` (finite) is whatever its other features: the one class
    /// the gate allows; `None` when the vote decides.
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

    /// Class ids of a block of raw feature vectors (row-major, `out.len()` rows), into `out`;
    /// `features` is scratch. A voxel with a non-finite feature is not classified (0).
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

    /// Moves the intensity features of each row of `features` whose intensity lies beyond
    /// every band to the nearer end of the drawn range: far from every training voxel a
    /// kernel's value is little more than its pair's bias, and at the range's end the vote
    /// among the classes the gate leaves (those drawn nearest that end) sees their voxels.
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

    /// The vote of the pairs whose classes `allowed_sets` allows, one set per row of `features`
    /// (raw, finite; scratch).
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
        let position = |id: u8| self.class_ids.iter().position(|&c| c == id).unwrap_or(0);
        let pair_positions: Vec<(usize, usize)> =
            self.pairs.iter().map(|pair| (position(pair.classes.0), position(pair.classes.1))).collect();
        // Every pair's decision value, also of pairs the gate rules out: a block is evaluated
        // pair by pair.
        let mut values = vec![0f32; out.len() * pairs];
        self.pair_values_block(features, &mut values)?;
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

    /// Every pair's decision value for each row of raw `features`, row by row into `values`
    /// (one value per pair, in pair order).
    pub fn pair_values_block(&self, features: &[f32], values: &mut [f32]) -> Result<(), SegmentationError> {
        let pairs = self.pairs.len();
        let rows = values.len() / pairs.max(1);
        let mut scaled = vec![0f32; features.len()];
        let mut pair_values = vec![0f32; rows];
        for (p, pair) in self.pairs.iter().enumerate() {
            scaled.copy_from_slice(features);
            pair.standardiser.apply_in_place(&mut scaled)?;
            pair.model.decision_values_block(&scaled, &mut pair_values)?;
            for (row, &f) in pair_values.iter().enumerate() {
                values[row * pairs + p] = f;
            }
        }
        Ok(())
    }

    /// The classes the gate allows for each row of raw `features` (`dim` values a row); none
    /// for a row with a non-finite value (not classified).
    pub fn allowed_sets(&self, features: &[f32], dim: usize) -> Vec<ClassSet> {
        features
            .chunks_exact(dim.max(1))
            .map(|row| if row.iter().all(|v| v.is_finite()) { self.gate.allowed(row[0]) } else { 0 })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    /// Four classes along one feature, spaced 1, 1 and 1000 apart (muscle, liver, ..., bone),
    /// with a second feature of noise; deviation 0.2 within each class.
    fn samples() -> (Vec<f32>, Vec<u8>) {
        let mut rng = SplitMix64::new(3);
        let centres = [0.0, 1.0, 2.0, 1000.0];
        let mut raw = Vec::new();
        let mut labels = Vec::new();
        for (class, &centre) in centres.iter().enumerate() {
            for _ in 0..40 {
                raw.push(centre + 0.2 * rng.next_gaussian());
                raw.push(rng.next_gaussian());
                labels.push(class as u8 + 1);
            }
        }
        (raw, labels)
    }

    #[test]
    fn close_classes_stay_apart_beside_a_far_one() {
        let (raw, labels) = samples();
        let params = SnSvmParams::default();
        let model = PairwiseSnSvm::train(
            &raw,
            &[1.0; 2],
            &labels,
            &[1, 2, 3, 4],
            IntensityGate::open(4),
            &params,
            KernelWidth::Automatic,
            0.01,
        )
        .unwrap();
        assert_eq!(model.pairs.len(), 6);
        let mut probes = vec![0.0, 0.3, 1.0, -0.2, 2.0, 0.1, 1000.0, 0.0, 0.45, 0.0, 1.55, 0.0];
        let mut out = vec![0u8; 6];
        model.classify_block(&mut probes, &mut out).unwrap();
        assert_eq!(out, [1, 2, 3, 4, 1, 3]);
        // One standardisation for all four squeezes the first three together.
        let standardiser = Standardiser::fit(&raw, 2).unwrap();
        let values = standardiser.apply(&raw).unwrap();
        let params = SnSvmParams { kernel: Kernel::Rbf { width: median_heuristic_width(&values, 2) }, ..params };
        let single = classify::train_with_classes(
            &SampleMatrix { dim: 2, values },
            &labels,
            &[1, 2, 3, 4],
            &params.check().unwrap(),
        )
        .unwrap();
        let mut probes = vec![0.0, 0.3, 1.0, -0.2, 2.0, 0.1, 1000.0, 0.0, 0.45, 0.0, 1.55, 0.0];
        standardiser.apply_in_place(&mut probes).unwrap();
        single.predict_block(&probes, &mut out).unwrap();
        assert_ne!(out, [1, 2, 3, 4, 1, 3], "the single model was expected to merge close classes");
    }

    #[test]
    fn the_gate_gives_a_voxel_its_band_s_class_and_leaves_the_rest_to_the_allowed_pairs() {
        // Air (-1000, flat), soft tissue (0, gentle gradients) and a thin class (200, steep
        // gradients). A voxel of soft tissue's intensity with a steep gradient: the thin class
        // wins its pairs on the gradient and so the vote; the gate gives it to the one class
        // whose band holds its intensity. A voxel between the bands of air and soft tissue
        // (the skin's air) is left to their pair.
        let mut rng = SplitMix64::new(11);
        let (mut raw, mut labels) = (Vec::new(), Vec::new());
        for (class, centre, gradient, spread) in
            [(1u8, -1000.0, 0.0, 1.0), (2, 0.0, 10.0, 10.0), (3, 200.0, 300.0, 60.0)]
        {
            for _ in 0..40 {
                raw.extend([centre + 5.0 * rng.next_gaussian(), gradient + spread * rng.next_gaussian().abs()]);
                labels.push(class);
            }
        }
        let train = |gate| {
            PairwiseSnSvm::train(
                &raw,
                &[1.0; 2],
                &labels,
                &[1, 2, 3],
                gate,
                &SnSvmParams::default(),
                KernelWidth::Automatic,
                0.01,
            )
            .unwrap()
        };
        let bands = [(-1010.0, -990.0), (-10.0, 10.0), (190.0, 210.0)];
        let gated = train(IntensityGate::from_bands(bands.iter().map(|&(low, high)| Band { low, high }).collect()));
        let open = train(IntensityGate::open(3));
        // The skin's air, a steep voxel inside soft tissue's band, one brighter than every band,
        // and a NaN.
        let probes = [-900.0, 300.0, 0.0, 300.0, 5000.0, 0.0, f32::NAN, 0.0];
        let (mut open_labels, mut gated_labels) = ([0u8; 4], [0u8; 4]);
        open.classify_block(&mut probes.clone(), &mut open_labels).unwrap();
        gated.classify_block(&mut probes.clone(), &mut gated_labels).unwrap();
        assert_eq!(open_labels[1], 3, "the vote of all pairs was expected to give the steep voxel to the thin class");
        assert!([1, 2].contains(&gated_labels[0]));
        assert_eq!(gated_labels[1..], [2, 3, 0]);
    }

    #[test]
    fn a_voxel_beyond_every_band_is_voted_on_at_the_drawn_range_s_end_with_its_own_gradient() {
        let (raw, labels) = samples();
        let bands = vec![Band { low: -10.0, high: 10.0 }, Band { low: 5.0, high: 40.0 }];
        let (raw, labels): (Vec<f32>, Vec<u8>) = (raw[..160].to_vec(), labels[..80].to_vec());
        let model = PairwiseSnSvm::train(
            &raw,
            &[1.0; 2],
            &labels,
            &[1, 2],
            IntensityGate::from_bands(bands),
            &SnSvmParams::default(),
            KernelWidth::Automatic,
            0.01,
        )
        .unwrap();
        // Intensity and gradient: brighter than every band, darker, and inside the range.
        let mut features = [1300.0, 7.0, -500.0, 3.0, 20.0, 9.0];
        model.move_into_drawn_range(&mut features, 2);
        assert_eq!(features, [40.0, 7.0, -10.0, 3.0, 20.0, 9.0]);
        let mut both = model.with_intensity_features(vec![true, true]);
        let mut bright = [1300.0, 700.0];
        both.move_into_drawn_range(&mut bright, 2);
        assert_eq!(bright, [40.0, 40.0], "every feature marked an intensity moves");
        both.gate = IntensityGate::open(2);
        let mut bright = [1300.0, 700.0];
        both.move_into_drawn_range(&mut bright, 2);
        assert_eq!(bright, [1300.0, 700.0], "an open gate moves nothing");
    }

    #[test]
    fn two_classes_are_the_single_model_on_their_standardisation() {
        let (raw, labels) = samples();
        let (raw, labels): (Vec<f32>, Vec<u8>) = (raw[..160].to_vec(), labels[..80].to_vec());
        let params = SnSvmParams::default();
        let model = PairwiseSnSvm::train(
            &raw,
            &[1.0; 2],
            &labels,
            &[1, 2],
            IntensityGate::open(2),
            &params,
            KernelWidth::Automatic,
            0.0,
        )
        .unwrap();
        let standardiser = Standardiser::fit(&raw, 2).unwrap();
        assert_eq!(model.pairs[0].standardiser, standardiser);
        let values = standardiser.apply(&raw).unwrap();
        let width = median_heuristic_width(&values, 2);
        assert_eq!(model.pairs[0].params.kernel, Kernel::Rbf { width });
        let single = classify::train_with_classes(
            &SampleMatrix { dim: 2, values },
            &labels,
            &[1, 2],
            &SnSvmParams { kernel: Kernel::Rbf { width }, ..params }.check().unwrap(),
        )
        .unwrap();
        let mut rng = SplitMix64::new(9);
        let probes: Vec<f32> = (0..400).map(|_| 0.5 + rng.next_gaussian()).collect();
        let (mut a, mut b) = (probes.clone(), probes);
        let (mut out_a, mut out_b) = (vec![0u8; 200], vec![0u8; 200]);
        model.classify_block(&mut a, &mut out_a).unwrap();
        standardiser.apply_in_place(&mut b).unwrap();
        single.predict_block(&b, &mut out_b).unwrap();
        assert_eq!(out_a, out_b);
        assert!(out_a.contains(&1) && out_a.contains(&2));
    }

    #[test]
    fn one_class_is_refused_as_the_single_model_refuses_it() {
        let (raw, labels) = samples();
        let (raw, labels) = (&raw[..80], &labels[..40]);
        let refused = PairwiseSnSvm::train(
            raw,
            &[1.0; 2],
            labels,
            &[1],
            IntensityGate::open(1),
            &SnSvmParams::default(),
            KernelWidth::Automatic,
            0.0,
        );
        assert!(matches!(
            refused,
            Err(SegmentationError::Classify(classify::ClassifyError::TooFewClasses { found: 1, .. }))
        ));
    }
}
