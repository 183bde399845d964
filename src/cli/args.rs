//! Command-line arguments as clap types: what the user typed, before any file is touched.

use crate::volume::dicom::{DicomOptions, Resample};
use crate::volume::{OpenOptions, VoxelType};
use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;

#[derive(Debug, Parser)]
#[command(
    name = "volasso",
    version,
    about = "Image-centric direct volume rendering: lassos on slices, SN-SVM, harmonic colours."
)]
pub struct Cli {
    /// More log output (-v info, -vv debug); RUST_LOG overrides.
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    pub verbose: u8,
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Dimensions, type, spacing, value range and memory use of a volume.
    Info(InfoArgs),
    /// Import a volume (e.g. a DICOM series) into a memory-mappable NRRD file.
    Import(ImportArgs),
    /// Classify every voxel from the lassos of a strokes file (SN-SVM); writes a label NRRD.
    Classify(ClassifyArgs),
    /// Classify as `classify` does, then ray-cast the result into a PNG (headless, wgpu).
    Render(RenderArgs),
    /// The kiosk UI (the default without a subcommand): a desktop window or a DRM display.
    Ui(super::ui::UiArgs),
    /// Drive the real UI headless from a touch script or an event recording.
    Replay(super::replay::ReplayArgs),
    /// Record a touchscreen's raw events as volasso-events/1 (Linux evdev).
    Record(RecordArgs),
    /// Measure classification accuracy on phantoms with known truth (simulated lassos).
    Accuracy(super::accuracy::AccuracyArgs),
    /// A DICOM storage SCP: a PACS pushes CT/MR series, each stored in --data-dir once complete.
    Receive(super::receive::ReceiveArgs),
    /// A classification of a DICOM series as a DICOM Segmentation (and the 3-D view as a
    /// Secondary Capture), new series of the series' study.
    Export(super::export::ExportArgs),
    /// Query, retrieve from and store to a PACS (DICOM C-FIND, C-GET, C-STORE as SCU).
    #[command(subcommand)]
    Pacs(super::pacs::PacsCommand),
    /// The appliance's settings (`settings.toml` in the data folder): show them, or set one.
    Settings(super::settings::SettingsArgs),
    /// The appliance's audit log (scans opened, received, sent; settings changed), oldest first.
    Audit(super::settings::AuditArgs),
}

#[derive(Debug, Args)]
pub struct RecordArgs {
    /// The input device, e.g. /dev/input/event3 (default: the first touchscreen found).
    #[arg(long, value_name = "PATH")]
    pub device: Option<PathBuf>,
    /// The recording to write (volasso-events/1 text).
    #[arg(long)]
    pub out: PathBuf,
    /// How long to record.
    #[arg(long, default_value_t = 30.0, value_parser = parse_seconds, value_name = "N")]
    pub seconds: f64,
}

fn parse_seconds(text: &str) -> Result<f64, String> {
    text.parse::<f64>()
        .ok()
        .filter(|s| *s > 0.0 && *s <= 86_400.0)
        .ok_or_else(|| format!("'{text}' is not a number of seconds from 0 to 86400"))
}

/// Pre-classified (the paper's RGBA volume) or post-classified rendering.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RenderModeChoice {
    Pre,
    Post,
}

#[derive(Debug, Args)]
pub struct RenderArgs {
    /// A volume file or DICOM folder, or `demo`.
    pub volume: PathBuf,
    #[command(flatten)]
    pub open: VolumeArgs,
    #[command(flatten)]
    pub scan: ScanArgs,
    /// The lassos: a volasso-strokes/1 JSON file.
    #[arg(long)]
    pub strokes: PathBuf,
    /// The PNG to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Image size in pixels, at most 2048 per side (the renderer's 2-D texture limit).
    #[arg(long, default_value = "800x600", value_parser = parse_render_size, value_name = "WxH")]
    pub size: [u32; 2],
    /// Camera orbit around the vertical axis, degrees (-3600 to 3600).
    #[arg(long, default_value_t = 30.0, allow_negative_numbers = true, value_parser = parse_azimuth)]
    pub azimuth: f32,
    /// Camera elevation, degrees (-90 to 90).
    #[arg(long, default_value_t = 20.0, allow_negative_numbers = true, value_parser = parse_elevation)]
    pub elevation: f32,
    /// Zoom: 1 fits the volume, 0.25 to 8 (the kiosk's range).
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true, value_parser = parse_zoom)]
    pub zoom: f32,
    #[arg(long, value_enum, default_value_t = RenderModeChoice::Post)]
    pub mode: RenderModeChoice,
}

