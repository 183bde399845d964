//! `volasso replay`: runs a touch script against the real UI, headless. A script is
//! either readable (`tap "Define class"`, `lasso z 0.3,0.4 ...`, see touch/script) or an
//! event recording (`volasso-events/1` or evemu-record text). Readable commands become
//! type-B multitouch events of a virtual touchscreen, and every event, scripted or recorded,
//! goes through the contact tracker and router the appliance uses with a real panel. A
//! command's finger jitter is seeded by its place in the run, not by the clock (which idle
//! waits move by however long the work took), so a script draws the same paths on every run.
//!
//! Expectations (`expect KEY VALUE`): `checks`.

mod checks;

use super::KioskError;
use super::harness::{FrameTimes, Harness};
use crate::app::AppConfig;
use crate::touch::contacts::ContactTracker;
use crate::touch::event::{DeviceInfo, RawEvent};
use crate::touch::format::EventsText;
use crate::touch::mapping::ScreenMapping;
use crate::touch::script::{self, ElementLocator, Rect, ScriptAction};
use crate::transfer::RgbImage;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// How long `wait-idle` may wait for background work, in real time.
pub const IDLE_TIMEOUT: Duration = Duration::from_secs(300);

/// A replay run's settings.
#[derive(Clone, Debug)]
pub struct ReplayOptions {
    /// Run one after another on the same UI.
    pub scripts: Vec<PathBuf>,
    pub screenshots: Option<PathBuf>,
    /// The events the script compiled to, written as `volasso-events/1` (replayable).
    pub events_out: Option<PathBuf>,
    pub size: [u32; 2],
    pub config: AppConfig,
}

/// What a run did and measured.
#[derive(Debug, Default)]
pub struct ReplayReport {
    pub steps: usize,
    pub events: usize,
    pub failures: Vec<String>,
    pub screenshots: Vec<PathBuf>,
    pub frames: FrameTimes,
    pub frames_while_classifying: FrameTimes,
    pub script_seconds: f64,
    pub wall_seconds: f64,
    /// `screen` at the end (the UI still answers queries).
    pub final_screen: String,
    /// Files or folders the app flushed to disk on the UI thread from its start to the end of
    /// the scripts (the autosave writes on its own thread; a restore's marker is the one write
    /// at start-up); the harness's own screenshots are not counted.
    pub ui_thread_syncs: u64,
    /// Where each element an `expect element NAME` found was, in screen pixels (x, y, width,
    /// height): what a test that drives the UI from outside (the image test) needs to know.
    pub elements: std::collections::BTreeMap<String, [f32; 4]>,
}

struct Locator<'a>(&'a Harness);

impl ElementLocator for Locator<'_> {
    fn screen_size(&self) -> [f32; 2] {
        self.0.size().map(|side| side as f32)
    }

    fn element_rect(&self, name: &str) -> Option<Rect> {
        self.0.element_rect(name)
    }
}

/// Runs the scripts; `Err` when one cannot run at all, failed expectations in the report.
pub fn run(options: &ReplayOptions) -> Result<ReplayReport, KioskError> {
    let started = Instant::now();
    // Counted from before the app starts: a restore's marker is written at start-up.
    let syncs_before = crate::atomic_file::syncs_on_this_thread();
    let mut harness = Harness::new(options.config.clone(), options.size)?;
    let mut run = Run {
        report: ReplayReport::default(),
        compiled: EventsText::new(&DeviceInfo::virtual_touchscreen()),
        taken: HashMap::new(),
        results: HashMap::new(),
        screenshot_syncs: 0,
    };
    for script in &options.scripts {
        run.script(&mut harness, script, options.screenshots.as_deref())?;
    }
    let ui_thread_syncs = crate::atomic_file::syncs_on_this_thread() - syncs_before - run.screenshot_syncs;
    if let Some(path) = &options.events_out {
        let text = run.compiled.finish();
        crate::atomic_file::write_atomically(path, |writer| std::io::Write::write_all(writer, text.as_bytes()))
            .map_err(|source| KioskError::Write { source, path: path.clone() })?;
    }
    let mut report = run.report;
    report.frames = harness.frame_times.clone();
    report.frames_while_classifying = harness.frame_times_while_classifying.clone();
    report.script_seconds = harness.now().as_secs_f64();
    report.wall_seconds = started.elapsed().as_secs_f64();
    report.final_screen = harness.app().query("screen").unwrap_or_default();
    report.ui_thread_syncs = ui_thread_syncs;
    Ok(report)
}

/// What one run accumulates over its scripts.
struct Run {
    report: ReplayReport,
    compiled: EventsText,
    taken: HashMap<String, RgbImage>,
    /// The app's result digest at each screenshot, for `same-result`.
    results: HashMap<String, String>,
    /// Disk flushes of the screenshots the harness wrote (on the UI thread, but not the app's).
    screenshot_syncs: u64,
}

