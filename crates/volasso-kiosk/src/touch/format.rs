//! `volasso-events/1`: our text format for touch recordings and compiled replay scripts.
//!
//! ```text
//! volasso-events/1
//! device: QEMU Virtio Tablet
//! x: 0 32767
//! y: 0 32767
//! slots: 10
//! multitouch: yes
//! # comments anywhere
//! 0.000000 EV_ABS ABS_MT_SLOT 0
//! 0.000000 EV_ABS ABS_MT_TRACKING_ID 17
//! 0.008000 EV_SYN SYN_REPORT 0
//! ```
//!
//! The first line is the magic; then `key: value` header lines (`x` and `y` required, the
//! position axes' minimum and maximum; `slots` defaults to 1 and `multitouch` to slots > 1);
//! then one event per line, `SECONDS.MICROS TYPE CODE VALUE`, type and code by the kernel's
//! names or as numbers (decimal or `0x` hex), an optional `# comment` after. Parsing never
//! panics: any problem is a [`TouchError::Parse`] with its line number; lines longer than
//! [`MAX_LINE_CHARS`], more than [`MAX_EVENTS`] events and pauses longer than
//! [`event::MAX_PAUSE_US`] between events are refused.
//!
//! Never: interprets the events (see `contacts`).

use super::TouchError;
use super::event::{self, AxisRange, DeviceInfo, RawEvent};
use std::fmt::Write as _;

/// The first line of every `volasso-events/1` file.
pub const MAGIC: &str = "volasso-events/1";
/// Longest line accepted (in bytes); a longer one is corrupt, not a recording.
pub const MAX_LINE_CHARS: usize = 4096;
/// Most events one recording may hold (64 MiB of events in memory).
pub const MAX_EVENTS: usize = 4_000_000;
/// Largest recording file read.
pub const MAX_FILE_BYTES: u64 = 256 << 20;

const FORMAT: &str = "volasso-events/1";

/// A recording: the device it came from and its events in order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Recording {
    pub device: DeviceInfo,
    pub events: Vec<RawEvent>,
}

fn parse_error(line_number: usize, problem: impl Into<String>) -> TouchError {
    TouchError::Parse { format: FORMAT, line_number, problem: problem.into() }
}

/// Parses `volasso-events/1` text.
pub fn parse(text: &str) -> Result<Recording, TouchError> {
    let lines = text.lines().enumerate().map(|(index, line)| (index + 1, line));
    let mut seen_magic = false;
    let mut name = String::from("unnamed touchscreen");
    let (mut x, mut y, mut slots, mut multitouch) = (None, None, None, None);
    let mut events = Vec::new();
    let mut pauses = event::PauseCheck::default();
    for (line_number, line) in lines {
        if line.len() > MAX_LINE_CHARS {
            return Err(parse_error(line_number, format!("line longer than {MAX_LINE_CHARS} bytes")));
        }
        let trimmed = line.trim();
        if !seen_magic {
            if trimmed.is_empty() {
                continue;
            }
            if trimmed != MAGIC {
                return Err(parse_error(line_number, format!("the first line must be '{MAGIC}'")));
            }
            seen_magic = true;
            continue;
        }
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        if let Some((key, value)) = header_line(trimmed) {
            if !events.is_empty() {
                return Err(parse_error(line_number, format!("header line '{key}:' after the first event")));
            }
            match key {
                "device" => name = value.to_string(),
                "x" => x = Some(parse_range(value).ok_or_else(|| parse_error(line_number, "x: needs MIN MAX"))?),
                "y" => y = Some(parse_range(value).ok_or_else(|| parse_error(line_number, "y: needs MIN MAX"))?),
                "slots" => {
                    let count = value.parse::<usize>().ok().filter(|&n| n >= 1);
                    slots = Some(count.ok_or_else(|| parse_error(line_number, "slots: needs a count of 1 or more"))?);
                }
                "multitouch" => {
                    multitouch = Some(match value {
                        "yes" => true,
                        "no" => false,
                        _ => return Err(parse_error(line_number, "multitouch: must be yes or no")),
                    })
                }
                _ => return Err(parse_error(line_number, format!("unknown header key '{key}'"))),
            }
            continue;
        }
        if events.len() >= MAX_EVENTS {
            return Err(TouchError::TooManyEvents { limit: MAX_EVENTS });
        }
        let content = trimmed.split('#').next().unwrap_or("");
        let event = parse_event(content).map_err(|problem| parse_error(line_number, problem))?;
        pauses.next(event.time_us).map_err(|problem| parse_error(line_number, problem))?;
        events.push(event);
    }
    if !seen_magic {
        return Err(TouchError::Incomplete { format: FORMAT, problem: format!("empty; expected '{MAGIC}'") });
    }
    let missing = |axis: &str| TouchError::Incomplete { format: FORMAT, problem: format!("no '{axis}:' header line") };
    let slot_count = slots.unwrap_or(1);
    let device = DeviceInfo {
        name,
        x: x.ok_or_else(|| missing("x"))?,
        y: y.ok_or_else(|| missing("y"))?,
        slot_count,
        multitouch: multitouch.unwrap_or(slot_count > 1),
    };
    Ok(Recording { device, events })
}

