//! The replay script language: readable touch scripts that drive the real UI through a
//! simulated touchscreen.
//!
//! ```text
//! # Outline the bone on the axial slice, name it, and look at it.
//! lasso z 0.30,0.40 0.50,0.40 0.50,0.60 0.30,0.60
//! tap "Define class"
//! wait 500ms
//! wait-idle
//! pinch view 1.5
//! rotate view 30
//! screenshot bone-class
//! expect classes 2
//! ```
//!
//! Touch commands name a screen element and give points as fractions of its rectangle
//! (`0,0` its top-left corner, `1,1` its bottom-right); `lasso x|y|z` is short for the element
//! `"slice x|y|z"`. Commands: `lasso ELEMENT P P P...` (closed, as a finger shuts a loop),
//! `path ELEMENT P P P...` (open, exactly as given: an overshoot, a spiral), `tap ELEMENT [P]`,
//! `double-tap ELEMENT [P]`, `press ELEMENT [P] DURATION` (a finger held still: a long press), `drag ELEMENT FROM TO`, `swipe ELEMENT left|right|up|down`,
//! `pinch ELEMENT SCALE`, `pan ELEMENT DX,DY` (fractions of the element's size), `rotate ELEMENT
//! DEGREES` (clockwise); `finger [jitter PX] [speed PX_PER_S]` (how the finger moves from
//! then on, [`FingerStyle`]: a value left out goes back to its default);
//! and `wait DURATION` (`500ms`, `2s`), `wait-idle`, `screenshot NAME`, `expect KEY VALUE`
//! (generic: the runner knows the keys; [`expectations`] measures the label volume for
//! `air-classified-below` and `lasso-voxels-kept`), `# comments`.
//!
//! `parse` only checks syntax; elements are resolved at run time through the UI's
//! [`ElementLocator`], and [`touch_events`] turns one [`TouchCommand`] into the raw evdev events
//! a finger would make, which the runner feeds through the same [`ContactTracker`] as a real
//! device (built with the identity [`ScreenMapping`] for the locator's screen size).
//! [`compile`] writes a whole script as `volasso-events/1` text (`volasso replay --compile`).
//!
//! Never: touches the UI itself, waits, or takes screenshots; the runner does.
//!
//! [`ContactTracker`]: super::ContactTracker
//! [`ScreenMapping`]: super::ScreenMapping

pub mod expectations;
mod parse;
mod synthesis;

pub use parse::parse;
pub use synthesis::{
    FingerStyle, GAP_AFTER_TOUCH_US, JITTER_PX, MOVE_INTERVAL_US, TAP_HOLD_US, TWO_FINGER_FRAMES, touch_events,
    touch_events_seeded,
};

use super::event::DeviceInfo;
use super::format::EventsText;

pub use crate::app::Rect;

/// What the UI tells the script runner about its screen.
pub trait ElementLocator {
    /// The window's size in pixels.
    fn screen_size(&self) -> [f32; 2];
    /// Where the element called `name` is on screen now, if it exists.
    fn element_rect(&self, name: &str) -> Option<Rect>;
}

/// A swipe's direction (the way the finger moves).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SwipeDirection {
    Left,
    Right,
    Up,
    Down,
}

/// A touch command, in element fractions; resolved to screen pixels only when run.
#[derive(Clone, Debug, PartialEq)]
pub enum TouchCommand {
    Lasso {
        element: String,
        points: Vec<[f32; 2]>,
    },
    /// A finger path through the points as drawn, not closed (an overshoot, a spiral, a tail).
    Path {
        element: String,
        points: Vec<[f32; 2]>,
    },
    Tap {
        element: String,
        at: [f32; 2],
    },
    DoubleTap {
        element: String,
        at: [f32; 2],
    },
    /// A finger held still (a long press) for `hold_ms`.
    Press {
        element: String,
        at: [f32; 2],
        hold_ms: u64,
    },
    Drag {
        element: String,
        from: [f32; 2],
        to: [f32; 2],
    },
    Swipe {
        element: String,
        direction: SwipeDirection,
    },
    Pinch {
        element: String,
        scale: f32,
    },
    Pan {
        element: String,
        offset: [f32; 2],
    },
    Rotate {
        element: String,
        angle_degrees: f32,
    },
}

