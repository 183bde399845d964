use super::*;
use crate::rng::SplitMix64;

/// Two Gaussian blobs per class in 3-D (class k centred at +-2k along feature k % 3).
fn blobs(per_class: usize, classes: u8, seed: u64) -> (Vec<f32>, Vec<u8>) {
    let mut rng = SplitMix64::new(seed);
    let (mut samples, mut labels) = (Vec::new(), Vec::new());
    for class in 1..=classes {
        for i in 0..per_class {
            let sign = if i % 2 == 0 { 1.0 } else { -1.0 };
            let mut vector = [rng.next_gaussian() * 0.5, rng.next_gaussian() * 0.5, rng.next_gaussian() * 0.5];
            vector[class as usize % 3] += sign * 2.0 * class as f32;
            samples.extend_from_slice(&vector);
            labels.push(class);
        }
    }
    (samples, labels)
}

#[test]
fn separates_held_out_blobs_and_xor() {
    let (train, train_labels) = blobs(60, 3, 1);
    let (test, test_labels) = blobs(200, 3, 2);
    let forest = Forest::train(&train, 3, &train_labels, &[1, 2, 3], &ForestParams::default()).unwrap();
    let mut predicted = vec![0u8; test_labels.len()];
    forest.predict_block(&test, &mut predicted).unwrap();
    let correct = predicted.iter().zip(&test_labels).filter(|(a, b)| a == b).count();
    assert!(correct as f64 / test_labels.len() as f64 > 0.97, "{correct} of {}", test_labels.len());

    // XOR of two features: no single split separates it, the trees' depth must.
    let mut rng = SplitMix64::new(3);
    let (mut samples, mut labels) = (Vec::new(), Vec::new());
    for _ in 0..400 {
        let (a, b) = (rng.next_f64() as f32 * 2.0 - 1.0, rng.next_f64() as f32 * 2.0 - 1.0);
        samples.extend_from_slice(&[a, b]);
        labels.push(if (a > 0.0) == (b > 0.0) { 1 } else { 2 });
    }
    let forest = Forest::train(&samples, 2, &labels, &[1, 2], &ForestParams::default()).unwrap();
    let queries = [0.5f32, 0.5, -0.5, -0.5, 0.5, -0.5, -0.5, 0.5];
    let mut out = [0u8; 4];
    forest.predict_block(&queries, &mut out).unwrap();
    assert_eq!(out, [1, 1, 2, 2]);
}

#[test]
fn extrapolates_as_the_nearest_extreme_class() {
    // One feature: class 1 at 0..1, class 2 at 2..3. Far beyond either end, the forest keeps
    // the class of that end (an RBF SVM decays towards its bias there).
    let samples: Vec<f32> =
        (0..100).map(|i| if i < 50 { i as f32 / 50.0 } else { 2.0 + (i - 50) as f32 / 50.0 }).collect();
    let labels: Vec<u8> = (0..100).map(|i| if i < 50 { 1 } else { 2 }).collect();
    let forest = Forest::train(&samples, 1, &labels, &[1, 2], &ForestParams::default()).unwrap();
    let mut out = [0u8; 2];
    forest.predict_block(&[-100.0, 100.0], &mut out).unwrap();
    assert_eq!(out, [1, 2]);
}

#[test]
fn class_balance_keeps_a_small_class() {
    // 300 samples of class 1 around 0, 12 of class 2 around 1.5, overlapping tails. Balanced
    // bootstraps give class 2 its share of the boundary.
    let mut rng = SplitMix64::new(5);
    let (mut samples, mut labels) = (Vec::new(), Vec::new());
    for _ in 0..300 {
        samples.push(rng.next_gaussian());
        labels.push(1);
    }
    for _ in 0..12 {
        samples.push(1.5 + 0.3 * rng.next_gaussian());
        labels.push(2);
    }
    let balanced = Forest::train(&samples, 1, &labels, &[1, 2], &ForestParams::default()).unwrap();
    let mut out = [0u8; 1];
    balanced.predict_block(&[1.6], &mut out).unwrap();
    assert_eq!(out, [2]);
}

