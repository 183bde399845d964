//! Image tests of the ray caster on phantoms with known answers (run on lavapipe in CI; the
//! tolerances below were set there, on "llvmpipe (LLVM 15, 256 bits)", Vulkan).

use super::super::test_support::{
    Phantom, capture, channel_differences, flat, gpu, hsv, hue_distance, look, opaque_centroid, opaque_disc_radius,
    pixel_at, style,
};
use super::*;
use crate::render::headless::{OFFSCREEN_FORMAT, OffscreenTarget};
use crate::render::{ClipBox, ClipPlane, LabelInterpolation, MAX_CLASS_OPACITY_FACTOR, Projection};
use crate::volume::VoxelType;

const SIZE: [u32; 2] = [128, 128];

fn sphere(dims: [usize; 3], spacing_mm: [f64; 3], voxel_type: VoxelType, radius_mm: f32) -> Phantom {
    Phantom::new(dims, spacing_mm, voxel_type, |p| {
        (p.iter().map(|c| c * c).sum::<f32>() <= radius_mm * radius_mm) as u8
    })
}

/// Renders a sphere of `radius_mm` and checks its silhouette against the analytic radius.
fn check_sphere_silhouette(name: &str, phantom: &Phantom, radius_mm: f32, camera: Camera) {
    let mut ray_caster = phantom.ray_caster(&[style(200.0, 1.0)], RenderMode::Postclassified);
    let image = capture(&mut ray_caster, &camera, &flat(RenderMode::Postclassified), SIZE);
    look(name, &image);
    let extent_mm = std::array::from_fn(|a| (phantom.volume.dims[a] as f64 * phantom.volume.spacing_mm[a]) as f32);
    let rays = camera.view_rays(extent_mm, SIZE[0], SIZE[1]);
    let expected_pixels = if rays.perspective {
        // The silhouette cone's half-angle is asin(R / d); the image plane is at tan(half fov).
        let distance = rays.eye_in_world.iter().map(|c| c * c).sum::<f32>().sqrt();
        (radius_mm / distance).asin().tan() / rays.view_half_height * SIZE[1] as f32 / 2.0
    } else {
        radius_mm / camera.mm_per_pixel(extent_mm, SIZE[0], SIZE[1])
    };
    let measured = opaque_disc_radius(&image);
    eprintln!("{name}: silhouette radius {measured:.2} px, analytic {expected_pixels:.2} px");
    assert!((measured - expected_pixels).abs() < 1.0, "{name}: radius {measured} px, expected {expected_pixels}");
    let centre = opaque_centroid(&image);
    assert!((centre[0] - 64.0).abs() < 0.5 && (centre[1] - 64.0).abs() < 0.5, "{name}: centred at {centre:?}");
}

#[test]
fn sphere_silhouette_matches_the_analytic_radius() {
    let phantom = sphere([64; 3], [1.0; 3], VoxelType::U8, 20.0);
    let front = Camera { zoom: 2.0, ..Camera::orthographic_front() };
    check_sphere_silhouette("sphere-orthographic", &phantom, 20.0, front);
    let oblique = Camera { azimuth_degrees: 35.0, elevation_degrees: -50.0, ..front };
    check_sphere_silhouette("sphere-orthographic-oblique", &phantom, 20.0, oblique);
    let perspective = Camera { projection: Projection::Perspective { fov_y_degrees: 40.0 }, ..front };
    check_sphere_silhouette("sphere-perspective", &phantom, 20.0, perspective);
}

#[test]
fn anisotropic_16_bit_sphere_is_round_in_world_space() {
    // Visible Male's spacing across x and y, and thick 2.5 mm slices along z.
    let phantom = sphere([40, 64, 26], [1.578, 0.996, 2.5], VoxelType::I16, 20.0);
    for (name, azimuth, elevation) in [("front", 0.0, 0.0), ("side", 90.0, 0.0), ("top", 0.0, 90.0)] {
        let camera = Camera {
            azimuth_degrees: azimuth,
            elevation_degrees: elevation,
            zoom: 2.0,
            ..Camera::orthographic_front()
        };
        check_sphere_silhouette(&format!("sphere-anisotropic-{name}"), &phantom, 20.0, camera);
    }
}

