//! What a card's tap and the loader's reports do to the app: thumbnails onto the chooser's
//! cards, a file that cannot be opened onto its card ("Cannot open" and why) and the banner,
//! an opened volume onto the work screen (with the saved session's classes, its panels in the
//! radiological convention, the 3-D view's home position and a banner for what its reader
//! tolerated, such as a missing slice under `--allow-gaps`), and the restore marker lifted
//! once a restored session has opened and classified (autosave.rs). Also the periodic listing
//! of the data folder, whose new volumes join the chooser.
//!
//! Never: opens files itself (library.rs does, on worker threads), or touches the window.

use crate::chooser::library::{LoadedVolume, LoaderEvent, VolumeSource};
use crate::model::{AppModel, RESCAN_POLLS, Screen, Show};
use crate::{Work, autosave};
use volasso_core::render::Camera;
use volasso_core::slices::HomeView;

impl AppModel {
    /// A restored session that opened and whose classification ended (or that had none to run)
    /// did not stop the app: the restore marker goes (autosave.rs).
    pub(crate) fn confirm_restore(&mut self) {
        if !self.restore_unconfirmed || self.ctl.work.is_none() || self.ctl.jobs.busy() {
            return;
        }
        self.restore_unconfirmed = false;
        if let Some(dir) = &self.config.session_dir {
            autosave::restored(dir);
        }
    }

    /// Appends the volumes that appeared in the data folder since the last listing (with their
    /// thumbnails, once the chooser has asked for thumbnails). Counted in polls, so that the
    /// replay harness's clock drives it like every other timer.
    pub(crate) fn rescan_data_folder(&mut self) {
        self.polls_since_scan += 1;
        if self.polls_since_scan < RESCAN_POLLS || self.config.data_dir.is_none() {
            return;
        }
        self.polls_since_scan = 0;
        let found = crate::chooser::library::scan(self.config.data_dir.as_deref());
        let added = self.cards.add_new(found);
        let retention = self.expiry.retention();
        self.cards.note_expiry(retention, std::time::SystemTime::now());
        if added.is_empty() {
            return;
        }
        log::info!("{} new volume(s) in the data folder", added.len());
        if self.thumbnails_requested {
            self.thumbnails_pending += added.len();
            self.loader.thumbnails(added);
        }
    }

    /// Drops the cards of scans whose file or folder is gone (deleted as expired), once nothing
    /// is being opened or thumbnailed: loader events name cards by index, so the cards are only
    /// renumbered while none is in flight; until then `cards_to_drop` stays set.
    pub(crate) fn drop_vanished(&mut self) {
        if !self.cards_to_drop || self.opening.is_some() || self.thumbnails_pending > 0 {
            return;
        }
        self.cards_to_drop = false;
        let gone = self.cards.drop_gone();
        if gone > 0 {
            log::info!("{gone} scan(s) gone from the chooser");
        }
    }

    /// The chooser index of `source`, added as a new card (its thumbnail asked for) when the
    /// chooser does not have it yet: a series just retrieved from the PACS, a kept result's scan.
    pub(crate) fn add_source(&mut self, source: VolumeSource) -> usize {
        let (index, new) = self.cards.add(source.clone());
        if new && self.thumbnails_requested {
            self.thumbnails_pending += 1;
            self.loader.thumbnails(vec![(index, source)]);
        }
        index
    }

    /// A chooser card tapped: its volume opens on the loader thread (a folder of several series
    /// says to pick one of their cards).
    pub(crate) fn open_volume(&mut self, index: usize) -> Show {
        let Some(source) = self.cards.source(index).cloned() else { return Show::default() };
        if self.opening.is_some() {
            return Show::default();
        }
        let series = self.cards.series_of(&source);
        if series > 1 {
            self.banner = format!("{} holds {series} series: open one of their cards.", source.name());
            return Show::status();
        }
        let name = source.name();
        self.start_opening(index, source, &name);
        Show::status()
    }

    /// Opens the scan of chooser card `index` on the loader thread (the classification of the
    /// scan open now stops); the status line says so.
    pub(crate) fn start_opening(&mut self, index: usize, source: VolumeSource, name: &str) {
        self.ctl.jobs.cancel();
        self.status = format!("Opening {name}...");
        self.opening = Some(index);
        self.loader.open(index, source);
    }

    /// Applies what the loader reported since the last poll.
    pub(crate) fn poll_loader(&mut self) -> Show {
        let mut show = Show::default();
        while let Some(event) = self.loader.poll() {
            show = show.and(self.loader_event(event));
        }
        show
    }

