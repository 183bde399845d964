//! The gallery and attract mode driven by touch: a kept result reopens as it was saved,
//! damaged entries say so on their cards, and the idle start screen turns the demo or the
//! newest kept result.

use crate::replay::{replay, script};
use crate::replay_sessions::{session_file, session_files};
use std::path::{Path, PathBuf};

/// The size the gallery and attract tests run at here; `.ci/replay-sizes` runs their scripts
/// at `THREE_SIZES` (replay.rs).
const PANEL_SIZES: [&str; 1] = ["1280x800"];

/// `volasso replay SCRIPT --data-dir DATA --size SIZE` in `work`: the report.
fn replay_on_data(script_name: &str, data: &Path, size: &str, work: &Path) -> serde_json::Value {
    replay(
        &["replay", script(script_name).to_str().unwrap(), "--data-dir", data.to_str().unwrap(), "--size", size],
        work,
    )
}

/// "Save" keeps the result in the data folder's gallery (one folder: the entry and its
/// thumbnail); its card in the chooser restores the same classes, visibility, labels, camera
/// and 3-D pixels (`gallery-save-open.touch`).
#[test]
fn a_kept_result_opens_from_the_gallery_as_it_was_saved() {
    for size in PANEL_SIZES {
        let work = tempfile::tempdir().unwrap();
        let data = work.path().join("data");
        std::fs::create_dir_all(&data).unwrap();
        let report = replay_on_data("gallery-save-open.touch", &data, size, work.path());
        assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{size}: {report}");
        let entries: Vec<PathBuf> =
            std::fs::read_dir(data.join("gallery")).unwrap().map(|e| e.unwrap().path()).collect();
        assert_eq!(entries.len(), 1, "{entries:?}");
        assert_eq!(session_files(&entries[0]), ["entry.json", "thumbnail.png"]);
        let entry: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(entries[0].join("entry.json")).unwrap()).unwrap();
        assert_eq!(entry["format"], "volasso-gallery/1");
        assert_eq!(entry["session"]["format"], "volasso-session/1");
        assert_eq!(entry["visible"], serde_json::json!([false, true]));
    }
}

/// The gallery of `gallery-problems.touch` under `work/data`: an entry whose scan is gone, one
/// without its entry file and one cut short.
pub(crate) fn write_gallery_problems(work: &Path) {
    let gallery = work.join("data/gallery");
    let entry = serde_json::json!({
        "format": "volasso-gallery/1",
        "saved_unix": 300,
        "volume_name": "gone.nrrd",
        "camera": {"azimuth_degrees": 10.0, "elevation_degrees": 5.0, "zoom": 1.0, "pan_mm": [0.0, 0.0]},
        "visible": [true],
        "session": serde_json::from_str::<serde_json::Value>(&session_file(&work.join("data/gone.nrrd"))).unwrap(),
    });
    let text = serde_json::to_string_pretty(&entry).unwrap();
    for (folder, file, bytes) in [
        ("result-300", "entry.json", text.as_bytes()),
        ("result-200", "thumbnail.png", b"\x89PNG".as_slice()),
        ("result-100", "entry.json", &text.as_bytes()[..60]),
    ] {
        std::fs::create_dir_all(gallery.join(folder)).unwrap();
        std::fs::write(gallery.join(folder).join(file), bytes).unwrap();
    }
}

/// Kept results that cannot be opened: one whose scan is gone says so plainly, one never
/// finished and one cut short say why, none opens, and the chooser still opens a volume
/// (`gallery-problems.touch`).
#[test]
fn damaged_gallery_entries_and_missing_scans_say_so_on_their_cards() {
    for size in PANEL_SIZES {
        let work = tempfile::tempdir().unwrap();
        write_gallery_problems(work.path());
        let data = work.path().join("data");
        let report = replay_on_data("gallery-problems.touch", &data, size, work.path());
        assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{size}: {report}");
    }
}

/// After the idle timeout the start screen plays a turntable of the demo (an empty gallery):
/// its pixels change as it turns, and a touch starts (`attract-demo.touch`). Both turntable
/// replays wait out two minutes of idle time and render a turn: they run with every script at
/// three sizes (`.ci/replay-sizes`); `cargo test` tests the attract model without a window
/// (`attract/tests.rs`).
#[test]
#[ignore = "slow: .ci/replay-sizes runs attract-demo.touch at three panel sizes"]
fn the_idle_start_screen_turns_the_demo_until_touched() {
    for size in PANEL_SIZES {
        let work = tempfile::tempdir().unwrap();
        let report = replay(&["replay", script("attract-demo.touch").to_str().unwrap(), "--size", size], work.path());
        assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{size}: {report}");
    }
}

/// With a kept result the turntable shows the newest one (`attract-gallery.touch`).
#[test]
#[ignore = "slow: .ci/replay-sizes runs attract-gallery.touch at three panel sizes"]
fn the_idle_start_screen_turns_the_newest_kept_result() {
    let work = tempfile::tempdir().unwrap();
    let data = work.path().join("data");
    std::fs::create_dir_all(&data).unwrap();
    let report = replay(
        &["replay", script("attract-gallery.touch").to_str().unwrap(), "--data-dir", data.to_str().unwrap()],
        work.path(),
    );
    assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{report}");
}
