//! Gesture recognition: [`FingerEvent`]s in, [`Gesture`]s out (tap, double tap, one-finger drag,
//! two-finger pinch, pan and rotate).
//!
//! Two-finger transforms are computed from the fingers' positions, not summed from increments:
//! the scale is the ratio of the current finger distance to the distance when the second finger
//! landed, the translation is the centroid's displacement since then, so neither depends on
//! how many move events arrive. (This is our own recogniser, not Slint's
//! `ScaleRotateGestureHandler`: the kiosk computes gestures in Rust from evdev, see `touch`.)
//! Only the rotation is accumulated, frame to frame, so that turns past 180 degrees are kept.
//!
//! Feed whole frames ([`GestureRecognizer::feed_frame`]): the transform is computed once per
//! frame, after all fingers have moved.
//!
//! A tap is reported when the finger lifts, so a double tap is always preceded by the [`Tap`]
//! of its first touch (no timer is needed, and replay stays deterministic). A third finger
//! during a two-finger gesture is ignored; when one of the two lifts, the gesture ends and the
//! remaining finger does nothing until every finger is up.
//!
//! Never: knows about screen elements or what a gesture does to the view.
//!
//! [`Tap`]: Gesture::Tap

use super::contacts::{FingerEvent, FingerPhase};

/// Movement within which a touch still counts as a tap, and beyond which it becomes a drag.
pub const TAP_SLOP_PX: f32 = crate::app::lasso::drawing::TAP_EXTENT_PX;
/// A touch held longer than this is not a tap.
pub const TAP_MAX_DURATION_MS: u64 = 500;
/// Longest time from the first tap's lift to the second's touch for a double tap.
pub const DOUBLE_TAP_INTERVAL_MS: u64 = 300;
/// Largest distance between the two taps of a double tap.
pub const DOUBLE_TAP_SLOP_PX: f32 = 40.0;
/// Change of finger distance before a two-finger gesture reports [`Gesture::Pinch`].
pub const PINCH_SLOP_PX: f32 = 8.0;
/// Centroid movement before a two-finger gesture reports [`Gesture::Pan`].
pub const PAN_SLOP_PX: f32 = 8.0;
/// Turn before a two-finger gesture reports [`Gesture::Rotate`].
pub const ROTATE_SLOP_DEGREES: f32 = 5.0;
/// Below this finger distance, scale and angle are undefined and left unchanged.
pub const MIN_FINGER_DISTANCE_PX: f32 = 2.0;
/// Fingers followed at once; more are ignored.
pub const MAX_FINGERS: usize = 16;

/// A recognised gesture; positions in screen pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Gesture {
    Tap {
        position: [f32; 2],
    },
    DoubleTap {
        position: [f32; 2],
    },
    /// A finger moved beyond [`TAP_SLOP_PX`]; `position` is where it first touched.
    DragStart {
        position: [f32; 2],
    },
    DragMove {
        position: [f32; 2],
    },
    DragEnd {
        position: [f32; 2],
    },
    /// Two fingers: `scale` is the current finger distance over the starting one.
    Pinch {
        centroid: [f32; 2],
        scale: f32,
    },
    /// Two fingers: the centroid's displacement since the gesture began.
    Pan {
        centroid: [f32; 2],
        translation_px: [f32; 2],
    },
    /// Two fingers: the turn since the gesture began, clockwise on screen (y points down).
    Rotate {
        centroid: [f32; 2],
        angle_degrees: f32,
    },
    /// A two-finger gesture finished (a finger lifted), with its totals.
    TwoFingerEnd {
        scale: f32,
        translation_px: [f32; 2],
        angle_degrees: f32,
    },
    /// The drag or two-finger gesture in progress is abandoned (contact lost, or a second
    /// finger turned a drag into a two-finger gesture): undo or ignore it.
    Cancel,
}

#[derive(Clone, Copy, Debug)]
struct TwoFinger {
    fingers: [u64; 2],
    start_distance: f32,
    start_centroid: [f32; 2],
    last_angle_radians: f32,
    angle_radians: f32,
    scale: f32,
    translation_px: [f32; 2],
    pinching: bool,
    panning: bool,
    rotating: bool,
}

#[derive(Clone, Copy, Debug)]
enum State {
    Idle,
    Pressed {
        finger: u64,
        start: [f32; 2],
        start_time_us: u64,
    },
    Dragging {
        finger: u64,
    },
    TwoFinger(TwoFinger),
    /// A gesture ended or was abandoned with fingers still down.
    WaitingForLift,
}