/// Three 16-voxel boxes of classes 1 (red), 2 (green), 3 (blue) on a diagonal of the x-z plane.
fn three_boxes() -> (Phantom, Vec<ClassStyle>, [[f32; 3]; 3]) {
    three_boxes_spaced([1.0; 3])
}

fn three_boxes_spaced(spacing_mm: [f64; 3]) -> (Phantom, Vec<ClassStyle>, [[f32; 3]; 3]) {
    let corners = [[6usize, 20, 6], [42, 20, 42], [24, 20, 24]];
    let phantom = Phantom::new([64; 3], spacing_mm, VoxelType::U8, |p| {
        let voxel: [usize; 3] = std::array::from_fn(|a| (p[a] / spacing_mm[a] as f32 + 32.0 - 0.5).round() as usize);
        let inside = |corner: [usize; 3]| (0..3).all(|a| voxel[a] >= corner[a] && voxel[a] < corner[a] + 16);
        (1..=3).find(|&class| inside(corners[class as usize - 1])).unwrap_or(0)
    });
    let centres = corners.map(|c| phantom.world_of_voxel(c.map(|v| v as f32 + 7.5)));
    (phantom, vec![style(0.0, 0.5), style(120.0, 0.5), style(240.0, 0.5)], centres)
}

fn front_camera() -> Camera {
    Camera { zoom: 1.5, ..Camera::orthographic_front() }
}

fn projected(camera: &Camera, point_in_world: [f32; 3]) -> [f32; 2] {
    camera.view_rays([64.0; 3], SIZE[0], SIZE[1]).project_to_pixel(point_in_world, SIZE[0], SIZE[1]).unwrap()
}

#[test]
fn class_colours_appear_where_the_classes_are_in_both_modes() {
    let (phantom, styles, centres) = three_boxes();
    let camera = front_camera();
    for mode in [RenderMode::Postclassified, RenderMode::Preclassified] {
        let image = capture(&mut phantom.ray_caster(&styles, mode), &camera, &flat(mode), SIZE);
        look(&format!("three-boxes-{mode:?}"), &image);
        for (style, centre) in styles.iter().zip(centres) {
            let pixel = pixel_at(&image, projected(&camera, centre));
            let [hue, saturation, value] = hsv([pixel[0], pixel[1], pixel[2]]);
            let middle_hue = 0.5 * (style.hue_degrees[0] + style.hue_degrees[1]);
            assert!(hue_distance(hue, middle_hue) <= 4.0 + 4.0, "{mode:?}: hue {hue} for {style:?}");
            assert!((saturation - style.saturation).abs() < 0.05, "{mode:?}: saturation {saturation}");
            assert!((value - style.value).abs() < 0.05, "{mode:?}: value {value}");
            assert!(pixel[3] > 0.98, "{mode:?}: 16 voxels at opacity 0.5 are opaque, alpha {}", pixel[3]);
        }
        let empty = pixel_at(&image, projected(&camera, [-20.0, 0.0, 20.0]));
        assert_eq!(empty, [0.0; 4], "{mode:?}: nothing drawn where no class is");
    }
}

#[test]
fn pre_and_post_classification_agree_away_from_borders() {
    // Anisotropic, with colour and opacity steep in the gradient factor, so both modes must
    // measure gradients in value per mm alike.
    let (phantom, mut styles, _) = three_boxes_spaced([1.5, 1.0, 0.75]);
    for style in &mut styles {
        style.hue_degrees[1] = style.hue_degrees[0] + 60.0;
        style.opacity = [0.05, 0.6];
        style.gradient_max = 60.0;
    }
    let camera = Camera { azimuth_degrees: 25.0, elevation_degrees: 15.0, ..front_camera() };
    let settings = |mode| RenderSettings { mode, background: [0.1, 0.1, 0.1, 1.0], ..RenderSettings::default() };
    let [post, pre] = [RenderMode::Postclassified, RenderMode::Preclassified]
        .map(|mode| capture(&mut phantom.ray_caster(&styles, mode), &camera, &settings(mode), SIZE));
    look("agree-post", &post);
    look("agree-pre", &pre);
    let differences = channel_differences(&post, &pre);
    let mean = differences.iter().map(|&d| d as f64).sum::<f64>() / differences.len() as f64;
    let large = differences.iter().filter(|&&d| d > 48).count() as f64 / differences.len() as f64;
    assert!(mean < 4.0, "mean channel difference {mean}/255");
    assert!(large < 0.03, "{:.1}% of pixels differ by more than 48/255 (borders only)", large * 100.0);
}

