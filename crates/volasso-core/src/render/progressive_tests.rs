use super::*;
use crate::render::RenderMode;
use crate::render::test_support::{Phantom, capture, channel_differences, gpu, style};
use crate::volume::VoxelType;

fn two_spheres() -> Phantom {
    Phantom::new([40; 3], [1.0, 1.0, 1.25], VoxelType::U8, |p| {
        let distance = |c: [f32; 3]| (0..3).map(|a| (p[a] - c[a]).powi(2)).sum::<f32>().sqrt();
        if distance([-5.0, 0.0, 0.0]) < 11.0 {
            1
        } else if distance([7.0, 3.0, 4.0]) < 9.0 {
            2
        } else {
            0
        }
    })
}

#[test]
fn a_full_frame_drawn_in_bands_is_the_frame_drawn_at_once() {
    let phantom = two_spheres();
    let styles = [style(10.0, 0.3), style(200.0, 0.6)];
    let camera = Camera { azimuth_degrees: 25.0, ..Camera::default() };
    let settings = RenderSettings::default();
    let size = [96, 70];
    let mut ray_caster = phantom.ray_caster(&styles, RenderMode::Postclassified);
    let gpu = gpu();
    let mut view = ProgressiveView::new(&gpu.device, &gpu.queue);
    // A cost that makes bands of 9 rows: 8 bands, the last one shorter.
    let row_work = work([size[0], 1], &settings);
    view.planner_mut().record_full(row_work, BAND_SECONDS / 9.0);
    let plan = view.planner().full_plan(size, &settings);
    assert_eq!(plan.bands.len(), 8, "{:?}", plan.bands);
    let banded = view.full(&mut ray_caster, &camera, &settings, size).unwrap();
    assert!(!view.refining());
    let whole = capture(&mut ray_caster, &camera, &settings, size);
    let differences = channel_differences(&banded, &whole);
    assert!(differences.iter().all(|&d| d == 0), "largest difference {:?}", differences.iter().max());
    assert!(whole.pixels().filter(|p| p[3] > 128).count() > 500, "something is drawn");
}

#[test]
fn a_preview_abandons_the_refinement_and_looks_like_the_frame() {
    let phantom = two_spheres();
    let styles = [style(10.0, 0.3), style(200.0, 0.6)];
    let camera = Camera::default();
    let settings = RenderSettings { background: [0.0; 4], ..RenderSettings::default() };
    let size = [120, 80];
    let mut ray_caster = phantom.ray_caster(&styles, RenderMode::Postclassified);
    let gpu = gpu();
    let mut view = ProgressiveView::new(&gpu.device, &gpu.queue);
    // First preview, before anything was measured: a quarter of the size per side.
    let preview = view.preview(&mut ray_caster, &camera, &settings, size).unwrap();
    assert_eq!(preview.dimensions(), (30, 20));
    // A cost that makes bands of 9 rows, whatever this machine measured.
    view.planner_mut().record_full(work([size[0], 1], &settings), BAND_SECONDS / 9.0);
    view.start_full(&camera, &settings, size);
    assert!(view.refine(&mut ray_caster).unwrap().is_none(), "the first of several bands");
    assert!(view.refining());
    let again = view.preview(&mut ray_caster, &camera, &settings, size).unwrap();
    assert!(!view.refining(), "a preview abandons the full frame");
    assert!(view.refine(&mut ray_caster).unwrap().is_none());
    assert!(again.width() <= size[0] && again.height() <= size[1], "{:?}", again.dimensions());
    // The preview covers the same part of the picture as the full frame.
    let full = view.full(&mut ray_caster, &camera, &settings, size).unwrap();
    let covered = |image: &image::RgbaImage| {
        image.pixels().filter(|p| p[3] > 128).count() as f64 / (image.width() * image.height()) as f64
    };
    assert!((covered(&preview) - covered(&full)).abs() < 0.05, "{} vs {}", covered(&preview), covered(&full));
}

