//! A simulated finger: one [`TouchCommand`] -> the raw evdev events a real touchscreen would
//! send for it, protocol B on a multitouch device (slots, tracking ids, only changed values,
//! `BTN_TOUCH`), `ABS_X/Y` + `BTN_TOUCH` on a single-touch one.
//!
//! Timing is finger-like: a frame every [`MOVE_INTERVAL_US`], paths interpolated along their
//! length at about [`DRAG_SPEED_PX_PER_S`], taps held [`TAP_HOLD_US`], and a little positional
//! jitter ([`JITTER_PX`], from the crate's seeded SplitMix64) on every point except where a
//! finger lands and lifts, so gestures end exactly where the script says. A [`FingerStyle`]
//! changes the speed and the jitter: a slow, shaking fingertip on a noisy panel.
//!
//! Never: feeds the events anywhere; the runner does.

use super::{ElementLocator, Rect, ScriptError, SwipeDirection, TouchCommand};
use crate::rng::{SplitMix64, hash64};
use crate::touch::event::*;
use crate::touch::mapping::ScreenMapping;

/// Time between two frames while fingers move (a 125 Hz touch controller).
pub const MOVE_INTERVAL_US: u64 = 8_000;
/// How long a tap's finger stays down.
pub const TAP_HOLD_US: u64 = 70_000;
/// From the first tap's lift to the second's touch in a double tap.
pub const DOUBLE_TAP_GAP_US: u64 = 120_000;
/// Finger speed along drags and lassos.
pub const DRAG_SPEED_PX_PER_S: f32 = 800.0;
/// Frames of a swipe (120 ms: a flick).
pub const SWIPE_FRAMES: usize = 15;
/// Frames of a pinch, pan or rotation.
pub const TWO_FINGER_FRAMES: usize = 30;
/// Standard deviation of the positional jitter.
pub const JITTER_PX: f32 = 0.4;
/// Rest after a command before the next may start, longer than the double-tap interval so
/// that two scripted taps never make a double tap.
pub const GAP_AFTER_TOUCH_US: u64 = 400_000;
/// How the simulated finger moves: its speed along drags, lassos and paths, and the jitter of
/// the points it reports. The script command `finger` sets it for the commands after it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FingerStyle {
    /// Standard deviation of each reported point's jitter, in x and in y (screen pixels).
    pub jitter_px: f32,
    /// Speed along drags, lassos and paths.
    pub speed_px_per_s: f32,
}

impl Default for FingerStyle {
    fn default() -> FingerStyle {
        FingerStyle { jitter_px: JITTER_PX, speed_px_per_s: DRAG_SPEED_PX_PER_S }
    }
}

impl FingerStyle {
    /// The jitters a `finger` line may ask for: none up to a tremor several millimetres wide.
    pub const JITTER_RANGE_PX: std::ops::RangeInclusive<f32> = 0.0..=20.0;
    /// The speeds a `finger` line may ask for: a careful crawl to a flick.
    pub const SPEED_RANGE_PX_PER_S: std::ops::RangeInclusive<f32> = 20.0..=5000.0;
}

/// Seed of the jitter (mixed with the command's start time).
const JITTER_SEED: u64 = 0x766f_6c61_7373_6f31;
/// Most frames one path is cut into.
const MAX_PATH_FRAMES: usize = 2_000;

/// The raw events of `command`, starting at `start_time_us`, on `device`, with elements placed
/// by `locator`. The device spans the locator's whole screen (identity mapping). The finger
/// moves as [`FingerStyle::default`]; the jitter is seeded by the start time.
pub fn touch_events(
    command: &TouchCommand,
    locator: &dyn ElementLocator,
    device: &DeviceInfo,
    start_time_us: u64,
) -> Result<Vec<RawEvent>, ScriptError> {
    touch_events_seeded(command, locator, device, start_time_us, start_time_us, &FingerStyle::default())
}