#[test]
fn deterministic_and_parallel_prediction_agrees() {
    let (train, labels) = blobs(40, 4, 7);
    let params = ForestParams { tree_count: 16, ..ForestParams::default() };
    let first = Forest::train(&train, 3, &labels, &[1, 2, 3, 4], &params).unwrap();
    let second = Forest::train(&train, 3, &labels, &[1, 2, 3, 4], &params).unwrap();
    assert_eq!(first.node_count(), second.node_count());
    let (test, _) = blobs(3000, 4, 8);
    let (mut a, mut b, mut c) = (vec![0u8; 12000], vec![0u8; 12000], vec![0u8; 12000]);
    first.predict_block(&test, &mut a).unwrap();
    second.predict_block(&test, &mut b).unwrap();
    first.predict_block_parallel(&test, &mut c).unwrap();
    assert_eq!(a, b);
    assert_eq!(a, c);
    let other = Forest::train(&train, 3, &labels, &[1, 2, 3, 4], &ForestParams { seed: 99, ..params }).unwrap();
    let mut d = vec![0u8; 12000];
    other.predict_block(&test, &mut d).unwrap();
    assert!(a.iter().zip(&d).filter(|(x, y)| x == y).count() > 11000);
}

#[test]
fn refuses_bad_input() {
    let bad = |params: ForestParams| match params.check() {
        Err(ClassifyError::InvalidParameter { name, .. }) => name,
        other => panic!("{other:?}"),
    };
    assert_eq!(bad(ForestParams { tree_count: 0, ..ForestParams::default() }), "tree count");
    assert_eq!(bad(ForestParams { min_samples_split: 1, ..ForestParams::default() }), "min samples per split");
    assert_eq!(bad(ForestParams { features_per_split: Some(0), ..ForestParams::default() }), "features per split");
    let params = ForestParams::default();
    assert!(matches!(
        Forest::train(&[0.0, 1.0], 1, &[1, 1], &[1, 2], &params),
        Err(ClassifyError::EmptyClass { class_id: 2 })
    ));
    assert!(matches!(
        Forest::train(&[0.0, 1.0], 1, &[1, 3], &[1, 2], &params),
        Err(ClassifyError::UnknownLabel { sample: 1, label: 3, .. })
    ));
    assert!(matches!(
        Forest::train(&[0.0, f32::NAN], 1, &[1, 2], &[1, 2], &params),
        Err(ClassifyError::NonFiniteSample { sample: 1, .. })
    ));
    let forest = Forest::train(&[0.0, 1.0], 1, &[1, 2], &[1, 2], &params).unwrap();
    assert!(forest.predict_block(&[0.0, 1.0, 2.0], &mut [0u8; 2]).is_err());
}

/// Votes of every vector walked through every tree one at a time, the reference for the
/// masked prediction.
fn walked_labels(forest: &Forest, vectors: &[f32]) -> Vec<u8> {
    let class_count = forest.class_ids.len();
    vectors
        .chunks_exact(forest.dim)
        .map(|vector| {
            let mut votes = vec![0f32; class_count];
            for tree in &forest.trees {
                for (vote, &frequency) in votes.iter_mut().zip(tree.leaf_frequencies(vector)) {
                    *vote += frequency;
                }
            }
            let best = (0..class_count).fold(0, |best, k| if votes[k] > votes[best] { k } else { best });
            forest.class_ids[best]
        })
        .collect()
}

