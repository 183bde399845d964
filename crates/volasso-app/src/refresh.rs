//! Moving state into the UI: each `push_*` sets only the `Session` properties it names. The poll
//! timer that collects finished work is `poll.rs`; nothing here starts or collects work.

use super::controller::{Changed, FAILURE_BANNER_START, Failure, failure_banner};
use super::painter::PictureRequest;
use super::pictures::class_colour;
use super::ui::{AppWindow, ClassEntry, Session, SliceView};
use super::{PANEL_COUNT, Screen, State};
use slint::{ComponentHandle, Model};
use std::cell::RefCell;
use std::rc::Rc;
use std::sync::Arc;
use volasso_core::transfer::RgbImage;

type Shared = Rc<RefCell<State>>;

/// Applies `edit` to the session; on success autosaves, reclassifies and refreshes.
pub(super) fn edit_session(
    window: &AppWindow,
    state: &Shared,
    edit: impl FnOnce(&mut super::session::WorkSession) -> Result<(), super::session::SessionError>,
) {
    let changed = state.borrow_mut().ctl.edit(edit);
    apply(window, state, changed);
}

pub(super) fn show_screen(window: &AppWindow, screen: Screen) {
    window.global::<Session>().set_screen(screen as i32);
}

/// Shows what the controller says changed: the status line, a new 3-D frame wanted or the 3-D
/// view emptied, and the work screen when classes, lassos or colours changed.
pub(super) fn apply(window: &AppWindow, state: &Shared, changed: Changed) {
    {
        let mut state = state.borrow_mut();
        if let Some(status) = &changed.status {
            state.status = status.clone();
        }
        match &changed.failure {
            Failure::Failed(reason) => state.banner = failure_banner(reason),
            Failure::Cleared if state.banner.starts_with(FAILURE_BANNER_START) => state.banner.clear(),
            Failure::Cleared | Failure::Unchanged => {}
        }
        if changed.view {
            state.view.dirty = true;
        }
    }
    if changed.view_cleared {
        window.global::<Session>().set_view_picture(slint::Image::default());
    }
    if changed.classes {
        push_work(window, state);
    } else if changed.status.is_some() || changed.failure != Failure::Unchanged {
        push_status(window, state);
    }
}

/// Everything on the work screen: slices, their layout and window, class bar, status.
pub(super) fn push_work(window: &AppWindow, state: &Shared) {
    for panel in 0..PANEL_COUNT {
        push_slice(window, state, panel);
    }
    push_slice_layout(window, state);
    push_classes(window, state);
    push_status(window, state);
}

