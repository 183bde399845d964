//! How the app is set up: the folders it reads and writes, the idle timeout, the panel's
//! density, the PACS peers and the clock (`volasso ui` and `volasso replay` options, the
//! appliance's environment).
//!
//! Never: reads files or the environment itself; the command line and the kiosk fill it in.

use crate::chooser::library::VolumeSource;
use crate::{clock, view3d};
use std::path::PathBuf;
use std::time::Duration;
use volasso_appliance::settings::Language;
use volasso_core::volume::OpenOptions;
use volasso_core::volume::dicom::PatientShown;

/// How the app is set up (`volasso ui` options).
#[derive(Clone, Debug)]
pub struct AppConfig {
    /// The folder whose volumes the chooser offers (besides the demo).
    pub data_dir: Option<PathBuf>,
    /// Where the session is autosaved; `None`: no autosave.
    pub session_dir: Option<PathBuf>,
    /// After this long without a touch the app returns to the start screen and forgets the
    /// session; `None`: never.
    pub idle_timeout: Option<Duration>,
    /// Open this volume at once instead of showing the start screen.
    pub initial_volume: Option<VolumeSource>,
    pub open_options: OpenOptions,
    /// The panel's pixel density, which sizes touch targets and text ([`crate::dpi`]); `None`:
    /// [`crate::dpi::DEFAULT_DPI`].
    pub dpi: Option<f32>,
    /// Where USB sticks are mounted (snapshots are copied onto each one found).
    pub media_roots: Vec<PathBuf>,
    /// The PACS peers to query, retrieve from and send results to (`--pacs`); none: no PACS
    /// button.
    pub pacs: Vec<volasso_dicom::pacs::Peer>,
    /// The clock of the platform's timers (scripted in the replay harness).
    pub clock: clock::Clock,
    /// Shown in the banner at start (the settings file could not be used, and why).
    pub notice: Option<String>,
    /// Whether the screens show whose scan it is (clinical mode: `Shown`; patient.rs).
    pub patient: PatientShown,
    /// Received series, the session, gallery entries, snapshots and outgoing results older
    /// than this are deleted (expiry.rs); `None`: kept.
    pub retention: Option<Duration>,
    /// The language of the screens (words.rs).
    pub language: Language,
}

impl Default for AppConfig {
    fn default() -> Self {
        AppConfig {
            data_dir: None,
            session_dir: None,
            idle_timeout: Some(DEFAULT_IDLE_TIMEOUT),
            initial_volume: None,
            open_options: OpenOptions::default(),
            dpi: None,
            media_roots: view3d::snapshot::DEFAULT_MEDIA_ROOTS.map(PathBuf::from).to_vec(),
            pacs: Vec::new(),
            clock: clock::Clock::default(),
            notice: None,
            retention: None,
            patient: PatientShown::Hidden,
            language: Language::En,
        }
    }
}

/// Where results are written before they are sent to the PACS: the session folder's
/// `outbox`, else the data folder's hidden `.outbox` (the chooser skips hidden folders).
pub(crate) fn outbox(config: &AppConfig) -> Option<PathBuf> {
    match (&config.session_dir, &config.data_dir) {
        (Some(session_dir), _) => Some(session_dir.join("outbox")),
        (None, Some(data_dir)) => Some(data_dir.join(".outbox")),
        (None, None) => None,
    }
}

/// Two minutes: long enough to think between lassos, short enough that a demo station is
/// fresh for the next visitor.
pub const DEFAULT_IDLE_TIMEOUT: Duration = Duration::from_secs(120);
