//! evemu-record's text format, read into the same [`Recording`] as `volasso-events/1`, so that
//! recordings made with the standard tool on any Linux machine replay through our tracker.
//!
//! ```text
//! # EVEMU 1.3
//! N: ELAN Touchscreen
//! I: 0018 04f3 2a1c 0100
//! P: 02 00 00 00 00 00 00 00
//! B: 01 00 00 00 00 00 00 00 00        (key bitmask bytes, continued over lines)
//! A: 35 0 3200 0 0 13                  (code min max fuzz flat resolution, code in hex)
//! E: 0.000001 0003 0039 0017   # EV_ABS / ABS_MT_TRACKING_ID 17
//! ```
//!
//! `N:` names the device, `B: 01` lines give its keys, `A:` lines its axes; `I:`, `P:`, `L:`
//! and `S:` are checked for shape and otherwise ignored. `E:` lines are `sec.usec type code
//! value` with type and code in hex and the value in decimal. A pause longer than
//! [`event::MAX_PAUSE_US`] between events is refused. Never panics; every problem is a
//! [`TouchError::Parse`] with its line number.
//!
//! Never: writes evemu files (we record `volasso-events/1`).

use super::TouchError;
use super::event::{self, DeviceInfo, RawEvent};
use super::format::{MAX_EVENTS, MAX_LINE_CHARS, Recording, parse_time_us};

const FORMAT: &str = "evemu";
/// Bytes of a key bitmask kept: `KEY_MAX / 8 + 1`.
const KEY_MASK_BYTES: usize = event::KEY_MAX as usize / 8 + 1;

fn parse_error(line_number: usize, problem: impl Into<String>) -> TouchError {
    TouchError::Parse { format: FORMAT, line_number, problem: problem.into() }
}

/// Parses evemu-record output.
pub fn parse(text: &str) -> Result<Recording, TouchError> {
    let mut name = String::from("unnamed touchscreen");
    let mut axes: Vec<(u16, i32, i32)> = Vec::new();
    let mut key_mask: Vec<u8> = Vec::new();
    let mut events = Vec::new();
    let mut pauses = event::PauseCheck::default();
    let mut described = false;
    for (index, line) in text.lines().enumerate() {
        let line_number = index + 1;
        if line.len() > MAX_LINE_CHARS {
            return Err(parse_error(line_number, format!("line longer than {MAX_LINE_CHARS} bytes")));
        }
        let trimmed = line.trim();
        if trimmed.is_empty() || trimmed.starts_with('#') {
            continue;
        }
        let Some((prefix, rest)) = trimmed.split_once(':') else {
            return Err(parse_error(line_number, "expected a line starting with N:, I:, P:, B:, A:, L:, S: or E:"));
        };
        let rest = rest.trim();
        match prefix {
            "N" => {
                name = rest.to_string();
                described = true;
            }
            "I" | "P" | "L" | "S" => {
                if !rest.split_whitespace().all(|word| u32::from_str_radix(word, 16).is_ok()) {
                    return Err(parse_error(line_number, format!("{prefix}: expects hexadecimal numbers")));
                }
            }
            "B" => {
                let bytes = hex_bytes(rest).ok_or_else(|| parse_error(line_number, "B: expects hexadecimal bytes"))?;
                if bytes.first() == Some(&(event::EV_KEY as u8)) {
                    let room = KEY_MASK_BYTES.saturating_sub(key_mask.len());
                    key_mask.extend(bytes[1..].iter().take(room));
                }
                described = true;
            }
            "A" => {
                let axis = parse_axis(rest)
                    .ok_or_else(|| parse_error(line_number, "A: expects 'code(hex) min max fuzz flat [resolution]'"))?;
                // A code appears once per device; later lines cannot grow the list past it.
                if !axes.iter().any(|(code, _, _)| *code == axis.0) && axes.len() <= usize::from(u8::MAX) {
                    axes.push(axis);
                }
                described = true;
            }
            "E" => {
                if events.len() >= MAX_EVENTS {
                    return Err(TouchError::TooManyEvents { limit: MAX_EVENTS });
                }
                let content = rest.split('#').next().unwrap_or("");
                let event = parse_event(content).map_err(|problem| parse_error(line_number, problem))?;
                pauses.next(event.time_us).map_err(|problem| parse_error(line_number, problem))?;
                events.push(event);
            }
            _ => return Err(parse_error(line_number, format!("unknown line type '{prefix}:'"))),
        }
    }
    if !described {
        return Err(TouchError::Incomplete {
            format: FORMAT,
            problem: "no device description (N:, B:, A: lines)".into(),
        });
    }
    let keys: Vec<u16> = (0..key_mask.len() * 8)
        .filter(|&bit| key_mask[bit / 8] & (1 << (bit % 8)) != 0)
        .filter_map(|bit| u16::try_from(bit).ok())
        .collect();
    let device = DeviceInfo::from_capabilities(&name, &axes, &keys).ok_or_else(|| TouchError::Incomplete {
        format: FORMAT,
        problem: format!("'{name}' is no touchscreen (no ABS_MT_POSITION_X/Y, nor ABS_X/Y with BTN_TOUCH or BTN_LEFT)"),
    })?;
    Ok(Recording { device, events })
}

