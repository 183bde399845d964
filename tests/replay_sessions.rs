//! Replays about what the app keeps and refuses across starts: hostile files in the data
//! folder, saved sessions on volumes that fail or stop the app, a restore that classifies.

use crate::replay::{replay, replay_allowing_caught_panics, script};
use std::path::{Path, PathBuf};

/// Writes the hostile files of `hostile-files.touch` into `folder`: each is a few hundred bytes
/// that lie about what they hold.
pub(crate) fn write_hostile_files(folder: &Path) {
    use std::io::Write;
    std::fs::create_dir_all(folder).unwrap();
    let mut bomb = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    bomb.write_all(&[0u8; 4096]).unwrap();
    let huge = [
        b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 1000000 1000000 1000\nencoding: gzip\n\n".as_slice(),
        &bomb.finish().unwrap(),
    ]
    .concat();
    let files: [(&str, Vec<u8>); 5] = [
        ("huge.nrrd", huge),
        (
            "skip.nrrd",
            b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nbyte skip: 18446744073709551615\n\n\x01\x01\x01\x01\x01\x01\x01\x01"
                .to_vec(),
        ),
        ("truncated_64x64x64_uint8.raw", vec![7u8; 1000]),
        ("garbage.dcm", (0..10_240u32).map(|i| (i * 7919 % 251) as u8).collect()),
        ("empty.nii", Vec::new()),
    ];
    for (name, bytes) in files {
        std::fs::write(folder.join(name), bytes).unwrap();
    }
}

fn assert_replayed(output: &std::process::Output, report: &Option<serde_json::Value>) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "replay failed ({:?}):\n{stderr}", output.status);
    let report = report.as_ref().expect("a JSON line");
    assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{report}\n{stderr}");
}

/// Hostile files in the data folder (a gzip bomb, an overflowing byte skip, a truncated raw,
/// garbage named .dcm, an empty .nii): the chooser shows each as a "cannot open" card, the UI
/// never waits on one, and the demo opens (`hostile-files.touch`).
#[test]
fn hostile_files_in_the_data_folder_become_cannot_open_cards() {
    let work = tempfile::tempdir().unwrap();
    let data = work.path().join("data");
    write_hostile_files(&data);
    let (output, report) = replay_allowing_caught_panics(
        &["replay", script("hostile-files.touch").to_str().unwrap(), "--data-dir", data.to_str().unwrap()],
        work.path(),
    );
    assert_replayed(&output, &report);
}

pub(crate) fn session_file(volume: &Path) -> String {
    serde_json::json!({
        "format": "volasso-session/1",
        "volume": volume.to_str().unwrap(),
        "template": "",
        "rotation_degrees": 0.0,
        "strokes": {"format": "volasso-strokes/1", "classes": [
            {"name": "Class 1", "strokes": [{"axis": "z", "slice": 0, "points": [[0, 0], [1, 0], [1, 1]]}]}
        ]},
    })
    .to_string()
}

/// A data folder of hostile files and a session folder whose saved session is on the one named
/// `volume`; the arguments that replay `restore-set-aside.touch` with them.
pub(crate) fn saved_session_on(work: &Path, volume: &str) -> (Vec<String>, PathBuf) {
    let (data, sessions) = (work.join("data"), work.join("sessions"));
    write_hostile_files(&data);
    std::fs::create_dir_all(&sessions).unwrap();
    std::fs::write(sessions.join("session.json"), session_file(&data.join(volume))).unwrap();
    let restore = script("restore-set-aside.touch").display().to_string();
    (vec!["replay".into(), restore, "--session-dir".into(), sessions.display().to_string()], sessions)
}

/// The files of a session folder, sorted.
pub(crate) fn session_files(folder: &Path) -> Vec<String> {
    let mut names: Vec<String> =
        std::fs::read_dir(folder).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

/// A saved session whose volume makes its reader fail is not restored: the start screen shows
/// a banner, and the session file is kept aside (renamed, with the lassos in it), so the next
/// start is an ordinary one.
#[test]
fn a_saved_session_on_a_hostile_volume_is_set_aside_with_a_banner() {
    let work = tempfile::tempdir().unwrap();
    let (args, sessions) = saved_session_on(work.path(), "skip.nrrd");
    let (output, report) = replay_allowing_caught_panics(&args, work.path());
    assert_replayed(&output, &report);
    let files = session_files(&sessions);
    assert_eq!(files.len(), 1, "{files:?}");
    assert!(files[0].starts_with("session-failed-"), "{files:?}");
    assert!(std::fs::read_to_string(sessions.join(&files[0])).unwrap().contains("Class 1"));
}

/// A saved session whose volume stops the whole app while it is restored (the gzip bomb, as
/// long as a reader allocates what a header claims) never becomes a restart loop: the next
/// start finds the restore marker, sets the session aside and shows the banner.
#[test]
fn a_restore_that_stops_the_app_is_not_tried_again() {
    let work = tempfile::tempdir().unwrap();
    let (args, sessions) = saved_session_on(work.path(), "huge.nrrd");
    let (first, report) = replay_allowing_caught_panics(&args, work.path());
    if first.status.success() {
        // The reader refused the file with an error: set aside at once.
        assert_replayed(&first, &report);
    } else {
        // The app stopped during the restore; the marker says so at the next start.
        assert!(session_files(&sessions).contains(&"session.restoring".to_string()));
        let (second, report) = replay_allowing_caught_panics(&args, work.path());
        assert_replayed(&second, &report);
    }
    let files = session_files(&sessions);
    assert_eq!(files.len(), 1, "{files:?}");
    assert!(files[0].starts_with("session-failed-"), "{files:?}");
}

/// A saved session that opens and classifies is restored, and its restore marker goes: a later
/// stop of the app is not blamed on the restore.
#[test]
fn a_restored_session_that_classifies_clears_its_restore_marker() {
    let work = tempfile::tempdir().unwrap();
    let sessions = work.path().join("sessions");
    std::fs::create_dir_all(&sessions).unwrap();
    let strokes: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/benches/strokes/demo-foot.strokes.json"))
            .unwrap(),
    )
    .unwrap();
    let session = serde_json::json!({
        "format": "volasso-session/1", "volume": "demo", "template": "", "rotation_degrees": 0.0, "strokes": strokes,
    });
    std::fs::write(sessions.join("session.json"), session.to_string()).unwrap();
    let restore = work.path().join("restore.touch");
    std::fs::write(
        &restore,
        "wait-idle\nexpect screen work\nexpect classes 2\nexpect classified 2\nexpect banner \"\"\n",
    )
    .unwrap();
    let report =
        replay(&["replay", restore.to_str().unwrap(), "--session-dir", sessions.to_str().unwrap()], work.path());
    assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{report}");
    assert_eq!(session_files(&sessions), ["session.json"]);
}