/// `key: value` where key is a lowercase word; event lines start with a digit, so never match.
fn header_line(line: &str) -> Option<(&str, &str)> {
    let (key, value) = line.split_once(':')?;
    let is_key = !key.is_empty() && key.bytes().all(|b| b.is_ascii_lowercase() || b == b'-' || b == b'_');
    is_key.then_some((key, value.trim()))
}

fn parse_range(text: &str) -> Option<AxisRange> {
    let mut parts = text.split_whitespace();
    let minimum = parts.next()?.parse().ok()?;
    let maximum = parts.next()?.parse().ok()?;
    (parts.next().is_none() && minimum <= maximum).then_some(AxisRange::new(minimum, maximum))
}

/// Parses `SECONDS.MICROS TYPE CODE VALUE`.
fn parse_event(content: &str) -> Result<RawEvent, String> {
    let fields: Vec<&str> = content.split_whitespace().take(5).collect();
    let [time, kind, code, value] = fields[..] else {
        return Err(format!("expected 'SECONDS.MICROS TYPE CODE VALUE', found '{}'", content.trim()));
    };
    let time_us =
        parse_time_us(time).ok_or_else(|| format!("'{time}' is not a time in seconds with up to 6 decimals"))?;
    let kind = event::type_from_name(kind)
        .or_else(|| parse_number(kind).filter(|&k| k <= event::EV_MAX))
        .ok_or_else(|| format!("'{kind}' is not an event type"))?;
    let code_number = event::code_from_name(kind, code)
        .or_else(|| parse_number(code))
        .ok_or_else(|| format!("'{code}' is not an event code of type {kind}"))?;
    let value = value.parse::<i32>().map_err(|_| format!("'{value}' is not a 32-bit integer value"))?;
    Ok(RawEvent { time_us, kind, code: code_number, value })
}

/// `12`, `12.5` or `12.000500` seconds as microseconds.
pub(crate) fn parse_time_us(text: &str) -> Option<u64> {
    let (seconds, fraction) = text.split_once('.').unwrap_or((text, ""));
    if seconds.is_empty() || !seconds.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    if fraction.len() > 6 || !fraction.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    let seconds: u64 = seconds.parse().ok()?;
    let micros: u64 =
        if fraction.is_empty() { 0 } else { fraction.parse::<u64>().ok()? * 10u64.pow(6 - fraction.len() as u32) };
    seconds.checked_mul(1_000_000)?.checked_add(micros)
}

/// A type or code number: decimal, or hex with `0x`.
fn parse_number(text: &str) -> Option<u16> {
    match text.strip_prefix("0x") {
        Some(hex) => u16::from_str_radix(hex, 16).ok(),
        None => text.parse().ok(),
    }
}

/// Writes `volasso-events/1` text, event by event, with comments in between.
#[derive(Clone, Debug)]
pub struct EventsText {
    text: String,
}

