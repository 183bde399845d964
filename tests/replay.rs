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

#[test]
fn the_workflow_on_a_real_256_cubed_volume() {
    let work = tempfile::tempdir().unwrap();
    let volume = support::data("engine_256x256x256_uint8.raw");
    let report = replay(
        &["replay", script("engine-workflow.touch").to_str().unwrap(), "--volume", volume.to_str().unwrap()],
        work.path(),
    );
    assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{report}");
    assert!(report["frames_while_classifying"]["count"].as_u64().unwrap_or(0) > 0, "{report}");
}

/// 10,000 random type-B events in 60 s with up to 10 fingers, off-screen positions, garbage
/// codes and SYN_DROPPED in the middle of gestures, then a script that needs a working UI.
#[test]
fn a_touch_storm_leaves_the_ui_answering_with_bounded_memory() {
    use volasso::touch::event::*;
    let work = tempfile::tempdir().unwrap();
    let device = DeviceInfo::virtual_touchscreen();
    let mut text = volasso::touch::format::EventsText::new(&device);
    let mut random = volasso::rng::SplitMix64::new(2026);
    let mut time_us = 0u64;
    let mut tracking = [None::<i32>; 10];
    let mut next_id = 1;
    let mut events = 0;
    while events < 10_000 {
        time_us += 60_000_000 / 10_000;
        let slot = random.below(10) as usize;
        let mut frame = vec![RawEvent::new(time_us, EV_ABS, ABS_MT_SLOT, slot as i32)];
        match random.below(20) {
            0 => frame = vec![RawEvent::new(time_us, EV_SYN, SYN_DROPPED, 0)],
            // Codes the tracker does not use, with any value.
            1 => {
                frame.push(RawEvent::new(time_us, EV_ABS, random.below(0x40) as u16, random.below(1 << 20) as i32 - 5))
            }
            2..=5 => {
                let id = if tracking[slot].is_some() { -1 } else { next_id };
                tracking[slot] = (id >= 0).then_some(id);
                next_id += 1;
                frame.push(RawEvent::new(time_us, EV_ABS, ABS_MT_TRACKING_ID, id));
            }
            _ => {
                // Positions a little beyond the axes too: the panel's edge, or a lying device.
                let x = random.below(36_000) as i32 - 1_500;
                let y = random.below(36_000) as i32 - 1_500;
                frame.push(RawEvent::new(time_us, EV_ABS, ABS_MT_POSITION_X, x));
                frame.push(RawEvent::new(time_us, EV_ABS, ABS_MT_POSITION_Y, y));
            }
        }
        frame.push(RawEvent::new(time_us, EV_SYN, SYN_REPORT, 0));
        for event in &frame {
            text.event(event);
        }
        events += frame.len();
    }
    let storm = work.path().join("storm.events");
    std::fs::write(&storm, text.finish()).unwrap();
    let report =
        replay(&["replay", storm.to_str().unwrap(), script("after-abuse.touch").to_str().unwrap()], work.path());
    assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{report}");
    assert!(report["events"].as_u64().unwrap_or(0) >= 10_000, "{report}");
    let peak_mb = report["peak_resident_mb"].as_f64().unwrap_or(f64::INFINITY);
    assert!(peak_mb < 1500.0, "peak resident memory {peak_mb} MB: {report}");
    eprintln!("touch storm: {report}");
}

/// A recording whose clock jumps by 10^10 s (a lying or corrupt timestamp) is refused at once
/// with the line and the jump, instead of being replayed frame by frame for days.
#[test]
fn a_recording_with_an_absurd_time_jump_is_refused_at_once() {
    let work = tempfile::tempdir().unwrap();
    let recording = work.path().join("jump.events");
    std::fs::write(
        &recording,
        "volasso-events/1\nx: 0 32767\ny: 0 32767\n0.000000 EV_ABS ABS_X 100\n0.000000 EV_SYN SYN_REPORT 0\n10000000000.000000 EV_ABS ABS_X 200\n10000000000.000000 EV_SYN SYN_REPORT 0\n",
    )
    .unwrap();
    let started = std::time::Instant::now();
    let output = support::volasso(&["replay", recording.to_str().unwrap()], &work.path().join("cache"));
    support::assert_clean_error(
        &output,
        "line 6: the event at 10000000000.000000 s comes 10000000000.000000 s after",
        "jump",
    );
    assert!(started.elapsed().as_secs() < 60, "took {:?}", started.elapsed());
}
