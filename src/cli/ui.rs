//! `volasso ui [VOLUME]` (and `volasso` alone): the kiosk UI, in a desktop window (winit) or
//! fullscreen on a DRM display (the appliance). Headless runs go through `volasso replay`.

use super::CliError;
use crate::app::{App, AppConfig};
use crate::appliance::settings::{self, Effective, Settings};
use crate::phantom::source::VolumeSource;
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use std::time::Duration;

/// Where the UI is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, ValueEnum)]
pub enum DisplayChoice {
    /// A window when a display server is there (DISPLAY or WAYLAND_DISPLAY), else DRM.
    #[default]
    Auto,
    /// A fullscreen desktop window (X11 or Wayland).
    Window,
    /// Straight on a DRM/KMS display, no display server (the appliance).
    Drm,
}

#[derive(Debug, Args, Default)]
pub struct UiArgs {
    /// Open this volume at once (a file, a DICOM folder, or `demo`); without it, the start
    /// screen and the chooser.
    pub volume: Option<PathBuf>,
    /// The folder whose volumes the chooser offers.
    #[arg(long, env = "VOLASSO_DATA_DIR")]
    pub data_dir: Option<PathBuf>,
    /// Where the session is autosaved and restored from; no autosave without it.
    #[arg(long, env = "VOLASSO_SESSION_DIR")]
    pub session_dir: Option<PathBuf>,
    /// Seconds without a touch before the start screen returns and the session is cleared;
    /// 0 never [default: the settings' `idle_timeout_s`, else 120].
    #[arg(long)]
    pub idle_timeout: Option<u64>,
    #[arg(long, value_enum, default_value_t = DisplayChoice::Auto)]
    pub display: DisplayChoice,
    /// A window instead of fullscreen (development).
    #[arg(long)]
    pub windowed: bool,
    /// The DRM device (`/dev/dri/cardN`); the first with a connected display when omitted.
    #[arg(long)]
    pub card: Option<PathBuf>,
    /// The touchscreen (`/dev/input/eventN`); the first one found when omitted.
    #[arg(long)]
    pub touch: Option<PathBuf>,
    /// Run without touch input on DRM.
    #[arg(long)]
    pub no_touch: bool,
    /// Turns touch coordinates to match a rotated panel: 0, 90, 180 or 270 degrees [default:
    /// the settings' `panel.rotation_degrees`, else 0].
    #[arg(long)]
    pub touch_rotate: Option<i32>,
    #[arg(long)]
    pub touch_flip_x: bool,
    #[arg(long)]
    pub touch_flip_y: bool,
    /// The panel's pixel density, which sizes touch targets (9.5 mm) and text; default: from
    /// the DRM display's physical size when it reports a believable one, else 150.
    #[arg(long, value_parser = super::args::parse_dpi, value_name = "DPI")]
    pub dpi: Option<f32>,
    #[command(flatten)]
    pub pacs: KioskPacsArgs,
}

/// The PACS peers of the kiosk's PACS screen and "Send to PACS".
#[derive(Debug, Args, Clone, Default)]
pub struct KioskPacsArgs {
    /// A PACS to query, retrieve from and send results to, as AE@host:port; repeatable, or
    /// several separated by commas (the PACS screen's "Next PACS" goes through them).
    #[arg(long = "pacs", env = "VOLASSO_PACS", value_delimiter = ',', value_name = "AE@HOST:PORT", value_parser = parse_peer)]
    pub pacs: Vec<String>,
    /// This kiosk's AE title (the calling AE title) [default: the settings'
    /// `receive.ae_title`, else VOLASSO].
    #[arg(long = "ae-title", env = "VOLASSO_AE_TITLE", value_name = "TITLE", value_parser = parse_ae_title)]
    pub ae_title: Option<String>,
    #[command(flatten)]
    pub tls: super::pacs::ClientTlsArgs,
}

/// How long the kiosk waits for a PACS to connect or answer.
const PACS_TIMEOUT: Duration = Duration::from_secs(30);

impl KioskPacsArgs {
    /// The peers (their addresses were checked when parsed), over TLS with `--tls-ca`: those
    /// given here, else the settings' (`settings`), with this kiosk's AE title given here, else
    /// the settings'.
    pub fn peers(&self, settings: &Effective) -> Result<Vec<crate::pacs::Peer>, CliError> {
        let tls = self.tls.config()?;
        let ae_title = self.ae_title.as_deref().unwrap_or(&settings.receive.ae_title);
        let peer = |text: &String| {
            crate::pacs::Peer::parse(text, ae_title, PACS_TIMEOUT)
                .map(|peer| crate::pacs::Peer { tls: tls.clone(), ..peer })
        };
        let given = if self.pacs.is_empty() { &settings.pacs } else { &self.pacs };
        Ok(given.iter().map(peer).collect::<Result<_, _>>()?)
    }
}

