//! The volumes the chooser offers: the built-in demo phantom and every volume file or DICOM
//! folder in the data folder; opening one (with its ranked slices and display windows) and
//! its thumbnail happen on worker threads, and failures come back as messages for a card or a
//! banner.
//!
//! Every file is treated as hostile (it may come from a USB stick or the network): a reader
//! that fails returns its error, and one that panics is caught at the worker's boundary
//! ([`guarded`]) and reported the same way, so one bad file neither stops the other thumbnails
//! nor leaves the chooser "Opening..." forever.
//!
//! A DICOM folder that holds several series (a PACS push, a study copied from a CD) is
//! listed on the thumbnail worker ([`series_of`]), without patient data, and each series
//! becomes a card of its own.
//!
//! Never: touches the UI; never fails the app for a bad file (it becomes a card that says so).

use crate::patient::Patient;
use crate::windowing::WindowChoices;
use crate::worker::{Report, Task, Threaded, Ticket, Worker};
use std::collections::{HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::Arc;
pub use volasso_core::phantom::source::VolumeSource;
use volasso_core::phantom::source::uid_tail;
use volasso_core::preset::Modality;
use volasso_core::slices::{SliceEntropies, SliceLayout, foreground_slice_entropies, plane_axes, slice_image};
use volasso_core::transfer::RgbImage;
use volasso_core::volume::dicom::{PatientShown, SeriesSummary, list_series};
use volasso_core::volume::{OpenOptions, Volume, open::detect_format};

/// Why a volume cannot be offered or opened; a card or banner shows it
/// ([`reason_for_display`]).
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    #[error(transparent)]
    Volume(#[from] volasso_core::volume::VolumeError),
    #[error("{name} has no voxels")]
    NoVoxels { name: String },
    /// The reader panicked inside ([`guarded`]).
    #[error("the reader failed on this file ({message})")]
    ReaderPanicked { message: String },
    #[error(transparent)]
    Slice(#[from] volasso_core::slices::SliceError),
    #[error("slice {slice} along {axis}: the picture does not hold its pixels")]
    Arrangement { slice: usize, axis: volasso_core::slices::Axis },
    #[error("cannot start a thread to open it")]
    NoThread,
}

/// The largest side of a thumbnail, in pixels.
pub const THUMBNAIL_SIDE: usize = 256;

/// The most entries the chooser lists, so a folder of thousands of files stays usable.
pub const MAX_ENTRIES: usize = 200;

/// Folders of the data folder that hold the appliance's own output, never a DICOM series: kept
/// results (gallery.rs), snapshots, the audit log and learned presets (presets.rs).
pub const RESERVED_FOLDERS: [&str; 4] = [
    crate::gallery::FOLDER,
    crate::view3d::snapshot::SNAPSHOT_FOLDER,
    volasso_appliance::audit::FOLDER,
    crate::presets::PRESETS_FOLDER,
];

/// The volumes to offer: the demo first, then the data folder's volumes by name.
pub fn scan(data_dir: Option<&Path>) -> Vec<VolumeSource> {
    let mut sources = vec![VolumeSource::Demo];
    let Some(data_dir) = data_dir else { return sources };
    let Ok(entries) = std::fs::read_dir(data_dir) else {
        log::warn!("cannot read the data folder {}", data_dir.display());
        return sources;
    };
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|path| !path.file_name().is_some_and(|name| name.to_string_lossy().starts_with('.')))
        .filter(|path| !path.file_name().is_some_and(|name| RESERVED_FOLDERS.iter().any(|r| name == *r)))
        .filter(|path| looks_like_volume(path))
        .collect();
    paths.sort();
    paths.truncate(MAX_ENTRIES);
    sources.extend(paths.into_iter().map(VolumeSource::Path));
    sources
}

/// The sources of a new listing `found` that `known` lacks, with the chooser index each gets
/// when appended, up to [`MAX_ENTRIES`] besides the demo. Volumes only ever append: the
/// chooser's indices stay valid for thumbnails and opens in flight, and a file that vanished
/// keeps its card and says so when opened.
pub fn appeared(known: &[VolumeSource], found: Vec<VolumeSource>) -> Vec<(usize, VolumeSource)> {
    let room = (MAX_ENTRIES + 1).saturating_sub(known.len());
    found
        .into_iter()
        .filter(|source| !known.contains(source))
        .take(room)
        .enumerate()
        .map(|(offset, source)| (known.len() + offset, source))
        .collect()
}

/// Volume files by name; raw data only with an Open SciVis name (a `.raw` beside a `.mhd` is
/// the MetaImage's data, not a volume of its own); folders are DICOM series.
fn looks_like_volume(path: &Path) -> bool {
    if path.is_dir() {
        return true;
    }
    let name = path.file_name().map(|n| n.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let known = [".nrrd", ".nhdr", ".mha", ".mhd", ".nii", ".nii.gz", ".dcm"];
    if known.iter().any(|extension| name.ends_with(extension)) {
        return true;
    }
    name.ends_with(".raw")
        && path.file_name().and_then(|n| n.to_str()).and_then(volasso_core::volume::raw::parse_name).is_some()
}

/// An opened volume with what the work screen needs at once.
#[derive(Clone)]
pub struct LoadedVolume {
    pub source: VolumeSource,
    pub volume: Arc<Volume>,
    pub entropies: SliceEntropies,
    /// The display windows offered, the first shown at once.
    pub windows: WindowChoices,
    /// Whose scan it is (clinical mode; patient.rs).
    pub patient: Patient,
    /// What a DICOM series is, for its card: description, modality and images; `None` for
    /// other scans (their file name says it).
    pub title: Option<String>,
    /// The SeriesInstanceUID of a DICOM series (the audit log names it hashed).
    pub series_uid: Option<String>,
    /// What kind of scan (a preset of one modality refuses the other): a DICOM series' own;
    /// the demo is a CT in Hounsfield units; other files say nothing.
    pub modality: Modality,
}

/// A card's picture and words.
#[derive(Clone, Debug)]
pub struct Thumbnail {
    pub image: RgbImage,
    /// Size and voxel type.
    pub detail: String,
    /// [`LoadedVolume::title`].
    pub title: Option<String>,
    /// The patient's line (patient.rs); empty when not shown.
    pub patient: String,
}

/// Runs `work`, turning a panic inside it into an error: the worker survives, and the file
/// that made a reader panic gets a card that says it cannot be opened.
pub fn guarded<T>(source: &VolumeSource, work: impl FnOnce() -> Result<T, OpenError>) -> Result<T, OpenError> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(work)) {
        Ok(result) => result,
        Err(payload) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|text| text.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "no message".to_string());
            log::error!("the reader failed inside on {}: {message}", source.key());
            Err(OpenError::ReaderPanicked { message })
        }
    }
}

