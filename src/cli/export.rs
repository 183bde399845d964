//! `volasso export SERIES --labels LABELS.nrrd --seg SEG.dcm [--sc SC.dcm]`: a classification
//! of a DICOM series as a DICOM Segmentation, and optionally the 3-D view (rendered headless as
//! `render` does, or a PNG given with `--sc-image`) as a Secondary Capture, each a new series
//! of the series' study ([`crate::dicom_out`]). The class names and colours come from the
//! class table `classify` wrote beside the labels. Prints one JSON line.
//!
//! Checks before anything is written: the series is DICOM and one file per slice, the labels
//! are uint8 with the series' dimensions, and the class table describes these labels (a class
//! name per style, no label beyond the table, the voxel counts of an unclipped table equal to
//! the labels', the same `run` as the labels' header when both name one). The objects are
//! staged whole and renamed together, the Segmentation last.
//!
//! Never: writes over an input or into the series' folder, or writes one object of the pair
//! without the other.

use super::CliError;
use super::args::{VolumeArgs, parse_render_size};
use crate::atomic_file::{commit_in_order, remove_stale_temporaries, stage};
use crate::dicom_out::{ExportError, Segment, SourceSeries, secondary_capture, segmentation, write_object};
use crate::render::headless::{Scene, render_to_image};
use crate::render::{Camera, RenderSettings, gpu};
use crate::transfer::{CLASS_TABLE_FORMAT, ClassStyle, class_table_path};
use crate::volume::VoxelType;
use clap::Args;
use serde_json::json;
use std::io::Read;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct ExportArgs {
    /// The DICOM series the labels were computed on (a folder, DICOMDIR or file).
    #[arg(value_name = "SERIES")]
    pub volume: PathBuf,
    #[command(flatten)]
    pub open: VolumeArgs,
    /// The label volume `volasso classify --out` wrote (its class table beside it).
    #[arg(long, value_name = "LABELS.nrrd")]
    pub labels: PathBuf,
    /// The DICOM Segmentation to write.
    #[arg(long, value_name = "SEG.dcm")]
    pub seg: PathBuf,
    /// Also write the 3-D view as a Secondary Capture image here.
    #[arg(long, value_name = "SC.dcm")]
    pub sc: Option<PathBuf>,
    /// The picture for --sc (PNG); without it the 3-D view is rendered headless.
    #[arg(long, value_name = "PNG", requires = "sc")]
    pub sc_image: Option<PathBuf>,
    /// Size of the rendered 3-D view for --sc.
    #[arg(long, default_value = "800x600", value_parser = parse_render_size, value_name = "WxH")]
    pub size: [u32; 2],
}

/// The class table as `classify` writes it: only what the export reads.
#[derive(serde::Deserialize)]
struct ClassTableFile {
    format: String,
    #[serde(default)]
    classes: Option<Vec<String>>,
    clip: Option<serde_json::Value>,
    voxel_counts: Vec<u64>,
    styles: Vec<ClassStyle>,
    #[serde(default)]
    run: Option<String>,
}

