//! Tests of the script language and of simulated fingers: every command, run through the same
//! contact tracker and gesture recogniser as a real device, gives the gesture it describes.

use super::*;
use crate::touch::contacts::{ContactTracker, FingerEvent, FingerPhase};
use crate::touch::event::*;
use crate::touch::format;
use crate::touch::gestures::{Gesture, GestureRecognizer};
use crate::touch::mapping::ScreenMapping;
use proptest::prelude::*;

/// A 1280x800 kiosk: the view on the right, three slices on the left, a button.
struct Screen;

impl ElementLocator for Screen {
    fn screen_size(&self) -> [f32; 2] {
        [1280.0, 800.0]
    }
    fn element_rect(&self, name: &str) -> Option<Rect> {
        let rect = |x, y, width, height| Some(Rect { x, y, width, height });
        match name {
            "view" => rect(400.0, 0.0, 880.0, 800.0),
            "slice x" => rect(0.0, 0.0, 400.0, 266.0),
            "slice y" => rect(0.0, 266.0, 400.0, 266.0),
            "slice z" => rect(0.0, 532.0, 400.0, 268.0),
            "Define class" => rect(20.0, 740.0, 160.0, 50.0),
            "nothing" => rect(0.0, 0.0, 0.0, 10.0),
            _ => None,
        }
    }
}

/// Runs a command's events through tracker and recogniser.
fn gestures_of(command: &TouchCommand, device: &DeviceInfo) -> (Vec<RawEvent>, Vec<FingerEvent>, Vec<Gesture>) {
    let events = touch_events(command, &Screen, device, 1_000_000).unwrap();
    let mut tracker = ContactTracker::new(device, ScreenMapping::new(device, Screen.screen_size()));
    let mut recognizer = GestureRecognizer::new();
    let (mut fingers, mut gestures) = (Vec::new(), Vec::new());
    for event in &events {
        let before = fingers.len();
        tracker.feed(event, &mut fingers);
        recognizer.feed_frame(&fingers[before..], &mut gestures);
    }
    assert_eq!(tracker.active_fingers(), 0, "every simulated finger lifts");
    (events, fingers, gestures)
}

fn command(line: &str) -> TouchCommand {
    match parse(line).unwrap().remove(0).action {
        ScriptAction::Touch(command) => command,
        other => panic!("{other:?}"),
    }
}

fn close(a: [f32; 2], b: [f32; 2], tolerance: f32) -> bool {
    (a[0] - b[0]).abs() <= tolerance && (a[1] - b[1]).abs() <= tolerance
}

#[test]
fn a_script_parses_into_steps() {
    let text = "# setup\nlasso z 0.30,0.40 0.50,0.40 0.50,0.60 0.30,0.60\ntap \"Define class\"\n\n  wait 500ms\nwait 1.5s\nwait-idle\nscreenshot bone-1\nexpect classes 2\nexpect status \"Ready to train\"\nswipe \"slice x\" left\n";
    let steps = parse(text).unwrap();
    let actions: Vec<_> = steps.iter().map(|s| s.action.clone()).collect();
    assert_eq!(
        actions,
        vec![
            ScriptAction::Touch(TouchCommand::Lasso {
                element: "slice z".into(),
                points: vec![[0.3, 0.4], [0.5, 0.4], [0.5, 0.6], [0.3, 0.6]]
            }),
            ScriptAction::Touch(TouchCommand::Tap { element: "Define class".into(), at: [0.5, 0.5] }),
            ScriptAction::Wait { duration_ms: 500 },
            ScriptAction::Wait { duration_ms: 1500 },
            ScriptAction::WaitIdle,
            ScriptAction::Screenshot { name: "bone-1".into() },
            ScriptAction::Expect { key: "classes".into(), value: "2".into() },
            ScriptAction::Expect { key: "status".into(), value: "Ready to train".into() },
            ScriptAction::Touch(TouchCommand::Swipe { element: "slice x".into(), direction: SwipeDirection::Left }),
        ]
    );
    assert_eq!(steps[1].line_number, 3);
    assert_eq!(steps[2].source, "wait 500ms");
}

