//! The UI driven by touch alone: `volasso replay` runs the real UI headless
//! (Slint's software renderer, the 3-D view on lavapipe or a GPU) from the scripts in
//! `tests/replay/`, and fails on any broken expectation. What each script proves is in its
//! header comment.

use crate::replay_sessions::{saved_session_on, write_hostile_files};
use crate::support;
use std::path::{Path, PathBuf};

pub(crate) fn script(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/replay").join(name)
}

/// Runs `volasso replay` and returns its JSON line; panics with its stderr on failure.
pub(crate) fn replay(args: &[&str], work: &Path) -> serde_json::Value {
    let output = support::volasso(args, &work.join("cache"));
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "replay {args:?} failed:\n{stderr}\n{stdout}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let line = stdout.lines().last().unwrap_or_default();
    serde_json::from_str(line).unwrap_or_else(|error| panic!("not a JSON line ({error}): {stdout}"))
}

/// Runs `volasso replay` and returns its output and JSON line (if it printed one); unlike
/// [`replay`], panics caught inside the app (a reader's, logged) are allowed.
pub(crate) fn replay_allowing_caught_panics(
    args: &[impl AsRef<str>],
    work: &Path,
) -> (std::process::Output, Option<serde_json::Value>) {
    let args: Vec<&str> = args.iter().map(AsRef::as_ref).collect();
    let output = support::volasso(&args, &work.join("cache"));
    let stdout = String::from_utf8_lossy(&output.stdout);
    let report = stdout.lines().last().and_then(|line| serde_json::from_str(line).ok());
    (output, report)
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
    // Every change was autosaved on the writer thread: the UI thread never waited for the disk.
    assert_eq!(report["ui_thread_syncs"].as_u64(), Some(0), "{report}");
    // The idle timeout at the end cleared the autosaved session.
    assert!(!session.join("session.json").exists());
}

/// The workflow on the engine 256³ with an idle timeout of one second of script time, far
/// shorter than its classification and 3-D view take: the timeout waits for the work the user
/// is waiting for, and the session and its result stay.
#[test]
fn the_workflow_on_a_real_256_cubed_volume() {
    let work = tempfile::tempdir().unwrap();
    let volume = support::data("engine_256x256x256_uint8.raw");
    let script = script("engine-workflow.touch");
    let report = replay(
        &["replay", script.to_str().unwrap(), "--volume", volume.to_str().unwrap(), "--idle-timeout", "1"],
        work.path(),
    );
    assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{report}");
    assert!(report["frames_while_classifying"]["count"].as_u64().unwrap_or(0) > 0, "{report}");
}

/// Runs `script` on `volume` (under ../shared/data) at each of `sizes` and asserts that every
/// expectation held.
fn replay_on(script_name: &str, volume: &str, sizes: &[&str]) {
    let volume = support::data(volume);
    for size in sizes {
        let work = tempfile::tempdir().unwrap();
        let report = replay(
            &["replay", script(script_name).to_str().unwrap(), "--volume", volume.to_str().unwrap(), "--size", size],
            work.path(),
        );
        assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{size}: {report}");
    }
}

/// Slices as a radiologist expects them, the patient's directions read off the screen at the
/// panels' edges, on the NIfTI brain (stored with y toward anterior, so its panels are
/// flipped), at two screen sizes (`orientation.touch`; the GE head CT runs it at every panel
/// size in [`every_script_passes_at_three_panel_sizes`]).
#[test]
fn slices_show_the_patient_in_the_radiological_convention_with_edge_letters() {
    replay_on("orientation.touch", "anatomical.nii", &["1280x800", "1024x600"]);
}

/// The panel sizes every script runs at: the reference 10-inch panel, a 7-inch bedside-arm
/// panel, and a 10-inch panel in portrait.
const THREE_SIZES: [&str; 3] = ["1280x800", "1024x600", "800x1280"];