/// The recogniser; feed it every finger event in order.
#[derive(Clone, Debug)]
pub struct GestureRecognizer {
    state: State,
    /// Fingers down and their last positions (at most [`MAX_FINGERS`]).
    fingers: Vec<(u64, [f32; 2])>,
    /// The last single tap: where and when its finger lifted, for double taps.
    last_tap: Option<([f32; 2], u64)>,
    /// A finger of the two-finger gesture moved in the frame being fed.
    two_finger_moved: bool,
}

impl Default for GestureRecognizer {
    fn default() -> Self {
        GestureRecognizer::new()
    }
}

/// The distance between two screen points, in pixels.
pub fn distance(a: [f32; 2], b: [f32; 2]) -> f32 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

impl GestureRecognizer {
    pub fn new() -> GestureRecognizer {
        GestureRecognizer {
            state: State::Idle,
            fingers: Vec::with_capacity(MAX_FINGERS),
            last_tap: None,
            two_finger_moved: false,
        }
    }

    /// Fingers the recogniser believes are down.
    pub fn fingers_down(&self) -> usize {
        self.fingers.len()
    }

    /// Feeds the finger events of one frame (what [`ContactTracker::feed`] appended at one
    /// `SYN_REPORT`); recognised gestures are appended to `out`. A two-finger transform is
    /// updated once, after the whole frame, so that two fingers moving together never show
    /// the half-moved state in between.
    ///
    /// [`ContactTracker::feed`]: super::ContactTracker::feed
    pub fn feed_frame(&mut self, events: &[FingerEvent], out: &mut Vec<Gesture>) {
        for event in events {
            self.feed_event(event, out);
        }
        if std::mem::take(&mut self.two_finger_moved) {
            if let State::TwoFinger(mut two) = self.state {
                if let (Some(a), Some(b)) = (self.position_of(two.fingers[0]), self.position_of(two.fingers[1])) {
                    two.update(a, b, out);
                    self.state = State::TwoFinger(two);
                }
            }
        }
    }

    /// Feeds one finger event as a frame of its own.
    pub fn feed(&mut self, event: &FingerEvent, out: &mut Vec<Gesture>) {
        self.feed_frame(std::slice::from_ref(event), out);
    }

    fn feed_event(&mut self, event: &FingerEvent, out: &mut Vec<Gesture>) {
        let known = self.fingers.iter().position(|(id, _)| *id == event.id);
        let position = if event.position.iter().all(|v| v.is_finite()) {
            event.position
        } else {
            match known {
                Some(index) => self.fingers[index].1,
                None => return,
            }
        };
        match (event.phase, known) {
            (FingerPhase::Down, None) if self.fingers.len() < MAX_FINGERS => {
                self.fingers.push((event.id, position));
                self.finger_down(event.id, position, event.time_us, out);
            }
            (FingerPhase::Move, Some(index)) => {
                self.fingers[index].1 = position;
                self.finger_moved(event.id, position, out);
            }
            (FingerPhase::Up, Some(index)) => {
                self.fingers.swap_remove(index);
                self.finger_up(event.id, position, event.time_us, out);
            }
            (FingerPhase::Cancel, Some(index)) => {
                self.fingers.swap_remove(index);
                self.finger_cancelled(event.id, out);
            }
            _ => {}
        }
    }

    fn finger_down(&mut self, id: u64, position: [f32; 2], time_us: u64, out: &mut Vec<Gesture>) {
        match self.state {
            State::Idle => self.state = State::Pressed { finger: id, start: position, start_time_us: time_us },
            State::Pressed { finger, .. } | State::Dragging { finger } => {
                if matches!(self.state, State::Dragging { .. }) {
                    out.push(Gesture::Cancel);
                }
                let first = self.position_of(finger).unwrap_or(position);
                self.state = State::TwoFinger(TwoFinger::new([finger, id], first, position));
                self.last_tap = None;
            }
            State::TwoFinger(_) | State::WaitingForLift => {}
        }
    }

    fn finger_moved(&mut self, id: u64, position: [f32; 2], out: &mut Vec<Gesture>) {
        match self.state {
            State::Pressed { finger, start, .. } if finger == id && distance(start, position) > TAP_SLOP_PX => {
                out.push(Gesture::DragStart { position: start });
                out.push(Gesture::DragMove { position });
                self.state = State::Dragging { finger };
            }
            State::Dragging { finger } if finger == id => out.push(Gesture::DragMove { position }),
            State::TwoFinger(two) if two.fingers.contains(&id) => self.two_finger_moved = true,
            _ => {}
        }
    }

