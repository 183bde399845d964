//! The settings screen: reached by a long press on the start screen's title, behind the PIN
//! (`volasso_appliance::pin`: chosen at the first visit, typed twice), and then one row per
//! setting of the settings file (`volasso_appliance::settings`), each changed by touch and
//! written at once, atomically, through the same [`Settings::set`] as `volasso settings set`,
//! so the screen and the command line accept and refuse the same values. Every change and
//! every wrong PIN is a line in the audit log. A model updated by [`SettingsIntent`]s on the
//! app's clock; `view.rs` shows it.
//!
//! Choices: a row steps through a short list of sensible values (previous / next), texts (AE
//! titles, PACS peers, the port) are typed on the screen's keyboard; a value the list lacks
//! (set from the command line) steps to its neighbours. A damaged settings file is shown as the
//! defaults with why, and the first change replaces it. What applies at once and what at the
//! next start is said on its row ([`Row::applies_later`]).
//!
//! Never: touches Slint, reads the clock itself, or keeps a PIN typed after it was checked.

use std::path::PathBuf;
use std::time::Duration;
use volasso_appliance::audit::Event;
use volasso_appliance::pin::{self, Attempts, Verdict};
use volasso_appliance::settings::{self, Effective, Language, Mode, Settings};

pub(crate) mod app;
#[cfg(test)]
mod tests;
pub(crate) mod view;

/// How long a finger rests on the start screen's title before the PIN is asked for.
pub const LONG_PRESS: Duration = Duration::from_secs(2);

/// Most digits of a PIN.
const PIN_DIGITS: usize = 8;
/// Most characters of a typed value (a list of PACS peers).
const MOST_TYPED: usize = 200;

/// What the screen shows.
#[derive(Clone, Debug, PartialEq)]
pub enum Phase {
    /// Not shown.
    Closed,
    Pin(PinEntry),
    Rows(Rows),
}

/// Why a PIN is being typed.
#[derive(Clone, Debug, PartialEq)]
pub enum PinStep {
    /// To reach the settings.
    Enter,
    /// None is set yet: the first one is being chosen.
    Choose,
    /// The chosen one again (never stored before it matches).
    Confirm { first: String },
}

/// The PIN keypad.
#[derive(Clone, Debug, PartialEq)]
pub struct PinEntry {
    pub step: PinStep,
    pub typed: String,
    /// What went wrong with the last PIN; empty when nothing did.
    pub message: String,
}

/// The settings as rows.
#[derive(Clone, Debug, PartialEq)]
pub struct Rows {
    pub settings: Settings,
    /// The last change's outcome, or why the file could not be read.
    pub message: String,
    /// A text row being typed.
    pub editing: Option<Editing>,
}

/// A text row on the keyboard.
#[derive(Clone, Debug, PartialEq)]
pub struct Editing {
    pub key: &'static str,
    pub text: String,
}

/// What the user did.
#[derive(Clone, Debug, PartialEq)]
pub enum SettingsIntent {
    /// A finger landed on (true) or left (false) the start screen's title.
    TitleHeld(bool),
    /// A key of the PIN keypad: a digit, `back` or `clear`.
    PinKey(String),
    PinDone,
    /// A row's previous (-1) or next (+1) value.
    Step {
        key: String,
        direction: i32,
    },
    /// A text row opens on the keyboard.
    Edit(String),
    /// A key of the keyboard: a character, `back` or `clear`.
    EditKey(String),
    EditDone,
    EditCancel,
    /// Back to the start screen (from the keypad or the rows).
    Close,
}

/// What the app does after an update.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SettingsEffects {
    /// The screen opened (the PIN keypad) or closed.
    pub shown: Option<bool>,
    /// A setting changed: the settings now in effect, to apply what applies at once.
    pub applied: Option<Effective>,
    /// Lines for the audit log.
    pub audit: Vec<(Event, String)>,
}

