//! The PACS screen and "Send to PACS" as the app model applies them: each intent to the
//! PACS model and its jobs to the worker, the worker's reports collected, a retrieved series
//! opened.
//!
//! Never: talks to the network itself (the worker does).

use super::{PacsIntent, SendRequest};
use crate::model::{AppModel, Show};
use volasso_core::phantom::source::VolumeSource;

/// The first date of "today's studies", as the PACS writes dates (`YYYYMMDD`): yesterday by the
/// kiosk's clock (UTC), so that today's studies are listed whatever the hospital's time zone
/// (a modality writes its local date; the kiosk may run on UTC).
fn todays_studies_since() -> String {
    let seconds = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let [year, month, day] = volasso_core::calendar::civil_from_days((seconds / 86_400) as i64 - 1);
    format!("{year:04}{month:02}{day:02}")
}

impl AppModel {
    /// What the user did on the PACS screen or to "Send to PACS".
    pub(crate) fn pacs_intent(&mut self, intent: PacsIntent) -> Show {
        let opens = intent == PacsIntent::Open;
        if let Some(job) = self.pacs.model.update(intent, &todays_studies_since()) {
            self.pacs.worker.send(job);
        }
        if opens {
            self.screen = crate::model::Screen::Pacs;
        }
        Show { screen: opens, pacs: true, ..Show::default() }
    }

    /// "Send to PACS": sends the classification shown, or says why it cannot.
    pub(crate) fn send_to_pacs(&mut self) -> Show {
        let work = self.ctl.work.as_ref();
        let classified = work.and_then(|work| work.classified.as_ref());
        if let Some(reason) = self.pacs.model.send_blocked(classified.is_some()) {
            self.pacs.model.send_message = reason.to_string();
            return Show { pacs: true, ..Show::default() };
        }
        let request = work.zip(classified).and_then(|(work, classified)| {
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
                .map(|(index, style)| volasso_dicom::dicom_out::Segment::of_class(name(index), style))
                .collect();
            let picture = self.view_picture.clone();
            Some(SendRequest { folder, series_uid, labels: classified.labels.clone(), segments, picture })
        });
        match request {
            Some(request) => self.pacs_intent(PacsIntent::Send(request)),
            None => Show { pacs: true, ..Show::default() },
        }
    }

    /// Collects the PACS worker's reports; a retrieved series opens.
    pub(crate) fn poll_pacs(&mut self) -> Show {
        let mut show = Show::default();
        while let Some(delivery) = self.pacs.worker.poll() {
            self.pacs.model.apply(delivery.output);
            show.pacs = true;
        }
        let retrieved = std::mem::take(&mut self.pacs.model.retrieved);
        if let Some(folder) = retrieved.first() {
            let index = self.add_source(VolumeSource::Path(folder.clone()));
            show = show.and(self.open_volume(index)).and(Show { cards: true, ..Show::default() });
        }
        show
    }
}