#[test]
fn gradient_factor_is_measured_in_value_per_mm_in_both_modes() {
    // A linear ramp 3x + y + 2z (per voxel) with spacing 2 x 1 x 0.5 mm: 1.5, 1 and 4 per mm,
    // the same everywhere, so the whole class shows `ClassStyle::rgba` at that magnitude.
    let dims = [32usize; 3];
    let mut values = Vec::new();
    let mut labels = Vec::new();
    for z in 0..32 {
        for y in 0..32 {
            for x in 0..32 {
                values.push((3 * x + y + 2 * z) as u8);
                labels.push([x, y, z].iter().all(|&c| (6..26).contains(&c)) as u8);
            }
        }
    }
    let volume = crate::volume::Volume::new(
        dims,
        [2.0, 1.0, 0.5],
        VoxelType::U8,
        crate::volume::ByteOrder::Little,
        crate::volume::ValueScale::IDENTITY,
        crate::volume::VoxelBytes::Owned(values),
        std::path::Path::new("ramp"),
    )
    .unwrap();
    let phantom = Phantom { volume, labels };
    let magnitude = (1.5f32 * 1.5 + 1.0 + 4.0 * 4.0).sqrt();
    let ramp_style = ClassStyle {
        hue_degrees: [0.0, 120.0],
        saturation: 1.0,
        value: 1.0,
        opacity: [0.5, 0.5],
        gradient_max: 2.0 * magnitude,
        emphasis: 1.0,
        visible: true,
    };
    let expected_hue = hsv(ramp_style.rgba(magnitude)[..3].try_into().unwrap())[0];
    assert!((expected_hue - 60.0).abs() < 1e-3);
    let camera = Camera { azimuth_degrees: 30.0, elevation_degrees: 20.0, ..Camera::orthographic_front() };
    for mode in [RenderMode::Postclassified, RenderMode::Preclassified] {
        let image =
            capture(&mut phantom.ray_caster(std::slice::from_ref(&ramp_style), mode), &camera, &flat(mode), SIZE);
        look(&format!("ramp-{mode:?}"), &image);
        let pixel = pixel_at(&image, [64.0, 64.0]);
        let hue = hsv(pixel[..3].try_into().unwrap())[0];
        assert!(hue_distance(hue, expected_hue) < 3.0, "{mode:?}: hue {hue}, expected {expected_hue}");
    }
}

#[test]
fn empty_space_skipping_never_changes_the_image() {
    // Curved surfaces cross the bricks at every sub-voxel offset, so a skip one sample too far
    // shows somewhere; class 2 (a box between the spheres) is hidden, so its bricks are empty.
    let phantom = Phantom::new([64; 3], [1.0; 3], VoxelType::U8, |p| {
        let distance = |c: [f32; 3]| (0..3).map(|a| (p[a] - c[a]).powi(2)).sum::<f32>().sqrt();
        if distance([-10.0, 3.0, -10.0]) < 14.0 {
            1
        } else if distance([14.0, -5.0, 14.0]) < 10.0 {
            3
        } else if p.iter().all(|c| c.abs() < 6.0) {
            2
        } else {
            0
        }
    });
    let mut styles = vec![style(0.0, 0.3), style(120.0, 0.3), style(240.0, 0.3)];
    styles[1].visible = false;
    let camera = Camera { azimuth_degrees: 40.0, elevation_degrees: 30.0, ..front_camera() };
    for mode in [RenderMode::Postclassified, RenderMode::Preclassified] {
        let mut ray_caster = phantom.ray_caster(&styles, mode);
        let with = RenderSettings { mode, ..RenderSettings::default() };
        let without = RenderSettings { empty_space_skipping: false, ..with };
        let skipped = capture(&mut ray_caster, &camera, &with, SIZE);
        let marched = capture(&mut ray_caster, &camera, &without, SIZE);
        let differences = channel_differences(&skipped, &marched);
        let changed = differences.iter().filter(|&&d| d > 1).count();
        assert!(
            changed == 0,
            "{mode:?}: {changed} pixels changed by skipping (largest {:?})",
            differences.iter().max()
        );
        let dominant = |channel: usize| {
            skipped
                .pixels()
                .filter(|p| p[3] > 128 && (0..3).all(|c| c == channel || p[channel] as u32 > p[c] as u32 + 30))
                .count()
        };
        assert!(
            dominant(0) > 100 && dominant(2) > 100 && dominant(1) == 0,
            "{mode:?}: red and blue drawn, green hidden"
        );
    }
}