/// One setting as a row.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    pub key: &'static str,
    pub label: &'static str,
    pub value: String,
    /// Typed on the keyboard rather than stepped.
    pub typed: bool,
    /// The appliance uses the new value from its next start (the PACS peers, the receiver, the
    /// panel's rotation and density), not at once.
    pub applies_later: bool,
}

/// The rows in order: key, label, the values a row steps through (none: typed), applies later.
const ROWS: [(&str, &str, &[&str], bool); 12] = [
    ("mode", "Mode", &["clinical", "demo"], false),
    ("language", "Language", &["en", "de"], false),
    ("idle_timeout_s", "Back to the start after", &["0", "30", "60", "120", "300", "600", "1800", "3600"], false),
    ("retention_hours", "Patient data kept for", &["0", "1", "8", "24", "48", "72", "168", "720"], false),
    ("usb_export", "Snapshots to USB sticks", &["false", "true"], false),
    ("receive.enabled", "DICOM receiver", &["false", "true"], true),
    ("receive.ae_title", "Receiver AE title", &[], true),
    ("receive.port", "Receiver port", &[], true),
    ("receive.allowed_aes", "Calling AE titles allowed", &[], true),
    ("pacs", "PACS peers (AE@host:port)", &[], true),
    ("panel.rotation_degrees", "Panel rotation", &["0", "90", "180", "270"], true),
    ("panel.dpi", "Panel density", &["default", "96", "120", "144", "160", "200", "240", "300"], true),
];

/// The settings screen's state, on the data folder's settings and PIN files.
#[derive(Debug)]
pub struct SettingsScreen {
    data_dir: Option<PathBuf>,
    pub phase: Phase,
    /// When the finger now on the title landed.
    held_since: Option<Duration>,
    attempts: Attempts,
}

impl SettingsScreen {
    /// The screen of the data folder `data_dir`; without one there is nothing to set and a long
    /// press does nothing.
    pub fn new(data_dir: Option<PathBuf>) -> SettingsScreen {
        SettingsScreen { data_dir, phase: Phase::Closed, held_since: None, attempts: Attempts::default() }
    }

    /// Whether the screen is showing.
    pub fn is_open(&self) -> bool {
        self.phase != Phase::Closed
    }

    /// The poll's tick at `now`: the keypad opens once the title has been held
    /// [`LONG_PRESS`].
    pub fn tick(&mut self, now: Duration) -> SettingsEffects {
        let mut effects = SettingsEffects::default();
        let Some(since) = self.held_since else { return effects };
        if now.saturating_sub(since) < LONG_PRESS || self.is_open() {
            return effects;
        }
        self.held_since = None;
        let Some(data_dir) = &self.data_dir else { return effects };
        let step = if pin::is_set(data_dir) { PinStep::Enter } else { PinStep::Choose };
        self.phase = Phase::Pin(PinEntry { step, typed: String::new(), message: String::new() });
        effects.shown = Some(true);
        effects
    }

    /// Applies `intent` at `now` (the app's clock).
    pub fn update(&mut self, intent: SettingsIntent, now: Duration) -> SettingsEffects {
        let mut effects = SettingsEffects::default();
        match intent {
            SettingsIntent::TitleHeld(true) => self.held_since = Some(now),
            SettingsIntent::TitleHeld(false) => self.held_since = None,
            SettingsIntent::Close => {
                self.close();
                effects.shown = Some(false);
            }
            SettingsIntent::PinKey(key) => {
                if let Phase::Pin(entry) = &mut self.phase {
                    edit(&mut entry.typed, &key, PIN_DIGITS, |c| c.is_ascii_digit());
                }
            }
            SettingsIntent::PinDone => self.pin_done(now, &mut effects),
            SettingsIntent::Step { key, direction } => self.step(&key, direction, &mut effects),
            SettingsIntent::Edit(key) => {
                if let Phase::Rows(rows) = &mut self.phase
                    && let Some(&(key, ..)) = ROWS.iter().find(|row| row.0 == key && row.2.is_empty())
                {
                    rows.editing =
                        Some(Editing { key, text: rows.settings.effective().value(key).unwrap_or_default() });
                }
            }
            SettingsIntent::EditKey(key) => {
                if let Phase::Rows(Rows { editing: Some(editing), .. }) = &mut self.phase {
                    edit(&mut editing.text, &key, MOST_TYPED, |c| c.is_ascii_graphic() || c == ' ');
                }
            }
            SettingsIntent::EditCancel => {
                if let Phase::Rows(rows) = &mut self.phase {
                    rows.editing = None;
                }
            }
            SettingsIntent::EditDone => {
                let editing = match &mut self.phase {
                    Phase::Rows(rows) => rows.editing.take(),
                    _ => None,
                };
                if let Some(editing) = editing {
                    self.change(editing.key, &editing.text, &mut effects);
                }
            }
        }
        effects
    }

