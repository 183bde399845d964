//! One-vs-one training: accuracy, order independence, input errors, and a hand-run timing.

use std::time::Instant;

use super::*;
use crate::classify::params::SnSvmParams;
use crate::classify::test_support::{SplitMix64, blobs};

fn samples(values: Vec<f64>) -> SampleMatrix {
    SampleMatrix { dim: 5, values }
}

fn defaults() -> SnSvmValidParams {
    SnSvmParams::default().check().unwrap()
}

fn to_f32(values: &[f64]) -> Vec<f32> {
    values.iter().map(|&v| v as f32).collect()
}

#[test]
fn separable_classes_are_all_recovered_by_voting() {
    for classes in [3, 4] {
        for params in [SnSvmParams::default(), SnSvmParams::plain_svm()] {
            let mut rng = SplitMix64::new(classes as u64);
            let (values, labels) = blobs(&mut rng, classes, 40, 5, 6.0);
            let model = train(&samples(values.clone()), &labels, &params.check().unwrap()).unwrap();
            assert_eq!(model.class_ids(), &(1..=classes as u8).collect::<Vec<_>>()[..]);
            assert_eq!(model.pairs().len(), classes * (classes - 1) / 2);
            assert_eq!(model.report().pairs.len(), model.pairs().len());
            assert!(!model.report().hit_cap());
            let mut predicted = vec![0u8; labels.len()];
            model.predict_block(&to_f32(&values), &mut predicted).unwrap();
            assert_eq!(predicted, labels, "100% training accuracy, {classes} classes, eta {}", params.eta);
        }
    }
}

#[test]
fn overlapping_classes_train_and_plain_svm_keeps_only_support_vectors() {
    let mut rng = SplitMix64::new(12);
    let (values, labels) = blobs(&mut rng, 3, 150, 5, 1.5);
    let plain = train(&samples(values.clone()), &labels, &SnSvmParams::plain_svm().check().unwrap()).unwrap();
    let support: usize = plain.report().pairs.iter().map(|p| p.support_vectors).sum();
    assert!(plain.training_point_count() < labels.len(), "non-support vectors dropped");
    assert!(plain.training_point_count() <= support);
    let sn = train(&samples(values.clone()), &labels, &defaults()).unwrap();
    assert_eq!(sn.training_point_count(), labels.len(), "gamma is dense for eta > 0");
    let mut predicted = vec![0u8; labels.len()];
    sn.predict_block(&to_f32(&values), &mut predicted).unwrap();
    let correct = predicted.iter().zip(&labels).filter(|(a, b)| a == b).count();
    assert!(correct as f64 > 0.8 * labels.len() as f64, "training accuracy {correct}/{}", labels.len());
}

#[test]
fn duplicated_samples_become_one_expansion_point() {
    let mut rng = SplitMix64::new(13);
    let (values, labels) = blobs(&mut rng, 2, 30, 5, 2.0);
    // Each sample twice: one expansion point per distinct vector remains.
    let doubled_values: Vec<f64> = values.iter().chain(&values).copied().collect();
    let doubled_labels: Vec<u8> = labels.iter().chain(&labels).copied().collect();
    let doubled = train(&samples(doubled_values), &doubled_labels, &defaults()).unwrap();
    assert_eq!(doubled.training_point_count(), labels.len());
    assert_eq!(doubled.report().samples, 2 * labels.len());
    assert_eq!(doubled.report().expansion_points, labels.len());
    let mut predicted = vec![0u8; labels.len()];
    doubled.predict_block(&to_f32(&values), &mut predicted).unwrap();
    assert_eq!(predicted, labels);
}

#[test]
fn model_does_not_depend_on_the_order_of_samples() {
    let mut rng = SplitMix64::new(15);
    let (values, labels) = blobs(&mut rng, 3, 40, 5, 1.5);
    let params = SnSvmParams { tolerance: 1e-10, ..SnSvmParams::default() }.check().unwrap();
    let model = train(&samples(values.clone()), &labels, &params).unwrap();
    let order = rng.permutation(labels.len());
    let shuffled_values: Vec<f64> = order.iter().flat_map(|&i| values[i * 5..(i + 1) * 5].to_vec()).collect();
    let shuffled_labels: Vec<u8> = order.iter().map(|&i| labels[i]).collect();
    let shuffled = train(&samples(shuffled_values), &shuffled_labels, &params).unwrap();
    let mut test = SplitMix64::new(16);
    for _ in 0..40 {
        let x: Vec<f64> = (0..5).map(|_| 2.0 * test.normal()).collect();
        let (a, b) = (model.decision_values_exact(&x).unwrap(), shuffled.decision_values_exact(&x).unwrap());
        for (u, v) in a.iter().zip(&b) {
            assert!((u - v).abs() < 1e-6, "{a:?} vs {b:?}");
        }
    }
}

