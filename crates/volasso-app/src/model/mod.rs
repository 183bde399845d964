//! The app as one model: everything the screens show (the screen, the chooser's cards, the
//! work on the open scan, the 3-D view's camera and clip plane, the banner and the status line,
//! the gallery, the presets, the PACS screen, the settings, the attract mode, the idle
//! accounting) and the workers behind it. Every callback of the window is an [`Intent`];
//! [`AppModel::update`] applies it and answers what the view must write again ([`Show`]). The
//! poll timer is one intent too ([`Intent::Poll`]): finished work is collected, the idle
//! timeout and the expiry sweep are counted.
//!
//! Each feature's part of `update` lives in its folder (`chooser/`, `lasso/`, `view3d/`,
//! `gallery/`, `presets/`, `pacs/`, `settings/`, `attract/`) as methods of [`AppModel`];
//! `view.rs` and each feature's `view.rs` write the model into the window.
//!
//! Never: touches the window or Slint, waits for a worker, or reads the clock but through
//! `config.clock`; on [`Workers::none`] no thread starts and no GPU opens.

use crate::chooser::cards::Cards;
use crate::chooser::library::{Loader, VolumeSource};
use crate::config::AppConfig;
use crate::controller::{Changed, Controller, ControllerWorkers, FAILURE_BANNER_START, Failure, failure_banner};
use crate::lasso::slices::SliceIntent;
use crate::pacs::{PacsIntent, PacsModel};
use crate::settings::{SettingsIntent, SettingsScreen};
use crate::view3d::interaction::{ViewIntent, ViewModel};
use crate::work::PANEL_COUNT;
use crate::{attract, audit, autosave, expiry, gallery, idle, painter, presets, view3d};
use std::path::PathBuf;
use std::time::Duration;
use volasso_core::transfer::{HueTemplate, TemplateType};

#[cfg(test)]
mod tests;

/// The data folder is listed again every this many polls (2 s), so that volumes copied there
/// while the app runs (a USB import on the appliance) appear in the chooser.
pub(crate) const RESCAN_POLLS: u32 = 125;

/// The screens, as `Session.screen` numbers them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Screen {
    Start = 0,
    Chooser = 1,
    Work = 2,
    Pacs = 3,
    Settings = 4,
}

/// What the user did (one variant per callback of the window), or the poll timer's tick.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Intent {
    /// "Start" on the start screen, or "back" to the chooser.
    ShowChooser,
    /// A chooser card tapped.
    OpenVolume(usize),
    /// A touch on a slice panel.
    Slice(SliceIntent),
    DefineClass,
    Undo,
    Clear,
    DeleteClass(usize),
    /// A class row's eye: hide or show the class.
    ToggleClass(usize),
    SavePreset,
    ApplyPreset(usize),
    /// The chooser's preset menu (`None`: no preset).
    ChoosePreset(Option<usize>),
    ToggleUnsure,
    DrawHereNext,
    /// A hue template by name, keeping the rotation.
    ChooseTemplate(String),
    /// The template's rotation in degrees.
    RotateTemplate(i32),
    /// A touch or button on the 3-D view.
    View(ViewIntent),
    DismissBanner,
    /// A class row's opacity slider, in percent.
    ClassOpacity(usize, i32),
    Snapshot,
    SaveResult,
    OpenResult(usize),
    Pacs(PacsIntent),
    SendToPacs,
    Settings(SettingsIntent),
    /// The poll timer: what the window measures now.
    Poll(Measures),
}

/// What the window measures, handed to the model with each poll.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Measures {
    /// The 3-D view's size in pixels.
    pub view_px: [u32; 2],
    /// The side of the attract mode's picture in pixels.
    pub attract_side: u32,
}

/// What changed on the attract mode's picture.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum AttractShow {
    /// The turntable starts: no caption yet.
    Begin,
    /// The turntable stopped: no picture.
    End,
    /// The picture due now.
    Frame(attract::Shown),
}

