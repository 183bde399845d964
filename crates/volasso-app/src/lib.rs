//! The kiosk app: the Slint UI (`ui/*.slint`) wired to the pipeline. It holds what the user is
//! doing (the open volume, the three slices shown, the session of classes and lassos, the
//! camera) and runs everything slow elsewhere: volumes open on a loader thread, the
//! classifier on a job thread, the 3-D view on a render thread, the autosave on a writer
//! thread (saver.rs), the slice pictures on a painter thread (painter.rs). The UI thread moves
//! data between them and Slint and never waits for them, nor for the disk.
//!
//! Data flow: callbacks (callbacks.rs, and lasso/slice_actions.rs for what touches a slice)
//! change `State`; what the user does to the classes goes to the Slint-free `Controller`
//! (controller.rs: the work, the template and the classification, autosave and 3-D view
//! workers), which says what changed; a 16 ms poll timer (`poll.rs`) collects finished work
//! and each feature applies its own (`chooser/loading.rs` what the loader reports);
//! `refresh.rs` pushes state into the `Session` global and depends on no feature, so the files'
//! imports run one way (callbacks and poll -> features -> refresh; `tests/architecture.rs`
//! fails on a cycle). The PACS screen (`pacs/`) is the shape the rest is moving to: a
//! Slint-free model updated by intents, its jobs behind the `Worker` trait (`worker.rs`), one
//! glue file. So are the 3-D view's camera and clip plane (`view3d/interaction.rs`), the idle
//! timeout (`idle.rs`, on the app's `clock.rs`) and the attract mode (`attract/`), each tested
//! without a window, a thread or a GPU; the work on an open volume is plain data (`work.rs`),
//! the set-up too (`config.rs`).
//!
//! Slices are shown as a radiologist expects them (`slices::SliceLayout`: axial, coronal and
//! sagittal panels with the patient's directions at their edges; the stored order and
//! "orientation unknown" when the file says nothing), and the 3-D view starts from the front
//! with the head up (`slices::HomeView`). Lassos are stored in voxel coordinates whatever the
//! flips (lasso/drawing.rs), and display windows never reach the classifier (windowing.rs). Every volume file is treated as hostile: one that fails or panics its
//! reader becomes a "Cannot open" card, and a saved session that cannot be restored (or that
//! stopped the app while restoring) is set aside with a banner (`autosave.rs`).
//!
//! Beyond the paper (§3.2-3.5), every lasso reclassifies at once, with the lassos not yet
//! defined as a provisional class, so the user sees the result of a lasso before deciding to
//! define the class.
//!
//! Never: draws pixels itself or reads input devices; the platform (the `volasso` crate's kiosk
//! or Slint's own winit backend) does that. This crate depends on no display, touch device or
//! command-line code, so cargo refuses an import of them here.

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
pub mod pacs;
mod painter;
pub mod patient;
pub mod pictures;
mod poll;
pub mod presets;
mod queries;
mod refresh;
mod saver;
pub mod session;
pub mod settings;
pub mod ui;
pub mod view3d;
pub mod windowing;
pub mod words;
mod work;
pub mod worker;
use work::{PANEL_COUNT, Work};

use chooser::library::{Loader, VolumeSource};
use controller::Controller;
use slint::ComponentHandle;
use std::cell::RefCell;
use std::path::PathBuf;
use std::rc::Rc;
use std::sync::Arc;
use std::time::Duration;
use ui::AppWindow;
use volasso_core::slices::Axis;
use volasso_core::strokes::StrokesFile;
use volasso_core::transfer::HueTemplate;

/// How often finished work is collected.
pub(crate) const POLL_INTERVAL: Duration = Duration::from_millis(16);

/// The data folder is listed again every this many polls (2 s), so that volumes copied there
/// while the app runs (a USB import on the appliance) appear in the chooser.
const RESCAN_POLLS: u32 = 125;

/// The screens of `Session.screen`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Screen {
    Start = 0,
    Chooser = 1,
    Work = 2,
    Pacs = 3,
    Settings = 4,
}

