//! Moving state into the UI, and collecting finished work from the loader, classifier and
//! renderer threads (the poll timer). Each `push_*` sets only the `Session` properties it names.

use super::jobs::JobOutcome;
use super::loading;
use super::pictures::{Highlight, class_colour, slice_picture};
use super::ui::{AppWindow, ClassEntry, Session, SliceView, VolumeCard};
use super::view3d::RenderReply;
use super::{PANEL_COUNT, Screen, State, autosave};
use crate::strokes::{ClassStrokes, StrokesFile};
use crate::transfer::{ClassStyle, RgbImage, apply_template};
use slint::{ComponentHandle, Model};
use std::cell::RefCell;
use std::rc::Rc;

type Shared = Rc<RefCell<State>>;

/// Collects finished work; called every 16 ms on the UI thread.
pub(super) fn poll(window: &AppWindow, state: &Shared) {
    loop {
        // A separate statement: the borrow must end before the event is handled.
        let event = state.borrow().loader.poll();
        let Some(event) = event else { break };
        loading::loader_event(window, state, event);
    }
    let outcome = state.borrow_mut().jobs.poll();
    match outcome {
        Some(JobOutcome::Done(classified)) => {
            {
                let mut state = state.borrow_mut();
                let seconds = classified.seconds;
                if let Some(work) = state.work.as_mut() {
                    work.classified = Some(classified);
                }
                state.status = format!("Classified in {seconds:.2} s");
            }
            styles_changed(window, state);
        }
        Some(JobOutcome::Failed(message)) => state.borrow_mut().status = message,
        None => {}
    }
    loading::confirm_restore(state);
    let reply = state.borrow_mut().renderer.poll();
    match reply {
        Some(RenderReply::Picture(picture)) => {
            let image = &picture.image;
            let buffer = slint::SharedPixelBuffer::<slint::Rgba8Pixel>::clone_from_slice(
                image.as_raw(),
                image.width(),
                image.height(),
            );
            window.global::<Session>().set_view_picture(slint::Image::from_rgba8(buffer));
        }
        Some(RenderReply::Failed(message)) => {
            log::warn!("{message}");
            state.borrow_mut().banner = message;
        }
        None => {}
    }
    request_frame_if_needed(window, state);
    push_status(window, state);
    loading::rescan_data_folder(state);
}

pub(super) fn show_screen(window: &AppWindow, screen: Screen) {
    window.global::<Session>().set_screen(screen as i32);
}

/// After the classes or lassos changed: autosave, classify again, show.
pub(super) fn session_changed(window: &AppWindow, state: &Shared) {
    save(state);
    {
        let mut state_ref = state.borrow_mut();
        let template = state_ref.template();
        let training = training_strokes(&state_ref);
        let State { work, jobs, .. } = &mut *state_ref;
        if let Some(work) = work.as_mut() {
            match training {
                Some(strokes) if work.requested.as_ref() != Some(&strokes) => {
                    jobs.start(work.loaded.volume.clone(), strokes.clone(), template);
                    work.requested = Some(strokes);
                }
                Some(_) => {}
                None => {
                    jobs.cancel();
                    work.requested = None;
                    work.classified = None;
                }
            }
        }
    }
    if state.borrow().work.as_ref().is_some_and(|work| work.classified.is_none()) {
        window.global::<Session>().set_view_picture(slint::Image::default());
    }
    push_work(window, state);
}

/// The defined classes plus the pending lassos as the provisional next class; `None` when
/// there are fewer than two.
fn training_strokes(state: &State) -> Option<StrokesFile> {
    let work = state.work.as_ref()?;
    let mut strokes = work.session.strokes();
    if !work.session.pending.is_empty() {
        strokes
            .classes
            .push(ClassStrokes { name: work.session.next_class_name(), strokes: work.session.pending.clone() });
    }
    // One class has nothing to be told apart from: its lassos are shown, nothing is trained.
    (strokes.classes.len() >= 2).then_some(strokes)
}

/// After colours or visibility changed (or a result came): 3-D view, overlays, class bar.
pub(super) fn styles_changed(window: &AppWindow, state: &Shared) {
    {
        let mut state = state.borrow_mut();
        let styles = display_styles(&state);
        let labels = state.work.as_ref().and_then(|w| w.classified.as_ref()).map(|c| c.labels.clone());
        if let (Some(styles), Some(labels)) = (styles, labels) {
            state.renderer.set_labels(labels, styles);
            state.view_dirty = true;
        }
    }
    push_work(window, state);
}

/// The classification's styles with the current template and the user's visibility.
fn display_styles(state: &State) -> Option<Vec<ClassStyle>> {
    let work = state.work.as_ref()?;
    let classified = work.classified.as_ref()?;
    let mut styles = classified.table.styles.clone();
    apply_template(&mut styles, &state.template());
    for (index, style) in styles.iter_mut().enumerate() {
        let shown = work.session.classes.get(index).is_none_or(|class| class.visible);
        style.visible = style.visible && shown;
    }
    Some(styles)
}

