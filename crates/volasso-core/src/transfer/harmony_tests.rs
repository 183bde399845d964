use super::*;
use crate::features::features_at;
use crate::phantom::demo_foot_with;
use crate::transfer::templates::TemplateType;
use std::path::Path;

/// The demo foot phantom at a small size with its truth as labels (3 classes: soft tissue,
/// bone, joint; air is background).
fn foot() -> (Volume, Vec<u8>) {
    let phantom = demo_foot_with([48, 32, 24], 7).unwrap();
    (phantom.volume, phantom.truth)
}

/// The hue in degrees of an RGB colour (for checking eq. 4 through the RGB conversion).
fn hue_of(rgb: [f32; 3]) -> f32 {
    let [r, g, b] = rgb;
    let max = r.max(g).max(b);
    let chroma = max - r.min(g).min(b);
    let sector = if max == r {
        ((g - b) / chroma).rem_euclid(6.0)
    } else if max == g {
        (b - r) / chroma + 2.0
    } else {
        (r - g) / chroma + 4.0
    };
    sector * 60.0
}

#[test]
fn statistics_match_a_brute_force_pass() {
    let (volume, labels) = foot();
    let whole = ClipBox::whole(volume.dims).unwrap();
    let statistics = class_statistics(&volume, &labels, 3, whole).unwrap();
    let [nx, ny, nz] = volume.dims;
    for class in 1..=3u8 {
        let mut count = 0u64;
        let mut sum = [0f64; 3];
        let mut gradient_max = 0f32;
        for (index, _) in labels.iter().enumerate().filter(|(_, l)| **l == class) {
            count += 1;
            let p = [index % nx, (index / nx) % ny, index / (nx * ny)];
            for a in 0..3 {
                sum[a] += (p[a] as f64 + 0.5) / [nx, ny, nz][a] as f64;
            }
            gradient_max = gradient_max.max(features_at(&volume, index)[1]);
        }
        let found = &statistics[class as usize - 1];
        assert!(count > 0);
        assert_eq!(found.voxel_count, count);
        assert_eq!(found.gradient_max, gradient_max, "the features stage's gradient, class {class}");
        for (found_sum, sum) in found.position_sum.into_iter().zip(sum) {
            assert!((found_sum - sum).abs() < 1e-6 * count as f64);
        }
    }
}

#[test]
fn saturation_value_and_opacity_stay_in_the_documented_ranges() {
    let (volume, labels) = foot();
    let styles = class_styles(&volume, &labels, 3, &HueTemplate::default_for(3)).unwrap();
    let statistics = class_statistics(&volume, &labels, 3, ClipBox::whole(volume.dims).unwrap()).unwrap();
    let variances: Vec<f64> = statistics.iter().map(|s| s.spatial_variance()).collect();
    let widest = (0..3).max_by(|&a, &b| variances[a].total_cmp(&variances[b])).unwrap();
    for (k, style) in styles.iter().enumerate() {
        assert!((0.79..=1.0).contains(&style.saturation), "S {style:?}");
        assert!((0.53..=1.0).contains(&style.value), "V {style:?}");
        assert!(style.opacity.iter().all(|o| (OPACITY_FLOOR..=OPACITY_CEILING).contains(o)), "{style:?}");
        assert!(style.opacity[1] >= style.opacity[0], "boundaries are enhanced");
        assert!(style.visible && style.emphasis == 1.0 && style.gradient_max > 0.0);
        if k == widest {
            assert_eq!(style.opacity, [OPACITY_FLOOR; 2], "the largest-variance class keeps the floor");
        }
    }
    // The ceiling is reached by the smallest-variance class at F = 1.
    let tightest = (0..3).min_by(|&a, &b| variances[a].total_cmp(&variances[b])).unwrap();
    assert!((styles[tightest].opacity[1] - OPACITY_CEILING).abs() < 1e-6);

    // Extremes: a class filling the unit cube has sigma^2 = 0.25 (S = 0.8); a single voxel in
    // a corner has D close to sqrt(3) / 2 (V close to 0.536).
    let dims = [20, 20, 20];
    let volume = Volume::from_f32(dims, [1.0, 1.0, 3.0], &vec![1.0; 8000], Path::new("cube")).unwrap();
    let mut labels = vec![1u8; 8000];
    labels[0] = 2;
    let styles = class_styles(&volume, &labels, 2, &HueTemplate::default_for(2)).unwrap();
    assert!((styles[0].saturation - 0.8).abs() < 0.002, "{}", styles[0].saturation);
    assert!((styles[1].value - 1.0 / (1.0 + 0.475 * 3f32.sqrt())).abs() < 1e-4, "{}", styles[1].value);
    assert_eq!(styles[1].saturation, 1.0);
}