#[test]
fn the_clip_box_and_class_visibility_remove_what_they_should() {
    let (phantom, mut styles, centres) = three_boxes();
    let camera = front_camera();
    let mut ray_caster = phantom.ray_caster(&styles, RenderMode::Postclassified);
    let whole = capture(&mut ray_caster, &camera, &flat(RenderMode::Postclassified), SIZE);
    let left_half = ClipBox { min: [0.0; 3], max: [0.5, 1.0, 1.0] };
    let clipped = RenderSettings { clip_box: left_half, ..flat(RenderMode::Postclassified) };
    let image = capture(&mut ray_caster, &camera, &clipped, SIZE);
    look("clipped-left-half", &image);
    let at = |image: &image::RgbaImage, point| pixel_at(image, projected(&camera, point));
    assert_eq!(at(&image, centres[0]), at(&whole, centres[0]), "the red box (x < 22) stays");
    assert_eq!(at(&image, centres[1])[3], 0.0, "the green box (x >= 42) is clipped away");
    let blue_left = [centres[2][0] - 3.0, 0.0, centres[2][2]];
    let blue_right = [centres[2][0] + 3.0, 0.0, centres[2][2]];
    assert!(at(&image, blue_left)[3] > 0.9 && at(&image, blue_right)[3] == 0.0, "the blue box is cut at x = 0");

    styles[0].visible = false;
    ray_caster.set_class_table(&styles).unwrap();
    let image = capture(&mut ray_caster, &camera, &flat(RenderMode::Postclassified), SIZE);
    assert_eq!(at(&image, centres[0])[3], 0.0, "hidden class 1");
    assert_eq!(at(&image, centres[1]), at(&whole, centres[1]), "class 2 untouched");
}

#[test]
fn a_clip_plane_cuts_what_the_box_cuts_and_tilts() {
    let (phantom, styles, centres) = three_boxes();
    let camera = front_camera();
    let mut ray_caster = phantom.ray_caster(&styles, RenderMode::Postclassified);
    let at = |image: &image::RgbaImage, point| pixel_at(image, projected(&camera, point));
    let post = flat(RenderMode::Postclassified);
    let whole = capture(&mut ray_caster, &camera, &post, SIZE);
    // x > 0 cut away: the box's left half, drawn alike.
    let plane = |normal, offset_mm| RenderSettings { clip_plane: Some(ClipPlane { normal, offset_mm }), ..post };
    let by_plane = capture(&mut ray_caster, &camera, &plane([2.0, 0.0, 0.0], 0.0), SIZE);
    let left_half = ClipBox { min: [0.0; 3], max: [0.5, 1.0, 1.0] };
    let by_box = capture(&mut ray_caster, &camera, &RenderSettings { clip_box: left_half, ..post }, SIZE);
    look("clip-plane-left-half", &by_plane);
    assert_eq!(at(&by_plane, centres[0]), at(&whole, centres[0]), "the red box (x < 0) stays");
    assert_eq!(at(&by_plane, centres[1])[3], 0.0, "the green box (x > 0) is cut away");
    let differing = by_plane.pixels().zip(by_box.pixels()).filter(|(a, b)| a != b).count();
    assert!(differing < 2 * SIZE[1] as usize, "plane and box agree but for the cut's edge: {differing} pixels");
    // Turned round, the plane keeps the other side.
    let other = capture(&mut ray_caster, &camera, &plane([-1.0, 0.0, 0.0], 0.0), SIZE);
    assert_eq!(at(&other, centres[0])[3], 0.0, "red cut away");
    assert_eq!(at(&other, centres[1]), at(&whole, centres[1]), "green kept");
    // Tilted toward the viewer (normal toward the eye): the front of each box is peeled and the
    // colour behind it shows, still drawn where the plane passes behind a box.
    let toward_eye = camera.view_rays([64.0; 3], SIZE[0], SIZE[1]).forward_in_world.map(|f| -f);
    let peeled = capture(&mut ray_caster, &camera, &plane(toward_eye, -1000.0), SIZE);
    assert!(peeled.pixels().all(|p| p[3] == 0), "everything in front of a far plane is cut");
    let kept = capture(&mut ray_caster, &camera, &plane(toward_eye, 1000.0), SIZE);
    assert_eq!(kept, whole, "a plane beyond the volume cuts nothing");
}