/// Which classifier `classify` trains.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ClassifierChoice {
    /// The paper's SN-SVM (eta = 0.3, spectral scaling).
    Snsvm,
    /// The classical RBF SVM (eta = 0).
    Svm,
    /// A random forest (class-balanced bootstraps, Gini splits).
    Forest,
}

/// What kind of scan a volume is, where the file does not say, and whether its shading is divided
/// out: `classify` and `render` classify alike.
#[derive(Debug, Args, Clone, Default)]
pub struct ScanArgs {
    /// The scan's modality, for files that do not say (a DICOM series says it itself): a preset
    /// trained on one modality refuses the other, and CT in Hounsfield units is kept as it is.
    #[arg(long, value_enum)]
    pub modality: Option<ModalityChoice>,
    /// MR: keep the scan's shading (the coils' bias field) instead of dividing it out and
    /// classifying again (the default for MR scans; CT and unknown scans are never corrected).
    #[arg(long)]
    pub keep_shading: bool,
}

impl ScanArgs {
    /// The modality of the scan at `path`: `--modality` where given, else what the file says.
    pub fn modality(&self, path: &std::path::Path, open: &VolumeArgs) -> crate::preset::Modality {
        match self.modality {
            Some(ModalityChoice::Ct) => crate::preset::Modality::Ct,
            Some(ModalityChoice::Mr) => crate::preset::Modality::Mr,
            None => crate::preset::modality_of(path, &open.open_options()),
        }
    }

    /// Whether a scan of `modality` has its shading divided out: MR scans, unless
    /// `--keep-shading`.
    pub fn corrects_shading(&self, modality: crate::preset::Modality) -> bool {
        modality == crate::preset::Modality::Mr && !self.keep_shading
    }
}

/// A scan's modality (`--modality`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModalityChoice {
    /// Computed tomography.
    Ct,
    /// Magnetic resonance.
    Mr,
}

/// The spatial step `classify` ends with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CoherenceChoice {
    None,
    Majority,
    Potts,
}

/// Which voxel features `classify` computes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FeatureChoice {
    /// The paper's 5-D set (intensity, gradient magnitude, three plane means).
    Paper5,
    /// 17-D: intensity, smoothing, gradients, Hessian eigenvalues and differences of Gaussians
    /// at four scales.
    Multiscale,
    /// 9-D: the same at the two finest scales (a third of the work).
    MultiscaleFine,
    /// 6-D: the paper's five and the gap depth (a grey closing minus the value: a thin dark
    /// layer between bright structures stands out, a blurred edge does not).
    Paper5Gap,
}

impl From<FeatureChoice> for crate::features::FeatureSet {
    fn from(choice: FeatureChoice) -> Self {
        match choice {
            FeatureChoice::Paper5 => crate::features::FeatureSet::Paper5,
            FeatureChoice::Multiscale => crate::features::FeatureSet::Multiscale,
            FeatureChoice::MultiscaleFine => crate::features::FeatureSet::MultiscaleFine,
            FeatureChoice::Paper5Gap => crate::features::FeatureSet::Paper5Gap,
        }
    }
}