#[test]
fn rescaled_opacity_is_eq_9_min_max_rescaled_over_all_voxels() {
    let (volume, labels) = foot();
    let styles = class_styles(&volume, &labels, 3, &HueTemplate::default_for(3)).unwrap();
    let statistics = class_statistics(&volume, &labels, 3, ClipBox::whole(volume.dims).unwrap()).unwrap();
    let largest = statistics.iter().map(|s| s.spatial_variance()).fold(0.0, f64::max);
    let raw: Vec<(usize, f32, f64)> = (0..labels.len())
        .filter(|&i| labels[i] > 0)
        .map(|i| {
            let class = labels[i] as usize - 1;
            let factor = (features_at(&volume, i)[1] / statistics[class].gradient_max) as f64;
            let a = 1.0 - statistics[class].spatial_variance() / largest;
            (class, factor as f32, a * (1.0 + factor))
        })
        .collect();
    let low = raw.iter().map(|r| r.2).fold(f64::INFINITY, f64::min);
    let high = raw.iter().map(|r| r.2).fold(0.0, f64::max);
    for &(class, factor, opacity) in raw.iter().step_by(7) {
        let expected = 0.2 + 0.8 * (opacity - low) / (high - low);
        let style = &styles[class];
        let line = style.opacity[0] + (style.opacity[1] - style.opacity[0]) * factor;
        assert!((line as f64 - expected).abs() < 1e-5, "class {class}: {line} vs {expected}");
    }
}

#[test]
fn hue_increases_with_the_gradient_factor() {
    let (volume, labels) = foot();
    for template in [HueTemplate::default_for(3), HueTemplate::new(TemplateType::X, 350.0)] {
        let styles = class_styles(&volume, &labels, 3, &template).unwrap();
        for style in &styles {
            let mut previous = None;
            for step in 0..=10 {
                let gradient = style.gradient_max * step as f32 / 10.0;
                let [r, g, b, _] = style.rgba(gradient);
                let hue = hue_of([r, g, b]);
                // Unwrap across 360 relative to the range's start.
                let along = (hue - style.hue_degrees[0]).rem_euclid(360.0);
                let expected = (style.hue_degrees[1] - style.hue_degrees[0]) * step as f32 / 10.0;
                assert!((along - expected).abs() < 0.05, "{style:?} step {step}: hue {hue}");
                if let Some(before) = previous {
                    assert!(along > before);
                }
                previous = Some(along);
            }
        }
    }
}

#[test]
fn clip_box_statistics_count_only_what_is_in_view() {
    let (volume, labels) = foot();
    let template = HueTemplate::default_for(3);
    let whole = class_styles(&volume, &labels, 3, &template).unwrap();
    let mut previous = whole.clone();
    previous[0].emphasis = 0.3;
    previous[2].visible = false;
    // The front half along x cuts every class of the foot.
    let half = ClipBox { lo: [0, 0, 0], hi: [23, 31, 23] };
    let clipped = class_styles_in_box(&volume, &labels, &template, half, &previous).unwrap();
    let whole_statistics = class_statistics(&volume, &labels, 3, ClipBox::whole(volume.dims).unwrap()).unwrap();
    let clipped_statistics = class_statistics(&volume, &labels, 3, half).unwrap();
    for k in 0..3 {
        assert!(clipped_statistics[k].voxel_count < whole_statistics[k].voxel_count, "class {k}");
        assert_ne!(clipped[k].value, whole[k].value, "class {k}");
        assert_eq!(clipped[k].hue_degrees, whole[k].hue_degrees);
    }
    assert_ne!(
        clipped.iter().map(|s| s.saturation).collect::<Vec<_>>(),
        whole.iter().map(|s| s.saturation).collect::<Vec<_>>()
    );
    assert_eq!((clipped[0].emphasis, clipped[2].visible), (0.3, false), "the caller's settings stay");
    // The box that is the whole volume gives the whole-volume styles.
    let all = class_styles_in_box(&volume, &labels, &template, ClipBox::whole(volume.dims).unwrap(), &whole).unwrap();
    assert_eq!(all, whole);
}

#[test]
fn empty_classes_and_bad_labels() {
    let (volume, labels) = foot();
    let styles = class_styles(&volume, &labels, 5, &HueTemplate::default_for(5)).unwrap();
    assert!(styles[..3].iter().all(|s| s.visible));
    for empty in &styles[3..] {
        assert!(!empty.visible);
        assert_eq!((empty.saturation, empty.value, empty.opacity, empty.gradient_max), (1.0, 1.0, [0.2; 2], 0.0));
    }
    assert!(matches!(
        class_styles(&volume, &labels, 2, &HueTemplate::default_for(2)),
        Err(TransferError::LabelOutOfRange { label: 3, class_count: 2, .. })
    ));
    assert!(matches!(
        class_styles(&volume, &labels[1..], 3, &HueTemplate::default_for(3)),
        Err(TransferError::LabelCount { .. })
    ));
    let flat = ClipBox { lo: [5, 0, 0], hi: [4, 3, 3] };
    assert!(matches!(class_statistics(&volume, &labels, 3, flat), Err(TransferError::ClipBox { .. })));
}

#[test]
fn a_label_out_of_range_in_the_last_voxel_of_a_volume_of_many_chunks_is_found() {
    let phantom = demo_foot_with([64, 48, 32], 7).unwrap();
    let mut labels = phantom.truth;
    assert!(labels.len() > 1 << 16, "more than one chunk of the parallel check");
    let last = labels.len() - 1;
    labels[last] = 9;
    assert!(matches!(
        check_labels(&phantom.volume, &labels, 3),
        Err(TransferError::LabelOutOfRange { voxel, label: 9, class_count: 3 }) if voxel == last
    ));
    labels[last] = 3;
    assert!(check_labels(&phantom.volume, &labels, 3).is_ok());
}
