//! Abuse: a minute of random, broken touch input through tracker and recogniser. Nothing may
//! panic, state stays bounded, finger events stay consistent, and a clean tap afterwards is
//! still recognised.

use super::contacts::{ContactTracker, FingerEvent, FingerPhase};
use super::event::*;
use super::gestures::{Gesture, GestureRecognizer, MAX_FINGERS};
use super::mapping::ScreenMapping;
use super::script::{self, ElementLocator, Rect, TouchCommand};
use crate::rng::SplitMix64;
use std::collections::HashSet;

const SCREEN: [f32; 2] = [1024.0, 768.0];
const EVENTS: u64 = 10_000;
const SIMULATED_US: u64 = 60_000_000;

struct Screen;

impl ElementLocator for Screen {
    fn screen_size(&self) -> [f32; 2] {
        SCREEN
    }
    fn element_rect(&self, name: &str) -> Option<Rect> {
        (name == "button").then_some(Rect { x: 100.0, y: 200.0, width: 80.0, height: 40.0 })
    }
}

/// One random event, mostly plausible, sometimes garbage.
fn random_event(rng: &mut SplitMix64, time_us: u64) -> RawEvent {
    let off_screen = |rng: &mut SplitMix64| rng.below(70_000) as i32 - 20_000;
    let (kind, code, value) = match rng.below(100) {
        0..=9 => (EV_ABS, ABS_MT_SLOT, if rng.below(10) == 0 { rng.next_u64() as i32 } else { rng.below(12) as i32 }),
        10..=19 => (EV_ABS, ABS_MT_TRACKING_ID, if rng.below(3) == 0 { -1 } else { rng.below(1000) as i32 }),
        20..=34 => (EV_ABS, ABS_MT_POSITION_X, off_screen(rng)),
        35..=49 => (EV_ABS, ABS_MT_POSITION_Y, off_screen(rng)),
        50..=54 => (EV_ABS, ABS_X, off_screen(rng)),
        55..=59 => (EV_ABS, ABS_Y, off_screen(rng)),
        60..=64 => (EV_KEY, [BTN_TOUCH, BTN_LEFT][rng.below(2) as usize], rng.below(3) as i32),
        65..=84 => (EV_SYN, SYN_REPORT, 0),
        85..=86 => (EV_SYN, SYN_DROPPED, 0),
        _ => (rng.next_u64() as u16, rng.next_u64() as u16, rng.next_u64() as i32),
    };
    RawEvent::new(time_us, kind, code, value)
}

/// Checks that finger events form valid lives: down once, then moves, then one up or cancel.
fn check_consistent(fingers: &[FingerEvent], alive: &mut HashSet<u64>, ended: &mut HashSet<u64>) {
    for finger in fingers {
        assert!(finger.position.iter().all(|v| v.is_finite()), "{finger:?}");
        assert!((0.0..=SCREEN[0]).contains(&finger.position[0]) && (0.0..=SCREEN[1]).contains(&finger.position[1]));
        match finger.phase {
            FingerPhase::Down => {
                assert!(!ended.contains(&finger.id) && alive.insert(finger.id), "{finger:?} down twice")
            }
            FingerPhase::Move => assert!(alive.contains(&finger.id), "{finger:?} moves while not down"),
            FingerPhase::Up | FingerPhase::Cancel => {
                assert!(alive.remove(&finger.id), "{finger:?} ends while not down");
                ended.insert(finger.id);
            }
        }
    }
}

fn abuse(device: &DeviceInfo, seed: u64) {
    let mut rng = SplitMix64::new(seed);
    let mut tracker = ContactTracker::new(device, ScreenMapping::new(device, SCREEN));
    let mut recognizer = GestureRecognizer::new();
    let (mut alive, mut ended) = (HashSet::new(), HashSet::new());
    let (mut fingers, mut gestures) = (Vec::new(), Vec::new());
    let mut most_fingers = 0;
    for index in 0..EVENTS {
        let event = random_event(&mut rng, index * SIMULATED_US / EVENTS);
        fingers.clear();
        tracker.feed(&event, &mut fingers);
        check_consistent(&fingers, &mut alive, &mut ended);
        recognizer.feed_frame(&fingers, &mut gestures);
        assert!(tracker.active_fingers() <= device.tracked_slots());
        assert!(recognizer.fingers_down() <= MAX_FINGERS);
        assert_eq!(tracker.active_fingers(), alive.len());
        most_fingers = most_fingers.max(tracker.active_fingers());
        // The recogniser's output is bounded by its input: a few gestures per finger event.
        assert!(gestures.len() < 4 * (index as usize + 1));
    }
    if device.multitouch {
        assert!(most_fingers >= 5, "the abuse reached {most_fingers} fingers at most");
    }
    assert!(ended.len() > 50, "only {} finger lives in a minute of abuse", ended.len());

    // Recovery: a drop cancels whatever is left; then a clean tap is a tap.
    let mut time_us = SIMULATED_US;
    fingers.clear();
    for code in [SYN_DROPPED, SYN_REPORT] {
        tracker.feed(&RawEvent::new(time_us, EV_SYN, code, 0), &mut fingers);
    }
    time_us += 1_000_000;
    let tap = TouchCommand::Tap { element: "button".into(), at: [0.5, 0.5] };
    recognizer.feed_frame(&fingers, &mut gestures);
    gestures.clear();
    for event in script::touch_events(&tap, &Screen, device, time_us).unwrap() {
        let before = fingers.len();
        tracker.feed(&event, &mut fingers);
        recognizer.feed_frame(&fingers[before..], &mut gestures);
    }
    check_consistent(&fingers, &mut alive, &mut ended);
    let taps: Vec<_> =
        gestures.iter().filter(|g| !matches!(g, Gesture::Cancel | Gesture::TwoFingerEnd { .. })).collect();
    assert_eq!(taps.len(), 1, "{gestures:?}");
    let Gesture::Tap { position } = *taps[0] else { panic!("{gestures:?}") };
    assert!((position[0] - 140.0).abs() < 0.1 && (position[1] - 220.0).abs() < 0.1, "{position:?}");
    assert_eq!(tracker.active_fingers(), 0);
    assert_eq!(recognizer.fingers_down(), 0);
}

#[test]
fn a_minute_of_random_multitouch_abuse_leaves_a_working_tap() {
    for seed in [1, 2, 3] {
        abuse(&DeviceInfo::virtual_touchscreen(), seed);
    }
}

#[test]
fn a_minute_of_random_single_touch_abuse_leaves_a_working_tap() {
    abuse(&DeviceInfo::virtual_tablet(), 4);
}

#[test]
fn a_device_declaring_absurd_slots_is_bounded() {
    let device = DeviceInfo { slot_count: usize::MAX, ..DeviceInfo::virtual_touchscreen() };
    abuse(&device, 5);
}
