//! `volasso replay SCRIPT... [--screenshots DIR]`: the real UI, headless, driven by a touch script
//! (crates/volasso-replay/src/replay.rs). Prints one JSON line with what ran and the UI thread's frame times;
//! exits non-zero when an expectation failed.

use super::CliError;
use super::args::parse_size;
use super::ui::UiArgs;
use crate::kiosk::replay::{self, ReplayOptions};
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// Readable touch scripts or `volasso-events/1` / evemu-record recordings, run one after
    /// another on the same UI.
    #[arg(required = true)]
    pub scripts: Vec<PathBuf>,
    /// Where `screenshot NAME` lines write NAME.png.
    #[arg(long)]
    pub screenshots: Option<PathBuf>,
    /// Writes every event the script produced as a `volasso-events/1` recording.
    #[arg(long, value_name = "FILE")]
    pub events_out: Option<PathBuf>,
    /// The screen size in pixels.
    #[arg(long, default_value = "1280x800", value_parser = parse_size, value_name = "WxH")]
    pub size: [u32; 2],
    /// Open this volume at once (a file, a DICOM folder, or `demo`) instead of the start screen.
    #[arg(long)]
    pub volume: Option<PathBuf>,
    /// The folder whose volumes the chooser offers.
    #[arg(long)]
    pub data_dir: Option<PathBuf>,
    /// Where the session is autosaved and restored from.
    #[arg(long)]
    pub session_dir: Option<PathBuf>,
    /// Seconds of script time without a touch before the start screen returns; 0 never
    /// [default: the settings' `idle_timeout_s` in --data-dir, else 120].
    #[arg(long)]
    pub idle_timeout: Option<u64>,
    /// The screen's pixel density, which sizes touch targets and text (default 150).
    #[arg(long, value_parser = super::args::parse_dpi, value_name = "DPI")]
    pub dpi: Option<f32>,
    #[command(flatten)]
    pub pacs: super::ui::KioskPacsArgs,
}

pub fn run(args: &ReplayArgs) -> Result<(), CliError> {
    if let Some(events_out) = &args.events_out {
        let mut inputs: Vec<(&'static str, &std::path::Path)> =
            args.scripts.iter().map(|script| ("touch script", script.as_path())).collect();
        inputs.extend(args.volume.iter().map(|volume| ("volume (--volume)", volume.as_path())));
        super::outputs::check(&inputs, &[("event recording (--events-out)", events_out)])?;
    }
    let ui = UiArgs {
        volume: args.volume.clone(),
        data_dir: args.data_dir.clone(),
        session_dir: args.session_dir.clone(),
        idle_timeout: args.idle_timeout,
        dpi: args.dpi,
        pacs: args.pacs.clone(),
        ..UiArgs::default()
    };
    let options = ReplayOptions {
        scripts: args.scripts.clone(),
        screenshots: args.screenshots.clone(),
        events_out: args.events_out.clone(),
        size: args.size,
        config: ui.config()?,
    };
    let report = replay::run(&options)?;
    let frames = |times: &crate::kiosk::harness::FrameTimes| {
        serde_json::json!({
            "count": times.count(),
            "median_ms": times.quantile_ms(0.5),
            "p95_ms": times.quantile_ms(0.95),
            "max_ms": times.quantile_ms(1.0),
        })
    };
    let line = serde_json::json!({
        "scripts": args.scripts.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "steps": report.steps,
        "events": report.events,
        "failures": report.failures,
        "screenshots": report.screenshots.iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
        "frames": frames(&report.frames),
        "frames_while_classifying": frames(&report.frames_while_classifying),
        "script_seconds": report.script_seconds,
        "wall_seconds": report.wall_seconds,
        "events_per_second": report.events as f64 / report.wall_seconds.max(1e-9),
        "final_screen": report.final_screen,
        "ui_thread_syncs": report.ui_thread_syncs,
        "elements": report.elements,
        "peak_resident_mb": super::memory::resident_memory().map(|m| m.peak_bytes as f64 / 1e6),
    });
    println!("{line}");
    for failure in &report.failures {
        eprintln!("volasso replay: {failure}");
    }
    if report.failures.is_empty() {
        Ok(())
    } else {
        Err(CliError::ExpectationsFailed { failed: report.failures.len() })
    }
}
