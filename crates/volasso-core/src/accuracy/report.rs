//! The harness's tables: one row per case, hand and method (macro and per-class Dice, time),
//! then the mean macro Dice per method over the tuning and the check cases, clean and leaky
//! lassos side by side.

use super::{CaseRole, Hand, Method, Outcome};
use std::fmt::Write;

fn role_name(role: CaseRole) -> &'static str {
    match role {
        CaseRole::Tune => "tune",
        CaseRole::Check => "check",
    }
}

/// One line of the table.
pub fn row(outcome: &Outcome) -> String {
    let per_class: Vec<String> = outcome
        .class_names
        .iter()
        .zip(&outcome.dice)
        .map(|(name, dice)| format!("{}={dice:.3}", name.replace(' ', "_")))
        .collect();
    format!(
        "{:<9} {:>4} {:<5} {:<5} {:<17} {:>6.3} {:>7.0} ms  {}",
        outcome.case.kind.name(),
        outcome.case.seed,
        role_name(outcome.case.role()),
        outcome.hand.name(),
        outcome.method.name(),
        outcome.macro_dice(),
        outcome.seconds * 1000.0,
        per_class.join(" ")
    )
}

/// The table's column titles, aligned with [`row`].
pub fn header() -> String {
    format!(
        "{:<9} {:>4} {:<5} {:<5} {:<17} {:>6} {:>10}  per-class Dice",
        "case", "seed", "role", "hand", "method", "macro", "time"
    )
}

/// Mean macro Dice of `method` drawn by `hand` over the outcomes of `role` (`None` for any
/// role); `None` when there are no such outcomes.
pub fn mean_macro_dice(outcomes: &[Outcome], method: Method, hand: Hand, role: Option<CaseRole>) -> Option<f64> {
    let values: Vec<f64> = outcomes
        .iter()
        .filter(|o| o.method == method && o.hand == hand && role.is_none_or(|r| o.case.role() == r))
        .map(Outcome::macro_dice)
        .collect();
    (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
}

/// Mean macro Dice per method over tuning and check cases, one pair of columns per hand, and
/// the median time.
pub fn summary(outcomes: &[Outcome], methods: &[Method], hands: &[Hand]) -> String {
    let mut text = format!("{:<17}", "method");
    for hand in hands {
        let _ = write!(text, " {:>12} {:>12}", format!("{} tune", hand.name()), format!("{} check", hand.name()));
    }
    let _ = writeln!(text, " {:>12}", "median time");
    let show = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
    for &method in methods {
        let mut times: Vec<f64> = outcomes.iter().filter(|o| o.method == method).map(|o| o.seconds).collect();
        times.sort_by(f64::total_cmp);
        let median = times.get(times.len() / 2).map_or(0.0, |t| t * 1000.0);
        let _ = write!(text, "{:<17}", method.name());
        for &hand in hands {
            let tune = mean_macro_dice(outcomes, method, hand, Some(CaseRole::Tune));
            let check = mean_macro_dice(outcomes, method, hand, Some(CaseRole::Check));
            let _ = write!(text, " {:>12} {:>12}", show(tune), show(check));
        }
        let _ = writeln!(text, " {median:>9.0} ms");
    }
    text
}

/// One JSON object per outcome (for `--json`).
pub fn json(outcome: &Outcome) -> serde_json::Value {
    serde_json::json!({
        "case": outcome.case.kind.name(),
        "seed": outcome.case.seed,
        "role": role_name(outcome.case.role()),
        "hand": outcome.hand.name(),
        "method": outcome.method.name(),
        "macro_dice": outcome.macro_dice(),
        "dice": outcome.class_names.iter().zip(&outcome.dice).map(|(n, d)| (n.to_string(), serde_json::json!(d))).collect::<serde_json::Map<String, serde_json::Value>>(),
        "training_voxels": outcome.training_voxels,
        "seconds": outcome.seconds,
    })
}
