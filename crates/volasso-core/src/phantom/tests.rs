use super::anatomy::{AIR, BONE, JOINT, SOFT_TISSUE};
use super::*;
use crate::features::{FeatureSet, Standardiser, features_of_voxels};
use crate::strokes::TrainingSet;
use rayon::prelude::*;

#[test]
fn demo_foot_is_deterministic_and_has_every_class() {
    let started = std::time::Instant::now();
    let phantom = demo_foot();
    println!(
        "demo foot {:?}: generated in {:.3} s on {} threads",
        phantom.volume.dims,
        started.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    assert_eq!(phantom.volume.dims, DEMO_FOOT_DIMS);
    assert_eq!(phantom.volume.voxel_type, VoxelType::I16);
    assert_eq!(phantom.volume.spacing_mm, [0.8, 0.8, 1.2]);
    assert_eq!(phantom.truth.len(), phantom.volume.voxel_count());
    let again = demo_foot();
    assert_eq!(phantom.volume.raw_bytes(), again.volume.raw_bytes());
    assert_eq!(phantom.truth, again.truth);
    let counts = phantom.class_voxel_counts();
    println!("voxels per class {:?}: {counts:?}", phantom.class_names);
    assert_eq!(phantom.class_names, ["air", "soft tissue", "bone", "joint"]);
    assert!(counts.iter().all(|&c| c > 3000), "{counts:?}");
}

/// The median HU of the voxels of `class` (after blur and noise).
fn median_hounsfield(phantom: &Phantom, class: u8) -> f64 {
    let mut values: Vec<f64> =
        (0..phantom.truth.len()).filter(|&i| phantom.truth[i] == class).map(|i| phantom.volume.value(i)).collect();
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

#[test]
fn tissues_have_ct_like_values_and_the_seed_changes_only_the_noise() {
    let phantom = demo_foot_with([96, 64, 48], 1).unwrap();
    let other_seed = demo_foot_with([96, 64, 48], 2).unwrap();
    assert_eq!(phantom.truth, other_seed.truth);
    assert_ne!(phantom.volume.raw_bytes(), other_seed.volume.raw_bytes());
    assert_eq!(phantom.volume.spacing_mm, [1.6, 1.6, 2.4]);
    let air = median_hounsfield(&phantom, AIR);
    let soft_tissue = median_hounsfield(&phantom, SOFT_TISSUE);
    let bone = median_hounsfield(&phantom, BONE);
    assert!((-1010.0..=-990.0).contains(&air), "air {air}");
    assert!((-20.0..=60.0).contains(&soft_tissue), "soft tissue {soft_tissue}");
    assert!((250.0..=1000.0).contains(&bone), "bone {bone}");
    let range = phantom.volume.value_range();
    assert!(range.min >= -1100.0 && range.max >= 1000.0 && range.max <= 1800.0, "{range:?}");
    // Noise: neighbouring air voxels differ, by about sqrt(2) x 12 HU.
    let differences: Vec<f64> = (0..2000).map(|i| phantom.volume.value(i + 1) - phantom.volume.value(i)).collect();
    let deviation = (differences.iter().map(|d| d * d).sum::<f64>() / 2000.0).sqrt();
    assert!((12.0..=22.0).contains(&deviation), "air noise {deviation}");
}

#[test]
fn joint_space_lies_between_bones() {
    let phantom = demo_foot();
    let dims = phantom.volume.dims;
    // Along each axis, a joint voxel has bone on both sides within 3 mm (it is a gap between
    // articular surfaces, not a coating).
    let mut between = 0;
    let mut joints = 0;
    for z in 1..dims[2] - 1 {
        for y in 1..dims[1] - 1 {
            for x in 1..dims[0] - 1 {
                let index = phantom.volume.index(x, y, z);
                if phantom.truth[index] != JOINT {
                    continue;
                }
                joints += 1;
                let steps = [1, dims[0], dims[0] * dims[1]];
                let reach = [4, 4, 3];
                let sandwiched = (0..3).any(|axis| {
                    let bone_within = |sign: i64| {
                        (1..=reach[axis]).any(|k| {
                            let at = index as i64 + sign * (k * steps[axis]) as i64;
                            at >= 0 && phantom.truth.get(at as usize) == Some(&BONE)
                        })
                    };
                    bone_within(1) && bone_within(-1)
                });
                between += sandwiched as usize;
            }
        }
    }
    assert!(between as f64 > 0.8 * joints as f64, "{between} of {joints}");
}

#[test]
fn small_and_invalid_sizes() {
    let tiny = demo_foot_with([8, 6, 5], 0).unwrap();
    assert_eq!(tiny.truth.len(), 240);
    assert!(demo_foot_with([0, 6, 5], 0).is_err());
}

#[test]
fn blur_keeps_constants_and_spreads_a_spike_by_one_sixth_eighth() {
    let mut values = vec![0f32; 12];
    values[3] = 8.0;
    values[11] = 8.0; // the edge is clamped: 1/8 (8 + 6 x 8 + 0) = 7
    blur_rows(&mut values, 6, 1);
    assert_eq!(values, [0.0, 0.0, 1.0, 6.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 7.0]);
    let mut plane = vec![3f32; 12];
    blur_rows(&mut plane, 12, 4);
    assert_eq!(plane, vec![3f32; 12]);
    let mut column = vec![0f32; 12];
    column[4] = 8.0; // (x 0, y 1) in a 4 x 3 plane
    blur_rows(&mut column, 12, 4);
    assert_eq!((column[0], column[4], column[8]), (1.0, 6.0, 1.0));
}

#[test]
fn dice_counts_overlap() {
    let truth = [0, 1, 1, 2, 2, 2];
    let labels = [0, 1, 2, 2, 2, 1];
    assert_eq!(dice(&truth, &labels, 1), 0.5);
    assert_eq!(dice(&truth, &labels, 2), 2.0 * 2.0 / 6.0);
    assert_eq!(dice(&truth, &labels, 7), 1.0);
}

/// Labels of the voxels `evaluated` by the `k` nearest standardised training vectors
/// (majority, ties to the lower class): a stand-in classifier that needs no training, to check
/// that the phantom's classes are within reach of the paper's features.
fn nearest_neighbour_labels(phantom: &Phantom, training: &TrainingSet, evaluated: &[usize], k: usize) -> Vec<u8> {
    let (voxels, labels) = training.labelled_voxels();
    let mut train = features_of_voxels(&phantom.volume, FeatureSet::Paper5, &voxels).unwrap();
    let standardiser = Standardiser::fit(&train, 5).unwrap();
    standardiser.apply_in_place(&mut train).unwrap();
    let mut features = features_of_voxels(&phantom.volume, FeatureSet::Paper5, evaluated).unwrap();
    standardiser.apply_in_place(&mut features).unwrap();
    let classes = training.classes.len();
    features
        .par_chunks_exact(5)
        .map(|f| {
            let mut best = vec![(f32::INFINITY, 0u8); k];
            for (t, &label) in train.chunks_exact(5).zip(&labels) {
                let d: f32 = f.iter().zip(t).map(|(a, b)| (a - b) * (a - b)).sum();
                if d < best[k - 1].0 {
                    best[k - 1] = (d, label);
                    best.sort_by(|a, b| a.0.total_cmp(&b.0));
                }
            }
            let mut votes = vec![0usize; classes + 1];
            best.iter().for_each(|&(_, label)| votes[label as usize] += 1);
            (1..=classes).max_by_key(|&c| (votes[c], std::cmp::Reverse(c))).unwrap_or(1) as u8
        })
        .collect()
}

/// Dice of each of `classes` over the voxels `evaluated`, when label k means `classes[k - 1]`.
fn dice_per_class(phantom: &Phantom, classes: &[u8], evaluated: &[usize], predicted: &[u8]) -> Vec<f64> {
    let truth: Vec<u8> = evaluated.iter().map(|&v| phantom.truth[v]).collect();
    let mapped: Vec<u8> = predicted.iter().map(|&label| classes[label as usize - 1]).collect();
    classes.iter().map(|&class| dice(&truth, &mapped, class)).collect()
}

/// Trains the stand-in classifier on lassos inside each of `classes` on the top-entropy
/// slices and scores it on every `stride`-th voxel.
fn separability(phantom: &Phantom, classes: &[u8], stride: usize) -> Vec<f64> {
    let mut strokes = lassos_inside(phantom, classes, 4, 2.5);
    if let Some(position) = classes.iter().position(|&c| c == JOINT) {
        // The joint space is too thin for an octagon of 2.5 pixels: tiny lassos along it,
        // each around one voxel of its mid-line.
        let thin = lassos_inside(phantom, &[JOINT], 40, 0.6);
        strokes.classes[position] = thin.classes[0].clone();
    }
    let training = TrainingSet::from_strokes(&strokes, phantom.volume.dims).unwrap().capped(150, 11);
    let evaluated: Vec<usize> = (0..phantom.truth.len()).step_by(stride).collect();
    let predicted = nearest_neighbour_labels(phantom, &training, &evaluated, 5);
    dice_per_class(phantom, classes, &evaluated, &predicted)
}

#[test]
fn air_soft_tissue_and_bone_are_separable_from_lassos_inside_them() {
    let phantom = demo_foot();
    let scores = separability(&phantom, &[AIR, SOFT_TISSUE, BONE], 7);
    println!("Dice air, soft tissue, bone (5-NN on Paper5, every 7th voxel): {scores:.3?}");
    assert!(scores.iter().all(|&s| s >= 0.9), "{scores:?}");
}

#[test]
#[ignore = "slow in debug; run with --release -- --ignored --nocapture to see joint separability"]
fn joint_space_with_the_paper_features() {
    let phantom = demo_foot();
    let scores = separability(&phantom, &[AIR, SOFT_TISSUE, BONE, JOINT], 1);
    println!("Dice air, soft tissue, bone, joint (5-NN on Paper5, all voxels): {scores:.3?}");
    assert!(scores[..3].iter().all(|&s| s >= 0.9), "{scores:?}");
}

#[test]
fn walking_a_row_with_distance_skips_equals_evaluating_every_voxel() {
    use super::anatomy::RowShapes;
    let spacing_mm = DEMO_FOOT_SPACING_MM;
    let mut differences = 0;
    let mut inside = 0;
    for z in (0..DEMO_FOOT_DIMS[2]).step_by(3) {
        for y in (0..DEMO_FOOT_DIMS[1]).step_by(4) {
            let (y_mm, z_mm) = (y as f64 * spacing_mm[1], z as f64 * spacing_mm[2]);
            let shapes = RowShapes::for_row(y_mm, z_mm);
            shapes.walk(y_mm, z_mm, spacing_mm[0], DEMO_FOOT_DIMS[0], |x, p, tissue| {
                assert_eq!(p[0], x as f64 * spacing_mm[0]);
                inside += (tissue != anatomy::Tissue::Air) as usize;
                differences += (shapes.tissue_at(p) != tissue) as usize;
            });
        }
    }
    assert!(inside > 10_000);
    assert_eq!(differences, 0);
}

#[test]
fn the_automatic_display_window_shows_soft_tissue_dark_and_bone_bright() {
    use crate::slices::DisplayWindow;
    let phantom = demo_foot_with([96, 64, 48], 4).unwrap();
    let window = DisplayWindow::automatic(&phantom.volume);
    println!("automatic window of the demo foot: {window:?}");
    assert_eq!(window.grey(-1000.0), 0);
    assert!(window.grey(anatomy::FAT_HU as f64) < window.grey(anatomy::MUSCLE_HU as f64));
    assert!(window.grey(anatomy::MUSCLE_HU as f64) < window.grey(anatomy::JOINT_HU as f64));
    assert!(window.grey(300.0) < 128 && window.grey(1250.0) > 200);
}
