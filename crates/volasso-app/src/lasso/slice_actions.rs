//! What touches on a slice do: finger paths become lassos or swipes (decided in drawing.rs,
//! with visible feedback for anything else), the ranked and scrubbed slice changes, a slice
//! is enlarged to fill the work area and zoomed and panned there with two fingers, and the
//! display window is picked from presets or dragged with two fingers on a slice of the grid.
//!
//! Never: changes what the classifier sees other than through lassos (windows are display
//! only), or draws.

use crate::lasso::drawing::{FingerPath, PathMeaning, Unclear};
use crate::ui::AppWindow;
use crate::windowing::{self, CUSTOM};
use crate::{State, refresh};
use std::cell::RefCell;
use std::rc::Rc;
use volasso_core::slices::Axis;

type Shared = Rc<RefCell<State>>;

/// The zoom of an enlarged slice: 1 fits the work area.
pub const ZOOM_RANGE: (f32, f32) = (1.0, 8.0);

pub(crate) fn lasso_down(
    window: &AppWindow,
    state: &Shared,
    panel: i32,
    point: [f32; 2],
    picture_px: [f32; 2],
    ms: f64,
) {
    let mut state_ref = state.borrow_mut();
    let Some(work) = state_ref.ctl.work.as_mut() else { return };
    let had_feedback = work.feedback.take().map(|(on, _)| on);
    let panel = panel.max(0) as usize;
    let broken_off = work.broken_off.take().filter(|(on, _)| *on == panel).map(|(_, path)| path);
    work.drawing = Some((panel, FingerPath::resumed_or_new(broken_off, picture_px, point, ms)));
    drop(state_ref);
    if let Some(on) = had_feedback {
        refresh::push_slice(window, state, on);
    }
    refresh::push_lasso(window, state);
}

pub(crate) fn lasso_move(window: &AppWindow, state: &Shared, panel: i32, point: [f32; 2], ms: f64) {
    let mut state_ref = state.borrow_mut();
    let Some((drawn_on, path)) = state_ref.ctl.work.as_mut().and_then(|work| work.drawing.as_mut()) else { return };
    if *drawn_on != panel.max(0) as usize {
        return;
    }
    path.add(point, ms);
    drop(state_ref);
    refresh::push_lasso(window, state);
}

/// The finger lifted (or the touch was cancelled: a negative point, e.g. a second finger
/// turned it into a two-finger gesture, which is not a path). A path that broke off open is
/// kept a moment, for the finger to land again and go on with it.
pub(crate) fn lasso_up(window: &AppWindow, state: &Shared, panel: i32, point: [f32; 2], ms: f64) {
    let meaning = {
        let mut state_ref = state.borrow_mut();
        let Some(work) = state_ref.ctl.work.as_mut() else { return };
        let Some((drawn_on, mut path)) = work.drawing.take() else { return };
        if drawn_on != panel.max(0) as usize {
            None
        } else if point[0] < 0.0 {
            path.cancelled().map(|unclear| (drawn_on, PathMeaning::Unclear(unclear)))
        } else {
            path.add(point, ms);
            let dims = work.loaded.volume.dims;
            let meaning = work.panels.get(drawn_on).map(|p| (drawn_on, path.meaning(dims, &p.layout, p.slice)));
            if let Some((_, PathMeaning::Unclear(Unclear::Open))) = meaning {
                work.broken_off = Some((drawn_on, path));
            }
            meaning
        }
    };
    refresh::push_lasso(window, state);
    match meaning {
        Some((_, PathMeaning::Lasso(lasso))) => refresh::edit_session(window, state, |session| {
            session.add_lasso(lasso);
            Ok(())
        }),
        Some((panel, PathMeaning::Swipe(delta))) => step_slice(window, state, panel as i32, delta),
        Some((panel, PathMeaning::Unclear(unclear))) => {
            {
                let mut state = state.borrow_mut();
                state.status = unclear.message().into();
                if let Some(work) = state.ctl.work.as_mut() {
                    work.feedback = Some((panel, unclear.message().into()));
                }
            }
            refresh::push_slice(window, state, panel);
            refresh::push_status(window, state);
        }
        None => {}
    }
}

/// The slice `delta` ranks further along the panel's ranking (a swipe, ◀ ▶).
pub(crate) fn step_slice(window: &AppWindow, state: &Shared, panel: i32, delta: i32) {
    move_slice(window, state, panel, |rank, order| {
        let rank = (rank as i64 + delta as i64).clamp(0, order.len() as i64 - 1) as usize;
        (rank, order[rank])
    });
}

