//! The kiosk app: the Slint UI (`ui/*.slint`) over the pipeline, as one model, one update and
//! one view (the Module / Widget / Logic split):
//!
//! * `model/`: [`Screen`] and everything the screens show, Slint-free; each window callback is
//!   an `Intent`, `AppModel::update` applies it and says what to show again (`Show`). Each
//!   feature's part of the update is in its folder (`chooser/loading.rs`, `lasso/`,
//!   `view3d/tools.rs`, `gallery/app.rs`, `presets/app.rs`, `pacs/app.rs`, `settings/app.rs`,
//!   `attract/app.rs`, `guidance.rs`), tested without a window, a thread or a GPU.
//! * Everything slow runs behind the `Worker` trait (`worker.rs`): scans open on loader
//!   threads, the classifier on a job thread (`jobs.rs`), the 3-D view on its render thread
//!   (`view3d/`), the slice pictures on the painter (`painter.rs`), the autosave, gallery,
//!   preset, snapshot, expiry, audit and PACS writers; the UI thread never waits for them.
//! * `callbacks.rs` maps each callback to its intent; `view/` and each feature's `view.rs`
//!   write the model into the Slint globals: the only Slint-bound code with this file.
//!
//! Slices are shown as a radiologist expects them (axial, coronal and sagittal panels with the
//! patient's directions at their edges), lassos are kept in voxel coordinates whatever the
//! flips, display windows never reach the classifier, and every file is hostile: one that
//! fails or panics its reader becomes a "Cannot open" card; a session that cannot be restored
//! is set aside with a banner (`autosave.rs`).
//!
//! Never: draws pixels itself or reads input devices; the platform (the kiosk crate or Slint's
//! own winit backend) does. This crate depends on no display, touch device or command-line
//! code, so cargo refuses an import of them here.

mod attract;
mod audit;
pub mod autosave;
mod callbacks;
pub mod chooser;
pub mod clock;
mod config;
pub use config::{AppConfig, DEFAULT_IDLE_TIMEOUT};
mod controller;
pub mod dpi;
mod elements;
mod expiry;
pub use elements::Rect;
pub mod gallery;
mod guidance;
mod idle;
pub mod jobs;
pub mod lasso;
pub mod memory;
mod model;
pub use model::Screen;
pub mod pacs;
mod painter;
pub mod patient;
pub mod pictures;
pub mod presets;
mod queries;
mod saver;
pub mod session;
pub mod settings;
pub mod ui;
mod view;
pub mod view3d;
pub mod windowing;
pub mod words;
mod work;
pub mod worker;
use work::Work;

use model::{AppModel, Intent};
use slint::ComponentHandle;
use std::cell::RefCell;
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::Arc;
use std::time::Duration;
use ui::AppWindow;
use volasso_core::slices::Axis;
use volasso_core::strokes::StrokesFile;

/// How often finished work is collected.
pub(crate) const POLL_INTERVAL: Duration = Duration::from_millis(16);

/// The model and the rows the view keeps for Slint, shared by the callbacks and the poll
/// timer (on the UI thread only). It reads as the model.
pub(crate) struct State {
    model: AppModel,
    rows: view::Rows,
}

impl std::ops::Deref for State {
    type Target = AppModel;
    fn deref(&self) -> &AppModel {
        &self.model
    }
}

impl std::ops::DerefMut for State {
    fn deref_mut(&mut self) -> &mut AppModel {
        &mut self.model
    }
}

/// The running app: the window, its state, and the timer that drives it.
pub struct App {
    window: AppWindow,
    state: Rc<RefCell<State>>,
    _poll_timer: slint::Timer,
}

impl Drop for App {
    /// The render thread is joined here rather than when `State` goes: the window's callbacks
    /// share `State`, and the process must not exit with the thread inside the GPU driver.
    fn drop(&mut self) {
        if let Ok(mut state) = self.state.try_borrow_mut() {
            state.ctl.renderer.shut_down();
            state.ctl.flush();
        }
    }
}

