//! The settings screen without a window: the long press, the PIN chosen and checked, rows
//! changed and written, on a temporary data folder and a scripted clock.

use super::*;

const SECOND: Duration = Duration::from_secs(1);

fn at(seconds: u64) -> Duration {
    Duration::from_secs(seconds)
}

fn type_pin(screen: &mut SettingsScreen, pin: &str, now: Duration) -> SettingsEffects {
    for digit in pin.chars() {
        screen.update(SettingsIntent::PinKey(digit.to_string()), now);
    }
    screen.update(SettingsIntent::PinDone, now)
}

/// A screen whose title was held long enough: the keypad is open.
fn held(data_dir: &std::path::Path) -> SettingsScreen {
    let mut screen = SettingsScreen::new(Some(data_dir.to_path_buf()));
    screen.update(SettingsIntent::TitleHeld(true), at(10));
    assert_eq!(screen.tick(at(12)).shown, Some(true));
    screen
}

fn message(screen: &SettingsScreen) -> String {
    match &screen.phase {
        Phase::Pin(entry) => entry.message.clone(),
        Phase::Rows(rows) => rows.message.clone(),
        Phase::Closed => String::new(),
    }
}

#[test]
fn only_a_long_press_on_the_title_asks_for_the_pin() {
    let data = tempfile::tempdir().unwrap();
    let mut screen = SettingsScreen::new(Some(data.path().to_path_buf()));
    screen.update(SettingsIntent::TitleHeld(true), at(10));
    assert_eq!(screen.tick(at(10) + LONG_PRESS - SECOND / 10), SettingsEffects::default());
    screen.update(SettingsIntent::TitleHeld(false), at(11));
    assert_eq!(screen.tick(at(20)), SettingsEffects::default(), "a tap is not a long press");
    assert!(!screen.is_open());
    screen.update(SettingsIntent::TitleHeld(true), at(30));
    assert_eq!(screen.tick(at(32)).shown, Some(true));
    assert!(matches!(&screen.phase, Phase::Pin(PinEntry { step: PinStep::Choose, .. })), "no PIN yet: one is chosen");
    // Without a data folder there is nothing to set.
    let mut nowhere = SettingsScreen::new(None);
    nowhere.update(SettingsIntent::TitleHeld(true), at(0));
    assert_eq!(nowhere.tick(at(5)).shown, None);
}

#[test]
fn the_first_pin_is_typed_twice_and_kept_only_as_a_hash() {
    let data = tempfile::tempdir().unwrap();
    let mut screen = held(data.path());
    type_pin(&mut screen, "12", at(13));
    assert_eq!(message(&screen), "A PIN is 4 to 8 digits");
    type_pin(&mut screen, "4711", at(14));
    type_pin(&mut screen, "4712", at(15));
    assert!(message(&screen).contains("differ"), "{}", message(&screen));
    assert!(!pin::is_set(data.path()), "a PIN that was not confirmed is not kept");
    type_pin(&mut screen, "4711", at(16));
    let effects = type_pin(&mut screen, "4711", at(17));
    assert_eq!(effects.audit, vec![(Event::SettingsChanged, "pin".to_string())]);
    assert!(matches!(screen.phase, Phase::Rows(_)));
    let stored = std::fs::read_to_string(pin::path(data.path())).unwrap();
    assert!(!stored.contains("4711"), "{stored}");
}

#[test]
fn a_wrong_pin_is_refused_and_logged_and_three_make_the_next_try_wait() {
    let data = tempfile::tempdir().unwrap();
    pin::set(data.path(), "4711").unwrap();
    let mut screen = held(data.path());
    let effects = type_pin(&mut screen, "0000", at(13));
    assert_eq!(effects.audit, vec![(Event::PinRefused, "settings screen".to_string())]);
    assert!(message(&screen).starts_with("Wrong PIN. 2 more tries"), "{}", message(&screen));
    type_pin(&mut screen, "0001", at(14));
    type_pin(&mut screen, "0002", at(15));
    assert!(message(&screen).contains("Wait 30 s"), "{}", message(&screen));
    // Even the right PIN waits.
    let effects = type_pin(&mut screen, "4711", at(20));
    assert!(effects.audit.is_empty());
    assert_eq!(message(&screen), "Wait 25 s before the next try");
    assert!(matches!(screen.phase, Phase::Pin(_)));
    type_pin(&mut screen, "4711", at(46));
    assert!(matches!(screen.phase, Phase::Rows(_)));
    // Closing forgets the rows; the next visit asks again.
    assert_eq!(screen.update(SettingsIntent::Close, at(50)).shown, Some(false));
    assert!(!screen.is_open());
}