/// `volume` as the chooser opens a scan that is not DICOM, in demo mode, with `modality`: the
/// app's logic tests' scan.
#[cfg(test)]
pub(crate) fn opened_for_tests(volume: Volume, modality: Modality) -> LoadedVolume {
    let entropies = foreground_slice_entropies(&volume);
    let windows = WindowChoices::for_volume(&volume);
    LoadedVolume {
        source: VolumeSource::Demo,
        volume: Arc::new(volume),
        entropies,
        windows,
        patient: Patient::NotShown,
        title: None,
        series_uid: None,
        modality,
    }
}

/// An error message for a card or banner that already names the file: without the path that
/// errors carry last (", in /var/lib/volasso/volumes/x.nrrd").
pub fn reason_for_display(message: &str, source: &VolumeSource) -> String {
    let mut reason = message.trim();
    if let VolumeSource::Path(path) | VolumeSource::Series { folder: path, .. } = source {
        let path = path.display().to_string();
        if let Some(shorter) = reason.strip_suffix(path.as_str()) {
            let shorter = shorter.trim_end();
            reason = shorter.strip_suffix(", in").or_else(|| shorter.strip_suffix(" in")).unwrap_or(shorter);
            reason = reason.trim_end_matches([',', ':', ' ']);
        }
    }
    if reason.is_empty() { "unknown error".to_string() } else { reason.to_string() }
}