#[test]
fn syntax_errors_name_the_line() {
    let cases = [
        ("tap", "usage"),
        ("lasso z 0.1,0.1 0.2,0.2", "three points"),
        ("lasso z 0.1,0.1 0.2,0.2 nan,0.3", "not a number"),
        ("drag view 0.5,0.5", "usage"),
        ("swipe view sideways", "sideways"),
        ("pinch view 0", "outside"),
        ("rotate view 1000", "beyond"),
        ("wait 500", "unit"),
        ("wait -5ms", "outside"),
        ("screenshot ../etc/passwd", "screenshot name"),
        ("tap \"Define class", "unterminated"),
        ("tap view\"x", "stray quote"),
        ("fly view", "unknown command"),
        ("expect classes", "usage"),
        ("finger jitter", "usage"),
        ("finger wobble 3", "not jitter or speed"),
        ("finger jitter 50", "outside"),
        ("finger speed 0", "outside"),
    ];
    for (line, fragment) in cases {
        let text = format!("# first\n{line}\n");
        let error = parse(&text).unwrap_err();
        assert!(matches!(error, ScriptError::Syntax { line_number: 2, .. }), "{line}: {error}");
        assert!(error.to_string().contains(fragment), "{line}: {error}");
    }
}

#[test]
fn a_tap_is_a_tap_on_the_element_on_both_kinds_of_device() {
    for device in [DeviceInfo::virtual_touchscreen(), DeviceInfo::virtual_tablet()] {
        let (events, _, gestures) = gestures_of(&command("tap \"Define class\" 0.25,0.5"), &device);
        assert_eq!(gestures.len(), 1, "{gestures:?}");
        let Gesture::Tap { position } = gestures[0] else { panic!("{gestures:?}") };
        assert!(close(position, [60.0, 765.0], 0.1), "{position:?}");
        let duration_us = events.last().unwrap().time_us - events[0].time_us;
        assert!((60_000..=100_000).contains(&duration_us), "a tap lasts {duration_us} us");
    }
}

#[test]
fn multitouch_events_are_protocol_b_with_only_changed_values() {
    let (events, _, _) = gestures_of(&command("drag view 0.1,0.5 0.9,0.5"), &DeviceInfo::virtual_touchscreen());
    assert_eq!(events[0], RawEvent::new(1_000_000, EV_ABS, ABS_MT_SLOT, 0));
    assert_eq!((events[1].code, events[1].value > 0), (ABS_MT_TRACKING_ID, true));
    // A horizontal drag without jitter would send no y at all; with it, fewer y than x.
    let count = |code| events.iter().filter(|e| e.kind == EV_ABS && e.code == code).count();
    assert!(count(ABS_MT_POSITION_Y) < count(ABS_MT_POSITION_X));
    assert_eq!(count(ABS_MT_SLOT), 1, "one finger selects its slot once");
    let frames: Vec<u64> = events.iter().filter(|e| e.is_report()).map(|e| e.time_us).collect();
    assert!(frames.windows(2).all(|w| w[1] - w[0] == MOVE_INTERVAL_US));
    assert!(events.last().unwrap().is_report());
}

#[test]
fn a_drag_ends_where_the_script_says() {
    let (_, fingers, gestures) = gestures_of(&command("drag view 0.5,0.5 0.7,0.5"), &DeviceInfo::virtual_touchscreen());
    assert!(fingers.iter().all(|f| f.id == fingers[0].id));
    assert!(matches!(gestures[0], Gesture::DragStart { position } if close(position, [840.0, 400.0], 0.1)));
    let Some(Gesture::DragEnd { position }) = gestures.last().copied() else { panic!("{gestures:?}") };
    assert!(close(position, [1016.0, 400.0], 0.1), "{position:?}");
}

