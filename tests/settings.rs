//! `volasso settings` and `volasso audit`: the appliance's settings file and audit log from the
//! command line (`docs/interfaces.md`).

use crate::support::{assert_clean_error, volasso};
use std::path::Path;

/// `volasso settings --data-dir DATA ARGS...`.
fn run(data: &Path, args: &[&str]) -> std::process::Output {
    let mut all = vec!["settings", "--data-dir", data.to_str().unwrap()];
    all.extend_from_slice(args);
    volasso(&all, data)
}

fn shown(data: &Path) -> serde_json::Value {
    let output = run(data, &["show"]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    serde_json::from_slice(&output.stdout).unwrap()
}

#[test]
fn set_changes_one_setting_show_prints_what_is_in_effect_and_the_audit_log_says_who_changed_what() {
    let data = tempfile::tempdir().unwrap();
    let defaults = shown(data.path());
    assert_eq!(defaults["mode"], "clinical");
    assert_eq!(defaults["retention_hours"], 24);
    assert_eq!(defaults["usb_export"], false);
    for (key, value) in [("mode", "demo"), ("receive.port", "4242"), ("pacs", "ORTHANC@127.0.0.1:4242")] {
        let output = run(data.path(), &["set", key, value]);
        assert!(output.status.success(), "{key}: {}", String::from_utf8_lossy(&output.stderr));
    }
    let demo = shown(data.path());
    assert_eq!(demo["mode"], "demo");
    assert_eq!((demo["retention_hours"].clone(), demo["usb_export"].clone()), (0.into(), true.into()));
    assert_eq!(demo["receive"]["port"], 4242);
    assert_eq!(demo["pacs"], serde_json::json!(["ORTHANC@127.0.0.1:4242"]));
    let audit = volasso(&["audit", "--data-dir", data.path().to_str().unwrap()], data.path());
    assert!(audit.status.success());
    let lines: Vec<serde_json::Value> =
        String::from_utf8_lossy(&audit.stdout).lines().map(|line| serde_json::from_str(line).unwrap()).collect();
    let details: Vec<&str> = lines.iter().map(|line| line["detail"].as_str().unwrap()).collect();
    assert_eq!(details, ["mode=demo", "receive.port=4242", "pacs=ORTHANC@127.0.0.1:4242"]);
    assert!(lines.iter().all(|line| line["event"] == "settings-changed"));
    let later = volasso(&["audit", "--data-dir", data.path().to_str().unwrap(), "--since", "2999-01-01"], data.path());
    assert!(later.status.success() && later.stdout.is_empty());
}

#[test]
fn get_prints_one_setting_in_effect_as_plain_text_for_a_start_script() {
    let data = tempfile::tempdir().unwrap();
    let got = |key: &str| {
        let output = run(data.path(), &["get", key]);
        (output.status.success(), String::from_utf8_lossy(&output.stdout).trim().to_string())
    };
    assert_eq!(got("receive.port"), (true, "11112".to_string()), "the default without a file");
    assert!(run(data.path(), &["set", "receive.port", "104"]).status.success());
    assert!(run(data.path(), &["set", "pacs", "ORTHANC@10.0.0.5:4242, BACKUP@10.0.0.6:104"]).status.success());
    assert_eq!(got("receive.port"), (true, "104".to_string()));
    assert_eq!(got("pacs"), (true, "ORTHANC@10.0.0.5:4242,BACKUP@10.0.0.6:104".to_string()));
    assert_eq!(got("retention_hours"), (true, "24".to_string()), "the mode's default");
    assert_clean_error(&run(data.path(), &["get", "receive"]), "no setting is called", "a table");
    // A damaged file: the safe default, and the exit status says so.
    std::fs::write(data.path().join("settings.toml"), "receive = 3\n").unwrap();
    assert_eq!(got("receive.port"), (false, "11112".to_string()));
}

#[test]
fn a_bad_key_or_value_is_one_clear_line_and_the_file_is_left_as_it_was() {
    let data = tempfile::tempdir().unwrap();
    assert!(run(data.path(), &["set", "mode", "demo"]).status.success());
    let before = std::fs::read(data.path().join("settings.toml")).unwrap();
    for (key, value, expected) in [
        ("mode", "party", "clinical or demo"),
        ("idle_timeout_s", "-30", "whole number"),
        ("receive.port", "70000", "port"),
        ("pacs", "ORTHANC@localhost", "port"),
        ("colour", "red", "no setting is called"),
    ] {
        assert_clean_error(&run(data.path(), &["set", key, value]), expected, &format!("{key} {value}"));
    }
    assert_eq!(std::fs::read(data.path().join("settings.toml")).unwrap(), before);
}

#[test]
fn a_damaged_file_shows_the_safe_defaults_with_its_problem_and_is_not_overwritten() {
    let data = tempfile::tempdir().unwrap();
    let file = data.path().join("settings.toml");
    std::fs::write(&file, "mode = \"demo\"\nidle_timeout_s = -30\n").unwrap();
    let output = run(data.path(), &["show"]);
    assert_clean_error(&output, "line 2", "a negative timeout");
    let defaults: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(defaults["mode"], "clinical", "nothing of the bad file applied");
    assert_clean_error(&run(data.path(), &["set", "mode", "demo"]), "does not parse", "set on a damaged file");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mode = \"demo\"\nidle_timeout_s = -30\n");
}

