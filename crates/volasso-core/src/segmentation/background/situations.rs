//! The background rule on stored 8- and 16-bit scans of the kinds it meets: a scan of air with
//! one small, very bright structure, an MRI whose air is noise under a bias field, and a CT
//! stored as integers with a rescale intercept; each with clean and leaky lassos, and labelled
//! end to end where the plan alone does not show the picture.

use super::tests::{classed, labelled};
use super::*;
use crate::rng::{gaussian_from_bits, hash64};
use crate::strokes::ClassSamples;
use crate::volume::{ByteOrder, ValueScale, VoxelBytes, VoxelType};
use std::path::Path;

const DIMS: [usize; 3] = [48, 48, 24];

fn index(x: usize, y: usize, z: usize) -> usize {
    x + DIMS[0] * (y + DIMS[1] * z)
}

/// A volume of `DIMS` stored as `voxel_type` (little-endian), from stored values.
fn stored(voxel_type: VoxelType, scale: ValueScale, value: impl Fn(usize, usize, usize) -> f64) -> Volume {
    let mut bytes = Vec::new();
    for z in 0..DIMS[2] {
        for y in 0..DIMS[1] {
            for x in 0..DIMS[0] {
                let v = value(x, y, z);
                match voxel_type {
                    VoxelType::U8 => bytes.push(v.round().clamp(0.0, 255.0) as u8),
                    VoxelType::U16 => bytes.extend((v.round().clamp(0.0, 65535.0) as u16).to_le_bytes()),
                    VoxelType::I16 => bytes.extend((v.round().clamp(-32768.0, 32767.0) as i16).to_le_bytes()),
                    other => panic!("no test volume of {other:?}"),
                }
            }
        }
    }
    Volume::new(DIMS, [1.0; 3], voxel_type, ByteOrder::Little, scale, VoxelBytes::Owned(bytes), Path::new("stored"))
        .unwrap()
}

/// A class of the voxels of the box `x`, `y` on plane 12, one stroke.
fn class(x: std::ops::Range<usize>, y: std::ops::Range<usize>) -> ClassSamples {
    let mut voxels: Vec<usize> = y.flat_map(|y| x.clone().map(move |x| index(x, y, 12))).collect();
    voxels.sort_unstable();
    ClassSamples::one_stroke("class".into(), voxels)
}

fn training(classes: Vec<ClassSamples>) -> TrainingSet {
    TrainingSet { classes, contested_voxels: 0 }
}

/// 8-bit: air 0..5 (nearly all of it), a dim ball (35..45) and a small, very bright rod
/// (245..255).
fn air_ball_rod() -> Volume {
    stored(VoxelType::U8, ValueScale::IDENTITY, |x, y, z| {
        let noise = (hash64(3, index(x, y, z) as u64) % 11) as f64 - 5.0;
        let (xf, yf, zf) = (x as f64, y as f64, z as f64);
        let ball = (xf - 16.0).powi(2) + (yf - 24.0).powi(2) + (2.0 * zf - 24.0).powi(2) < 100.0;
        let rod = (xf - 36.0).powi(2) + (yf - 24.0).powi(2) < 6.0 && (4..20).contains(&z);
        if rod {
            250.0 + noise
        } else if ball {
            40.0 + noise
        } else {
            noise.abs()
        }
    })
}

#[test]
fn a_small_very_bright_structure_does_not_make_the_tissues_air() {
    let volume = air_ball_rod();
    // The case: Otsu splits the rod off, with the ball on the air's side.
    assert!(volume.otsu_threshold() > 45.0, "{}", volume.otsu_threshold());
    // Clean lassos inside the ball and the rod; then a leaky one around the ball that takes
    // in the air beside it (x 2..7).
    for (ball, leaked) in [(class(13..19, 22..26), 0), (class(2..19, 22..26), 5 * 4)] {
        let set = training(vec![ball, class(35..38, 23..26)]);
        let (cleaned, plan) = super::plan(&volume, &set, Background::Automatic);
        assert!(!plan.air_is_a_class);
        let threshold = plan.threshold.expect("a level");
        assert!(threshold < 35.0, "below the ball: {threshold}");
        assert_eq!((cleaned, plan.dropped_per_class), (set.clone(), vec![0, 0]), "{leaked} air voxels trained");

        let labels = labelled(&volume, &set);
        let (air_labelled, air) = classed(&labels, |i| volume.value(i) <= 5.0);
        assert!(air_labelled * 100 < air, "{air_labelled} of {air} air voxels have a class");
        assert_eq!(labels[index(16, 24, 12)], 1, "the ball's centre");
        assert_eq!(labels[index(36, 24, 12)], 2, "the rod's centre");
    }
}

