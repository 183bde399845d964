//! Unit tests of the gesture recogniser (kept beside it; split out for length).

use super::*;
use FingerPhase::*;

/// Feeds `(finger, phase, x, y, time_ms)`, events of equal time as one frame, and returns
/// every gesture.
fn run(recognizer: &mut GestureRecognizer, events: &[(u64, FingerPhase, f32, f32, u64)]) -> Vec<Gesture> {
    let mut out = Vec::new();
    let events: Vec<FingerEvent> = events
        .iter()
        .map(|&(id, phase, x, y, time_ms)| FingerEvent { id, phase, position: [x, y], time_us: time_ms * 1000 })
        .collect();
    for frame in events.chunk_by(|a, b| a.time_us == b.time_us) {
        recognizer.feed_frame(frame, &mut out);
    }
    out
}

#[test]
fn fingers_moving_in_one_frame_show_no_half_moved_state() {
    // Fed one event at a time, the first finger's move alone would look like a pan.
    let events = pinch(100.0, 200.0, 1);
    let got = run(&mut GestureRecognizer::new(), &events);
    assert!(!got.iter().any(|g| matches!(g, Gesture::Pan { .. })), "{got:?}");
    let mut recognizer = GestureRecognizer::new();
    let mut one_by_one = Vec::new();
    for &(id, phase, x, y, time_ms) in &events {
        recognizer.feed(&FingerEvent { id, phase, position: [x, y], time_us: time_ms * 1000 }, &mut one_by_one);
    }
    assert!(one_by_one.iter().any(|g| matches!(g, Gesture::Pan { .. })), "the test would not catch it: {one_by_one:?}");
}

/// Two fingers on a horizontal line about (500, 500), `from_px` apart, spreading to `to_px` in
/// `steps` frames, then lifting.
fn pinch(from_px: f32, to_px: f32, steps: usize) -> Vec<(u64, FingerPhase, f32, f32, u64)> {
    let mut events = vec![(1, Down, 500.0 - from_px / 2.0, 500.0, 0), (2, Down, 500.0 + from_px / 2.0, 500.0, 8)];
    for step in 1..=steps {
        let d = from_px + (to_px - from_px) * step as f32 / steps as f32;
        let t = 8 + step as u64 * 8;
        events.push((1, Move, 500.0 - d / 2.0, 500.0, t));
        events.push((2, Move, 500.0 + d / 2.0, 500.0, t));
    }
    let end = 16 + steps as u64 * 8;
    events.push((1, Up, 500.0 - to_px / 2.0, 500.0, end));
    events.push((2, Up, 500.0 + to_px / 2.0, 500.0, end));
    events
}

fn last_scale(gestures: &[Gesture]) -> Option<f32> {
    gestures.iter().rev().find_map(|g| match g {
        Gesture::Pinch { scale, .. } => Some(*scale),
        _ => None,
    })
}

#[test]
fn a_short_still_touch_is_a_tap_at_its_landing_point() {
    let got = run(
        &mut GestureRecognizer::new(),
        &[(1, Down, 100.0, 100.0, 0), (1, Move, 105.0, 103.0, 40), (1, Up, 105.0, 103.0, 80)],
    );
    assert_eq!(got, vec![Gesture::Tap { position: [100.0, 100.0] }]);
}

#[test]
fn a_long_press_is_not_a_tap() {
    let got = run(
        &mut GestureRecognizer::new(),
        &[(1, Down, 100.0, 100.0, 0), (1, Up, 100.0, 100.0, TAP_MAX_DURATION_MS + 1)],
    );
    assert!(got.is_empty(), "{got:?}");
}

#[test]
fn two_quick_taps_close_together_make_a_double_tap() {
    let mut recognizer = GestureRecognizer::new();
    let got = run(
        &mut recognizer,
        &[
            (1, Down, 100.0, 100.0, 0),
            (1, Up, 100.0, 100.0, 60),
            (2, Down, 110.0, 95.0, 200),
            (2, Up, 110.0, 95.0, 260),
        ],
    );
    assert_eq!(got, vec![Gesture::Tap { position: [100.0, 100.0] }, Gesture::DoubleTap { position: [110.0, 95.0] }]);
    // A third tap starts afresh rather than making another double tap.
    let got = run(&mut recognizer, &[(3, Down, 110.0, 95.0, 400), (3, Up, 110.0, 95.0, 450)]);
    assert_eq!(got, vec![Gesture::Tap { position: [110.0, 95.0] }]);
}

