//! Touches on the slices without a window: each intent's change to the work and what it asks
//! the screen to show again.

use super::*;
use volasso_core::phantom::demo_foot_with;

fn work() -> Work {
    let volume = demo_foot_with([96, 64, 48], 7).unwrap().volume;
    Work::new(crate::chooser::library::opened_for_tests(volume, volasso_core::preset::Modality::Ct))
}

/// A finger's path on `panel` through `points`, 20 ms apart; the outcome of its lifting.
fn path(work: &mut Work, panel: usize, points: &[[f32; 2]]) -> SliceOutcome {
    let picture_px = [400.0, 300.0];
    let down = work.on_slices(SliceIntent::Down { panel, point: points[0], picture_px, ms: 0.0 });
    assert!(down.path);
    for (k, &point) in points.iter().enumerate().skip(1) {
        work.on_slices(SliceIntent::Move { panel, point, ms: 20.0 * k as f64 });
    }
    let last = *points.last().unwrap();
    work.on_slices(SliceIntent::Up { panel, point: last, ms: 20.0 * points.len() as f64 })
}

/// A closed square loop from `low` to `high` (fractions of the picture), 10 points a side.
fn square(low: f32, high: f32) -> Vec<[f32; 2]> {
    let side = |k: usize| low + (high - low) * k as f32 / 10.0;
    let mut points: Vec<[f32; 2]> = (0..10).map(|k| [side(k), low]).collect();
    points.extend((0..10).map(|k| [high, side(k)]));
    points.extend((0..10).map(|k| [side(10 - k), high]));
    points.extend((0..=10).map(|k| [low, side(10 - k)]));
    points
}

#[test]
fn a_loop_becomes_a_lasso_and_a_tap_says_what_to_do_on_its_panel() {
    let mut work = work();
    let lifted = path(&mut work, 0, &square(0.3, 0.6));
    assert!(lifted.path && lifted.lasso.is_some(), "{lifted:?}");
    assert!(work.drawing.is_none());

    let tapped = path(&mut work, 1, &[[0.5, 0.5], [0.5, 0.5]]);
    assert!(tapped.lasso.is_none());
    assert_eq!(tapped.panels, [1]);
    assert_eq!(tapped.status.as_deref(), Some("Draw a closed loop around the structure"));
    assert_eq!(work.feedback.as_ref().map(|(panel, _)| *panel), Some(1));
    // The next touch takes the feedback away and redraws its panel.
    let down = work.on_slices(SliceIntent::Down { panel: 0, point: [0.1, 0.1], picture_px: [400.0, 300.0], ms: 0.0 });
    assert_eq!(down.panels, [1]);
    assert!(work.feedback.is_none());
    // A second finger cancels the path: no lasso, nothing said.
    let cancelled = work.on_slices(SliceIntent::Up { panel: 0, point: [-1.0, -1.0], ms: 10.0 });
    assert!(cancelled.path && cancelled.lasso.is_none() && cancelled.status.is_none(), "{cancelled:?}");
    // A move on another panel than the path's changes nothing.
    work.on_slices(SliceIntent::Down { panel: 0, point: [0.1, 0.1], picture_px: [400.0, 300.0], ms: 0.0 });
    assert_eq!(work.on_slices(SliceIntent::Move { panel: 2, point: [0.2, 0.2], ms: 5.0 }), SliceOutcome::default());
}

#[test]
fn stepping_and_scrubbing_stay_within_the_axis() {
    let mut work = work();
    let order = work.loaded.entropies.axis(work.panels[0].axis).order.clone();
    let stepped = work.on_slices(SliceIntent::Step { panel: 0, delta: 1 });
    assert_eq!(stepped.panels, [0]);
    assert_eq!((work.panels[0].rank, work.panels[0].slice), (1, order[1]));
    work.on_slices(SliceIntent::Step { panel: 0, delta: 10_000 });
    assert_eq!(work.panels[0].rank, order.len() - 1);
    work.on_slices(SliceIntent::Step { panel: 0, delta: -10_000 });
    assert_eq!((work.panels[0].rank, work.panels[0].slice), (0, order[0]));
    work.on_slices(SliceIntent::Scrub { panel: 0, slice: 1_000 });
    assert_eq!(work.panels[0].slice, order.len() - 1);
    assert_eq!(order[work.panels[0].rank], work.panels[0].slice);
    work.on_slices(SliceIntent::Scrub { panel: 0, slice: -5 });
    assert_eq!(work.panels[0].slice, 0);
    assert_eq!(work.on_slices(SliceIntent::Step { panel: 9, delta: 1 }), SliceOutcome::default());
}

#[test]
fn an_enlarged_slice_zooms_and_pans_within_its_edges_and_the_grid_drags_the_window() {
    let mut work = work();
    assert_eq!(work.on_slices(SliceIntent::Enlarge(7)), SliceOutcome::default());
    let enlarged = work.on_slices(SliceIntent::Enlarge(1));
    assert!(enlarged.layout);
    assert_eq!((work.enlarged, work.zoom, work.pan), (Some(1), 1.0, [0.0; 2]));
    let axis = work.panels[1].axis;
    work.on_slices(SliceIntent::Gesture { axis, zoom: 20.0, pan: [9.0, -9.0] });
    assert_eq!(work.zoom, ZOOM_RANGE.1);
    let limit = (ZOOM_RANGE.1 - 1.0) / 2.0;
    assert_eq!(work.pan, [limit, -limit]);
    assert_eq!(work.on_slices(SliceIntent::Gesture { axis, zoom: f32::NAN, pan: [0.0; 2] }), SliceOutcome::default());
    // Another panel's axis while one is enlarged: nothing.
    let other = work.panels[0].axis;
    assert_eq!(
        work.on_slices(SliceIntent::Gesture { axis: other, zoom: 2.0, pan: [0.1, 0.0] }),
        SliceOutcome::default()
    );
    assert!(work.on_slices(SliceIntent::Shrink).layout);
    assert_eq!(work.enlarged, None);

    let before = work.window;
    let dragged = work.on_slices(SliceIntent::Gesture { axis, zoom: 1.0, pan: [0.2, 0.1] });
    assert!(dragged.window && dragged.status.is_some(), "{dragged:?}");
    assert_eq!(work.window_name, CUSTOM);
    assert_ne!(work.window, before);
    let name = work.loaded.windows.names()[0];
    let chosen = work.on_slices(SliceIntent::ChooseWindow(name.into()));
    assert!(chosen.window);
    assert_eq!(work.window_name, name);
    assert_eq!(work.on_slices(SliceIntent::ChooseWindow("no such window".into())), SliceOutcome::default());
}