/// The arguments `script` needs beyond `--size`: its volume, or the files it is about, written
/// into `work`. What each script proves is in its header comment:
/// * `flat-band.touch`: a flat band around the skull's lower edge becomes a class, a quick
///   sideways stroke still changes the slice, and display windows never reach the classifier;
/// * `enlarge-loop.touch`: an enlarged, zoomed slice takes a loop around a small structure;
/// * `cranium-skull-lasso.touch`, `vismale-scalp-lasso.touch`: loops that take in air leave the
///   air background, on a 16-bit clinical CT and on the 8-bit Visible Male head;
/// * `cranium-finger-loops.touch`: loops run on past their start or started inside, on the CT;
/// * `chest-lung-lasso.touch`: a loop in a lung as black as the air, on a windowed chest CT
///   phantom whose lungs leave through its top face (written into `work`);
/// * `orientation.touch`: the patient's directions at the panels' edges (the GE head CT);
/// * `panels.touch`: every screen's controls whole, apart and 9 mm wide;
/// * `series-picker.touch`: a folder of two DICOM series gives each a card that opens it;
/// * `presets.touch`: a preset saved on the demo colours it again from the chooser, takes a new
///   loop, and colours the Philips head CT from the work screen (a data folder with a link to it);
/// * `gallery-*.touch`, `attract-gallery.touch`: kept results in a data folder of their own;
/// * `clip.touch`, `opacity.touch` (then `opacity-restored.touch` on its session),
///   `snapshot.touch`: the 3-D view's tools on the demo volume;
/// * `unsure.touch`: where the classifier is unsure, and "Draw here next", on the demo volume;
/// * `classification-fails.touch`: a float CT with a column of NaN voxels (`hostile_cli`);
/// * `finger-loops.touch`: a loop run on past its start and one with a tail, on the demo volume;
/// * `shaky-finger.touch`: the same loops drawn by a slow, shaking fingertip, on the demo volume;
/// * the others run on the demo volume from the start screen.
fn script_arguments(script: &str, work: &Path) -> Vec<String> {
    let volume = |name: &str| vec!["--volume".to_string(), support::data(name).display().to_string()];
    let volume_demo = || vec!["--volume".to_string(), "demo".to_string()];
    match script {
        "flat-band.touch" | "orientation.touch" => volume("dicom/ge_head_tilt"),
        "enlarge-loop.touch" | "cranium-skull-lasso.touch" | "cranium-finger-loops.touch" => {
            volume("cranium_ct_256x256x108_int16.raw")
        }
        "vismale-scalp-lasso.touch" => volume("vismale_128x256x256_uint8.raw"),
        "chest-lung-lasso.touch" => {
            std::fs::create_dir_all(work).unwrap();
            let chest = work.join("chest.nrrd");
            let phantom = volasso::phantom::bodies::chest_ct_windowed([128, 100, 64], 1).unwrap();
            support::write_u8_nrrd(&chest, &phantom.volume);
            vec!["--volume".to_string(), chest.display().to_string()]
        }
        "engine-workflow.touch" => volume("engine_256x256x256_uint8.raw"),
        "hostile-files.touch" => {
            let data = work.join("data");
            write_hostile_files(&data);
            vec!["--data-dir".into(), data.display().to_string()]
        }
        "restore-set-aside.touch" => saved_session_on(work, "skip.nrrd").0.split_off(2),
        "clip.touch" | "unsure.touch" | "finger-loops.touch" | "shaky-finger.touch" | "nested-loops.touch" => {
            volume_demo()
        }
        "opacity.touch" => {
            let sessions = work.join("sessions");
            [volume_demo(), vec!["--session-dir".into(), sessions.display().to_string()]].concat()
        }
        "opacity-restored.touch" => {
            // The session opacity.touch leaves, restored at the next start.
            let sessions = work.join("sessions");
            let report = replay(
                &[
                    "replay",
                    self::script("opacity.touch").to_str().unwrap(),
                    "--volume",
                    "demo",
                    "--session-dir",
                    sessions.to_str().unwrap(),
                ],
                work,
            );
            assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "opacity.touch: {report}");
            vec!["--session-dir".into(), sessions.display().to_string()]
        }
        "snapshot.touch" => {
            let data = work.join("data");
            std::fs::create_dir_all(&data).unwrap();
            [volume_demo(), vec!["--data-dir".into(), data.display().to_string()]].concat()
        }
        "gallery-save-open.touch" | "attract-gallery.touch" => {
            let data = work.join("data");
            std::fs::create_dir_all(&data).unwrap();
            vec!["--data-dir".into(), data.display().to_string()]
        }
        "gallery-problems.touch" => {
            crate::replay_gallery::write_gallery_problems(work);
            vec!["--data-dir".into(), work.join("data").display().to_string()]
        }
        "classification-fails.touch" => {
            std::fs::create_dir_all(work).unwrap();
            let volume = work.join("nan-column.nrrd");
            crate::hostile_cli::write_nan_column(&volume);
            vec!["--volume".into(), volume.display().to_string()]
        }
        "presets.touch" => {
            let data = work.join("data");
            std::fs::create_dir_all(&data).unwrap();
            std::os::unix::fs::symlink(support::data("dicom/philips_phantom_5mm"), data.join("philips")).unwrap();
            vec!["--data-dir".into(), data.display().to_string()]
        }
        "series-picker.touch" => {
            let study = work.join("data/study");
            std::fs::create_dir_all(&study).unwrap();
            for series in ["philips_phantom_5mm", "ge_head_tilt"] {
                std::os::unix::fs::symlink(support::data(&format!("dicom/{series}")), study.join(series)).unwrap();
            }
            vec!["--data-dir".into(), work.join("data").display().to_string()]
        }
        _ => Vec::new(),
    }
}