/// Opens `source` and ranks its slices (paper eq. 1).
pub fn load(source: &VolumeSource, options: &OpenOptions, shown: PatientShown) -> Result<LoadedVolume, OpenError> {
    if let VolumeSource::Path(path) = source {
        detect_format(path, options)?;
    }
    let volume = source.open(options)?;
    if volume.voxel_count() == 0 {
        return Err(OpenError::NoVoxels { name: source.name() });
    }
    let entropies = foreground_slice_entropies(&volume);
    // Here, off the interactive path: every training on the volume needs them.
    volume.otsu_threshold();
    volume.body();
    let windows = WindowChoices::for_volume(&volume);
    let summary = crate::patient::series_summary(source, shown, &options.limits());
    let patient = Patient::of(summary.as_ref(), shown);
    let title = summary.as_ref().and_then(|summary| folder_title(source, summary));
    let modality = match (source, &summary) {
        (VolumeSource::Demo, _) => Modality::Ct,
        (_, Some(summary)) => Modality::from_code(&summary.modality),
        (_, None) => Modality::Unknown,
    };
    let series_uid = summary.map(|summary| summary.series_uid);
    Ok(LoadedVolume {
        source: source.clone(),
        volume: Arc::new(volume),
        entropies,
        windows,
        patient,
        title,
        series_uid,
        modality,
    })
}

/// The thumbnail and a one-line description of a loaded volume: its top axial slice (the
/// stored z slice when the orientation is unknown), shown as the work screen shows it.
pub fn thumbnail(loaded: &LoadedVolume) -> Result<Thumbnail, OpenError> {
    let volume = &loaded.volume;
    let orientation = volume.orientation.as_ref();
    let layout = SliceLayout::new(orientation, plane_axes(orientation)[0]);
    let slice = loaded.entropies.axis(layout.axis).top();
    let grey = slice_image(volume, layout.axis, slice, loaded.windows.initial().window)?;
    let (shown, shown_width, shown_height) = layout
        .arrange_pixels(&grey.pixels, 1, grey.width, grey.height)
        .ok_or(OpenError::Arrangement { slice, axis: layout.axis })?;
    let step = (shown_width.max(shown_height)).div_ceil(THUMBNAIL_SIDE).max(1);
    let (width, height) = (shown_width.div_ceil(step), shown_height.div_ceil(step));
    let mut pixels = Vec::with_capacity(width * height * 3);
    for j in 0..height {
        for i in 0..width {
            pixels.extend([shown[(j * step) * shown_width + i * step]; 3]);
        }
    }
    let [x, y, z] = volume.dims;
    let detail = format!("{x} x {y} x {z}  {}", volume.voxel_type.name());
    Ok(Thumbnail {
        image: RgbImage { width, height, pixels },
        detail,
        title: loaded.title.clone(),
        patient: loaded.patient.line(),
    })
}

/// The series of a DICOM folder, when it holds more than one: each becomes a source (and a
/// card) of its own, labelled with what a person can tell them apart by. `None` for anything
/// What a person tells a series by: its description, modality and images, e.g. `STD BRAIN 5MM
/// (CT, 28 images)`; never patient data.
fn series_label(series: &SeriesSummary) -> String {
    let kind = [series.modality.as_str(), &format!("{} images", series.images)]
        .into_iter()
        .filter(|part| !part.is_empty())
        .collect::<Vec<_>>()
        .join(", ");
    match series.description.trim() {
        "" => format!("series {} ({kind})", uid_tail(&series.series_uid)),
        description => format!("{description} ({kind})"),
    }
}

/// The card name of a folder that is one DICOM series: the series' label, after the folder's
/// name unless the receiver named the folder (a hash says nothing to a person). `None` for a
/// series of a folder of several (its source is named so already).
fn folder_title(source: &VolumeSource, series: &SeriesSummary) -> Option<String> {
    let VolumeSource::Path(_) = source else { return None };
    let name = source.name();
    let label = series_label(series);
    Some(if volasso_appliance::retention::is_received_series(&name) { label } else { format!("{name}: {label}") })
}