#[test]
fn a_lasso_is_a_closed_drag_through_its_points() {
    let (_, fingers, gestures) =
        gestures_of(&command("lasso z 0.30,0.40 0.50,0.40 0.50,0.60 0.30,0.60"), &DeviceInfo::virtual_touchscreen());
    let rect = Screen.element_rect("slice z").unwrap();
    let corners = [[0.3, 0.4], [0.5, 0.4], [0.5, 0.6], [0.3, 0.6]].map(|p| rect.point(p));
    // The path passes near every corner and returns to the first.
    for corner in corners {
        assert!(fingers.iter().any(|f| close(f.position, corner, 3.0)), "misses {corner:?}");
    }
    assert!(close(fingers.last().unwrap().position, corners[0], 0.1));
    assert!(matches!(gestures.last(), Some(Gesture::DragEnd { .. })));
    let moves = gestures.iter().filter(|g| matches!(g, Gesture::DragMove { .. })).count();
    assert!(moves > 10, "{moves} moves");
}

#[test]
fn a_path_ends_where_it_is_told_without_closing() {
    let (_, fingers, gestures) =
        gestures_of(&command("path z 0.30,0.40 0.50,0.40 0.50,0.60 0.30,0.60"), &DeviceInfo::virtual_touchscreen());
    let rect = Screen.element_rect("slice z").unwrap();
    assert!(close(fingers[0].position, rect.point([0.3, 0.4]), 0.1));
    assert!(close(fingers.last().unwrap().position, rect.point([0.3, 0.6]), 0.1));
    assert!(matches!(gestures.last(), Some(Gesture::DragEnd { .. })));
}

#[test]
fn a_double_tap_is_a_tap_then_a_double_tap() {
    let (_, _, gestures) = gestures_of(&command("double-tap view"), &DeviceInfo::virtual_touchscreen());
    assert!(
        matches!(gestures[..], [Gesture::Tap { .. }, Gesture::DoubleTap { position }] if close(position, [840.0, 400.0], 0.1))
    );
}

#[test]
fn a_press_holds_one_finger_still_for_its_duration() {
    let (_, fingers, gestures) = gestures_of(&command("press view 0.5,0.5 2s"), &DeviceInfo::virtual_touchscreen());
    let held_us = fingers.last().unwrap().time_us - fingers[0].time_us;
    assert!((2_000_000..2_100_000).contains(&held_us), "held {held_us} us");
    assert!(fingers.iter().all(|finger| close(finger.position, [840.0, 400.0], 4.0)), "a resting finger stays put");
    assert!(!gestures.iter().any(|gesture| matches!(gesture, Gesture::DragStart { .. })), "{gestures:?}");
    assert!(parse("press view 90s").is_err(), "a press of minutes is a stuck finger");
    assert!(parse("press view").is_err(), "a press says how long");
}

#[test]
fn swipes_move_the_way_they_say() {
    for (direction, sign) in [("left", [-1.0, 0.0]), ("right", [1.0, 0.0]), ("up", [0.0, -1.0]), ("down", [0.0, 1.0])] {
        let (_, fingers, _) =
            gestures_of(&command(&format!("swipe \"slice y\" {direction}")), &DeviceInfo::virtual_touchscreen());
        let (first, last) = (fingers[0].position, fingers.last().unwrap().position);
        let moved = [last[0] - first[0], last[1] - first[1]];
        assert!(moved[0] * sign[0] + moved[1] * sign[1] > 100.0, "{direction}: {moved:?}");
        let duration_us = fingers.last().unwrap().time_us - fingers[0].time_us;
        assert!(duration_us <= 200_000, "a swipe is quick: {duration_us} us");
    }
}

