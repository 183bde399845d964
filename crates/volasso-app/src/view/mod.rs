//! The one view: writes the model (model.rs) into the window's globals, as much as an
//! update's [`Show`] says changed, and keeps the rows Slint shows (slices, classes, cards).
//! Each feature's own part is its `view.rs`; the callbacks that make intents are
//! `callbacks.rs`.
//!
//! Never: decides anything, starts or collects work (but asks the painter for the pictures of
//! the slices it shows).

use crate::State;
use crate::model::Show;
use crate::pictures::class_colour;
use crate::ui::{AppWindow, ClassEntry, ResultCard, Session, SliceView, VolumeCard};
use crate::work::PANEL_COUNT;
use slint::{ComponentHandle, Model};
use std::rc::Rc;
use std::time::Duration;

pub(crate) mod images;
pub(crate) use images::{rgba_to_slint_image, to_slint_image};

/// How long the snapshot's confirmation stays over the 3-D view.
const TOAST_TIME: Duration = Duration::from_secs(6);

/// The rows Slint shows, and the timer that clears the 3-D view's confirmation.
#[derive(Default)]
pub(crate) struct Rows {
    pub slices: Rc<slint::VecModel<SliceView>>,
    pub classes: Rc<slint::VecModel<ClassEntry>>,
    pub volumes: Rc<slint::VecModel<VolumeCard>>,
    pub results: Rc<slint::VecModel<ResultCard>>,
    toast_timer: Rc<slint::Timer>,
}

impl Rows {
    /// The rows, set into the window's `Session` once.
    pub(crate) fn wire(&self, window: &AppWindow) {
        let session = window.global::<Session>();
        session.set_slices(self.slices.clone().into());
        session.set_classes(self.classes.clone().into());
        session.set_volumes(self.volumes.clone().into());
        session.set_results(self.results.clone().into());
    }
}

/// Writes what `show` names into the window.
pub(crate) fn show(window: &AppWindow, state: &mut State, show: Show) {
    let session = window.global::<Session>();
    if show.language {
        crate::settings::view::show_language(state.config.language);
    }
    if show.screen {
        session.set_screen(state.screen as i32);
    }
    if show.view_picture {
        let picture = state.view_picture.as_ref().map_or_else(slint::Image::default, rgba_to_slint_image);
        session.set_view_picture(picture);
    }
    if show.view_caption {
        session.set_view_caption(crate::words::tr(state.view_caption).into());
    }
    if let Some(shown) = show.attract {
        crate::attract::view::show(window, shown);
    }
    if show.work {
        push_work(window, state);
    } else {
        for panel in (0..PANEL_COUNT).filter(|&panel| show.panels[panel]) {
            push_slice(state, panel);
        }
        if show.slice_layout {
            push_slice_layout(window, state);
        }
        if show.lasso_path {
            push_lasso(state);
        }
        if show.status {
            push_status(window, state);
        }
    }
    if show.pictures {
        show_pictures(state);
    }
    if let Some(index) = show.class_opacity {
        show_class_opacity(state, index);
    }
    if show.clipping {
        session.set_clipping(state.ctl.look.clip.is_some());
    }
    if let Some(message) = show.toast {
        show_toast(window, state, message);
    }
    if show.cards {
        crate::chooser::view::show_cards(state);
    }
    if show.results {
        crate::gallery::view::show_cards(state);
    }
    if show.presets {
        crate::presets::view::show(window, state);
    }
    if show.pacs || show.work || show.screen {
        crate::pacs::view::show(window, state);
    }
    if show.settings {
        crate::settings::view::show(window, state);
    }
}

/// The opacity knob of class row `index`, in place: replacing the rows would end the
/// finger's drag.
fn show_class_opacity(state: &State, index: usize) {
    let opacity = (state.ctl.class_opacity(index) * 100.0).round() as i32;
    if let Some(mut entry) = state.rows.classes.row_data(index)
        && entry.opacity != opacity
    {
        entry.opacity = opacity;
        state.rows.classes.set_row_data(index, entry);
    }
}

/// The confirmation over the 3-D view, cleared after [`TOAST_TIME`].
fn show_toast(window: &AppWindow, state: &State, message: String) {
    window.global::<Session>().set_view_toast(crate::words::tr(&message).into());
    let weak = window.as_weak();
    state.rows.toast_timer.start(slint::TimerMode::SingleShot, TOAST_TIME, move || {
        if let Some(window) = weak.upgrade() {
            window.global::<Session>().set_view_toast("".into());
        }
    });
}

/// The slice pictures the painter finished, into their panels' rows.
fn show_pictures(state: &mut State) {
    for (panel, picture) in std::mem::take(&mut state.finished_pictures) {
        if let Some(mut view) =
            (panel < state.rows.slices.row_count()).then(|| state.rows.slices.row_data(panel)).flatten()
        {
            view.picture = to_slint_image(&picture);
            state.rows.slices.set_row_data(panel, view);
        }
    }
}

/// Everything on the work screen: slices, their layout and window, class bar, status.
fn push_work(window: &AppWindow, state: &mut State) {
    for panel in 0..PANEL_COUNT {
        push_slice(state, panel);
    }
    push_slice_layout(window, state);
    push_classes(window, state);
    push_status(window, state);
}

