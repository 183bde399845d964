//! The replay harness: the real app on the kiosk platform with a hand-advanced clock, driven
//! by finger events, with screenshots, idle waits and frame-time measurement. `volasso replay`
//! runs scripts through it; the appliance's loop shares its platform and router.
//!
//! Time: the clock moves only when the harness advances it (event times, `wait`), so timers
//! (the idle timeout, double taps) behave the same on a fast and a slow machine; background
//! work (loading, classifying, rendering) runs in real time, and `wait_idle` waits for it.

use super::KioskError;
use super::platform::{Clock, KioskWindow};
use super::router::{Routed, TouchRouter};
use crate::app::{App, AppConfig};
use crate::touch::contacts::FingerEvent;
use crate::touch::script::Rect;
use crate::transfer::RgbImage;
use slint::Rgb8Pixel;
use std::cell::Cell;
use std::rc::Rc;
use std::time::{Duration, Instant};

/// How far the clock moves per frame while waiting: one frame at 60 Hz.
pub const FRAME: Duration = Duration::from_millis(16);

/// Wall-clock durations of UI-thread frames (timers, callbacks, drawing), in seconds.
#[derive(Clone, Debug, Default)]
pub struct FrameTimes {
    pub seconds: Vec<f64>,
}

impl FrameTimes {
    pub fn count(&self) -> usize {
        self.seconds.len()
    }

    /// The `q`-quantile (0..=1) in milliseconds; 0 without frames.
    pub fn quantile_ms(&self, q: f64) -> f64 {
        if self.seconds.is_empty() {
            return 0.0;
        }
        let mut sorted = self.seconds.clone();
        sorted.sort_by(f64::total_cmp);
        let position = ((sorted.len() - 1) as f64 * q.clamp(0.0, 1.0)).round() as usize;
        sorted[position] * 1000.0
    }
}

/// The app under a scripted hand; see the module doc.
pub struct Harness {
    app: App,
    window: KioskWindow,
    now: Rc<Cell<Duration>>,
    router: TouchRouter,
    pixels: Vec<Rgb8Pixel>,
    /// Every frame drawn so far.
    pub frame_times: FrameTimes,
    /// Frames drawn while a classification job ran.
    pub frame_times_while_classifying: FrameTimes,
}

impl Harness {
    /// Installs the kiosk platform (once per process) and starts the app at `size` pixels.
    pub fn new(mut config: AppConfig, size: [u32; 2]) -> Result<Harness, KioskError> {
        let now = Rc::new(Cell::new(Duration::ZERO));
        config.clock = Clock::Manual(now.clone());
        let window = KioskWindow::install(size, config.clock.clone())?;
        let app = App::new(config).map_err(KioskError::StartUi)?;
        use slint::ComponentHandle;
        app.window().show().map_err(KioskError::ShowUi)?;
        let pixels = vec![Rgb8Pixel::default(); size[0] as usize * size[1] as usize];
        let mut harness = Harness {
            app,
            window,
            now,
            router: TouchRouter::default(),
            pixels,
            frame_times: FrameTimes::default(),
            frame_times_while_classifying: FrameTimes::default(),
        };
        harness.frame();
        Ok(harness)
    }

    pub fn app(&self) -> &App {
        &self.app
    }

    pub fn size(&self) -> [u32; 2] {
        self.window.size()
    }

    /// The clock's time since start.
    pub fn now(&self) -> Duration {
        self.now.get()
    }

    /// Where the element with accessible label `label` is on screen (the first visible one).
    pub fn element_rect(&self, label: &str) -> Option<Rect> {
        self.app.element_rect(label)
    }

    /// The accessible value of the element with accessible label `label`, and where it is.
    pub fn element_value(&self, label: &str) -> Option<(Rect, String)> {
        self.app.element_value(label)
    }

    /// Feeds one finger event at its time (the clock moves there first, frame by frame).
    pub fn finger(&mut self, event: &FingerEvent) {
        self.advance_to(Duration::from_micros(event.time_us));
        let app = &self.app;
        let mut routed = Vec::new();
        self.router.route(event, &|label| app.element_rect(label), &mut routed);
        if !routed.is_empty() {
            self.app.note_input();
        }
        for action in routed {
            match action {
                Routed::Pointer(window_event) => self.window.dispatch(window_event),
                Routed::ViewGesture { zoom, pan_pixels, turn_degrees } => {
                    self.app.view_gesture(zoom, pan_pixels, turn_degrees)
                }
                Routed::SliceGesture { axis, zoom, pan_fraction } => self.app.slice_gesture(axis, zoom, pan_fraction),
            }
        }
    }

    /// Moves the clock to `time` (never back), drawing a frame every [`FRAME`] on the way.
    pub fn advance_to(&mut self, time: Duration) {
        while self.now.get() + FRAME <= time {
            self.now.set(self.now.get() + FRAME);
            self.frame();
        }
        if time > self.now.get() {
            self.now.set(time);
            self.frame();
        }
    }

    pub fn wait(&mut self, duration: Duration) {
        self.advance_to(self.now.get() + duration);
    }

    /// Runs frames until nothing is loading, classifying or rendering (background work runs
    /// in real time, so this also sleeps); fails after `timeout` of real time.
    pub fn wait_idle(&mut self, timeout: Duration) -> Result<(), KioskError> {
        let started = Instant::now();
        let mut idle_frames = 0;
        while idle_frames < 3 {
            if started.elapsed() > timeout {
                return Err(KioskError::StillBusy { seconds: timeout.as_secs() });
            }
            std::thread::sleep(Duration::from_millis(2));
            self.now.set(self.now.get() + FRAME);
            self.frame();
            idle_frames = if self.app.is_idle() { idle_frames + 1 } else { 0 };
        }
        Ok(())
    }

    /// One UI frame: due timers (the app's poll among them), then drawing if anything changed.
    fn frame(&mut self) {
        let started = Instant::now();
        self.window.update_timers();
        let width = self.window.size()[0] as usize;
        let drawn = self.window.draw_if_needed(&mut self.pixels, width);
        let seconds = started.elapsed().as_secs_f64();
        if drawn {
            self.frame_times.seconds.push(seconds);
            if self.app.query("classifying").as_deref() == Some("true") {
                self.frame_times_while_classifying.seconds.push(seconds);
            }
        }
    }

    /// The screen as it is now.
    pub fn screenshot(&mut self) -> RgbImage {
        self.window.request_redraw();
        self.frame();
        let [width, height] = self.window.size();
        let pixels = self.pixels.iter().flat_map(|p| [p.r, p.g, p.b]).collect();
        RgbImage { width: width as usize, height: height as usize, pixels }
    }
}
