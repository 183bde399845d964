//! Linux input events as plain data: [`RawEvent`] (the kernel's `struct input_event`), the names
//! of the event types and codes a touchscreen uses, and [`DeviceInfo`] (what a touchscreen
//! declares about itself: axis ranges, slot count, multitouch or not).
//!
//! Numbers are those of `linux/input-event-codes.h`; names are the kernel's, so recordings and
//! evemu files read the same as `evtest` output.
//!
//! Never: opens devices or interprets events (see `device` and `contacts`).

/// One `struct input_event`: a timestamp, an event type (`EV_*`), a code and a value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct RawEvent {
    /// Microseconds since the recording's (or the device clock's) origin.
    pub time_us: u64,
    /// The event type, `EV_SYN`, `EV_KEY`, `EV_ABS`, ...
    pub kind: u16,
    pub code: u16,
    pub value: i32,
}

/// The longest pause a recording may hold between an event and the next: an hour, longer than
/// any of the app's timers (the idle timeout is two minutes), which a replay steps through in
/// under a second (225,000 frames of 16 ms; about 2 µs each on the start screen). A replay moves
/// its clock through every frame of a pause, so a lying timestamp (a jump of centuries) would
/// keep it busy for weeks.
pub const MAX_PAUSE_US: u64 = 3_600_000_000;

/// Refuses a recording's event that comes more than [`MAX_PAUSE_US`] after the latest one
/// before it. Times that go back are not pauses (a replay never moves its clock back).
#[derive(Clone, Copy, Debug, Default)]
pub struct PauseCheck {
    latest_us: Option<u64>,
}

impl PauseCheck {
    /// Checks the next event's time; the problem in words if it jumps too far.
    pub fn next(&mut self, time_us: u64) -> Result<(), String> {
        let latest_us = self.latest_us.map_or(time_us, |latest| latest.max(time_us));
        if let Some(before) = self.latest_us
            && time_us - before.min(time_us) > MAX_PAUSE_US
        {
            return Err(format!(
                "the event at {} s comes {} s after the one before it (at {} s); a recording may pause at most {} s between events",
                seconds(time_us),
                seconds(time_us - before),
                seconds(before),
                MAX_PAUSE_US / 1_000_000
            ));
        }
        self.latest_us = Some(latest_us);
        Ok(())
    }
}

fn seconds(time_us: u64) -> String {
    format!("{}.{:06}", time_us / 1_000_000, time_us % 1_000_000)
}

impl RawEvent {
    pub const fn new(time_us: u64, kind: u16, code: u16, value: i32) -> RawEvent {
        RawEvent { time_us, kind, code, value }
    }

    /// Whether this event closes a frame (`EV_SYN SYN_REPORT`).
    pub fn is_report(&self) -> bool {
        self.kind == EV_SYN && self.code == SYN_REPORT
    }
}

pub const EV_SYN: u16 = 0x00;
pub const EV_KEY: u16 = 0x01;
pub const EV_REL: u16 = 0x02;
pub const EV_ABS: u16 = 0x03;
pub const EV_MSC: u16 = 0x04;

pub const SYN_REPORT: u16 = 0;
pub const SYN_CONFIG: u16 = 1;
pub const SYN_MT_REPORT: u16 = 2;
pub const SYN_DROPPED: u16 = 3;

pub const BTN_LEFT: u16 = 0x110;
pub const BTN_RIGHT: u16 = 0x111;
pub const BTN_MIDDLE: u16 = 0x112;
pub const BTN_TOOL_PEN: u16 = 0x140;
pub const BTN_TOOL_FINGER: u16 = 0x145;
pub const BTN_TOUCH: u16 = 0x14a;
pub const BTN_TOOL_DOUBLETAP: u16 = 0x14d;
pub const BTN_TOOL_TRIPLETAP: u16 = 0x14e;
pub const BTN_TOOL_QUADTAP: u16 = 0x14f;
pub const BTN_TOOL_QUINTTAP: u16 = 0x148;

pub const REL_X: u16 = 0x00;
pub const REL_Y: u16 = 0x01;
pub const REL_WHEEL: u16 = 0x08;

