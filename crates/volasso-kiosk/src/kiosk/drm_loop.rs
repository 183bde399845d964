//! The appliance's main loop: the app drawn by Slint's software renderer straight into a DRM
//! display's buffers, touch from the project's evdev reader (the kiosk crate's touch) through the same
//! router as the replay harness (without depending on it), systemd told when the UI is up and that it is alive.
//!
//! Why this reader and not Slint's libinput path: it is the code the replay tests exercise,
//! it computes multi-touch gestures in Rust (Slint has no public multi-touch events), and it
//! needs neither libinput nor Slint's linuxkms backend (see platform.rs).
//!
//! Never: exits on its own; systemd's `Restart=always` brings it back if it dies.

use super::KioskError;
use super::platform::{Clock, KioskWindow, Xrgb8888};
use super::router::{Routed, TouchRouter};
use crate::app::{App, AppConfig};
use crate::display::DrmDisplay;
use crate::touch::contacts::{ContactTracker, FingerEvent};
use crate::touch::device::TouchDevice;
use crate::touch::mapping::{Rotation, ScreenMapping};
use std::path::PathBuf;
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

/// The longest the loop sleeps: a frame at 60 Hz.
const FRAME: Duration = Duration::from_millis(16);

/// Which touchscreen, and how its axes map to the display.
#[derive(Clone, Debug, Default)]
pub struct TouchOptions {
    /// `None`: the first touchscreen found; no touch (with a warning) when there is none.
    pub device: Option<PathBuf>,
    pub disabled: bool,
    pub rotation_degrees: i32,
    pub flip_x: bool,
    pub flip_y: bool,
}

/// Runs the UI fullscreen on the DRM display `card` (the first connected one when `None`).
/// The UI is sized for `config.dpi` when set (`--dpi`), else for the panel's density from the
/// connector's physical size when believable (dpi.rs).
pub fn run(mut config: AppConfig, card: Option<PathBuf>, touch: TouchOptions) -> Result<(), KioskError> {
    let mut display = DrmDisplay::open(card.as_deref())?;
    let size = display.size();
    let panel_dpi = display.physical_size_mm().and_then(|mm| crate::app::dpi::from_physical_size(size, mm));
    config.dpi = Some(crate::app::dpi::resolve(config.dpi, panel_dpi));
    log::info!("panel {:?} mm, UI at {:.0} dpi", display.physical_size_mm(), config.dpi.unwrap_or_default());
    config.clock = Clock::Real(Instant::now());
    let window = KioskWindow::install(size, config.clock.clone())?;
    let app = App::new(config).map_err(KioskError::StartUi)?;
    use slint::ComponentHandle;
    app.window().show().map_err(KioskError::ShowUi)?;
    let fingers = start_touch(&touch, size);
    let mut router = TouchRouter::default();
    let mut routed = Vec::new();
    let mut pixels = vec![Xrgb8888::default(); size[0] as usize * size[1] as usize];
    let mut ready = false;
    let watchdog = Watchdog::from_environment();
    loop {
        let timeout = window.until_next_timer().unwrap_or(FRAME).min(FRAME);
        if let Some(fingers) = &fingers {
            match fingers.recv_timeout(timeout) {
                Ok(first) => {
                    for event in std::iter::once(first).chain(fingers.try_iter()) {
                        routed.clear();
                        router.route(&event, &|label| app.element_rect(label), &mut routed);
                        deliver(&app, &window, &mut routed);
                    }
                }
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => {}
            }
        } else {
            std::thread::sleep(timeout);
        }
        window.update_timers();
        if window.draw_if_needed(&mut pixels, size[0] as usize) {
            display.present(|target, stride| copy_rows(&pixels, size, target, stride))?;
            if !ready {
                ready = true;
                println!("volasso: ready {}x{}", size[0], size[1]);
                watchdog.notify("READY=1");
            }
        }
        watchdog.keep_alive();
    }
}

