//! What the loader thread reports, applied to the app: thumbnails onto the chooser's cards, a
//! file that cannot be opened onto its card ("Cannot open" and why) and the banner, an opened
//! volume onto the work screen (with the saved session's classes, its panels in the
//! radiological convention, the 3-D view's home position and a banner for what its reader
//! tolerated, such as a missing slice under `--allow-gaps`), and the restore marker
//! lifted once a restored session has opened and classified (autosave.rs). Also the periodic
//! listing of the data folder, whose new volumes join the chooser.
//!
//! Never: opens files itself (library.rs does, on worker threads).

use super::library::{LoadedVolume, LoaderEvent, VolumeSource};
use super::refresh::{session_changed, show_screen, to_slint_image};
use super::session::WorkSession;
use super::ui::{AppWindow, Session, VolumeCard};
use super::{Panel, Screen, State, Work, autosave};
use crate::render::Camera;
use crate::slices::{HomeView, SliceLayout, plane_axes};
use slint::{ComponentHandle, Model};
use std::cell::RefCell;
use std::rc::Rc;

type Shared = Rc<RefCell<State>>;

/// A restored session that opened and whose classification ended (or that had none to run)
/// did not stop the app: the restore marker goes (autosave.rs).
pub(super) fn confirm_restore(state: &Shared) {
    let mut state = state.borrow_mut();
    if !state.restore_unconfirmed || state.work.is_none() || state.jobs.busy() {
        return;
    }
    state.restore_unconfirmed = false;
    if let Some(dir) = &state.config.session_dir {
        autosave::restored(dir);
    }
}

/// Appends the volumes that appeared in the data folder since the last listing (with their
/// thumbnails, once the chooser has asked for thumbnails). Counted in polls, so that the
/// replay harness's clock drives it like every other timer.
pub(super) fn rescan_data_folder(state: &Shared) {
    let mut state = state.borrow_mut();
    state.polls_since_scan += 1;
    if state.polls_since_scan < super::RESCAN_POLLS || state.config.data_dir.is_none() {
        return;
    }
    state.polls_since_scan = 0;
    let found = super::library::scan(state.config.data_dir.as_deref());
    let added = super::library::appeared(&state.sources, found);
    if added.is_empty() {
        return;
    }
    log::info!("{} new volume(s) in the data folder", added.len());
    for (_, source) in &added {
        state.sources.push(source.clone());
        state.volumes_model.push(VolumeCard {
            name: source.name().into(),
            detail: "".into(),
            thumbnail: slint::Image::default(),
            failed: false,
        });
    }
    if state.thumbnails_requested {
        state.thumbnails_pending += added.len();
        state.loader.thumbnails(added);
    }
}

pub(super) fn loader_event(window: &AppWindow, state: &Shared, event: LoaderEvent) {
    match event {
        LoaderEvent::Thumbnail { index, result } => {
            let model = state.borrow().volumes_model.clone();
            {
                let mut state = state.borrow_mut();
                state.thumbnails_pending = state.thumbnails_pending.saturating_sub(1);
            }
            let Some(mut card) = model.row_data(index) else { return };
            match result {
                Ok((image, detail)) => {
                    card.thumbnail = to_slint_image(&image);
                    card.detail = detail.into();
                }
                Err(message) => {
                    let source = state.borrow().sources.get(index).cloned();
                    log::warn!("cannot open {}: {message}", source.as_ref().map_or(String::new(), |s| s.key()));
                    mark_failed(&mut card, &reason(&message, source.as_ref()));
                }
            }
            model.set_row_data(index, card);
        }
        LoaderEvent::Opened { index, result } => {
            let mut state_ref = state.borrow_mut();
            if state_ref.opening != Some(index) {
                return;
            }
            state_ref.opening = None;
            state_ref.status.clear();
            match result {
                Ok(loaded) => {
                    drop(state_ref);
                    open_work(window, state, *loaded);
                }
                Err(message) => {
                    let source = state_ref.sources.get(index).cloned();
                    let name = source.as_ref().map(|source| source.name()).unwrap_or_default();
                    log::warn!("cannot open {name}: {message}");
                    let message = reason(&message, source.as_ref());
                    // The restore's volume: the session is set aside, and the banner says where.
                    let restoring = state_ref.restore.take().is_some() && state_ref.restore_unconfirmed;
                    state_ref.restore_unconfirmed = false;
                    state_ref.banner = match (&state_ref.config.session_dir, restoring) {
                        (Some(dir), true) => autosave::abandon(dir, name, message.clone()).message(),
                        _ => format!("Cannot open {name}: {message}."),
                    };
                    let model = state_ref.volumes_model.clone();
                    drop(state_ref);
                    if let Some(mut card) = model.row_data(index) {
                        mark_failed(&mut card, &message);
                        model.set_row_data(index, card);
                    }
                }
            }
        }
    }
}