#[test]
fn per_class_opacity_scales_one_class_and_zero_hides_it() {
    let (phantom, mut styles, centres) = three_boxes();
    let camera = front_camera();
    let settings = flat(RenderMode::Postclassified);
    let mut ray_caster = phantom.ray_caster(&styles, RenderMode::Postclassified);
    let whole = capture(&mut ray_caster, &camera, &settings, SIZE);
    let at = |image: &image::RgbaImage, point| pixel_at(image, projected(&camera, point));
    assert_eq!(ray_caster.class_opacity(1), Some(styles[0].emphasis));
    assert_eq!((ray_caster.class_opacity(0), ray_caster.class_opacity(4)), (None, None));

    // Zero: the same picture as hiding the class.
    ray_caster.set_class_opacity(1, 0.0).unwrap();
    let zero = capture(&mut ray_caster, &camera, &settings, SIZE);
    styles[0].visible = false;
    let mut hidden_caster = phantom.ray_caster(&styles, RenderMode::Postclassified);
    let hidden = capture(&mut hidden_caster, &camera, &settings, SIZE);
    assert!(channel_differences(&zero, &hidden).iter().all(|&d| d == 0));
    assert_eq!(at(&zero, centres[0])[3], 0.0, "class 1 is gone");
    assert_eq!(at(&zero, centres[1]), at(&whole, centres[1]), "class 2 untouched");

    // A twentieth of the opacity: class 1 fainter, then back to the start.
    ray_caster.set_class_opacity(1, 0.05).unwrap();
    let faint = capture(&mut ray_caster, &camera, &settings, SIZE);
    let (faint_alpha, whole_alpha) = (at(&faint, centres[0])[3], at(&whole, centres[0])[3]);
    assert!(faint_alpha > 0.05 && faint_alpha < whole_alpha - 0.1, "{faint_alpha} vs {whole_alpha}");
    ray_caster.set_class_opacity(1, 1.0).unwrap();
    let back = capture(&mut ray_caster, &camera, &settings, SIZE);
    assert!(channel_differences(&back, &whole).iter().all(|&d| d == 0));

    for (label, factor) in [(0, 1.0), (4, 1.0), (1, -0.1), (1, f32::NAN), (1, MAX_CLASS_OPACITY_FACTOR + 1.0)] {
        let result = ray_caster.set_class_opacity(label, factor);
        assert!(matches!(result, Err(RenderError::BadSetting { .. })), "{label} {factor}: {result:?}");
    }
    assert_eq!(ray_caster.class_opacity(1), Some(1.0), "a refused setting changes nothing");
}

#[test]
fn opacity_is_corrected_for_the_sample_distance() {
    // A 10-voxel slab along the view direction at opacity 0.1 per voxel: 1 - 0.9^10 whatever
    // the step.
    let phantom = Phantom::new([32; 3], [1.0; 3], VoxelType::U8, |p| (p[1].abs() < 5.0) as u8);
    let mut ray_caster = phantom.ray_caster(&[style(60.0, 0.1)], RenderMode::Postclassified);
    let expected = 1.0 - 0.9f32.powi(10);
    for step_voxels in [0.25, 0.5, 1.0, 2.0] {
        let settings = RenderSettings { step_voxels, ..flat(RenderMode::Postclassified) };
        let image = capture(&mut ray_caster, &Camera::orthographic_front(), &settings, SIZE);
        let patch: Vec<f32> = (54..74)
            .flat_map(|y| (54..74).map(move |x| (x, y)))
            .map(|(x, y)| image.get_pixel(x, y)[3] as f32 / 255.0)
            .collect();
        let mean = patch.iter().sum::<f32>() / patch.len() as f32;
        assert!((mean - expected).abs() < 0.02, "step {step_voxels}: alpha {mean}, expected {expected}");
    }
}