/// What the view must write again after an update; each field names a part of the screens.
#[derive(Debug, Default, PartialEq)]
pub(crate) struct Show {
    /// `AppModel::screen`.
    pub screen: bool,
    /// The whole work screen: slices, their layout, the class bar, the status.
    pub work: bool,
    /// These panels' slices (their pictures asked of the painter).
    pub panels: [bool; PANEL_COUNT],
    /// The slice pictures the painter finished (`AppModel::finished_pictures`).
    pub pictures: bool,
    /// The lasso path being drawn.
    pub lasso_path: bool,
    /// The enlarged panel, its zoom and pan, the display window.
    pub slice_layout: bool,
    /// The status line, the banner, the busy flags.
    pub status: bool,
    /// `AppModel::view_picture` (the 3-D view's picture, or none).
    pub view_picture: bool,
    /// `AppModel::view_caption`.
    pub view_caption: bool,
    /// The opacity knob of this class row, in place (a finger may be dragging it).
    pub class_opacity: Option<usize>,
    /// Whether the clip plane is on.
    pub clipping: bool,
    /// The confirmation shown over the 3-D view for a while.
    pub toast: Option<String>,
    /// The chooser's volume cards that changed (`Cards::take_changes`).
    pub cards: bool,
    /// The gallery's result cards.
    pub results: bool,
    /// Both preset menus.
    pub presets: bool,
    /// The PACS screen and "Send to PACS" (which the work screen's changes reach too).
    pub pacs: bool,
    /// The settings screen.
    pub settings: bool,
    /// The screens' language (`config.language`).
    pub language: bool,
    /// The attract mode's picture.
    pub attract: Option<AttractShow>,
}

impl Show {
    /// Everything `other` shows, with this.
    pub fn and(mut self, other: Show) -> Show {
        self.screen |= other.screen;
        self.work |= other.work;
        for (mine, theirs) in self.panels.iter_mut().zip(other.panels) {
            *mine |= theirs;
        }
        self.pictures |= other.pictures;
        self.lasso_path |= other.lasso_path;
        self.slice_layout |= other.slice_layout;
        self.status |= other.status;
        self.view_picture |= other.view_picture;
        self.view_caption |= other.view_caption;
        self.class_opacity = other.class_opacity.or(self.class_opacity);
        self.clipping |= other.clipping;
        self.toast = other.toast.or(self.toast);
        self.cards |= other.cards;
        self.results |= other.results;
        self.presets |= other.presets;
        self.pacs |= other.pacs;
        self.settings |= other.settings;
        self.language |= other.language;
        self.attract = other.attract.or(self.attract);
        self
    }

    /// Only the status line.
    pub fn status() -> Show {
        Show { status: true, ..Show::default() }
    }

    /// The whole work screen.
    pub fn work() -> Show {
        Show { work: true, ..Show::default() }
    }

    /// Every panel's slice.
    pub fn every_panel() -> Show {
        Show { panels: [true; PANEL_COUNT], ..Show::default() }
    }
}

/// The app: what the screens show and the workers behind it (module doc).
pub(crate) struct AppModel {
    pub config: AppConfig,
    /// The screen shown.
    pub screen: Screen,
    /// The chooser's scans and their cards.
    pub cards: Cards,
    /// Polls since the data folder was last listed.
    pub polls_since_scan: u32,
    /// Scans were deleted as expired: their cards go once no card is being loaded.
    pub cards_to_drop: bool,
    pub loader: Loader,
    pub thumbnails_requested: bool,
    /// Thumbnails asked for and not yet made.
    pub thumbnails_pending: usize,
    /// The chooser index of the scan being opened.
    pub opening: Option<usize>,
    /// The work on the open volume and its workers (classification, autosave, 3-D view).
    pub ctl: Controller,
    /// Draws the slice pictures off the UI thread.
    pub painter: painter::SlicePainter,
    /// Per panel, the volume (its address) and axis of the picture it shows, so a new picture
    /// keeps the old one in place only while both are the same.
    pub panel_pictures: Vec<(usize, volasso_core::slices::Axis)>,
    /// Slice pictures the painter finished, per panel, not yet shown.
    pub finished_pictures: Vec<(usize, volasso_core::transfer::RgbImage)>,
    /// The 3-D view's camera, what a finger on it does, its size and whether it needs a frame.
    pub view: ViewModel,
    /// The 3-D view's newest picture (what a snapshot and "Save" keep); `None`: an empty view.
    pub view_picture: Option<image::RgbaImage>,
    /// What the 3-D view says of its home position.
    pub view_caption: &'static str,
    /// Snapshots of the 3-D view being written.
    pub snapshots: view3d::snapshot::SnapshotWriter,
    pub banner: String,
    pub status: String,
    /// A session read at start-up (or a kept result's), applied once its volume is open.
    pub restore: Option<autosave::SavedSession>,
    /// The restore marker is down (autosave.rs): the restored session has not yet shown that it
    /// opens and classifies without stopping the app.
    pub restore_unconfirmed: bool,
    /// The gallery of kept results: a save in flight, a result being opened.
    pub gallery: gallery::model::GalleryModel,
    /// The start screen's turntable after the idle timeout.
    pub attract: attract::Attract,
    /// The side of the turntable's picture, as the window last measured it.
    pub attract_side: u32,
    /// The PACS screen and "Send to PACS", with their worker.
    pub pacs: crate::pacs::Pacs,
    /// The idle timeout, counted from the later of the last touch and the end of the work
    /// the user waits for ([`AppModel::works_for_user`]).
    pub idle: idle::Idle,
    /// The sweep of expired patient data.
    pub expiry: expiry::Expiry,
    /// The kiosk's lines in the audit log.
    pub audit: audit::Audit,
    /// The settings screen behind the PIN.
    pub settings: SettingsScreen,
    /// The learned presets in the data folder and the chooser's choice.
    pub presets: presets::Presets,
}

