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
//! Where things are comes from a locator asked by accessible label, only when a second finger
//! lands: `view` and `slice area z` / `y` / `x`.
//!
//! Never: reads devices or scripts; it is fed [`FingerEvent`]s in screen pixels.

use crate::slices::Axis;
use crate::touch::contacts::{FingerEvent, FingerPhase};
use crate::touch::gestures::{Gesture, GestureRecognizer};
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

/// See the module doc.
pub struct TouchRouter {
    /// The finger that is Slint's pointer, and where it landed.
    pointer_finger: Option<u64>,
    pointer_landing: [f32; 2],
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
            FingerPhase::Up | FingerPhase::Cancel => self.fingers_down.retain(|&id| id != event.id),
            FingerPhase::Move => {
                if !self.fingers_down.contains(&event.id) {
                    return;
                }
            }
        }
        if self.fingers_down.len() >= 2 && self.target.is_none() && event.phase == FingerPhase::Down {
            let target = target_at(event.position, locate);
            // Both fingers of a gesture are on what it acts on (module doc).
            let pointer_elsewhere = self.pointer_finger.is_some() && target_at(self.pointer_landing, locate) != target;
            self.target = target.filter(|_| !pointer_elsewhere);
            if self.target.is_some() {
                self.totals = (1.0, [0.0; 2], 0.0);
                if self.pointer_finger.take().is_some() {
                    out.push(Routed::Pointer(WindowEvent::PointerExited));
                }
            }
        }
        // The recogniser sees every finger, so it knows both when a second one lands.
        self.recognised.clear();
        self.gestures.feed(event, &mut self.recognised);
        if let Some(target) = self.target {
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
            if self.fingers_down.is_empty() {
                self.target = None;
            }
            return;
        }
        match (event.phase, self.pointer_finger) {
            (FingerPhase::Down, None) => {
                self.pointer_finger = Some(event.id);
                self.pointer_landing = event.position;
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