/// As [`touch_events`], with the finger moving as `style` and its jitter seeded by
/// `jitter_seed`: a runner whose clock depends on how long background work took (the replay
/// harness's idle waits) still draws the same path for the same command.
pub fn touch_events_seeded(
    command: &TouchCommand,
    locator: &dyn ElementLocator,
    device: &DeviceInfo,
    start_time_us: u64,
    jitter_seed: u64,
    style: &FingerStyle,
) -> Result<Vec<RawEvent>, ScriptError> {
    let size = locator.screen_size();
    if !(size.iter().all(|v| v.is_finite() && *v >= 1.0)) {
        return Err(ScriptError::BadScreen { size });
    }
    let rect = element(locator, command.element())?;
    let two_fingers =
        matches!(command, TouchCommand::Pinch { .. } | TouchCommand::Pan { .. } | TouchCommand::Rotate { .. });
    if two_fingers && !device.multitouch {
        return Err(ScriptError::NeedsMultitouch { command: command.keyword(), device: device.name.clone() });
    }
    let mut finger = Finger::new(device, ScreenMapping::new(device, size), start_time_us, jitter_seed, *style);
    let centre = rect.point([0.5, 0.5]);
    let short_side = rect.width.min(rect.height);
    match command {
        TouchCommand::Tap { at, .. } => finger.tap(rect.point(*at)),
        TouchCommand::DoubleTap { at, .. } => {
            finger.tap(rect.point(*at));
            finger.time_us += DOUBLE_TAP_GAP_US;
            finger.tap(rect.point(*at));
        }
        TouchCommand::Press { at, hold_ms, .. } => finger.hold(rect.point(*at), hold_ms * 1000),
        TouchCommand::Drag { from, to, .. } => finger.stroke(&[rect.point(*from), rect.point(*to)]),
        TouchCommand::Lasso { points, .. } => {
            let mut path: Vec<[f32; 2]> = points.iter().map(|p| rect.point(*p)).collect();
            // A lasso closes on itself, as a finger would draw it.
            path.extend(path.first().copied());
            finger.stroke(&path);
        }
        TouchCommand::Path { points, .. } => {
            finger.stroke(&points.iter().map(|p| rect.point(*p)).collect::<Vec<_>>());
        }
        TouchCommand::Swipe { direction, .. } => {
            let (from, to) = match direction {
                SwipeDirection::Left => ([0.8, 0.5], [0.2, 0.5]),
                SwipeDirection::Right => ([0.2, 0.5], [0.8, 0.5]),
                SwipeDirection::Up => ([0.5, 0.8], [0.5, 0.2]),
                SwipeDirection::Down => ([0.5, 0.2], [0.5, 0.8]),
            };
            finger.stroke_frames(&[rect.point(from), rect.point(to)], SWIPE_FRAMES);
        }
        TouchCommand::Pinch { scale, .. } => {
            // Start small enough that the spread fingers stay inside the element.
            let start = 0.6 * short_side / scale.max(1.0);
            finger.two_fingers(|t| {
                let half = 0.5 * start * (1.0 + (scale - 1.0) * t);
                [[centre[0] - half, centre[1]], [centre[0] + half, centre[1]]]
            });
        }
        TouchCommand::Pan { offset, .. } => {
            let half = 0.15 * short_side;
            let shift = [offset[0] * rect.width, offset[1] * rect.height];
            finger.two_fingers(|t| {
                let c = [centre[0] + shift[0] * t, centre[1] + shift[1] * t];
                [[c[0] - half, c[1]], [c[0] + half, c[1]]]
            });
        }
        TouchCommand::Rotate { angle_degrees, .. } => {
            let radius = 0.25 * short_side;
            finger.two_fingers(|t| {
                let (sin, cos) = (angle_degrees.to_radians() * t).sin_cos();
                let arm = [radius * cos, radius * sin];
                [[centre[0] - arm[0], centre[1] - arm[1]], [centre[0] + arm[0], centre[1] + arm[1]]]
            });
        }
    }
    Ok(finger.events)
}

