//! What each `Session` callback does to the app's [`State`]. Every callback counts as input
//! (the idle timeout restarts), changes state, starts slow work elsewhere, and pushes what
//! changed back to the UI (refresh.rs).

use super::refresh;
use super::ui::{AppWindow, Session};
use super::{Screen, State};
use crate::lasso::slice_actions::slice_intent;
use crate::lasso::slices::SliceIntent;
use crate::view3d::interaction::ViewIntent;
use crate::view3d::tools::view_intent;
use slint::ComponentHandle;
use std::cell::RefCell;
use std::rc::Rc;
use volasso_core::transfer::{HueTemplate, TemplateType};

type Shared = Rc<RefCell<State>>;

/// Makes a callback closure that upgrades the window, restarts the idle timeout and runs `body`.
macro_rules! handler {
    ($window:expr, $state:expr, |$w:ident, $s:ident $(, $arg:ident : $ty:ty)*| $body:block) => {{
        let weak = $window.as_weak();
        let state = $state.clone();
        move |$($arg: $ty),*| {
            if let Some($w) = weak.upgrade() {
                let $s: &Shared = &state;
                touched($s);
                $body
            }
        }
    }};
}

pub(super) fn wire(window: &AppWindow, state: &Shared) {
    let session = window.global::<Session>();
    session.on_start(handler!(window, state, |w, s| { show_chooser(&w, s) }));
    session.on_show_chooser(handler!(window, state, |w, s| { show_chooser(&w, s) }));
    session.on_open_volume(handler!(window, state, |w, s, index: i32| {
        crate::chooser::loading::open_volume(&w, s, index)
    }));
    wire_pacs(window, state);
    wire_settings(window, state);
    session.on_lasso_down(handler!(window, state, |w,
                                                   s,
                                                   panel: i32,
                                                   x: f32,
                                                   y: f32,
                                                   width: f32,
                                                   height: f32,
                                                   ms: f32| {
        let (panel, point, picture_px, ms) = (panel.max(0) as usize, [x, y], [width, height], ms as f64);
        slice_intent(&w, s, SliceIntent::Down { panel, point, picture_px, ms })
    }));
    session.on_lasso_move(handler!(window, state, |w, s, panel: i32, x: f32, y: f32, ms: f32| {
        slice_intent(&w, s, SliceIntent::Move { panel: panel.max(0) as usize, point: [x, y], ms: ms as f64 })
    }));
    session.on_lasso_up(handler!(window, state, |w, s, panel: i32, x: f32, y: f32, ms: f32| {
        slice_intent(&w, s, SliceIntent::Up { panel: panel.max(0) as usize, point: [x, y], ms: ms as f64 })
    }));
    session.on_enlarge(handler!(window, state, |w, s, panel: i32| {
        slice_intent(&w, s, SliceIntent::Enlarge(panel.max(0) as usize))
    }));
    session.on_shrink(handler!(window, state, |w, s| { slice_intent(&w, s, SliceIntent::Shrink) }));
    session.on_choose_window(handler!(window, state, |w, s, name: slint::SharedString| {
        slice_intent(&w, s, SliceIntent::ChooseWindow(name.into()))
    }));
    session.on_step_slice(handler!(window, state, |w, s, panel: i32, delta: i32| {
        slice_intent(&w, s, SliceIntent::Step { panel: panel.max(0) as usize, delta })
    }));
    session.on_scrub_slice(handler!(window, state, |w, s, panel: i32, slice: i32| {
        slice_intent(&w, s, SliceIntent::Scrub { panel: panel.max(0) as usize, slice })
    }));
    session.on_define_class(handler!(window, state, |w, s| {
        refresh::edit_session(&w, s, |session| session.define_class().map(|_| ()))
    }));
    session.on_undo(handler!(window, state, |w, s| { refresh::edit_session(&w, s, |session| session.undo()) }));
    session.on_clear(handler!(window, state, |w, s| {
        refresh::edit_session(&w, s, |session| {
            session.clear();
            Ok(())
        })
    }));
    session.on_delete_class(handler!(window, state, |w, s, index: i32| {
        refresh::edit_session(&w, s, |session| session.delete_class(index.max(0) as usize))
    }));
    session.on_toggle_class(handler!(window, state, |w, s, index: i32| { toggle_class(&w, s, index) }));
    session.on_save_preset(handler!(window, state, |w, s| { crate::presets::view::save(&w, s) }));
    session.on_apply_preset(handler!(window, state, |w, s, index: i32| { crate::presets::view::apply(&w, s, index) }));
    session
        .on_choose_preset(handler!(window, state, |w, s, index: i32| { crate::presets::view::choose(&w, s, index) }));
    session.on_toggle_unsure(handler!(window, state, |w, s| { super::guidance::toggle_unsure(&w, s) }));
    session.on_draw_here_next(handler!(window, state, |w, s| { super::guidance::draw_here_next(&w, s) }));
    session.on_choose_template(handler!(window, state, |w, s, name: slint::SharedString| {
        let rotation = s.borrow().template().rotation_degrees;
        if let Some(template) = TemplateType::from_name(&name) {
            set_template(&w, s, HueTemplate::new(template, rotation));
        }
    }));
    session.on_rotate_template(handler!(window, state, |w, s, degrees: i32| {
        let template = s.borrow().template().template;
        set_template(&w, s, HueTemplate::new(template, degrees as f32));
    }));
    // The 3-D view's touches and buttons are intents of its model (view3d/interaction.rs);
    // while clipping, one finger moves the clip plane instead of orbiting.
    session.on_reset_view(handler!(window, state, |w, s| { view_intent(&w, s, ViewIntent::ResetView) }));
    session.on_view_press(handler!(window, state, |w, s, x: f32, y: f32| {
        view_intent(&w, s, ViewIntent::Press([x, y]))
    }));
    session.on_view_drag(handler!(window, state, |w, s, x: f32, y: f32| {
        let view_height = w.global::<Session>().get_view_height().max(1.0) as u32;
        view_intent(&w, s, ViewIntent::Drag { to: [x, y], view_height })
    }));
    session.on_view_release(handler!(window, state, |w, s| { view_intent(&w, s, ViewIntent::Release) }));
    session.on_view_zoom(handler!(window, state, |w, s, zoom: f32| {
        view_intent(&w, s, ViewIntent::Gesture { zoom, pan_pixels: [0.0; 2], turn_degrees: 0.0 })
    }));
    session.on_dismiss_banner(handler!(window, state, |w, s| {
        s.borrow_mut().banner.clear();
        refresh::push_status(&w, s);
    }));
    // The 3-D view's tools (per-class opacity, clip plane, snapshot).
    session.on_class_opacity(handler!(window, state, |w, s, index: i32, percent: i32| {
        crate::view3d::tools::class_opacity(&w, s, index, percent)
    }));
    session.on_toggle_clip(handler!(window, state, |w, s| { view_intent(&w, s, ViewIntent::ToggleClip) }));
    session.on_reset_clip(handler!(window, state, |w, s| { view_intent(&w, s, ViewIntent::ResetClip) }));
    session.on_snapshot(handler!(window, state, |w, s| { crate::view3d::tools::snapshot(&w, s) }));
    // The gallery: keep the current result, open a kept one (results.rs).
    session.on_save_result(handler!(window, state, |w, s| { crate::gallery::view::save(&w, s) }));
    session.on_open_result(handler!(window, state, |w, s, index: i32| { crate::gallery::view::open(&w, s, index) }));
}