impl EventsText {
    /// Starts a file with the magic and `device`'s header.
    pub fn new(device: &DeviceInfo) -> EventsText {
        let mut text = String::new();
        let name: String = device.name.chars().filter(|c| !c.is_control()).collect();
        let _ = writeln!(text, "{MAGIC}");
        let _ = writeln!(text, "device: {}", name.trim());
        let _ = writeln!(text, "x: {} {}", device.x.minimum, device.x.maximum);
        let _ = writeln!(text, "y: {} {}", device.y.minimum, device.y.maximum);
        let _ = writeln!(text, "slots: {}", device.slot_count.max(1));
        let _ = writeln!(text, "multitouch: {}", if device.multitouch { "yes" } else { "no" });
        EventsText { text }
    }

    /// A comment line (line breaks in `comment` become separate comment lines).
    pub fn comment(&mut self, comment: &str) {
        for line in comment.lines() {
            let _ = writeln!(self.text, "# {line}");
        }
    }

    pub fn event(&mut self, event: &RawEvent) {
        let kind = event::type_name(event.kind).map_or_else(|| event.kind.to_string(), str::to_string);
        let code = event::code_name(event.kind, event.code).map_or_else(|| event.code.to_string(), str::to_string);
        let (seconds, micros) = (event.time_us / 1_000_000, event.time_us % 1_000_000);
        let _ = writeln!(self.text, "{seconds}.{micros:06} {kind} {code} {}", event.value);
    }

    pub fn finish(self) -> String {
        self.text
    }
}