/// Everything the callbacks and the poll timer share (on the UI thread only).
struct State {
    config: AppConfig,
    /// The chooser's scans and their cards.
    cards: chooser::cards::Cards,
    /// Polls since the data folder was last listed.
    polls_since_scan: u32,
    /// Scans were deleted as expired: their cards go once no card is being loaded.
    cards_to_drop: bool,
    loader: Loader,
    thumbnails_requested: bool,
    /// Thumbnails asked for and not yet made.
    thumbnails_pending: usize,
    opening: Option<usize>,
    /// The work on the open volume and its workers (classification, autosave, 3-D view).
    ctl: Controller,
    /// Draws the slice pictures off the UI thread.
    painter: painter::SlicePainter,
    /// Per panel, the volume (its address) and axis of the picture it shows, so a new picture
    /// keeps the old one in place only while both are the same.
    panel_pictures: Vec<(usize, Axis)>,
    /// The 3-D view's camera, what a finger on it does, its size and whether it needs a frame.
    view: view3d::interaction::ViewModel,
    banner: String,
    status: String,
    /// A session read at start-up, applied once its volume is open.
    restore: Option<autosave::SavedSession>,
    /// The restore marker is down (autosave.rs): the restored session has not yet shown that it
    /// opens and classifies without stopping the app.
    restore_unconfirmed: bool,
    slices_model: Rc<slint::VecModel<ui::SliceView>>,
    classes_model: Rc<slint::VecModel<ui::ClassEntry>>,
    volumes_model: Rc<slint::VecModel<ui::VolumeCard>>,
    /// The 3-D view's tools: clip plane by touch, the picture a snapshot writes.
    tools: view3d::tools::Tools,
    /// The gallery of kept results: its cards, a save in flight, a result being opened.
    results: gallery::view::Results,
    /// The start screen's turntable after the idle timeout.
    attract: attract::Attract,
    /// The PACS screen and "Send to PACS", with their worker.
    pacs: pacs::view::Pacs,
    /// The idle timeout, counted from the later of the last touch and the end of the work
    /// the user waits for ([`State::works_for_user`]).
    idle: idle::Idle,
    /// The sweep of expired patient data.
    expiry: expiry::Expiry,
    /// The kiosk's lines in the audit log.
    audit: audit::Audit,
    /// The settings screen behind the PIN.
    settings: settings::SettingsScreen,
    /// The learned presets in the data folder and the chooser's choice.
    presets: presets::view::Presets,
}

impl State {
    /// The classes the classifier is trained on: the defined ones, and the pending lassos as
    /// a provisional next class.
    fn training_class_count(&self) -> usize {
        self.ctl.training_class_count()
    }

    /// The template in use for the current number of classes.
    fn template(&self) -> HueTemplate {
        self.ctl.template()
    }

    /// Nothing is being opened, classified or rendered (replay's `wait-idle`).
    fn is_idle(&self) -> bool {
        !self.works_for_user() && self.thumbnails_pending == 0 && !self.attract.busy() && !self.expiry.busy()
    }

    /// The sweep of expired data, when due, sparing the scan open or opening (the job is made
    /// only when a sweep is due, not on every poll).
    fn sweep_expired(&mut self, now: Duration) {
        let (config, ctl, cards, opening) = (&self.config, &self.ctl, &self.cards, self.opening);
        let expired = self.expiry.tick(now, |retention| {
            let open = ctl.work.as_ref().map(|work| &work.loaded.source);
            let opening = opening.and_then(|index| cards.source(index));
            let keep = open.into_iter().chain(opening).filter_map(|source| source.path().map(PathBuf::from)).collect();
            let data_dir = config.data_dir.clone()?;
            Some(expiry::SweepJob { data_dir, session_dir: config.session_dir.clone(), retention, keep })
        });
        if let Some(expired) = expired {
            for thing in &expired {
                log::info!("expired and deleted: the {} {}", thing.kind.name(), thing.name);
            }
            self.cards_to_drop = true;
        }
    }

    /// Work the user waits for: a volume or a kept result opening, a classification, the
    /// slices or the 3-D view being drawn, a snapshot being written. The idle timeout does
    /// not clear a session while it lasts.
    fn works_for_user(&self) -> bool {
        self.opening.is_some()
            || self.ctl.jobs.busy()
            || self.ctl.renderer.busy()
            || !self.ctl.renderer.settled()
            || self.painter.busy()
            || self.tools.snapshots.busy()
            || self.view.dirty
            || self.results.busy()
            || self.presets.shelf.busy()
            || self.pacs.busy()
    }
}