#[test]
fn two_finger_commands_give_their_transform() {
    let device = DeviceInfo::virtual_touchscreen();
    let end = |gestures: &[Gesture]| match gestures.last() {
        Some(Gesture::TwoFingerEnd { scale, translation_px, angle_degrees }) => {
            (*scale, *translation_px, *angle_degrees)
        }
        other => panic!("{other:?}"),
    };
    for scale in [1.5f32, 0.5, 3.0] {
        let (_, _, gestures) = gestures_of(&command(&format!("pinch view {scale}")), &device);
        let (got, translation, angle) = end(&gestures);
        assert!((got - scale).abs() < 1e-3 * scale, "pinch {scale}: {got}");
        assert!(translation[0].abs() < 0.5 && translation[1].abs() < 0.5 && angle.abs() < 0.5);
    }
    let (_, _, gestures) = gestures_of(&command("pan view 0.1,-0.05"), &device);
    let (scale, translation, _) = end(&gestures);
    assert!(close(translation, [88.0, -40.0], 0.1) && (scale - 1.0).abs() < 1e-3, "{translation:?}");
    let (_, _, gestures) = gestures_of(&command("rotate view 30"), &device);
    let (_, _, angle) = end(&gestures);
    assert!((angle - 30.0).abs() < 0.1, "{angle}");
    let (_, _, gestures) = gestures_of(&command("rotate view -200"), &device);
    assert!((end(&gestures).2 + 200.0).abs() < 0.1);
}

#[test]
fn run_time_errors_are_clear() {
    let device = DeviceInfo::virtual_touchscreen();
    let error = touch_events(&command("tap missing"), &Screen, &device, 0).unwrap_err();
    assert!(matches!(error, ScriptError::UnknownElement { ref element } if element == "missing"));
    assert!(matches!(
        touch_events(&command("tap nothing"), &Screen, &device, 0),
        Err(ScriptError::EmptyElement { .. })
    ));
    let error = touch_events(&command("pinch view 2"), &Screen, &DeviceInfo::virtual_tablet(), 0).unwrap_err();
    assert!(error.to_string().contains("single-touch"), "{error}");
}

#[test]
fn jitter_is_seeded_and_reproducible() {
    let device = DeviceInfo::virtual_touchscreen();
    let drag = command("drag view 0.1,0.1 0.9,0.9");
    let first = touch_events(&drag, &Screen, &device, 5_000).unwrap();
    assert_eq!(first, touch_events(&drag, &Screen, &device, 5_000).unwrap());
    let later: Vec<_> = touch_events(&drag, &Screen, &device, 9_000).unwrap().iter().map(|e| e.value).collect();
    assert_ne!(first.iter().map(|e| e.value).collect::<Vec<_>>(), later, "another start time, other jitter");
}

#[test]
fn a_seeded_path_is_the_same_at_any_start_time() {
    let device = DeviceInfo::virtual_touchscreen();
    let lasso = command("lasso view 0.3,0.3 0.7,0.3 0.7,0.7 0.3,0.7");
    let values = |start_us: u64, seed: u64| -> Vec<(u16, u16, i32)> {
        let events = touch_events_seeded(&lasso, &Screen, &device, start_us, seed, &FingerStyle::default()).unwrap();
        events.iter().filter(|e| e.code != ABS_MT_TRACKING_ID).map(|e| (e.kind, e.code, e.value)).collect()
    };
    assert_eq!(values(5_000, 7), values(812_345, 7), "the start time moved the path");
    assert_ne!(values(5_000, 7), values(5_000, 8), "another seed, other jitter");
    let times: Vec<u64> = touch_events_seeded(&lasso, &Screen, &device, 812_345, 7, &FingerStyle::default())
        .unwrap()
        .iter()
        .map(|e| e.time_us)
        .collect();
    assert_eq!(times.first(), Some(&812_345));
}

