//! Tests of the live reader. Where `/dev/uinput` can be used, a virtual multitouch screen is
//! created and read back through [`TouchDevice`]; elsewhere that test says it was skipped.

use super::*;
use crate::touch::contacts::FingerPhase;
use crate::touch::mapping::ScreenMapping;
use std::time::Duration;

#[test]
fn evdev_events_convert_field_for_field() {
    let event = evdev::InputEvent::new(EV_ABS, ABS_MT_POSITION_X, -123);
    assert_eq!(raw_event_from_evdev(&event), RawEvent::new(0, EV_ABS, ABS_MT_POSITION_X, -123));
    let now_us = SystemTime::now().duration_since(SystemTime::UNIX_EPOCH).unwrap().as_micros() as u64;
    let event = raw_event_from_evdev(&evdev::InputEvent::new_now(EV_SYN, SYN_REPORT, 0));
    assert!(event.is_report());
    assert!(event.time_us.abs_diff(now_us) < 5_000_000, "{} vs {now_us}", event.time_us);
}

#[test]
fn single_touch_resync_presses_at_the_current_position_or_does_nothing() {
    assert!(single_touch_resync(false, [1, 2], 5).is_empty());
    let events = single_touch_resync(true, [10, 20], 5);
    let device = DeviceInfo { x: AxisRange::new(0, 100), y: AxisRange::new(0, 100), ..DeviceInfo::virtual_tablet() };
    let mut tracker = ContactTracker::new(&device, ScreenMapping::new(&device, [100.0, 100.0]));
    let mut out = Vec::new();
    // A press is under way, events are dropped, and the resync re-acquires the finger.
    for event in [
        RawEvent::new(0, EV_KEY, BTN_TOUCH, 1),
        RawEvent::new(0, EV_SYN, SYN_REPORT, 0),
        RawEvent::new(1, EV_SYN, SYN_DROPPED, 0),
        RawEvent::new(2, EV_SYN, SYN_REPORT, 0),
    ]
    .iter()
    .chain(&events)
    {
        tracker.feed(event, &mut out);
    }
    let phases: Vec<_> = out.iter().map(|f| (f.id, f.phase, f.position)).collect();
    assert_eq!(
        phases,
        vec![
            (1, FingerPhase::Down, [0.0, 0.0]),
            (1, FingerPhase::Cancel, [0.0, 0.0]),
            (2, FingerPhase::Down, [10.0, 20.0])
        ]
    );
}

#[test]
fn without_input_devices_opening_the_first_says_none_was_found() {
    if Path::new("/dev/input").exists() {
        eprintln!("skipped: this machine has /dev/input, so the 'none found' path cannot be forced");
        return;
    }
    assert!(find_touchscreens().is_empty());
    let error = TouchDevice::open_first().err().unwrap();
    assert!(matches!(error, TouchError::NoTouchscreen { checked: 0 }), "{error}");
    let error = TouchDevice::open(Path::new("/dev/input/event0")).err().unwrap();
    assert!(error.to_string().contains("/dev/input/event0"), "{error}");
}

/// Builds a ten-slot virtual touchscreen through uinput.
fn virtual_touchscreen() -> std::io::Result<evdev::uinput::VirtualDevice> {
    use evdev::{AbsInfo, AbsoluteAxisCode, AttributeSet, KeyCode, PropType, UinputAbsSetup};
    let keys: AttributeSet<KeyCode> = [KeyCode(BTN_TOUCH)].into_iter().collect();
    let properties: AttributeSet<PropType> = [PropType::DIRECT].into_iter().collect();
    let axis =
        |code: u16, maximum: i32| UinputAbsSetup::new(AbsoluteAxisCode(code), AbsInfo::new(0, 0, maximum, 0, 0, 0));
    evdev::uinput::VirtualDevice::builder()?
        .name("volasso uinput touchscreen")
        .with_keys(&keys)?
        .with_properties(&properties)?
        .with_absolute_axis(&axis(ABS_X, 4095))?
        .with_absolute_axis(&axis(ABS_Y, 4095))?
        .with_absolute_axis(&axis(ABS_MT_SLOT, 9))?
        .with_absolute_axis(&axis(ABS_MT_TRACKING_ID, 65535))?
        .with_absolute_axis(&axis(ABS_MT_POSITION_X, 4095))?
        .with_absolute_axis(&axis(ABS_MT_POSITION_Y, 4095))?
        .build()
}

#[test]
fn a_uinput_touchscreen_is_read_back_through_the_reader() {
    if !Path::new("/dev/uinput").exists() {
        eprintln!("skipped: /dev/uinput does not exist on this machine, so no virtual touchscreen can be made");
        return;
    }
    let mut virtual_device = match virtual_touchscreen() {
        Ok(device) => device,
        Err(error) => {
            eprintln!("skipped: /dev/uinput exists but a virtual device cannot be created: {error}");
            return;
        }
    };
    // udev needs a moment to create the node.
    std::thread::sleep(Duration::from_millis(300));
    let node = virtual_device
        .enumerate_dev_nodes_blocking()
        .unwrap()
        .filter_map(Result::ok)
        .find(|path| path.to_string_lossy().contains("event"))
        .expect("the virtual device has an event node");
    let device = TouchDevice::open(&node).unwrap();
    assert_eq!(device.info().name, "volasso uinput touchscreen");
    assert!(device.info().multitouch);
    assert_eq!(device.info().slot_count, 10);
    assert_eq!(device.info().x, AxisRange::new(0, 4095));
    let tracker = ContactTracker::new(device.info(), ScreenMapping::new(device.info(), [4095.0, 4095.0]));
    let (sender, receiver) = std::sync::mpsc::channel();
    let _reader = device.spawn_finger_reader(tracker, sender).unwrap();

    let event = |code, value| evdev::InputEvent::new(EV_ABS, code, value);
    let key = |value| evdev::InputEvent::new(EV_KEY, BTN_TOUCH, value);
    virtual_device
        .emit(&[
            event(ABS_MT_SLOT, 0),
            event(ABS_MT_TRACKING_ID, 1),
            event(ABS_MT_POSITION_X, 100),
            event(ABS_MT_POSITION_Y, 200),
            key(1),
        ])
        .unwrap();
    virtual_device.emit(&[event(ABS_MT_POSITION_X, 300)]).unwrap();
    virtual_device.emit(&[event(ABS_MT_TRACKING_ID, -1), key(0)]).unwrap();
    let mut got = Vec::new();
    while got.len() < 3 {
        match receiver.recv_timeout(Duration::from_secs(5)) {
            Ok(finger) => got.push((finger.phase, finger.position)),
            Err(error) => panic!("only {got:?} arrived: {error}"),
        }
    }
    assert_eq!(
        got,
        vec![
            (FingerPhase::Down, [100.0, 200.0]),
            (FingerPhase::Move, [300.0, 200.0]),
            (FingerPhase::Up, [300.0, 200.0])
        ]
    );
}
