use super::*;

fn folder_with(text: &str) -> tempfile::TempDir {
    let folder = tempfile::tempdir().unwrap();
    std::fs::write(path(folder.path()), text).unwrap();
    folder
}

#[test]
fn without_a_file_the_defaults_hold_and_each_mode_has_its_own() {
    let folder = tempfile::tempdir().unwrap();
    let loaded = load(folder.path());
    assert!(loaded.problem.is_none());
    let clinical = loaded.settings.effective();
    assert_eq!(clinical.mode, Mode::Clinical);
    assert_eq!((clinical.retention_hours, clinical.usb_export, clinical.receive.enabled), (24, false, true));
    assert_eq!(clinical.idle_timeout_s, DEFAULT_IDLE_TIMEOUT_S);
    let demo = Settings { mode: Mode::Demo, ..Settings::default() }.effective();
    assert_eq!((demo.retention_hours, demo.usb_export, demo.receive.enabled), (0, true, false));
}

#[test]
fn what_set_writes_reads_back_and_a_set_value_beats_the_mode_s_default() {
    let folder = tempfile::tempdir().unwrap();
    let mut settings = Settings::default();
    for (key, value) in [
        ("mode", "demo"),
        ("language", "de"),
        ("idle_timeout_s", "300"),
        ("retention_hours", "48"),
        ("usb_export", "false"),
        ("receive.enabled", "true"),
        ("receive.ae_title", "KIOSK1"),
        ("receive.port", "104"),
        ("receive.allowed_aes", "CT1, MR2"),
        ("pacs", "ORTHANC@127.0.0.1:4242,PACS2@pacs.example:11112"),
        ("panel.rotation_degrees", "90"),
        ("panel.dpi", "160"),
    ] {
        settings.set(key, value).unwrap_or_else(|error| panic!("{key} {value}: {error}"));
    }
    write(folder.path(), &settings).unwrap();
    use std::os::unix::fs::PermissionsExt;
    let mode = std::fs::metadata(path(folder.path())).unwrap().permissions().mode();
    assert_eq!(mode & 0o777, 0o640, "the receiver (the kiosk's group) reads it");
    let read_back = read(folder.path()).unwrap().unwrap();
    assert_eq!(read_back, settings);
    let effective = read_back.effective();
    assert_eq!((effective.retention_hours, effective.usb_export, effective.receive.enabled), (48, false, true));
    assert_eq!(effective.receive.allowed_aes, ["CT1", "MR2"]);
    assert_eq!(effective.pacs.len(), 2);
    // "default" gives a setting back to its mode.
    settings.set("usb_export", "default").unwrap();
    settings.set("retention_hours", "default").unwrap();
    assert_eq!((settings.effective().usb_export, settings.effective().retention_hours), (true, 0));
}

#[test]
fn a_bad_value_is_refused_by_its_key_and_nothing_changes() {
    let mut settings = Settings::default();
    let before = settings.clone();
    for (key, value, words) in [
        ("mode", "party", "clinical or demo"),
        ("idle_timeout_s", "-5", "whole number"),
        ("idle_timeout_s", "999999", "whole number"),
        ("retention_hours", "soon", "whole number"),
        ("usb_export", "maybe", "true, false or default"),
        ("receive.ae_title", "A TITLE LONGER THAN 16", "16 characters"),
        ("receive.port", "0", "port"),
        ("receive.port", "70000", "port"),
        ("receive.allowed_aes", "OK,BAD\\ONE", "backslash"),
        ("pacs", "ORTHANC@127.0.0.1", "port"),
        ("panel.rotation_degrees", "45", "0, 90, 180 or 270"),
        ("panel.dpi", "5", "40 to 600"),
        ("language", "tlh", "en or de"),
    ] {
        let error = settings.set(key, value).expect_err(&format!("{key} {value}")).to_string();
        assert!(error.starts_with(key), "{error}");
        assert!(error.contains(words), "{key} {value}: {error}");
    }
    let unknown = settings.set("colour", "red").expect_err("unknown").to_string();
    assert!(unknown.contains("\"colour\"") && unknown.contains("receive.port"), "{unknown}");
    assert_eq!(settings, before);
}

#[test]
fn a_bad_file_gives_the_safe_defaults_and_one_message_naming_it() {
    for (text, words) in [
        ("\u{0}\u{1}garbage = = =", "does not parse"),
        ("idle_timeout_s = -30\n", "does not parse"),
        ("mode = \"party\"\n", "does not parse"),
        ("colour = \"red\"\n", "does not parse"),
        ("[receive]\nport = 0\n", "receive.port"),
        ("pacs = [\"no-port@host\"]\n", "pacs"),
    ] {
        let folder = folder_with(text);
        let loaded = load(folder.path());
        assert_eq!(loaded.settings, Settings::default(), "{text:?}");
        let problem = loaded.problem.expect("a message").to_string();
        assert!(problem.contains(words), "{text:?}: {problem}");
        if words == "does not parse" {
            assert!(problem.contains(FILE), "names the file: {problem}");
        }
    }
    let folder = tempfile::tempdir().unwrap();
    std::fs::write(path(folder.path()), vec![b'#'; 1 << 20]).unwrap();
    assert!(matches!(load(folder.path()).problem, Some(SettingsError::TooLarge { .. })));
}

#[test]
fn a_file_written_by_hand_with_some_settings_keeps_the_rest_at_their_defaults() {
    let folder = folder_with("mode = \"demo\"\n[receive]\nport = 4242\n");
    let settings = read(folder.path()).unwrap().unwrap();
    assert_eq!(settings.mode, Mode::Demo);
    assert_eq!(settings.receive.port, 4242);
    assert_eq!(settings.receive.ae_title, "VOLASSO");
    assert_eq!(settings.effective().idle_timeout_s, DEFAULT_IDLE_TIMEOUT_S);
}

#[test]
fn every_key_reads_back_as_set_takes_it() {
    let mut settings = Settings::default();
    for (key, value) in [("mode", "demo"), ("pacs", "A@10.0.0.5:104,B@10.0.0.6:4242"), ("panel.dpi", "160")] {
        settings.set(key, value).unwrap();
    }
    for key in KEYS {
        let value = settings.effective().value(key).unwrap_or_else(|| panic!("{key} has no value"));
        let mut again = settings.clone();
        again.set(key, &value).unwrap_or_else(|error| panic!("{key}={value}: {error}"));
        assert_eq!(again.effective(), settings.effective(), "{key}={value}");
    }
    assert_eq!(settings.effective().value("pacs").as_deref(), Some("A@10.0.0.5:104,B@10.0.0.6:4242"));
    assert_eq!(Settings::default().effective().value("panel.dpi").as_deref(), Some("default"));
    assert_eq!(Settings::default().effective().value("receive"), None, "a table is no setting");
}
