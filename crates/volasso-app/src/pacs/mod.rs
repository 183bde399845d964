//! The hospital round trip on the kiosk. The PACS screen lists the day's CT and MR studies of
//! a configured PACS, searches one by patient ID or accession number typed on a keypad, and
//! retrieves a tapped study with its progress; the work screen's "Send to PACS" stores the
//! classification as a DICOM Segmentation and the 3-D view as a Secondary Capture in the
//! scan's own study (`docs/kiosk.md`, "PACS").
//!
//! All behaviour is here, without a window: [`PacsModel::update`] takes what the user did (a
//! [`PacsIntent`]) and answers the [`PacsJob`] to run; the jobs run behind one
//! [`Worker`](super::worker::Worker) ([`jobs`]), whose reports go back through
//! [`PacsModel::apply`]. `view.rs` alone talks to Slint.
//!
//! Never: offers a PACS screen where no PACS is configured, says a result was sent before the
//! PACS answered every object with success, offers "Send to PACS" for a volume that did not
//! come from a DICOM series, or logs a patient's name or ID.

pub(crate) mod app;
pub mod jobs;
#[cfg(test)]
mod tests;
pub mod view;

use std::path::PathBuf;
use volasso_core::phantom::source::VolumeSource;
use volasso_dicom::pacs::{FindQuery, Peer, StudyFound};

/// The most characters a search may hold (the keypad stops there).
const MOST_TYPED: usize = 24;

/// Which identifier the keypad's digits search.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SearchField {
    PatientId,
    Accession,
}

/// What the user does on the PACS screen and to "Send to PACS".
#[derive(Clone, Debug, PartialEq)]
pub enum PacsIntent {
    /// The chooser's "PACS" button: the screen opens on today's studies.
    Open,
    /// A keypad key: a digit or letter, `back` (delete the last) or `clear`.
    Key(String),
    /// Search patient IDs or accession numbers.
    Field(SearchField),
    /// Search for what is typed (every date).
    Search,
    /// Today's CT and MR studies again.
    Today,
    /// Retrieve the study shown at this row.
    Retrieve(usize),
    /// The next configured PACS (with several).
    NextPeer,
    /// "Send to PACS" on the work screen, with what to send.
    Send(SendRequest),
}

/// What "Send to PACS" sends: the scan it was classified on and the classification.
#[derive(Clone, Debug, PartialEq)]
pub struct SendRequest {
    /// The DICOM folder and, for a folder of several series, the series.
    pub folder: PathBuf,
    pub series_uid: Option<String>,
    /// One label per voxel in the series' order (0: no class).
    pub labels: std::sync::Arc<Vec<u8>>,
    /// Per class (label 1, 2, ...): its segment, name and colour.
    pub segments: Vec<volasso_dicom::dicom_out::Segment>,
    /// The 3-D view as shown, for the Secondary Capture; `None`: the SEG alone.
    pub picture: Option<image::RgbaImage>,
}

/// Work for the PACS worker.
#[derive(Debug)]
pub enum PacsJob {
    Find {
        peer: Peer,
        query: FindQuery,
    },
    /// Retrieves these series of the study, one C-GET each (a study's other objects, its
    /// reports and earlier results, are not the kiosk's to store).
    Get {
        peer: Peer,
        data_dir: PathBuf,
        study_uid: String,
        series_uids: Vec<String>,
    },
    Send {
        peer: Peer,
        outbox: PathBuf,
        request: Box<SendRequest>,
        /// The data folder whose audit log records a send that went; `None`: none.
        audit_dir: Option<PathBuf>,
    },
}

/// What the PACS worker reports.
#[derive(Debug)]
pub enum PacsReport {
    Found(Result<Vec<StudyFound>, String>),
    /// Images filed so far by the running retrieval.
    Stored(u64),
    /// The retrieval ended: the folders of the series published (CT and MR that the kiosk
    /// reads), or why none was.
    Retrieved(Result<Vec<PathBuf>, String>),
    /// The send ended: what the PACS answered, in a sentence for the screen.
    Sent(Result<String, String>),
}