impl Run {
    fn script(&mut self, harness: &mut Harness, path: &Path, screenshots: Option<&Path>) -> Result<(), KioskError> {
        let text = read_script(path)?;
        let device = DeviceInfo::virtual_touchscreen();
        if is_recording(&text) {
            let recording = crate::touch::read_recording(path)
                .map_err(|source| KioskError::Recording { source, path: path.to_path_buf() })?;
            let first = recording.events.first().map_or(0, |e| e.time_us);
            let start = harness.now().as_micros() as u64 + 1_000;
            let events: Vec<RawEvent> = recording
                .events
                .iter()
                .map(|e| RawEvent { time_us: start + e.time_us.saturating_sub(first), ..*e })
                .collect();
            self.feed(harness, &recording.device, &events);
            return harness.wait_idle(IDLE_TIMEOUT);
        }
        let steps = script::parse(&text).map_err(|source| KioskError::Script { source, path: path.to_path_buf() })?;
        let mut finger = script::FingerStyle::default();
        for step in &steps {
            self.report.steps += 1;
            self.compiled.comment(&step.source);
            let at = |problem: String| format!("{}:{}: {problem}", path.display(), step.line_number);
            match &step.action {
                ScriptAction::Touch(command) => {
                    // The clock after an idle wait depends on how long the work took; the
                    // jitter's seed must not, or one script would draw other lassos each run.
                    let start_us = harness.now().as_micros() as u64 + 1_000;
                    let seed = self.report.steps as u64;
                    match script::touch_events_seeded(command, &Locator(harness), &device, start_us, seed, &finger) {
                        Ok(events) => self.feed(harness, &device, &events),
                        Err(error) => self.report.failures.push(at(error.to_string())),
                    }
                }
                ScriptAction::Finger(style) => finger = *style,
                ScriptAction::Wait { duration_ms } => harness.wait(Duration::from_millis(*duration_ms)),
                ScriptAction::WaitIdle => {
                    if let Err(error) = harness.wait_idle(IDLE_TIMEOUT) {
                        self.report.failures.push(at(error.to_string()));
                    }
                }
                ScriptAction::Screenshot { name } => {
                    let image = harness.screenshot();
                    if let Some(dir) = screenshots {
                        let file = dir.join(format!("{name}.png"));
                        std::fs::create_dir_all(dir)
                            .map_err(|source| KioskError::Write { source, path: dir.to_path_buf() })?;
                        let before = crate::atomic_file::syncs_on_this_thread();
                        crate::transfer::write_png(&file, &image)?;
                        self.screenshot_syncs += crate::atomic_file::syncs_on_this_thread() - before;
                        self.report.screenshots.push(file);
                    }
                    self.taken.insert(name.clone(), image);
                    self.results.insert(name.clone(), harness.app().result_digest());
                }
                ScriptAction::Expect { key, value } => {
                    if key == "element"
                        && let Some(rect) = harness.element_rect(value)
                    {
                        self.report.elements.insert(value.clone(), [rect.x, rect.y, rect.width, rect.height]);
                    }
                    let result = match key.as_str() {
                        "same-result" => checks::same_result(harness, &self.taken, &self.results, value),
                        "view-steady" => checks::view_steady(harness, value),
                        _ => checks::expect(harness, &self.taken, key, value),
                    };
                    if let Err(message) = result {
                        self.report.failures.push(at(message));
                    }
                }
            }
        }
        Ok(())
    }

    /// Sends raw events through a contact tracker for `device` into the harness.
    fn feed(&mut self, harness: &mut Harness, device: &DeviceInfo, events: &[RawEvent]) {
        let size = harness.size().map(|side| side as f32);
        let mut tracker = ContactTracker::new(device, ScreenMapping::new(device, size));
        let mut fingers = Vec::new();
        for event in events {
            self.compiled.event(event);
            self.report.events += 1;
            fingers.clear();
            tracker.feed(event, &mut fingers);
            for finger in &fingers {
                harness.finger(finger);
            }
            harness.advance_to(Duration::from_micros(event.time_us));
        }
        // A recording may end with fingers down; lift them so the next command starts clean.
        fingers.clear();
        tracker.cancel_all(harness.now().as_micros() as u64, &mut fingers);
        for finger in &fingers {
            harness.finger(finger);
        }
    }
}

/// A touch script or recording: a regular UTF-8 file of at most a recording's ceiling
/// (`touch::format::MAX_FILE_BYTES`), so a FIFO or `/dev/zero` is refused, not read for ever.
fn read_script(path: &std::path::Path) -> Result<String, KioskError> {
    Ok(crate::input_file::read_text(path, "touch script", crate::touch::format::MAX_FILE_BYTES)?)
}

/// Event recordings start with their format line or carry evemu's `E:` event lines.
fn is_recording(text: &str) -> bool {
    text.trim_start().starts_with(crate::touch::format::MAGIC)
        || text.lines().any(|line| line.starts_with("E:") || line.starts_with("N:"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recordings_are_told_from_scripts() {
        assert!(is_recording("volasso-events/1\n"));
        assert!(is_recording("# EVEMU 1.3\nN: panel\nE: 0.000001 0003 0039 0000\n"));
        assert!(!is_recording("tap Start\nwait-idle\n"));
    }
}
