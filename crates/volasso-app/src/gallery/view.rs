//! The gallery on the screens: "Save" on the work screen, the kept results as cards on the
//! chooser after the volumes, a card tapped opening its scan; what each does is the model's
//! (model.rs), this file reads the window and the work for it and shows its answers.
//!
//! Never: decides what is saved or opened; the model does.

use crate::State;
use crate::gallery::model::{CurrentResult, GalleryModel};
use crate::gallery::{self, Listed};
use crate::refresh;
use crate::ui::{AppWindow, ResultCard, Session};
use slint::{ComponentHandle, Model};
use std::cell::RefCell;
use std::rc::Rc;

type Shared = Rc<RefCell<State>>;

/// The gallery's part of the app's state: the model and its cards.
#[derive(Default)]
pub(crate) struct Results {
    pub(crate) model: GalleryModel,
    pub(crate) cards: Rc<slint::VecModel<ResultCard>>,
}

impl Results {
    /// A save is still being written.
    pub(crate) fn busy(&self) -> bool {
        self.model.busy()
    }
}

/// Lists the gallery again onto the chooser's result cards.
pub(crate) fn refresh_cards(state: &Shared) {
    let mut state = state.borrow_mut();
    let data_dir = state.config.data_dir.clone();
    state.results.model.relist(data_dir.as_deref());
    let cards: Vec<ResultCard> = state.results.model.listed().iter().map(card).collect();
    state.results.cards.set_vec(cards);
}

fn card(listed: &Listed) -> ResultCard {
    match listed {
        Listed::Entry { entry, thumbnail, .. } => ResultCard {
            name: entry.volume_name.clone().into(),
            date: gallery::date_text(entry.saved_unix).into(),
            thumbnail: thumbnail.as_ref().map_or_else(slint::Image::default, refresh::rgba_to_slint_image),
            problem: if entry.volume_missing() { crate::words::tr(&entry.missing_message()).into() } else { "".into() },
        },
        Listed::Damaged { folder, reason } => ResultCard {
            name: folder.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned()).into(),
            date: "".into(),
            thumbnail: slint::Image::default(),
            problem: crate::words::tr(&format!("This saved result cannot be read: {reason}")).into(),
        },
    }
}

/// "Save": the current result and the 3-D view's picture to the gallery.
pub(crate) fn save(window: &AppWindow, state: &Shared) {
    let picture = window.global::<Session>().get_view_picture().to_rgba8();
    let picture = picture.and_then(|p| image::RgbaImage::from_raw(p.width(), p.height(), p.as_bytes().to_vec()));
    let saved_unix =
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |since| since.as_secs());
    {
        let mut state = state.borrow_mut();
        let current = current_result(&state);
        let data_dir = state.config.data_dir.clone();
        state.status = state.results.model.save(data_dir.as_deref(), current, picture, saved_unix);
    }
    refresh::push_status(window, state);
}

/// The result on the work screen, when a scan is open.
fn current_result(state: &State) -> Option<CurrentResult> {
    let work = state.ctl.work.as_ref()?;
    Some(CurrentResult {
        session: state.ctl.saved_session()?,
        volume_name: work.loaded.source.name(),
        classified: work.classified.is_some(),
        camera: state.view.camera,
        visible: work.session.classes.iter().map(|class| class.visible).collect(),
    })
}

/// Collects a finished save, and puts back a result's camera and visibility once its volume
/// is open; called by the poll timer.
pub(crate) fn poll(window: &AppWindow, state: &Shared) {
    let finished = state.borrow_mut().results.model.poll();
    if let Some(status) = finished {
        state.borrow_mut().status = status;
        refresh_cards(state);
        refresh::push_status(window, state);
    }
    put_back(window, state);
}

/// The opened result's camera and visibility, once its volume is the open one.
fn put_back(window: &AppWindow, state: &Shared) {
    let mut state_ref = state.borrow_mut();
    let opening = state_ref.opening.is_some();
    let open_key = state_ref.ctl.work.as_ref().map(|work| work.loaded.source.key());
    let Some(look) = state_ref.results.model.look_to_put_back(opening, open_key.as_deref()) else { return };
    state_ref.view.camera = look.camera;
    state_ref.view.dirty = true;
    let mut changed = None;
    for (index, shown) in look.visible.into_iter().enumerate() {
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
    let opening = {
        let mut state = state.borrow_mut();
        if state.opening.is_some() {
            return;
        }
        match state.results.model.open(index.max(0) as usize) {
            None => return,
            Some(Err(message)) => {
                state.status = message;
                None
            }
            Some(Ok(opening)) => Some(opening),
        }
    };
    if let Some(opening) = opening {
        // A scan outside the data folder joins the chooser, so indices stay aligned.
        let index = crate::chooser::loading::add_source(state, opening.source.clone());
        let mut state = state.borrow_mut();
        state.ctl.jobs.cancel();
        state.status = format!("Opening {}...", opening.volume_name);
        state.restore = Some(opening.session);
        state.opening = Some(index);
        state.loader.open(index, opening.source);
    }
    refresh::push_status(window, state);
}

/// Replay keys: `results` (cards), `result-problem-N` (the message on card N, from 1; empty
/// when it opens).
pub(crate) fn query(state: &State, key: &str) -> Option<String> {
    if key == "results" {
        return Some(state.results.cards.row_count().to_string());
    }
    let number: usize = key.strip_prefix("result-problem-")?.parse().ok()?;
    let card = state.results.cards.row_data(number.checked_sub(1)?)?;
    Some(card.problem.to_string())
}