#[test]
fn a_loop_drawn_in_the_air_beside_a_bright_structure_is_still_the_air() {
    let volume = air_ball_rod();
    let set = training(vec![class(2..12, 2..8), class(13..19, 22..26)]);
    let (cleaned, plan) = super::plan(&volume, &set, Background::Automatic);
    assert!(plan.air_is_a_class && super::tests::keeps_every_other_class(&volume, &cleaned, &plan));
}

/// An MRI's air at voxel `i`: the magnitude of complex Gaussian noise (Rayleigh, about 20).
fn rayleigh_air(i: u64) -> f64 {
    let (a, b) = (f64::from(gaussian_from_bits(hash64(2, i))), f64::from(gaussian_from_bits(hash64(3, i))));
    16.0 * (a * a + b * b).sqrt()
}

/// 16-bit MRI: air is Rayleigh-like noise (about 20) under a bias field that doubles from x = 0
/// to the far face, a head (an ellipse through every z plane, cut by the z faces) of tissue at
/// 600 with a brighter core at 900.
fn mri_head() -> Volume {
    stored(VoxelType::U16, ValueScale::IDENTITY, |x, y, z| {
        let i = index(x, y, z) as u64;
        let bias = 1.0 + x as f64 / DIMS[0] as f64;
        let (dx, dy) = ((x as f64 - 24.0) / 18.0, (y as f64 - 24.0) / 20.0);
        let radius = (dx * dx + dy * dy).sqrt();
        let base = if radius < 0.5 {
            900.0 + 30.0 * f64::from(gaussian_from_bits(hash64(1, i)))
        } else if radius < 1.0 {
            600.0 + 30.0 * f64::from(gaussian_from_bits(hash64(1, i)))
        } else {
            rayleigh_air(i)
        };
        base * bias
    })
}

#[test]
fn an_mri_with_noisy_biased_air_keeps_the_air_background() {
    let volume = mri_head();
    // The outer tissue's lasso leaks over the head's edge at x = 6 into the air (x 2..6); the
    // core's is clean.
    let set = training(vec![class(2..12, 20..28), class(22..27, 22..27)]);
    let (_, plan) = super::plan(&volume, &set, Background::Automatic);
    assert!(!plan.air_is_a_class);
    let labels = labelled(&volume, &set);
    let outside = |x: usize, y: usize| ((x as f64 - 24.0) / 18.0).powi(2) + ((y as f64 - 24.0) / 20.0).powi(2) > 1.2;
    let (air_labelled, air) = classed(&labels, |i| outside(index_x(i), i / DIMS[0] % DIMS[1]));
    assert!(air_labelled * 100 < air, "{air_labelled} of {air} air voxels have a class");
    assert_eq!(labels[index(10, 24, 12)], 1, "the outer tissue");
    assert_eq!(labels[index(24, 24, 12)], 2, "the core");
}

#[test]
fn a_ct_stored_as_integers_with_an_intercept_keeps_its_air_and_lungs_apart() {
    // int16 stored 0..=2024 with intercept -1024 (HU): air -1000, body 40, a lung at -850 cut
    // by the z = 0 face, bone 1000.
    let volume = stored(VoxelType::I16, ValueScale { slope: 1.0, intercept: -1024.0 }, |x, y, z| {
        let noise = 10.0 * f64::from(gaussian_from_bits(hash64(4, index(x, y, z) as u64)));
        let body = (8..40).contains(&x) && (8..40).contains(&y);
        let lung = (12..20).contains(&x) && (12..36).contains(&y) && z < 16;
        let bone = (28..34).contains(&x) && (16..30).contains(&y);
        let hu = match (body, lung, bone) {
            (false, _, _) => -1000.0,
            (true, true, _) => -850.0,
            (true, false, true) => 1000.0,
            _ => 40.0,
        };
        hu + noise + 1024.0
    });
    // Lung and bone: the lung is a class, the air outside is not.
    let set = training(vec![class(13..19, 14..34), class(29..33, 18..28)]);
    let (_, plan) = super::plan(&volume, &set, Background::Automatic);
    let threshold = plan.threshold.expect("a level");
    assert!(!plan.air_is_a_class && (-960.0..-880.0).contains(&threshold), "{threshold}");
    // Soft tissue and bone: Otsu's level, the lung is background with the air.
    let set = training(vec![class(21..27, 14..34), class(29..33, 18..28)]);
    let (_, plan) = super::plan(&volume, &set, Background::Automatic);
    assert_eq!(plan.threshold.map(|t| t > -700.0), Some(true), "{:?}", plan.threshold);
}