/// Slice `slice` of the panel's axis (the scrubber).
pub(crate) fn scrub_slice(window: &AppWindow, state: &Shared, panel: i32, slice: i32) {
    move_slice(window, state, panel, |_, order| {
        let slice = (slice.max(0) as usize).min(order.len() - 1);
        (order.iter().position(|&s| s == slice).unwrap_or(0), slice)
    });
}

/// Shows on `panel` the (rank, slice) that `choose` picks from the current rank and the
/// axis's ranking (never empty: an axis has at least one slice).
fn move_slice(window: &AppWindow, state: &Shared, panel: i32, choose: impl FnOnce(usize, &[usize]) -> (usize, usize)) {
    let panel = panel.max(0) as usize;
    {
        let mut state = state.borrow_mut();
        let Some(work) = state.ctl.work.as_mut() else { return };
        work.feedback = None;
        let ranking = &work.loaded.entropies;
        let Some(shown) = work.panels.get_mut(panel) else { return };
        (shown.rank, shown.slice) = choose(shown.rank, &ranking.axis(shown.axis).order);
    }
    refresh::push_slice(window, state, panel);
}

/// The slice of `panel` fills the work area, at zoom 1.
pub(crate) fn enlarge(window: &AppWindow, state: &Shared, panel: i32) {
    {
        let mut state = state.borrow_mut();
        let Some(work) = state.ctl.work.as_mut() else { return };
        let panel = panel.max(0) as usize;
        if panel >= work.panels.len() {
            return;
        }
        work.enlarged = Some(panel);
        work.zoom = 1.0;
        work.pan = [0.0; 2];
        work.drawing = None;
        work.broken_off = None;
    }
    refresh::push_slice_layout(window, state);
}

/// Back to the three slices.
pub(crate) fn shrink(window: &AppWindow, state: &Shared) {
    if let Some(work) = state.borrow_mut().ctl.work.as_mut() {
        work.enlarged = None;
        work.drawing = None;
        work.broken_off = None;
    }
    refresh::push_slice_layout(window, state);
}

pub(crate) fn choose_window(window: &AppWindow, state: &Shared, name: &str) {
    {
        let mut state = state.borrow_mut();
        let Some(work) = state.ctl.work.as_mut() else { return };
        let Some(preset) = work.loaded.windows.find(name) else { return };
        work.window = preset.window;
        work.window_name = preset.name.to_string();
        state.status = windowing::describe(preset.name, preset.window);
    }
    refresh::push_work(window, state);
}

/// Two fingers on the slice normal to `axis`: on the enlarged slice they zoom (`zoom`
/// multiplies) and pan (`pan` in fractions of the visible area); on a slice of the grid they
/// drag the display window (windowing.rs).
pub(crate) fn slice_gesture(window: &AppWindow, state: &Shared, axis: Axis, zoom: f32, pan: [f32; 2]) {
    if !(zoom.is_finite() && zoom > 0.0 && pan.iter().all(|p| p.is_finite())) {
        return;
    }
    let window_changed = {
        let mut state_ref = state.borrow_mut();
        let Some(work) = state_ref.ctl.work.as_mut() else { return };
        let Some(panel) = work.panels.iter().position(|p| p.axis == axis) else { return };
        if work.enlarged == Some(panel) {
            let zoomed = (work.zoom * zoom).clamp(ZOOM_RANGE.0, ZOOM_RANGE.1);
            let ratio = zoomed / work.zoom;
            work.zoom = zoomed;
            // The point at the area's centre stays there as the zoom changes; the picture
            // cannot be pushed further than its edges.
            let limit = (zoomed - 1.0) / 2.0;
            work.pan = std::array::from_fn(|a| (work.pan[a] * ratio + pan[a]).clamp(-limit, limit));
            false
        } else if work.enlarged.is_none() && pan != [0.0; 2] {
            let range = work.loaded.volume.value_range();
            work.window = windowing::dragged(work.window, pan, range);
            work.window_name = CUSTOM.to_string();
            let described = windowing::describe(CUSTOM, work.window);
            state_ref.status = described;
            true
        } else {
            return;
        }
    };
    if window_changed {
        refresh::push_work(window, state);
    } else {
        refresh::push_slice_layout(window, state);
    }
}
