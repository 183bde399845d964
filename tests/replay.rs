//! The UI driven by touch alone (issues 6 and 7): `volasso replay` runs the real UI headless
//! (Slint's software renderer, the 3-D view on lavapipe or a GPU) from the scripts in
//! `tests/replay/`, and fails on any broken expectation. What each script proves is in its
//! header comment.

use crate::support;
use std::path::{Path, PathBuf};

fn script(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/replay").join(name)
}

/// Runs `volasso replay` and returns its JSON line; panics with its stderr on failure.
fn replay(args: &[&str], work: &Path) -> serde_json::Value {
    let output = support::volasso(args, &work.join("cache"));
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "replay {args:?} failed:\n{stderr}\n{stdout}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let line = stdout.lines().last().unwrap_or_default();
    serde_json::from_str(line).unwrap_or_else(|error| panic!("not a JSON line ({error}): {stdout}"))
}

#[test]
fn the_whole_workflow_on_the_demo_volume_by_touch() {
    let work = tempfile::tempdir().unwrap();
    let shots = work.path().join("shots");
    let session = work.path().join("session");
    let report = replay(
        &[
            "replay",
            script("demo-workflow.touch").to_str().unwrap(),
            "--screenshots",
            shots.to_str().unwrap(),
            "--session-dir",
            session.to_str().unwrap(),
        ],
        work.path(),
    );
    assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{report}");
    assert!(shots.join("two-classes.png").exists());
    // The idle timeout at the end cleared the autosaved session.
    assert!(!session.join("session.json").exists());
}