/// else (a file, a folder of one series, a folder that cannot be listed: opening it says why).
pub fn series_of(source: &VolumeSource, options: &OpenOptions) -> Option<Vec<VolumeSource>> {
    let VolumeSource::Path(folder) = source else { return None };
    if !folder.is_dir() {
        return None;
    }
    let listed = list_series(folder, PatientShown::Hidden, &options.limits()).ok()?;
    (listed.len() > 1).then(|| {
        listed
            .into_iter()
            .map(|series| {
                let label = series_label(&series);
                VolumeSource::Series { folder: folder.clone(), series_uid: series.series_uid, label }
            })
            .collect()
    })
}

/// What the loader thread reports.
pub enum LoaderEvent {
    Thumbnail {
        index: usize,
        result: Result<Thumbnail, OpenError>,
    },
    /// The folder at `index` holds several series, each a source of its own.
    Series {
        index: usize,
        series: Vec<VolumeSource>,
    },
    Opened {
        index: usize,
        result: Result<Box<LoadedVolume>, OpenError>,
    },
}

/// The loader's two tasks: thumbnails of many sources, one volume opened.
#[allow(clippy::type_complexity)]
fn loader_tasks(
    options: OpenOptions,
    shown: PatientShown,
) -> (Task<Vec<(usize, VolumeSource)>, LoaderEvent>, Task<(usize, VolumeSource), LoaderEvent>) {
    let thumbnail_options = options.clone();
    let thumbnails: Task<Vec<(usize, VolumeSource)>, LoaderEvent> =
        Arc::new(move |sources, _: &Ticket, report: &Report<'_, LoaderEvent>| {
            for (index, source) in sources {
                let options = &thumbnail_options;
                if let Ok(Some(series)) = guarded(&source, || Ok(series_of(&source, options))) {
                    report(LoaderEvent::Series { index, series });
                    continue;
                }
                let result = guarded(&source, || load(&source, options, shown).and_then(|loaded| thumbnail(&loaded)));
                report(LoaderEvent::Thumbnail { index, result });
            }
        });
    let opens: Task<(usize, VolumeSource), LoaderEvent> =
        Arc::new(move |(index, source), _: &Ticket, report: &Report<'_, LoaderEvent>| {
            let result = guarded(&source, || load(&source, &options, shown)).map(Box::new);
            report(LoaderEvent::Opened { index, result });
        });
    (thumbnails, opens)
}

/// Opens volumes off the UI thread: thumbnails one after another on one thread, and each
/// volume the user picks on a thread of its own, so a pick never waits behind thumbnails.
pub struct Loader {
    thumbnails: Box<dyn Worker<Vec<(usize, VolumeSource)>, LoaderEvent>>,
    opens: Box<dyn Worker<(usize, VolumeSource), LoaderEvent>>,
    /// The chooser indices of each job not yet ended, to say they failed should the job end
    /// without a word.
    thumbnailing: HashMap<u64, Vec<usize>>,
    opening: HashMap<u64, usize>,
    /// Failures of such jobs, one event per index, still to be polled.
    failed: VecDeque<LoaderEvent>,
}

impl Loader {
    /// Opens with `options`, reading who the patient is when `shown` (clinical mode).
    pub fn new(options: OpenOptions, shown: PatientShown) -> Loader {
        let (thumbnails, opens) = loader_tasks(options, shown);
        Loader::over(Box::new(Threaded::new("thumbnails", thumbnails)), Box::new(Threaded::new("open", opens)))
    }

    /// A loader with no thread: each job runs at `poll`, on the caller's thread.
    #[cfg(test)]
    pub fn inline(options: OpenOptions, shown: PatientShown) -> Loader {
        use crate::worker::Inline;
        let (thumbnails, opens) = loader_tasks(options, shown);
        Loader::over(Box::new(Inline::new(thumbnails)), Box::new(Inline::new(opens)))
    }