#[test]
fn slow_or_distant_second_taps_are_single_taps() {
    let late = 60 + DOUBLE_TAP_INTERVAL_MS + 1;
    let got = run(
        &mut GestureRecognizer::new(),
        &[
            (1, Down, 100.0, 100.0, 0),
            (1, Up, 100.0, 100.0, 60),
            (2, Down, 100.0, 100.0, late),
            (2, Up, 100.0, 100.0, late + 50),
        ],
    );
    assert_eq!(got, vec![Gesture::Tap { position: [100.0, 100.0] }; 2]);
    let far = 100.0 + DOUBLE_TAP_SLOP_PX + 1.0;
    let got = run(
        &mut GestureRecognizer::new(),
        &[(1, Down, 100.0, 100.0, 0), (1, Up, 100.0, 100.0, 60), (2, Down, far, 100.0, 100), (2, Up, far, 100.0, 150)],
    );
    assert_eq!(got, vec![Gesture::Tap { position: [100.0, 100.0] }, Gesture::Tap { position: [far, 100.0] }]);
}

#[test]
fn moving_past_the_slop_is_a_drag() {
    let got = run(
        &mut GestureRecognizer::new(),
        &[
            (1, Down, 100.0, 100.0, 0),
            (1, Move, 110.0, 100.0, 8),
            (1, Move, 130.0, 100.0, 16),
            (1, Move, 150.0, 120.0, 24),
            (1, Up, 150.0, 120.0, 1000),
        ],
    );
    assert_eq!(
        got,
        vec![
            Gesture::DragStart { position: [100.0, 100.0] },
            Gesture::DragMove { position: [130.0, 100.0] },
            Gesture::DragMove { position: [150.0, 120.0] },
            Gesture::DragEnd { position: [150.0, 120.0] },
        ]
    );
}

#[test]
fn pinch_scale_is_the_distance_ratio_whatever_the_number_of_steps() {
    for steps in [1, 4, 100] {
        let mut recognizer = GestureRecognizer::new();
        let got = run(&mut recognizer, &pinch(100.0, 200.0, steps));
        let scale = last_scale(&got).unwrap();
        assert!((scale - 2.0).abs() < 1e-3, "{steps} steps: scale {scale}");
        let Some(Gesture::TwoFingerEnd { scale, translation_px, angle_degrees }) = got.last().copied() else {
            panic!("{got:?}")
        };
        assert!((scale - 2.0).abs() < 1e-3);
        assert!(translation_px[0].abs() < 1e-3 && translation_px[1].abs() < 1e-3);
        assert!(angle_degrees.abs() < 1e-3);
        let unwanted = |g: &&Gesture| matches!(g, Gesture::Pan { .. } | Gesture::Rotate { .. } | Gesture::Tap { .. });
        assert_eq!(got.iter().find(unwanted), None, "{steps} steps");
        assert_eq!(recognizer.fingers_down(), 0);
    }
    let got = run(&mut GestureRecognizer::new(), &pinch(300.0, 100.0, 7));
    assert!((last_scale(&got).unwrap() - 1.0 / 3.0).abs() < 1e-3);
}

#[test]
fn two_fingers_moving_together_pan_and_turning_rotates() {
    let mut events = vec![(1, Down, 400.0, 500.0, 0), (2, Down, 600.0, 500.0, 0)];
    for step in 1..=10u64 {
        let dy = 5.0 * step as f32;
        events.push((1, Move, 400.0, 500.0 + dy, step * 8));
        events.push((2, Move, 600.0, 500.0 + dy, step * 8));
    }
    let got = run(&mut GestureRecognizer::new(), &events);
    let Some(Gesture::Pan { translation_px, .. }) =
        got.iter().rev().find(|g| matches!(g, Gesture::Pan { .. })).copied()
    else {
        panic!("{got:?}")
    };
    assert!((translation_px[1] - 50.0).abs() < 1e-3 && translation_px[0].abs() < 1e-3);
    assert!(!got.iter().any(|g| matches!(g, Gesture::Pinch { .. } | Gesture::Rotate { .. })));

    // Turn the pair by 200 degrees about their centre in 20 frames: the angle passes 180.
    let mut events = vec![(1, Down, 400.0, 500.0, 0), (2, Down, 600.0, 500.0, 0)];
    for step in 1..=20u64 {
        let angle = (10.0 * step as f32).to_radians();
        let (sin, cos) = angle.sin_cos();
        events.push((1, Move, 500.0 - 100.0 * cos, 500.0 - 100.0 * sin, step * 8));
        events.push((2, Move, 500.0 + 100.0 * cos, 500.0 + 100.0 * sin, step * 8));
    }
    let got = run(&mut GestureRecognizer::new(), &events);
    let Some(Gesture::Rotate { angle_degrees, .. }) = got.last().copied() else { panic!("{got:?}") };
    assert!((angle_degrees - 200.0).abs() < 1e-2, "{angle_degrees}");
}

