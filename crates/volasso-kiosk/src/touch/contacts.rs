//! The contact tracker: raw evdev events in, [`FingerEvent`]s (down, move, up, cancel) out, once
//! per frame (`SYN_REPORT`), positions in screen pixels.
//!
//! Implements the kernel's multitouch protocol B (Documentation/input/multi-touch-protocol.rst):
//! `ABS_MT_SLOT` selects a slot, `ABS_MT_TRACKING_ID` >= 0 starts a contact in it and -1 ends
//! it, `ABS_MT_POSITION_X/Y` move it; values persist per slot, and the kernel sends only what
//! changed. Single-touch absolute devices (QEMU's usb/virtio tablet: `ABS_X/Y` with `BTN_TOUCH`
//! or `BTN_LEFT`) are tracked as one finger.
//!
//! A contact the device reports as a palm (`ABS_MT_TOOL_TYPE` [`MT_TOOL_PALM`], per slot like
//! the position) is no finger: the heel of a hand resting on the panel while a finger draws
//! gives no event, and a finger that turns out to be a palm is cancelled. It stays ignored
//! until it lifts, as libinput ignores it.
//!
//! `SYN_DROPPED` means the kernel's buffer overflowed: every event up to the next `SYN_REPORT`
//! is dropped, every contact is cancelled ([`FingerPhase::Cancel`]), and contacts are
//! re-acquired from what follows: a slot that reports a position without having been given a
//! tracking id since the drop is taken to be a finger still down. State is a fixed array of
//! [`MAX_SLOTS`] slots; slots beyond the device's declared count, unknown codes and garbage are
//! ignored.
//!
//! Never: recognises gestures (see `gestures`) or reads devices (see `device`).

use super::event::*;
use super::mapping::ScreenMapping;

/// What happened to a finger in a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FingerPhase {
    Down,
    Move,
    Up,
    /// The finger's contact is lost without a lift (events were dropped); whatever it was doing
    /// is abandoned.
    Cancel,
}

/// One finger's change in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FingerEvent {
    /// Unique for the tracker's lifetime (never reused, unlike the kernel's tracking ids).
    pub id: u64,
    pub phase: FingerPhase,
    /// Screen pixels.
    pub position: [f32; 2],
    /// The time of the frame's `SYN_REPORT`.
    pub time_us: u64,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum SlotContact {
    #[default]
    Empty,
    /// A contact; its tracking id is `None` when re-acquired after a drop.
    Active { tracking_id: Option<i32> },
    /// After `SYN_DROPPED`: whether a finger is there is not known yet.
    Unknown,
}

#[derive(Clone, Copy, Debug, Default)]
struct Slot {
    contact: SlotContact,
    /// Device units; persists across contacts, as in the kernel.
    device_position: [i32; 2],
    /// Changes since the last frame.
    lifted: bool,
    started: bool,
    moved: bool,
    /// The finger this slot's contact is reported as, once reported down.
    finger: Option<u64>,
    last_position: [f32; 2],
    /// The device says the slot's tool is a palm (persists per slot, as the position does).
    palm_tool: bool,
    /// The slot's contact has been a palm: it is ignored until it lifts.
    ignored: bool,
}

/// Protocol-B (and single-touch) state machine; see the module docs.
#[derive(Clone, Debug)]
pub struct ContactTracker {
    multitouch: bool,
    slot_count: usize,
    mapping: ScreenMapping,
    slots: [Slot; MAX_SLOTS],
    /// `None` while the device has selected a slot we do not track.
    current_slot: Option<usize>,
    /// Between `SYN_DROPPED` and the next `SYN_REPORT`.
    dropping: bool,
    /// Single-touch: `BTN_TOUCH` and `BTN_LEFT` states; the finger is down while either is.
    buttons: [bool; 2],
    next_finger_id: u64,
}

impl ContactTracker {
    pub fn new(device: &DeviceInfo, mapping: ScreenMapping) -> ContactTracker {
        ContactTracker {
            multitouch: device.multitouch,
            slot_count: device.tracked_slots(),
            mapping,
            slots: [Slot::default(); MAX_SLOTS],
            current_slot: Some(0),
            dropping: false,
            buttons: [false; 2],
            next_finger_id: 1,
        }
    }