    fn over(
        thumbnails: Box<dyn Worker<Vec<(usize, VolumeSource)>, LoaderEvent>>,
        opens: Box<dyn Worker<(usize, VolumeSource), LoaderEvent>>,
    ) -> Loader {
        Loader { thumbnails, opens, thumbnailing: HashMap::new(), opening: HashMap::new(), failed: VecDeque::new() }
    }

    /// Thumbnails of `sources`, each reported under its index in the chooser.
    pub fn thumbnails(&mut self, sources: Vec<(usize, VolumeSource)>) {
        let indices = sources.iter().map(|(index, _)| *index).collect();
        let generation = self.thumbnails.send(sources);
        self.thumbnailing.insert(generation, indices);
    }

    pub fn open(&mut self, index: usize, source: VolumeSource) {
        let generation = self.opens.send((index, source));
        self.opening.insert(generation, index);
    }

    pub fn poll(&mut self) -> Option<LoaderEvent> {
        if let Some(delivery) = self.opens.poll() {
            self.opening.remove(&delivery.generation);
            return Some(delivery.output);
        }
        if let Some(delivery) = self.thumbnails.poll() {
            let reported = match &delivery.output {
                LoaderEvent::Thumbnail { index, .. } | LoaderEvent::Series { index, .. } => Some(*index),
                LoaderEvent::Opened { .. } => None,
            };
            if let Some(indices) = self.thumbnailing.get_mut(&delivery.generation) {
                indices.retain(|index| Some(*index) != reported);
                if indices.is_empty() {
                    self.thumbnailing.remove(&delivery.generation);
                }
            }
            return Some(delivery.output);
        }
        // A job whose thread could not start (or that panicked past its guard) fails every
        // index it was about, so no card and no open waits for ever.
        while let Some(generation) = self.opens.ended_silently() {
            if let Some(index) = self.opening.remove(&generation) {
                self.failed.push_back(LoaderEvent::Opened { index, result: Err(OpenError::NoThread) });
            }
        }
        while let Some(generation) = self.thumbnails.ended_silently() {
            for index in self.thumbnailing.remove(&generation).unwrap_or_default() {
                self.failed.push_back(LoaderEvent::Thumbnail { index, result: Err(OpenError::NoThread) });
            }
        }
        self.failed.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_data_folder_lists_volumes_after_the_demo_and_skips_other_files() {
        let folder = tempfile::tempdir().unwrap();
        for name in ["b.nrrd", "a.nii.gz", "notes.txt", ".hidden.nrrd", "head.mhd", "head.raw", "ct_8x8x8_uint8.raw"] {
            std::fs::write(folder.path().join(name), b"x").unwrap();
        }
        std::fs::create_dir(folder.path().join("series")).unwrap();
        for reserved in RESERVED_FOLDERS {
            std::fs::create_dir(folder.path().join(reserved)).unwrap();
        }
        std::fs::write(folder.path().join("settings.toml"), b"mode = \"demo\"\n").unwrap();
        let names: Vec<String> = scan(Some(folder.path())).iter().map(VolumeSource::name).collect();
        assert_eq!(names, ["Demo: CT foot phantom", "a.nii.gz", "b.nrrd", "ct_8x8x8_uint8.raw", "head.mhd", "series"]);
        assert_eq!(scan(Some(&folder.path().join("missing"))), vec![VolumeSource::Demo]);
    }

    #[test]
    fn volumes_copied_in_later_are_appended_after_the_known_ones() {
        let folder = tempfile::tempdir().unwrap();
        std::fs::write(folder.path().join("b.nrrd"), b"x").unwrap();
        let known = scan(Some(folder.path()));
        assert!(appeared(&known, scan(Some(folder.path()))).is_empty());
        // A name sorting before the known one still goes to the end, so indices stay valid.
        std::fs::write(folder.path().join("a.nrrd"), b"x").unwrap();
        let added = appeared(&known, scan(Some(folder.path())));
        assert_eq!(added, vec![(2, VolumeSource::Path(folder.path().join("a.nrrd")))]);
        let full: Vec<VolumeSource> =
            (0..=MAX_ENTRIES).map(|i| VolumeSource::Path(format!("{i}.nrrd").into())).collect();
        assert!(appeared(&full, scan(Some(folder.path()))).is_empty());
    }

    #[test]
    fn a_bad_file_is_a_message_not_a_panic() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("broken.nrrd");
        std::fs::write(&path, b"NRRD0004\ntype: short\ndimension: 3\nsizes: 10 10 10\nencoding: raw\n\n").unwrap();
        let error = load(&VolumeSource::Path(path), &OpenOptions::default(), PatientShown::Hidden).err().unwrap();
        assert!(matches!(error, OpenError::Volume(_)), "{error}");
        assert!(!error.to_string().is_empty());
    }

