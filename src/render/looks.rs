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
use crate::volume::{OpenOptions, Volume, VoxelType};
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
    render_real("engine", "../shared/data/engine_256x256x256_uint8.raw", None, &[60.0, 140.0], camera);
    render_real("lobster", "../shared/data/lobster_301x324x56_uint8.raw", Some([1.0, 1.0, 1.4]), &[40.0, 90.0], camera);
    let face = Camera { azimuth_degrees: 180.0, elevation_degrees: 10.0, ..camera };
    render_real(
        "vismale",
        "../shared/data/vismale_128x256x256_uint8.raw",
        Some([1.578, 0.996, 1.008]),
        &[40.0, 100.0],
        face,
    );
    render_real(
        "cranium",
        "../shared/data/cranium_ct_256x256x108_int16.raw",
        Some([0.957, 0.957, 1.5]),
        &[-400.0, 250.0],
        face,
    );
}

#[test]
#[ignore = "pictures of the class-border methods for a person; set VOLASSO_RENDER_LOOK"]
fn class_border_comparison() {
    // A sphere (class 1) half sunk into a slab (class 2): a curved border between classes.
    let phantom = Phantom::new([48; 3], [1.0; 3], VoxelType::U8, |p| {
        let in_sphere = p[0] * p[0] + p[1] * p[1] + (p[2] - 2.0) * (p[2] - 2.0) <= 13.0 * 13.0;
        if in_sphere {
            1
        } else if p[2] < 2.0 && p[0].abs() < 20.0 && p[1].abs() < 20.0 && p[2] > -12.0 {
            2
        } else {
            0
        }
    });
    let styles = [style(0.0, 0.7), style(210.0, 0.7)];
    let camera = Camera {
        azimuth_degrees: 30.0,
        elevation_degrees: 25.0,
        zoom: 2.2,
        pan_mm: [0.0, 0.0],
        projection: Projection::Perspective { fov_y_degrees: 30.0 },
    };
    let cases = [
        ("largest-indicator", RenderMode::Postclassified, LabelInterpolation::LargestIndicatorWeight),
        ("nearest-label", RenderMode::Postclassified, LabelInterpolation::Nearest),
        ("trilinear-rgba", RenderMode::Preclassified, LabelInterpolation::LargestIndicatorWeight),
    ];
    for shading in [false, true] {
        for (name, mode, label_interpolation) in cases {
            let settings = RenderSettings {
                mode,
                label_interpolation,
                shading,
                background: [1.0, 1.0, 1.0, 1.0],
                ..RenderSettings::default()
            };
            let image = capture(&mut phantom.ray_caster(&styles, mode), &camera, &settings, [384, 384]);
            look(&format!("border-{name}-{}", if shading { "shaded" } else { "flat" }), &image);
            assert!(image.pixels().any(|p| p[2] < 200), "{name}: nothing drawn");
        }
    }
}