/// A touch: the idle timeout starts again (idle.rs).
pub(super) fn touched(state: &Shared) {
    let mut state = state.borrow_mut();
    let now = state.config.clock.now();
    state.idle.touched(now);
}

/// The idle timeout passed: the session is forgotten and the start screen comes back, with
/// its turntable.
pub(super) fn reset_to_start(window: &AppWindow, state: &Shared) {
    {
        let mut state = state.borrow_mut();
        let now = state.config.clock.now();
        state.settings.update(super::settings::SettingsIntent::Close, now);
        state.ctl.forget();
        state.panel_pictures.clear();
        state.restore = None;
        state.restore_unconfirmed = false;
        state.view.forget();
        state.banner.clear();
        state.status.clear();
    }
    log::info!("idle timeout: back to the start screen, session cleared");
    window.global::<Session>().set_view_picture(slint::Image::default());
    refresh::push_work(window, state);
    refresh::show_screen(window, Screen::Start);
    super::attract::view::begin(window, state);
}

fn show_chooser(window: &AppWindow, state: &Shared) {
    {
        let mut state = state.borrow_mut();
        if !state.thumbnails_requested {
            state.thumbnails_requested = true;
            let sources: Vec<_> = state.cards.sources().iter().cloned().enumerate().collect();
            state.thumbnails_pending = sources.len();
            state.loader.thumbnails(sources);
        }
    }
    super::attract::view::end(window, state);
    crate::gallery::view::refresh_cards(state);
    crate::presets::view::relist(window, state);
    refresh::show_screen(window, Screen::Chooser);
}

