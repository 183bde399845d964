use super::*;
use crate::rng::{gaussian_from_bits, hash64};
use std::path::Path;

fn volume_of(dims: [usize; 3], value: impl Fn(usize, usize, usize) -> f32) -> Volume {
    let [nx, ny, nz] = dims;
    let values: Vec<f32> = (0..nx * ny * nz).map(|i| value(i % nx, i / nx % ny, i / (nx * ny))).collect();
    Volume::from_f32(dims, [1.0; 3], &values, Path::new("phantom")).unwrap()
}

/// A windowed 8-bit chest: air and lungs at 0, the chest wall at 120, the lungs running out of
/// the volume's top face (z = nz - 1) and joined to it by a trachea.
fn chest(dims: [usize; 3]) -> Volume {
    let [nx, ny, _] = dims;
    volume_of(dims, |x, y, z| {
        let (u, v) = (x as f64 - nx as f64 / 2.0, y as f64 - ny as f64 / 2.0);
        let in_wall = (u / 20.0).powi(2) + (v / 14.0).powi(2) < 1.0;
        let in_lung = ((u.abs() - 9.0) / 7.0).powi(2) + (v / 10.0).powi(2) < 1.0 && z > 3;
        let noise = 4.0 * gaussian_from_bits(hash64(11, (x + 97 * y + 9973 * z) as u64));
        if in_wall && !in_lung { (120.0 + noise).max(0.0) } else { noise.max(0.0) }
    })
}

#[test]
fn lungs_as_dark_as_the_air_and_open_to_a_face_are_inside_the_body() {
    let dims = [48, 36, 20];
    let body = Body::find(&chest(dims), chest(dims).otsu_threshold());
    let lung = 24 - 9 + 48 * (18 + 36 * (dims[2] - 1));
    assert!(body.contains(lung), "a lung voxel on the top face is inside");
    assert!(!body.contains(0), "a corner of the air is outside");
    assert!(!body.contains(2 + 48 * (18 + 36 * 10)), "air beside the chest is outside");
    // The chest wall's and lungs' cross-section is inside on every plane.
    let inside_per_plane = body.voxel_count() / dims[2];
    assert!((800..1000).contains(&inside_per_plane), "{inside_per_plane}");
}

/// An MRI-like head: Rician air (about 35), a scalp at 800, a thin dark skull at 130 and fluid
/// at 260 under it, a brain at 600.
fn head(dims: [usize; 3]) -> Volume {
    let [nx, ny, nz] = dims;
    volume_of(dims, |x, y, z| {
        let r = ((x as f64 - nx as f64 / 2.0).powi(2)
            + (y as f64 - ny as f64 / 2.0).powi(2)
            + (z as f64 - nz as f64 / 2.0).powi(2))
        .sqrt();
        let tissue = match r {
            r if r < 9.0 => 600.0,
            r if r < 11.0 => 260.0,
            r if r < 13.0 => 130.0,
            r if r < 15.0 => 800.0,
            _ => 0.0,
        };
        let seed = (x + 101 * y + 10007 * z) as u64;
        let (a, b) = (28.0 * gaussian_from_bits(hash64(3, seed)), 28.0 * gaussian_from_bits(hash64(4, seed)));
        ((tissue + a).powi(2) + b * b).sqrt()
    })
}

#[test]
fn an_mri_s_dark_skull_and_fluid_are_inside_and_its_air_is_not() {
    let dims = [40, 40, 40];
    let volume = head(dims);
    let body = Body::find(&volume, volume.otsu_threshold());
    // Above the air's noise; the skull and the fluid are inside, below the level or not.
    assert!((50.0..500.0).contains(&body.level), "{}", body.level);
    let at = |x: usize, y: usize, z: usize| body.contains(x + 40 * (y + 40 * z));
    assert!(at(20, 20 + 12, 20), "the skull");
    assert!(at(20, 20 + 10, 20), "the fluid");
    // The air around the head: outside, specks of Rician noise included.
    let air = (0..volume.voxel_count()).filter(|&i| {
        let (x, y, z) = (i % 40, i / 40 % 40, i / 1600);
        ((x as f64 - 20.0).powi(2) + (y as f64 - 20.0).powi(2) + (z as f64 - 20.0).powi(2)).sqrt() > 16.5
    });
    let (mut count, mut inside) = (0, 0);
    for i in air {
        count += 1;
        inside += usize::from(body.contains(i));
    }
    assert!(inside * 1000 < count, "{inside} of {count} air voxels inside");
}

#[test]
fn a_bright_speck_in_the_air_is_not_a_body_and_a_box_s_cavity_is_inside() {
    let dims = [24, 24, 24];
    let volume = volume_of(dims, |x, y, z| {
        let shell = (4..20).contains(&x) && (4..20).contains(&y) && (4..24).contains(&z);
        let cavity = (8..16).contains(&x) && (8..16).contains(&y) && (8..24).contains(&z);
        if (x, y, z) == (1, 1, 1) {
            500.0
        } else if shell && !cavity {
            200.0
        } else {
            0.0
        }
    });
    let body = Body::find(&volume, volume.otsu_threshold());
    let at = |x: usize, y: usize, z: usize| body.contains(x + 24 * (y + 24 * z));
    assert!(!at(1, 1, 1), "a one-voxel speck");
    assert!(at(12, 12, 12), "the cavity, open to the top face through the box's bore");
    assert!(at(12, 12, 23), "the bore on the top face is ringed in its own plane");
    // A notch open to the side (x 0..8 at y 10..14, z 8..12) is ringed in no axial slice.
    let notched = volume_of(dims, |x, y, z| {
        let shell = (4..20).contains(&x) && (4..20).contains(&y) && (4..24).contains(&z);
        let notch = x < 8 && (10..14).contains(&y) && (8..12).contains(&z);
        if shell && !notch { 200.0 } else { 0.0 }
    });
    let notched_body = Body::find(&notched, notched.otsu_threshold());
    assert!(!notched_body.contains(6 + 24 * (12 + 24 * 10)), "the notch is air");
    assert!(!at(2, 12, 12), "the air beside the box");
    assert_eq!(body.row_span(12, 12), Some((4, 19)));
    assert_eq!(body.row_span(1, 1), None);
}

#[test]
fn the_voxels_outside_are_every_voxel_not_inside_and_none_past_the_volume() {
    // 48 x 36 x 20 voxels is not a multiple of 64 in the last word: its spare bits are not voxels.
    for dims in [[48, 36, 20], [7, 5, 3]] {
        let volume = chest(dims);
        let body = Body::find(&volume, volume.otsu_threshold());
        let outside: Vec<usize> = body.outside().collect();
        let expected: Vec<usize> = (0..volume.voxel_count()).filter(|&voxel| !body.contains(voxel)).collect();
        assert_eq!(outside, expected, "{dims:?}");
        assert_eq!(outside.len() + body.voxel_count(), volume.voxel_count());
    }
}