#[test]
fn split_masks_find_the_leaves_walks_find() {
    // Random labels grow bushy trees: shallow ones are masked; deep ones have more than 32
    // leaves and are walked. Class counts for each way of summing votes (4, 8 and any number
    // of frequencies per leaf), group sizes from 1 to beyond a chunk, and NaN and infinite
    // values, which go right at every split.
    let mut rng = SplitMix64::new(7);
    let train: Vec<f32> = (0..3 * 400).map(|_| rng.next_f64() as f32).collect();
    let mut test: Vec<f32> = (0..3 * 300).map(|_| rng.next_f64() as f32).collect();
    test[4] = f32::NAN;
    test[9] = f32::INFINITY;
    test[13] = f32::NEG_INFINITY;
    for class_count in [2u8, 4, 7, 10] {
        let labels: Vec<u8> = (0..400).map(|_| 1 + rng.below(u64::from(class_count)) as u8).collect();
        let class_ids: Vec<u8> = (1..=class_count).collect();
        for max_depth in [3, 6, 30] {
            let params = ForestParams { max_depth, tree_count: 12, ..ForestParams::default() };
            let forest = Forest::train(&train, 3, &labels, &class_ids, &params).unwrap();
            let walked_trees = forest.trees.iter().filter(|tree| tree.split_masks().is_none()).count();
            // Depth 6 mixes masked and walked trees (up to 64 leaves), whose votes must still
            // add up in tree order.
            let expected = match max_depth {
                3 => 0..=0,
                6 => 1..=11,
                _ => 12..=12,
            };
            assert!(expected.contains(&walked_trees), "depth {max_depth}: {walked_trees} trees walked");
            for count in [1, 2, leaf_masks::LANES - 1, leaf_masks::LANES, leaf_masks::LANES + 3, test.len() / 3] {
                let vectors = &test[..count * 3];
                let mut masked = vec![0u8; count];
                forest.predict_block(vectors, &mut masked).unwrap();
                let context = format!("{class_count} classes, depth {max_depth}, {count} vectors");
                assert_eq!(masked, walked_labels(&forest, vectors), "{context}");
            }
        }
    }
}

#[test]
fn thresholds_in_raw_units_label_raw_vectors_as_standardised_ones() {
    // Raw features in very different units (HU-like and a small gradient-like one), extreme
    // and non-finite values included: the forest moved into raw units by the standardiser's
    // exact preimages agrees with the original on standardised vectors, vector for vector.
    let mut rng = SplitMix64::new(11);
    let raw_train: Vec<f32> = (0..2 * 300)
        .map(|k| if k % 2 == 0 { 3000.0 * rng.next_f64() as f32 - 1000.0 } else { 0.02 * rng.next_f64() as f32 })
        .collect();
    let labels: Vec<u8> =
        raw_train.chunks_exact(2).map(|v| if v[0] + 50_000.0 * v[1] > 800.0 { 2 } else { 1 }).collect();
    let standardiser = crate::features::Standardiser::fit(&raw_train, 2).unwrap();
    let mut train = raw_train.clone();
    standardiser.apply_in_place(&mut train).unwrap();
    let forest = Forest::train(&train, 2, &labels, &[1, 2], &ForestParams::default()).unwrap();
    let raw_forest = forest.with_thresholds(|feature, threshold| standardiser.raw_threshold(feature, threshold));
    let mut raw: Vec<f32> = (0..2 * 2000)
        .map(|k| if k % 2 == 0 { 5000.0 * rng.next_f64() as f32 - 2000.0 } else { 0.04 * rng.next_f64() as f32 - 0.01 })
        .collect();
    raw.extend([f32::NAN, 0.0, f32::INFINITY, 0.01, f32::NEG_INFINITY, f32::NAN, 400.0, 1e30]);
    let mut standardised = raw.clone();
    standardiser.apply_in_place(&mut standardised).unwrap();
    let (mut expected, mut found) = (vec![0u8; raw.len() / 2], vec![0u8; raw.len() / 2]);
    forest.predict_block(&standardised, &mut expected).unwrap();
    raw_forest.predict_block(&raw, &mut found).unwrap();
    assert_eq!(found, expected);
    assert!(expected.contains(&1) && expected.contains(&2));
}