/// Writes the session for restore, when autosave is on and a volume is open.
pub(super) fn save(state: &Shared) {
    let state = state.borrow();
    let (Some(dir), Some(work)) = (&state.config.session_dir, &state.work) else { return };
    let template = state.chosen_template;
    let saved = autosave::SavedSession {
        volume: work.loaded.source.key(),
        template: template.map_or(String::new(), |t| t.template.name().to_string()),
        rotation_degrees: template.map_or(0.0, |t| t.rotation_degrees),
        strokes: work.session.strokes(),
    };
    if let Err(message) = autosave::save(dir, &saved) {
        log::warn!("{message}");
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
    let Some(work) = state.work.as_ref() else {
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
    let Some(work) = state.work.as_ref() else {
        state.classes_model.set_vec(Vec::new());
        session.set_volume_name("".into());
        return;
    };
    let template = state.template();
    let styles = display_styles(&state);
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
    session.set_template_name(template.template.name().into());
    session.set_template_rotation(template.rotation_degrees.rem_euclid(360.0) as i32);
    session.set_volume_name(work.loaded.source.name().into());
}

pub(super) fn push_status(window: &AppWindow, state: &Shared) {
    let state = state.borrow();
    let session = window.global::<Session>();
    let busy = state.jobs.busy() || state.opening.is_some();
    let status = match state.jobs.progress() {
        Some(progress) => format!("Classifying... {:.0} %", progress * 100.0),
        None => state.status.clone(),
    };
    let hint = match state.work.as_ref() {
        Some(work) if work.classified.is_some() => "",
        Some(work) if work.session.classes.is_empty() && work.session.pending.is_empty() => {
            "Draw a loop around a structure on any slice, then tap Define class. Each class gets its colour here in 3-D."
        }
        Some(_) if state.training_class_count() < 2 => {
            "Now draw a loop around something else: the 3-D view appears once two classes can be told apart."
        }
        Some(_) => "Classifying...",
        None => "",
    };
    session.set_view_hint(hint.into());
    session.set_busy(busy);
    session.set_progress(state.jobs.progress().unwrap_or(0.0));
    session.set_status(status.into());
    session.set_banner(state.banner.clone().into());
}

pub(super) fn push_volumes(window: &AppWindow, state: &Shared) {
    let state = state.borrow();
    let cards: Vec<VolumeCard> = state
        .sources
        .iter()
        .map(|source| VolumeCard {
            name: source.name().into(),
            detail: "".into(),
            thumbnail: slint::Image::default(),
            failed: false,
        })
        .collect();
    state.volumes_model.set_vec(cards);
    drop(state);
    let _ = window;
}

/// The slice picture of one panel (grey, classes, lassos, arranged for the screen) and its
/// numbers, title, edge letters and feedback.
pub(super) fn push_slice(window: &AppWindow, state: &Shared, panel: usize) {
    let mut state_ref = state.borrow_mut();
    let model = state_ref.slices_model.clone();
    let Some(work) = state_ref.work.as_ref() else {
        model.set_vec(Vec::new());
        return;
    };
    let Some(shown) = work.panels.get(panel) else { return };
    let volume = &work.loaded.volume;
    let styles = display_styles(&state_ref);
    let classification = work.classified.as_ref().zip(styles.as_deref()).map(|(c, s)| (c.labels.as_slice(), s));
    let template = state_ref.template();
    let total = state_ref.training_class_count();
    let next = work.session.classes.len();
    let mut highlights: Vec<Highlight> = Vec::new();
    if classification.is_none() {
        for (index, class) in work.session.classes.iter().enumerate() {
            highlights.push(Highlight { lassos: &class.lassos, colour: class_colour(None, &template, index, total) });
        }
    }
    highlights.push(Highlight { lassos: &work.session.pending, colour: class_colour(None, &template, next, next + 1) });
    let layout = &shown.layout;
    let (picture, failure) = match slice_picture(volume, layout, shown.slice, work.window, classification, &highlights)
    {
        Ok(picture) => (to_slint_image(&picture), None),
        Err(message) => (slint::Image::default(), Some(message)),
    };
    let [across_mm, down_mm] = layout.screen_extent_mm(volume.dims, volume.spacing_mm);
    let letters = layout.edge_letters;
    let letter = |pick: fn(&crate::slices::EdgeLetters) -> &'static str| letters.as_ref().map_or("", pick).into();
    let view = SliceView {
        axis: shown.axis.name().into(),
        title: layout.plane.map_or_else(|| format!("Slice {}", shown.axis), |plane| plane.name().to_string()).into(),
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
            .map_or(String::new(), |(_, m)| m.clone())
            .into(),
    };
    if let Some(message) = failure {
        // The file under the volume changed (truncated) or the slice is gone: say so once.
        log::warn!("slice picture: {message}");
        let banner = format!("Cannot show the slice: {message}");
        if state_ref.banner != banner {
            state_ref.banner = banner;
        }
    }
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
    let Some(work) = state.work.as_ref() else { return };
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

/// Asks the renderer for a frame when the view needs one and none is being drawn: half size
/// while a finger orbits (twice the frame rate on a slow GPU), full size when it lifts.
fn request_frame_if_needed(window: &AppWindow, state: &Shared) {
    let session = window.global::<Session>();
    let scale = window.window().scale_factor();
    let size = [session.get_view_width(), session.get_view_height()].map(|logical| (logical * scale).round() as u32);
    let mut state = state.borrow_mut();
    if size != state.view_size {
        state.view_size = size;
        state.view_dirty = true;
    }
    let classified = state.work.as_ref().is_some_and(|work| work.classified.is_some());
    if !state.view_dirty || state.renderer.busy() || !classified || size[0] == 0 || size[1] == 0 {
        if !classified {
            state.view_dirty = false;
        }
        return;
    }
    state.view_dirty = false;
    let size = if state.orbit_from.is_some() { size.map(|side| (side / 2).max(1)) } else { size };
    let camera = state.camera;
    state.renderer.request_frame(camera, size);
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
