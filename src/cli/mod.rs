//! The `volasso` command line (`interfaces.md`): parse, run one subcommand, report the one error.
//!
//! Each subcommand lives in its own file and calls the pipeline; this module only dispatches,
//! sets up logging and turns an error into one sentence on stderr with a non-zero status.

mod accuracy;
mod args;
mod classify;
mod export;
mod import;
mod info;
mod memory;
mod npy;
mod outputs;
mod pacs;
mod receive;
mod record;
mod render;
mod replay;
mod settings;
pub mod ui;

pub use args::{Cli, Command, VolumeArgs};

use clap::Parser;
use std::process::ExitCode;

/// Everything a subcommand can fail with, each variant one pipeline stage's error.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    #[error(transparent)]
    Volume(#[from] crate::volume::VolumeError),
    #[error("{0}")]
    Usage(String),
    #[error(transparent)]
    Strokes(#[from] crate::strokes::StrokesError),
    #[error(transparent)]
    Segmentation(#[from] crate::segmentation::SegmentationError),
    #[error(transparent)]
    Transfer(#[from] crate::transfer::TransferError),
    #[error(transparent)]
    Render(#[from] crate::render::RenderError),
    #[error(transparent)]
    Touch(#[from] crate::touch::TouchError),
    #[error("cannot write {}: {source}", path.display())]
    Output { source: std::io::Error, path: std::path::PathBuf },
    /// The training voxels cannot train a classifier.
    #[error(transparent)]
    Training(#[from] crate::pipeline::TrainingError),
    /// An output path names an input, another output or a folder.
    #[error(transparent)]
    Paths(#[from] outputs::PathClash),
    #[error(transparent)]
    Accuracy(#[from] crate::accuracy::AccuracyError),
    /// A preset cannot be read, written or applied.
    #[error(transparent)]
    Preset(#[from] crate::preset::PresetError),
    /// The kiosk (DRM display, platform, replay harness) failed.
    #[error(transparent)]
    Kiosk(#[from] crate::kiosk::KioskError),
    /// DRM failed where a display server runs, in a build without a desktop window.
    #[error(
        "{source} (a display server is running, but this build has no desktop window: build with `--features window`)"
    )]
    DrmBesideDisplayServer { source: crate::kiosk::KioskError },
    #[error("cannot open the UI window: {0}")]
    Window(#[source] slint::PlatformError),
    #[error("this build has no desktop window support (cargo feature `window`)")]
    NoWindowSupport,
    #[error("recording touch input needs Linux evdev")]
    NoEvdev,
    /// A replay ran, and this many of its expectations did not hold (each printed before).
    #[error("{failed} expectation(s) failed")]
    ExpectationsFailed { failed: usize },
    /// A classification cannot be exported as DICOM.
    #[error(transparent)]
    Export(#[from] crate::dicom_out::ExportError),
    /// A PACS could not be queried, retrieved from or stored to.
    #[error(transparent)]
    Pacs(#[from] crate::pacs::PacsError),
    /// The appliance's settings cannot be read, changed or written.
    #[error(transparent)]
    Settings(#[from] crate::appliance::settings::SettingsError),
}

/// Runs the command line with the process's arguments.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging(cli.verbose);
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("volasso: error: {error}");
            ExitCode::FAILURE
        }
    }
}

/// Runs one parsed command line.
/// A pipeline error as the command line reports it: a strokes problem names the strokes file.
fn pipeline_error(error: crate::pipeline::PipelineError, strokes: &std::path::Path) -> CliError {
    use crate::pipeline::PipelineError;
    match error {
        PipelineError::Strokes(error) => error.with_path(strokes).into(),
        PipelineError::Segmentation(error) => error.into(),
        PipelineError::Transfer(error) => error.into(),
        PipelineError::Volume(error) => error.into(),
        PipelineError::Training(error) => CliError::Training(error),
        PipelineError::Preset(error) => CliError::Preset(error),
        error @ PipelineError::ScribbleShape { .. } => CliError::Usage(error.to_string()),
    }
}

pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Some(Command::Info(args)) => info::run(&args),
        Some(Command::Import(args)) => import::run(&args),
        Some(Command::Classify(args)) => classify::run(&args),
        Some(Command::Render(args)) => render::run(&args),
        Some(Command::Ui(args)) => ui::run(&args),
        Some(Command::Replay(args)) => replay::run(&args),
        Some(Command::Record(args)) => record::run(&args),
        Some(Command::Accuracy(args)) => accuracy::run(&args),
        Some(Command::Receive(args)) => receive::run(&args),
        Some(Command::Export(args)) => export::run(&args),
        Some(Command::Pacs(command)) => pacs::run(&command),
        Some(Command::Settings(args)) => settings::run(&args),
        Some(Command::Audit(args)) => settings::run_audit(&args),
        None => ui::run(&ui::UiArgs::from_environment()?),
    }
}

fn init_logging(verbose: u8) {
    let level = match verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    let _ = env_logger::Builder::from_env(env_logger::Env::default().default_filter_or(level))
        .format_timestamp(None)
        .try_init();
}

/// Opens the volume a subcommand names: a file or folder, or the demo phantom
/// ([`crate::phantom::source::DEMO_VOLUME`]).
pub fn open_volume(path: &std::path::Path, args: &VolumeArgs) -> Result<crate::volume::Volume, CliError> {
    Ok(crate::phantom::source::VolumeSource::from_path(path).open(&args.open_options())?)
}
