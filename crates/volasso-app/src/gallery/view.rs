//! The gallery in the app: "Save" on the work screen hands the current result (the session
//! record, the camera, the classes' visibility and the 3-D view's picture) to a writer thread
//! (gallery.rs writes it), the chooser shows the kept results as cards after the volumes, and
//! opening a card opens its volume with its classes, then puts back its camera and visibility
//! once the volume is open. A damaged entry's card says why; one whose scan is gone says so and
//! cannot be opened.
//!
//! Never: writes on the UI thread, or opens a result whose volume is missing.

use crate::State;
use crate::chooser::library::VolumeSource;
use crate::gallery::{self, GalleryEntry, GalleryError, Listed};
use crate::refresh;
use crate::ui::{AppWindow, ResultCard, Session};
use crate::worker::{Report, Task, Threaded, Ticket, Worker};
use slint::{ComponentHandle, Model};
use std::cell::RefCell;
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::Arc;
use volasso_core::render::Camera;

type Shared = Rc<RefCell<State>>;

/// One kept result to write: where, what, and the 3-D view's picture.
pub(crate) struct SaveJob {
    data_dir: PathBuf,
    entry: GalleryEntry,
    picture: image::RgbaImage,
}

/// The gallery's part of the app's state.
pub(crate) struct Results {
    /// The gallery as last listed, in card order.
    listed: Vec<Listed>,
    /// Writes a kept result off the UI thread, a thread per save.
    writer: Box<dyn Worker<SaveJob, Result<PathBuf, GalleryError>>>,
    /// A result being opened: its volume key, camera and visibility, put back once it is open.
    pending: Option<(String, Camera, Vec<bool>)>,
    pub(crate) model: Rc<slint::VecModel<ResultCard>>,
}

impl Default for Results {
    fn default() -> Self {
        let task: Task<SaveJob, Result<PathBuf, GalleryError>> =
            Arc::new(|job: SaveJob, _: &Ticket, report: &Report<'_, Result<PathBuf, GalleryError>>| {
                report(gallery::save(&job.data_dir, &job.entry, &job.picture))
            });
        Results {
            listed: Vec::new(),
            writer: Box::new(Threaded::new("gallery", task)),
            pending: None,
            model: Rc::default(),
        }
    }
}

impl Results {
    /// A save is still being written.
    pub(crate) fn busy(&self) -> bool {
        self.writer.busy()
    }
}

/// Lists the gallery again onto the chooser's result cards.
pub(crate) fn refresh_cards(state: &Shared) {
    let mut state = state.borrow_mut();
    let listed = state.config.data_dir.as_deref().map(gallery::list).unwrap_or_default();
    let cards: Vec<ResultCard> = listed.iter().map(card).collect();
    state.results.listed = listed;
    state.results.model.set_vec(cards);
}

fn card(listed: &Listed) -> ResultCard {
    match listed {
        Listed::Entry { entry, thumbnail, .. } => ResultCard {
            name: entry.volume_name.clone().into(),
            date: gallery::date_text(entry.saved_unix).into(),
            thumbnail: thumbnail.as_ref().map_or_else(slint::Image::default, |image| {
                let buffer = slint::SharedPixelBuffer::<slint::Rgba8Pixel>::clone_from_slice(
                    image.as_raw(),
                    image.width(),
                    image.height(),
                );
                slint::Image::from_rgba8(buffer)
            }),
            problem: if entry.volume_missing() { entry.missing_message().into() } else { "".into() },
        },
        Listed::Damaged { folder, reason } => ResultCard {
            name: folder.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned()).into(),
            date: "".into(),
            thumbnail: slint::Image::default(),
            problem: format!("This saved result cannot be read: {reason}").into(),
        },
    }
}

/// "Save": the current result to the gallery, written on a thread of its own.
pub(crate) fn save(window: &AppWindow, state: &Shared) {
    let picture = window.global::<Session>().get_view_picture().to_rgba8();
    let mut state_ref = state.borrow_mut();
    let message = match prepare(&state_ref, picture) {
        Err(message) => message,
        Ok((data_dir, entry, picture)) => {
            state_ref.results.writer.send(SaveJob { data_dir, entry, picture });
            "Saving to the gallery...".to_string()
        }
    };
    state_ref.status = message;
    drop(state_ref);
    refresh::push_status(window, state);
}

type Prepared = (PathBuf, GalleryEntry, image::RgbaImage);