#[test]
fn shading_darkens_the_rim_and_can_be_switched_off() {
    let phantom = sphere([48; 3], [1.0; 3], VoxelType::U8, 16.0);
    let mut ray_caster = phantom.ray_caster(&[style(30.0, 1.0)], RenderMode::Postclassified);
    let camera = Camera { zoom: 1.5, ..Camera::orthographic_front() };
    let rim = projected(&camera, [13.5, 0.0, 0.0]);
    let centre = projected(&camera, [0.0; 3]);
    let shaded_settings = RenderSettings { shading: true, ..flat(RenderMode::Postclassified) };
    let shaded = capture(&mut ray_caster, &camera, &shaded_settings, SIZE);
    look("sphere-shaded", &shaded);
    let brightness = |image: &image::RgbaImage, at| hsv(pixel_at(image, at)[..3].try_into().unwrap())[2];
    assert!(brightness(&shaded, centre) > brightness(&shaded, rim) + 0.15, "headlight: the centre faces the eye");
    let flat_image = capture(&mut ray_caster, &camera, &flat(RenderMode::Postclassified), SIZE);
    assert!((brightness(&flat_image, centre) - brightness(&flat_image, rim)).abs() < 0.03);
}

#[test]
fn label_cells_never_change_the_image() {
    // Three classes touching along curved borders, seen at an angle: cells of every kind.
    let phantom = Phantom::new([48; 3], [1.0, 1.0, 1.5], VoxelType::U8, |p| {
        let distance = |c: [f32; 3]| (0..3).map(|a| (p[a] - c[a]).powi(2)).sum::<f32>().sqrt();
        if distance([-6.0, 0.0, -4.0]) < 13.0 {
            1
        } else if distance([8.0, 2.0, 6.0]) < 12.0 {
            3
        } else if p.iter().all(|c| c.abs() < 16.0) {
            2
        } else {
            0
        }
    });
    let styles = [style(0.0, 0.4), style(120.0, 0.15), style(240.0, 0.5)];
    let camera = Camera { azimuth_degrees: 35.0, elevation_degrees: 25.0, ..front_camera() };
    for label_interpolation in [LabelInterpolation::LargestIndicatorWeight, LabelInterpolation::Nearest] {
        let settings = RenderSettings { label_interpolation, ..RenderSettings::default() };
        let mut ray_caster = phantom.ray_caster(&styles, RenderMode::Postclassified);
        let with_cells = capture(&mut ray_caster, &camera, &settings, SIZE);
        ray_caster.mark_every_cell_mixed();
        let voted = capture(&mut ray_caster, &camera, &settings, SIZE);
        let differences = channel_differences(&with_cells, &voted);
        assert!(differences.iter().all(|&d| d == 0), "{label_interpolation:?}: largest {:?}", differences.iter().max());
        assert!(with_cells.pixels().filter(|p| p[3] > 128).count() > 1000, "something is drawn");
    }
}

/// Two classes meeting at the plane x = 0, seen along the plane: any colour that is not one of
/// the two classes' own is bleeding.
fn largest_bleeding(mode: RenderMode, label_interpolation: LabelInterpolation) -> f32 {
    let phantom = Phantom::new([32; 3], [1.0; 3], VoxelType::U8, |p| {
        if p.iter().all(|c| c.abs() < 12.0) { if p[0] < 0.0 { 1 } else { 2 } } else { 0 }
    });
    let styles = [style(0.0, 0.6), style(232.0, 0.6)];
    let settings = RenderSettings { label_interpolation, ..flat(mode) };
    let camera = Camera { zoom: 3.0, ..Camera::orthographic_front() };
    let image = capture(&mut phantom.ray_caster(&styles, mode), &camera, &settings, SIZE);
    look(&format!("bleeding-{mode:?}-{label_interpolation:?}"), &image);
    let pure: Vec<[f32; 3]> = styles
        .iter()
        .flat_map(|s| (0..=20).map(move |i| s.rgba(s.gradient_max * i as f32 / 20.0)))
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    image
        .pixels()
        .filter(|p| p[3] > 240)
        .map(|p| {
            let rgb = [0, 1, 2].map(|c| p[c] as f32 / 255.0);
            pure.iter().map(|q| (0..3).map(|c| (rgb[c] - q[c]).abs()).fold(0.0, f32::max)).fold(f32::MAX, f32::min)
        })
        .fold(0.0, f32::max)
}