pub const ABS_X: u16 = 0x00;
pub const ABS_Y: u16 = 0x01;
pub const ABS_PRESSURE: u16 = 0x18;
pub const ABS_MT_SLOT: u16 = 0x2f;
pub const ABS_MT_TOUCH_MAJOR: u16 = 0x30;
pub const ABS_MT_TOUCH_MINOR: u16 = 0x31;
pub const ABS_MT_WIDTH_MAJOR: u16 = 0x32;
pub const ABS_MT_WIDTH_MINOR: u16 = 0x33;
pub const ABS_MT_ORIENTATION: u16 = 0x34;
pub const ABS_MT_POSITION_X: u16 = 0x35;
pub const ABS_MT_POSITION_Y: u16 = 0x36;
pub const ABS_MT_TOOL_TYPE: u16 = 0x37;
/// `ABS_MT_TOOL_TYPE`'s value for a palm (`MT_TOOL_PALM`): a touch controller's judgement that
/// the contact is not a fingertip (hid-multitouch reports a contact without its confidence bit
/// so).
pub const MT_TOOL_PALM: i32 = 2;
pub const ABS_MT_TRACKING_ID: u16 = 0x39;
pub const ABS_MT_PRESSURE: u16 = 0x3a;

pub const MSC_SCAN: u16 = 0x04;
pub const MSC_TIMESTAMP: u16 = 0x05;

/// The largest valid event type (`EV_MAX`) and code (`KEY_MAX`); anything above is garbage.
pub const EV_MAX: u16 = 0x1f;
pub const KEY_MAX: u16 = 0x2ff;

const TYPE_NAMES: &[(u16, &str)] =
    &[(EV_SYN, "EV_SYN"), (EV_KEY, "EV_KEY"), (EV_REL, "EV_REL"), (EV_ABS, "EV_ABS"), (EV_MSC, "EV_MSC")];

const SYN_NAMES: &[(u16, &str)] = &[
    (SYN_REPORT, "SYN_REPORT"),
    (SYN_CONFIG, "SYN_CONFIG"),
    (SYN_MT_REPORT, "SYN_MT_REPORT"),
    (SYN_DROPPED, "SYN_DROPPED"),
];

const KEY_NAMES: &[(u16, &str)] = &[
    (BTN_LEFT, "BTN_LEFT"),
    (BTN_RIGHT, "BTN_RIGHT"),
    (BTN_MIDDLE, "BTN_MIDDLE"),
    (BTN_TOOL_PEN, "BTN_TOOL_PEN"),
    (BTN_TOOL_FINGER, "BTN_TOOL_FINGER"),
    (BTN_TOUCH, "BTN_TOUCH"),
    (BTN_TOOL_DOUBLETAP, "BTN_TOOL_DOUBLETAP"),
    (BTN_TOOL_TRIPLETAP, "BTN_TOOL_TRIPLETAP"),
    (BTN_TOOL_QUADTAP, "BTN_TOOL_QUADTAP"),
    (BTN_TOOL_QUINTTAP, "BTN_TOOL_QUINTTAP"),
];

const REL_NAMES: &[(u16, &str)] = &[(REL_X, "REL_X"), (REL_Y, "REL_Y"), (REL_WHEEL, "REL_WHEEL")];

const ABS_NAMES: &[(u16, &str)] = &[
    (ABS_X, "ABS_X"),
    (ABS_Y, "ABS_Y"),
    (ABS_PRESSURE, "ABS_PRESSURE"),
    (ABS_MT_SLOT, "ABS_MT_SLOT"),
    (ABS_MT_TOUCH_MAJOR, "ABS_MT_TOUCH_MAJOR"),
    (ABS_MT_TOUCH_MINOR, "ABS_MT_TOUCH_MINOR"),
    (ABS_MT_WIDTH_MAJOR, "ABS_MT_WIDTH_MAJOR"),
    (ABS_MT_WIDTH_MINOR, "ABS_MT_WIDTH_MINOR"),
    (ABS_MT_ORIENTATION, "ABS_MT_ORIENTATION"),
    (ABS_MT_POSITION_X, "ABS_MT_POSITION_X"),
    (ABS_MT_POSITION_Y, "ABS_MT_POSITION_Y"),
    (ABS_MT_TOOL_TYPE, "ABS_MT_TOOL_TYPE"),
    (ABS_MT_TRACKING_ID, "ABS_MT_TRACKING_ID"),
    (ABS_MT_PRESSURE, "ABS_MT_PRESSURE"),
];