/// What a save writes, or why there is nothing to save.
fn prepare(state: &State, picture: Option<slint::SharedPixelBuffer<slint::Rgba8Pixel>>) -> Result<Prepared, String> {
    if state.results.busy() {
        return Err("Still saving the last result...".into());
    }
    let data_dir = state.config.data_dir.clone().ok_or("Cannot save: there is no data folder")?;
    let work = state.ctl.work.as_ref().ok_or("Nothing to save: no scan is open")?;
    if work.classified.is_none() {
        return Err("Nothing to save yet: draw two classes first".into());
    }
    let session = state.ctl.saved_session().ok_or("Nothing to save: no scan is open")?;
    let picture = picture
        .filter(|p| p.width() > 0 && p.height() > 0)
        .and_then(|p| image::RgbaImage::from_raw(p.width(), p.height(), p.as_bytes().to_vec()))
        .ok_or("Nothing to save yet: the 3-D view has no picture")?;
    let saved_unix =
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |since| since.as_secs());
    let entry = GalleryEntry {
        session,
        volume_name: work.loaded.source.name(),
        saved_unix,
        camera: state.view.camera,
        visible: work.session.classes.iter().map(|class| class.visible).collect(),
    };
    Ok((data_dir, entry, picture))
}

/// Collects a finished save, and puts back a result's camera and visibility once its volume
/// is open; called by the poll timer.
pub(crate) fn poll(window: &AppWindow, state: &Shared) {
    let finished = {
        let mut state = state.borrow_mut();
        let results = &mut state.results;
        match results.writer.poll() {
            Some(delivery) => Some(delivery.output.map_err(|error| error.to_string())),
            // Its thread could not start, or stopped without a word (logged).
            None => results.writer.ended_silently().map(|_| Err("the gallery writer stopped".to_string())),
        }
    };
    if let Some(result) = finished {
        {
            let mut state = state.borrow_mut();
            state.status = match result {
                Ok(folder) => {
                    log::info!("result kept in {}", folder.display());
                    "Saved to the gallery".to_string()
                }
                Err(message) => {
                    log::warn!("cannot save the result: {message}");
                    format!("Cannot save: {message}")
                }
            };
        }
        refresh_cards(state);
        refresh::push_status(window, state);
    }
    put_back(window, state);
}

/// The opened result's camera and visibility, once its volume is the open one.
fn put_back(window: &AppWindow, state: &Shared) {
    let mut state_ref = state.borrow_mut();
    let Some((key, camera, visible)) = state_ref.results.pending.clone() else { return };
    if state_ref.opening.is_some() {
        return;
    }
    state_ref.results.pending = None;
    let open = state_ref.ctl.work.as_ref().is_some_and(|work| work.loaded.source.key() == key);
    if !open {
        // The volume did not open (its card and the banner say why).
        return;
    }
    state_ref.view.camera = camera;
    state_ref.view.dirty = true;
    let mut changed = None;
    for (index, shown) in visible.into_iter().enumerate() {
        let class_shown = state_ref.ctl.work.as_ref().and_then(|w| w.session.classes.get(index)).map(|c| c.visible);
        if class_shown == Some(!shown) {
            changed = Some(state_ref.ctl.toggle_class(index));
        }
    }
    drop(state_ref);
    if let Some(changed) = changed {
        refresh::apply(window, state, changed);
    }
}

/// A result card tapped: its volume opens with its classes; its camera and visibility follow.
pub(crate) fn open(window: &AppWindow, state: &Shared, index: i32) {
    let entry = {
        let mut state = state.borrow_mut();
        if state.opening.is_some() {
            return;
        }
        let Some(Listed::Entry { entry, .. }) = state.results.listed.get(index.max(0) as usize).cloned() else {
            return;
        };
        if entry.volume_missing() {
            state.status = entry.missing_message();
            return;
        }
        entry
    };
    let source = VolumeSource::from_key(&entry.session.volume);
    // A scan outside the data folder joins the chooser, so indices stay aligned.
    let index = crate::chooser::loading::add_source(state, source.clone());
    {
        let mut state = state.borrow_mut();
        state.ctl.jobs.cancel();
        state.status = format!("Opening {}...", entry.volume_name);
        state.results.pending = Some((entry.session.volume.clone(), entry.camera, entry.visible.clone()));
        state.restore = Some(entry.session.clone());
        state.opening = Some(index);
        state.loader.open(index, source);
    }
    refresh::push_status(window, state);
}

/// Replay keys: `results` (cards), `result-problem-N` (the message on card N, from 1; empty
/// when it opens).
pub(crate) fn query(state: &State, key: &str) -> Option<String> {
    if key == "results" {
        return Some(state.results.model.row_count().to_string());
    }
    let number: usize = key.strip_prefix("result-problem-")?.parse().ok()?;
    let card = state.results.model.row_data(number.checked_sub(1)?)?;
    Some(card.problem.to_string())
}
