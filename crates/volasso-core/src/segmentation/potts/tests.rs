//! The Potts sweeps: a blurred border moved to where its intensity crosses halfway, noise
//! specks joining their surroundings while a thin bright structure stays, the background left
//! alone, and the noise measured without the values a window clipped.

use super::*;
use crate::rng::hash64;
use std::path::Path;

const DIMS: [usize; 3] = [24, 10, 10];

/// Deterministic noise in -5..=5.
fn noise(index: usize) -> f32 {
    (hash64(11, index as u64) % 11) as f32 - 5.0
}

fn volume(value: impl Fn(usize, usize, usize) -> f32) -> Volume {
    let [size_x, size_y, size_z] = DIMS;
    let mut values = Vec::with_capacity(size_x * size_y * size_z);
    for z in 0..size_z {
        for y in 0..size_y {
            for x in 0..size_x {
                values.push(value(x, y, z) + noise(values.len()));
            }
        }
    }
    Volume::from_f32(DIMS, [1.0; 3], &values, Path::new("potts")).unwrap()
}

fn labels(label: impl Fn(usize, usize, usize) -> u8) -> Vec<u8> {
    let [size_x, size_y, size_z] = DIMS;
    (0..size_x * size_y * size_z).map(|i| label(i % size_x, i / size_x % size_y, i / (size_x * size_y))).collect()
}

#[test]
fn a_blurred_border_moves_to_where_the_intensity_crosses_halfway() {
    // Tissue 1 at 100 up to x = 10, tissue 2 at 300 from x = 13, the blur's ramp between
    // (150 at x = 11, 250 at x = 12): halfway (200) lies between x = 11 and x = 12. The
    // classifier put the border two voxels into tissue 2 (x = 12 and 13 labelled 1).
    let ramp = [100.0, 100.0, 100.0, 100.0, 100.0, 100.0, 100.0, 100.0, 100.0, 100.0, 100.0, 150.0, 250.0];
    let volume = volume(|x, _, _| ramp.get(x).copied().unwrap_or(300.0));
    let mut labels = labels(|x, _, _| if x < 14 { 1 } else { 2 });
    let changed = potts_sweeps(&volume, &mut labels, Neighbourhood::Cube);
    assert_eq!(changed, 2 * DIMS[1] * DIMS[2], "the planes x = 12 and 13 move, nothing else");
    for (index, &label) in labels.iter().enumerate() {
        assert_eq!(label, if index % DIMS[0] < 12 { 1 } else { 2 }, "voxel {index}");
    }
}

#[test]
fn a_noise_speck_joins_its_surroundings_and_a_line_far_brighter_stays() {
    // Tissue at 100: a pair of voxels labelled 2 at the tissue's own intensity (noise the
    // classifier took for another class), and a line one voxel wide along z at 300 (a vessel).
    let line = |x: usize, y: usize| x == 16 && y == 5;
    let volume = volume(|x, y, _| if line(x, y) { 300.0 } else { 100.0 });
    let speck = |x: usize, y: usize, z: usize| (x == 6 || x == 7) && y == 4 && z == 4;
    let mut labels = labels(|x, y, z| {
        if line(x, y) {
            3
        } else if speck(x, y, z) {
            2
        } else {
            1
        }
    });
    assert_eq!(potts_sweeps(&volume, &mut labels, Neighbourhood::Cube), 2);
    assert!(!labels.contains(&2), "the speck joined the tissue");
    let on_line = labels.iter().enumerate().filter(|&(i, _)| line(i % DIMS[0], i / DIMS[0] % DIMS[1]));
    assert!(on_line.clone().count() == DIMS[2] && on_line.into_iter().all(|(_, &label)| label == 3));
}

#[test]
fn background_is_neither_changed_nor_counted() {
    // A sheet of class 2 one voxel thick at its own intensity between the air (label 0, at 0)
    // and class 1: the air does not vote, and no background voxel takes a class.
    let volume = volume(|x, _, _| match x {
        0..8 => 0.0,
        8 => 200.0,
        _ => 100.0,
    });
    let original = labels(|x, _, _| match x {
        0..8 => 0,
        8 => 2,
        _ => 1,
    });
    let mut labels = original.clone();
    assert_eq!(potts_sweeps(&volume, &mut labels, Neighbourhood::Cube), 0);
    assert_eq!(labels, original);
}

#[test]
fn the_noise_is_measured_without_the_values_a_window_clipped() {
    // Class 1 is clipped to the volume's lowest value (a windowed CT's lungs, all 0); class 2
    // has the noise: the deviation is class 2's, not the clipped class's zero.
    let clipped = Volume::from_f32(
        DIMS,
        [1.0; 3],
        &(0..DIMS.iter().product::<usize>())
            .map(|i| if i % DIMS[0] < 12 { -10.0 } else { 100.0 + noise(i) })
            .collect::<Vec<f32>>(),
        Path::new("clipped"),
    )
    .unwrap();
    let labels = labels(|x, _, _| if x < 12 { 1 } else { 2 });
    let deviation = noise_deviation(&clipped, &labels);
    let unclipped = noise_deviation(&volume(|_, _, _| 100.0), &labels);
    assert!(deviation > 2.0, "deviation {deviation}");
    assert!((deviation - unclipped).abs() < 0.5 * unclipped, "{deviation} against {unclipped}");
}
