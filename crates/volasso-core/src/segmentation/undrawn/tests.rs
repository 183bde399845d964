//! Undrawn tissues: a large piece of the ventricle's class far from its loop, with the grey
//! matter's intensity, goes to the class it is nearest, or to none when it is far larger than
//! the drawn ventricle and no drawn class has its intensity, and such a piece that mixes the
//! ventricle's intensity with another loses the other's voxels; a second lung, the ventricle's
//! class's own intensity far from the loop (its few outliers too), cells of one class apart from
//! the drawn one, and anything without loops stay.

use super::*;
use crate::segmentation::tests::scene;

const DIMS: [usize; 3] = [40, 20, 20];

fn at(x: usize, y: usize, z: usize) -> usize {
    x + DIMS[0] * (y + DIMS[1] * z)
}

/// White matter (class 2, 760) everywhere, drawn at (35, 10, 10); a ventricle (class 1, 300) of
/// 4x4x4 at x 4-7 drawn at its middle; a slab of grey matter (575) at x 12-27 that the classifier
/// called `grey_label`; a scalp class (3, 650) at x 38-39, drawn.
fn brain(grey_label: u8) -> (Volume, Vec<u8>, Vec<(usize, u8)>) {
    brain_with_slab(575.0, grey_label)
}

/// [`brain`] with the slab at x 12-27 (100 times the ventricle's 64 voxels) of `value`.
fn brain_with_slab(value: f32, slab_label: u8) -> (Volume, Vec<u8>, Vec<(usize, u8)>) {
    brain_scene(|_, _, _| 300.0, |_, _, _| (value, slab_label))
}

/// The scene of [`brain`]: the ventricle's values from `ventricle`, the slab's values and labels
/// from `slab`, each given (x, y, z); the loops as [`brain`] draws them.
fn brain_scene(
    ventricle: impl Fn(usize, usize, usize) -> f32,
    slab: impl Fn(usize, usize, usize) -> (f32, u8),
) -> (Volume, Vec<u8>, Vec<(usize, u8)>) {
    let (volume, labels) = scene(DIMS, |x, y, z| {
        if (4..8).contains(&x) && (8..12).contains(&y) && (8..12).contains(&z) {
            (ventricle(x, y, z), 1)
        } else if (12..28).contains(&x) {
            slab(x, y, z)
        } else if x >= 38 {
            (650.0, 3)
        } else {
            (760.0, 2)
        }
    });
    let lassoed = vec![(at(5, 9, 9), 1), (at(6, 10, 10), 1), (at(35, 10, 10), 2), (at(39, 10, 10), 3)];
    (volume, labels, lassoed)
}

#[test]
fn a_large_piece_apart_from_the_loops_with_another_class_s_intensity_goes_to_that_class() {
    let (volume, mut labels, lassoed) = brain(1);
    let grey: Vec<usize> = (0..labels.len()).filter(|&v| (12..28).contains(&(v % DIMS[0]))).collect();
    let settled = settle_undrawn(&volume, &mut labels, &lassoed);
    assert_eq!(settled, Settled { relabelled: grey.len(), unlabelled: 0 });
    // 575 lies 75 from the scalp's 650, 185 from the white matter's 760, 275 from the ventricle's 300.
    assert!(grey.iter().all(|&v| labels[v] == 3));
    // The drawn ventricle keeps its class.
    assert_eq!(labels[at(5, 9, 9)], 1);
    assert_eq!(labels.iter().filter(|&&label| label == 1).count(), 64);
}

/// The failure it prevents: a leaky loop round a ventricle, mostly white matter, gives the
/// ventricle's class the partial volume's intensities, and the grey matter, nearer them than
/// any other drawn class, became the ventricle everywhere in the brain.
#[test]
fn a_far_larger_piece_that_no_class_drew_the_intensity_of_gets_no_class() {
    // 420 lies 120 from the ventricle's 300, 230 from the scalp's 650, 340 from the white's 760.
    let (volume, mut labels, lassoed) = brain_with_slab(420.0, 1);
    let slab: Vec<usize> = (0..labels.len()).filter(|&v| (12..28).contains(&(v % DIMS[0]))).collect();
    assert!(slab.len() > NO_CLASS_RATIO * 64);
    let settled = settle_undrawn(&volume, &mut labels, &lassoed);
    assert_eq!(settled, Settled { relabelled: 0, unlabelled: slab.len() });
    assert!(slab.iter().all(|&v| labels[v] == 0));
    assert_eq!(labels.iter().filter(|&&label| label == 1).count(), 64);
    assert_eq!(labels[at(35, 10, 10)], 2);
}