    fn loader_event(&mut self, event: LoaderEvent) -> Show {
        match event {
            LoaderEvent::Thumbnail { index, result } => {
                self.thumbnails_pending = self.thumbnails_pending.saturating_sub(1);
                match result {
                    Ok(thumbnail) => {
                        let size = [thumbnail.image.width, thumbnail.image.height];
                        self.cards.thumbnail(index, thumbnail);
                        // The card's name (a description, modality and count, or a file's name;
                        // no patient data), for whoever reads the journal (the image test does).
                        let name = self.cards.card(index).map_or(String::new(), |card| card.name.clone());
                        log::info!("card {}: \"{name}\" with a {}x{} thumbnail", index + 1, size[0], size[1]);
                    }
                    Err(error) => {
                        let message = error.to_string();
                        let source = self.cards.source(index).cloned();
                        log::warn!("cannot open {}: {message}", source.as_ref().map_or(String::new(), |s| s.key()));
                        self.cards.failed_to_open(index, &reason(&message, source.as_ref()));
                    }
                }
                Show::default()
            }
            LoaderEvent::Series { index, series } => {
                self.thumbnails_pending = self.thumbnails_pending.saturating_sub(1);
                self.cards.folder_of_series(index, series.len());
                let added = self.cards.add_new(series);
                log::info!("a folder holds {} series", added.len());
                self.thumbnails_pending += added.len();
                self.loader.thumbnails(added);
                Show::default()
            }
            LoaderEvent::Opened { index, result } => {
                if self.opening != Some(index) {
                    return Show::default();
                }
                self.opening = None;
                self.status.clear();
                match result {
                    Ok(loaded) => self.open_work(*loaded),
                    Err(error) => {
                        let message = error.to_string();
                        let source = self.cards.source(index).cloned();
                        let name = source.as_ref().map(|source| source.name()).unwrap_or_default();
                        log::warn!("cannot open {name}: {message}");
                        let message = reason(&message, source.as_ref());
                        // The restore's volume: the session is set aside, and the banner says where.
                        let restoring = self.restore.take().is_some() && self.restore_unconfirmed;
                        self.restore_unconfirmed = false;
                        self.banner = match (&self.config.session_dir, restoring) {
                            (Some(dir), true) => autosave::abandon(dir, name, message.clone()).message(),
                            _ => format!("Cannot open {name}: {message}."),
                        };
                        self.cards.failed_to_open(index, &message);
                        Show::status()
                    }
                }
            }
        }
    }

    /// The work screen on a newly opened volume, with the saved session's classes if it was
    /// saved for this volume, and the preset chosen on the chooser.
    fn open_work(&mut self, loaded: LoadedVolume) -> Show {
        let home = loaded.volume.orientation.as_ref().map(HomeView::of);
        self.view_caption = home_caption(home.as_ref());
        self.view.open(match home {
            Some(home) => Camera {
                azimuth_degrees: home.azimuth_degrees,
                elevation_degrees: home.elevation_degrees,
                ..Camera::default()
            },
            None => Camera::default(),
        });
        self.audit.record(volasso_appliance::audit::Event::ScanOpened, loaded.series_uid.clone(), None);
        // Whether the scan can go back to the PACS; a send's answer belongs to the scan before.
        self.pacs.model.opened(&loaded.source);
        if !loaded.volume.warnings.is_empty() {
            for warning in &loaded.volume.warnings {
                log::warn!("{}: {warning}", loaded.source.name());
            }
            self.banner = format!("{}: {}", loaded.source.name(), loaded.volume.warnings.join("; "));
        }
        // Pictures of the last volume are never kept for this one (view::push_slice).
        self.panel_pictures.clear();
        self.view_picture = None;
        let saved = self.restore.take();
        let changed = self.ctl.open(Work::new(loaded), saved);
        self.screen = Screen::Work;
        let show = Show { screen: true, view_picture: true, view_caption: true, ..Show::default() };
        let show = show.and(self.changed(changed));
        match self.presets.chosen {
            Some(index) => show.and(self.apply_preset(index)),
            None => show,
        }
    }
}

/// What the 3-D view says about its home position: nothing when it shows the patient from the
/// front with the head up; otherwise what it shows instead (`HomeView`'s flags).
pub(crate) fn home_caption(home: Option<&HomeView>) -> &'static str {
    match home {
        None => "Orientation unknown: stored axes",
        Some(home) if home.mirrored => {
            "Front view, mirrored: the patient's left is on the left (left-handed file axes)"
        }
        Some(home) if !home.exact => "Nearest front view with the head up",
        Some(_) => "",
    }
}

fn reason(message: &str, source: Option<&VolumeSource>) -> String {
    source.map_or_else(|| message.to_string(), |source| crate::chooser::library::reason_for_display(message, source))
}
