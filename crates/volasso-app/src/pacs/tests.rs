//! The PACS screen's and "Send to PACS"'s behaviour, without a window, a thread or a network:
//! intents in, jobs and what the screen shows out; the worker's reports applied.

use super::*;
use crate::worker::{Inline, Report, Task, Ticket, Worker};
use std::sync::Arc;
use std::time::Duration;
use volasso_dicom::dicom_out::Segment;
use volasso_dicom::pacs::SeriesFound;

const TODAY: &str = "20261206";

fn peer(title: &str) -> Peer {
    Peer::parse(&format!("{title}@127.0.0.1:4242"), "VOLASSO", Duration::from_secs(5)).unwrap()
}

fn model() -> PacsModel {
    PacsModel::new(vec![peer("ORTHANC")], Some("/data".into()), Some("/session/outbox".into()))
}

fn series(modality: &str, images: Option<u64>) -> SeriesFound {
    SeriesFound {
        series_uid: format!("1.2.{modality}"),
        modality: modality.into(),
        description: String::new(),
        number: Some(1),
        images,
    }
}

fn study(uid: &str, date: &str, series: Vec<SeriesFound>) -> StudyFound {
    StudyFound {
        study_uid: uid.into(),
        study_date: date.into(),
        accession_number: "A1".into(),
        description: "CHEST".into(),
        modalities: series.iter().map(|s| s.modality.clone()).collect(),
        series,
        patient_name: "DOE JANE".into(),
        patient_id: "12345".into(),
    }
}

#[test]
fn opening_asks_for_todays_studies_and_lists_only_those_with_ct_or_mr() {
    let mut model = model();
    let Some(PacsJob::Find { peer, query }) = model.update(PacsIntent::Open, TODAY) else { panic!("a search") };
    assert_eq!(peer.ae_title, "ORTHANC");
    assert_eq!(query.since.as_deref(), Some(TODAY));
    assert!(model.busy());
    model.apply(PacsReport::Found(Ok(vec![
        study("1.1", "20261205", vec![series("CT", Some(40)), series("SR", Some(1))]),
        study("1.2", "20261206", vec![series("SR", Some(1))]),
        study("1.3", "20261206", vec![series("MR", None)]),
    ])));
    assert!(!model.busy());
    let rows = model.rows();
    assert_eq!(rows.len(), 2, "the report-only study is left out: {rows:?}");
    assert_eq!(rows[0].date, "2026-12-06", "newest first");
    assert_eq!(rows[1].detail, "CT · 1 series · 40 images");
    assert_eq!(rows[1].name, "DOE JANE");
    assert_eq!(model.message, "2 studies: tap one to retrieve it");
}

#[test]
fn the_keypad_types_a_search_by_patient_id_or_accession_number() {
    let mut model = model();
    assert!(model.update(PacsIntent::Search, TODAY).is_none(), "nothing typed: no search");
    for key in ["1", "2", "x", "3", "back", "??", "", "4"] {
        assert!(model.update(PacsIntent::Key(key.into()), TODAY).is_none());
    }
    assert_eq!(model.typed, "12X4");
    let Some(PacsJob::Find { query, .. }) = model.update(PacsIntent::Search, TODAY) else { panic!("a search") };
    assert_eq!(query.patient_id.as_deref(), Some("12X4"));
    assert_eq!((query.accession_number, query.since), (None, None), "a search spans every date");
    model.apply(PacsReport::Found(Ok(Vec::new())));
    assert_eq!(model.message, "No CT or MR study found");
    model.update(PacsIntent::Field(SearchField::Accession), TODAY);
    let Some(PacsJob::Find { query, .. }) = model.update(PacsIntent::Search, TODAY) else { panic!("a search") };
    assert_eq!((query.patient_id, query.accession_number.as_deref()), (None, Some("12X4")));
    model.apply(PacsReport::Found(Ok(Vec::new())));
    model.update(PacsIntent::Key("clear".into()), TODAY);
    assert_eq!(model.typed, "");
    for _ in 0..40 {
        model.update(PacsIntent::Key("9".into()), TODAY);
    }
    assert_eq!(model.typed.len(), MOST_TYPED);
}