#[test]
fn a_stepped_row_is_written_at_once_audited_and_applied() {
    let data = tempfile::tempdir().unwrap();
    pin::set(data.path(), "4711").unwrap();
    let mut screen = held(data.path());
    type_pin(&mut screen, "4711", at(13));
    let row = |screen: &SettingsScreen, key: &str| screen.rows().into_iter().find(|row| row.key == key).unwrap();
    assert_eq!(row(&screen, "mode").value, "Clinical");
    assert_eq!(row(&screen, "retention_hours").value, "24 h");
    let effects = screen.update(SettingsIntent::Step { key: "mode".into(), direction: 1 }, at(14));
    assert_eq!(effects.audit, vec![(Event::SettingsChanged, "mode=demo".to_string())]);
    let applied = effects.applied.expect("applied");
    assert_eq!((applied.mode, applied.retention_hours, applied.usb_export), (Mode::Demo, 0, true));
    assert_eq!(settings::read(data.path()).unwrap().unwrap().mode, Mode::Demo);
    assert_eq!(row(&screen, "retention_hours").value, "Until deleted by hand", "demo mode keeps nothing patient");
    // Steps wrap round; a value set from the command line steps to its neighbours.
    screen.update(SettingsIntent::Step { key: "idle_timeout_s".into(), direction: -1 }, at(15));
    assert_eq!(row(&screen, "idle_timeout_s").value, "1 min");
    let mut settings = settings::read(data.path()).unwrap().unwrap();
    settings.set("idle_timeout_s", "90").unwrap();
    settings::write(data.path(), &settings).unwrap();
    screen.update(SettingsIntent::Close, at(16));
    screen.update(SettingsIntent::TitleHeld(true), at(20));
    screen.tick(at(23));
    type_pin(&mut screen, "4711", at(24));
    assert_eq!(row(&screen, "idle_timeout_s").value, "90 s");
    screen.update(SettingsIntent::Step { key: "idle_timeout_s".into(), direction: 1 }, at(25));
    assert_eq!(row(&screen, "idle_timeout_s").value, "2 min");
    assert!(row(&screen, "pacs").applies_later && !row(&screen, "mode").applies_later);
}

#[test]
fn a_typed_value_is_checked_as_the_command_line_checks_it() {
    let data = tempfile::tempdir().unwrap();
    pin::set(data.path(), "4711").unwrap();
    let mut screen = held(data.path());
    type_pin(&mut screen, "4711", at(13));
    screen.update(SettingsIntent::Edit("pacs".into()), at(14));
    for key in "ORTHANC@pacs".chars() {
        screen.update(SettingsIntent::EditKey(key.to_string()), at(14));
    }
    let effects = screen.update(SettingsIntent::EditDone, at(15));
    assert_eq!(effects.applied, None);
    assert!(message(&screen).contains("pacs"), "a peer without a port is refused by name: {}", message(&screen));
    assert!(settings::read(data.path()).unwrap().is_none(), "nothing written");
    screen.update(SettingsIntent::Edit("pacs".into()), at(16));
    for key in "ORTHANC@127.0.0.1:4242".chars() {
        screen.update(SettingsIntent::EditKey(key.to_string()), at(16));
    }
    screen.update(SettingsIntent::EditKey("back".into()), at(16));
    screen.update(SettingsIntent::EditKey("3".into()), at(16));
    let effects = screen.update(SettingsIntent::EditDone, at(17));
    assert_eq!(effects.audit, vec![(Event::SettingsChanged, "pacs=ORTHANC@127.0.0.1:4243".to_string())]);
    assert_eq!(settings::read(data.path()).unwrap().unwrap().pacs, vec!["ORTHANC@127.0.0.1:4243".to_string()]);
    // Cancel keeps the value.
    screen.update(SettingsIntent::Edit("receive.ae_title".into()), at(18));
    screen.update(SettingsIntent::EditKey("clear".into()), at(18));
    screen.update(SettingsIntent::EditCancel, at(18));
    assert_eq!(settings::read(data.path()).unwrap().unwrap().receive.ae_title, "VOLASSO");
}

#[test]
fn a_damaged_settings_file_shows_the_defaults_and_the_first_change_replaces_it() {
    let data = tempfile::tempdir().unwrap();
    pin::set(data.path(), "4711").unwrap();
    std::fs::write(settings::path(data.path()), "mode = \"party\"\n").unwrap();
    let mut screen = held(data.path());
    type_pin(&mut screen, "4711", at(13));
    assert!(message(&screen).contains("a change replaces the file"), "{}", message(&screen));
    screen.update(SettingsIntent::Step { key: "usb_export".into(), direction: 1 }, at(14));
    let settings = settings::read(data.path()).unwrap().unwrap();
    assert_eq!((settings.mode, settings.usb_export), (Mode::Clinical, Some(true)));
}

#[test]
fn neighbours_wrap_and_place_unlisted_values() {
    let list = ["0", "30", "60", "120"];
    assert_eq!(neighbour(&list, "120", 1), "0");
    assert_eq!(neighbour(&list, "0", -1), "120");
    assert_eq!(neighbour(&list, "45", 1), "60");
    assert_eq!(neighbour(&list, "45", -1), "30");
    assert_eq!(neighbour(&list, "500", 1), "0");
    assert_eq!(neighbour(&["default", "96"], "72", 1), "96");
}