/// What the PACS screen and the "Send to PACS" button are doing.
#[derive(Clone, Debug, PartialEq)]
pub enum Phase {
    Idle,
    Searching,
    Retrieving { row: usize, stored: u64, expected: Option<u64> },
}

/// What a row of the study list shows.
#[derive(Clone, Debug, PartialEq)]
pub struct StudyRow {
    pub name: String,
    pub patient_id: String,
    /// `YYYY-MM-DD`, or empty.
    pub date: String,
    pub description: String,
    /// E.g. `CT · 2 series · 180 images`.
    pub detail: String,
}

/// Everything the PACS screen and the send button show.
#[derive(Debug)]
pub struct PacsModel {
    peers: Vec<Peer>,
    peer: usize,
    /// Where retrieved series are published (the data folder), and where objects to send are
    /// written first (under the session folder or the data folder); `None`: retrieval and
    /// sending are impossible, and the screen says so.
    data_dir: Option<PathBuf>,
    outbox: Option<PathBuf>,
    pub field: SearchField,
    pub typed: String,
    studies: Vec<StudyFound>,
    pub phase: Phase,
    /// The line under the title: how many studies, progress, or what failed.
    pub message: String,
    /// Whether a send is running.
    pub sending: bool,
    /// The send's progress or answer, shown beside the button.
    pub send_message: String,
    /// Series retrieved and not yet opened: the app opens the first and clears this.
    pub retrieved: Vec<PathBuf>,
    last_failed: bool,
    /// The open scan came from DICOM (a folder or one series of it), so it has a study to
    /// join; decided once when it opens ([`Self::opened`]).
    from_dicom: bool,
}

impl PacsModel {
    pub fn new(peers: Vec<Peer>, data_dir: Option<PathBuf>, outbox: Option<PathBuf>) -> PacsModel {
        PacsModel {
            peers,
            peer: 0,
            data_dir,
            outbox,
            field: SearchField::PatientId,
            typed: String::new(),
            studies: Vec::new(),
            phase: Phase::Idle,
            message: String::new(),
            sending: false,
            send_message: String::new(),
            retrieved: Vec::new(),
            last_failed: false,
            from_dicom: false,
        }
    }

    /// The PACS in use, `AE@host:port`; empty when none is configured (no PACS button).
    pub fn peer_name(&self) -> String {
        self.peers.get(self.peer).map(Peer::describe).unwrap_or_default()
    }

    pub fn has_several_peers(&self) -> bool {
        self.peers.len() > 1
    }

    /// Whether the last search or retrieval failed (its message says why).
    pub fn failed(&self) -> bool {
        self.last_failed
    }

    /// A search or retrieval is running (the screen's keys wait).
    pub fn busy(&self) -> bool {
        self.phase != Phase::Idle
    }

    /// The retrieval's progress in 0..=1, when its size is known.
    pub fn progress(&self) -> Option<f32> {
        match self.phase {
            Phase::Retrieving { stored, expected: Some(expected), .. } if expected > 0 => {
                Some((stored as f32 / expected as f32).min(1.0))
            }
            _ => None,
        }
    }

    pub fn rows(&self) -> Vec<StudyRow> {
        self.studies.iter().map(row).collect()
    }

    /// A scan opened from `source`: whether it can go back to the PACS (only a DICOM folder or
    /// series has a study to join: every other format is a file, the demo none), and no
    /// answer of a send from the scan before.
    pub fn opened(&mut self, source: &VolumeSource) {
        self.from_dicom = match source {
            VolumeSource::Series { .. } => true,
            VolumeSource::Path(path) => path.is_dir(),
            VolumeSource::Demo => false,
        };
        self.send_message.clear();
    }

