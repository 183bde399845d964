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

/// The pairwise model of [`samples`]' four classes behind `gate`, default parameters.
fn four_classes(gate: IntensityGate) -> PairwiseSnSvm {
    let (raw, labels) = samples();
    PairwiseSnSvm::train(
        &raw,
        &Scaling::weighted(vec![1.0; 2]),
        &labels,
        &[1, 2, 3, 4],
        gate,
        &SnSvmParams::default(),
        KernelWidth::Automatic,
        0.01,
    )
    .unwrap()
}

#[test]
fn close_classes_stay_apart_beside_a_far_one() {
    let (raw, labels) = samples();
    let params = SnSvmParams::default();
    let model = four_classes(IntensityGate::open(4));
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
    for (class, centre, gradient, spread) in [(1u8, -1000.0, 0.0, 1.0), (2, 0.0, 10.0, 10.0), (3, 200.0, 300.0, 60.0)] {
        for _ in 0..40 {
            raw.extend([centre + 5.0 * rng.next_gaussian(), gradient + spread * rng.next_gaussian().abs()]);
            labels.push(class);
        }
    }
    let train = |gate| {
        PairwiseSnSvm::train(
            &raw,
            &Scaling::weighted(vec![1.0; 2]),
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
fn pairs_evaluated_only_where_the_gate_allows_both_classes_vote_as_every_pair_evaluated_would() {
    let bands = [(-1.0, 2.0), (0.5, 2.5), (1.5, 3.0), (900.0, 1100.0)];
    let model = four_classes(IntensityGate::from_bands(bands.iter().map(|&(low, high)| Band { low, high }).collect()));
    let mut rng = SplitMix64::new(5);
    let probes: Vec<f32> = (0..300).flat_map(|_| [-0.5 + 3.5 * rng.next_f64() as f32, rng.next_gaussian()]).collect();
    let mut labels_out = vec![0u8; 300];
    model.classify_block(&mut probes.clone(), &mut labels_out).unwrap();
    // The reference: every pair's value, then the vote among the allowed classes.
    let allowed = model.allowed_sets(&probes, 2);
    let mut values = vec![0f32; 300 * model.pairs.len()];
    model.pair_values_block(&probes, &[ClassSet::MAX; 300], &mut values).unwrap();
    let positions: Vec<(usize, usize)> =
        model.pairs.iter().map(|pair| (pair.classes.0 as usize - 1, pair.classes.1 as usize - 1)).collect();
    let (mut votes, mut strength) = ([0u32; 4], [0f32; 4]);
    let expected: Vec<u8> = allowed
        .iter()
        .zip(values.chunks_exact(model.pairs.len()))
        .map(|(&set, values)| match set.count_ones() {
            0 => 0,
            1 => set.trailing_zeros() as u8 + 1,
            _ => {
                classify::tally_votes_among(&positions, values, set, &mut votes, &mut strength);
                classify::vote_winner(&votes, &strength) as u8 + 1
            }
        })
        .collect();
    assert_eq!(labels_out, expected);
    let sizes: Vec<u32> = allowed.iter().map(|set| set.count_ones()).collect();
    assert!(sizes.contains(&2) && sizes.contains(&3), "the probes were meant to leave two and three classes");
    assert!([1, 2, 3].iter().all(|class| labels_out.contains(class)));
}

#[test]
fn a_voxel_beyond_every_band_is_voted_on_at_the_drawn_range_s_end_with_its_own_gradient() {
    let (raw, labels) = samples();
    let bands = vec![Band { low: -10.0, high: 10.0 }, Band { low: 5.0, high: 40.0 }];
    let (raw, labels): (Vec<f32>, Vec<u8>) = (raw[..160].to_vec(), labels[..80].to_vec());
    let model = PairwiseSnSvm::train(
        &raw,
        &Scaling::weighted(vec![1.0; 2]),
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
        &Scaling::weighted(vec![1.0; 2]),
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
        &Scaling::weighted(vec![1.0; 2]),
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

#[test]
fn pair_values_of_a_misshapen_block_are_an_error_not_a_panic() {
    let model = four_classes(IntensityGate::open(4));
    let features = [0.0f32, 0.1, 1.0, 0.2, 2.0];
    let mut values = vec![0f32; 2 * model.pairs.len()];
    let odd = model.pair_values_block(&features, &[ClassSet::MAX; 2], &mut values);
    assert!(matches!(odd, Err(SegmentationError::Classify(classify::ClassifyError::FeatureBlockShape { .. }))));
    let short = model.pair_values_block(&features[..4], &[ClassSet::MAX; 2], &mut values[..3]);
    assert!(matches!(short, Err(SegmentationError::Classify(classify::ClassifyError::OutputBlockShape { .. }))));
    assert!(model.pair_values_block(&features[..4], &[ClassSet::MAX; 2], &mut values).is_ok());
}