    pub fn mapping(&self) -> &ScreenMapping {
        &self.mapping
    }

    /// Fingers currently down (reported and not yet lifted).
    pub fn active_fingers(&self) -> usize {
        self.slots.iter().filter(|slot| slot.finger.is_some()).count()
    }

    /// Feeds one event; finger events of a completed frame are appended to `out`.
    pub fn feed(&mut self, event: &RawEvent, out: &mut Vec<FingerEvent>) {
        if self.dropping {
            if event.is_report() {
                self.dropping = false;
                self.cancel_all(event.time_us, out);
            }
            return;
        }
        match (event.kind, event.code) {
            (EV_SYN, SYN_REPORT) => self.report(event.time_us, out),
            (EV_SYN, SYN_DROPPED) => self.dropping = true,
            (EV_ABS, code) if self.multitouch => self.multitouch_axis(code, event.value),
            (EV_ABS, ABS_X) => self.single_touch_axis(0, event.value),
            (EV_ABS, ABS_Y) => self.single_touch_axis(1, event.value),
            (EV_KEY, BTN_TOUCH) if !self.multitouch => self.single_touch_button(0, event.value),
            (EV_KEY, BTN_LEFT) if !self.multitouch => self.single_touch_button(1, event.value),
            _ => {}
        }
    }

    /// Cancels every contact now (a drop, a device unplugged, the UI losing focus); slots are
    /// left unknown until events say otherwise.
    pub fn cancel_all(&mut self, time_us: u64, out: &mut Vec<FingerEvent>) {
        for slot in &mut self.slots {
            if let Some(id) = slot.finger.take() {
                out.push(FingerEvent { id, phase: FingerPhase::Cancel, position: slot.last_position, time_us });
            }
            slot.contact = if self.multitouch { SlotContact::Unknown } else { SlotContact::Empty };
            slot.lifted = false;
            slot.started = false;
            slot.moved = false;
        }
        // A single-touch device's buttons are re-learnt from their next press.
        self.buttons = [false; 2];
    }

    fn multitouch_axis(&mut self, code: u16, value: i32) {
        if code == ABS_MT_SLOT {
            self.current_slot = usize::try_from(value).ok().filter(|&slot| slot < self.slot_count);
            return;
        }
        let Some(slot) = self.current_slot.map(|index| &mut self.slots[index]) else { return };
        match code {
            ABS_MT_TRACKING_ID if value < 0 => {
                if slot.contact != SlotContact::Empty {
                    slot.lifted = true;
                }
                slot.contact = SlotContact::Empty;
                slot.started = false;
            }
            // The same id again is no change (the kernel filters those; a recording may not).
            ABS_MT_TRACKING_ID if slot.contact != (SlotContact::Active { tracking_id: Some(value) }) => {
                if matches!(slot.contact, SlotContact::Active { .. }) {
                    slot.lifted = true;
                }
                slot.contact = SlotContact::Active { tracking_id: Some(value) };
                slot.started = true;
            }
            ABS_MT_TOOL_TYPE => slot.palm_tool = value == MT_TOOL_PALM,
            ABS_MT_POSITION_X | ABS_MT_POSITION_Y => {
                slot.device_position[usize::from(code == ABS_MT_POSITION_Y)] = value;
                slot.moved = true;
                if slot.contact == SlotContact::Unknown {
                    slot.contact = SlotContact::Active { tracking_id: None };
                    slot.started = true;
                }
            }
            _ => {}
        }
    }

    fn single_touch_axis(&mut self, axis: usize, value: i32) {
        self.slots[0].device_position[axis] = value;
        self.slots[0].moved = true;
    }

    fn single_touch_button(&mut self, button: usize, value: i32) {
        let was_down = self.buttons.iter().any(|&b| b);
        // Value 2 is autorepeat: still pressed.
        self.buttons[button] = value != 0;
        let down = self.buttons.iter().any(|&b| b);
        let slot = &mut self.slots[0];
        if down && !was_down {
            slot.contact = SlotContact::Active { tracking_id: None };
            slot.started = true;
        } else if !down && was_down {
            slot.contact = SlotContact::Empty;
            slot.lifted = true;
            slot.started = false;
        }
    }