impl TouchCommand {
    /// The element the command acts on.
    pub fn element(&self) -> &str {
        match self {
            TouchCommand::Lasso { element, .. }
            | TouchCommand::Path { element, .. }
            | TouchCommand::Tap { element, .. }
            | TouchCommand::DoubleTap { element, .. }
            | TouchCommand::Press { element, .. }
            | TouchCommand::Drag { element, .. }
            | TouchCommand::Swipe { element, .. }
            | TouchCommand::Pinch { element, .. }
            | TouchCommand::Pan { element, .. }
            | TouchCommand::Rotate { element, .. } => element,
        }
    }

    /// The script keyword.
    pub fn keyword(&self) -> &'static str {
        match self {
            TouchCommand::Lasso { .. } => "lasso",
            TouchCommand::Path { .. } => "path",
            TouchCommand::Tap { .. } => "tap",
            TouchCommand::DoubleTap { .. } => "double-tap",
            TouchCommand::Press { .. } => "press",
            TouchCommand::Drag { .. } => "drag",
            TouchCommand::Swipe { .. } => "swipe",
            TouchCommand::Pinch { .. } => "pinch",
            TouchCommand::Pan { .. } => "pan",
            TouchCommand::Rotate { .. } => "rotate",
        }
    }
}

/// What one script line asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum ScriptAction {
    Touch(TouchCommand),
    /// How the finger moves for the touch commands after this one.
    Finger(FingerStyle),
    Wait {
        duration_ms: u64,
    },
    /// Wait until the UI has no work in flight (the runner decides what that means).
    WaitIdle,
    Screenshot {
        name: String,
    },
    /// A check for the runner: `key` names what to look at, `value` what it should be.
    Expect {
        key: String,
        value: String,
    },
}

/// One script line: its number, its text and what it asks for.
#[derive(Clone, Debug, PartialEq)]
pub struct ScriptStep {
    pub line_number: usize,
    /// The line as written, trimmed (for logs and compiled comments).
    pub source: String,
    pub action: ScriptAction,
}

/// Everything parsing and running a script can fail with.
#[derive(Debug, thiserror::Error)]
pub enum ScriptError {
    #[error("line {line_number}: {problem}")]
    Syntax { line_number: usize, problem: String },
    #[error("the script has more than {limit_lines} lines")]
    TooLong { limit_lines: usize },
    #[error("no element named '{element}' on screen")]
    UnknownElement { element: String },
    #[error("element '{element}' has no usable rectangle ({rect:?})")]
    EmptyElement { element: String, rect: Rect },
    #[error("the screen size {size:?} is not usable")]
    BadScreen { size: [f32; 2] },
    #[error("'{command}' needs two fingers, but '{device}' is a single-touch device")]
    NeedsMultitouch { command: &'static str, device: String },
    #[error("line {line_number}: {source}")]
    AtLine { line_number: usize, source: Box<ScriptError> },
}

/// Writes a whole script as `volasso-events/1` text for `device`, resolving elements through
/// `locator` now: touch commands become events, waits advance the clock, and every other step
/// becomes a comment line.
pub fn compile(steps: &[ScriptStep], locator: &dyn ElementLocator, device: &DeviceInfo) -> Result<String, ScriptError> {
    let mut text = EventsText::new(device);
    let mut time_us = 0u64;
    let mut style = FingerStyle::default();
    for step in steps {
        text.comment(&format!("line {}: {}", step.line_number, step.source));
        match &step.action {
            ScriptAction::Touch(command) => {
                let events =
                    touch_events_seeded(command, locator, device, time_us, time_us, &style).map_err(|source| {
                        ScriptError::AtLine { line_number: step.line_number, source: Box::new(source) }
                    })?;
                for event in &events {
                    text.event(event);
                }
                time_us = events.last().map_or(time_us, |e| e.time_us).saturating_add(GAP_AFTER_TOUCH_US);
            }
            ScriptAction::Wait { duration_ms } => time_us = time_us.saturating_add(duration_ms.saturating_mul(1000)),
            ScriptAction::Finger(finger) => style = *finger,
            ScriptAction::WaitIdle | ScriptAction::Screenshot { .. } | ScriptAction::Expect { .. } => {}
        }
    }
    Ok(text.finish())
}

#[cfg(test)]
mod tests;