#[test]
fn post_classification_does_not_bleed_colours_across_class_borders() {
    let indicator = largest_bleeding(RenderMode::Postclassified, LabelInterpolation::LargestIndicatorWeight);
    let nearest = largest_bleeding(RenderMode::Postclassified, LabelInterpolation::Nearest);
    let interpolated_rgba = largest_bleeding(RenderMode::Preclassified, LabelInterpolation::LargestIndicatorWeight);
    assert!(indicator < 0.03, "largest indicator weight: off by {indicator}");
    assert!(nearest < 0.03, "nearest label: off by {nearest}");
    assert!(interpolated_rgba > 0.2, "the test must see bleeding where it exists: {interpolated_rgba}");
}

#[test]
fn srgb_targets_store_the_same_display_values() {
    let (phantom, styles, _) = three_boxes();
    let gpu = gpu();
    let camera = front_camera();
    let settings = flat(RenderMode::Postclassified);
    let mut plain = phantom.ray_caster(&styles, RenderMode::Postclassified);
    let expected = capture(&mut plain, &camera, &settings, SIZE);
    let mut srgb = RayCaster::new(&gpu.device, &gpu.queue, wgpu::TextureFormat::Rgba8UnormSrgb).unwrap();
    srgb.set_class_table(&styles).unwrap();
    srgb.set_volume(&phantom.volume).unwrap();
    srgb.set_labels(&phantom.labels).unwrap();
    let target =
        OffscreenTarget::new(&gpu.device, &gpu.queue, SIZE[0], SIZE[1], wgpu::TextureFormat::Rgba8UnormSrgb).unwrap();
    let image = target.capture(&mut srgb, &camera, &settings).unwrap();
    let largest = channel_differences(&expected, &image).into_iter().max().unwrap();
    assert!(largest <= 2, "sRGB round trip off by {largest}/255");
}

fn target_view(device: &wgpu::Device, size: [u32; 2]) -> wgpu::TextureView {
    device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("test target"),
            size: wgpu::Extent3d { width: size[0], height: size[1], depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: OFFSCREEN_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        })
        .create_view(&Default::default())
}

#[test]
fn missing_or_mismatched_inputs_are_errors_not_garbage() {
    let gpu = gpu();
    let (phantom, styles, _) = three_boxes();
    let mut ray_caster = RayCaster::new(&gpu.device, &gpu.queue, OFFSCREEN_FORMAT).unwrap();
    let target = OffscreenTarget::new(&gpu.device, &gpu.queue, 8, 8, OFFSCREEN_FORMAT).unwrap();
    let camera = Camera::default();
    let post = flat(RenderMode::Postclassified);
    assert!(matches!(
        target.capture(&mut ray_caster, &camera, &post),
        Err(RenderError::MissingInput { missing, .. }) if missing.contains("scalar")
    ));
    assert!(matches!(ray_caster.set_labels(&phantom.labels), Err(RenderError::MissingInput { .. })));
    ray_caster.set_volume(&phantom.volume).unwrap();
    assert!(matches!(
        target.capture(&mut ray_caster, &camera, &post),
        Err(RenderError::MissingInput { missing, .. }) if missing.contains("label")
    ));
    assert!(matches!(ray_caster.set_labels(&phantom.labels[1..]), Err(RenderError::DataSize { .. })));
    assert!(matches!(
        ray_caster.set_rgba(VolumeGeometry::of(&phantom.volume), &phantom.labels),
        Err(RenderError::DataSize { .. })
    ));
    ray_caster.set_labels(&phantom.labels).unwrap();
    ray_caster.set_class_table(&styles).unwrap();
    assert!(target.capture(&mut ray_caster, &camera, &post).is_ok());
    ray_caster.resize(4, 4);
    let mut encoder = gpu.device.create_command_encoder(&Default::default());
    let view = target_view(&gpu.device, [8, 8]);
    assert!(matches!(ray_caster.render(&mut encoder, &view, &camera, &post), Err(RenderError::BadSetting { .. })));
    let bad = RenderSettings { step_voxels: 0.0, ..post };
    assert!(matches!(target.capture(&mut ray_caster, &camera, &bad), Err(RenderError::BadSetting { .. })));
    let huge =
        Phantom::new([4, 4, gpu.device.limits().max_texture_dimension_3d as usize + 1], [1.0; 3], VoxelType::U8, |_| 1);
    assert!(matches!(ray_caster.set_volume(&huge.volume), Err(RenderError::VolumeTooLarge { .. })));
}