/// Which slice is enlarged, its zoom and pan, and the display window's name and presets.
pub(super) fn push_slice_layout(window: &AppWindow, state: &Shared) {
    let state = state.borrow();
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

pub(super) fn push_classes(window: &AppWindow, state: &Shared) {
    let state = state.borrow();
    let session = window.global::<Session>();
    session.set_clipping(state.ctl.look.clip.is_some());
    let Some(work) = state.ctl.work.as_ref() else {
        state.classes_model.set_vec(Vec::new());
        session.set_volume_name("".into());
        session.set_patient("".into());
        return;
    };
    let template = state.template();
    let styles = state.ctl.display_styles();
    let counts = work.classified.as_ref().map(|c| &c.table.voxel_counts);
    let total = state.training_class_count();
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
    state.classes_model.set_vec(entries);
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

pub(super) fn push_status(window: &AppWindow, state: &Shared) {
    let state = state.borrow();
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
pub(super) fn push_slice(window: &AppWindow, state: &Shared, panel: usize) {
    let mut state_ref = state.borrow_mut();
    let model = state_ref.slices_model.clone();
    let Some(work) = state_ref.ctl.work.as_ref() else {
        model.set_vec(Vec::new());
        return;
    };
    let Some(shown) = work.panels.get(panel) else { return };
    let volume = &work.loaded.volume;
    let styles = state_ref.ctl.display_styles();
    let classification = work.classified.as_ref().zip(styles).map(|(c, s)| (c.labels.clone(), s));
    let template = state_ref.template();
    let total = state_ref.training_class_count();
    let next = work.session.classes.len();
    let mut highlights = Vec::new();
    if classification.is_none() {
        for (index, class) in work.session.classes.iter().enumerate() {
            highlights.push((class.lassos.clone(), class_colour(None, &template, index, total)));
        }
    }
    highlights.push((work.session.pending.clone(), class_colour(None, &template, next, next + 1)));
    let layout = &shown.layout;
    let request = PictureRequest {
        panel,
        volume: volume.clone(),
        layout: *layout,
        slice: shown.slice,
        window: work.window,
        classification,
        highlights,
        clip: state_ref.ctl.look.clip,
        unsure: work
            .guidance()
            .filter(|_| work.unsure_shown)
            .map(|guidance| (guidance.segmenter.clone(), guidance.survey.threshold)),
    };
    let [across_mm, down_mm] = layout.screen_extent_mm(volume.dims, volume.spacing_mm);
    let letters = layout.edge_letters;
    let letter =
        |pick: fn(&volasso_core::slices::EdgeLetters) -> &'static str| letters.as_ref().map_or("", pick).into();
    let same_picture = (Arc::as_ptr(volume) as usize, shown.axis);
    let previous = (panel < model.row_count()).then(|| model.row_data(panel)).flatten();
    let picture = previous
        .filter(|_| state_ref.panel_pictures.get(panel) == Some(&same_picture))
        .map_or_else(slint::Image::default, |view| view.picture);
    let view = SliceView {
        axis: shown.axis.name().into(),
        title: crate::words::tr(
            &layout.plane.map_or_else(|| format!("Slice {}", shown.axis), |plane| plane.name().to_string()),
        )
        .into(),
        oriented: layout.plane.is_some(),
        picture,
        slice: shown.slice as i32,
        count: volume.dims[shown.axis.position()] as i32,
        rank: shown.rank as i32 + 1,
        aspect: (across_mm / down_mm.max(1e-9)) as f32,
        lasso: work
            .drawing
            .as_ref()
            .filter(|(on, _)| *on == panel)
            .map_or(String::new(), |(_, path)| path.svg_commands())
            .into(),
        letter_top: letter(|l| l.top),
        letter_right: letter(|l| l.right),
        letter_bottom: letter(|l| l.bottom),
        letter_left: letter(|l| l.left),
        feedback: work
            .feedback
            .as_ref()
            .filter(|(on, _)| *on == panel)
            .map_or(String::new(), |(_, m)| crate::words::tr(m))
            .into(),
    };
    if state_ref.panel_pictures.len() <= panel {
        state_ref.panel_pictures.resize(panel + 1, same_picture);
    }
    state_ref.panel_pictures[panel] = same_picture;
    state_ref.painter.request(request);
    drop(state_ref);
    if panel < model.row_count() {
        model.set_row_data(panel, view);
    } else {
        model.push(view);
    }
    let _ = window;
}

/// Only the lasso path of the panel being drawn on (cheap: no new picture).
pub(super) fn push_lasso(window: &AppWindow, state: &Shared) {
    let state = state.borrow();
    let Some(work) = state.ctl.work.as_ref() else { return };
    for panel in 0..state.slices_model.row_count() {
        let Some(mut view) = state.slices_model.row_data(panel) else { continue };
        let lasso =
            work.drawing.as_ref().filter(|(on, _)| *on == panel).map_or(String::new(), |(_, path)| path.svg_commands());
        if view.lasso.as_str() != lasso {
            view.lasso = lasso.into();
            state.slices_model.set_row_data(panel, view);
        }
    }
    let _ = window;
}

/// A rendered picture (the 3-D view's, a turntable's) as Slint shows it.
pub(crate) fn rgba_to_slint_image(image: &image::RgbaImage) -> slint::Image {
    let buffer =
        slint::SharedPixelBuffer::<slint::Rgba8Pixel>::clone_from_slice(image.as_raw(), image.width(), image.height());
    slint::Image::from_rgba8(buffer)
}

pub(super) fn to_slint_image(image: &RgbImage) -> slint::Image {
    if image.width == 0 || image.height == 0 {
        return slint::Image::default();
    }
    let buffer = slint::SharedPixelBuffer::<slint::Rgb8Pixel>::clone_from_slice(
        &image.pixels,
        image.width as u32,
        image.height as u32,
    );
    slint::Image::from_rgb8(buffer)
}

fn to_colour([r, g, b]: [u8; 3]) -> slint::Color {
    slint::Color::from_rgb_u8(r, g, b)
}