/// The workers an [`AppModel`] runs on: threads and the GPU ([`Workers::threaded`]), or, for
/// the model's tests, none at all ([`Workers::none`]: each job runs at the next poll).
pub(crate) struct Workers {
    pub controller: ControllerWorkers,
    pub loader: Loader,
    pub painter: painter::SlicePainter,
    pub snapshots: view3d::snapshot::SnapshotWriter,
    pub gallery: gallery::model::GalleryModel,
    pub pacs: Box<dyn crate::worker::Worker<crate::pacs::PacsJob, crate::pacs::PacsReport>>,
    pub expiry: expiry::Expiry,
    pub audit: audit::Audit,
    pub presets: presets::Shelf,
    pub attract: attract::Attract,
}

impl Workers {
    /// Threads, and the GPU on the render thread.
    pub fn threaded(config: &AppConfig) -> Workers {
        Workers {
            controller: ControllerWorkers::threaded(),
            loader: Loader::new(config.open_options.clone(), config.patient),
            painter: painter::SlicePainter::new(),
            snapshots: view3d::snapshot::SnapshotWriter::default(),
            gallery: gallery::model::GalleryModel::default(),
            pacs: crate::pacs::jobs::threaded(),
            expiry: expiry::Expiry::new(config.retention),
            audit: audit::Audit::new(config.data_dir.as_deref()),
            presets: presets::Shelf::default(),
            attract: attract::Attract::default(),
        }
    }

    /// No thread and no GPU: every job runs on the caller's thread at the next poll, the
    /// renderer draws nothing.
    #[cfg(test)]
    pub fn none(config: &AppConfig) -> Workers {
        use crate::worker::Inline;
        use std::sync::Arc;
        Workers {
            controller: ControllerWorkers {
                renderer: view3d::ViewRenderer::blank_pictures(),
                jobs: crate::jobs::ClassificationJobs::inline(),
                saver: crate::saver::AutosaveWriter::inline(),
            },
            loader: Loader::inline(config.open_options.clone(), config.patient),
            painter: painter::SlicePainter::inline(),
            snapshots: view3d::snapshot::SnapshotWriter::inline(),
            gallery: gallery::model::GalleryModel::with_writer(Box::new(Inline::new(gallery::model::save_task()))),
            pacs: Box::new(Inline::new(Arc::new(crate::pacs::jobs::run))),
            expiry: expiry::Expiry::with_worker(config.retention, Box::new(Inline::new(expiry::sweep_task()))),
            audit: audit::Audit::new(None),
            presets: presets::Shelf::with_writer(None, Box::new(Inline::new(presets::write_task()))),
            attract: attract::Attract::with_workers(attract::Workers {
                loader: |options| Box::new(Inline::new(attract::open_task(options))),
                controller: || Controller::with_workers(None, ControllerWorkers::inline()),
            }),
        }
    }
}

impl AppModel {
    /// The model on `workers`, with `restore` (a session read at start-up) and `banner`.
    pub fn new(
        config: AppConfig,
        workers: Workers,
        restore: Option<autosave::SavedSession>,
        banner: String,
    ) -> AppModel {
        let Workers { controller, loader, painter, snapshots, gallery, pacs, expiry, audit, presets, attract } =
            workers;
        AppModel {
            screen: Screen::Start,
            loader,
            cards: Cards::new(crate::chooser::library::scan(config.data_dir.as_deref())),
            polls_since_scan: 0,
            cards_to_drop: false,
            thumbnails_requested: false,
            thumbnails_pending: 0,
            opening: None,
            ctl: Controller::with_workers(config.session_dir.clone(), controller),
            painter,
            panel_pictures: Vec::new(),
            finished_pictures: Vec::new(),
            view: ViewModel::default(),
            view_picture: None,
            view_caption: "",
            snapshots,
            banner,
            status: String::new(),
            restore_unconfirmed: restore.is_some(),
            restore,
            gallery,
            attract,
            attract_side: attract::MAX_SIDE,
            pacs: crate::pacs::Pacs {
                model: PacsModel::new(config.pacs.clone(), config.data_dir.clone(), crate::config::outbox(&config)),
                worker: pacs,
                shown_rows: Vec::new(),
            },
            idle: idle::Idle::new(config.idle_timeout, config.clock.now()),
            expiry,
            audit,
            settings: SettingsScreen::new(config.data_dir.clone()),
            presets: presets::Presets { shelf: presets, chosen: None },
            config,
        }
    }