    /// Ends a frame: lifts first (a slot may lift and start again in one frame), then moves
    /// and new contacts.
    fn report(&mut self, time_us: u64, out: &mut Vec<FingerEvent>) {
        for slot in &mut self.slots {
            let ended = slot.lifted || (slot.started && slot.finger.is_some());
            if ended {
                if let Some(id) = slot.finger.take() {
                    out.push(FingerEvent { id, phase: FingerPhase::Up, position: slot.last_position, time_us });
                }
            }
            if ended || slot.started {
                slot.ignored = false;
            }
            if slot.palm_tool && matches!(slot.contact, SlotContact::Active { .. }) {
                // A palm: what it began as a finger is abandoned, and it is no finger until it lifts.
                if let Some(id) = slot.finger.take() {
                    out.push(FingerEvent { id, phase: FingerPhase::Cancel, position: slot.last_position, time_us });
                }
                slot.ignored = true;
            }
        }
        for index in 0..MAX_SLOTS {
            let slot = &self.slots[index];
            let active = matches!(slot.contact, SlotContact::Active { .. });
            let (started, moved, finger) = (slot.started, slot.moved, slot.finger);
            let active = active && !slot.ignored;
            let position = self.mapping.map(slot.device_position).position;
            let slot = &mut self.slots[index];
            if active && finger.is_none() && (started || moved) {
                let id = self.next_finger_id;
                self.next_finger_id += 1;
                slot.finger = Some(id);
                slot.last_position = position;
                out.push(FingerEvent { id, phase: FingerPhase::Down, position, time_us });
            } else if let (true, Some(id)) = (moved && active && position != slot.last_position, finger) {
                slot.last_position = position;
                out.push(FingerEvent { id, phase: FingerPhase::Move, position, time_us });
            }
            slot.lifted = false;
            slot.started = false;
            slot.moved = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn screen_device() -> DeviceInfo {
        // Device units equal screen pixels, so expectations read directly.
        DeviceInfo {
            x: AxisRange::new(0, 1000),
            y: AxisRange::new(0, 1000),
            slot_count: 4,
            ..DeviceInfo::virtual_touchscreen()
        }
    }

    fn tracker(device: &DeviceInfo) -> ContactTracker {
        ContactTracker::new(device, ScreenMapping::new(device, [1000.0, 1000.0]))
    }

    fn run(tracker: &mut ContactTracker, frames: &[&[(u16, u16, i32)]]) -> Vec<(u64, FingerPhase, [f32; 2])> {
        let mut out = Vec::new();
        for (index, frame) in frames.iter().enumerate() {
            let time_us = index as u64 * 8000;
            for &(kind, code, value) in frame.iter() {
                tracker.feed(&RawEvent::new(time_us, kind, code, value), &mut out);
            }
            tracker.feed(&RawEvent::new(time_us, EV_SYN, SYN_REPORT, 0), &mut out);
        }
        out.iter().map(|e| (e.id, e.phase, e.position)).collect()
    }

    use FingerPhase::*;

    #[test]
    fn two_fingers_down_move_and_lift() {
        let mut t = tracker(&screen_device());
        let got = run(
            &mut t,
            &[
                &[
                    (EV_ABS, ABS_MT_SLOT, 0),
                    (EV_ABS, ABS_MT_TRACKING_ID, 10),
                    (EV_ABS, ABS_MT_POSITION_X, 100),
                    (EV_ABS, ABS_MT_POSITION_Y, 200),
                ],
                &[
                    (EV_ABS, ABS_MT_SLOT, 1),
                    (EV_ABS, ABS_MT_TRACKING_ID, 11),
                    (EV_ABS, ABS_MT_POSITION_X, 300),
                    (EV_ABS, ABS_MT_POSITION_Y, 400),
                ],
                // Only y changes on slot 1: x persists.
                &[(EV_ABS, ABS_MT_POSITION_Y, 450)],
                &[(EV_ABS, ABS_MT_SLOT, 0), (EV_ABS, ABS_MT_TRACKING_ID, -1)],
                &[(EV_ABS, ABS_MT_SLOT, 1), (EV_ABS, ABS_MT_TRACKING_ID, -1)],
            ],
        );
        assert_eq!(
            got,
            vec![
                (1, Down, [100.0, 200.0]),
                (2, Down, [300.0, 400.0]),
                (2, Move, [300.0, 450.0]),
                (1, Up, [100.0, 200.0]),
                (2, Up, [300.0, 450.0]),
            ]
        );
        assert_eq!(t.active_fingers(), 0);
    }

    #[test]
    fn a_palm_is_no_finger_and_a_finger_that_becomes_one_is_cancelled() {
        let mut t = tracker(&screen_device());
        let got = run(
            &mut t,
            &[
                &[(EV_ABS, ABS_MT_SLOT, 0), (EV_ABS, ABS_MT_TRACKING_ID, 10), (EV_ABS, ABS_MT_POSITION_X, 100)],
                // The heel of the hand lands as a palm while the finger moves: no event for it.
                &[
                    (EV_ABS, ABS_MT_POSITION_X, 110),
                    (EV_ABS, ABS_MT_SLOT, 1),
                    (EV_ABS, ABS_MT_TRACKING_ID, 11),
                    (EV_ABS, ABS_MT_TOOL_TYPE, MT_TOOL_PALM),
                    (EV_ABS, ABS_MT_POSITION_X, 600),
                ],
                &[(EV_ABS, ABS_MT_POSITION_X, 620), (EV_ABS, ABS_MT_SLOT, 0), (EV_ABS, ABS_MT_POSITION_X, 120)],
                // Still a palm when the controller calls it a finger again: ignored until it lifts.
                &[(EV_ABS, ABS_MT_SLOT, 1), (EV_ABS, ABS_MT_TOOL_TYPE, 0), (EV_ABS, ABS_MT_POSITION_X, 630)],
                &[(EV_ABS, ABS_MT_TRACKING_ID, -1)],
                // The next contact in that slot is a finger (the tool type persists: finger).
                &[(EV_ABS, ABS_MT_TRACKING_ID, 12), (EV_ABS, ABS_MT_POSITION_X, 700)],
                // A finger that turns out to be a palm is cancelled, then silent.
                &[(EV_ABS, ABS_MT_TOOL_TYPE, MT_TOOL_PALM)],
                &[(EV_ABS, ABS_MT_POSITION_X, 720)],
                &[(EV_ABS, ABS_MT_TRACKING_ID, -1), (EV_ABS, ABS_MT_SLOT, 0), (EV_ABS, ABS_MT_TRACKING_ID, -1)],
            ],
        );
        assert_eq!(
            got,
            vec![
                (1, Down, [100.0, 0.0]),
                (1, Move, [110.0, 0.0]),
                (1, Move, [120.0, 0.0]),
                (2, Down, [700.0, 0.0]),
                (2, Cancel, [700.0, 0.0]),
                (1, Up, [120.0, 0.0]),
            ]
        );
        assert_eq!(t.active_fingers(), 0);
    }

    #[test]
    fn a_new_contact_in_the_same_slot_gets_a_new_finger_and_keeps_the_slot_position() {
        let mut t = tracker(&screen_device());
        let got = run(
            &mut t,
            &[
                &[(EV_ABS, ABS_MT_TRACKING_ID, 5), (EV_ABS, ABS_MT_POSITION_X, 10), (EV_ABS, ABS_MT_POSITION_Y, 20)],
                // Lift and touch again at the same place within one frame: the kernel sends no
                // position, since it did not change.
                &[(EV_ABS, ABS_MT_TRACKING_ID, -1), (EV_ABS, ABS_MT_TRACKING_ID, 6)],
            ],
        );
        assert_eq!(got, vec![(1, Down, [10.0, 20.0]), (1, Up, [10.0, 20.0]), (2, Down, [10.0, 20.0])]);
    }

    #[test]
    fn slots_beyond_the_declared_count_are_ignored() {
        let mut t = tracker(&screen_device());
        let got = run(
            &mut t,
            &[
                &[(EV_ABS, ABS_MT_SLOT, 4), (EV_ABS, ABS_MT_TRACKING_ID, 1), (EV_ABS, ABS_MT_POSITION_X, 1)],
                &[(EV_ABS, ABS_MT_SLOT, -3), (EV_ABS, ABS_MT_TRACKING_ID, 1), (EV_ABS, ABS_MT_POSITION_X, 1)],
                &[(EV_ABS, ABS_MT_SLOT, i32::MAX), (EV_ABS, ABS_MT_TRACKING_ID, 1)],
                &[(EV_ABS, ABS_MT_SLOT, 3), (EV_ABS, ABS_MT_TRACKING_ID, 2), (EV_ABS, ABS_MT_POSITION_X, 7)],
            ],
        );
        assert_eq!(got, vec![(1, Down, [7.0, 0.0])]);
    }

    #[test]
    fn syn_dropped_cancels_everything_and_reacquires_fingers_that_report() {
        let mut t = tracker(&screen_device());
        let got = run(
            &mut t,
            &[
                &[(EV_ABS, ABS_MT_SLOT, 0), (EV_ABS, ABS_MT_TRACKING_ID, 1), (EV_ABS, ABS_MT_POSITION_X, 100)],
                &[(EV_ABS, ABS_MT_SLOT, 1), (EV_ABS, ABS_MT_TRACKING_ID, 2), (EV_ABS, ABS_MT_POSITION_X, 200)],
                // The drop: these events are lost, including a lift of slot 0 ...
                &[(EV_SYN, SYN_DROPPED, 0), (EV_ABS, ABS_MT_SLOT, 0), (EV_ABS, ABS_MT_TRACKING_ID, -1)],
                // ... slot 1's finger is still down and moves: re-acquired as a new finger.
                &[(EV_ABS, ABS_MT_SLOT, 1), (EV_ABS, ABS_MT_POSITION_X, 250)],
                &[(EV_ABS, ABS_MT_POSITION_X, 260)],
                &[(EV_ABS, ABS_MT_TRACKING_ID, -1)],
            ],
        );
        assert_eq!(
            got,
            vec![
                (1, Down, [100.0, 0.0]),
                (2, Down, [200.0, 0.0]),
                (1, Cancel, [100.0, 0.0]),
                (2, Cancel, [200.0, 0.0]),
                (3, Down, [250.0, 0.0]),
                (3, Move, [260.0, 0.0]),
                (3, Up, [260.0, 0.0]),
            ]
        );
        assert_eq!(t.active_fingers(), 0);
    }

    #[test]
    fn single_touch_tablets_are_one_finger() {
        let device = DeviceInfo { multitouch: false, slot_count: 1, ..screen_device() };
        let mut t = tracker(&device);
        let got = run(
            &mut t,
            &[
                // Hover: a tablet reports positions without a press.
                &[(EV_ABS, ABS_X, 10), (EV_ABS, ABS_Y, 10)],
                &[(EV_KEY, BTN_LEFT, 1)],
                &[(EV_ABS, ABS_X, 30)],
                &[(EV_KEY, BTN_TOUCH, 1)],
                &[(EV_KEY, BTN_LEFT, 0), (EV_ABS, ABS_Y, 40)],
                &[(EV_KEY, BTN_TOUCH, 0)],
                // MT events on a single-touch device are ignored.
                &[(EV_ABS, ABS_MT_TRACKING_ID, 3), (EV_ABS, ABS_MT_POSITION_X, 500)],
            ],
        );
        assert_eq!(
            got,
            vec![(1, Down, [10.0, 10.0]), (1, Move, [30.0, 10.0]), (1, Move, [30.0, 40.0]), (1, Up, [30.0, 40.0])]
        );
    }

    #[test]
    fn rotated_mapping_is_applied() {
        let device = screen_device();
        let mapping =
            ScreenMapping::new(&device, [1000.0, 1000.0]).with_rotation(super::super::mapping::Rotation::Degrees180);
        let mut t = ContactTracker::new(&device, mapping);
        let got = run(
            &mut t,
            &[&[(EV_ABS, ABS_MT_TRACKING_ID, 1), (EV_ABS, ABS_MT_POSITION_X, 100), (EV_ABS, ABS_MT_POSITION_Y, 300)]],
        );
        assert_eq!(got, vec![(1, Down, [900.0, 700.0])]);
    }
}
