//! Block prediction: f32 against f64, SIMD paths against each other, voting rules.

use super::*;
use crate::classify::SampleMatrix;
use crate::classify::model::ModelParts;
use crate::classify::ovo::{ClassPair, TrainReport, train};
use crate::classify::params::SnSvmParams;
use crate::classify::test_support::{SplitMix64, blobs};

fn trained(seed: u64, classes: usize, per_class: usize, params: SnSvmParams) -> Model {
    let mut rng = SplitMix64::new(seed);
    let (values, labels) = blobs(&mut rng, classes, per_class, 5, 2.0);
    train(&SampleMatrix { dim: 5, values }, &labels, &params.check().unwrap()).unwrap()
}

fn voxels(seed: u64, count: usize, dim: usize) -> Vec<f32> {
    let mut rng = SplitMix64::new(seed);
    (0..count * dim).map(|_| (2.0 * rng.normal()) as f32).collect()
}

#[test]
fn fast_exp_matches_f64_exp() {
    let mut worst_relative = 0.0f64;
    let steps = 2_000_000;
    for step in 0..=steps {
        let x = -87.0 * step as f64 / steps as f64;
        let x32 = x as f32;
        let exact = (x32 as f64).exp();
        for fast in [exp_nonpositive::<Separate>(x32), exp_nonpositive::<Fused>(x32)] {
            worst_relative = worst_relative.max((fast as f64 - exact).abs() / exact);
        }
    }
    // About 2 ulp of f32 (ulp = 2^-23 = 1.2e-7 relative).
    assert!(worst_relative < 2.5e-7, "worst relative error {worst_relative:e}");
    assert_eq!(exp_nonpositive::<Separate>(0.0), 1.0);
    assert_eq!(exp_nonpositive::<Fused>(-0.0), 1.0);
    assert!(exp_nonpositive::<Separate>(-200.0) < 2e-38);
    assert!(exp_nonpositive::<Fused>(-200.0) >= 0.0);
}

fn paths() -> Vec<SimdPath> {
    let mut paths = vec![SimdPath::Portable];
    #[cfg(target_arch = "x86_64")]
    if SimdPath::avx2_fma_available() {
        paths.push(SimdPath::Avx2Fma);
    }
    paths
}

#[test]
fn block_decision_values_agree_with_the_f64_reference_on_every_path() {
    for params in [SnSvmParams::default(), SnSvmParams::plain_svm()] {
        let model = trained(1, 3, 200, params);
        let features = voxels(2, 3000, 5);
        let pair_count = model.pairs().len();
        for path in paths() {
            let mut out = vec![0.0f32; 3000 * pair_count];
            model.decision_values_with(path, &features, &mut out);
            let mut worst = 0.0f64;
            for (x, values) in features.chunks_exact(5).zip(out.chunks_exact(pair_count)) {
                let x64: Vec<f64> = x.iter().map(|&v| v as f64).collect();
                let exact = model.decision_values_exact(&x64).unwrap();
                for (a, b) in values.iter().zip(&exact) {
                    worst = worst.max((*a as f64 - b).abs());
                }
            }
            assert!(worst < 1e-5, "f32 block vs f64 on {path:?}: {worst:e}");
        }
    }
}

#[test]
fn every_path_gives_the_same_labels() {
    let model = trained(3, 4, 60, SnSvmParams::default());
    let count = 1001; // odd: one voxel goes through the single-voxel pass
    let features = voxels(4, count, 5);
    let pair_count = model.pairs().len();
    let mut reference = vec![0.0f32; count * pair_count];
    general_block(&model, &features, &mut reference);
    let mut reference_labels = vec![0u8; count];
    model.predict_checked(SimdPath::Portable, &features, &mut reference_labels);
    for path in paths() {
        let mut values = vec![0.0f32; count * pair_count];
        model.decision_values_with(path, &features, &mut values);
        for (a, b) in values.iter().zip(&reference) {
            assert!((a - b).abs() < 1e-4, "{path:?} {a} vs scalar std-exp {b}");
        }
        let mut labels = vec![0u8; count];
        model.predict_checked(path, &features, &mut labels);
        for (voxel, (a, b)) in labels.iter().zip(&reference_labels).enumerate() {
            // Rounding may flip a vote only where a decision value is within it of 0.
            let close = values[voxel * pair_count..(voxel + 1) * pair_count].iter().any(|f| f.abs() < 1e-4);
            assert!(a == b || close, "{path:?}: voxel {voxel} {a} vs {b}");
        }
    }
    let mut labels = vec![0u8; count];
    model.predict_block(&features, &mut labels).unwrap();
    let mut parallel = vec![0u8; count];
    model.predict_block_parallel(&features, &mut parallel).unwrap();
    assert_eq!(labels, parallel);
    assert!(labels.iter().all(|&l| (1..=4).contains(&l)));
    // A voxel's values do not depend on its neighbours in the block (a full lane group against
    // a short, zero-padded one).
    let mut alone = vec![0.0f32; pair_count];
    for voxel in [0, 1, count - 1] {
        model.decision_values_block(&features[voxel * 5..(voxel + 1) * 5], &mut alone).unwrap();
        let mut block = vec![0.0f32; count * pair_count];
        model.decision_values_block(&features, &mut block).unwrap();
        assert_eq!(&block[voxel * pair_count..(voxel + 1) * pair_count], &alone[..]);
    }
}