/// Runs `volasso replay` once per argument list, a few at a time (each is one process; the
/// classifier inside uses every core, so more at once would only queue), and returns the
/// failures: the arguments with the report or the error.
fn replay_all(runs: Vec<Vec<String>>) -> Vec<String> {
    let workers = std::thread::available_parallelism().map_or(2, |n| n.get()).clamp(2, 4);
    let queue = std::sync::Mutex::new(runs);
    let failures = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                while let Some(args) = queue.lock().unwrap().pop() {
                    let work = tempfile::tempdir().unwrap();
                    let arguments: Vec<&str> = args.iter().map(String::as_str).collect();
                    let (output, report) = replay_allowing_caught_panics(&arguments, work.path());
                    let passed = output.status.success()
                        && report.as_ref().is_some_and(|r| r["failures"].as_array().is_some_and(Vec::is_empty));
                    if !passed {
                        let stderr = String::from_utf8_lossy(&output.stderr);
                        let tail: String = stderr.lines().rev().take(8).collect::<Vec<_>>().join(" | ");
                        failures.lock().unwrap().push(format!("{args:?}: {report:?} {tail}"));
                    }
                }
            });
        }
    });
    failures.into_inner().unwrap()
}

/// Every script in tests/replay/ passes at the reference panel size: the scripts name what
/// they touch by accessible label and give points as fractions of an element, so they do not
/// depend on where the layout puts things. A new script runs here without being listed; one
/// that needs a volume or files says so in [`script_arguments`].
#[test]
fn every_script_passes_at_the_reference_panel_size() {
    every_script_passes_at(&THREE_SIZES[..1]);
}

/// Scripts whose own tests run them at the reference size (with the same files, or more checks
/// of what they leave): [`every_script_passes_at_the_reference_panel_size`] does not run them a
/// second time.
const WITH_OWN_TESTS: [&str; 15] = [
    "pacs-round-trip.touch",
    "pacs-store-refused.touch",
    "pacs-down.touch",
    "gallery-save-open.touch",
    "gallery-problems.touch",
    "attract-gallery.touch",
    "attract-demo.touch",
    "demo-workflow.touch",
    "engine-workflow.touch",
    "panels.touch",
    "after-abuse.touch",
    "hostile-files.touch",
    "restore-set-aside.touch",
    "classification-fails.touch",
    "twelve-classes.touch",
];

