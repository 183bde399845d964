//! Touches to the UI. The first finger down is Slint's pointer: taps, drags, lassos and
//! one-finger orbits are ordinary pointer events for the `TouchArea`s. A second finger on the
//! 3-D view or on a slice, where the first finger landed too, turns the touch into a two-finger
//! gesture: the pointer press is cancelled (a lasso being drawn is dropped, not taken as a path;
//! the slice says so) and pinch, pan and rotate go to the app directly, computed from finger positions by [`crate::touch::gestures`] (Slint
//! has no public multi-touch events). On a slice, pans are given in fractions of the slice's
//! visible area, so the app needs no screen geometry.
//!
//! A second finger that lands anywhere else than where the first one did (another visitor's
//! hand on the 3-D view while a loop is drawn on a slice, a palm on another panel) is no part of
//! a gesture: it is ignored, and the first finger goes on as it was.
//!
//! A second touch that lands where the first finger is already drawing (it has moved past a
//! tap's slop) is held: the loop goes on until that touch itself moves by
//! [`HELD_TOUCH_SLOP_PX`], as both fingers of a deliberate pinch or pan do. The heel of the
//! drawing hand, a knuckle, or a palm the panel reports as a finger for its first frames (and
//! then as a palm, which cancels it) rests where it landed and never interrupts the loop.
//!
//! Where things are comes from a locator asked by accessible label, only when a second finger
//! lands: `view` and `slice area z` / `y` / `x`.
//!
//! Never: reads devices or scripts; it is fed [`FingerEvent`]s in screen pixels.

use crate::slices::Axis;
use crate::touch::contacts::{FingerEvent, FingerPhase};
use crate::touch::gestures::{Gesture, GestureRecognizer, TAP_SLOP_PX, distance};
use crate::touch::script::Rect;
use slint::LogicalPosition;
use slint::platform::{PointerEventButton, WindowEvent};

/// What the router asks of the app: pointer events for Slint, gestures for the 3-D view.
pub enum Routed {
    Pointer(WindowEvent),
    /// zoom factor, pan in pixels, turn in degrees.
    ViewGesture {
        zoom: f32,
        pan_pixels: [f32; 2],
        turn_degrees: f32,
    },
    /// On the slice normal to `axis`: zoom factor, pan in fractions of its visible area.
    SliceGesture {
        axis: Axis,
        zoom: f32,
        pan_fraction: [f32; 2],
    },
}

/// What a two-finger gesture acts on.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Target {
    View,
    Slice(Axis, Rect),
}

/// How far (screen pixels) a second touch held while the first finger draws must move to start
/// a two-finger gesture (module doc): twice a tap's slop, more than a resting palm's centre
/// wanders as it settles, less than the first frames of a pinch.
pub const HELD_TOUCH_SLOP_PX: f32 = 2.0 * TAP_SLOP_PX;

/// A second touch on what the first finger is drawing on, not yet a gesture.
#[derive(Clone, Copy, Debug)]
struct HeldTouch {
    id: u64,
    landing: [f32; 2],
    target: Target,
}

/// See the module doc.
pub struct TouchRouter {
    /// The finger that is Slint's pointer, where it landed and how far it has gone from there.
    pointer_finger: Option<u64>,
    pointer_landing: [f32; 2],
    pointer_travel: f32,
    /// A second touch held while the pointer finger draws (module doc).
    held: Option<HeldTouch>,
    /// From a second finger on the view or a slice until every finger has lifted.
    target: Option<Target>,
    fingers_down: Vec<u64>,
    gestures: GestureRecognizer,
    /// The two-finger gesture's totals so far (scale, translation, angle): the recogniser
    /// reports totals since the gesture began, the camera wants steps.
    totals: (f32, [f32; 2], f32),
    recognised: Vec<Gesture>,
}

impl Default for TouchRouter {
    fn default() -> Self {
        TouchRouter {
            pointer_finger: None,
            pointer_landing: [0.0; 2],
            pointer_travel: 0.0,
            held: None,
            target: None,
            fingers_down: Vec::new(),
            gestures: GestureRecognizer::new(),
            totals: (1.0, [0.0; 2], 0.0),
            recognised: Vec::new(),
        }
    }
}