const MSC_NAMES: &[(u16, &str)] = &[(MSC_SCAN, "MSC_SCAN"), (MSC_TIMESTAMP, "MSC_TIMESTAMP")];

fn code_table(kind: u16) -> &'static [(u16, &'static str)] {
    match kind {
        EV_SYN => SYN_NAMES,
        EV_KEY => KEY_NAMES,
        EV_REL => REL_NAMES,
        EV_ABS => ABS_NAMES,
        EV_MSC => MSC_NAMES,
        _ => &[],
    }
}

/// The kernel's name of an event type, if it is one we name.
pub fn type_name(kind: u16) -> Option<&'static str> {
    TYPE_NAMES.iter().find(|(number, _)| *number == kind).map(|(_, name)| *name)
}

/// The event type called `name` (`EV_ABS`), if it is one we name.
pub fn type_from_name(name: &str) -> Option<u16> {
    TYPE_NAMES.iter().find(|(_, n)| *n == name).map(|(number, _)| *number)
}

/// The kernel's name of `code` within event type `kind` (`ABS_MT_SLOT`), if we name it.
pub fn code_name(kind: u16, code: u16) -> Option<&'static str> {
    code_table(kind).iter().find(|(number, _)| *number == code).map(|(_, name)| *name)
}

/// The code called `name` within event type `kind`, if we name it.
pub fn code_from_name(kind: u16, name: &str) -> Option<u16> {
    code_table(kind).iter().find(|(_, n)| *n == name).map(|(number, _)| *number)
}

/// The range a device reports on one absolute axis (both ends inclusive, as `input_absinfo`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AxisRange {
    pub minimum: i32,
    pub maximum: i32,
}

impl AxisRange {
    pub const fn new(minimum: i32, maximum: i32) -> AxisRange {
        AxisRange { minimum, maximum }
    }

    /// `maximum - minimum` as a float, never below 1 (a degenerate axis must not divide by 0).
    pub fn span(&self) -> f64 {
        (self.maximum as f64 - self.minimum as f64).max(1.0)
    }
}

/// The most multitouch slots tracked; a device declaring more is tracked on its first
/// `MAX_SLOTS` (fingers eleven and up are not needed by any gesture).
pub const MAX_SLOTS: usize = 16;

/// What a touchscreen says about itself.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeviceInfo {
    pub name: String,
    /// The position axes: `ABS_MT_POSITION_X/Y` on a multitouch device, `ABS_X/Y` otherwise.
    pub x: AxisRange,
    pub y: AxisRange,
    /// Multitouch slots declared (`ABS_MT_SLOT` maximum + 1); 1 on a single-touch device.
    pub slot_count: usize,
    /// Type-B multitouch (slots and tracking ids) rather than one absolute pointer.
    pub multitouch: bool,
}

impl DeviceInfo {
    /// The device that replay scripts are compiled for: a ten-finger type-B touchscreen with
    /// the 15-bit axes of QEMU's and most USB HID touch panels.
    pub fn virtual_touchscreen() -> DeviceInfo {
        DeviceInfo {
            name: "volasso virtual touchscreen".into(),
            x: AxisRange::new(0, 32767),
            y: AxisRange::new(0, 32767),
            slot_count: 10,
            multitouch: true,
        }
    }

    /// A single-touch absolute pointer such as QEMU's usb-tablet or virtio-tablet.
    pub fn virtual_tablet() -> DeviceInfo {
        DeviceInfo {
            name: "volasso virtual tablet".into(),
            x: AxisRange::new(0, 32767),
            y: AxisRange::new(0, 32767),
            slot_count: 1,
            multitouch: false,
        }
    }