#[test]
fn a_finger_line_sets_the_speed_and_jitter_of_the_touches_after_it() {
    let steps = parse("finger jitter 3 speed 200\nfinger speed 400\nfinger\n").unwrap();
    let styles: Vec<FingerStyle> = steps
        .iter()
        .map(|step| match step.action {
            ScriptAction::Finger(style) => style,
            ref other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(styles[0], FingerStyle { jitter_px: 3.0, speed_px_per_s: 200.0 });
    assert_eq!(styles[1], FingerStyle { speed_px_per_s: 400.0, ..FingerStyle::default() });
    assert_eq!(styles[2], FingerStyle::default());
    // A quarter of the default speed takes four times the frames; no jitter: every reported
    // point lies on the path (a horizontal drag keeps its row).
    let device = DeviceInfo::virtual_touchscreen();
    let drag = command("drag view 0.1,0.5 0.9,0.5");
    let frames = |style: &FingerStyle| {
        let events = touch_events_seeded(&drag, &Screen, &device, 0, 1, style).unwrap();
        let rows: std::collections::BTreeSet<i32> =
            events.iter().filter(|e| e.code == ABS_MT_POSITION_Y).map(|e| e.value).collect();
        (events.iter().filter(|e| e.code == SYN_REPORT).count(), rows.len())
    };
    let steady = FingerStyle { jitter_px: 0.0, ..FingerStyle::default() };
    let (fast, rows) = frames(&steady);
    assert_eq!(rows, 1);
    let (slow, _) = frames(&FingerStyle { speed_px_per_s: steady.speed_px_per_s / 4.0, ..steady });
    assert!((4 * fast - 8..=4 * fast + 8).contains(&slow), "{fast} {slow}");
    let (_, shaken_rows) = frames(&FingerStyle { jitter_px: 3.0, ..steady });
    assert!(shaken_rows > 5, "{shaken_rows}");
}

#[test]
fn compile_writes_a_replayable_recording() {
    let script = parse("tap view\nwait 1s\nscreenshot a\npinch view 2\nexpect classes 2\n").unwrap();
    let device = DeviceInfo::virtual_touchscreen();
    let text = compile(&script, &Screen, &device).unwrap();
    assert!(text.contains("# line 3: screenshot a"), "{text}");
    assert!(text.contains("# line 5: expect classes 2"));
    let recording = format::parse(&text).unwrap();
    assert_eq!(recording.device, device);
    assert!(recording.events.windows(2).all(|w| w[0].time_us <= w[1].time_us), "time runs forward");
    // The pinch starts after the tap, the rest and the 1 s wait.
    let tap_end = touch_events(&command("tap view"), &Screen, &device, 0).unwrap().last().unwrap().time_us;
    let second_start = recording.events.iter().find(|e| e.time_us > tap_end).unwrap().time_us;
    assert_eq!(second_start, tap_end + GAP_AFTER_TOUCH_US + 1_000_000);
    let error = compile(&parse("tap view\ntap ghost\n").unwrap(), &Screen, &device).unwrap_err();
    assert!(error.to_string().starts_with("line 2:"), "{error}");
    let fingers = {
        let mut tracker = ContactTracker::new(&device, ScreenMapping::new(&device, Screen.screen_size()));
        let mut out = Vec::new();
        recording.events.iter().for_each(|e| tracker.feed(e, &mut out));
        out
    };
    assert_eq!(fingers.iter().filter(|f| f.phase == FingerPhase::Down).count(), 3);
}

proptest! {
    #[test]
    fn random_scripts_never_panic(text in "(?s)[a-z\" .,0-9#\\n-]{0,300}") {
        if let Ok(steps) = parse(&text) {
            let _ = compile(&steps, &Screen, &DeviceInfo::virtual_touchscreen());
        }
    }

    #[test]
    fn random_touch_commands_never_panic(x in -10.0f32..10.0, y in -10.0f32..10.0, scale in 0.1f32..10.0, angle in -720.0f32..720.0) {
        let device = DeviceInfo::virtual_touchscreen();
        for command in [
            TouchCommand::Drag { element: "view".into(), from: [x, y], to: [y, x] },
            TouchCommand::Lasso { element: "view".into(), points: vec![[x, y], [x, x], [y, y]] },
            TouchCommand::Pinch { element: "view".into(), scale },
            TouchCommand::Rotate { element: "view".into(), angle_degrees: angle },
            TouchCommand::Pan { element: "view".into(), offset: [x, y] },
        ] {
            let events = touch_events(&command, &Screen, &device, 0).unwrap();
            prop_assert!(events.iter().all(|e| e.kind != EV_ABS || e.code == ABS_MT_SLOT || e.code == ABS_MT_TRACKING_ID
                || (0..=32767).contains(&e.value)), "positions stay within the device's axes");
        }
    }
}