    /// The rows as shown, English words.
    pub fn rows(&self) -> Vec<Row> {
        let Phase::Rows(rows) = &self.phase else { return Vec::new() };
        let effective = rows.settings.effective();
        ROWS.iter()
            .map(|&(key, label, choices, applies_later)| Row {
                key,
                label,
                value: shown_value(key, &effective),
                typed: choices.is_empty(),
                applies_later,
            })
            .collect()
    }

    fn close(&mut self) {
        self.phase = Phase::Closed;
        self.held_since = None;
    }

    fn pin_done(&mut self, now: Duration, effects: &mut SettingsEffects) {
        let (Phase::Pin(entry), Some(data_dir)) = (&mut self.phase, &self.data_dir) else { return };
        let typed = std::mem::take(&mut entry.typed);
        match entry.step.clone() {
            PinStep::Choose if !pin::well_formed(&typed) => entry.message = "A PIN is 4 to 8 digits".into(),
            PinStep::Choose => {
                entry.step = PinStep::Confirm { first: typed };
                entry.message = String::new();
            }
            PinStep::Confirm { first } if first != typed => {
                entry.step = PinStep::Choose;
                entry.message = "The two PINs differ: choose one again".into();
            }
            PinStep::Confirm { .. } => match pin::set(data_dir, &typed) {
                Ok(()) => {
                    effects.audit.push((Event::SettingsChanged, "pin".into()));
                    self.open_rows();
                }
                Err(error) => entry.message = format!("The PIN was not kept: {error}"),
            },
            PinStep::Enter => match pin::check(data_dir, &typed, &mut self.attempts, now) {
                Ok(Verdict::Accepted) => self.open_rows(),
                Ok(Verdict::NotSet) => {
                    entry.step = PinStep::Choose;
                    entry.message = "No PIN is set: choose one".into();
                }
                Ok(Verdict::Refused { tries_left }) => {
                    effects.audit.push((Event::PinRefused, "settings screen".into()));
                    entry.message = match tries_left {
                        0 => {
                            format!("Wrong PIN. Wait {} s before the next try", whole_seconds(self.attempts.wait(now)))
                        }
                        1 => "Wrong PIN. One more try before a wait".into(),
                        n => format!("Wrong PIN. {n} more tries before a wait"),
                    };
                }
                Ok(Verdict::Wait(wait)) => {
                    entry.message = format!("Wait {} s before the next try", whole_seconds(wait));
                }
                Err(error) => entry.message = format!("{error}: set a PIN with `volasso settings set-pin`"),
            },
        }
    }

    fn open_rows(&mut self) {
        let Some(data_dir) = &self.data_dir else { return };
        let (settings, message) = match settings::read(data_dir) {
            Ok(settings) => (settings.unwrap_or_default(), String::new()),
            Err(problem) => {
                (Settings::default(), format!("{problem}. Showing the defaults; a change replaces the file"))
            }
        };
        self.phase = Phase::Rows(Rows { settings, message, editing: None });
    }

    fn step(&mut self, key: &str, direction: i32, effects: &mut SettingsEffects) {
        let Phase::Rows(rows) = &self.phase else { return };
        let Some(&(key, _, choices, _)) = ROWS.iter().find(|row| row.0 == key && !row.2.is_empty()) else { return };
        let current = rows.settings.effective().value(key).unwrap_or_default();
        let value = neighbour(choices, &current, direction);
        self.change(key, &value, effects);
    }