/// At most this many fingers are tracked; more are ignored (a palm on the glass).
const MAX_FINGERS: usize = 10;

impl TouchRouter {
    /// Routes one finger event; `locate` says where the element with an accessible label is on
    /// screen, if shown (module doc).
    pub fn route(&mut self, event: &FingerEvent, locate: &dyn Fn(&str) -> Option<Rect>, out: &mut Vec<Routed>) {
        let position = LogicalPosition::new(event.position[0], event.position[1]);
        match event.phase {
            FingerPhase::Down => {
                if self.fingers_down.contains(&event.id) || self.fingers_down.len() >= MAX_FINGERS {
                    return;
                }
                self.fingers_down.push(event.id);
            }
            FingerPhase::Up | FingerPhase::Cancel => {
                self.fingers_down.retain(|&id| id != event.id);
                if self.held.is_some_and(|held| held.id == event.id) || self.pointer_finger == Some(event.id) {
                    self.held = None;
                }
            }
            FingerPhase::Move => {
                if !self.fingers_down.contains(&event.id) {
                    return;
                }
                if self.pointer_finger == Some(event.id) {
                    self.pointer_travel = self.pointer_travel.max(distance(event.position, self.pointer_landing));
                }
                if let Some(held) = self.held.filter(|held| held.id == event.id)
                    && distance(event.position, held.landing) > HELD_TOUCH_SLOP_PX
                {
                    self.held = None;
                    self.start_gesture(held.target, out);
                }
            }
        }
        if self.fingers_down.len() >= 2 && self.target.is_none() && event.phase == FingerPhase::Down {
            if self.fingers_down.len() == 2 {
                // The recogniser's totals start again with a second finger.
                self.totals = (1.0, [0.0; 2], 0.0);
            }
            let target = target_at(event.position, locate);
            // Both fingers of a gesture are on what it acts on (module doc).
            let pointer_elsewhere = self.pointer_finger.is_some() && target_at(self.pointer_landing, locate) != target;
            let drawing = self.pointer_finger.is_some() && self.pointer_travel > TAP_SLOP_PX;
            match target.filter(|_| !pointer_elsewhere) {
                Some(target) if drawing && self.held.is_none() => {
                    self.held = Some(HeldTouch { id: event.id, landing: event.position, target });
                }
                Some(_) if drawing => {}
                Some(target) => self.start_gesture(target, out),
                None => {}
            }
        }
        // The recogniser sees every finger, so it knows both when a second one lands; the totals
        // follow it while a touch is held, so a gesture that starts late starts without a jump.
        self.recognised.clear();
        self.gestures.feed(event, &mut self.recognised);
        if self.target.is_some() || self.held.is_some() {
            for gesture in &self.recognised {
                let (scale, translation, angle) = &mut self.totals;
                let (zoom, pan_pixels, turn_degrees) = match *gesture {
                    Gesture::Pinch { scale: total, .. } if total > 0.0 && *scale > 0.0 => {
                        let step = total / *scale;
                        *scale = total;
                        (step, [0.0; 2], 0.0)
                    }
                    Gesture::Pan { translation_px, .. } => {
                        let step = [translation_px[0] - translation[0], translation_px[1] - translation[1]];
                        *translation = translation_px;
                        (1.0, step, 0.0)
                    }
                    Gesture::Rotate { angle_degrees, .. } => {
                        let step = angle_degrees - *angle;
                        *angle = angle_degrees;
                        (1.0, [0.0; 2], step)
                    }
                    _ => continue,
                };
                let Some(target) = self.target else { continue };
                out.push(match target {
                    Target::View => Routed::ViewGesture { zoom, pan_pixels, turn_degrees },
                    // Slices do not turn: their orientation is the patient's.
                    Target::Slice(_, _) if turn_degrees != 0.0 => continue,
                    Target::Slice(axis, area) => Routed::SliceGesture {
                        axis,
                        zoom,
                        pan_fraction: [pan_pixels[0] / area.width.max(1.0), pan_pixels[1] / area.height.max(1.0)],
                    },
                });
            }
            if self.target.is_some() {
                if self.fingers_down.is_empty() {
                    self.target = None;
                }
                return;
            }
        }
        match (event.phase, self.pointer_finger) {
            (FingerPhase::Down, None) => {
                self.pointer_finger = Some(event.id);
                self.pointer_landing = event.position;
                self.pointer_travel = 0.0;
                out.push(Routed::Pointer(WindowEvent::PointerMoved { position }));
                out.push(Routed::Pointer(WindowEvent::PointerPressed { position, button: PointerEventButton::Left }));
            }
            (FingerPhase::Move, Some(id)) if id == event.id => {
                out.push(Routed::Pointer(WindowEvent::PointerMoved { position }));
            }
            (FingerPhase::Up, Some(id)) if id == event.id => {
                self.pointer_finger = None;
                out.push(Routed::Pointer(WindowEvent::PointerReleased { position, button: PointerEventButton::Left }));
                out.push(Routed::Pointer(WindowEvent::PointerExited));
            }
            (FingerPhase::Cancel, Some(id)) if id == event.id => {
                self.pointer_finger = None;
                out.push(Routed::Pointer(WindowEvent::PointerExited));
            }
            _ => {}
        }
    }
}