/// Runs `volasso replay` on `script` (its text) with `data` as the data folder (the script and
/// the cache beside it, so the chooser lists only what the test put there).
fn replay_in(data: &Path, script: &str) -> std::process::Output {
    let work = tempfile::tempdir().unwrap();
    let path = work.path().join("script.touch");
    std::fs::write(&path, script).unwrap();
    volasso(&["replay", path.to_str().unwrap(), "--data-dir", data.to_str().unwrap()], &work.path().join("cache"))
}

#[test]
fn the_kiosk_takes_its_idle_timeout_from_the_settings_and_a_flag_beats_them() {
    let data = tempfile::tempdir().unwrap();
    assert!(run(data.path(), &["set", "idle_timeout_s", "5"]).status.success());
    let back_at_start = "tap Start\nexpect screen chooser\nwait 6s\nexpect screen start\n";
    let output = replay_in(data.path(), back_at_start);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stdout));
    let flag = data.path().join("flag.touch");
    std::fs::write(&flag, "tap Start\nwait 6s\nexpect screen chooser\n").unwrap();
    let args = ["replay", flag.to_str().unwrap(), "--data-dir", data.path().to_str().unwrap(), "--idle-timeout", "60"];
    let output = volasso(&args, &data.path().join("cache"));
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stdout));
}

#[test]
fn a_kiosk_with_a_damaged_settings_file_starts_on_the_safe_defaults_and_says_why() {
    let data = tempfile::tempdir().unwrap();
    std::fs::write(data.path().join("settings.toml"), "idle_timeout_s = 5\nmode = \"party\"\n").unwrap();
    // Nothing of the file applies: the default two minutes, not its five seconds.
    let output = replay_in(data.path(), "tap Start\nwait 6s\nexpect screen chooser\n");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stdout));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("settings.toml") && stderr.contains("safe defaults"), "{stderr}");
}

/// A copy of a file of the shared data (`../shared/data`) at `to`.
fn copy_series(name: &str, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    std::fs::copy(crate::support::data(name), to.join("0000000000000001.dcm")).unwrap();
}

#[test]
fn a_received_series_card_says_when_it_is_deleted_and_a_copied_scan_says_nothing() {
    let data = tempfile::tempdir().unwrap();
    copy_series("dicom/ct_small.dcm", &data.path().join("CT-0123456789abcdef"));
    copy_series("dicom/ct_small.dcm", &data.path().join("copied by hand"));
    // Clinical mode's 24 hours (no settings file: its defaults); the demo's card first.
    let script = "tap Start\nwait-idle\nwait 3s\nexpect cards 3\nexpect expires-1 \"\"\n\
                  expect expires-2 \"Deleted in 23 h\"\nexpect expires-3 \"\"\n";
    let output = replay_in(data.path(), script);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stdout));
}