#[test]
fn a_far_larger_piece_with_its_class_s_drawn_intensity_stays() {
    // CSF far from the drawn ventricle (the brain's outer CSF): the ventricle's own value.
    let (volume, mut labels, lassoed) = brain_with_slab(300.0, 1);
    let before = labels.clone();
    assert_eq!(settle_undrawn(&volume, &mut labels, &lassoed), Settled::default());
    assert_eq!(labels, before);
}

#[test]
fn without_loops_nothing_changes() {
    let (volume, mut labels, _) = brain(1);
    let before = labels.clone();
    assert_eq!(settle_undrawn(&volume, &mut labels, &[]), Settled::default());
    assert_eq!(labels, before);
}

#[test]
fn a_large_piece_whose_intensity_is_its_own_class_s_stays() {
    // A second lung: the drawn lung at x 2-9, the other at x 12-35 (three times its size, with
    // the same intensity), soft tissue between and round them.
    let (volume, mut labels) = scene(DIMS, |x, _, _| match x {
        2..10 => (-850.0, 1),
        12..36 => (-820.0, 1),
        _ => (40.0, 2),
    });
    let lassoed = vec![(at(5, 10, 10), 1), (at(0, 10, 10), 2)];
    let before = labels.clone();
    assert_eq!(settle_undrawn(&volume, &mut labels, &lassoed), Settled::default());
    assert_eq!(labels, before);
}

#[test]
fn cells_of_one_class_apart_from_the_drawn_one_stay() {
    // Medium (class 1, 40); cells (class 2) of 4x4x4 every 8 voxels along x, one drawn. A cell
    // at 70 lies nearer the medium's 40 than the drawn cell's 105, but is no larger than it.
    let (volume, mut labels) = scene(DIMS, |x, y, z| {
        let cell = x % 8 >= 2 && x % 8 < 6 && (8..12).contains(&y) && (8..12).contains(&z);
        if cell { (if x < 8 { 105.0 } else { 70.0 }, 2) } else { (40.0, 1) }
    });
    let lassoed = vec![(at(3, 9, 9), 2), (at(0, 0, 0), 1)];
    let before = labels.clone();
    assert_eq!(settle_undrawn(&volume, &mut labels, &lassoed), Settled::default());
    assert_eq!(labels, before);
}

/// [`brain`] with the ventricle's values spread over 290, 300 and 310, and the slab at x 12-27
/// of class 1 holding 300 where `undrawn_at(x, y, z)` is false and 520 where it is true.
fn brain_with_mixed_slab(undrawn_at: impl Fn(usize, usize, usize) -> bool) -> (Volume, Vec<u8>, Vec<(usize, u8)>) {
    brain_scene(
        |x, y, z| 290.0 + 10.0 * ((x + y + z) % 3) as f32,
        |x, y, z| (if undrawn_at(x, y, z) { 520.0 } else { 300.0 }, 1),
    )
}

/// The failure it prevents: clean loops in a ventricle and on the scalp leave the skull, the CSF
/// round the brain and the cortex one piece of the ventricle's class, whose median is the
/// ventricle's own; the cortex in it kept the class.
#[test]
fn a_far_larger_piece_of_its_class_s_intensity_and_an_undrawn_one_loses_the_undrawn_voxels() {
    // Ten of the slab's sixteen columns at the ventricle's 300, six at 520 (nearest the
    // ventricle's median all the same: 220 from it, 240 from the white matter's 760).
    let undrawn_at = |x: usize, _: usize, _: usize| x >= 22;
    let (volume, mut labels, lassoed) = brain_with_mixed_slab(undrawn_at);
    let undrawn: Vec<usize> = (0..labels.len()).filter(|&v| (22..28).contains(&(v % DIMS[0]))).collect();
    let settled = settle_undrawn(&volume, &mut labels, &lassoed);
    assert_eq!(settled, Settled { relabelled: 0, unlabelled: undrawn.len() });
    assert!(undrawn.iter().all(|&v| labels[v] == 0));
    assert_eq!(labels[at(15, 10, 10)], 1, "the slab's CSF keeps the ventricle's class");
    assert_eq!(labels[at(5, 9, 9)], 1);
}

#[test]
fn a_far_larger_piece_of_its_class_s_intensity_keeps_its_few_outliers() {
    // One voxel in twenty of the slab at 520: the noise's tails of a tissue the class drew.
    let undrawn_at = |x: usize, y: usize, z: usize| (x + 3 * y + 7 * z) % 20 == 0;
    let (volume, mut labels, lassoed) = brain_with_mixed_slab(undrawn_at);
    let outliers = (0..labels.len()).filter(|&v| (12..28).contains(&(v % DIMS[0])) && volume.value(v) == 520.0).count();
    assert!(outliers > 0 && (outliers as f64) < MIXED_SHARE * (16 * 20 * 20) as f64);
    let before = labels.clone();
    assert_eq!(settle_undrawn(&volume, &mut labels, &lassoed), Settled::default());
    assert_eq!(labels, before);
}
