//! The window's callbacks as a table: each `Session` or `SettingsPage` callback becomes one
//! [`Intent`] of the model, applied by [`send`] (the model updates, the view shows what
//! changed).
//!
//! Never: decides anything.

use crate::lasso::slices::SliceIntent;
use crate::model::Intent;
use crate::pacs::{PacsIntent, SearchField};
use crate::settings::SettingsIntent as Setting;
use crate::ui::{AppWindow, Session, SettingsPage};
use crate::view3d::interaction::ViewIntent;
use crate::{State, view};
use slint::{ComponentHandle, SharedString};
use std::cell::RefCell;
use std::rc::Rc;

type Shared = Rc<RefCell<State>>;

/// Applies `intent` to the model and shows what changed.
pub(crate) fn send(window: &AppWindow, state: &Shared, intent: Intent) {
    let mut state = state.borrow_mut();
    let show = state.update(intent);
    view::show(window, &mut state, show);
}

/// A callback closure: the window's arguments become the intent `make` returns (none: nothing
/// happens).
macro_rules! on {
    ($window:expr, $state:expr, || $make:expr) => {
        on!($window, $state, | | $make)
    };
    ($window:expr, $state:expr, |$($arg:ident : $ty:ty),*| $make:expr) => {{
        let weak = $window.as_weak();
        let state = $state.clone();
        move |$($arg: $ty),*| {
            if let Some(window) = weak.upgrade() {
                let intent: Option<Intent> = $make;
                if let Some(intent) = intent {
                    send(&window, &state, intent);
                }
            }
        }
    }};
}

/// A row index from the window (negative: none).
fn row(index: i32) -> Option<usize> {
    usize::try_from(index).ok()
}