    fn finger_up(&mut self, id: u64, position: [f32; 2], time_us: u64, out: &mut Vec<Gesture>) {
        match self.state {
            State::Pressed { finger, start, start_time_us } if finger == id => {
                let held_us = time_us.saturating_sub(start_time_us);
                if held_us <= TAP_MAX_DURATION_MS * 1000 {
                    let double = self.last_tap.is_some_and(|(previous, lifted_us)| {
                        start_time_us.saturating_sub(lifted_us) <= DOUBLE_TAP_INTERVAL_MS * 1000
                            && distance(previous, start) <= DOUBLE_TAP_SLOP_PX
                    });
                    if double {
                        out.push(Gesture::DoubleTap { position: start });
                        self.last_tap = None;
                    } else {
                        out.push(Gesture::Tap { position: start });
                        self.last_tap = Some((start, time_us));
                    }
                } else {
                    self.last_tap = None;
                }
            }
            State::Dragging { finger } if finger == id => {
                out.push(Gesture::DragEnd { position });
                self.last_tap = None;
            }
            State::TwoFinger(two) if two.fingers.contains(&id) => out.push(Gesture::TwoFingerEnd {
                scale: two.scale,
                translation_px: two.translation_px,
                angle_degrees: two.angle_radians.to_degrees(),
            }),
            _ => {}
        }
        self.settle();
    }

    fn finger_cancelled(&mut self, id: u64, out: &mut Vec<Gesture>) {
        match self.state {
            State::Dragging { finger } if finger == id => out.push(Gesture::Cancel),
            State::TwoFinger(two) if two.fingers.contains(&id) => out.push(Gesture::Cancel),
            _ => {}
        }
        self.last_tap = None;
        self.settle();
    }

    /// After a lift: idle when no finger is left, otherwise wait for the rest to lift.
    fn settle(&mut self) {
        let (involved, count) = match self.state {
            State::Pressed { finger, .. } | State::Dragging { finger } => ([finger, finger], 1),
            State::TwoFinger(two) => (two.fingers, 2),
            State::Idle | State::WaitingForLift => ([0, 0], 0),
        };
        let still_down = count > 0 && involved[..count].iter().all(|id| self.position_of(*id).is_some());
        if !still_down {
            self.state = if self.fingers.is_empty() { State::Idle } else { State::WaitingForLift };
        }
    }

    fn position_of(&self, id: u64) -> Option<[f32; 2]> {
        self.fingers.iter().find(|(finger, _)| *finger == id).map(|(_, position)| *position)
    }
}

impl TwoFinger {
    fn new(fingers: [u64; 2], a: [f32; 2], b: [f32; 2]) -> TwoFinger {
        TwoFinger {
            fingers,
            start_distance: distance(a, b),
            start_centroid: [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0],
            last_angle_radians: (b[1] - a[1]).atan2(b[0] - a[0]),
            angle_radians: 0.0,
            scale: 1.0,
            translation_px: [0.0, 0.0],
            pinching: false,
            panning: false,
            rotating: false,
        }
    }

    fn update(&mut self, a: [f32; 2], b: [f32; 2], out: &mut Vec<Gesture>) {
        let current_distance = distance(a, b);
        let centroid = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
        if self.start_distance >= MIN_FINGER_DISTANCE_PX && current_distance >= MIN_FINGER_DISTANCE_PX {
            self.scale = current_distance / self.start_distance;
            let angle = (b[1] - a[1]).atan2(b[0] - a[0]);
            let mut turn = angle - self.last_angle_radians;
            // The shorter way round: a frame never turns by more than half a circle.
            turn -= std::f32::consts::TAU * (turn / std::f32::consts::TAU).round();
            self.angle_radians += turn;
            self.last_angle_radians = angle;
        }
        self.translation_px = [centroid[0] - self.start_centroid[0], centroid[1] - self.start_centroid[1]];
        self.pinching |= (current_distance - self.start_distance).abs() > PINCH_SLOP_PX;
        self.panning |= self.translation_px[0].hypot(self.translation_px[1]) > PAN_SLOP_PX;
        self.rotating |= self.angle_radians.to_degrees().abs() > ROTATE_SLOP_DEGREES;
        if self.pinching {
            out.push(Gesture::Pinch { centroid, scale: self.scale });
        }
        if self.panning {
            out.push(Gesture::Pan { centroid, translation_px: self.translation_px });
        }
        if self.rotating {
            out.push(Gesture::Rotate { centroid, angle_degrees: self.angle_radians.to_degrees() });
        }
    }
}

#[cfg(test)]
#[path = "gestures_tests.rs"]
mod tests;