    /// Why "Send to PACS" cannot be used for the scan opened last, with a classification shown
    /// or not; `None`: it can.
    pub fn send_blocked(&self, classified: bool) -> Option<&'static str> {
        if self.peers.is_empty() {
            return Some("No PACS is configured");
        }
        if !self.from_dicom {
            return Some("Only a scan from DICOM can go back to the PACS");
        }
        if !classified {
            return Some("Classify first: draw two classes");
        }
        if self.sending {
            return Some("Sending...");
        }
        None
    }

    /// What `intent` changes, and the job it starts, if any; "today's studies" are those dated
    /// `since` (`YYYYMMDD`) or later.
    pub fn update(&mut self, intent: PacsIntent, since: &str) -> Option<PacsJob> {
        let peer = self.peers.get(self.peer).cloned()?;
        match intent {
            PacsIntent::Open | PacsIntent::Today if !self.busy() => {
                self.typed.clear();
                self.phase = Phase::Searching;
                self.message = "Asking the PACS for today's studies...".into();
                let query = FindQuery { since: Some(since.to_string()), ..FindQuery::default() };
                Some(PacsJob::Find { peer, query })
            }
            PacsIntent::Key(key) => {
                match key.as_str() {
                    "back" => {
                        self.typed.pop();
                    }
                    "clear" => self.typed.clear(),
                    key if key.chars().count() == 1
                        && key.chars().all(|c| c.is_ascii_alphanumeric())
                        && self.typed.len() < MOST_TYPED =>
                    {
                        self.typed.push_str(&key.to_ascii_uppercase())
                    }
                    _ => {}
                }
                None
            }
            PacsIntent::Field(field) => {
                self.field = field;
                None
            }
            PacsIntent::Search if !self.busy() && !self.typed.is_empty() => {
                self.phase = Phase::Searching;
                let (what, query) = match self.field {
                    SearchField::PatientId => {
                        ("patient ID", FindQuery { patient_id: Some(self.typed.clone()), ..FindQuery::default() })
                    }
                    SearchField::Accession => (
                        "accession number",
                        FindQuery { accession_number: Some(self.typed.clone()), ..FindQuery::default() },
                    ),
                };
                self.message = format!("Searching for {what} {}...", self.typed);
                Some(PacsJob::Find { peer, query })
            }
            PacsIntent::Retrieve(row) if !self.busy() => {
                let study = self.studies.get(row)?;
                let Some(data_dir) = self.data_dir.clone() else {
                    self.message = "Cannot retrieve: the kiosk has no data folder".into();
                    return None;
                };
                let expected = readable_series(study).map(|series| series.images).sum::<Option<u64>>();
                self.phase = Phase::Retrieving { row, stored: 0, expected };
                self.message = format!("Retrieving {}...", describe(study));
                let series_uids = readable_series(study).map(|series| series.series_uid.clone()).collect();
                Some(PacsJob::Get { peer, data_dir, study_uid: study.study_uid.clone(), series_uids })
            }
            PacsIntent::NextPeer if !self.busy() && self.peers.len() > 1 => {
                self.peer = (self.peer + 1) % self.peers.len();
                self.studies.clear();
                self.update(PacsIntent::Today, since)
            }
            PacsIntent::Send(request) if !self.sending => {
                let Some(outbox) = self.outbox.clone() else {
                    self.send_message = "Not sent: the kiosk has no folder to write the result in".into();
                    return None;
                };
                self.sending = true;
                self.send_message = format!("Sending to {}...", peer.ae_title);
                Some(PacsJob::Send { peer, outbox, request: Box::new(request), audit_dir: self.data_dir.clone() })
            }
            _ => None,
        }
    }

    /// What a report of the PACS worker changes.
    pub fn apply(&mut self, report: PacsReport) {
        self.last_failed = matches!(report, PacsReport::Found(Err(_)) | PacsReport::Retrieved(Err(_)))
            || (self.last_failed && matches!(report, PacsReport::Sent(_)));
        match report {
            PacsReport::Found(Ok(studies)) => {
                self.phase = Phase::Idle;
                self.studies = studies.into_iter().filter(|study| readable_series(study).next().is_some()).collect();
                self.studies.sort_by(|a, b| b.study_date.cmp(&a.study_date));
                self.message = match self.studies.len() {
                    0 => "No CT or MR study found".into(),
                    1 => "1 study: tap it to retrieve it".into(),
                    count => format!("{count} studies: tap one to retrieve it"),
                };
            }
            PacsReport::Found(Err(problem)) => {
                self.phase = Phase::Idle;
                self.studies.clear();
                self.message = format!("The PACS did not answer the search: {problem}");
            }
            PacsReport::Stored(count) => {
                if let Phase::Retrieving { stored, expected, .. } = &mut self.phase {
                    *stored = count;
                    self.message = match expected {
                        Some(expected) => format!("Retrieving: {count} of {expected} images"),
                        None => format!("Retrieving: {count} images"),
                    };
                }
            }
            PacsReport::Retrieved(Ok(series)) => {
                self.phase = Phase::Idle;
                self.message = match series.len() {
                    0 => "The PACS sent no CT or MR series the kiosk can open".into(),
                    1 => "Retrieved: opening the series".into(),
                    count => format!("Retrieved {count} series: opening the first"),
                };
                self.retrieved = series;
            }
            PacsReport::Retrieved(Err(problem)) => {
                self.phase = Phase::Idle;
                self.message = format!("Not retrieved: {problem}");
            }
            PacsReport::Sent(answer) => {
                self.sending = false;
                self.send_message = match answer {
                    Ok(answer) => answer,
                    Err(problem) => format!("Not sent: {problem}"),
                };
            }
        }
    }
}