fn element(locator: &dyn ElementLocator, name: &str) -> Result<Rect, ScriptError> {
    let rect = locator.element_rect(name).ok_or_else(|| ScriptError::UnknownElement { element: name.into() })?;
    let usable = [rect.x, rect.y, rect.width, rect.height].iter().all(|v| v.is_finite())
        && rect.width > 0.0
        && rect.height > 0.0;
    if !usable {
        return Err(ScriptError::EmptyElement { element: name.into(), rect });
    }
    Ok(rect)
}

/// Up to two simulated fingers writing events as a touch controller would.
struct Finger {
    multitouch: bool,
    mapping: ScreenMapping,
    time_us: u64,
    events: Vec<RawEvent>,
    rng: SplitMix64,
    style: FingerStyle,
    /// The slot the device last selected (`None` before the first).
    current_slot: Option<i32>,
    /// Per slot: the last device position sent (the kernel sends only changes).
    sent_position: [Option<[i32; 2]>; 2],
    next_tracking_id: i32,
}

impl Finger {
    fn new(
        device: &DeviceInfo,
        mapping: ScreenMapping,
        start_time_us: u64,
        jitter_seed: u64,
        style: FingerStyle,
    ) -> Finger {
        Finger {
            multitouch: device.multitouch,
            mapping,
            time_us: start_time_us,
            events: Vec::new(),
            rng: SplitMix64::new(hash64(JITTER_SEED, jitter_seed)),
            style,
            current_slot: None,
            sent_position: [None; 2],
            // Tracking ids grow over a device's life; derive them from the clock.
            next_tracking_id: ((start_time_us / 1000) % 30_000) as i32 * 2 + 1,
        }
    }

    fn push(&mut self, kind: u16, code: u16, value: i32) {
        self.events.push(RawEvent::new(self.time_us, kind, code, value));
    }

    fn select_slot(&mut self, slot: usize) {
        if self.multitouch && self.current_slot != Some(slot as i32) {
            self.push(EV_ABS, ABS_MT_SLOT, slot as i32);
            self.current_slot = Some(slot as i32);
        }
    }

    fn jittered(&mut self, point: [f32; 2]) -> [f32; 2] {
        let dx = self.rng.next_gaussian() * self.style.jitter_px;
        let dy = self.rng.next_gaussian() * self.style.jitter_px;
        [point[0] + dx, point[1] + dy]
    }

    fn position(&mut self, slot: usize, point: [f32; 2]) {
        let device = self.mapping.unmap(point);
        let previous = self.sent_position[slot];
        let codes = if self.multitouch { [ABS_MT_POSITION_X, ABS_MT_POSITION_Y] } else { [ABS_X, ABS_Y] };
        for axis in 0..2 {
            if previous.is_none_or(|p| p[axis] != device[axis]) {
                self.select_slot(slot);
                self.push(EV_ABS, codes[axis], device[axis]);
            }
        }
        self.sent_position[slot] = Some(device);
    }

    fn down(&mut self, slot: usize, point: [f32; 2]) {
        if self.multitouch {
            self.select_slot(slot);
            let id = self.next_tracking_id;
            self.next_tracking_id += 1;
            self.push(EV_ABS, ABS_MT_TRACKING_ID, id);
            self.position(slot, point);
        } else {
            self.position(slot, point);
        }
    }

    fn up(&mut self, slot: usize) {
        if self.multitouch {
            self.select_slot(slot);
            self.push(EV_ABS, ABS_MT_TRACKING_ID, -1);
        }
    }

    /// Ends a frame and lets a frame interval pass.
    fn report(&mut self) {
        self.push(EV_SYN, SYN_REPORT, 0);
        self.time_us += MOVE_INTERVAL_US;
    }

    fn tap(&mut self, point: [f32; 2]) {
        self.down(0, point);
        self.push(EV_KEY, BTN_TOUCH, 1);
        self.report();
        // A resting finger wobbles a little halfway through.
        self.time_us += TAP_HOLD_US / 2 - MOVE_INTERVAL_US;
        let wobble = self.jittered(point);
        self.position(0, wobble);
        self.report();
        self.time_us += TAP_HOLD_US / 2 - MOVE_INTERVAL_US;
        self.up(0);
        self.push(EV_KEY, BTN_TOUCH, 0);
        self.report();
    }