    #[test]
    fn reasons_for_display_drop_the_path_the_card_already_names() {
        let source = VolumeSource::Path("/data/empty.nii".into());
        let reason = |message: &str| reason_for_display(message, &source);
        assert_eq!(
            reason("0 bytes of voxel data (truncated), in /data/empty.nii"),
            "0 bytes of voxel data (truncated)"
        );
        assert_eq!(reason("cannot read: /data/empty.nii"), "cannot read");
        assert_eq!(reason("unreadable DICOM file in /data/empty.nii"), "unreadable DICOM file");
        assert_eq!(reason("bad header in /data/other.nii"), "bad header in /data/other.nii");
        assert_eq!(reason(""), "unknown error");
    }

    #[test]
    fn a_panicking_reader_is_an_error_and_the_thumbnail_worker_goes_on() {
        let source = VolumeSource::Path("hostile.nrrd".into());
        let error = guarded(&source, || -> Result<(), OpenError> { panic!("byte skip overflows") }).unwrap_err();
        assert_eq!(error.to_string(), "the reader failed on this file (byte skip overflows)");
        let error = guarded(&source, || -> Result<(), OpenError> { panic!("{} voxels", 7) }).unwrap_err();
        assert!(error.to_string().contains("7 voxels"), "{error}");
        assert_eq!(guarded(&source, || Ok(3)).ok(), Some(3));

        // Files that fail, then the demo: every thumbnail is reported, in order.
        let folder = tempfile::tempdir().unwrap();
        let empty = folder.path().join("empty.nii");
        std::fs::write(&empty, b"").unwrap();
        let mut loader = Loader::new(
            OpenOptions { cache_dir: Some(folder.path().join("cache")), ..Default::default() },
            PatientShown::Hidden,
        );
        loader.thumbnails(vec![(1, VolumeSource::Path(empty)), (0, VolumeSource::Demo)]);
        let mut reported = Vec::new();
        let started = std::time::Instant::now();
        while reported.len() < 2 && started.elapsed().as_secs() < 60 {
            match loader.poll() {
                Some(LoaderEvent::Thumbnail { index, result }) => reported.push((index, result.is_ok())),
                Some(LoaderEvent::Opened { .. }) => panic!("nothing was opened"),
                Some(LoaderEvent::Series { .. }) => panic!("no folder was listed"),
                None => std::thread::sleep(std::time::Duration::from_millis(10)),
            }
        }
        assert_eq!(reported, [(1, false), (0, true)]);
    }

    #[test]
    fn the_demo_loads_with_a_thumbnail() {
        let loaded = load(&VolumeSource::Demo, &OpenOptions::default(), PatientShown::Shown).unwrap();
        let Thumbnail { image, detail, title, patient } = thumbnail(&loaded).unwrap();
        assert_eq!((title, patient.as_str()), (None, "No patient data (not a DICOM scan)"));
        assert!(image.width <= THUMBNAIL_SIDE && image.height <= THUMBNAIL_SIDE);
        assert_eq!(image.pixels.len(), image.width * image.height * 3);
        assert!(detail.starts_with("192 x 128 x 96"), "{detail}");
        assert_eq!(VolumeSource::from_key(&VolumeSource::Demo.key()), VolumeSource::Demo);
    }
}