impl App {
    /// Builds the UI on the current Slint platform. With a saved session in
    /// `config.session_dir`, its volume opens and its classes come back. Volumes decode into
    /// at most the kiosk's memory ceiling ([`memory`]) unless the options set one.
    pub fn new(mut config: AppConfig) -> Result<App, slint::PlatformError> {
        if config.open_options.max_decoded_bytes.is_none() {
            config.open_options.max_decoded_bytes = memory::kiosk_memory_ceiling();
        }
        let window = AppWindow::new()?;
        settings::view::show_language(config.language);
        window.global::<ui::Theme>().set_dpi(dpi::resolve(config.dpi, None));
        let (restore, banner) = match config.session_dir.as_deref().map(autosave::begin_restore) {
            Some(autosave::Restore::Session(session)) => (Some(session), String::new()),
            Some(autosave::Restore::SetAside(set_aside)) => (None, set_aside.message()),
            Some(autosave::Restore::Nothing) | None => (None, String::new()),
        };
        let banner = match &config.notice {
            Some(notice) if banner.is_empty() => notice.clone(),
            Some(notice) => format!("{notice}. {banner}"),
            None => banner,
        };
        let workers = model::Workers::threaded(&config);
        let model = AppModel::new(config, workers, restore, banner);
        let state = Rc::new(RefCell::new(State { model, rows: view::Rows::default() }));
        let app = App { window, state: state.clone(), _poll_timer: slint::Timer::default() };
        state.borrow().rows.wire(&app.window);
        callbacks::wire(&app.window, &state);
        let weak = app.window.as_weak();
        app._poll_timer.start(slint::TimerMode::Repeated, POLL_INTERVAL, move || {
            if let Some(window) = weak.upgrade() {
                callbacks::poll(&window, &state);
            }
        });
        {
            let mut state = app.state.borrow_mut();
            let show = state.start_up().and(model::Show { pacs: true, ..model::Show::default() });
            view::show(&app.window, &mut state, show);
        }
        Ok(app)
    }

    pub fn window(&self) -> &AppWindow {
        &self.window
    }

    /// The pixel density the UI is sized for (`AppConfig::dpi`).
    pub fn dpi(&self) -> f32 {
        self.window.global::<ui::Theme>().get_dpi()
    }

    /// Shows the window (with Slint's own backend) and runs its event loop until it closes.
    pub fn run(&self) -> Result<(), slint::PlatformError> {
        self.window.run()
    }

    /// A touch happened somewhere: the idle timeout starts again.
    pub fn note_input(&self) {
        let mut state = self.state.borrow_mut();
        let now = state.config.clock.now();
        state.idle.touched(now);
    }

    /// Nothing is being opened, classified or rendered (replay's `wait-idle`).
    pub fn is_idle(&self) -> bool {
        self.state.borrow().is_idle()
    }

    /// The open volume, the label volume shown and the lassos it was trained on (replay
    /// scripts' label expectations); `None` before the first classification.
    pub fn classification(&self) -> Option<(Arc<volasso_core::volume::Volume>, Arc<Vec<u8>>, StrokesFile)> {
        let state = self.state.borrow();
        let work = state.ctl.work.as_ref()?;
        let classified = work.classified.as_ref()?;
        Some((work.loaded.volume.clone(), classified.labels.clone(), work.requested.clone()?))
    }

    /// The snapshots in the data folder's `snapshots/` (replay's `expect snapshots`), sorted.
    pub fn snapshot_files(&self) -> Vec<PathBuf> {
        self.state.borrow().config.data_dir.as_deref().map_or_else(Vec::new, view3d::snapshot::files_in)
    }

    /// The size of the 3-D view's newest picture, in pixels.
    pub fn view_picture_size(&self) -> Option<[u32; 2]> {
        self.state.borrow().view_picture.as_ref().map(|picture| [picture.width(), picture.height()])
    }

    /// What a result is, in one line (replay's `same-result`; queries.rs).
    pub fn result_digest(&self) -> String {
        queries::result_digest(&self.state.borrow())
    }

    /// The 3-D view shows a whole frame at the size it is drawn at (not a smaller preview).
    pub fn view_whole(&self) -> bool {
        let size = self.window.global::<ui::Session>().get_view_picture().size();
        let wanted = self.state.borrow().view.size;
        let scale = (view3d::MAX_PICTURE_SIDE as f32 / wanted[0].max(wanted[1]).max(1) as f32).min(1.0);
        let wanted = wanted.map(|side| ((side as f32 * scale) as u32).max(1));
        [size.width, size.height] == wanted
    }

    /// A two-finger gesture on the 3-D view: `zoom` multiplies the zoom, `pan_pixels` moves the
    /// picture, `turn_degrees` turns it about the view direction (as azimuth).
    pub fn view_gesture(&self, zoom: f32, pan_pixels: [f32; 2], turn_degrees: f32) {
        // While clipping, the pan and the turn tilt the plane instead.
        let gesture = view3d::interaction::ViewIntent::Gesture { zoom, pan_pixels, turn_degrees };
        callbacks::send(&self.window, &self.state, Intent::View(gesture));
    }

    /// A two-finger gesture on the slice normal to `axis`: `zoom` multiplies the zoom and
    /// `pan` moves it (fractions of the slice's visible area) when that slice is enlarged;
    /// otherwise `pan` drags the display window (windowing.rs).
    pub fn slice_gesture(&self, axis: Axis, zoom: f32, pan: [f32; 2]) {
        let gesture = lasso::slices::SliceIntent::Gesture { axis, zoom, pan };
        callbacks::send(&self.window, &self.state, Intent::Slice(gesture));
    }

    /// The app's state by name, for replay scripts' `expect KEY VALUE` (the keys: queries.rs).
    pub fn query(&self, key: &str) -> Option<String> {
        queries::query(&self.state.borrow(), key)
    }
}