#[test]
fn training_twice_gives_the_same_bits() {
    // Same strokes, same labels: parallel linear algebra must not make the model drift.
    let mut rng = SplitMix64::new(17);
    let (values, labels) = blobs(&mut rng, 3, 150, 5, 1.5);
    let first = train(&samples(values.clone()), &labels, &defaults()).unwrap();
    let second = train(&samples(values), &labels, &defaults()).unwrap();
    assert_eq!(first.coefficients(), second.coefficients());
    assert_eq!(first.biases(), second.biases());
    assert_eq!(first.report(), second.report());
}

#[test]
fn identical_feature_vectors_across_classes_do_not_hang() {
    let values = vec![0.5; 5 * 60];
    let labels: Vec<u8> = (0..60).map(|i| if i < 35 { 1 } else { 2 }).collect();
    let model = train(&samples(values), &labels, &defaults()).unwrap();
    assert!(!model.report().hit_cap());
    let mut predicted = [0u8; 1];
    model.predict_block(&[0.5; 5], &mut predicted).unwrap();
    assert!(predicted[0] == 1 || predicted[0] == 2);
}

#[test]
fn bad_input_gives_the_right_error() {
    let params = defaults();
    let one_class = train(&samples(vec![0.0; 10]), &[1, 1], &params);
    assert_eq!(one_class.err(), Some(ClassifyError::TooFewClasses { found: 1, class_ids: vec![1] }));
    let none = train(&samples(Vec::new()), &[], &params);
    assert_eq!(none.err(), Some(ClassifyError::TooFewClasses { found: 0, class_ids: vec![] }));
    let empty = train_with_classes(&samples(vec![0.0; 15]), &[1, 2, 1], &[1, 2, 3], &params);
    assert_eq!(empty.err(), Some(ClassifyError::EmptyClass { class_id: 3 }));
    let unknown = train_with_classes(&samples(vec![0.0; 15]), &[1, 2, 4], &[1, 2, 3], &params);
    assert!(matches!(unknown, Err(ClassifyError::UnknownLabel { sample: 2, label: 4, .. })));
    let duplicate = train_with_classes(&samples(vec![0.0; 10]), &[1, 2], &[1, 2, 2], &params);
    assert_eq!(duplicate.err(), Some(ClassifyError::DuplicateClass { class_id: 2 }));
    let zero_class = train_with_classes(&samples(vec![0.0; 10]), &[1, 2], &[0, 1, 2], &params);
    assert_eq!(zero_class.err(), Some(ClassifyError::BackgroundClass));
    let mut values = vec![0.0; 15];
    values[7] = f64::NAN;
    let nan = train(&samples(values), &[1, 2, 1], &params);
    assert!(matches!(nan, Err(ClassifyError::NonFiniteSample { sample: 1, feature: 2, .. })));
    let mut values = vec![0.0; 15];
    values[14] = f64::NEG_INFINITY;
    let infinite = train(&samples(values), &[1, 2, 1], &params);
    assert!(matches!(infinite, Err(ClassifyError::NonFiniteSample { sample: 2, feature: 4, .. })));
    let background = train(&samples(vec![0.0; 15]), &[1, 0, 2], &params);
    assert_eq!(background.err(), Some(ClassifyError::BackgroundLabel { sample: 1 }));
    let count = train(&samples(vec![0.0; 15]), &[1, 2], &params);
    assert_eq!(count.err(), Some(ClassifyError::LabelCount { labels: 2, samples: 3 }));
    let ragged = train(&samples(vec![0.0; 14]), &[1, 2], &params);
    assert_eq!(ragged.err(), Some(ClassifyError::RaggedSamples { values: 14, dim: 5 }));
    let zero_dim = train(&SampleMatrix { dim: 0, values: vec![] }, &[], &params);
    assert_eq!(zero_dim.err(), Some(ClassifyError::ZeroDimension));
    let too_large =
        train(&samples(vec![0.0; 5 * (MAX_POINTS_PER_PAIR + 1)]), &vec![1; MAX_POINTS_PER_PAIR + 1], &params);
    assert!(too_large.is_err());
    let mut labels = vec![1u8; MAX_POINTS_PER_PAIR + 1];
    labels[0] = 2;
    let too_large = train(&samples(vec![0.0; 5 * (MAX_POINTS_PER_PAIR + 1)]), &labels, &params);
    assert!(matches!(too_large, Err(ClassifyError::PairTooLarge { points, .. }) if points == MAX_POINTS_PER_PAIR + 1));
}