/// Which slice is enlarged, its zoom and pan, and the display window's name and presets.
fn push_slice_layout(window: &AppWindow, state: &State) {
    let session = window.global::<Session>();
    let Some(work) = state.ctl.work.as_ref() else {
        session.set_enlarged(-1);
        return;
    };
    session.set_enlarged(work.enlarged.map_or(-1, |panel| panel as i32));
    session.set_slice_zoom(work.zoom);
    session.set_slice_pan_x(work.pan[0]);
    session.set_slice_pan_y(work.pan[1]);
    session.set_window_name(work.window_name.clone().into());
    let names: Vec<slint::SharedString> = work.loaded.windows.names().into_iter().map(Into::into).collect();
    session.set_window_names(Rc::new(slint::VecModel::from(names)).into());
}

fn push_classes(window: &AppWindow, state: &State) {
    let session = window.global::<Session>();
    session.set_clipping(state.ctl.look.clip.is_some());
    let Some(work) = state.ctl.work.as_ref() else {
        state.rows.classes.set_vec(Vec::new());
        session.set_volume_name("".into());
        session.set_patient("".into());
        return;
    };
    let template = state.ctl.template();
    let styles = state.ctl.display_styles();
    let counts = work.classified.as_ref().map(|c| &c.table.voxel_counts);
    let total = state.ctl.training_class_count();
    let entries: Vec<ClassEntry> = work
        .session
        .classes
        .iter()
        .enumerate()
        .map(|(index, class)| ClassEntry {
            name: class.name.clone().into(),
            colour: to_colour(class_colour(styles.as_ref().and_then(|s| s.get(index)), &template, index, total)),
            visible: class.visible,
            voxels: counts.and_then(|c| c.get(index)).map_or(0, |&n| n.min(i32::MAX as u64) as i32),
            opacity: (state.ctl.class_opacity(index) * 100.0).round() as i32,
        })
        .collect();
    state.rows.classes.set_vec(entries);
    let next = work.session.classes.len();
    session.set_next_colour(to_colour(class_colour(None, &template, next, next + 1)));
    session.set_pending_lassos(work.session.pending.len() as i32);
    let dims = work.loaded.volume.dims;
    let pending_voxels: usize = work.session.pending.iter().map(|lasso| lasso.selected_voxels(dims).len()).sum();
    session.set_pending_voxels(pending_voxels.min(i32::MAX as usize) as i32);
    session.set_can_undo(work.session.can_undo());
    session.set_can_define(work.session.can_define());
    session.set_can_guide(work.guidance().is_some());
    session.set_can_save_preset(work.guidance().is_some() && state.config.data_dir.is_some());
    session.set_unsure_shown(work.unsure_shown);
    session.set_template_name(template.template.name().into());
    session.set_template_rotation(template.rotation_degrees.rem_euclid(360.0) as i32);
    session.set_volume_name(work.loaded.title.clone().unwrap_or_else(|| work.loaded.source.name()).into());
    session.set_patient(work.loaded.patient.line().into());
}

fn push_status(window: &AppWindow, state: &State) {
    let session = window.global::<Session>();
    let busy = state.ctl.jobs.busy() || state.opening.is_some();
    let status = match state.ctl.jobs.progress() {
        Some(progress) => format!("Classifying... {:.0} %", progress * 100.0),
        None => state.status.clone(),
    };
    let hint = crate::words::tr(state.ctl.view_hint());
    session.set_view_hint(hint.into());
    session.set_busy(busy);
    session.set_progress(state.ctl.jobs.progress().unwrap_or(0.0));
    session.set_status(crate::words::tr(&status).into());
    session.set_banner(crate::words::tr(&state.banner).into());
}

/// The numbers, title, edge letters and feedback of one panel, and its picture (grey, classes,
/// lassos, arranged for the screen) asked of the painter thread; until it comes
/// ([`picture_done`]) the panel keeps its picture when it still shows the same volume along the
/// same axis, and none otherwise (never another scan's slice).
fn push_slice(state: &mut State, panel: usize) {
    let rows = state.rows.slices.clone();
    if state.ctl.work.is_none() {
        rows.set_vec(Vec::new());
        return;
    }
    let Some(shown) = state.panel_shown(panel) else { return };
    let previous = (panel < rows.row_count()).then(|| rows.row_data(panel)).flatten();
    let picture = previous.filter(|_| shown.keep_picture).map_or_else(slint::Image::default, |view| view.picture);
    let [top, right, bottom, left] = shown.letters.map(slint::SharedString::from);
    let view = SliceView {
        axis: shown.axis.into(),
        title: crate::words::tr(&shown.title).into(),
        oriented: shown.oriented,
        picture,
        slice: shown.slice,
        count: shown.count,
        rank: shown.rank,
        aspect: shown.aspect,
        lasso: shown.lasso.into(),
        letter_top: top,
        letter_right: right,
        letter_bottom: bottom,
        letter_left: left,
        feedback: crate::words::tr(&shown.feedback).into(),
    };
    if panel < rows.row_count() {
        rows.set_row_data(panel, view);
    } else {
        rows.push(view);
    }
}

/// Only the lasso path of the panel being drawn on (cheap: no new picture).
fn push_lasso(state: &State) {
    let Some(work) = state.ctl.work.as_ref() else { return };
    for panel in 0..state.rows.slices.row_count() {
        let Some(mut view) = state.rows.slices.row_data(panel) else { continue };
        let lasso =
            work.drawing.as_ref().filter(|(on, _)| *on == panel).map_or(String::new(), |(_, path)| path.svg_commands());
        if view.lasso.as_str() != lasso {
            view.lasso = lasso.into();
            state.rows.slices.set_row_data(panel, view);
        }
    }
}

fn to_colour([r, g, b]: [u8; 3]) -> slint::Color {
    slint::Color::from_rgb_u8(r, g, b)
}