fn parse_peer(text: &str) -> Result<String, String> {
    crate::pacs::Peer::parse(text, "VOLASSO", PACS_TIMEOUT).map(|_| text.to_string()).map_err(|error| error.to_string())
}

fn parse_ae_title(text: &str) -> Result<String, String> {
    crate::receive::check_ae_title(text).map(|()| text.to_string()).map_err(|error| error.to_string())
}

/// `volasso` alone: the UI with its defaults (and the VOLASSO_* environment variables).
#[derive(Debug, clap::Parser)]
struct UiOnly {
    #[command(flatten)]
    args: UiArgs,
}

impl UiArgs {
    /// The UI's settings from the VOLASSO_* environment variables; a value that does not parse
    /// (a PACS address without a port) is an error, never silently the default.
    pub fn from_environment() -> Result<UiArgs, CliError> {
        use clap::Parser;
        UiOnly::try_parse_from(["volasso"]).map(|only| only.args).map_err(|error| CliError::Usage(error.to_string()))
    }
}

impl UiArgs {
    /// The appliance's settings in `--data-dir` (`settings.toml`; the defaults without one),
    /// and why its file could not be used.
    fn settings(&self) -> (Effective, Option<String>) {
        let Some(data_dir) = &self.data_dir else { return (Settings::default().effective(), None) };
        let loaded = settings::load(data_dir);
        let problem = loaded.problem.map(|problem| {
            log::error!("{problem}; the kiosk runs on the safe defaults");
            format!("Running on the safe defaults: {problem}")
        });
        (loaded.settings.effective(), problem)
    }

    /// The app's set-up: each option given here, else the settings', else its default.
    pub fn config(&self) -> Result<AppConfig, CliError> {
        Ok(self.config_and_settings()?.0)
    }

    /// [`Self::config`] and the settings it was made from (the settings file read once).
    fn config_and_settings(&self) -> Result<(AppConfig, Effective), CliError> {
        let (mut settings, notice) = self.settings();
        if let Some(seconds) = self.idle_timeout {
            settings.idle_timeout_s = seconds;
        }
        let mut config = AppConfig {
            data_dir: self.data_dir.clone(),
            session_dir: self.session_dir.clone(),
            idle_timeout: settings.idle_timeout(),
            initial_volume: self.volume.as_ref().map(|path| VolumeSource::from_path(path)),
            dpi: self.dpi.or(settings.panel.dpi),
            pacs: self.pacs.peers(&settings)?,
            notice,
            language: settings.language,
            retention: settings.retention(),
            patient: settings.patient_shown(),
            ..AppConfig::default()
        };
        // No USB stick gets a snapshot unless the settings allow it (clinical mode's default).
        if !settings.usb_export {
            config.media_roots.clear();
        }
        Ok((config, settings))
    }
}

pub fn run(args: &UiArgs) -> Result<(), CliError> {
    let has_display_server = std::env::var_os("DISPLAY").is_some() || std::env::var_os("WAYLAND_DISPLAY").is_some();
    match args.display {
        DisplayChoice::Window => run_window(args),
        DisplayChoice::Drm => run_drm(args),
        DisplayChoice::Auto if has_display_server && cfg!(feature = "window") => run_window(args),
        // A display server usually holds the DRM card, so a developer who left out the feature
        // is told how to get a window rather than only why DRM failed.
        DisplayChoice::Auto if has_display_server => run_drm(args).map_err(|error| match error {
            CliError::Kiosk(source) => CliError::DrmBesideDisplayServer { source },
            other => other,
        }),
        DisplayChoice::Auto => run_drm(args),
    }
}

fn run_window(args: &UiArgs) -> Result<(), CliError> {
    if !cfg!(feature = "window") {
        return Err(CliError::NoWindowSupport);
    }
    let app = App::new(args.config()?).map_err(CliError::Window)?;
    if !args.windowed {
        use slint::ComponentHandle;
        app.window().window().set_fullscreen(true);
    }
    app.run().map_err(CliError::Window)
}

fn run_drm(args: &UiArgs) -> Result<(), CliError> {
    let (config, settings) = args.config_and_settings()?;
    let touch = crate::kiosk::drm_loop::TouchOptions {
        device: args.touch.clone(),
        disabled: args.no_touch,
        rotation_degrees: args.touch_rotate.unwrap_or(i32::from(settings.panel.rotation_degrees)),
        flip_x: args.touch_flip_x,
        flip_y: args.touch_flip_y,
    };
    Ok(crate::kiosk::drm_loop::run(config, args.card.clone(), touch)?)
}