impl TouchRouter {
    /// Two fingers on `target` from now on: the pointer press is cancelled.
    fn start_gesture(&mut self, target: Target, out: &mut Vec<Routed>) {
        self.target = Some(target);
        if self.pointer_finger.take().is_some() {
            out.push(Routed::Pointer(WindowEvent::PointerExited));
        }
    }
}

/// The gesture target under `position`: the 3-D view, or a slice's visible area.
fn target_at(position: [f32; 2], locate: &dyn Fn(&str) -> Option<Rect>) -> Option<Target> {
    if locate("view").is_some_and(|rect| rect.contains(position)) {
        return Some(Target::View);
    }
    Axis::ALL.into_iter().find_map(|axis| {
        let area = locate(&format!("slice area {}", axis.name()))?;
        area.contains(position).then_some(Target::Slice(axis, area))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn finger(id: u64, phase: FingerPhase, position: [f32; 2], time_us: u64) -> FingerEvent {
        FingerEvent { id, phase, position, time_us }
    }

    /// Routes two fingers landing at `a` and `b` and moving by `(da, db)` over 10 frames.
    fn two_fingers(a: [f32; 2], b: [f32; 2], da: [f32; 2], db: [f32; 2]) -> Vec<Routed> {
        let locate = |label: &str| match label {
            "view" => Some(Rect { x: 600.0, y: 0.0, width: 400.0, height: 400.0 }),
            "slice area y" => Some(Rect { x: 0.0, y: 0.0, width: 300.0, height: 200.0 }),
            _ => None,
        };
        let mut router = TouchRouter::default();
        let mut out = Vec::new();
        router.route(&finger(1, FingerPhase::Down, a, 0), &locate, &mut out);
        router.route(&finger(2, FingerPhase::Down, b, 10_000), &locate, &mut out);
        for step in 1..=10 {
            let t = step as f32 / 10.0;
            let time = 10_000 + step * 8_000;
            let at = |p: [f32; 2], d: [f32; 2]| [p[0] + d[0] * t, p[1] + d[1] * t];
            router.route(&finger(1, FingerPhase::Move, at(a, da), time), &locate, &mut out);
            router.route(&finger(2, FingerPhase::Move, at(b, db), time + 1), &locate, &mut out);
        }
        router.route(&finger(1, FingerPhase::Up, at_end(a, da), 200_000), &locate, &mut out);
        router.route(&finger(2, FingerPhase::Up, at_end(b, db), 200_001), &locate, &mut out);
        out
    }

    fn at_end(p: [f32; 2], d: [f32; 2]) -> [f32; 2] {
        [p[0] + d[0], p[1] + d[1]]
    }

    #[test]
    fn two_fingers_on_a_slice_pan_it_in_fractions_and_cancel_the_pointer() {
        // Both fingers move 60 px down on a 300 x 200 slice area: a pan of 0.3 of its height.
        let out = two_fingers([100.0, 80.0], [160.0, 80.0], [0.0, 60.0], [0.0, 60.0]);
        assert!(matches!(out[1], Routed::Pointer(WindowEvent::PointerPressed { .. })));
        assert!(matches!(out[2], Routed::Pointer(WindowEvent::PointerExited)), "the first finger's press is cancelled");
        let (mut pan, mut zoom) = ([0.0f32; 2], 1.0f32);
        for routed in &out[3..] {
            match routed {
                Routed::SliceGesture { axis: Axis::Y, zoom: z, pan_fraction } => {
                    zoom *= z;
                    pan = [pan[0] + pan_fraction[0], pan[1] + pan_fraction[1]];
                }
                Routed::Pointer(_) => panic!("no pointer events during a two-finger gesture"),
                Routed::ViewGesture { .. } | Routed::SliceGesture { .. } => panic!("a gesture for something else"),
            }
        }
        assert!(pan[0].abs() < 1e-4 && (pan[1] - 0.3).abs() < 1e-4, "{pan:?}");
        assert!((zoom - 1.0).abs() < 1e-4);
    }

    #[test]
    fn a_pinch_on_a_slice_zooms_and_one_on_the_view_stays_the_views() {
        let out = two_fingers([100.0, 100.0], [160.0, 100.0], [-30.0, 0.0], [30.0, 0.0]);
        let zoom: f32 = out
            .iter()
            .filter_map(|routed| match routed {
                Routed::SliceGesture { zoom, .. } => Some(*zoom),
                _ => None,
            })
            .product();
        assert!((zoom - 2.0).abs() < 1e-3, "{zoom}");
        let out = two_fingers([700.0, 100.0], [760.0, 100.0], [-30.0, 0.0], [30.0, 0.0]);
        assert!(out.iter().any(|routed| matches!(routed, Routed::ViewGesture { .. })));
        assert!(!out.iter().any(|routed| matches!(routed, Routed::SliceGesture { .. })));
        // Elsewhere (no element there), two fingers are just a pointer and an ignored finger.
        let out = two_fingers([400.0, 500.0], [460.0, 500.0], [-30.0, 0.0], [30.0, 0.0]);
        assert!(out.iter().all(|routed| matches!(routed, Routed::Pointer(_))));
    }

    /// A finger drawing on the slice area from (100, 100) for 30 frames, 3 px a frame; a second
    /// touch lands on the slice at frame 10 and then goes to `second(frame)` each frame (`None`:
    /// it lifts there, or is cancelled as a palm with `cancelled`).
    fn drawing_with_a_second_touch(second: impl Fn(u64) -> Option<[f32; 2]>, cancelled: bool) -> Vec<Routed> {
        let locate =
            |label: &str| (label == "slice area z").then_some(Rect { x: 0.0, y: 0.0, width: 400.0, height: 400.0 });
        let mut router = TouchRouter::default();
        let mut out = Vec::new();
        let first = |frame: u64| [100.0 + 3.0 * frame as f32, 100.0];
        router.route(&finger(1, FingerPhase::Down, first(0), 0), &locate, &mut out);
        let mut down = false;
        for frame in 1..=30u64 {
            let time = frame * 8_000;
            router.route(&finger(1, FingerPhase::Move, first(frame), time), &locate, &mut out);
            if frame < 10 {
                continue;
            }
            match (second(frame), down) {
                (Some(at), false) => router.route(&finger(2, FingerPhase::Down, at, time + 1), &locate, &mut out),
                (Some(at), true) => router.route(&finger(2, FingerPhase::Move, at, time + 1), &locate, &mut out),
                (None, true) => {
                    let phase = if cancelled { FingerPhase::Cancel } else { FingerPhase::Up };
                    router.route(&finger(2, phase, [300.0, 300.0], time + 1), &locate, &mut out);
                }
                (None, false) => {}
            }
            down = second(frame).is_some();
        }
        router.route(&finger(1, FingerPhase::Up, first(30), 300_000), &locate, &mut out);
        out
    }

    #[test]
    fn a_touch_resting_where_a_finger_draws_leaves_it_drawing() {
        // The heel of the hand lands beside the path and wanders a few pixels as it settles;
        // it lifts, or the panel turns it into a palm and cancels it: the loop goes on.
        let resting =
            |frame: u64| (frame < 20).then_some([300.0 + (frame % 3) as f32 * 4.0, 300.0 - frame as f32 * 0.5]);
        for cancelled in [false, true] {
            let out = drawing_with_a_second_touch(resting, cancelled);
            assert!(out.iter().all(|routed| matches!(routed, Routed::Pointer(_))), "a gesture");
            let moves = out.iter().filter(|r| matches!(r, Routed::Pointer(WindowEvent::PointerMoved { .. }))).count();
            assert_eq!(moves, 31, "the landing and all thirty moves");
            assert!(matches!(out[out.len() - 2], Routed::Pointer(WindowEvent::PointerReleased { .. })));
        }
        // Resting until the drawing finger lifts, too.
        let out = drawing_with_a_second_touch(|_| Some([300.0, 300.0]), false);
        assert!(matches!(out[out.len() - 2], Routed::Pointer(WindowEvent::PointerReleased { .. })));
    }

    #[test]
    fn a_held_touch_that_moves_starts_the_gesture_without_a_jump() {
        // The second finger pans down 5 px a frame from frame 10: past the held slop (24 px) at
        // frame 15 the gesture starts, the loop is cancelled, and the pans given from then on add
        // up to what the fingers moved from that frame on, not since the second one landed.
        let out = drawing_with_a_second_touch(|frame| Some([300.0, 300.0 + 5.0 * (frame - 10) as f32]), false);
        let exited = out.iter().position(|r| matches!(r, Routed::Pointer(WindowEvent::PointerExited))).unwrap();
        assert!(
            out[exited + 1..].iter().all(|r| matches!(r, Routed::SliceGesture { axis: Axis::Z, .. })),
            "after the start"
        );
        let moves =
            out[..exited].iter().filter(|r| matches!(r, Routed::Pointer(WindowEvent::PointerMoved { .. }))).count();
        assert_eq!(moves, 1 + 15, "the loop went on until the second finger had moved 25 px");
        let pan: f32 = out
            .iter()
            .filter_map(|routed| match routed {
                Routed::SliceGesture { pan_fraction, .. } => Some(pan_fraction[1] * 400.0),
                _ => None,
            })
            .sum();
        // The recogniser's pan is the mean of both fingers' movement: the drawing finger moves
        // across, the second one 5 px down a frame, 2.5 px for the pair; from the frame that
        // started the gesture on (15 to 30) 40 px, where the whole movement since it landed is 50.
        assert!((pan - 40.0).abs() < 1e-3, "{pan}");
    }

    #[test]
    fn a_second_finger_elsewhere_leaves_the_first_finger_drawing() {
        // A loop drawn on the slice while another hand lands on the 3-D view and moves: the
        // pointer goes on (presses, moves, releases) and nothing gestures.
        let out = two_fingers([100.0, 100.0], [700.0, 100.0], [40.0, 40.0], [-30.0, 20.0]);
        assert!(out.iter().all(|routed| matches!(routed, Routed::Pointer(_))), "a gesture");
        let moves = out.iter().filter(|r| matches!(r, Routed::Pointer(WindowEvent::PointerMoved { .. }))).count();
        assert_eq!(moves, 11, "the first finger's landing and its ten moves");
        assert!(matches!(out[out.len() - 2], Routed::Pointer(WindowEvent::PointerReleased { .. })));
        // And the other way round: drawing on the view's orbit, a finger on a slice.
        let out = two_fingers([700.0, 100.0], [100.0, 100.0], [40.0, 0.0], [0.0, 40.0]);
        assert!(out.iter().all(|routed| matches!(routed, Routed::Pointer(_))));
    }
}
