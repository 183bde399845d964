//! Pictures for a person to look at: the real volumes of `../shared/data` with made-up
//! threshold classes and class tables, and the class-border comparison of the label
//! interpolation methods. Ignored by default (seconds each on lavapipe); run with
//!
//! `VOLASSO_RENDER_LOOK=/tmp/render-look cargo test --lib render::looks -- --ignored`
//!
//! The tests check only that something was drawn; the pictures are the point.

use super::test_support::{Phantom, capture, look, style};
use super::{Camera, LabelInterpolation, Projection, RenderMode, RenderSettings};
use crate::transfer::ClassStyle;
use crate::volume::{OpenOptions, Volume};
use std::path::Path;

/// Label k where the value reaches `thresholds[k - 1]` (and not the next), 0 below the first.
fn threshold_labels(volume: &Volume, thresholds: &[f32]) -> Vec<u8> {
    let mut labels = vec![0u8; volume.voxel_count()];
    let plane = volume.dims[0] * volume.dims[1];
    let mut slice = vec![0f32; plane];
    for (z, out) in labels.chunks_exact_mut(plane).enumerate() {
        volume.read_z_slice_f32(z, &mut slice);
        for (label, value) in out.iter_mut().zip(&slice) {
            *label = thresholds.iter().filter(|t| value >= *t).count() as u8;
        }
    }
    labels
}

/// A made-up table: a faint warm class, then more opaque cooler ones.
fn made_up_styles(classes: usize, gradient_max: f32) -> Vec<ClassStyle> {
    let looks = [(25.0, 0.05, 0.25), (200.0, 0.35, 0.8), (120.0, 0.6, 0.95)];
    looks[..classes]
        .iter()
        .map(|&(hue, low, high)| ClassStyle {
            hue_degrees: [hue, hue + 30.0],
            saturation: 0.7,
            value: 0.95,
            opacity: [low, high],
            gradient_max,
            emphasis: 1.0,
            visible: true,
        })
        .collect()
}

fn render_real(name: &str, path: &str, spacing_mm: Option<[f64; 3]>, thresholds: &[f32], camera: Camera) {
    let options = OpenOptions { spacing_mm, ..Default::default() };
    let volume = crate::volume::open(Path::new(path), &options).unwrap();
    let labels = threshold_labels(&volume, thresholds);
    let range = volume.value_range();
    let min_spacing = volume.spacing_mm.iter().copied().fold(f64::INFINITY, f64::min);
    let styles = made_up_styles(thresholds.len(), (0.25 * (range.max - range.min) / min_spacing) as f32);
    let phantom = Phantom { volume, labels };
    for mode in [RenderMode::Postclassified, RenderMode::Preclassified] {
        let mut ray_caster = phantom.ray_caster(&styles, mode);
        let settings = RenderSettings { mode, background: [0.08, 0.08, 0.1, 1.0], ..RenderSettings::default() };
        let image = capture(&mut ray_caster, &camera, &settings, [512, 512]);
        look(&format!("{name}-{mode:?}"), &image);
        assert!(image.pixels().any(|p| p[0] > 60 || p[1] > 60 || p[2] > 60), "{name} {mode:?}: nothing drawn");
    }
}

#[test]
#[ignore = "pictures of real data for a person; set VOLASSO_RENDER_LOOK"]
fn real_volumes() {
    let camera = Camera::default();
    render_real(
        "engine",
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/engine_256x256x256_uint8.raw"),
        None,
        &[60.0, 140.0],
        camera,
    );
    render_real(
        "lobster",
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/lobster_301x324x56_uint8.raw"),
        Some([1.0, 1.0, 1.4]),
        &[40.0, 90.0],
        camera,
    );
    let face = Camera { azimuth_degrees: 180.0, elevation_degrees: 10.0, ..camera };
    render_real(
        "vismale",
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/vismale_128x256x256_uint8.raw"),
        Some([1.578, 0.996, 1.008]),
        &[40.0, 100.0],
        face,
    );
    render_real(
        "cranium",
        concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/cranium_ct_256x256x108_int16.raw"),
        Some([0.957, 0.957, 1.5]),
        &[-400.0, 250.0],
        face,
    );
}