#[test]
fn a_finger_lifting_mid_pinch_ends_the_pinch_and_the_other_finger_does_nothing() {
    let mut recognizer = GestureRecognizer::new();
    let mut events = pinch(100.0, 150.0, 5);
    events.truncate(events.len() - 2);
    events.push((1, Up, 475.0, 500.0, 100));
    // The remaining finger wanders off and lifts: no drag, no tap.
    events.push((2, Move, 700.0, 600.0, 120));
    events.push((2, Up, 700.0, 600.0, 130));
    let got = run(&mut recognizer, &events);
    let ends: Vec<_> = got.iter().filter(|g| matches!(g, Gesture::TwoFingerEnd { .. })).collect();
    assert_eq!(ends.len(), 1);
    assert!(matches!(got.last(), Some(Gesture::TwoFingerEnd { scale, .. }) if (scale - 1.5).abs() < 1e-3), "{got:?}");
    assert_eq!(recognizer.fingers_down(), 0);
    // And the recogniser is back to idle: a tap works.
    let got = run(&mut recognizer, &[(3, Down, 10.0, 10.0, 500), (3, Up, 10.0, 10.0, 550)]);
    assert_eq!(got, vec![Gesture::Tap { position: [10.0, 10.0] }]);
}

#[test]
fn a_second_finger_turns_a_drag_into_a_cancelled_drag_and_a_two_finger_gesture() {
    let got = run(
        &mut GestureRecognizer::new(),
        &[
            (1, Down, 100.0, 100.0, 0),
            (1, Move, 150.0, 100.0, 8),
            (2, Down, 300.0, 100.0, 16),
            (2, Move, 400.0, 100.0, 24),
        ],
    );
    assert_eq!(
        got[..3],
        [
            Gesture::DragStart { position: [100.0, 100.0] },
            Gesture::DragMove { position: [150.0, 100.0] },
            Gesture::Cancel
        ]
    );
    assert!(matches!(got[3], Gesture::Pinch { scale, .. } if (scale - 250.0 / 150.0).abs() < 1e-4), "{got:?}");
}

#[test]
fn cancel_abandons_drags_and_pinches_and_never_taps() {
    let mut recognizer = GestureRecognizer::new();
    let got =
        run(&mut recognizer, &[(1, Down, 100.0, 100.0, 0), (1, Move, 200.0, 100.0, 8), (1, Cancel, 200.0, 100.0, 16)]);
    assert_eq!(got.last(), Some(&Gesture::Cancel));
    let got = run(&mut recognizer, &[(2, Down, 100.0, 100.0, 100), (2, Cancel, 100.0, 100.0, 110)]);
    assert!(got.is_empty(), "a cancelled touch is no tap: {got:?}");
    let mut events = pinch(100.0, 200.0, 3);
    events.truncate(events.len() - 2);
    events.push((1, Cancel, 0.0, 0.0, 100));
    events.push((2, Cancel, 0.0, 0.0, 100));
    let got = run(&mut recognizer, &events);
    assert_eq!(got.last(), Some(&Gesture::Cancel));
    assert!(!got.iter().any(|g| matches!(g, Gesture::TwoFingerEnd { .. })));
    assert_eq!(recognizer.fingers_down(), 0);
}

#[test]
fn a_third_finger_is_ignored_and_unknown_or_broken_events_change_nothing() {
    let mut recognizer = GestureRecognizer::new();
    let mut events = pinch(100.0, 200.0, 4);
    events.insert(3, (9, Down, 0.0, 0.0, 12));
    events.insert(4, (9, Move, 900.0, 900.0, 13));
    events.insert(5, (42, Up, 1.0, 1.0, 14));
    events.insert(6, (1, Move, f32::NAN, 0.0, 15));
    let got = run(&mut recognizer, &events);
    assert!((last_scale(&got).unwrap() - 2.0).abs() < 1e-3);
    assert_eq!(recognizer.fingers_down(), 1, "finger 9 is still down");
    let got = run(&mut recognizer, &[(9, Up, 0.0, 0.0, 300), (5, Down, 1.0, 1.0, 400), (5, Up, 1.0, 1.0, 420)]);
    assert_eq!(got, vec![Gesture::Tap { position: [1.0, 1.0] }]);
}

#[test]
fn fingers_beyond_the_maximum_are_ignored() {
    let mut recognizer = GestureRecognizer::new();
    let events: Vec<_> = (0..100).map(|id| (id, Down, id as f32, 0.0, id)).collect();
    run(&mut recognizer, &events);
    assert_eq!(recognizer.fingers_down(), MAX_FINGERS);
}