    /// The scan to open at start-up: the restored session's, else the configured one; it is
    /// opened at once.
    pub fn start_up(&mut self) -> Show {
        let source = match (&self.restore, &self.config.initial_volume) {
            (Some(saved), _) => Some(VolumeSource::from_key(&saved.volume)),
            (None, Some(source)) => Some(source.clone()),
            (None, None) => None,
        };
        if let Some(source) = source {
            let (index, _) = self.cards.add(source.clone());
            self.loader.open(index, source);
            self.opening = Some(index);
            self.status = "Opening the volume...".into();
        }
        self.relist_presets().and(Show { cards: true, status: true, ..Show::default() })
    }

    /// Applies `intent`; answers what the view must write again. Every intent but the poll
    /// is a touch: the idle timeout starts again.
    pub fn update(&mut self, intent: Intent) -> Show {
        if !matches!(intent, Intent::Poll(_)) {
            let now = self.config.clock.now();
            self.idle.touched(now);
        }
        match intent {
            Intent::ShowChooser => self.show_chooser(),
            Intent::OpenVolume(index) => self.open_volume(index),
            Intent::Slice(intent) => self.on_slices(intent),
            Intent::DefineClass => self.edit(|session| session.define_class().map(|_| ())),
            Intent::Undo => self.edit(|session| session.undo()),
            Intent::Clear => self.edit(|session| {
                session.clear();
                Ok(())
            }),
            Intent::DeleteClass(index) => self.edit(|session| session.delete_class(index)),
            Intent::ToggleClass(index) => {
                let changed = self.ctl.toggle_class(index);
                self.changed(changed)
            }
            Intent::SavePreset => self.save_preset(),
            Intent::ApplyPreset(index) => self.apply_preset(index),
            Intent::ChoosePreset(index) => {
                self.presets.chosen = index;
                Show { presets: true, ..Show::default() }
            }
            Intent::ToggleUnsure => self.toggle_unsure(),
            Intent::DrawHereNext => self.draw_here_next(),
            Intent::ChooseTemplate(name) => match TemplateType::from_name(&name) {
                Some(template) => self.set_template(HueTemplate::new(template, self.ctl.template().rotation_degrees)),
                None => Show::default(),
            },
            Intent::RotateTemplate(degrees) => {
                self.set_template(HueTemplate::new(self.ctl.template().template, degrees as f32))
            }
            Intent::View(intent) => self.view_intent(intent),
            Intent::DismissBanner => {
                self.banner.clear();
                Show::status()
            }
            Intent::ClassOpacity(index, percent) => self.class_opacity(index, percent),
            Intent::Snapshot => self.snapshot(),
            Intent::SaveResult => self.save_result(),
            Intent::OpenResult(index) => self.open_result(index),
            Intent::Pacs(intent) => self.pacs_intent(intent),
            Intent::SendToPacs => self.send_to_pacs(),
            Intent::Settings(intent) => self.settings_intent(intent),
            Intent::Poll(measures) => self.poll(measures),
        }
    }

    /// The poll timer: finished work collected, a new 3-D frame asked for when due, the data
    /// folder listed again now and then, the expiry sweep and the idle timeout counted.
    fn poll(&mut self, measures: Measures) -> Show {
        self.attract_side = measures.attract_side.clamp(64, attract::MAX_SIDE);
        let mut show = self.poll_loader();
        show = show.and(self.poll_gallery()).and(self.poll_presets()).and(self.tick_attract());
        let changed = self.ctl.poll();
        if changed != Changed::default() {
            show = show.and(self.changed(changed));
        }
        self.confirm_restore();
        show = show.and(self.poll_pictures()).and(self.poll_renderer());
        self.request_frame_if_needed(measures.view_px);
        show = show.and(self.poll_snapshots()).and(self.poll_pacs()).and(self.tick_settings());
        self.rescan_data_folder();
        self.drop_vanished();
        let now = self.config.clock.now();
        self.sweep_expired(now);
        let working = self.works_for_user();
        if self.idle.tick(now, working) {
            show = show.and(self.reset_to_start());
        }
        show.and(Show { status: true, cards: true, ..Show::default() })
    }