#[derive(Debug, Args)]
pub struct ClassifyArgs {
    /// A volume file or DICOM folder, or `demo`.
    pub volume: PathBuf,
    #[command(flatten)]
    pub open: VolumeArgs,
    /// The lassos: a volasso-strokes/1 JSON file (with `--preset`: loops that add to it).
    #[arg(long, required_unless_present = "preset")]
    pub strokes: Option<PathBuf>,
    /// Classify with a learned preset (`*.volasso-preset`) instead of, or as well as, loops.
    #[arg(long, value_name = "P")]
    pub preset: Option<PathBuf>,
    /// Save this classification as a learned preset (written atomically).
    #[arg(long, value_name = "P")]
    pub save_preset: Option<PathBuf>,
    #[command(flatten)]
    pub scan: ScanArgs,
    /// The label volume to write (NRRD, uint8; 0 = background, k = the k-th class).
    #[arg(long)]
    pub out: PathBuf,
    /// The classifier; without it, the paper's SN-SVM on its 5-D features and the gap depth
    /// (`paper5-gap`). `snsvm` and `svm` use the paper's 5-D features and `forest` the fine
    /// multi-scale features unless `--features` says otherwise.
    #[arg(long, value_enum)]
    pub classifier: Option<ClassifierChoice>,
    /// The voxel features (default: `paper5-gap`; `paper5` with `--classifier snsvm` or `svm`,
    /// `multiscale-fine` with `--classifier forest`).
    #[arg(long, value_enum)]
    pub features: Option<FeatureChoice>,
    /// Random forest: number of trees.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub trees: Option<u32>,
    /// Training voxels kept by the largest class; a smaller class keeps N times the fourth root
    /// of its size over the largest's (stratified over its strokes).
    #[arg(long, default_value_t = crate::segmentation::DEFAULT_TRAINING_CAP, value_name = "N", value_parser = parse_cap)]
    pub cap: usize,
    /// Background: `auto` (the air joined to the volume's faces and everything below Otsu's
    /// threshold, unless a class reaches there; air a lasso took in is not trained on),
    /// `none`, or a value: voxels below it get label 0 and are not evaluated.
    #[arg(long, default_value = "auto", value_parser = parse_background, value_name = "auto|none|VALUE", allow_negative_numbers = true)]
    pub background: crate::segmentation::Background,
    /// Also write the paper's pre-classified RGBA volume (4 x uint8 per voxel) as NRRD.
    #[arg(long, value_name = "RGBA.nrrd")]
    pub rgba: Option<PathBuf>,
    /// Evaluate the classifier on every foreground voxel (no coarse-to-fine refinement).
    #[arg(long)]
    pub exact: bool,
    /// The spatial step after classification: `potts` (the majority filter, then each voxel at
    /// a border between classes takes the label of least energy in a Potts model of the
    /// image), `majority` (a voxel that disagrees with its face neighbours takes its 3x3x3
    /// neighbourhood's majority label) or `none`.
    #[arg(long, value_enum, default_value = "potts")]
    pub coherence: CoherenceChoice,
    /// RBF kernel width g in exp(-g |x - y|^2) on standardised features.
    #[arg(long, value_name = "G", allow_negative_numbers = true)]
    pub kernel_width: Option<f64>,
    /// SVM box constraint C.
    #[arg(long, value_name = "C", allow_negative_numbers = true)]
    pub c: Option<f64>,
    /// SN-SVM eta (ignored with --classifier svm).
    #[arg(long, value_name = "ETA", allow_negative_numbers = true)]
    pub eta: Option<f64>,
    /// Benchmark: run training and prediction N times and report the median of each timing
    /// (the label volume of the last run is written).
    #[arg(long, default_value_t = 1, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeat: u32,
    /// Also write the training and predicted voxels' features as .npy files into DIR (for
    /// scripts/compare_sklearn.py).
    #[arg(long, value_name = "DIR")]
    pub export_features: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct InfoArgs {
    /// A volume file or DICOM folder, or `demo` for the built-in phantom.
    pub volume: PathBuf,
    #[command(flatten)]
    pub open: VolumeArgs,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub struct ImportArgs {
    /// A volume file or DICOM folder.
    pub source: PathBuf,
    #[command(flatten)]
    pub open: VolumeArgs,
    /// The NRRD file to write (atomically).
    #[arg(long)]
    pub out: PathBuf,
}

/// How to read a volume that does not describe itself fully.
#[derive(Debug, Args, Clone, Default)]
pub struct VolumeArgs {
    /// Raw data dimensions, e.g. 256,256,128 (with --type).
    #[arg(long, value_parser = parse_dims, value_name = "X,Y,Z")]
    pub dims: Option<[usize; 3]>,
    /// Raw data type: uint8, int8, uint16, int16, uint32, int32, float32, float64.
    #[arg(long = "type", value_parser = parse_type, value_name = "TYPE")]
    pub voxel_type: Option<VoxelType>,
    /// Voxel spacing in mm, e.g. 1,1,1.4 (overrides the file's).
    #[arg(long, value_parser = parse_spacing, value_name = "X,Y,Z", allow_hyphen_values = true)]
    pub spacing: Option<[f64; 3]>,
    /// DICOM: the SeriesInstanceUID to read when a folder holds several series.
    #[arg(long, value_name = "UID")]
    pub series: Option<String>,
    /// DICOM: refuse (instead of resampling) series with gantry tilt or uneven slice gaps.
    #[arg(long)]
    pub no_resample: bool,
    /// DICOM: slice spacing in mm for resampled series.
    #[arg(long, value_name = "MM", allow_negative_numbers = true)]
    pub slice_spacing: Option<f64>,
    /// DICOM: open a series with a missing or unreadable slice, resampled across the hole
    /// (refused without it).
    #[arg(long)]
    pub allow_gaps: bool,
    /// Read a detached data file (NRRD `data file`, MetaImage `ElementDataFile`, NIfTI `.img`)
    /// that lies outside its header's folder.
    #[arg(long)]
    pub allow_external_data: bool,
    /// Folder for imported volumes (default: $VOLASSO_CACHE_DIR, else ~/.cache/volasso).
    #[arg(long, value_name = "DIR")]
    pub cache_dir: Option<PathBuf>,
}

impl VolumeArgs {
    pub fn open_options(&self) -> OpenOptions {
        OpenOptions {
            dims: self.dims,
            voxel_type: self.voxel_type,
            spacing_mm: self.spacing,
            dicom: DicomOptions {
                series_uid: self.series.clone(),
                resample: if self.no_resample { Resample::Refuse } else { Resample::Auto },
                slice_spacing_mm: self.slice_spacing,
                allow_gaps: self.allow_gaps,
            },
            cache_dir: self.cache_dir.clone(),
            allow_external_data: self.allow_external_data,
            ..OpenOptions::default()
        }
    }
}

fn parse_triple<T: std::str::FromStr>(text: &str) -> Result<[T; 3], String> {
    let parts: Vec<T> = text
        .split(',')
        .map(|p| p.trim().parse::<T>().map_err(|_| format!("'{p}' is not a number")))
        .collect::<Result<_, _>>()?;
    parts.try_into().map_err(|_| format!("'{text}' is not three comma-separated numbers"))
}

fn parse_dims(text: &str) -> Result<[usize; 3], String> {
    let dims = parse_triple::<usize>(text)?;
    if dims.contains(&0) {
        return Err("dimensions must be positive".into());
    }
    Ok(dims)
}

fn parse_spacing(text: &str) -> Result<[f64; 3], String> {
    let spacing = parse_triple::<f64>(text)?;
    if spacing.iter().any(|s| !(s.is_finite() && *s > 0.0)) {
        return Err("spacing must be positive".into());
    }
    Ok(spacing)
}

fn parse_background(text: &str) -> Result<crate::segmentation::Background, String> {
    use crate::segmentation::Background;
    match text {
        "auto" => Ok(Background::Automatic),
        "none" => Ok(Background::None),
        value => match value.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Background::Below(v)),
            _ => Err(format!("'{value}' is not auto, none or a number")),
        },
    }
}

