//! The PACS model on screen: intents from Session's pacs-* callbacks go to
//! [`PacsModel::update`] and its jobs to the PACS worker; the poll timer hands the worker's
//! reports back and opens a retrieved series; [`push`] writes the model into Session.
//!
//! Never: decides anything (that is `PacsModel`'s).

use super::{PacsIntent, PacsModel, SendRequest};
use crate::refresh;
use crate::ui::{AppWindow, Session, StudyRow};
use crate::worker::Worker;
use crate::{Screen, State};
use slint::{ComponentHandle, ModelRc, VecModel};
use std::cell::RefCell;
use std::rc::Rc;
use volasso_core::phantom::source::VolumeSource;
use volasso_dicom::dicom_out::Segment;

type Shared = Rc<RefCell<State>>;

/// The model and its worker, as the app holds them.
pub(crate) struct Pacs {
    pub(crate) model: PacsModel,
    pub(crate) worker: Box<dyn Worker<super::PacsJob, super::PacsReport>>,
    /// The study rows last written into Session: the list is set again only when they change
    /// (a keypad key changes none).
    pub(crate) shown_rows: Vec<super::StudyRow>,
}

impl Pacs {
    /// A job of the worker is running (replay's `wait-idle` waits for it).
    pub(crate) fn busy(&self) -> bool {
        self.worker.busy()
    }
}

/// The first date of "today's studies", as the PACS writes dates (`YYYYMMDD`): yesterday by the
/// kiosk's clock (UTC), so that today's studies are listed whatever the hospital's time zone
/// (a modality writes its local date; the kiosk may run on UTC).
fn todays_studies_since() -> String {
    let seconds = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let [year, month, day] = volasso_core::calendar::civil_from_days((seconds / 86_400) as i64 - 1);
    format!("{year:04}{month:02}{day:02}")
}

/// What the user did on the PACS screen or to "Send to PACS".
pub(crate) fn intent(window: &AppWindow, shared: &Shared, intent: PacsIntent) {
    let opens = intent == PacsIntent::Open;
    {
        let mut state = shared.borrow_mut();
        let pacs = &mut state.pacs;
        if let Some(job) = pacs.model.update(intent, &todays_studies_since()) {
            pacs.worker.send(job);
        }
    }
    if opens {
        refresh::show_screen(window, Screen::Pacs);
    }
    push(window, shared);
}

/// "Send to PACS": sends the classification shown, or says why it cannot.
pub(crate) fn send(window: &AppWindow, shared: &Shared) {
    let request = {
        let mut state = shared.borrow_mut();
        let work = state.ctl.work.as_ref();
        let classified = work.and_then(|work| work.classified.as_ref());
        if let Some(reason) = state.pacs.model.send_blocked(classified.is_some()) {
            state.pacs.model.send_message = reason.to_string();
            None
        } else {
            work.zip(classified).and_then(|(work, classified)| {
                let (folder, series_uid) = match &work.loaded.source {
                    VolumeSource::Series { folder, series_uid, .. } => (folder.clone(), Some(series_uid.clone())),
                    VolumeSource::Path(folder) => (folder.clone(), None),
                    VolumeSource::Demo => return None,
                };
                // The lassos not yet defined are classified as a provisional last class.
                let name = |index: usize| {
                    work.session
                        .classes
                        .get(index)
                        .map_or_else(|| format!("Class {} (not defined)", index + 1), |c| c.name.clone())
                };
                let segments = (classified.table.styles.iter().enumerate())
                    .map(|(index, style)| Segment::of_class(name(index), style))
                    .collect();
                let picture = state.tools.picture.clone();
                Some(SendRequest { folder, series_uid, labels: classified.labels.clone(), segments, picture })
            })
        }
    };
    match request {
        Some(request) => intent(window, shared, PacsIntent::Send(request)),
        None => push(window, shared),
    }
}

/// Collects the PACS worker's reports (the poll timer); a retrieved series opens.
pub(crate) fn poll(window: &AppWindow, shared: &Shared) {
    let mut changed = false;
    let retrieved = {
        let mut state = shared.borrow_mut();
        while let Some(delivery) = state.pacs.worker.poll() {
            state.pacs.model.apply(delivery.output);
            changed = true;
        }
        std::mem::take(&mut state.pacs.model.retrieved)
    };
    if let Some(folder) = retrieved.first() {
        let index = crate::chooser::loading::add_source(shared, VolumeSource::Path(folder.clone()));
        crate::chooser::loading::open_volume(window, shared, index as i32);
    }
    if changed {
        push(window, shared);
    }
}

/// Writes the model into Session.
pub(crate) fn push(window: &AppWindow, shared: &Shared) {
    let session = window.global::<Session>();
    {
        let mut state = shared.borrow_mut();
        let rows = state.pacs.model.rows();
        if rows != state.pacs.shown_rows {
            let shown: Vec<StudyRow> = rows
                .iter()
                .map(|row| StudyRow {
                    name: row.name.clone().into(),
                    patient_id: row.patient_id.clone().into(),
                    date: row.date.clone().into(),
                    description: row.description.clone().into(),
                    detail: row.detail.clone().into(),
                })
                .collect();
            session.set_pacs_studies(ModelRc::new(VecModel::from(shown)));
            state.pacs.shown_rows = rows;
        }
    }
    let state = shared.borrow();
    let model = &state.pacs.model;
    session.set_pacs_name(model.peer_name().into());
    session.set_pacs_several(model.has_several_peers());
    session.set_pacs_typed(model.typed.clone().into());
    session.set_pacs_by_accession(model.field == super::SearchField::Accession);
    session.set_pacs_message(crate::words::tr(&model.message).into());
    session.set_pacs_busy(model.busy());
    session.set_pacs_progress(model.progress().unwrap_or(-1.0));
    drop(state);
    push_send(window, shared);
}

/// Writes what "Send to PACS" shows into Session (each poll: it follows the classification).
pub(crate) fn push_send(window: &AppWindow, shared: &Shared) {
    let state = shared.borrow();
    let model = &state.pacs.model;
    let session = window.global::<Session>();
    let work = state.ctl.work.as_ref();
    let blocked = model.send_blocked(work.is_some_and(|w| w.classified.is_some()));
    session.set_send_blocked(blocked.unwrap_or_default().into());
    session.set_send_message(crate::words::tr(&model.send_message).into());
}