/// A card whose file cannot be opened says so ("Cannot open"), and why.
fn mark_failed(card: &mut VolumeCard, reason: &str) {
    let mut characters = reason.chars();
    let sentence: String =
        characters.next().map(|first| first.to_uppercase().chain(characters).collect()).unwrap_or_default();
    card.failed = true;
    card.detail = sentence.into();
    card.thumbnail = slint::Image::default();
}

fn reason(message: &str, source: Option<&VolumeSource>) -> String {
    source.map_or_else(|| message.to_string(), |source| super::library::reason_for_display(message, source))
}

/// The work screen on a newly opened volume, with the saved session's classes if it was saved
/// for this volume.
fn open_work(window: &AppWindow, state: &Shared, loaded: LoadedVolume) {
    let caption;
    {
        let mut state = state.borrow_mut();
        let orientation = loaded.volume.orientation.as_ref();
        let panels = plane_axes(orientation).map(|axis| Panel {
            axis,
            rank: 0,
            slice: loaded.entropies.axis(axis).top(),
            layout: SliceLayout::new(orientation, axis),
        });
        let mut session = WorkSession::default();
        if let Some(saved) = state.restore.take()
            && saved.volume == loaded.source.key()
        {
            session = WorkSession::from_strokes(&saved.strokes);
            if let Some(template) = crate::transfer::TemplateType::from_name(&saved.template) {
                state.chosen_template = Some(crate::transfer::HueTemplate::new(template, saved.rotation_degrees));
            }
        }
        let home = orientation.map(HomeView::of);
        caption = home_caption(home.as_ref());
        state.home_camera = match home {
            Some(home) => Camera {
                azimuth_degrees: home.azimuth_degrees,
                elevation_degrees: home.elevation_degrees,
                ..Camera::default()
            },
            None => Camera::default(),
        };
        state.camera = state.home_camera;
        if !loaded.volume.warnings.is_empty() {
            for warning in &loaded.volume.warnings {
                log::warn!("{}: {warning}", loaded.source.name());
            }
            state.banner = format!("{}: {}", loaded.source.name(), loaded.volume.warnings.join("; "));
        }
        state.renderer.set_volume(loaded.volume.clone());
        let initial = loaded.windows.initial();
        state.work = Some(Work {
            loaded,
            session,
            panels,
            drawing: None,
            classified: None,
            requested: None,
            window: initial.window,
            window_name: initial.name.to_string(),
            enlarged: None,
            zoom: 1.0,
            pan: [0.0; 2],
            feedback: None,
        });
    }
    let session = window.global::<Session>();
    session.set_view_picture(slint::Image::default());
    session.set_view_caption(caption.into());
    show_screen(window, Screen::Work);
    session_changed(window, state);
}

/// What the 3-D view says about its home position: nothing when it shows the patient from the
/// front with the head up; otherwise what it shows instead (`HomeView`'s flags).
pub(super) fn home_caption(home: Option<&HomeView>) -> &'static str {
    match home {
        None => "Orientation unknown: stored axes",
        Some(home) if home.mirrored => {
            "Front view, mirrored: the patient's left is on the left (left-handed file axes)"
        }
        Some(home) if !home.exact => "Nearest front view with the head up",
        Some(_) => "",
    }
}