pub(super) fn parse_size(text: &str) -> Result<[u32; 2], String> {
    size_within(text, 8192)
}

/// The largest side of an image `render` draws: the renderer asks the GPU for WebGPU's
/// downlevel limits (`render::gpu::required_limits`), whose 2-D textures stop at 2048.
pub const MAX_RENDER_SIDE: u32 = 2048;

pub(super) fn parse_render_size(text: &str) -> Result<[u32; 2], String> {
    size_within(text, MAX_RENDER_SIDE)
}

fn size_within(text: &str, largest: u32) -> Result<[u32; 2], String> {
    let (width, height) = text.split_once('x').ok_or_else(|| format!("'{text}' is not WxH"))?;
    let parse = |t: &str| t.trim().parse::<u32>().ok().filter(|&v| (1..=largest).contains(&v));
    match (parse(width), parse(height)) {
        (Some(w), Some(h)) => Ok([w, h]),
        _ => Err(format!("'{text}' is not WxH with sides from 1 to {largest}")),
    }
}

/// A number within `range`, for a camera option; `what` names it in the message.
fn number_within(text: &str, range: std::ops::RangeInclusive<f32>, what: &str) -> Result<f32, String> {
    text.trim()
        .parse::<f32>()
        .ok()
        .filter(|value| range.contains(value))
        .ok_or_else(|| format!("'{text}' is not {what} from {} to {}", range.start(), range.end()))
}