/// The series of `study` that the kiosk reads (CT and MR).
fn readable_series(study: &StudyFound) -> impl Iterator<Item = &volasso_dicom::pacs::SeriesFound> {
    study.series.iter().filter(|series| matches!(series.modality.as_str(), "CT" | "MR"))
}

/// A study in a few words for the status line: its description or its date.
fn describe(study: &StudyFound) -> String {
    if study.description.is_empty() {
        format!("the study of {}", date(&study.study_date))
    } else {
        study.description.clone()
    }
}

/// `YYYYMMDD` as `YYYY-MM-DD`; anything else as it is.
fn date(text: &str) -> String {
    if text.len() == 8 && text.bytes().all(|b| b.is_ascii_digit()) {
        format!("{}-{}-{}", &text[..4], &text[4..6], &text[6..])
    } else {
        text.to_string()
    }
}

fn row(study: &StudyFound) -> StudyRow {
    let series: Vec<_> = readable_series(study).collect();
    let mut modalities: Vec<&str> = series.iter().map(|s| s.modality.as_str()).collect();
    modalities.dedup();
    let images: Option<u64> = series.iter().map(|s| s.images).sum();
    let mut detail = format!("{} · {} series", modalities.join("/"), series.len());
    if let Some(images) = images {
        detail.push_str(&format!(" · {images} images"));
    }
    StudyRow {
        name: if study.patient_name.is_empty() { "(no name)".into() } else { study.patient_name.clone() },
        patient_id: study.patient_id.clone(),
        date: date(&study.study_date),
        description: study.description.clone(),
        detail,
    }
}

/// The PACS model and its worker, as the app holds them.
pub(crate) struct Pacs {
    pub(crate) model: PacsModel,
    pub(crate) worker: Box<dyn crate::worker::Worker<PacsJob, PacsReport>>,
    /// The study rows last written into the window: the list is set again only when they
    /// change (a keypad key changes none).
    pub(crate) shown_rows: Vec<StudyRow>,
}

impl Pacs {
    /// A job of the worker is running (replay's `wait-idle` waits for it).
    pub(crate) fn busy(&self) -> bool {
        self.worker.busy()
    }
}
