//! Parsing replay scripts into [`ScriptStep`]s (syntax only; see the parent module for the
//! language). Never panics; each problem names its line.

use super::{FingerStyle, ScriptAction, ScriptError, ScriptStep, SwipeDirection, TouchCommand};

/// Most lines a script may have.
pub const MAX_SCRIPT_LINES: usize = 100_000;
/// Most points in one lasso.
pub const MAX_LASSO_POINTS: usize = 1000;
/// Longest wait, 10 minutes.
pub const MAX_WAIT_MS: u64 = 600_000;
/// Longest press, a minute (a finger held longer is a stuck contact, not a gesture).
pub const MAX_PRESS_MS: u64 = 60_000;
/// Pinch scales accepted.
pub const PINCH_SCALE_RANGE: std::ops::RangeInclusive<f32> = 0.1..=10.0;
/// Rotations accepted, degrees either way.
pub const MAX_ROTATE_DEGREES: f32 = 720.0;

/// Parses a whole script.
pub fn parse(text: &str) -> Result<Vec<ScriptStep>, ScriptError> {
    let mut steps = Vec::new();
    for (index, line) in text.lines().enumerate() {
        if index >= MAX_SCRIPT_LINES {
            return Err(ScriptError::TooLong { limit_lines: MAX_SCRIPT_LINES });
        }
        let line_number = index + 1;
        let source = line.trim();
        if source.is_empty() || source.starts_with('#') {
            continue;
        }
        let action = parse_line(source).map_err(|problem| ScriptError::Syntax { line_number, problem })?;
        steps.push(ScriptStep { line_number, source: source.to_string(), action });
    }
    Ok(steps)
}

/// Splits a line into words; `"quoted words"` are one word (without the quotes).
fn words(line: &str) -> Result<Vec<String>, String> {
    let mut words = Vec::new();
    let mut rest = line.trim_start();
    while !rest.is_empty() {
        if let Some(quoted) = rest.strip_prefix('"') {
            let end = quoted.find('"').ok_or("unterminated quote")?;
            words.push(quoted[..end].to_string());
            rest = quoted[end + 1..].trim_start();
        } else {
            let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
            if rest[..end].contains('"') {
                return Err(format!("stray quote in '{}'", &rest[..end]));
            }
            words.push(rest[..end].to_string());
            rest = rest[end..].trim_start();
        }
    }
    Ok(words)
}

