//! What the loader thread reports, applied to the app: thumbnails onto the chooser's cards, a
//! file that cannot be opened onto its card ("Cannot open" and why) and the banner, an opened
//! volume onto the work screen (with the saved session's classes, its panels in the
//! radiological convention, the 3-D view's home position and a banner for what its reader
//! tolerated, such as a missing slice under `--allow-gaps`), and the restore marker
//! lifted once a restored session has opened and classified (autosave.rs). Also the periodic
//! listing of the data folder, whose new volumes join the chooser.
//!
//! Never: opens files itself (library.rs does, on worker threads).

use crate::chooser::cards::{Card, Changes};
use crate::chooser::library::{LoadedVolume, LoaderEvent, VolumeSource};
use crate::refresh::{self, apply, show_screen, to_slint_image};
use crate::ui::{AppWindow, Session, VolumeCard};
use crate::{Screen, State, Work, autosave};
use slint::{ComponentHandle, Model};
use std::cell::RefCell;
use std::rc::Rc;
use volasso_core::render::Camera;
use volasso_core::slices::HomeView;

type Shared = Rc<RefCell<State>>;

/// A restored session that opened and whose classification ended (or that had none to run)
/// did not stop the app: the restore marker goes (autosave.rs).
pub(crate) fn confirm_restore(state: &Shared) {
    let mut state = state.borrow_mut();
    if !state.restore_unconfirmed || state.ctl.work.is_none() || state.ctl.jobs.busy() {
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
pub(crate) fn rescan_data_folder(state: &Shared) {
    let mut state = state.borrow_mut();
    state.polls_since_scan += 1;
    if state.polls_since_scan < crate::RESCAN_POLLS || state.config.data_dir.is_none() {
        return;
    }
    state.polls_since_scan = 0;
    let found = crate::chooser::library::scan(state.config.data_dir.as_deref());
    let added = state.cards.add_new(found);
    let retention = state.expiry.retention();
    state.cards.note_expiry(retention, std::time::SystemTime::now());
    if added.is_empty() {
        return;
    }
    log::info!("{} new volume(s) in the data folder", added.len());
    if state.thumbnails_requested {
        state.thumbnails_pending += added.len();
        state.loader.thumbnails(added);
    }
}

/// Drops the cards of scans whose file or folder is gone (deleted as expired), once nothing
/// is being opened or thumbnailed: loader events name cards by index, so the cards are only
/// renumbered while none is in flight; until then `cards_to_drop` stays set.
pub(crate) fn drop_vanished(state: &Shared) {
    let mut state = state.borrow_mut();
    if !state.cards_to_drop || state.opening.is_some() || state.thumbnails_pending > 0 {
        return;
    }
    state.cards_to_drop = false;
    let gone = state.cards.drop_gone();
    if gone > 0 {
        log::info!("{gone} scan(s) gone from the chooser");
    }
}

/// The chooser index of `source`, added as a new card (its thumbnail asked for) when the
/// chooser does not have it yet: a series just retrieved from the PACS.
pub(crate) fn add_source(state: &Shared, source: VolumeSource) -> usize {
    let mut state = state.borrow_mut();
    let (index, new) = state.cards.add(source.clone());
    if !new {
        return index;
    }
    if state.thumbnails_requested {
        state.thumbnails_pending += 1;
        state.loader.thumbnails(vec![(index, source)]);
    }
    index
}

/// A chooser card tapped: its volume opens on the loader thread (a folder of several series
/// says to pick one of their cards).
pub(crate) fn open_volume(window: &AppWindow, shared: &Shared, index: i32) {
    {
        let mut state = shared.borrow_mut();
        let Some(source) = state.cards.source(index.max(0) as usize).cloned() else { return };
        if state.opening.is_some() {
            return;
        }
        let series = state.cards.series_of(&source);
        if series > 1 {
            state.banner = format!("{} holds {series} series: open one of their cards.", source.name());
            drop(state);
            refresh::push_status(window, shared);
            return;
        }
        state.ctl.jobs.cancel();
        state.status = format!("Opening {}...", source.name());
        state.opening = Some(index as usize);
        state.loader.open(index as usize, source);
    }
    refresh::push_status(window, shared);
}

pub(crate) fn loader_event(window: &AppWindow, state: &Shared, event: LoaderEvent) {
    match event {
        LoaderEvent::Thumbnail { index, result } => {
            let mut state = state.borrow_mut();
            state.thumbnails_pending = state.thumbnails_pending.saturating_sub(1);
            match result {
                Ok(thumbnail) => {
                    let size = [thumbnail.image.width, thumbnail.image.height];
                    state.cards.thumbnail(index, thumbnail);
                    // The card's name (a description, modality and count, or a file's name; no
                    // patient data), for whoever reads the journal (the image test does).
                    let name = state.cards.card(index).map_or(String::new(), |card| card.name.clone());
                    log::info!("card {}: \"{name}\" with a {}x{} thumbnail", index + 1, size[0], size[1]);
                }
                Err(error) => {
                    let message = error.to_string();
                    let source = state.cards.source(index).cloned();
                    log::warn!("cannot open {}: {message}", source.as_ref().map_or(String::new(), |s| s.key()));
                    state.cards.failed_to_open(index, &reason(&message, source.as_ref()));
                }
            }
        }
        LoaderEvent::Series { index, series } => show_series(state, index, series),
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
                Err(error) => {
                    let message = error.to_string();
                    let source = state_ref.cards.source(index).cloned();
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
                    state_ref.cards.failed_to_open(index, &message);
                }
            }
        }
    }
}

