//! Exact and coarse-to-fine labelling against each other and against voxel-by-voxel features.

use super::*;
use crate::features::FeatureSet;
use crate::segmentation::{ClassifierKind, SegmentationOptions, train};

#[test]
fn exact_labels_are_the_classes_of_every_foreground_voxels_features() {
    // The slab readers decode only the rows near foreground; whatever they skip, exact
    // labelling must give each foreground voxel the class of its own features, computed
    // here voxel by voxel from the volume, and leave the rest background; the lassoed
    // voxels keep their class.
    let phantom = crate::phantom::demo_foot_with([40, 30, 21], 5).unwrap();
    let strokes = crate::phantom::lassos_inside(&phantom, &[1, 2], 3, 2.0);
    let training = crate::strokes::TrainingSet::from_strokes(&strokes, phantom.volume.dims).unwrap();
    let volume = &phantom.volume;
    for options in [SegmentationOptions::default(), SegmentationOptions::paper(), SegmentationOptions::forest()] {
        let options = SegmentationOptions { coherence: crate::segmentation::Coherence::None, ..options };
        let segmenter = train(volume, &training, &options).unwrap();
        let threshold = segmenter.summary.background_threshold.unwrap_or(f64::NEG_INFINITY);
        let labels =
            label_volume_in(volume, &segmenter, Order::Exact, 4, &|_| {}, &AtomicBool::new(false), None).unwrap();
        let foreground: Vec<usize> =
            (0..volume.voxel_count()).filter(|&index| volume.value(index) >= threshold).collect();
        assert!(foreground.len() > 1000 && foreground.len() < volume.voxel_count());
        let mut features = crate::features::features_of_voxels(volume, options.feature_set, &foreground).unwrap();
        let mut expected = vec![0u8; foreground.len()];
        segmenter.classify_block(&mut features, &mut expected).unwrap();
        let mut expected_labels = vec![0u8; volume.voxel_count()];
        for (&index, &label) in foreground.iter().zip(&expected) {
            expected_labels[index] = label;
        }
        for &(voxel, class) in &segmenter.lassoed {
            expected_labels[voxel] = class;
        }
        assert!(labels.labels == expected_labels, "{:?}", options.feature_set);
        assert_eq!(labels.classified_voxels, foreground.len());
    }
}

#[test]
fn one_sweep_labels_as_two_passes_do() {
    // A small demo foot (an odd number of planes) with lassos inside two classes, on the
    // multi-scale features (the sweep's case): every slab depth and order gives the same
    // labels, and coarse-to-fine evaluates fewer voxels than exact labelling.
    let phantom = crate::phantom::demo_foot_with([64, 44, 33], 3).unwrap();
    let strokes = crate::phantom::lassos_inside(&phantom, &[1, 2], 4, 2.5);
    let training = crate::strokes::TrainingSet::from_strokes(&strokes, phantom.volume.dims).unwrap();
    let options = SegmentationOptions {
        feature_set: FeatureSet::MultiscaleFine,
        classifier_kind: ClassifierKind::Forest(Default::default()),
        ..SegmentationOptions::default()
    };
    let segmenter = train(&phantom.volume, &training, &options).unwrap();
    let run = |order, slab_depth| {
        label_volume_in(&phantom.volume, &segmenter, order, slab_depth, &|_| {}, &AtomicBool::new(false), None).unwrap()
    };
    let passes = run(Order::TwoPasses, 32);
    let exact = run(Order::Exact, 32);
    assert!(passes.evaluated_voxels < exact.evaluated_voxels);
    assert!(passes.labels.iter().filter(|&&label| label != 0).count() > 1000);
    for slab_depth in [2, 4, 6, 32] {
        let sweep = run(Order::OneSweep, slab_depth);
        assert!(sweep.labels == passes.labels, "slab depth {slab_depth}");
        assert_eq!(sweep.classified_voxels, exact.classified_voxels);
    }
}