/// The settings screen's callbacks and the start screen's title, each an intent of
/// `settings::SettingsScreen`.
fn wire_settings(window: &AppWindow, state: &Shared) {
    use super::settings::SettingsIntent as I;
    use super::settings::view::intent;
    use slint::SharedString;
    let page = window.global::<crate::ui::SettingsPage>();
    page.on_title_held(handler!(window, state, |w, s, down: bool| { intent(&w, s, I::TitleHeld(down)) }));
    page.on_pin_key(handler!(window, state, |w, s, key: SharedString| { intent(&w, s, I::PinKey(key.into())) }));
    page.on_pin_done(handler!(window, state, |w, s| { intent(&w, s, I::PinDone) }));
    page.on_step(handler!(window, state, |w, s, key: SharedString, direction: i32| {
        intent(&w, s, I::Step { key: key.into(), direction })
    }));
    page.on_edit(handler!(window, state, |w, s, key: SharedString| { intent(&w, s, I::Edit(key.into())) }));
    page.on_edit_key(handler!(window, state, |w, s, key: SharedString| { intent(&w, s, I::EditKey(key.into())) }));
    page.on_edit_done(handler!(window, state, |w, s| { intent(&w, s, I::EditDone) }));
    page.on_edit_cancel(handler!(window, state, |w, s| { intent(&w, s, I::EditCancel) }));
    page.on_close(handler!(window, state, |w, s| { intent(&w, s, I::Close) }));
}

/// The PACS screen's callbacks and "Send to PACS", each an intent of `pacs::PacsModel`.
fn wire_pacs(window: &AppWindow, state: &Shared) {
    use super::pacs::view::{intent, send};
    use super::pacs::{PacsIntent, SearchField};
    let session = window.global::<Session>();
    session.on_pacs_open(handler!(window, state, |w, s| { intent(&w, s, PacsIntent::Open) }));
    session.on_pacs_key(handler!(window, state, |w, s, key: slint::SharedString| {
        intent(&w, s, PacsIntent::Key(key.to_string()))
    }));
    session.on_pacs_field(handler!(window, state, |w, s, accession: bool| {
        let field = if accession { SearchField::Accession } else { SearchField::PatientId };
        intent(&w, s, PacsIntent::Field(field))
    }));
    session.on_pacs_search(handler!(window, state, |w, s| { intent(&w, s, PacsIntent::Search) }));
    session.on_pacs_today(handler!(window, state, |w, s| { intent(&w, s, PacsIntent::Today) }));
    session.on_pacs_retrieve(handler!(window, state, |w, s, row: i32| {
        intent(&w, s, PacsIntent::Retrieve(row.max(0) as usize))
    }));
    session.on_pacs_next(handler!(window, state, |w, s| { intent(&w, s, PacsIntent::NextPeer) }));
    session.on_send_to_pacs(handler!(window, state, |w, s| { send(&w, s) }));
}

fn toggle_class(window: &AppWindow, state: &Shared, index: i32) {
    let changed = state.borrow_mut().ctl.toggle_class(index.max(0) as usize);
    refresh::apply(window, state, changed);
}

fn set_template(window: &AppWindow, state: &Shared, template: HueTemplate) {
    let changed = state.borrow_mut().ctl.choose_template(template);
    refresh::apply(window, state, changed);
}
