//! The hospital round trip driven by touch: `volasso replay --pacs` against Orthanc started on
//! loopback (tests/pacs.rs's [`Orthanc`]) with the Philips phantom. The chooser's PACS list finds
//! the study on the keypad, retrieves and opens it, two loops classify it and "Send to PACS"
//! stores a Segmentation and a Secondary Capture that Orthanc then lists in the study; a PACS
//! that is down is said on screen. Without Orthanc or dcmtk the tests say so and are skipped.

use crate::dicom_codecs::dcmtk_available;
use crate::dicom_export::philips;
use crate::pacs::{Orthanc, free_port};
use crate::replay::{replay, script};

/// The sizes the round trip's screenshots are taken at: the 10-inch and the 7-inch panel.
const PANEL_SIZES: [&str; 2] = ["1280x800", "1024x600"];

#[test]
fn a_study_found_on_the_keypad_is_retrieved_classified_and_sent_back_by_touch() {
    if !dcmtk_available() {
        return;
    }
    let Some(orthanc) = Orthanc::start(None) else { return };
    orthanc.load_philips();
    // The second run finds the study holding the first run's results: only its CT series is
    // retrieved (a PACS's studies hold reports and earlier results the kiosk does not store).
    for (run, size) in PANEL_SIZES.into_iter().enumerate() {
        let work = tempfile::tempdir().unwrap();
        let (data, session, shots) = (work.path().join("data"), work.path().join("session"), work.path().join("shots"));
        std::fs::create_dir_all(&data).unwrap();
        let report = replay(
            &[
                "replay",
                script("pacs-round-trip.touch").to_str().unwrap(),
                "--pacs",
                &orthanc.address(),
                "--data-dir",
                data.to_str().unwrap(),
                "--session-dir",
                session.to_str().unwrap(),
                "--screenshots",
                shots.to_str().unwrap(),
                "--size",
                size,
            ],
            work.path(),
        );
        assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{size}: {report}\n{}", orthanc.log());
        // The study now holds the scan, the Segmentation and the Secondary Capture.
        let series = orthanc.series();
        let mut modalities: Vec<&str> = series.iter().map(|(_, _, modality)| modality.as_str()).collect();
        modalities.sort();
        let expected = [vec!["CT", "OT", "SEG"], vec!["CT", "OT", "OT", "SEG", "SEG"]];
        assert_eq!(modalities, expected[run], "{size}: {series:?}");
        assert!(series.iter().all(|(study, _, _)| *study == series[0].0), "one study: {series:?}");
        // Nothing written for sending is left behind.
        let outbox = session.join("outbox");
        let left = std::fs::read_dir(&outbox).map_or(0, |entries| entries.count());
        assert_eq!(left, 0, "{} holds what was sent", outbox.display());
        for shot in ["pacs-list.png", "pacs-sent.png"] {
            assert!(shots.join(shot).exists(), "{size}: {shot}");
        }
        // The audit log: retrieved, opened, sent; the series by its hash.
        let audit = volasso::appliance::audit::AuditLog::new(&data).entries(0).unwrap();
        let events: Vec<String> = audit.iter().map(|entry| format!("{:?}", entry.event)).collect();
        assert_eq!(events, ["SeriesRetrieved", "ScanOpened", "ResultSent"], "{size}: {audit:?}");
        assert!(audit.iter().all(|entry| entry.series == audit[0].series && entry.series.is_some()), "{audit:?}");
    }
}

#[test]
fn a_pacs_that_is_down_is_said_on_screen_and_a_scan_not_from_dicom_cannot_be_sent() {
    let work = tempfile::tempdir().unwrap();
    let data = work.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    let nobody = format!("ORTHANC@127.0.0.1:{}", free_port());
    let report = replay(
        &[
            "replay",
            script("pacs-down.touch").to_str().unwrap(),
            "--pacs",
            &nobody,
            "--data-dir",
            data.to_str().unwrap(),
        ],
        work.path(),
    );
    assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{report}");
}

#[test]
fn a_pacs_that_fails_a_store_is_said_on_screen_and_the_result_is_not_reported_sent() {
    if !dcmtk_available() {
        return;
    }
    // Orthanc fails every Secondary Capture (modality OT) it is sent.
    let lua = "function ReceivedInstanceFilter(dicom, origin, info)\n  if dicom.Modality == 'OT' then\n    \
               error('this PACS takes no Secondary Capture')\n  end\n  return true\nend\n";
    let Some(orthanc) = Orthanc::start(Some(lua)) else { return };
    let work = tempfile::tempdir().unwrap();
    let session = work.path().join("session");
    let report = replay(
        &[
            "replay",
            script("pacs-store-refused.touch").to_str().unwrap(),
            "--volume",
            philips().to_str().unwrap(),
            "--pacs",
            &orthanc.address(),
            "--session-dir",
            session.to_str().unwrap(),
        ],
        work.path(),
    );
    assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{report}\n{}", orthanc.log());
    // The Segmentation went in before the picture failed; what was written is gone.
    let modalities: Vec<String> = orthanc.series().into_iter().map(|(_, _, modality)| modality).collect();
    assert_eq!(modalities, ["SEG"], "{}", orthanc.log());
    assert_eq!(std::fs::read_dir(session.join("outbox")).map_or(0, |entries| entries.count()), 0);
}