#[test]
fn model_can_be_shared_across_threads() {
    fn shareable<T: Send + Sync>() {}
    shareable::<Model>();
}

/// On-CPU time of this thread (Linux schedstat), so that figures taken on a busy shared machine
/// still mean something; NaN elsewhere.
fn thread_cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|text| text.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(f64::NAN, |nanoseconds| nanoseconds * 1e-9)
}

/// User + system CPU time of the whole process (Linux /proc, clock ticks of 10 ms); NaN elsewhere.
fn process_cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|text| {
            // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
            let rest = text.rsplit_once(')')?.1;
            let fields: Vec<&str> = rest.split_whitespace().collect();
            let user: f64 = fields.get(11)?.parse().ok()?;
            let system: f64 = fields.get(12)?.parse().ok()?;
            Some((user + system) / 100.0)
        })
        .unwrap_or(f64::NAN)
}

/// Hand-run figures: `cargo test --release --lib classify::ovo::tests::timing -- --ignored --nocapture`.
#[test]
#[ignore = "timing, run by hand in release mode"]
fn timing_train() {
    let params = defaults();
    for classes in [2, 3, 4] {
        for per_class in [200, 500, 1000] {
            let mut rng = SplitMix64::new(77);
            let (values, labels) = blobs(&mut rng, classes, per_class, 5, 1.5);
            let (start, start_cpu) = (Instant::now(), process_cpu_seconds());
            let model = train(&samples(values), &labels, &params).unwrap();
            let seconds = start.elapsed().as_secs_f64();
            let cpu_seconds = process_cpu_seconds() - start_cpu;
            let iterations: usize = model.report().pairs.iter().map(|p| p.iterations).sum();
            println!(
                "train {classes} classes x {per_class} points/class, dim 5: {seconds:.3} s wall, {cpu_seconds:.2} CPU-s ({} pairs, {iterations} SMO steps)",
                model.pairs().len()
            );
        }
    }
}

#[test]
#[ignore = "timing, run by hand in release mode"]
fn timing_predict() {
    for params in [SnSvmParams::default(), SnSvmParams::plain_svm()] {
        let mut rng = SplitMix64::new(78);
        let (values, labels) = blobs(&mut rng, 3, 200, 5, 1.5);
        let model = train(&samples(values), &labels, &params.check().unwrap()).unwrap();
        let count = 1_000_000;
        let features: Vec<f32> = (0..count * 5).map(|_| (2.0 * rng.normal()) as f32).collect();
        let mut labels_out = vec![0u8; count];
        // Best of three: the machine is shared, and on-CPU time still includes cache and
        // hyper-thread contention.
        let (mut single, mut single_cpu, mut parallel) = (f64::MAX, f64::MAX, f64::MAX);
        for _ in 0..3 {
            let (start, start_cpu) = (Instant::now(), thread_cpu_seconds());
            model.predict_block(&features, &mut labels_out).unwrap();
            single = single.min(start.elapsed().as_secs_f64());
            single_cpu = single_cpu.min(thread_cpu_seconds() - start_cpu);
            let start = Instant::now();
            model.predict_block_parallel(&features, &mut labels_out).unwrap();
            parallel = parallel.min(start.elapsed().as_secs_f64());
        }
        println!(
            "predict eta {}: N_tot {}, 3 classes, dim 5: {:.0} voxels/s single-threaded ({:.0} per on-CPU second), {:.0} voxels/s on {} threads",
            params.eta,
            model.training_point_count(),
            count as f64 / single,
            count as f64 / single_cpu,
            count as f64 / parallel,
            rayon::current_num_threads()
        );
    }
}