fn parse_azimuth(text: &str) -> Result<f32, String> {
    number_within(text, -3600.0..=3600.0, "an angle in degrees")
}

fn parse_elevation(text: &str) -> Result<f32, String> {
    number_within(text, -90.0..=90.0, "an elevation in degrees")
}

fn parse_zoom(text: &str) -> Result<f32, String> {
    number_within(text, 0.25..=8.0, "a zoom")
}

fn parse_cap(text: &str) -> Result<usize, String> {
    text.trim()
        .parse::<usize>()
        .ok()
        .filter(|&cap| cap >= 1)
        .ok_or_else(|| format!("'{text}' is not a number of training voxels of at least 1"))
}

/// A pixel density for `--dpi`: a number within `app::dpi::DPI_RANGE`.
pub(super) fn parse_dpi(text: &str) -> Result<f32, String> {
    let range = crate::app::dpi::DPI_RANGE;
    text.trim().parse::<f32>().ok().filter(|dpi| range.contains(dpi)).ok_or_else(|| {
        format!("'{text}' is not a pixel density from {} to {} dots per inch", range.start(), range.end())
    })
}

fn parse_type(text: &str) -> Result<VoxelType, String> {
    VoxelType::from_name(text)
        .ok_or_else(|| format!("'{text}' is not one of uint8, int8, uint16, int16, uint32, int32, float32, float64"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    fn parse(args: &[&str]) -> Result<Cli, clap::Error> {
        Cli::try_parse_from(std::iter::once("volasso").chain(args.iter().copied()))
    }

    #[test]
    fn the_render_size_limit_is_the_renderer_s() {
        assert_eq!(MAX_RENDER_SIDE, wgpu::Limits::downlevel_defaults().max_texture_dimension_2d);
        let args = ["render", "demo", "--strokes", "s.json", "--out", "o.png", "--size"];
        assert!(parse(&[&args[..], &["2048x2048"]].concat()).is_ok());
        let error = parse(&[&args[..], &["2049x600"]].concat()).unwrap_err().to_string();
        assert!(error.contains("from 1 to 2048"), "{error}");
    }

    #[test]
    fn negative_numbers_are_read_after_a_space_then_checked() {
        let classify = ["classify", "demo", "--strokes", "s.json", "--out", "o.nrrd"];
        let Some(Command::Classify(args)) =
            parse(&[&classify[..], &["--background", "-500"]].concat()).unwrap().command
        else {
            panic!("not classify")
        };
        assert_eq!(args.background, crate::segmentation::Background::Below(-500.0));
        let parsed = parse(&[&classify[..], &["--eta", "-1", "--spacing", "-1,1,1"]].concat());
        let error = parsed.unwrap_err().to_string();
        assert!(error.contains("spacing must be positive"), "{error}");
        let render = ["render", "demo", "--strokes", "s.json", "--out", "o.png"];
        let Some(Command::Render(args)) =
            parse(&[&render[..], &["--azimuth", "-45", "--elevation", "-90", "--zoom", "0.25"]].concat())
                .unwrap()
                .command
        else {
            panic!("not render")
        };
        assert_eq!([args.azimuth, args.elevation, args.zoom], [-45.0, -90.0, 0.25]);
        for (option, value, words) in [
            ("--zoom", "-1", "not a zoom from 0.25 to 8"),
            ("--zoom", "0", "not a zoom"),
            ("--zoom", "NaN", "not a zoom"),
            ("--azimuth", "1e308", "not an angle in degrees from -3600 to 3600"),
            ("--azimuth", "nan", "not an angle"),
            ("--elevation", "91", "not an elevation in degrees from -90 to 90"),
        ] {
            let error = parse(&[&render[..], &[option, value]].concat()).unwrap_err().to_string();
            assert!(error.contains(words), "{option} {value}: {error}");
        }
        let error = parse(&[&classify[..], &["--cap", "0"]].concat()).unwrap_err().to_string();
        assert!(error.contains("at least 1"), "{error}");
    }
}