/// The whole recording as `volasso-events/1` text.
pub fn write(recording: &Recording) -> String {
    let mut text = EventsText::new(&recording.device);
    for event in &recording.events {
        text.event(event);
    }
    text.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::touch::event::*;
    use proptest::prelude::*;

    fn sample() -> Recording {
        Recording {
            device: DeviceInfo::virtual_touchscreen(),
            events: vec![
                RawEvent::new(0, EV_ABS, ABS_MT_SLOT, 0),
                RawEvent::new(0, EV_ABS, ABS_MT_TRACKING_ID, 17),
                RawEvent::new(1, EV_ABS, ABS_MT_POSITION_X, -5),
                RawEvent::new(8_000, EV_SYN, SYN_REPORT, 0),
                RawEvent::new(3_600_000_123, 0x15, 0x2ff, i32::MIN),
            ],
        }
    }

    #[test]
    fn write_then_parse_gives_the_recording_back() {
        let recording = sample();
        let text = write(&recording);
        assert!(text.contains("0.008000 EV_SYN SYN_REPORT 0"), "{text}");
        assert!(text.contains("3600.000123 21 767 -2147483648"), "unnamed numbers stay numbers: {text}");
        assert_eq!(parse(&text).unwrap(), recording);
    }

    #[test]
    fn numbers_names_comments_and_defaults_are_accepted() {
        let text =
            "\nvolasso-events/1\n# a comment\nx: 0 100\ny: -5 5\n\n0.5 3 0x35 42 # trailing\n1 EV_SYN SYN_REPORT 0\n";
        let recording = parse(text).unwrap();
        assert_eq!(recording.device.slot_count, 1);
        assert!(!recording.device.multitouch);
        assert_eq!(recording.device.y, AxisRange::new(-5, 5));
        assert_eq!(
            recording.events,
            vec![RawEvent::new(500_000, EV_ABS, ABS_MT_POSITION_X, 42), RawEvent::new(1_000_000, 0, 0, 0)]
        );
    }

    #[test]
    fn errors_name_the_line() {
        let cases = [
            ("not-events\n", 1, "first line"),
            ("volasso-events/1\nx: 0\n", 2, "MIN MAX"),
            ("volasso-events/1\nx: 0 1\ny: 0 1\n0.1 EV_ABS ABS_X\n", 4, "expected"),
            ("volasso-events/1\nx: 0 1\ny: 0 1\n0.1234567 EV_ABS ABS_X 1\n", 4, "time"),
            ("volasso-events/1\nx: 0 1\ny: 0 1\n-1 EV_ABS ABS_X 1\n", 4, "time"),
            ("volasso-events/1\nx: 0 1\ny: 0 1\n1 EV_NOPE ABS_X 1\n", 4, "event type"),
            ("volasso-events/1\nx: 0 1\ny: 0 1\n1 EV_ABS BTN_TOUCH 1\n", 4, "event code"),
            ("volasso-events/1\nx: 0 1\ny: 0 1\n1 EV_ABS ABS_X 99999999999\n", 4, "32-bit"),
            ("volasso-events/1\nx: 0 1\n1 EV_ABS ABS_X 1\ny: 0 1\n", 4, "after the first event"),
            ("volasso-events/1\ncolour: red\n", 2, "unknown header"),
            ("volasso-events/1\nslots: 0\n", 2, "slots"),
            // A jump of 317 years: refused, not replayed frame by frame.
            (
                "volasso-events/1\nx: 0 1\ny: 0 1\n1 EV_SYN SYN_REPORT 0\n0.5 EV_SYN SYN_REPORT 0\n10000000000 EV_SYN SYN_REPORT 0\n",
                6,
                "comes 9999999999.000000 s after the one before it (at 1.000000 s); a recording may pause at most 3600 s",
            ),
        ];
        for (text, line, fragment) in cases {
            let error = parse(text).unwrap_err();
            let message = error.to_string();
            assert!(
                matches!(error, TouchError::Parse { line_number, .. } if line_number == line),
                "{text:?}: {message}"
            );
            assert!(message.contains(fragment), "{text:?}: {message}");
        }
        assert!(parse("volasso-events/1\nx: 0 1\n").unwrap_err().to_string().contains("'y:'"));
        assert!(parse("").is_err());
        let long = format!("volasso-events/1\n# {}\n", "a".repeat(MAX_LINE_CHARS));
        assert!(parse(&long).unwrap_err().to_string().contains("longer"));
    }

    #[test]
    fn times_parse_exactly() {
        assert_eq!(parse_time_us("0.000001"), Some(1));
        assert_eq!(parse_time_us("12.5"), Some(12_500_000));
        assert_eq!(parse_time_us("7"), Some(7_000_000));
        assert_eq!(parse_time_us("99999999999999999999"), None);
        assert_eq!(parse_time_us("18446744073709.551615"), Some(u64::MAX));
        assert_eq!(parse_time_us("18446744073709.551616"), None, "overflows microseconds");
        assert_eq!(parse_time_us(".5"), None);
        assert_eq!(parse_time_us("1.+5"), None);
    }

    proptest! {
        #[test]
        fn random_text_never_panics(text in "(?s).{0,400}") {
            let _ = parse(&text);
            let _ = parse(&format!("{MAGIC}\nx: 0 9\ny: 0 9\n{text}"));
        }

        #[test]
        fn random_event_lines_never_panic(
            lines in proptest::collection::vec("[0-9.]{0,8} (EV_[A-Z]{0,4}|[0-9x]{0,6}) [A-Z_0-9x]{0,12} -?[0-9]{0,11}", 0..20)
        ) {
            let _ = parse(&format!("{MAGIC}\nx: 0 9\ny: 0 9\n{}", lines.join("\n")));
        }

        #[test]
        fn any_events_round_trip(
            start in 0..u64::MAX / 2,
            events in proptest::collection::vec((0..=event::MAX_PAUSE_US, 0u16..=0x1f, any::<u16>(), any::<i32>()), 0..50)
        ) {
            let mut time_us = start;
            let events: Vec<RawEvent> = events
                .into_iter()
                .map(|(pause, k, c, v)| {
                    time_us += pause;
                    RawEvent::new(time_us, k, c, v)
                })
                .collect();
            let recording = Recording { device: DeviceInfo::virtual_tablet(), events };
            prop_assert_eq!(parse(&write(&recording)).unwrap(), recording);
        }
    }
}