#[test]
fn a_received_series_older_than_the_retention_is_gone_from_the_chooser_and_the_audit_log_says_so() {
    let data = tempfile::tempdir().unwrap();
    let old = data.path().join("CT-0123456789abcdef");
    let new = data.path().join("CT-fedcba9876543210");
    copy_series("dicom/ct_small.dcm", &old);
    copy_series("dicom/ct_small.dcm", &new);
    let day_and_a_half = std::time::SystemTime::now() - std::time::Duration::from_secs(36 * 3600);
    std::fs::File::open(&old).unwrap().set_modified(day_and_a_half).unwrap();
    // Clinical mode's 24 hours (no settings file: its defaults). The demo and the newer series.
    let output = replay_in(data.path(), "wait-idle\nwait 1s\ntap Start\nexpect screen chooser\nexpect cards 2\n");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stdout));
    assert!(!old.exists() && new.exists());
    let audit = volasso(&["audit", "--data-dir", data.path().to_str().unwrap()], data.path());
    let text = String::from_utf8_lossy(&audit.stdout);
    assert!(text.contains("\"event\":\"data-expired\"") && text.contains("series CT-0123456789abcdef"), "{text}");
    // In demo mode nothing expires.
    assert!(run(data.path(), &["set", "mode", "demo"]).status.success());
    std::fs::File::open(&new).unwrap().set_modified(day_and_a_half).unwrap();
    let output = replay_in(data.path(), "wait-idle\nwait 1s\ntap Start\nexpect cards 2\n");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stdout));
    assert!(new.exists());
}

/// A data folder holding the shared Philips phantom series (its files linked, not copied).
fn philips_in(data: &Path) {
    let folder = data.join("philips_phantom_5mm");
    std::fs::create_dir_all(&folder).unwrap();
    let shared = crate::support::data("dicom/philips_phantom_5mm");
    for entry in std::fs::read_dir(&shared).unwrap() {
        let path = entry.unwrap().path();
        std::os::unix::fs::symlink(&path, folder.join(path.file_name().unwrap())).unwrap();
    }
}

#[test]
fn clinical_mode_shows_whose_scan_it_is_and_demo_mode_shows_and_writes_none_of_it() {
    let open = "tap Start\nwait-idle\ntap \"philips_phantom_5mm: STD BRAIN 5MM (CT, 28 images)\"\nwait-idle\n\
                expect screen work\nexpect layout 9mm\n";
    let clinical = tempfile::tempdir().unwrap();
    philips_in(clinical.path());
    let script = format!("{open}expect patient HEAD · ID PLASTIC · M · study 2015-02-06 · CT STD BRAIN 5MM\n");
    let output = replay_in(clinical.path(), &script);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stdout));
    // Demo mode, a whole visit: two classes drawn, the result kept, a snapshot, the session
    // autosaved; then nothing written or logged holds the patient's ID.
    let demo = tempfile::tempdir().unwrap();
    philips_in(demo.path());
    assert!(run(demo.path(), &["set", "mode", "demo"]).status.success());
    let visit = "expect patient \"\"\n\
                 lasso \"slice z\" 0.40,0.40 0.60,0.40 0.60,0.60 0.40,0.60\ntap \"Define class\"\n\
                 lasso \"slice z\" 0.05,0.05 0.20,0.05 0.20,0.20 0.05,0.20\ntap \"Define class\"\n\
                 wait-idle\nexpect classified 2\ntap \"Save result\"\nwait-idle\ntap Snapshot\nwait-idle\n\
                 expect snapshots 1\n";
    let work = tempfile::tempdir().unwrap();
    let script = work.path().join("visit.touch");
    std::fs::write(&script, format!("{open}{visit}")).unwrap();
    let session = demo.path().join("session");
    let args = [
        "replay",
        script.to_str().unwrap(),
        "--data-dir",
        demo.path().to_str().unwrap(),
        "--session-dir",
        session.to_str().unwrap(),
    ];
    let output = volasso(&args, &work.path().join("cache"));
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stdout));
    // Nothing the demo run wrote or logged holds the patient's ID (its name, HEAD, is a word
    // the logs may use for other things).
    let logged = format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    assert!(!logged.contains("PLASTIC"), "{logged}");
    let kept = walk(demo.path()).iter().filter(|path| path.ends_with("entry.json")).count();
    assert_eq!(kept, 1, "the result was kept");
    assert!(session.join("session.json").exists(), "the session was autosaved");
    let mut written = Vec::new();
    for entry in walk(demo.path()) {
        if !entry.is_symlink() && entry.is_file() {
            written.push(std::fs::read(&entry).unwrap());
        }
    }
    assert!(written.iter().all(|bytes| !String::from_utf8_lossy(bytes).contains("PLASTIC")));
}

