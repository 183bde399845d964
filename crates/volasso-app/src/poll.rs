//! The poll timer (every 16 ms on the UI thread): collects what the workers finished (the
//! loader, the gallery, the classifier, the painter, the renderer, the snapshots, the PACS),
//! asks for a new 3-D frame when one is due, and lists the data folder again now and then.
//! Each feature applies its own results; this only calls them in order.
//!
//! Never: waits for a worker.

use super::State;
use super::controller::Changed;
use super::refresh::{apply, push_status, rgba_to_slint_image, to_slint_image};
use super::ui::{AppWindow, Session};
use super::view3d::RenderReply;
use super::view3d::interaction::{Scene, ViewIntent};
use crate::chooser::loading;
use slint::{ComponentHandle, Model};
use std::cell::RefCell;
use std::rc::Rc;

type Shared = Rc<RefCell<State>>;

/// Collects finished work; called every 16 ms on the UI thread.
pub(super) fn poll(window: &AppWindow, state: &Shared) {
    loop {
        // A separate statement: the borrow must end before the event is handled.
        let event = state.borrow_mut().loader.poll();
        let Some(event) = event else { break };
        loading::loader_event(window, state, event);
    }
    crate::gallery::view::poll(window, state);
    crate::presets::view::poll(window, state);
    crate::attract::view::tick(window, state);
    let changed = state.borrow_mut().ctl.poll();
    if changed != Changed::default() {
        apply(window, state, changed);
    }
    loading::confirm_restore(state);
    picture_done(state);
    let reply = state.borrow_mut().ctl.renderer.poll();
    match reply {
        Some(RenderReply::Picture(picture)) => {
            window.global::<Session>().set_view_picture(rgba_to_slint_image(&picture.image));
            state.borrow_mut().tools.picture = Some(picture.image);
        }
        Some(RenderReply::Failed(error)) => {
            let message = error.to_string();
            log::warn!("{message}");
            state.borrow_mut().banner = message;
        }
        None => {}
    }
    request_frame_if_needed(window, state);
    crate::view3d::tools::poll(window, state);
    super::pacs::view::poll(window, state);
    super::pacs::view::push_send(window, state);
    push_status(window, state);
    loading::rescan_data_folder(state);
    loading::drop_vanished(state);
    loading::show_cards(state);
}

/// Shows the slice pictures the painter thread finished.
fn picture_done(state: &Shared) {
    loop {
        let finished = state.borrow_mut().painter.poll();
        let Some((panel, result)) = finished else { return };
        let mut state = state.borrow_mut();
        match result {
            Ok(picture) => {
                let model = state.slices_model.clone();
                if let Some(mut view) = (panel < model.row_count()).then(|| model.row_data(panel)).flatten() {
                    view.picture = to_slint_image(&picture);
                    model.set_row_data(panel, view);
                }
            }
            Err(error) => {
                // The file under the volume changed (truncated) or the slice is gone: say so once.
                let message = error.to_string();
                log::warn!("slice picture: {message}");
                let banner = format!("Cannot show the slice: {message}");
                if state.banner != banner {
                    state.banner = banner;
                }
            }
        }
    }
}

/// Asks the renderer for a frame when the view needs one and none is being drawn: half size
/// while a finger orbits (twice the frame rate on a slow GPU), full size when it lifts.
fn request_frame_if_needed(window: &AppWindow, state: &Shared) {
    let session = window.global::<Session>();
    let scale = window.window().scale_factor();
    let size = [session.get_view_width(), session.get_view_height()].map(|logical| (logical * scale).round() as u32);
    let mut state = state.borrow_mut();
    state.view.update(ViewIntent::Resized(size), Scene::default());
    let classified = state.ctl.work.as_ref().is_some_and(|work| work.classified.is_some());
    if !state.view.dirty || state.ctl.renderer.busy() || !classified || size[0] == 0 || size[1] == 0 {
        if !classified {
            state.view.dirty = false;
        }
        return;
    }
    state.view.dirty = false;
    let size = if state.view.orbiting() { size.map(|side| (side / 2).max(1)) } else { size };
    let camera = state.view.camera;
    state.ctl.renderer.request_frame(camera, size);
}
