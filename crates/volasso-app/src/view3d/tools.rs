//! The 3-D view's tools as the UI calls them: a class's opacity slider, the view's touches and
//! buttons (camera and clip plane, decided by interaction.rs), and the snapshot (snapshot.rs).
//! Each turns a `Session` callback into a change and pushes what changed, without rebuilding
//! the class rows a finger is dragging on.
//!
//! Never: draws, reads input devices or touches the disk itself.

use crate::State;
use crate::refresh;
use crate::ui::{AppWindow, Session};
use crate::view3d::clip;
use crate::view3d::interaction::{Scene, ViewIntent};
use crate::view3d::snapshot::{Places, SnapshotWriter};
use slint::{ComponentHandle, Model};
use std::cell::RefCell;
use std::rc::Rc;
use volasso_core::render::ClipPlane;

type Shared = Rc<RefCell<State>>;

/// The opacity slider of class row `index` moved to `percent`: the 3-D view redraws, the row's
/// knob follows, and the slices are redrawn only when the class appears or disappears there.
pub(crate) fn class_opacity(window: &AppWindow, state: &Shared, index: i32, percent: i32) {
    let Ok(index) = usize::try_from(index) else { return };
    let changed = {
        let mut state = state.borrow_mut();
        let changed = state.ctl.set_class_opacity(index, percent);
        if changed.view {
            state.view.dirty = true;
        }
        let opacity = (state.ctl.class_opacity(index) * 100.0).round() as i32;
        // The row is updated in place: replacing the model would end the finger's drag.
        if let Some(mut entry) = state.classes_model.row_data(index)
            && entry.opacity != opacity
        {
            entry.opacity = opacity;
            state.classes_model.set_row_data(index, entry);
        }
        changed
    };
    if changed.classes {
        for panel in 0..crate::PANEL_COUNT {
            refresh::push_slice(window, state, panel);
        }
    }
}

/// What the view's tools keep between callbacks.
#[derive(Default)]
pub(crate) struct Tools {
    /// The newest whole picture of the 3-D view (what a snapshot writes).
    pub(crate) picture: Option<image::RgbaImage>,
    pub(crate) snapshots: SnapshotWriter,
    /// The confirmation shown over the view, and the timer that clears it.
    toast_timer: Rc<slint::Timer>,
}

/// How long the snapshot's confirmation stays.
const TOAST_TIME: std::time::Duration = std::time::Duration::from_secs(6);

/// The volume's box in mm, when one is open.
fn open_extent(state: &State) -> Option<[f32; 3]> {
    let volume = &state.ctl.work.as_ref()?.loaded.volume;
    Some(clip::extent_mm(volume.dims, volume.spacing_mm))
}

/// A new clip plane (or none): to the renderer, the slices and (when `save`) the session.
fn set_clip(window: &AppWindow, state: &Shared, plane: Option<ClipPlane>, save: bool) {
    {
        let mut state = state.borrow_mut();
        state.ctl.look.clip = plane;
        state.ctl.renderer.set_clip(plane);
        state.view.dirty = true;
        if save {
            state.ctl.save();
        }
    }
    window.global::<Session>().set_clipping(plane.is_some());
    for panel in 0..crate::PANEL_COUNT {
        refresh::push_slice(window, state, panel);
    }
}

/// A touch or button on the 3-D view (`interaction::ViewIntent`): the model moves the camera
/// or the clip plane; a new plane goes to the renderer, the slices and, once final, the session.
pub(crate) fn view_intent(window: &AppWindow, state: &Shared, intent: ViewIntent) {
    let effects = {
        let mut state = state.borrow_mut();
        let scene = Scene { extent_mm: open_extent(&state), clip: state.ctl.look.clip };
        state.view.update(intent, scene)
    };
    if let Some(change) = effects.clip {
        set_clip(window, state, change.plane, change.save);
    }
    if effects.save {
        state.borrow_mut().ctl.save();
    }
}

/// "Snapshot": the 3-D view's newest picture to the data folder and any USB stick.
pub(crate) fn snapshot(window: &AppWindow, state: &Shared) {
    let refused = {
        let mut state = state.borrow_mut();
        let open = state.ctl.work.is_some();
        let places = Places { data_dir: state.config.data_dir.clone(), media_roots: state.config.media_roots.clone() };
        match state.tools.picture.clone().filter(|_| open) {
            Some(picture) => {
                state.tools.snapshots.start(picture, places);
                None
            }
            None => Some("Nothing to save yet: the 3-D view shows no picture".to_string()),
        }
    };
    if let Some(message) = refused {
        show_toast(window, state, message);
    }
}

/// Collects finished snapshots (the poll timer): their confirmation is shown over the view.
pub(crate) fn poll(window: &AppWindow, state: &Shared) {
    let outcome = state.borrow_mut().tools.snapshots.poll();
    if let Some(outcome) = outcome {
        let message = outcome.message();
        log::info!("{message}");
        show_toast(window, state, message);
    }
}

fn show_toast(window: &AppWindow, state: &Shared, message: String) {
    window.global::<Session>().set_view_toast(message.into());
    let timer = state.borrow().tools.toast_timer.clone();
    let weak = window.as_weak();
    timer.start(slint::TimerMode::SingleShot, TOAST_TIME, move || {
        if let Some(window) = weak.upgrade() {
            window.global::<Session>().set_view_toast("".into());
        }
    });
}