/// int16 CT with intercept -1024 (HU), mostly air (-1000, noise 60) around a body (40) with a
/// bone (1000); along the body's low-x side a layer of foam whose edge is blurred into the air
/// (-850, -700, -600 and -550 HU from x = 4 to 7), joined to the air and darker than Otsu's
/// level, as a phantom's foam or a patient's bedding is.
fn air_foam_body() -> Volume {
    stored(VoxelType::I16, ValueScale { slope: 1.0, intercept: -1024.0 }, |x, y, z| {
        let noise = f64::from(gaussian_from_bits(hash64(5, index(x, y, z) as u64)));
        let inside = (8..40).contains(&y);
        let hu = match x {
            4..=7 if inside => [-850.0, -700.0, -600.0, -550.0][x - 4] + 10.0 * noise,
            8..40 if inside && (28..34).contains(&x) && (16..30).contains(&y) => 1000.0 + 10.0 * noise,
            8..40 if inside => 40.0 + 10.0 * noise,
            _ => -1000.0 + 60.0 * noise,
        };
        hu + 1024.0
    })
}

#[test]
fn a_dark_layer_joined_to_the_air_drawn_off_centre_is_a_class_and_the_air_stays_background() {
    let volume = air_foam_body();
    let otsu = volume.otsu_threshold();
    let split = volume.split_below(otsu).expect("a split below Otsu's level");
    // The case: the foam lies in the face air at Otsu's level, and its few voxels leave the
    // split below it short of two clear populations by Otsu's measure.
    assert!(otsu > -500.0 && split.separability < SEPARATE_POPULATIONS, "{otsu} {split:?}");
    // A finger off-centre: the foam's loop takes in two columns of air (x 2..4) beside its
    // four.
    let set = training(vec![class(2..8, 14..34), class(20..26, 14..34), class(29..33, 18..28)]);
    let (_, plan) = super::plan(&volume, &set, Background::Automatic);
    assert!(!plan.air_is_a_class, "the foam is not the air");
    let threshold = plan.threshold.expect("a level");
    assert!(threshold > -1000.0 && threshold < -550.0, "{threshold}");

    let labels = labelled(&volume, &set);
    let (air_labelled, air) = classed(&labels, |i| index_x(i) < 3);
    assert!(air_labelled * 20 < air, "{air_labelled} of {air} air voxels have a class");
    assert_eq!(labels[index(6, 24, 12)], 1, "the foam");
    assert_eq!(labels[index(22, 24, 12)], 2, "the body");
}

fn index_x(voxel: usize) -> usize {
    voxel % DIMS[0]
}

#[test]
fn a_loop_drawn_in_an_mri_s_air_where_the_bias_field_brightens_it_is_still_the_air() {
    // The air at x 40..46 is nearly twice as bright as at x = 0, but its values are the noise
    // on the faces, not a dark tissue above them.
    let volume = mri_head();
    let set = training(vec![class(40..46, 2..8), class(22..27, 22..27)]);
    let (cleaned, plan) = super::plan(&volume, &set, Background::Automatic);
    assert!(
        plan.air_is_a_class && super::tests::keeps_every_other_class(&volume, &cleaned, &plan),
        "{:?}",
        plan.threshold
    );
}

/// 16-bit MRI of the side of a head, as a T1 scan whose faces cut the head: Rayleigh-like air
/// (about 20, x < 12), bright scalp (800, x 12..15), a dark skull three voxels thick (150,
/// x 15..18; below Otsu's level and joined to the faces that cut it) and brain (600) beyond.
fn mri_head_side() -> Volume {
    stored(VoxelType::U16, ValueScale::IDENTITY, |x, y, z| {
        let i = index(x, y, z) as u64;
        let tissue = |value: f64| value + 30.0 * f64::from(gaussian_from_bits(hash64(1, i)));
        match x {
            0..12 => rayleigh_air(i),
            12..15 => tissue(800.0),
            15..18 => tissue(150.0),
            _ => tissue(600.0),
        }
    })
}

#[test]
fn a_dark_skull_drawn_with_a_finger_s_leak_is_a_class_and_the_air_stays_background() {
    let volume = mri_head_side();
    // The case: the skull lies below Otsu's level, in the face air.
    assert!(volume.otsu_threshold() > 200.0, "{}", volume.otsu_threshold());
    // The skull's loop (x 13..20) reaches two voxels into the scalp and the brain on each side
    // of the skull: less than half of it lies in the face air, its core is the skull.
    let set = training(vec![class(13..20, 12..36), class(26..36, 16..32)]);
    let (_, plan) = super::plan(&volume, &set, Background::Automatic);
    assert!(!plan.air_is_a_class);
    let threshold = plan.threshold.expect("a level");
    assert!((40.0..110.0).contains(&threshold), "between the air and the skull: {threshold}");

    let labels = labelled(&volume, &set);
    let (air_labelled, air) = classed(&labels, |i| index_x(i) < 10);
    assert!(air_labelled * 20 < air, "{air_labelled} of {air} air voxels have a class");
    let skull: Vec<usize> = (0..DIMS[2]).flat_map(|z| (0..DIMS[1]).map(move |y| index(16, y, z))).collect();
    let labelled_skull = skull.iter().filter(|&&i| labels[i] == 1).count();
    assert!(labelled_skull * 10 >= skull.len() * 9, "{labelled_skull} of {} skull voxels", skull.len());
}