/// Every path under `folder`, links not followed.
fn walk(folder: &Path) -> Vec<std::path::PathBuf> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir(folder).into_iter().flatten().flatten() {
        let path = entry.path();
        if path.is_dir() && !path.is_symlink() {
            found.extend(walk(&path));
        }
        found.push(path);
    }
    found
}

#[test]
fn the_receiver_listens_on_nothing_while_the_settings_keep_dicom_intake_off_and_starts_when_they_allow_it() {
    use std::io::BufRead;
    let data = tempfile::tempdir().unwrap();
    assert!(run(data.path(), &["set", "mode", "demo"]).status.success());
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_volasso"))
        .args(["receive", "--port", "0", "--listen", "127.0.0.1", "--data-dir", data.path().to_str().unwrap()])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("volasso runs");
    let (lines, receiver) = std::sync::mpsc::channel();
    let stderr = child.stderr.take().unwrap();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stderr).lines().map_while(Result::ok) {
            if lines.send(line).is_err() {
                break;
            }
        }
    });
    let wait_for = |words: &str, seconds: u64| {
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(seconds);
        let mut seen = Vec::new();
        while let Some(left) = deadline.checked_duration_since(std::time::Instant::now()) {
            match receiver.recv_timeout(left) {
                Ok(line) if line.contains(words) => return seen,
                Ok(line) => seen.push(line),
                Err(_) => break,
            }
        }
        panic!("no line with {words:?} within {seconds} s: {seen:?}");
    };
    let before = wait_for("DICOM intake is off", 20);
    assert!(before.iter().all(|line| !line.contains("listening on")), "{before:?}");
    assert!(run(data.path(), &["set", "receive.enabled", "true"]).status.success());
    wait_for("listening on 127.0.0.1:", 20);
    let _ = child.kill();
    let _ = child.wait();
}

#[test]
fn set_pin_keeps_a_salted_hash_of_the_pin_read_from_standard_input_and_refuses_another_form() {
    use std::io::Write;
    let data = tempfile::tempdir().unwrap();
    let set_pin = |pin: &str| {
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_volasso"))
            .args(["settings", "--data-dir", data.path().to_str().unwrap(), "set-pin"])
            .stdin(std::process::Stdio::piped())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("volasso runs");
        child.stdin.take().unwrap().write_all(format!("{pin}\n").as_bytes()).unwrap();
        child.wait_with_output().unwrap()
    };
    assert_clean_error(&set_pin("12"), "4 to 8 digits", "a short PIN");
    assert!(!data.path().join("pin").exists());
    let output = set_pin("4711");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let stored = std::fs::read_to_string(data.path().join("pin")).unwrap();
    assert!(stored.starts_with("$argon2") && !stored.contains("4711"), "{stored}");
    let mut attempts = volasso::appliance::pin::Attempts::default();
    let verdict = volasso::appliance::pin::check(data.path(), "4711", &mut attempts, std::time::Duration::ZERO);
    assert_eq!(verdict.unwrap(), volasso::appliance::pin::Verdict::Accepted);
}