    /// One finger resting at `point` for `hold_us`, reporting a small wobble every frame
    /// interval as a resting finger does.
    fn hold(&mut self, point: [f32; 2], hold_us: u64) {
        self.down(0, point);
        self.push(EV_KEY, BTN_TOUCH, 1);
        self.report();
        // Each report moves the clock on by one move interval.
        let frames = (hold_us / MOVE_INTERVAL_US.max(1)).max(2);
        for _ in 1..frames {
            let wobble = self.jittered(point);
            self.position(0, wobble);
            self.report();
        }
        self.up(0);
        self.push(EV_KEY, BTN_TOUCH, 0);
        self.report();
    }

    /// One finger along `path` at the style's speed.
    fn stroke(&mut self, path: &[[f32; 2]]) {
        let length: f32 = path.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).sum();
        let step_px = self.style.speed_px_per_s * MOVE_INTERVAL_US as f32 / 1e6;
        let frames = (length / step_px).ceil();
        let frames = if frames.is_finite() { (frames as usize).clamp(4, MAX_PATH_FRAMES) } else { 4 };
        self.stroke_frames(path, frames);
    }

    /// One finger along `path`, in `frames` moves after landing.
    fn stroke_frames(&mut self, path: &[[f32; 2]], frames: usize) {
        let points = resample(path, frames);
        let Some((&first, rest)) = points.split_first() else { return };
        self.down(0, first);
        self.push(EV_KEY, BTN_TOUCH, 1);
        self.report();
        for (index, &point) in rest.iter().enumerate() {
            let point = if index + 1 == rest.len() { point } else { self.jittered(point) };
            self.position(0, point);
            self.report();
        }
        self.up(0);
        self.push(EV_KEY, BTN_TOUCH, 0);
        self.report();
    }

    /// Two fingers placed by `at(t)` for t from 0 to 1 over [`TWO_FINGER_FRAMES`] frames.
    fn two_fingers(&mut self, at: impl Fn(f32) -> [[f32; 2]; 2]) {
        let [a, b] = at(0.0);
        self.down(0, a);
        self.down(1, b);
        self.push(EV_KEY, BTN_TOUCH, 1);
        self.push(EV_KEY, BTN_TOOL_DOUBLETAP, 1);
        self.report();
        for frame in 1..=TWO_FINGER_FRAMES {
            let [mut a, mut b] = at(frame as f32 / TWO_FINGER_FRAMES as f32);
            if frame < TWO_FINGER_FRAMES {
                a = self.jittered(a);
                b = self.jittered(b);
            }
            self.position(0, a);
            self.position(1, b);
            self.report();
        }
        self.up(0);
        self.up(1);
        self.push(EV_KEY, BTN_TOUCH, 0);
        self.push(EV_KEY, BTN_TOOL_DOUBLETAP, 0);
        self.report();
    }
}

/// `frames + 1` points evenly spaced along the polyline `path` (its first and last included).
fn resample(path: &[[f32; 2]], frames: usize) -> Vec<[f32; 2]> {
    let Some(&first) = path.first() else { return Vec::new() };
    let segment_lengths: Vec<f32> = path.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).collect();
    let total: f32 = segment_lengths.iter().sum();
    let frames = frames.max(1);
    if total.is_nan() || total <= 0.0 {
        return vec![first; frames + 1];
    }
    let mut points = Vec::with_capacity(frames + 1);
    let mut segment = 0;
    let mut walked = 0.0f32;
    for frame in 0..=frames {
        let target = total * frame as f32 / frames as f32;
        while segment + 1 < segment_lengths.len() && walked + segment_lengths[segment] < target {
            walked += segment_lengths[segment];
            segment += 1;
        }
        let (a, b) = (path[segment], path[segment + 1]);
        let t = if segment_lengths[segment] > 0.0 {
            ((target - walked) / segment_lengths[segment]).clamp(0.0, 1.0)
        } else {
            0.0
        };
        points.push([a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t]);
    }
    points
}