fn three_class_model() -> Model {
    let pairs =
        vec![ClassPair { first: 2, second: 5 }, ClassPair { first: 2, second: 7 }, ClassPair { first: 5, second: 7 }];
    Model::assemble(ModelParts {
        dim: 1,
        kernel: Kernel::Rbf { width: 1.0 },
        class_ids: vec![2, 5, 7],
        pairs,
        points: vec![0.0],
        coefficients: vec![1.0, 1.0, 1.0],
        biases: vec![0.0; 3],
        report: TrainReport { pairs: Vec::new(), samples: 1, expansion_points: 0 },
    })
}

#[test]
fn voting_counts_then_breaks_ties_by_strength_then_by_id() {
    let model = three_class_model();
    let mut votes = vec![0; 3];
    let mut strength = vec![0.0; 3];
    let mut label = |values: [f32; 3]| vote(&model, &values, &mut votes, &mut strength);
    // Pairs (2,5), (2,7), (5,7).
    assert_eq!(label([1.0, 1.0, 1.0]), 2, "two votes win");
    assert_eq!(label([-1.0, 1.0, 1.0]), 5, "5 beats 2 and 7");
    assert_eq!(label([-1.0, -1.0, -1.0]), 7);
    // Cycles: one vote each, decided by the |f| of each class's winning vote.
    assert_eq!(label([1.0, -0.5, 2.0]), 5, "cycle: 5 has the largest |f| (2.0)");
    assert_eq!(label([3.0, -0.5, 2.0]), 2, "cycle: 2 has the largest |f| (3.0)");
    assert_eq!(label([1.0, -1.0, 1.0]), 2, "equal strength: smallest id");
    assert_eq!(label([0.0, 0.0, 0.0]), 7, "f = 0 votes for the second class");
    assert_eq!(label([f32::NAN, 1.0, 1.0]), 0, "non-finite input is background");
}

#[test]
fn non_finite_features_give_background_and_bad_shapes_are_errors() {
    let model = trained(6, 2, 20, SnSvmParams::default());
    let mut features = voxels(7, 3, 5);
    features[7] = f32::NAN;
    features[10] = f32::INFINITY;
    let mut labels = [9u8; 3];
    model.predict_block(&features, &mut labels).unwrap();
    assert_eq!(labels[1], 0);
    assert_eq!(labels[2], 0);
    assert_ne!(labels[0], 0);
    assert_eq!(
        model.predict_block(&features[..14], &mut labels),
        Err(ClassifyError::FeatureBlockShape { values: 14, dim: 5 })
    );
    assert_eq!(
        model.predict_block(&features, &mut labels[..2]),
        Err(ClassifyError::OutputBlockShape { expected: 3, found: 2 })
    );
    let mut out = vec![0.0f32; 2];
    assert_eq!(
        model.decision_values_block(&features, &mut out),
        Err(ClassifyError::OutputBlockShape { expected: 3, found: 2 })
    );
    assert!(model.decision_values_exact(&[0.0; 4]).is_err());
}

#[test]
fn two_class_labels_are_the_votes_of_the_decision_values() {
    // The two-class shortcut of `predict_checked` against the general vote, voxel by voxel.
    let model = trained(8, 2, 40, SnSvmParams::default());
    let count = 333;
    let mut features = voxels(9, count, 5);
    features[5 * 17 + 2] = f32::NAN;
    let mut values = vec![0.0f32; count];
    model.decision_values_with(SimdPath::best(), &features, &mut values);
    let mut labels = vec![0u8; count];
    model.predict_block(&features, &mut labels).unwrap();
    let (mut votes, mut strength) = (vec![0u32; 2], vec![0f32; 2]);
    for (voxel, (&label, &f)) in labels.iter().zip(&values).enumerate() {
        assert_eq!(label, vote(&model, &[f], &mut votes, &mut strength), "voxel {voxel}");
    }
    assert_eq!(labels[17], 0);
    assert!(labels.contains(&1) && labels.contains(&2));
}