/// The running app: the window, its state, and the timers that drive it.
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
        let sources = chooser::library::scan(config.data_dir.as_deref());
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
        let state = State {
            loader: Loader::new(config.open_options.clone(), config.patient),
            cards: chooser::cards::Cards::new(sources),
            polls_since_scan: 0,
            cards_to_drop: false,
            thumbnails_requested: false,
            thumbnails_pending: 0,
            opening: None,
            ctl: Controller::new(config.session_dir.clone()),
            painter: painter::SlicePainter::new(),
            panel_pictures: Vec::new(),
            view: view3d::interaction::ViewModel::default(),
            banner,
            status: String::new(),
            restore_unconfirmed: restore.is_some(),
            restore,
            slices_model: Rc::new(slint::VecModel::default()),
            classes_model: Rc::new(slint::VecModel::default()),
            volumes_model: Rc::new(slint::VecModel::default()),
            tools: view3d::tools::Tools::default(),
            results: gallery::view::Results::default(),
            attract: attract::Attract::default(),
            pacs: pacs::view::Pacs {
                model: pacs::PacsModel::new(config.pacs.clone(), config.data_dir.clone(), config::outbox(&config)),
                worker: pacs::jobs::threaded(),
                shown_rows: Vec::new(),
            },
            idle: idle::Idle::new(config.idle_timeout, config.clock.now()),
            expiry: expiry::Expiry::new(config.retention),
            audit: audit::Audit::new(config.data_dir.as_deref()),
            settings: settings::SettingsScreen::new(config.data_dir.clone()),
            presets: presets::view::Presets::default(),
            config,
        };
        let state = Rc::new(RefCell::new(state));
        let app = App { window, state: state.clone(), _poll_timer: slint::Timer::default() };
        {
            let session = app.window.global::<ui::Session>();
            let state = state.borrow();
            session.set_slices(state.slices_model.clone().into());
            session.set_classes(state.classes_model.clone().into());
            session.set_volumes(state.volumes_model.clone().into());
            session.set_results(state.results.cards.clone().into());
        }
        callbacks::wire(&app.window, &state);
        pacs::view::push(&app.window, &state);
        let weak = app.window.as_weak();
        let polled = state.clone();
        app._poll_timer.start(slint::TimerMode::Repeated, POLL_INTERVAL, move || {
            if let Some(window) = weak.upgrade() {
                poll::poll(&window, &polled);
                settings::view::tick(&window, &polled);
                let timed_out = {
                    let mut state = polled.borrow_mut();
                    let (now, working) = (state.config.clock.now(), state.works_for_user());
                    state.sweep_expired(now);
                    state.idle.tick(now, working)
                };
                if timed_out {
                    callbacks::reset_to_start(&window, &polled);
                }
            }
        });
        app.start_up();
        Ok(app)
    }

    fn start_up(&self) {
        let mut state = self.state.borrow_mut();
        let source = match (&state.restore, &state.config.initial_volume) {
            (Some(saved), _) => Some(VolumeSource::from_key(&saved.volume)),
            (None, Some(source)) => Some(source.clone()),
            (None, None) => None,
        };
        if let Some(source) = source {
            let (index, _) = state.cards.add(source.clone());
            state.loader.open(index, source);
            state.opening = Some(index);
            state.status = "Opening the volume...".into();
        }
        drop(state);
        chooser::loading::show_cards(&self.state);
        presets::view::relist(&self.window, &self.state);
        refresh::push_status(&self.window, &self.state);
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
        callbacks::touched(&self.state);
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
        let state = self.state.borrow();
        let Some(folder) = state.config.data_dir.as_ref().map(|dir| dir.join(view3d::snapshot::SNAPSHOT_FOLDER)) else {
            return Vec::new();
        };
        let mut files: Vec<PathBuf> = std::fs::read_dir(folder)
            .map(|entries| entries.filter_map(|entry| entry.ok().map(|e| e.path())).collect())
            .unwrap_or_default();
        files.retain(|path| path.extension().is_some_and(|ext| ext == "png"));
        files.sort();
        files
    }

    /// The size of the 3-D view's newest picture, in pixels.
    pub fn view_picture_size(&self) -> Option<[u32; 2]> {
        self.state.borrow().tools.picture.as_ref().map(|picture| [picture.width(), picture.height()])
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
        view3d::tools::view_intent(&self.window, &self.state, gesture);
    }

    /// A two-finger gesture on the slice normal to `axis`: `zoom` multiplies the zoom and
    /// `pan` moves it (fractions of the slice's visible area) when that slice is enlarged;
    /// otherwise `pan` drags the display window (windowing.rs).
    pub fn slice_gesture(&self, axis: Axis, zoom: f32, pan: [f32; 2]) {
        lasso::slice_actions::slice_intent(
            &self.window,
            &self.state,
            lasso::slices::SliceIntent::Gesture { axis, zoom, pan },
        );
    }

    /// The app's state by name, for replay scripts' `expect KEY VALUE` (the keys: queries.rs).
    pub fn query(&self, key: &str) -> Option<String> {
        let screen = self.window.global::<ui::Session>().get_screen();
        queries::query(&self.state.borrow(), screen, key)
    }
}
