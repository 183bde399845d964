//! The harness's table: one row per case and method (macro and per-class Dice, time), then
//! the mean macro Dice per method over the tuning and over the check cases.

use super::{CaseRole, Method, Outcome};
use std::fmt::Write;

/// One line of the table.
pub fn row(outcome: &Outcome) -> String {
    let per_class: Vec<String> = outcome
        .class_names
        .iter()
        .zip(&outcome.dice)
        .map(|(name, dice)| format!("{}={dice:.3}", name.replace(' ', "_")))
        .collect();
    format!(
        "{:<9} {:>4} {:<5} {:<17} {:>6.3} {:>7.0} ms  {}",
        outcome.case.kind.name(),
        outcome.case.seed,
        match outcome.case.role() {
            CaseRole::Tune => "tune",
            CaseRole::Check => "check",
        },
        outcome.method.name(),
        outcome.macro_dice(),
        outcome.seconds * 1000.0,
        per_class.join(" ")
    )
}

pub fn header() -> String {
    format!("{:<9} {:>4} {:<5} {:<17} {:>6} {:>10}  per-class Dice", "case", "seed", "role", "method", "macro", "time")
}

/// Mean macro Dice of `method` over the outcomes of `role` (`None` when there are none).
pub fn mean_macro_dice(outcomes: &[Outcome], method: Method, role: Option<CaseRole>) -> Option<f64> {
    let values: Vec<f64> = outcomes
        .iter()
        .filter(|o| o.method == method && role.is_none_or(|r| o.case.role() == r))
        .map(Outcome::macro_dice)
        .collect();
    (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
}

/// Mean macro Dice and median time per method, over tuning cases, check cases and all.
pub fn summary(outcomes: &[Outcome], methods: &[Method]) -> String {
    let mut text = format!("{:<17} {:>8} {:>8} {:>8} {:>12}\n", "method", "tune", "check", "all", "median time");
    let show = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
    for &method in methods {
        let mut times: Vec<f64> = outcomes.iter().filter(|o| o.method == method).map(|o| o.seconds).collect();
        times.sort_by(f64::total_cmp);
        let median = times.get(times.len() / 2).map_or(0.0, |t| t * 1000.0);
        let _ = writeln!(
            text,
            "{:<17} {:>8} {:>8} {:>8} {:>9.0} ms",
            method.name(),
            show(mean_macro_dice(outcomes, method, Some(CaseRole::Tune))),
            show(mean_macro_dice(outcomes, method, Some(CaseRole::Check))),
            show(mean_macro_dice(outcomes, method, None)),
            median
        );
    }
    text
}

/// One JSON object per outcome (for `--json`).
pub fn json(outcome: &Outcome) -> serde_json::Value {
    serde_json::json!({
        "case": outcome.case.kind.name(),
        "seed": outcome.case.seed,
        "role": match outcome.case.role() { CaseRole::Tune => "tune", CaseRole::Check => "check" },
        "method": outcome.method.name(),
        "macro_dice": outcome.macro_dice(),
        "dice": outcome.class_names.iter().zip(&outcome.dice).map(|(n, d)| (n.to_string(), serde_json::json!(d))).collect::<serde_json::Map<String, serde_json::Value>>(),
        "training_voxels": outcome.training_voxels,
        "seconds": outcome.seconds,
    })
}