    /// Sets `key` to `value`, writes the file and says what happened.
    fn change(&mut self, key: &'static str, value: &str, effects: &mut SettingsEffects) {
        let (Phase::Rows(rows), Some(data_dir)) = (&mut self.phase, &self.data_dir) else { return };
        let mut changed = rows.settings.clone();
        if let Err(problem) = changed.set(key, value) {
            rows.message = problem.to_string();
            return;
        }
        if changed == rows.settings {
            return;
        }
        match settings::write(data_dir, &changed) {
            Ok(()) => {
                rows.settings = changed;
                rows.message = String::new();
                effects.audit.push((Event::SettingsChanged, format!("{key}={}", value.trim())));
                effects.applied = Some(rows.settings.effective());
            }
            Err(problem) => rows.message = problem.to_string(),
        }
    }
}

/// A wait as the keypad says it: whole seconds, at least one.
fn whole_seconds(wait: Duration) -> u64 {
    wait.as_secs().max(1)
}

/// A keypad key applied to `text`: `back` deletes the last character, `clear` all; another key
/// is appended when `allowed` and the text is shorter than `most`.
fn edit(text: &mut String, key: &str, most: usize, allowed: impl Fn(char) -> bool) {
    match key {
        "back" => {
            text.pop();
        }
        "clear" => text.clear(),
        _ if text.chars().count() < most && key.chars().count() == 1 && key.chars().all(allowed) => text.push_str(key),
        _ => {}
    }
}

/// The value after (`direction` > 0) or before `current` in `choices`, wrapping round; a value
/// not in the list goes to the list's value next to it (numbers by size).
fn neighbour(choices: &[&str], current: &str, direction: i32) -> String {
    let count = choices.len() as i64;
    if let Some(at) = choices.iter().position(|&choice| choice == current) {
        let next = (at as i64 + i64::from(direction.signum())).rem_euclid(count.max(1));
        return choices[next as usize].to_string();
    }
    let number = |text: &str| text.parse::<f64>().ok();
    let Some(value) = number(current) else { return choices.first().copied().unwrap_or_default().to_string() };
    let pick = if direction > 0 {
        choices.iter().find(|&&choice| number(choice).is_some_and(|n| n > value))
    } else {
        choices.iter().rev().find(|&&choice| number(choice).is_some_and(|n| n < value))
    };
    pick.or(choices.first()).copied().unwrap_or_default().to_string()
}

/// A setting's value in words.
fn shown_value(key: &str, effective: &Effective) -> String {
    let on_off = |on: bool| (if on { "On" } else { "Off" }).to_string();
    match key {
        "mode" => (if effective.mode == Mode::Demo { "Demo (no patient data)" } else { "Clinical" }).into(),
        "language" => (if effective.language == Language::De { "Deutsch" } else { "English" }).into(),
        "idle_timeout_s" => match effective.idle_timeout_s {
            0 => "Never".into(),
            s if s % 60 == 0 => format!("{} min", s / 60),
            s => format!("{s} s"),
        },
        "retention_hours" => match effective.retention_hours {
            0 => "Until deleted by hand".into(),
            h if h % 24 == 0 && h > 24 => format!("{} days", h / 24),
            h => format!("{h} h"),
        },
        "usb_export" => on_off(effective.usb_export),
        "receive.enabled" => on_off(effective.receive.enabled),
        "receive.allowed_aes" if effective.receive.allowed_aes.is_empty() => "Any".into(),
        "receive.allowed_aes" => effective.receive.allowed_aes.join(", "),
        "pacs" if effective.pacs.is_empty() => "None".into(),
        "pacs" => effective.pacs.join(", "),
        "panel.rotation_degrees" => format!("{}°", effective.panel.rotation_degrees),
        "panel.dpi" => effective.panel.dpi.map_or("From the display".into(), |dpi| format!("{dpi} dpi")),
        _ => effective.value(key).unwrap_or_default(),
    }
}