#[test]
fn a_retrieval_shows_its_progress_and_hands_over_the_series_to_open() {
    let mut model = model();
    model.update(PacsIntent::Open, TODAY);
    let with_a_report = vec![series("CT", Some(30)), series("SR", Some(1)), series("MR", Some(10))];
    model.apply(PacsReport::Found(Ok(vec![study("1.1", TODAY, with_a_report)])));
    let Some(PacsJob::Get { study_uid, data_dir, series_uids, .. }) = model.update(PacsIntent::Retrieve(0), TODAY)
    else {
        panic!("a retrieval")
    };
    assert_eq!((study_uid.as_str(), data_dir.as_path()), ("1.1", std::path::Path::new("/data")));
    assert_eq!(series_uids, ["1.2.CT", "1.2.MR"], "its CT and MR series only");
    assert!(model.update(PacsIntent::Retrieve(0), TODAY).is_none(), "one retrieval at a time");
    assert!(model.update(PacsIntent::Today, TODAY).is_none(), "no search during a retrieval");
    model.apply(PacsReport::Stored(10));
    assert_eq!(model.progress(), Some(0.25));
    assert_eq!(model.message, "Retrieving: 10 of 40 images");
    model.apply(PacsReport::Retrieved(Ok(vec!["/data/CT-1".into()])));
    assert!(!model.busy());
    assert_eq!(model.retrieved, vec![PathBuf::from("/data/CT-1")]);
    assert_eq!(model.progress(), None);
}

#[test]
fn a_pacs_that_fails_is_said_on_screen_and_nothing_is_opened() {
    let mut model = model();
    model.update(PacsIntent::Open, TODAY);
    model.apply(PacsReport::Found(Err("cannot connect to ORTHANC@127.0.0.1:4242".into())));
    assert_eq!(model.message, "The PACS did not answer the search: cannot connect to ORTHANC@127.0.0.1:4242");
    assert!(model.rows().is_empty());
    model.update(PacsIntent::Open, TODAY);
    model.apply(PacsReport::Found(Ok(vec![study("1.1", TODAY, vec![series("CT", None)])])));
    model.update(PacsIntent::Retrieve(0), TODAY);
    model.apply(PacsReport::Retrieved(Err("the PACS refused the C-GET".into())));
    assert_eq!(model.message, "Not retrieved: the PACS refused the C-GET");
    assert!(model.retrieved.is_empty());
    assert!(model.update(PacsIntent::Retrieve(5), TODAY).is_none(), "a row that is not there");
}

#[test]
fn send_to_pacs_says_why_it_cannot_and_reports_only_what_the_pacs_answered() {
    let dicom = tempfile::tempdir().unwrap();
    let nrrd = dicom.path().join("scan.nrrd");
    std::fs::write(&nrrd, b"").unwrap();
    let from_dicom = VolumeSource::Path(dicom.path().to_path_buf());
    let mut model_without = PacsModel::new(Vec::new(), None, None);
    model_without.opened(&from_dicom);
    assert_eq!(model_without.send_blocked(true), Some("No PACS is configured"));
    let mut model = model();
    model.opened(&VolumeSource::Demo);
    assert_eq!(model.send_blocked(true), Some("Only a scan from DICOM can go back to the PACS"));
    model.opened(&VolumeSource::Path(nrrd));
    assert_eq!(model.send_blocked(true), Some("Only a scan from DICOM can go back to the PACS"));
    model.opened(&from_dicom);
    assert_eq!(model.send_blocked(false), Some("Classify first: draw two classes"));
    assert_eq!(model.send_blocked(true), None);
    let request = SendRequest {
        folder: dicom.path().to_path_buf(),
        series_uid: None,
        labels: Arc::new(vec![0, 1, 2]),
        segments: vec![
            Segment { label: "Class 1".into(), rgb: [1.0, 0.0, 0.0] },
            Segment { label: "Class 2".into(), rgb: [0.0, 1.0, 0.0] },
        ],
        picture: None,
    };
    let Some(PacsJob::Send { outbox, .. }) = model.update(PacsIntent::Send(request.clone()), TODAY) else {
        panic!("a send")
    };
    assert_eq!(outbox, PathBuf::from("/session/outbox"));
    assert_eq!(model.send_blocked(true), Some("Sending..."));
    assert!(model.update(PacsIntent::Send(request.clone()), TODAY).is_none(), "one send at a time");
    model.apply(PacsReport::Sent(Err("ORTHANC refused 1 of 2 objects: no space".into())));
    assert_eq!(model.send_message, "Not sent: ORTHANC refused 1 of 2 objects: no space");
    assert_eq!(model.send_blocked(true), None, "it can be sent again");
    // The next scan opened starts without the last one's answer.
    model.opened(&from_dicom);
    assert_eq!(model.send_message, "");
}