/// Every script in tests/replay/ passes at each of [`THREE_SIZES`]. It runs every script three
/// times, minutes on a slow 2-core machine, so it is a check of its own (`.ci/replay-sizes`);
/// `every_screen_fits_every_panel_size_with_9_mm_targets` checks every screen's layout at
/// every size in each `cargo test`.
#[test]
#[ignore = "slow: every replay script at three panel sizes; .ci/replay-sizes runs it"]
fn every_script_passes_at_three_panel_sizes() {
    every_script_passes_at(&THREE_SIZES);
}

fn every_script_passes_at(sizes: &[&str]) {
    let folder = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/replay");
    let mut scripts: Vec<String> = std::fs::read_dir(&folder)
        .unwrap()
        .map(|entry| entry.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".touch"))
        .collect();
    scripts.sort();
    assert!(scripts.len() >= 11, "{scripts:?}");
    let fixtures = tempfile::tempdir().unwrap();
    let mut runs = Vec::new();
    for (index, name) in scripts.iter().enumerate() {
        if sizes.len() == 1 && WITH_OWN_TESTS.contains(&name.as_str()) {
            continue;
        }
        // The PACS scripts need a PACS running: replay_pacs.rs starts Orthanc for each.
        if name.starts_with("pacs-") {
            continue;
        }
        for size in sizes {
            // Each run gets its own copy of the files its script is about.
            let work = fixtures.path().join(format!("{index}-{size}"));
            let mut args =
                vec!["replay".to_string(), script(name).display().to_string(), "--size".into(), size.to_string()];
            args.extend(script_arguments(name, &work));
            runs.push(args);
        }
    }
    let started = std::time::Instant::now();
    let count = runs.len();
    let failures = replay_all(runs);
    eprintln!("{count} replays at {sizes:?} in {:.1} s", started.elapsed().as_secs_f64());
    assert!(failures.is_empty(), "{} of {count} failed:\n{}", failures.len(), failures.join("\n"));
}