pub(crate) fn wire(window: &AppWindow, state: &Shared) {
    let s = window.global::<Session>();
    let panel = |panel: i32| panel.max(0) as usize;
    s.on_start(on!(window, state, || Some(Intent::ShowChooser)));
    s.on_show_chooser(on!(window, state, || Some(Intent::ShowChooser)));
    s.on_open_volume(on!(window, state, |index: i32| row(index).map(Intent::OpenVolume)));
    s.on_lasso_down(on!(window, state, |p: i32, x: f32, y: f32, width: f32, height: f32, ms: f32| {
        let down = SliceIntent::Down { panel: panel(p), point: [x, y], picture_px: [width, height], ms: ms as f64 };
        Some(Intent::Slice(down))
    }));
    s.on_lasso_move(on!(window, state, |p: i32, x: f32, y: f32, ms: f32| {
        Some(Intent::Slice(SliceIntent::Move { panel: panel(p), point: [x, y], ms: ms as f64 }))
    }));
    s.on_lasso_up(on!(window, state, |p: i32, x: f32, y: f32, ms: f32| {
        Some(Intent::Slice(SliceIntent::Up { panel: panel(p), point: [x, y], ms: ms as f64 }))
    }));
    s.on_enlarge(on!(window, state, |p: i32| Some(Intent::Slice(SliceIntent::Enlarge(panel(p))))));
    s.on_shrink(on!(window, state, || Some(Intent::Slice(SliceIntent::Shrink))));
    s.on_choose_window(on!(window, state, |name: SharedString| {
        Some(Intent::Slice(SliceIntent::ChooseWindow(name.into())))
    }));
    s.on_step_slice(on!(window, state, |p: i32, delta: i32| {
        Some(Intent::Slice(SliceIntent::Step { panel: panel(p), delta }))
    }));
    s.on_scrub_slice(on!(window, state, |p: i32, slice: i32| {
        Some(Intent::Slice(SliceIntent::Scrub { panel: panel(p), slice }))
    }));
    s.on_define_class(on!(window, state, || Some(Intent::DefineClass)));
    s.on_undo(on!(window, state, || Some(Intent::Undo)));
    s.on_clear(on!(window, state, || Some(Intent::Clear)));
    s.on_delete_class(on!(window, state, |index: i32| Some(Intent::DeleteClass(index.max(0) as usize))));
    s.on_toggle_class(on!(window, state, |index: i32| Some(Intent::ToggleClass(index.max(0) as usize))));
    s.on_save_preset(on!(window, state, || Some(Intent::SavePreset)));
    s.on_apply_preset(on!(window, state, |index: i32| row(index).map(Intent::ApplyPreset)));
    s.on_choose_preset(on!(window, state, |index: i32| Some(Intent::ChoosePreset(row(index)))));
    s.on_toggle_unsure(on!(window, state, || Some(Intent::ToggleUnsure)));
    s.on_draw_here_next(on!(window, state, || Some(Intent::DrawHereNext)));
    s.on_choose_template(on!(window, state, |name: SharedString| Some(Intent::ChooseTemplate(name.into()))));
    s.on_rotate_template(on!(window, state, |degrees: i32| Some(Intent::RotateTemplate(degrees))));
    // The 3-D view's touches and buttons are intents of its model (view3d/interaction.rs);
    // while clipping, one finger moves the clip plane instead of orbiting.
    s.on_reset_view(on!(window, state, || Some(Intent::View(ViewIntent::ResetView))));
    s.on_view_press(on!(window, state, |x: f32, y: f32| Some(Intent::View(ViewIntent::Press([x, y])))));
    let (weak, shared) = (window.as_weak(), state.clone());
    s.on_view_drag(move |x: f32, y: f32| {
        if let Some(window) = weak.upgrade() {
            let view_height = window.global::<Session>().get_view_height().max(1.0) as u32;
            send(&window, &shared, Intent::View(ViewIntent::Drag { to: [x, y], view_height }));
        }
    });
    s.on_view_release(on!(window, state, || Some(Intent::View(ViewIntent::Release))));
    s.on_view_zoom(on!(window, state, |zoom: f32| {
        Some(Intent::View(ViewIntent::Gesture { zoom, pan_pixels: [0.0; 2], turn_degrees: 0.0 }))
    }));
    s.on_dismiss_banner(on!(window, state, || Some(Intent::DismissBanner)));
    s.on_class_opacity(on!(window, state, |index: i32, percent: i32| {
        row(index).map(|index| Intent::ClassOpacity(index, percent))
    }));
    s.on_toggle_clip(on!(window, state, || Some(Intent::View(ViewIntent::ToggleClip))));
    s.on_reset_clip(on!(window, state, || Some(Intent::View(ViewIntent::ResetClip))));
    s.on_snapshot(on!(window, state, || Some(Intent::Snapshot)));
    s.on_save_result(on!(window, state, || Some(Intent::SaveResult)));
    s.on_open_result(on!(window, state, |index: i32| Some(Intent::OpenResult(index.max(0) as usize))));
    // The PACS screen and "Send to PACS".
    let pacs = |intent: PacsIntent| Some(Intent::Pacs(intent));
    s.on_pacs_open(on!(window, state, || pacs(PacsIntent::Open)));
    s.on_pacs_key(on!(window, state, |key: SharedString| pacs(PacsIntent::Key(key.to_string()))));
    s.on_pacs_field(on!(window, state, |accession: bool| {
        pacs(PacsIntent::Field(if accession { SearchField::Accession } else { SearchField::PatientId }))
    }));
    s.on_pacs_search(on!(window, state, || pacs(PacsIntent::Search)));
    s.on_pacs_today(on!(window, state, || pacs(PacsIntent::Today)));
    s.on_pacs_retrieve(on!(window, state, |index: i32| pacs(PacsIntent::Retrieve(index.max(0) as usize))));
    s.on_pacs_next(on!(window, state, || pacs(PacsIntent::NextPeer)));
    s.on_send_to_pacs(on!(window, state, || Some(Intent::SendToPacs)));
    // The settings screen and the start screen's title.
    let page = window.global::<SettingsPage>();
    let setting = |intent: Setting| Some(Intent::Settings(intent));
    page.on_title_held(on!(window, state, |down: bool| setting(Setting::TitleHeld(down))));
    page.on_pin_key(on!(window, state, |key: SharedString| setting(Setting::PinKey(key.into()))));
    page.on_pin_done(on!(window, state, || setting(Setting::PinDone)));
    page.on_step(on!(window, state, |key: SharedString, direction: i32| {
        setting(Setting::Step { key: key.into(), direction })
    }));
    page.on_edit(on!(window, state, |key: SharedString| setting(Setting::Edit(key.into()))));
    page.on_edit_key(on!(window, state, |key: SharedString| setting(Setting::EditKey(key.into()))));
    page.on_edit_done(on!(window, state, || setting(Setting::EditDone)));
    page.on_edit_cancel(on!(window, state, || setting(Setting::EditCancel)));
    page.on_close(on!(window, state, || setting(Setting::Close)));
}

/// The poll timer's tick: what the window measures goes with it.
pub(crate) fn poll(window: &AppWindow, state: &Shared) {
    let session = window.global::<Session>();
    let scale = window.window().scale_factor();
    let view_px = [session.get_view_width(), session.get_view_height()].map(|logical| (logical * scale).round() as u32);
    let attract_side = crate::attract::view::picture_side(window);
    send(window, state, Intent::Poll(crate::model::Measures { view_px, attract_side }));
}