    /// Slots the contact tracker follows: the declared count, at most [`MAX_SLOTS`].
    pub fn tracked_slots(&self) -> usize {
        self.slot_count.clamp(1, MAX_SLOTS)
    }

    /// Classifies a device from its absolute axes `(code, minimum, maximum)` and its keys, as
    /// found through evdev or in an evemu description. `None` when it is no touchscreen:
    /// neither `ABS_MT_POSITION_X/Y`, nor `ABS_X/Y` with `BTN_TOUCH` or `BTN_LEFT`.
    pub fn from_capabilities(name: &str, axes: &[(u16, i32, i32)], keys: &[u16]) -> Option<DeviceInfo> {
        let axis = |code: u16| axes.iter().find(|(c, _, _)| *c == code).map(|&(_, min, max)| AxisRange::new(min, max));
        if let (Some(x), Some(y)) = (axis(ABS_MT_POSITION_X), axis(ABS_MT_POSITION_Y)) {
            // A device with MT axes but no ABS_MT_SLOT speaks protocol A; its frames still come
            // through one slot, so it is tracked as one finger.
            let slot_count = axis(ABS_MT_SLOT).map_or(1, |slots| (slots.maximum.max(0) as usize).saturating_add(1));
            return Some(DeviceInfo { name: name.into(), x, y, slot_count, multitouch: axis(ABS_MT_SLOT).is_some() });
        }
        let has_button = keys.contains(&BTN_TOUCH) || keys.contains(&BTN_LEFT);
        match (axis(ABS_X), axis(ABS_Y)) {
            (Some(x), Some(y)) if has_button => {
                Some(DeviceInfo { name: name.into(), x, y, slot_count: 1, multitouch: false })
            }
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_numbers_round_trip() {
        for kind in [EV_SYN, EV_KEY, EV_REL, EV_ABS, EV_MSC] {
            let name = type_name(kind).unwrap();
            assert_eq!(type_from_name(name), Some(kind));
            for &(code, code_text) in code_table(kind) {
                assert_eq!(code_name(kind, code), Some(code_text));
                assert_eq!(code_from_name(kind, code_text), Some(code));
            }
        }
        assert_eq!(code_from_name(EV_ABS, "BTN_TOUCH"), None, "names are per type");
        assert_eq!(code_name(EV_ABS, ABS_MT_TRACKING_ID), Some("ABS_MT_TRACKING_ID"));
        assert_eq!(ABS_MT_TRACKING_ID, 57);
        assert_eq!(BTN_TOUCH, 330);
    }

    #[test]
    fn capabilities_classify_multitouch_single_touch_and_others() {
        let mt = DeviceInfo::from_capabilities(
            "panel",
            &[
                (ABS_X, 0, 4095),
                (ABS_Y, 0, 4095),
                (ABS_MT_SLOT, 0, 9),
                (ABS_MT_POSITION_X, 0, 1919),
                (ABS_MT_POSITION_Y, 0, 1079),
            ],
            &[BTN_TOUCH],
        )
        .unwrap();
        assert!(mt.multitouch);
        assert_eq!(mt.slot_count, 10);
        assert_eq!(mt.x, AxisRange::new(0, 1919), "MT axes win over the legacy ones");

        let tablet =
            DeviceInfo::from_capabilities("QEMU", &[(ABS_X, 0, 32767), (ABS_Y, 0, 32767)], &[BTN_LEFT]).unwrap();
        assert!(!tablet.multitouch);
        assert_eq!(tablet.slot_count, 1);

        assert!(DeviceInfo::from_capabilities("joystick", &[(ABS_X, -128, 127), (ABS_Y, -128, 127)], &[]).is_none());
        assert!(DeviceInfo::from_capabilities("keyboard", &[], &[BTN_LEFT]).is_none());
    }

    #[test]
    fn tracked_slots_are_bounded() {
        let mut info = DeviceInfo::virtual_touchscreen();
        info.slot_count = 1 << 20;
        assert_eq!(info.tracked_slots(), MAX_SLOTS);
        info.slot_count = 0;
        assert_eq!(info.tracked_slots(), 1);
    }
}