#[test]
fn without_a_pacs_nothing_starts() {
    let mut model = PacsModel::new(Vec::new(), Some("/data".into()), None);
    assert_eq!(model.peer_name(), "");
    for intent in [PacsIntent::Open, PacsIntent::Today, PacsIntent::Search, PacsIntent::Retrieve(0)] {
        assert!(model.update(intent, TODAY).is_none());
    }
}

#[test]
fn the_next_pacs_is_asked_for_its_own_studies() {
    let mut model = PacsModel::new(vec![peer("FIRST"), peer("SECOND")], Some("/data".into()), None);
    assert!(model.has_several_peers());
    model.update(PacsIntent::Open, TODAY);
    model.apply(PacsReport::Found(Ok(vec![study("1.1", TODAY, vec![series("CT", None)])])));
    let Some(PacsJob::Find { peer, .. }) = model.update(PacsIntent::NextPeer, TODAY) else { panic!("a search") };
    assert_eq!(peer.ae_title, "SECOND");
    assert!(model.rows().is_empty(), "the first PACS's studies are not shown as the second's");
    assert!(model.peer_name().starts_with("SECOND@"));
}

/// The model and a worker together, as the app runs them, with a fake PACS that answers on
/// the caller's thread.
#[test]
fn intents_jobs_and_reports_round_trip_through_a_worker() {
    let task: Task<PacsJob, PacsReport> =
        Arc::new(|job: PacsJob, _: &Ticket, report: &Report<'_, PacsReport>| match job {
            PacsJob::Find { query, .. } => {
                let found = if query.patient_id.as_deref() == Some("7") {
                    vec![study("7.1", TODAY, vec![series("CT", Some(2))])]
                } else {
                    Vec::new()
                };
                report(PacsReport::Found(Ok(found)))
            }
            PacsJob::Get { data_dir, .. } => {
                report(PacsReport::Stored(1));
                report(PacsReport::Stored(2));
                report(PacsReport::Retrieved(Ok(vec![data_dir.join("CT-7")])))
            }
            PacsJob::Send { .. } => report(PacsReport::Sent(Ok("Sent to ORTHANC: segmentation stored".into()))),
        });
    let mut worker = Inline::new(task);
    let mut model = model();
    let mut run = |model: &mut PacsModel, intent| {
        if let Some(job) = model.update(intent, TODAY) {
            worker.send(job);
        }
        while let Some(delivery) = worker.poll() {
            model.apply(delivery.output);
        }
    };
    run(&mut model, PacsIntent::Key("7".into()));
    run(&mut model, PacsIntent::Search);
    assert_eq!(model.rows().len(), 1);
    run(&mut model, PacsIntent::Retrieve(0));
    assert_eq!(model.retrieved, vec![PathBuf::from("/data/CT-7")]);
    assert!(!model.busy());
}