fn parse_line(line: &str) -> Result<ScriptAction, String> {
    let words = words(line)?;
    let Some((keyword, arguments)) = words.split_first() else { return Err("empty line".into()) };
    let arity = |range: std::ops::RangeInclusive<usize>, usage: &str| {
        if range.contains(&arguments.len()) { Ok(()) } else { Err(format!("usage: {usage}")) }
    };
    let element = || arguments.first().cloned().unwrap_or_default();
    let touch = |command: TouchCommand| -> Result<ScriptAction, String> { Ok(ScriptAction::Touch(command)) };
    match keyword.as_str() {
        "lasso" | "path" => {
            if arguments.len() < 4 {
                return Err(format!("usage: {keyword} ELEMENT X,Y X,Y X,Y ... (at least three points)"));
            }
            if arguments.len() - 1 > MAX_LASSO_POINTS {
                return Err(format!("a {keyword} may have at most {MAX_LASSO_POINTS} points"));
            }
            let points = arguments[1..].iter().map(|p| point(p)).collect::<Result<Vec<_>, _>>()?;
            let element = match element().as_str() {
                axis @ ("x" | "y" | "z") => format!("slice {axis}"),
                other => other.to_string(),
            };
            if keyword == "lasso" {
                touch(TouchCommand::Lasso { element, points })
            } else {
                touch(TouchCommand::Path { element, points })
            }
        }
        "tap" | "double-tap" => {
            arity(1..=2, &format!("{keyword} ELEMENT [X,Y]"))?;
            let at = arguments.get(1).map_or(Ok([0.5, 0.5]), |p| point(p))?;
            if keyword == "tap" {
                touch(TouchCommand::Tap { element: element(), at })
            } else {
                touch(TouchCommand::DoubleTap { element: element(), at })
            }
        }
        "press" => {
            arity(2..=3, "press ELEMENT [X,Y] DURATION (e.g. 2s)")?;
            let at = if arguments.len() == 3 { point(&arguments[1])? } else { [0.5, 0.5] };
            let hold_ms = duration_ms(&arguments[arguments.len() - 1])?;
            if hold_ms > MAX_PRESS_MS {
                return Err(format!("a press lasts at most {} s", MAX_PRESS_MS / 1000));
            }
            touch(TouchCommand::Press { element: element(), at, hold_ms })
        }
        "drag" => {
            arity(3..=3, "drag ELEMENT FROM_X,FROM_Y TO_X,TO_Y")?;
            touch(TouchCommand::Drag { element: element(), from: point(&arguments[1])?, to: point(&arguments[2])? })
        }
        "swipe" => {
            arity(2..=2, "swipe ELEMENT left|right|up|down")?;
            let direction = match arguments[1].as_str() {
                "left" => SwipeDirection::Left,
                "right" => SwipeDirection::Right,
                "up" => SwipeDirection::Up,
                "down" => SwipeDirection::Down,
                other => return Err(format!("'{other}' is not left, right, up or down")),
            };
            touch(TouchCommand::Swipe { element: element(), direction })
        }
        "pinch" => {
            arity(2..=2, "pinch ELEMENT SCALE")?;
            let scale = number(&arguments[1])?;
            if !PINCH_SCALE_RANGE.contains(&scale) {
                return Err(format!("pinch scale {scale} is outside {PINCH_SCALE_RANGE:?}"));
            }
            touch(TouchCommand::Pinch { element: element(), scale })
        }
        "pan" => {
            arity(2..=2, "pan ELEMENT DX,DY")?;
            touch(TouchCommand::Pan { element: element(), offset: point(&arguments[1])? })
        }
        "rotate" => {
            arity(2..=2, "rotate ELEMENT DEGREES")?;
            let angle_degrees = number(&arguments[1])?;
            if angle_degrees.abs() > MAX_ROTATE_DEGREES {
                return Err(format!("rotation {angle_degrees} is beyond {MAX_ROTATE_DEGREES} degrees"));
            }
            touch(TouchCommand::Rotate { element: element(), angle_degrees })
        }
        "wait" => {
            arity(1..=1, "wait DURATION (e.g. 500ms, 2s)")?;
            Ok(ScriptAction::Wait { duration_ms: duration_ms(&arguments[0])? })
        }
        "finger" => {
            let mut style = FingerStyle::default();
            let usage = "usage: finger [jitter PX] [speed PX_PER_S]";
            for pair in arguments.chunks(2) {
                let [key, value] = pair else { return Err(usage.into()) };
                let value = number(value)?;
                let (field, range) = match key.as_str() {
                    "jitter" => (&mut style.jitter_px, FingerStyle::JITTER_RANGE_PX),
                    "speed" => (&mut style.speed_px_per_s, FingerStyle::SPEED_RANGE_PX_PER_S),
                    other => return Err(format!("'{other}' is not jitter or speed; {usage}")),
                };
                if !range.contains(&value) {
                    return Err(format!("finger {key} {value} is outside {range:?}"));
                }
                *field = value;
            }
            Ok(ScriptAction::Finger(style))
        }
        "wait-idle" => {
            arity(0..=0, "wait-idle")?;
            Ok(ScriptAction::WaitIdle)
        }
        "screenshot" => {
            arity(1..=1, "screenshot NAME")?;
            let name = &arguments[0];
            let valid = !name.is_empty()
                && !name.starts_with('.')
                && name.chars().all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c));
            if !valid {
                return Err(format!("screenshot name '{name}' must be letters, digits, '-', '_' or '.'"));
            }
            Ok(ScriptAction::Screenshot { name: name.clone() })
        }
        "expect" => {
            if arguments.len() < 2 {
                return Err("usage: expect KEY VALUE".into());
            }
            Ok(ScriptAction::Expect { key: arguments[0].clone(), value: arguments[1..].join(" ") })
        }
        other => Err(format!("unknown command '{other}'")),
    }
}

/// `X,Y`, two finite numbers.
fn point(text: &str) -> Result<[f32; 2], String> {
    let (x, y) = text.split_once(',').ok_or_else(|| format!("'{text}' is not a point X,Y"))?;
    Ok([number(x)?, number(y)?])
}

fn number(text: &str) -> Result<f32, String> {
    text.trim().parse::<f32>().ok().filter(|v| v.is_finite()).ok_or_else(|| format!("'{text}' is not a number"))
}

/// `500ms`, `2s`, `1.5s`.
fn duration_ms(text: &str) -> Result<u64, String> {
    let (number_text, factor) = if let Some(ms) = text.strip_suffix("ms") {
        (ms, 1.0)
    } else if let Some(s) = text.strip_suffix('s') {
        (s, 1000.0)
    } else {
        return Err(format!("'{text}' needs a unit: ms or s"));
    };
    let value = number(number_text)? as f64 * factor;
    if !(0.0..=MAX_WAIT_MS as f64).contains(&value) {
        return Err(format!("wait '{text}' is outside 0 to {MAX_WAIT_MS} ms"));
    }
    Ok(value.round() as u64)
}