pub fn run(args: &ExportArgs) -> Result<(), CliError> {
    let table_path = class_table_path(&args.labels);
    let mut inputs: Vec<(&'static str, &Path)> =
        vec![("series", &args.volume), ("labels (--labels)", &args.labels), ("class table", &table_path)];
    if let Some(image) = &args.sc_image {
        inputs.push(("picture (--sc-image)", image));
    }
    let mut outputs: Vec<(&'static str, &Path)> = vec![("Segmentation (--seg)", &args.seg)];
    if let Some(sc) = &args.sc {
        outputs.push(("Secondary Capture (--sc)", sc));
    }
    super::outputs::check(&inputs, &outputs)?;
    for (_, output) in &outputs {
        for removed in remove_stale_temporaries(output) {
            log::info!("removed {}, left by a run that was stopped", removed.display());
        }
    }
    let source = SourceSeries::read(&args.volume, args.open.series.as_deref())?;
    let labels = crate::volume::open(&args.labels, &crate::volume::OpenOptions::default())?;
    if labels.voxel_type != VoxelType::U8 {
        return Err(ExportError::LabelType { found: labels.voxel_type.name(), path: args.labels.clone() }.into());
    }
    if labels.dims != source.dims {
        return Err(
            ExportError::LabelDims { labels: labels.dims, series: source.dims, path: args.labels.clone() }.into()
        );
    }
    let label_bytes = labels.raw_bytes();
    let table = read_table(&table_path, label_bytes, labels_run(&args.labels).as_deref())?;
    let names = table.classes.unwrap_or_default();
    let segments: Vec<Segment> =
        names.iter().zip(&table.styles).map(|(name, style)| Segment::of_class(name.clone(), style)).collect();
    let seg = segmentation(&source, label_bytes, &segments)?;
    let sc = match &args.sc {
        None => None,
        Some(path) => {
            let picture = match &args.sc_image {
                Some(image) => read_picture(image)?,
                None => render_view(args, &source, label_bytes, &table.styles)?,
            };
            Some((path, secondary_capture(&source, &picture)?))
        }
    };
    let output = |path: &Path| {
        let path = path.to_path_buf();
        move |source| CliError::Output { source, path }
    };
    let mut staged = Vec::new();
    if let Some((path, object)) = &sc {
        staged.push(stage(path, |file| write_object(object, file)).map_err(output(path))?);
    }
    staged.push(stage(&args.seg, |file| write_object(&seg, file)).map_err(output(&args.seg))?);
    commit_in_order(staged).map_err(|(source, path)| CliError::Output { source, path })?;
    let uid = |object: &dicom_object::FileDicomObject<dicom_object::InMemDicomObject>, tag| {
        object.element(tag).ok().and_then(|element| element.to_str().ok()).map(|text| text.into_owned())
    };
    use dicom_dictionary_std::tags;
    let line = json!({
        "seg": args.seg,
        "seg_series_uid": uid(&seg, tags::SERIES_INSTANCE_UID),
        "segments": segments.len(),
        "frames": uid(&seg, tags::NUMBER_OF_FRAMES).and_then(|n| n.trim().parse::<u64>().ok()),
        "sc": args.sc,
        "sc_series_uid": sc.as_ref().and_then(|(_, object)| uid(object, tags::SERIES_INSTANCE_UID)),
        "study_uid": source.text(tags::STUDY_INSTANCE_UID),
        "series_uid": source.series_uid,
    });
    println!("{line}");
    Ok(())
}

/// The `# volasso run RUN` comment of a label NRRD's header, if it has one.
fn labels_run(path: &Path) -> Option<String> {
    let mut head = Vec::new();
    std::fs::File::open(path).ok()?.take(64 * 1024).read_to_end(&mut head).ok()?;
    let text = String::from_utf8_lossy(&head);
    text.lines()
        .take_while(|line| !line.is_empty())
        .find_map(|line| line.strip_prefix("# volasso run ").map(|run| run.trim().to_string()))
}

/// Reads the class table and checks it describes `labels` (see the module doc).
fn read_table(path: &Path, labels: &[u8], labels_run: Option<&str>) -> Result<ClassTableFile, ExportError> {
    let mismatch = |problem: String| ExportError::ClassTable { problem, path: path.to_path_buf() };
    let text = std::fs::read_to_string(path).map_err(|error| mismatch(format!("it cannot be read ({error})")))?;
    let table: ClassTableFile =
        serde_json::from_str(&text).map_err(|error| mismatch(format!("it is not a class table ({error})")))?;
    if table.format != CLASS_TABLE_FORMAT {
        return Err(mismatch(format!("its format is {:?}, not {CLASS_TABLE_FORMAT:?}", table.format)));
    }
    let Some(names) = &table.classes else {
        return Err(mismatch("it names no classes (a \"classes\" list, written by volasso classify)".into()));
    };
    let count = table.styles.len();
    if names.len() != count || table.voxel_counts.len() != count || count == 0 {
        return Err(mismatch(format!(
            "{} class names, {count} styles and {} voxel counts",
            names.len(),
            table.voxel_counts.len()
        )));
    }
    let mut counts = [0u64; 256];
    for &label in labels {
        counts[usize::from(label)] += 1;
    }
    if let Some(label) = (count + 1..256).find(|&label| counts[label] > 0) {
        return Err(mismatch(format!("the labels hold class {label}, the table {count} classes")));
    }
    if table.clip.as_ref().is_none_or(serde_json::Value::is_null) && table.voxel_counts[..] != counts[1..=count] {
        return Err(mismatch(format!(
            "its voxel counts {:?} are not the labels' {:?}",
            table.voxel_counts,
            &counts[1..=count]
        )));
    }
    if let (Some(table_run), Some(labels_run)) = (&table.run, labels_run)
        && table_run != labels_run
    {
        return Err(mismatch(format!("it was written by run {table_run}, the labels by run {labels_run}")));
    }
    Ok(table)
}

/// A PNG (any colour type) as RGBA.
fn read_picture(path: &Path) -> Result<image::RgbaImage, ExportError> {
    let problem = |problem: String| ExportError::Picture { problem, path: path.to_path_buf() };
    let reader = image::ImageReader::open(path)
        .map_err(|error| problem(error.to_string()))?
        .with_guessed_format()
        .map_err(|error| problem(error.to_string()))?;
    let mut reader = reader;
    reader.limits(image::Limits::default());
    Ok(reader.decode().map_err(|error| problem(error.to_string()))?.to_rgba8())
}

/// The 3-D view of the labels, rendered headless as `render` draws it.
fn render_view(
    args: &ExportArgs,
    source: &SourceSeries,
    labels: &[u8],
    styles: &[ClassStyle],
) -> Result<image::RgbaImage, CliError> {
    let mut options = args.open.open_options();
    options.dicom.series_uid = Some(source.series_uid.clone());
    options.dicom.resample = crate::volume::dicom::Resample::Refuse;
    let volume = crate::volume::open(&args.volume, &options)?;
    let gpu = gpu::acquire()?;
    let scene = Scene { volume: &volume, labels, class_styles: styles, rgba: None };
    Ok(render_to_image(&gpu.device, &gpu.queue, &scene, &Camera::default(), &RenderSettings::default(), args.size)?)
}