fn deliver(app: &App, window: &KioskWindow, routed: &mut Vec<Routed>) {
    if !routed.is_empty() {
        app.note_input();
    }
    for action in routed.drain(..) {
        match action {
            Routed::Pointer(event) => window.dispatch(event),
            Routed::ViewGesture { zoom, pan_pixels, turn_degrees } => app.view_gesture(zoom, pan_pixels, turn_degrees),
            Routed::SliceGesture { axis, zoom, pan_fraction } => app.slice_gesture(axis, zoom, pan_fraction),
        }
    }
}

fn copy_rows(pixels: &[Xrgb8888], size: [u32; 2], target: &mut [u32], stride: usize) {
    let width = size[0] as usize;
    for (row, source) in pixels.chunks_exact(width).enumerate() {
        if let Some(destination) = target.get_mut(row * stride..row * stride + width) {
            destination.copy_from_slice(bytemuck::cast_slice(source));
        }
    }
}

/// Finger events from the touchscreen, or `None` (logged) when there is none.
fn start_touch(options: &TouchOptions, size: [u32; 2]) -> Option<Receiver<FingerEvent>> {
    if options.disabled {
        return None;
    }
    let device = match &options.device {
        Some(path) => TouchDevice::open(path),
        None => TouchDevice::open_first(),
    };
    let device = match device {
        Ok(device) => device,
        Err(error) => {
            log::warn!("no touch input: {error}");
            return None;
        }
    };
    let rotation = Rotation::from_degrees(options.rotation_degrees).unwrap_or_else(|| {
        log::warn!("touch rotation {} is not 0, 90, 180 or 270; using 0", options.rotation_degrees);
        Rotation::from_degrees(0).unwrap_or_default()
    });
    let mapping = ScreenMapping::new(device.info(), [size[0] as f32, size[1] as f32])
        .with_rotation(rotation)
        .with_flip(options.flip_x, options.flip_y);
    log::info!("touch from {} ({})", device.path().display(), device.info().name);
    let tracker = ContactTracker::new(device.info(), mapping);
    let (sender, receiver) = channel();
    match device.spawn_finger_reader(tracker, sender) {
        Ok(_) => Some(receiver),
        Err(error) => {
            log::warn!("no touch input: {error}");
            None
        }
    }
}

/// systemd's notification socket: readiness once, then keep-alives at half the watchdog
/// interval (`WATCHDOG_USEC`). Without `NOTIFY_SOCKET` it does nothing.
struct Watchdog {
    socket: Option<(std::os::unix::net::UnixDatagram, std::os::unix::net::SocketAddr)>,
    interval: Option<Duration>,
    last: std::cell::Cell<Instant>,
}

impl Watchdog {
    fn from_environment() -> Watchdog {
        let socket = std::env::var("NOTIFY_SOCKET").ok().and_then(|path| {
            let address = match path.strip_prefix('@') {
                Some(abstract_name) => {
                    use std::os::linux::net::SocketAddrExt;
                    std::os::unix::net::SocketAddr::from_abstract_name(abstract_name.as_bytes()).ok()?
                }
                None => std::os::unix::net::SocketAddr::from_pathname(path).ok()?,
            };
            Some((std::os::unix::net::UnixDatagram::unbound().ok()?, address))
        });
        let interval = std::env::var("WATCHDOG_USEC")
            .ok()
            .and_then(|usec| usec.parse::<u64>().ok())
            .map(|usec| Duration::from_micros(usec / 2));
        Watchdog { socket, interval, last: std::cell::Cell::new(Instant::now()) }
    }

    fn notify(&self, message: &str) {
        if let Some((socket, address)) = &self.socket
            && let Err(error) = socket.send_to_addr(message.as_bytes(), address)
        {
            log::warn!("cannot notify systemd: {error}");
        }
    }

    fn keep_alive(&self) {
        if let Some(interval) = self.interval
            && self.last.get().elapsed() >= interval
        {
            self.last.set(Instant::now());
            self.notify("WATCHDOG=1");
        }
    }
}
