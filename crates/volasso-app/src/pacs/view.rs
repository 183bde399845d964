//! The PACS screen and "Send to PACS" on screen: `show` writes the model (mod.rs) into
//! Session.
//!
//! Never: decides anything (that is `PacsModel`'s).

use crate::State;
use crate::ui::{AppWindow, Session, StudyRow};
use slint::{ComponentHandle, ModelRc, VecModel};

/// Writes the model into Session: the study list only when its rows changed.
pub(crate) fn show(window: &AppWindow, state: &mut State) {
    let session = window.global::<Session>();
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
    let model = &state.pacs.model;
    session.set_pacs_name(model.peer_name().into());
    session.set_pacs_several(model.has_several_peers());
    session.set_pacs_typed(model.typed.clone().into());
    session.set_pacs_by_accession(model.field == super::SearchField::Accession);
    session.set_pacs_message(crate::words::tr(&model.message).into());
    session.set_pacs_busy(model.busy());
    session.set_pacs_progress(model.progress().unwrap_or(-1.0));
    // "Send to PACS" follows the classification.
    let blocked = model.send_blocked(state.ctl.work.as_ref().is_some_and(|w| w.classified.is_some()));
    session.set_send_blocked(blocked.unwrap_or_default().into());
    session.set_send_message(crate::words::tr(&model.send_message).into());
}