/// A folder of several series: its card says so, and each series joins the chooser as a card of
/// its own (appended, so the indices of cards in flight stay valid), with its thumbnail.
fn show_series(state: &Shared, index: usize, series: Vec<VolumeSource>) {
    let mut state = state.borrow_mut();
    state.thumbnails_pending = state.thumbnails_pending.saturating_sub(1);
    state.cards.folder_of_series(index, series.len());
    let added = state.cards.add_new(series);
    log::info!("a folder holds {} series", added.len());
    state.thumbnails_pending += added.len();
    state.loader.thumbnails(added);
}

/// Shows the cards that changed (cards.rs) in the chooser.
pub(crate) fn show_cards(state: &Shared) {
    let mut state = state.borrow_mut();
    let changes = state.cards.take_changes();
    let model = state.volumes_model.clone();
    let card = |index: usize| state.cards.card(index).map(to_volume_card);
    match changes {
        Changes::None => {}
        Changes::All => model.set_vec((0..state.cards.len()).filter_map(card).collect::<Vec<_>>()),
        Changes::Rows(rows) => {
            for index in rows {
                let Some(shown) = card(index) else { continue };
                if index < model.row_count() {
                    model.set_row_data(index, shown);
                } else {
                    // New cards come in order after the shown ones.
                    while model.row_count() < index {
                        let Some(before) = card(model.row_count()) else { break };
                        model.push(before);
                    }
                    model.push(shown);
                }
            }
        }
    }
}

/// A card as the chooser shows it.
fn to_volume_card(card: &Card) -> VolumeCard {
    VolumeCard {
        name: card.name.clone().into(),
        detail: crate::words::tr(&card.detail).into(),
        patient: card.patient.clone().into(),
        expires: crate::words::tr(&card.expires).into(),
        thumbnail: card.thumbnail.as_ref().map_or_else(slint::Image::default, to_slint_image),
        failed: card.failed,
    }
}

fn reason(message: &str, source: Option<&VolumeSource>) -> String {
    source.map_or_else(|| message.to_string(), |source| crate::chooser::library::reason_for_display(message, source))
}

/// The work screen on a newly opened volume, with the saved session's classes if it was saved
/// for this volume.
fn open_work(window: &AppWindow, state: &Shared, loaded: LoadedVolume) {
    let caption;
    let changed;
    {
        let mut state = state.borrow_mut();
        let home = loaded.volume.orientation.as_ref().map(HomeView::of);
        caption = home_caption(home.as_ref());
        state.view.open(match home {
            Some(home) => Camera {
                azimuth_degrees: home.azimuth_degrees,
                elevation_degrees: home.elevation_degrees,
                ..Camera::default()
            },
            None => Camera::default(),
        });
        state.audit.record(volasso_appliance::audit::Event::ScanOpened, loaded.series_uid.clone(), None);
        // Whether the scan can go back to the PACS; a send's answer belongs to the scan before.
        state.pacs.model.opened(&loaded.source);
        if !loaded.volume.warnings.is_empty() {
            for warning in &loaded.volume.warnings {
                log::warn!("{}: {warning}", loaded.source.name());
            }
            state.banner = format!("{}: {}", loaded.source.name(), loaded.volume.warnings.join("; "));
        }
        // Pictures of the last volume are never kept for this one (refresh::push_slice).
        state.panel_pictures.clear();
        let saved = state.restore.take();
        changed = state.ctl.open(Work::new(loaded), saved);
    }
    let session = window.global::<Session>();
    session.set_view_picture(slint::Image::default());
    session.set_view_caption(crate::words::tr(caption).into());
    show_screen(window, Screen::Work);
    apply(window, state, changed);
    crate::presets::view::apply_chosen(window, state);
}

/// What the 3-D view says about its home position: nothing when it shows the patient from the
/// front with the head up; otherwise what it shows instead (`HomeView`'s flags).
pub(crate) fn home_caption(home: Option<&HomeView>) -> &'static str {
    match home {
        None => "Orientation unknown: stored axes",
        Some(home) if home.mirrored => {
            "Front view, mirrored: the patient's left is on the left (left-handed file axes)"
        }
        Some(home) if !home.exact => "Nearest front view with the head up",
        Some(_) => "",
    }
}