#[test]
fn previews_are_sized_to_the_budget_from_measured_costs() {
    let settings = RenderSettings::default();
    let preview_settings = FramePlanner::preview_settings(&settings);
    assert_eq!(preview_settings.step_voxels, 1.0, "twice the default half-voxel step");
    assert_eq!(FramePlanner::preview_settings(&RenderSettings { step_voxels: 6.0, ..settings }).step_voxels, 8.0);
    let full = [1280, 800];
    let mut planner = FramePlanner::default();
    assert_eq!(planner.preview_plan(full, &settings).size, [320, 200], "before any measurement");
    // A full frame of 1.6 s: the preview is planned for 60 % of 150 ms.
    planner.record_full(work(full, &settings), 1.6);
    let plan = planner.preview_plan(full, &settings);
    let predicted = planner.predicted_preview_seconds(full, &settings).unwrap();
    assert!((predicted - PREVIEW_TARGET_FRACTION * PREVIEW_BUDGET_SECONDS).abs() < 0.01, "{predicted}");
    assert!(plan.size[0] < 1280 && plan.size[0] > 160, "{:?}", plan.size);
    assert!((plan.size[0] as f64 / plan.size[1] as f64 - 1.6).abs() < 0.02, "the aspect stays");
    // Previews that came out slower make the next one smaller; a fast machine gets full size.
    planner.record_preview(plan.work(), 0.3);
    assert!(planner.preview_plan(full, &settings).size[0] < plan.size[0]);
    let mut fast = FramePlanner::default();
    fast.record_preview(1e6, 1e-6);
    assert_eq!(fast.preview_plan(full, &settings).size, full);
    // A slow one stops at an eighth per side and samples further apart, up to a limit.
    let mut slower = FramePlanner::default();
    // Twice the work of a preview at an eighth per side (which is half the frame's work per
    // pixel) in the planned time: twice the sample distance.
    let seconds = PREVIEW_TARGET_FRACTION * PREVIEW_BUDGET_SECONDS * 2.0 * 2.0 / MIN_PREVIEW_SCALE.powi(2);
    slower.record_full(work(full, &settings), seconds);
    let plan = slower.preview_plan(full, &settings);
    assert_eq!(plan.size, [160, 100]);
    assert!((plan.settings.step_voxels - 2.0).abs() < 0.05, "{}", plan.settings.step_voxels);
    let mut slow = FramePlanner::default();
    slow.record_full(1.0, 10.0);
    assert_eq!(slow.preview_plan(full, &settings).size, [160, 100]);
    assert_eq!(slow.preview_plan(full, &settings).settings.step_voxels, MAX_PREVIEW_STEP_VOXELS);
    // Measurements that mean nothing are ignored.
    slow.record_full(0.0, 1.0);
    slow.record_full(1.0, f64::NAN);
    assert_eq!(slow.preview_plan(full, &settings).size, [160, 100]);
}

#[test]
fn bands_cover_every_row_once() {
    let settings = RenderSettings::default();
    for (cost, size) in
        [(None, [1280u32, 800u32]), (Some(1e-7), [1280, 800]), (Some(1.0), [33, 7]), (Some(1e-12), [5, 3])]
    {
        let mut planner = FramePlanner::default();
        if let Some(cost) = cost {
            planner.record_full(1.0, cost);
        }
        let plan = planner.full_plan(size, &settings);
        let mut next_row = 0;
        for band in &plan.bands {
            assert!(band.fits(size) && band.x == 0 && band.width == size[0], "{band:?}");
            assert_eq!(band.y, next_row);
            next_row += band.height;
        }
        assert_eq!(next_row, size[1], "{cost:?} {size:?}");
    }
}

#[test]
fn regions_outside_the_frame_are_refused() {
    let phantom = two_spheres();
    let mut ray_caster = phantom.ray_caster(&[style(10.0, 0.3), style(200.0, 0.6)], RenderMode::Postclassified);
    let gpu = gpu();
    let target = OffscreenTarget::new(&gpu.device, &gpu.queue, 16, 16, OFFSCREEN_FORMAT).unwrap();
    let settings = RenderSettings::default();
    for region in [
        PixelRegion { x: 0, y: 10, width: 16, height: 7 },
        PixelRegion { x: 0, y: 0, width: 0, height: 4 },
        PixelRegion { x: u32::MAX, y: 0, width: 2, height: 4 },
    ] {
        let result = target.draw_region(&mut ray_caster, &Camera::default(), &settings, Some(region));
        assert!(matches!(result, Err(RenderError::BadSetting { name: "region", .. })), "{region:?}: {result:?}");
    }
    target
        .draw_region(
            &mut ray_caster,
            &Camera::default(),
            &settings,
            Some(PixelRegion { x: 3, y: 4, width: 13, height: 12 }),
        )
        .unwrap();
}
