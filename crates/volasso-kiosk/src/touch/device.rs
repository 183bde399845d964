//! Live touch input on Linux: finds the touchscreen among `/dev/input/event*`, describes it as a
//! [`DeviceInfo`], and reads its events on a thread into a channel, through the `evdev` crate.
//!
//! This is how touch reaches the appliance (see the parent module): the raw events, including
//! `SYN_DROPPED`, go to the same [`ContactTracker`] that replay tests use. The crate's
//! synchronising `Device` is not used because it hides the drop and re-syncs only the current
//! multitouch slot; instead, after a drop the reader asks a single-touch device whether it is
//! pressed (there is nothing else to know) and injects that state, while multitouch slots are
//! re-acquired by the tracker from the events that follow.
//!
//! Never: maps to the screen or recognises gestures itself; it only feeds the tracker.

use super::TouchError;
use super::contacts::{ContactTracker, FingerEvent};
use super::event::*;
use evdev::raw_stream::RawDevice;
use std::path::{Path, PathBuf};
use std::sync::mpsc::Sender;
use std::thread::JoinHandle;
use std::time::SystemTime;

/// An open touchscreen.
pub struct TouchDevice {
    path: PathBuf,
    info: DeviceInfo,
    raw: RawDevice,
}

/// The event as a [`RawEvent`], its time in microseconds since the Unix epoch (the kernel's
/// `CLOCK_REALTIME` stamp; 0 if it is before the epoch).
pub fn raw_event_from_evdev(event: &evdev::InputEvent) -> RawEvent {
    let time_us = event.timestamp().duration_since(SystemTime::UNIX_EPOCH).map_or(0, |d| d.as_micros() as u64);
    RawEvent { time_us, kind: event.event_type().0, code: event.code(), value: event.value() }
}

/// What `raw` says about itself, if it is a touchscreen.
pub fn describe(raw: &RawDevice) -> Option<DeviceInfo> {
    let name = raw.name().unwrap_or("unnamed input device");
    let axes: Vec<(u16, i32, i32)> = match raw.get_absinfo() {
        Ok(infos) => infos.map(|(code, info)| (code.0, info.minimum(), info.maximum())).collect(),
        Err(_) => Vec::new(),
    };
    let keys: Vec<u16> = raw.supported_keys().map(|keys| keys.iter().map(|key| key.0).collect()).unwrap_or_default();
    DeviceInfo::from_capabilities(name, &axes, &keys)
}

/// Every touchscreen under `/dev/input` that this process may open, by path.
pub fn find_touchscreens() -> Vec<(PathBuf, DeviceInfo)> {
    let mut found: Vec<(PathBuf, DeviceInfo)> =
        evdev::raw_stream::enumerate().filter_map(|(path, raw)| Some((path, describe(&raw)?))).collect();
    found.sort_by(|a, b| a.0.cmp(&b.0));
    found
}

/// The events that tell the tracker a single-touch device's state after a drop: pressed or
/// not, and where.
pub fn single_touch_resync(pressed: bool, device_position: [i32; 2], time_us: u64) -> Vec<RawEvent> {
    if !pressed {
        return Vec::new();
    }
    vec![
        RawEvent::new(time_us, EV_ABS, ABS_X, device_position[0]),
        RawEvent::new(time_us, EV_ABS, ABS_Y, device_position[1]),
        RawEvent::new(time_us, EV_KEY, BTN_TOUCH, 1),
        RawEvent::new(time_us, EV_SYN, SYN_REPORT, 0),
    ]
}

impl TouchDevice {
    /// Opens the touchscreen at `path`.
    pub fn open(path: &Path) -> Result<TouchDevice, TouchError> {
        let raw = RawDevice::open(path).map_err(|source| TouchError::OpenDevice { source, path: path.into() })?;
        let info = describe(&raw).ok_or_else(|| TouchError::NotATouchscreen { path: path.into() })?;
        Ok(TouchDevice { path: path.into(), info, raw })
    }

    /// Opens the first touchscreen found (by path order).
    pub fn open_first() -> Result<TouchDevice, TouchError> {
        let mut checked = 0;
        let mut candidates: Vec<(PathBuf, RawDevice, DeviceInfo)> = Vec::new();
        for (path, raw) in evdev::raw_stream::enumerate() {
            checked += 1;
            if let Some(info) = describe(&raw) {
                candidates.push((path, raw, info));
            }
        }
        candidates.sort_by(|a, b| a.0.cmp(&b.0));
        let (path, raw, info) = candidates.into_iter().next().ok_or(TouchError::NoTouchscreen { checked })?;
        Ok(TouchDevice { path, info, raw })
    }

    pub fn info(&self) -> &DeviceInfo {
        &self.info
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Reads events on a new thread and sends each as a [`RawEvent`]. The thread ends when
    /// the receiver is gone (noticed at the next event) or the device fails (unplugged).
    pub fn spawn_reader(self, sender: Sender<RawEvent>) -> Result<JoinHandle<Result<(), TouchError>>, TouchError> {
        self.spawn(move |event| sender.send(*event).is_ok())
    }

    /// As [`spawn_reader`](Self::spawn_reader), but runs the events through `tracker` on the
    /// reading thread and sends finger events.
    pub fn spawn_finger_reader(
        self,
        mut tracker: ContactTracker,
        sender: Sender<FingerEvent>,
    ) -> Result<JoinHandle<Result<(), TouchError>>, TouchError> {
        let mut fingers = Vec::new();
        self.spawn(move |event| {
            fingers.clear();
            tracker.feed(event, &mut fingers);
            fingers.iter().all(|finger| sender.send(*finger).is_ok())
        })
    }

    /// Runs the read loop on a thread; `deliver` returns false to stop.
    fn spawn(
        self,
        mut deliver: impl FnMut(&RawEvent) -> bool + Send + 'static,
    ) -> Result<JoinHandle<Result<(), TouchError>>, TouchError> {
        let TouchDevice { path, info, mut raw } = self;
        let thread_path = path.clone();
        std::thread::Builder::new()
            .name("touch-reader".into())
            .spawn(move || {
                let mut after_drop = false;
                loop {
                    let events: Vec<RawEvent> = raw
                        .fetch_events()
                        .map_err(|source| TouchError::ReadDevice { source, path: thread_path.clone() })?
                        .map(|event| raw_event_from_evdev(&event))
                        .collect();
                    for event in &events {
                        if !deliver(event) {
                            return Ok(());
                        }
                        if event.kind == EV_SYN && event.code == SYN_DROPPED {
                            after_drop = true;
                        } else if after_drop && event.is_report() {
                            after_drop = false;
                            if !info.multitouch {
                                for resync in resync_single_touch(&raw, event.time_us) {
                                    if !deliver(&resync) {
                                        return Ok(());
                                    }
                                }
                            }
                        }
                    }
                }
            })
            .map_err(|source| TouchError::ReadDevice { source, path })
    }
}

/// Queries a single-touch device's button and position now (after a drop).
fn resync_single_touch(raw: &RawDevice, time_us: u64) -> Vec<RawEvent> {
    let pressed = raw
        .get_key_state()
        .is_ok_and(|keys| keys.contains(evdev::KeyCode(BTN_TOUCH)) || keys.contains(evdev::KeyCode(BTN_LEFT)));
    let position = raw.get_abs_state().map_or([0, 0], |abs| [abs[ABS_X as usize].value, abs[ABS_Y as usize].value]);
    single_touch_resync(pressed, position, time_us)
}

#[cfg(test)]
#[path = "device_tests.rs"]
mod tests;