    /// Collects the slice pictures the painter finished; a slice that cannot be drawn (the file
    /// under the volume changed) is said once in the banner.
    fn poll_pictures(&mut self) -> Show {
        let mut show = Show::default();
        while let Some((panel, result)) = self.painter.poll() {
            match result {
                Ok(picture) => {
                    self.finished_pictures.retain(|(shown, _)| *shown != panel);
                    self.finished_pictures.push((panel, picture));
                    show.pictures = true;
                }
                Err(error) => {
                    let message = error.to_string();
                    log::warn!("slice picture: {message}");
                    self.banner = format!("Cannot show the slice: {message}");
                    show.status = true;
                }
            }
        }
        show
    }

    /// Applies what the controller says changed: the status line, a failure's banner, a new
    /// 3-D frame wanted or the 3-D view emptied; the work screen when classes, lassos or
    /// colours changed.
    pub fn changed(&mut self, changed: Changed) -> Show {
        if let Some(status) = &changed.status {
            self.status = status.clone();
        }
        match &changed.failure {
            Failure::Failed(reason) => self.banner = failure_banner(reason),
            Failure::Cleared if self.banner.starts_with(FAILURE_BANNER_START) => self.banner.clear(),
            Failure::Cleared | Failure::Unchanged => {}
        }
        if changed.view {
            self.view.dirty = true;
        }
        if changed.view_cleared {
            self.view_picture = None;
        }
        Show {
            view_picture: changed.view_cleared,
            work: changed.classes,
            status: changed.status.is_some() || changed.failure != Failure::Unchanged,
            ..Show::default()
        }
    }

    /// Applies `edit` to the session; on success autosaves and reclassifies.
    pub fn edit(
        &mut self,
        edit: impl FnOnce(&mut crate::session::WorkSession) -> Result<(), crate::session::SessionError>,
    ) -> Show {
        let changed = self.ctl.edit(edit);
        self.changed(changed)
    }

    fn set_template(&mut self, template: HueTemplate) -> Show {
        let changed = self.ctl.choose_template(template);
        self.changed(changed)
    }

    /// Nothing is being opened, classified or rendered (replay's `wait-idle`).
    pub fn is_idle(&self) -> bool {
        !self.works_for_user() && self.thumbnails_pending == 0 && !self.attract.busy() && !self.expiry.busy()
    }

    /// Work the user waits for: a volume or a kept result opening, a classification, the
    /// slices or the 3-D view being drawn, a snapshot being written. The idle timeout does
    /// not clear a session while it lasts.
    pub fn works_for_user(&self) -> bool {
        self.opening.is_some()
            || self.ctl.jobs.busy()
            || self.ctl.renderer.busy()
            || !self.ctl.renderer.settled()
            || self.painter.busy()
            || self.snapshots.busy()
            || self.view.dirty
            || self.gallery.busy()
            || self.presets.shelf.busy()
            || self.pacs.busy()
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

    /// The idle timeout passed: the session is forgotten and the start screen comes back, with
    /// its turntable.
    pub fn reset_to_start(&mut self) -> Show {
        let now = self.config.clock.now();
        self.settings.update(SettingsIntent::Close, now);
        self.ctl.forget();
        self.panel_pictures.clear();
        self.restore = None;
        self.restore_unconfirmed = false;
        self.view.forget();
        self.view_picture = None;
        self.banner.clear();
        self.status.clear();
        log::info!("idle timeout: back to the start screen, session cleared");
        self.screen = Screen::Start;
        Show { screen: true, work: true, view_picture: true, settings: true, ..Show::default() }
            .and(self.begin_attract())
    }

    /// The chooser, with thumbnails asked for the first time it shows.
    fn show_chooser(&mut self) -> Show {
        if !self.thumbnails_requested {
            self.thumbnails_requested = true;
            let sources: Vec<_> = self.cards.sources().iter().cloned().enumerate().collect();
            self.thumbnails_pending = sources.len();
            self.loader.thumbnails(sources);
        }
        let show = self.end_attract().and(self.relist_gallery()).and(self.relist_presets());
        self.screen = Screen::Chooser;
        show.and(Show { screen: true, ..Show::default() })
    }
}