#[test]
fn the_settings_screen_is_reached_by_a_long_press_and_the_pin_and_its_mode_switch_hides_the_patient() {
    let data = tempfile::tempdir().unwrap();
    philips_in(data.path());
    volasso::appliance::pin::set(data.path(), "4711").unwrap();
    let card = "\"philips_phantom_5mm: STD BRAIN 5MM (CT, 28 images)\"";
    let script = format!(
        "press title 2500ms\nexpect screen settings\nexpect layout 9mm\n\
         tap 9\ntap 9\ntap 9\ntap 9\ntap OK\nexpect pin-message \"Wrong PIN. 2 more tries before a wait\"\n\
         tap 4\ntap 7\ntap 1\ntap 1\ntap OK\nexpect setting.mode Clinical\nexpect layout 9mm\n\
         tap \"Mode next\"\nexpect setting.mode \"Demo (no patient data)\"\n\
         tap Done\nexpect screen start\ntap Start\nwait-idle\ntap {card}\nwait-idle\n\
         expect screen work\nexpect patient \"\"\n"
    );
    let output = replay_in(data.path(), &script);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stdout));
    let written = std::fs::read_to_string(data.path().join("settings.toml")).unwrap();
    assert!(written.contains("mode = \"demo\""), "{written}");
    let output = volasso(&["audit", "--data-dir", data.path().to_str().unwrap()], data.path());
    let audit = String::from_utf8_lossy(&output.stdout);
    assert!(audit.contains("\"event\":\"pin-refused\""), "{audit}");
    assert!(audit.contains("\"detail\":\"mode=demo\""), "{audit}");
    assert!(!audit.contains("4711") && !audit.contains("9999"), "no PIN typed is logged: {audit}");
    // A short press on the title is a tap: it starts, like the rest of the start screen.
    let output = replay_in(data.path(), "press title 1s\nexpect screen chooser\n");
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stdout));
}

/// The language switched on the settings screen: the screens, the app's lines and the patient's
/// dates speak German, and every screen on the way keeps its controls whole, apart and 9 mm wide
/// with German's longer words, on the 7-inch landscape panel and the 10-inch one in portrait.
#[test]
fn the_language_switched_on_the_settings_screen_speaks_german_on_every_screen_on_the_way() {
    for (size, dpi) in [("1024x600", "170"), ("800x1280", "150")] {
        let data = tempfile::tempdir().unwrap();
        philips_in(data.path());
        volasso::appliance::pin::set(data.path(), "4711").unwrap();
        let script = "press title 2500ms\ntap 4\ntap 7\ntap 1\ntap 1\ntap OK\nexpect setting.language English\n\
                      tap \"Language next\"\nexpect setting.language Deutsch\n\
                      expect layout 9mm\ntap Done\nexpect layout 9mm\ntap Start\nwait-idle\nexpect layout 9mm\n\
                      tap \"philips_phantom_5mm: STD BRAIN 5MM (CT, 28 images)\"\nwait-idle\nexpect layout 9mm\n\
                      expect patient \"HEAD · ID PLASTIC · M · Studie 06.02.2015 · CT STD BRAIN 5MM\"\n\
                      lasso \"slice z\" 0.40,0.40 0.60,0.40 0.60,0.60 0.40,0.60\nexpect layout 9mm\n";
        let work = tempfile::tempdir().unwrap();
        let path = work.path().join("german.touch");
        std::fs::write(&path, script).unwrap();
        let args = [
            "replay",
            path.to_str().unwrap(),
            "--data-dir",
            data.path().to_str().unwrap(),
            "--size",
            size,
            "--dpi",
            dpi,
        ];
        let output = volasso(&args, &work.path().join("cache"));
        assert!(output.status.success(), "{size}: {}", String::from_utf8_lossy(&output.stdout));
        let written = std::fs::read_to_string(data.path().join("settings.toml")).unwrap();
        assert!(written.contains("language = \"de\""), "{written}");
    }
}
