//! Touches to the UI. The first finger down is Slint's pointer: taps, drags, lassos and
//! one-finger orbits are ordinary pointer events for the `TouchArea`s. A second finger on the
//! 3-D view turns the touch into a two-finger gesture: the pointer press is cancelled and
//! pinch, pan and rotate go to the app directly, computed from finger positions by
//! [`crate::touch::gestures`] (Slint has no public multi-touch events).
//!
//! Never: reads devices or scripts; it is fed [`FingerEvent`]s in screen pixels.

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
}

/// See the module doc.
pub struct TouchRouter {
    /// The finger that is Slint's pointer.
    pointer_finger: Option<u64>,
    /// True from a second finger on the view until every finger has lifted.
    view_gesture: bool,
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
            view_gesture: false,
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
    /// Routes one finger event; `view` is where the 3-D view is on screen, if shown.
    pub fn route(&mut self, event: &FingerEvent, view: Option<Rect>, out: &mut Vec<Routed>) {
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
        let on_view = view.is_some_and(|rect| rect.contains(event.position));
        if self.fingers_down.len() >= 2 && on_view && !self.view_gesture && event.phase == FingerPhase::Down {
            self.view_gesture = true;
            self.totals = (1.0, [0.0; 2], 0.0);
            if self.pointer_finger.take().is_some() {
                out.push(Routed::Pointer(WindowEvent::PointerExited));
            }
        }
        // The recogniser sees every finger, so it knows both when a second one lands.
        self.recognised.clear();
        self.gestures.feed(event, &mut self.recognised);
        if self.view_gesture {
            for gesture in &self.recognised {
                let (scale, translation, angle) = &mut self.totals;
                match *gesture {
                    Gesture::Pinch { scale: total, .. } if total > 0.0 && *scale > 0.0 => {
                        out.push(Routed::ViewGesture { zoom: total / *scale, pan_pixels: [0.0; 2], turn_degrees: 0.0 });
                        *scale = total;
                    }
                    Gesture::Pan { translation_px, .. } => {
                        let step = [translation_px[0] - translation[0], translation_px[1] - translation[1]];
                        out.push(Routed::ViewGesture { zoom: 1.0, pan_pixels: step, turn_degrees: 0.0 });
                        *translation = translation_px;
                    }
                    Gesture::Rotate { angle_degrees, .. } => {
                        let step = angle_degrees - *angle;
                        out.push(Routed::ViewGesture { zoom: 1.0, pan_pixels: [0.0; 2], turn_degrees: step });
                        *angle = angle_degrees;
                    }
                    _ => {}
                }
            }
            if self.fingers_down.is_empty() {
                self.view_gesture = false;
            }
            return;
        }
        match (event.phase, self.pointer_finger) {
            (FingerPhase::Down, None) => {
                self.pointer_finger = Some(event.id);
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