/// Every screen fits the 7-inch panel and the 10-inch one in portrait in German too (longer
/// words): `panels.touch` with the settings' language German (`.ci/replay-sizes`).
#[test]
#[ignore = "slow: .ci/replay-sizes runs it"]
fn every_screen_fits_in_german_with_9_mm_targets() {
    let data = tempfile::tempdir().unwrap();
    let mut settings = volasso::appliance::settings::Settings::default();
    settings.set("language", "de").unwrap();
    volasso::appliance::settings::write(data.path(), &settings).unwrap();
    let runs = [("1024x600", "170"), ("800x1280", "150")]
        .iter()
        .map(|(size, dpi)| {
            let panels = script("panels.touch").display().to_string();
            let data = data.path().display().to_string();
            ["replay", &panels, "--size", size, "--dpi", dpi, "--data-dir", &data].map(String::from).to_vec()
        })
        .collect();
    let failures = replay_all(runs);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Every screen fits every panel (`panels.touch`: controls whole, apart and at least 9 mm on
/// each side) at the five panel sizes the kiosk meets, each at the density of a real panel of
/// that size: a 24-inch 1080p monitor, a 10.1-inch 1280x800 panel, a 7-inch 1024x600 panel, a
/// 7-inch 800x480 panel, and the 10.1-inch panel in portrait.
#[test]
fn every_screen_fits_every_panel_size_with_9_mm_targets() {
    let panels =
        [("1920x1080", "92"), ("1280x800", "150"), ("1024x600", "170"), ("800x480", "133"), ("800x1280", "150")];
    let runs = panels
        .iter()
        .map(|(size, dpi)| {
            ["replay", script("panels.touch").to_str().unwrap(), "--size", size, "--dpi", dpi]
                .map(String::from)
                .to_vec()
        })
        .collect();
    let failures = replay_all(runs);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
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

/// Replays the recording `events` on the demo volume once it has settled, then checks
/// `expectations` (script lines).
fn recording_on_the_demo_volume(events: &str, expectations: &str) {
    let work = tempfile::tempdir().unwrap();
    let settle = work.path().join("settle.touch");
    std::fs::write(&settle, "wait-idle\n").unwrap();
    let check = work.path().join("check.touch");
    std::fs::write(&check, expectations).unwrap();
    let paths = [settle, script(events), check];
    let mut args = vec!["replay", "--volume", "demo"];
    args.extend(paths.iter().map(|path| path.to_str().unwrap()));
    let report = replay(&args, work.path());
    assert_eq!(report["failures"].as_array().map(Vec::len), Some(0), "{report}");
}

/// A loop cut off by a second finger on the same slice (`second-finger.events`: two thirds of
/// the way round a second finger lands beside the path and moves, as a two-finger pan does) is
/// told on its slice, not dropped without a word; nothing is lassoed.
#[test]
fn a_loop_cut_off_by_a_second_finger_is_told_on_its_slice() {
    recording_on_the_demo_volume(
        "second-finger.events",
        "expect pending 0\nexpect feedback A second touch interrupted the loop: draw it again with one finger\n",
    );
}

/// A second touch resting beside the path on the same slice (`resting-hand.events`: the heel of
/// the drawing hand, or a palm the panel reports as a finger) does not cut the loop off: it
/// becomes a lasso.
#[test]
fn a_touch_resting_beside_the_path_leaves_the_loop_drawn() {
    recording_on_the_demo_volume("resting-hand.events", "expect pending 1\nexpect feedback \"\"\n");
}

/// A palm beside the path that the panel reports as a finger for its first frames and then as a
/// palm (`palm-late.events`), as controllers that judge a contact over a few frames do: it is
/// held while it rests, then cancelled, and the loop becomes a lasso.
#[test]
fn a_palm_first_reported_as_a_finger_leaves_the_loop_drawn() {
    recording_on_the_demo_volume("palm-late.events", "expect pending 1\nexpect feedback \"\"\n");
}

/// A palm resting on the panel while a finger draws (`palm.events`: the panel reports the
/// contact as `MT_TOOL_PALM`) is no second finger: the loop becomes a lasso.
#[test]
fn a_palm_resting_on_the_panel_leaves_the_loop_drawn() {
    recording_on_the_demo_volume("palm.events", "expect pending 1\nexpect feedback \"\"\n");
}

/// Another hand touching the 3-D view while a loop is drawn on a slice (`other-hand.events`) is
/// no part of a gesture: the loop goes on and becomes a lasso.
#[test]
fn another_hand_on_the_view_leaves_the_loop_drawn() {
    recording_on_the_demo_volume("other-hand.events", "expect pending 1\nexpect feedback \"\"\n");
}

/// `expect element NAME` puts where the element is in the report (the image test taps what a
/// script found on the host): the 3-D view inside the window, at the size asked for.
#[test]
fn an_element_a_script_expects_is_reported_with_its_rectangle() {
    let work = tempfile::tempdir().unwrap();
    let path = work.path().join("where.touch");
    std::fs::write(&path, "wait-idle\nexpect element view\nexpect element \"Define class\"\n").unwrap();
    let report = replay(&["replay", path.to_str().unwrap(), "--volume", "demo", "--size", "1024x600"], work.path());
    for name in ["view", "Define class"] {
        let rect: Vec<f64> = report["elements"][name].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        assert!(
            rect[2] > 0.0 && rect[3] > 0.0 && rect[0] + rect[2] <= 1024.0 && rect[1] + rect[3] <= 600.0,
            "{rect:?}"
        );
    }
}