#[test]
#[ignore = "pictures of the class-border methods for a person; set VOLASSO_RENDER_LOOK"]
fn class_border_comparison() {
    // A sphere (class 1, red) half sunk into a slab (class 2, blue). The scalar is a smooth ramp
    // across the union's surface (as in real data), so only the labels say where one class
    // ends and the other begins; they do so voxel by voxel, as a classifier's labels do.
    let dims = [48usize; 3];
    let mut values = Vec::new();
    let mut labels = Vec::new();
    for z in 0..48 {
        for y in 0..48 {
            for x in 0..48 {
                let p = [x, y, z].map(|c| c as f32 + 0.5 - 24.0);
                let sphere = (p[0] * p[0] + p[1] * p[1] + (p[2] - 2.0).powi(2)).sqrt() - 13.0;
                let outside = [p[0].abs() - 20.0, p[1].abs() - 20.0, (p[2] + 5.0).abs() - 7.0];
                let slab = outside.iter().map(|o| o.max(0.0).powi(2)).sum::<f32>().sqrt()
                    + outside.iter().copied().fold(f32::MIN, f32::max).min(0.0);
                values.push(200.0 * (0.5 - sphere.min(slab) / 3.0).clamp(0.0, 1.0));
                labels.push(if sphere < 0.0 {
                    1
                } else if slab < 0.0 {
                    2
                } else {
                    0
                });
            }
        }
    }
    let volume = Volume::from_f32(dims, [1.0; 3], &values, Path::new("sphere on slab")).unwrap();
    let phantom = Phantom { volume, labels };
    let styles = [style(0.0, 0.7), style(215.0, 0.7)];
    let overview = Camera {
        azimuth_degrees: 30.0,
        elevation_degrees: 25.0,
        zoom: 2.2,
        pan_mm: [0.0, 0.0],
        projection: Projection::Perspective { fov_y_degrees: 30.0 },
    };
    // Close up on the seam where the sphere enters the slab, on the side facing the camera.
    let rays = overview.view_rays([48.0; 3], 256, 256);
    let azimuth = overview.azimuth_degrees.to_radians();
    let seam = [13.0 * azimuth.sin(), -13.0 * azimuth.cos(), 2.0];
    let along = |axis: [f32; 3]| -(0..3).map(|a| axis[a] * seam[a]).sum::<f32>();
    let close_up = Camera { zoom: 6.0, pan_mm: [along(rays.right_in_world), along(rays.up_in_world)], ..overview };
    let cases = [
        ("largest-indicator", RenderMode::Postclassified, LabelInterpolation::LargestIndicatorWeight),
        ("nearest-label", RenderMode::Postclassified, LabelInterpolation::Nearest),
        ("trilinear-rgba", RenderMode::Preclassified, LabelInterpolation::LargestIndicatorWeight),
    ];
    let tile = 256;
    let mut sheet = image::RgbaImage::new(3 * tile, 2 * tile);
    for (column, (name, mode, label_interpolation)) in cases.into_iter().enumerate() {
        let mut ray_caster = phantom.ray_caster(&styles, mode);
        for (row, (camera, shading)) in [(overview, true), (close_up, false)].into_iter().enumerate() {
            let settings = RenderSettings {
                mode,
                label_interpolation,
                shading,
                background: [1.0, 1.0, 1.0, 1.0],
                ..RenderSettings::default()
            };
            let image = capture(&mut ray_caster, &camera, &settings, [tile, tile]);
            look(&format!("border-{name}-{}", if shading { "shaded" } else { "flat-close-up" }), &image);
            assert!(image.pixels().any(|p| p[2] < 200), "{name}: nothing drawn");
            image::imageops::replace(&mut sheet, &image, (column as u32 * tile) as i64, (row as u32 * tile) as i64);
        }
    }
    look("border-comparison-sheet", &sheet);
}