fn hex_bytes(text: &str) -> Option<Vec<u8>> {
    let bytes: Option<Vec<u8>> = text.split_whitespace().map(|word| u8::from_str_radix(word, 16).ok()).collect();
    bytes.filter(|b| !b.is_empty())
}

fn parse_axis(text: &str) -> Option<(u16, i32, i32)> {
    let words: Vec<&str> = text.split_whitespace().take(7).collect();
    if !(5..=6).contains(&words.len()) {
        return None;
    }
    let code = u16::from_str_radix(words[0], 16).ok()?;
    let numbers: Option<Vec<i32>> = words[1..].iter().map(|w| w.parse().ok()).collect();
    let numbers = numbers?;
    Some((code, numbers[0], numbers[1])).filter(|(_, min, max)| min <= max)
}

fn parse_event(content: &str) -> Result<RawEvent, String> {
    let words: Vec<&str> = content.split_whitespace().take(5).collect();
    let [time, kind, code, value] = words[..] else {
        return Err(format!("E: expects 'sec.usec type code value', found '{}'", content.trim()));
    };
    let time_us = parse_time_us(time).ok_or_else(|| format!("'{time}' is not a time sec.usec"))?;
    let kind = u16::from_str_radix(kind, 16).map_err(|_| format!("'{kind}' is not a hexadecimal event type"))?;
    let code = u16::from_str_radix(code, 16).map_err(|_| format!("'{code}' is not a hexadecimal event code"))?;
    let value = value.parse::<i32>().map_err(|_| format!("'{value}' is not a 32-bit integer value"))?;
    Ok(RawEvent { time_us, kind, code, value })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::touch::event::*;
    use proptest::prelude::*;

    /// The shape of a real evemu-record capture of a two-finger touchscreen (trimmed).
    const CAPTURE: &str = "# EVEMU 1.3
# Kernel: 6.1.0
# Input device name: \"ELAN Touchscreen\"
N: ELAN Touchscreen
I: 0018 04f3 2a1c 0100
P: 02 00 00 00 00 00 00 00
B: 00 0b 00 00 00 00 00 00 00
B: 01 00 00 00 00 00 00 00 00
B: 01 00 00 00 00 00 00 00 00
B: 01 00 00 00 00 00 00 00 00
B: 01 00 00 00 00 00 00 00 00
B: 01 00 00 00 00 00 00 00 00
B: 01 00 04 00 00 00 00 00 00
B: 03 03 00 00 00 00 80 f3 06
A: 00 0 3200 0 0 13
A: 01 0 1800 0 0 13
A: 2f 0 9 0 0 0
A: 35 0 3200 0 0 13
A: 36 0 1800 0 0 13
A: 39 0 65535 0 0 0
################################
#      Waiting for events      #
################################
E: 0.000001 0003 0039 0017	# EV_ABS / ABS_MT_TRACKING_ID   17
E: 0.000001 0003 0035 1600	# EV_ABS / ABS_MT_POSITION_X    1600
E: 0.000001 0003 0036 0900	# EV_ABS / ABS_MT_POSITION_Y    900
E: 0.000001 0001 014a 0001	# EV_KEY / BTN_TOUCH            1
E: 0.000001 0000 0000 0000	# ------------ SYN_REPORT (0) ---------- +0ms
E: 0.080123 0003 0039 -001	# EV_ABS / ABS_MT_TRACKING_ID   -1
E: 0.080123 0001 014a 0000	# EV_KEY / BTN_TOUCH            0
E: 0.080123 0000 0000 0000	# ------------ SYN_REPORT (0) ---------- +80ms
";

    #[test]
    fn a_capture_parses_into_device_and_events() {
        let recording = parse(CAPTURE).unwrap();
        assert_eq!(recording.device.name, "ELAN Touchscreen");
        assert!(recording.device.multitouch);
        assert_eq!(recording.device.slot_count, 10);
        assert_eq!(recording.device.x, AxisRange::new(0, 3200));
        assert_eq!(recording.device.y, AxisRange::new(0, 1800));
        assert_eq!(recording.events.len(), 8);
        assert_eq!(recording.events[0], RawEvent::new(1, EV_ABS, ABS_MT_TRACKING_ID, 17));
        assert_eq!(recording.events[3], RawEvent::new(1, EV_KEY, BTN_TOUCH, 1));
        assert_eq!(recording.events[5], RawEvent::new(80_123, EV_ABS, ABS_MT_TRACKING_ID, -1));
    }

    #[test]
    fn a_capture_replays_through_the_tracker() {
        use crate::touch::contacts::{ContactTracker, FingerPhase};
        use crate::touch::mapping::ScreenMapping;
        let recording = parse(CAPTURE).unwrap();
        let mut tracker =
            ContactTracker::new(&recording.device, ScreenMapping::new(&recording.device, [1920.0, 1080.0]));
        let mut fingers = Vec::new();
        recording.events.iter().for_each(|event| tracker.feed(event, &mut fingers));
        let got: Vec<_> = fingers.iter().map(|f| (f.phase, f.position, f.time_us)).collect();
        assert_eq!(got, vec![(FingerPhase::Down, [960.0, 540.0], 1), (FingerPhase::Up, [960.0, 540.0], 80_123)]);
    }

    #[test]
    fn a_single_touch_tablet_is_recognised_by_its_key_bits() {
        // BTN_LEFT = 0x110: key byte 34, bit 0.
        let mut mask = vec!["00"; 34];
        mask.push("01");
        let text = format!("N: QEMU Tablet\nB: 01 {}\nA: 00 0 32767 0 0 0\nA: 01 0 32767 0 0 0\n", mask.join(" "));
        let recording = parse(&text).unwrap();
        assert!(!recording.device.multitouch);
        assert_eq!(recording.device.x, AxisRange::new(0, 32767));
        // Without the key it is no touchscreen.
        let error = parse("N: Stick\nA: 00 0 255 0 0 0\nA: 01 0 255 0 0 0\n").unwrap_err();
        assert!(error.to_string().contains("no touchscreen"), "{error}");
    }

    #[test]
    fn errors_name_the_line() {
        let cases = [
            ("N: x\nQ: 1\n", 2, "unknown line type"),
            ("N: x\nA: 35 0\n", 2, "A:"),
            ("N: x\nA: zz 0 1 0 0 0\n", 2, "A:"),
            ("N: x\nB: 01 1ff\n", 2, "B:"),
            ("N: x\nE: 0.1 0003 0035\n", 2, "E:"),
            ("N: x\nE: 0.1 0003 00zz 1\n", 2, "event code"),
            ("N: x\nE: 0.1 0003 0035 1.5\n", 2, "integer"),
            ("N: x\nE: abc 0003 0035 1\n", 2, "time"),
            ("N: x\nhello\n", 2, "expected"),
            ("N: x\nE: 1.000000 0000 0000 0\nE: 10000000001.000000 0000 0000 0\n", 3, "may pause at most 3600 s"),
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
        assert!(parse("# only comments\n").is_err());
    }

    proptest! {
        #[test]
        fn random_text_never_panics(text in "(?s).{0,400}") {
            let _ = parse(&text);
            let _ = parse(&format!("{CAPTURE}{text}"));
        }

        #[test]
        fn random_evemu_lines_never_panic(
            lines in proptest::collection::vec("[NIPBALSE]: ([0-9a-f.-]{0,6} ){0,8}", 0..30)
        ) {
            let _ = parse(&lines.join("\n"));
        }
    }
}
