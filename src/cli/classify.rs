//! `volasso classify VOLUME --strokes S.json --out LABELS.nrrd [--rgba RGBA.nrrd]`: the paper's
//! pipeline on the command line. Beside the labels it writes `LABELS.classes.json`, the
//! per-class colour table (§3.5, `transfer::ClassTable`). Prints one JSON line (`interfaces.md`).
//!
//! The outputs are written as one unit, and only when the whole result is valid: each goes to
//! a temporary file beside its target first (the RGBA volume streamed, never held whole), and
//! only then are they renamed, the RGBA volume first and the label volume last. A reader that
//! sees new labels can trust the class table beside them is new too; a kill at any moment
//! leaves each file old or whole, and the next run removes the temporaries the killed one left
//! (`atomic_file::remove_stale_temporaries`). Every output names its run: the NRRD headers
//! carry a `# volasso run RUN` line and the class table a `"run": "RUN"` field, where RUN is
//! `NANOSECONDS-PID` (nanoseconds since 1970, so later runs sort after earlier ones).
//!
//! Timings in the JSON: `load` opens the volume and rasterises the lassos; `features` computes
//! and standardises the training voxels' features; `train` fits the classifier; `predict`
//! classifies the volume, including the features of every voxel it evaluates (they are
//! computed on the fly, slab by slab, never stored); `total` is their sum (writing the label
//! file is not timed). With `--repeat N` each is the median over N runs: the classification
//! benchmark (`benches/RESULTS.md`).

use super::args::{ClassifierChoice, ClassifyArgs, CoherenceChoice};
use super::{CliError, outputs};
use crate::atomic_file::{commit_in_order, remove_stale_temporaries, stage};
use crate::classify::ForestParams;
use crate::classify::{Kernel, SnSvmParams};
use crate::features::{FeatureSet, FeatureSlabReader, Standardiser};
use crate::pipeline::{self, MAX_PAIRWISE_CLASSES, RunControl};
use crate::preset::Preset;
use crate::segmentation::{
    self, ClassifierKind, Coherence, KernelWidth, LabelVolume, Refinement, SegmentationOptions, Segmenter,
};
use crate::strokes::{StrokesFile, TrainingSet};
use crate::transfer::{self, ClassTable, HueTemplate, TransferError, class_table_path};
use crate::volume::{ByteOrder, Volume, VoxelType, nrrd};
use serde_json::json;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

pub fn run(args: &ClassifyArgs) -> Result<(), CliError> {
    let total = Instant::now();
    let table_path = class_table_path(&args.out);
    let export_paths: Vec<std::path::PathBuf> =
        args.export_features.iter().flat_map(|folder| EXPORTED.map(|name| folder.join(name))).collect();
    let mut outputs: Vec<(&'static str, &Path)> =
        vec![("label volume (--out)", &args.out), ("class table written beside --out", &table_path)];
    if let Some(rgba) = &args.rgba {
        outputs.push(("RGBA volume (--rgba)", rgba));
    }
    if let Some(preset) = &args.save_preset {
        outputs.push(("preset (--save-preset)", preset));
    }
    outputs.extend(export_paths.iter().map(|path| ("feature export (--export-features)", path.as_path())));
    let mut inputs: Vec<(&'static str, &Path)> = vec![("volume", &args.volume)];
    inputs.extend(args.strokes.as_deref().map(|path| ("strokes file (--strokes)", path)));
    inputs.extend(args.preset.as_deref().map(|path| ("preset (--preset)", path)));
    outputs::check(&inputs, &outputs)?;
    if args.export_features.is_some() && args.preset.is_some() {
        return Err(CliError::Usage("--export-features needs loops only: it cannot be given with --preset".into()));
    }
    let preset = args.preset.as_deref().map(Preset::read).transpose()?;
    remove_stale_outputs(args);
    let volume = super::open_volume(&args.volume, &args.open)?;
    outputs::check_mapped("volume's voxel data", &outputs)?;
    let modality = args.scan.modality(&args.volume, &args.open);
    if let Some(preset) = &preset {
        preset.check_scan(&volume, modality)?;
    }
    let strokes_path = args.strokes.clone().unwrap_or_default();
    let strokes = args.strokes.as_deref().map(|path| StrokesFile::read_for_volume(path, volume.dims)).transpose()?;
    let training = strokes
        .as_ref()
        .map(|strokes| TrainingSet::from_strokes(strokes, volume.dims).map_err(|e| e.with_path(&strokes_path)))
        .transpose()?;
    if let Some(training) = training.as_ref().filter(|training| training.contested_voxels > 0) {
        log::warn!("{} voxels were lassoed for two classes and are not used", training.contested_voxels);
    }
    // Properties of the volume, computed once when it is opened (as the app does), not on
    // every training: they belong to the load time.
    volume.otsu_threshold();
    volume.body();
    let load_seconds = total.elapsed().as_secs_f64();

    let mut class_names: Vec<String> = match (&preset, &strokes) {
        (Some(preset), Some(strokes)) => {
            let drawn: Vec<String> = strokes.classes.iter().map(|class| class.name.clone()).collect();
            crate::preset::joined_classes(&preset.class_names(), &drawn).0
        }
        (Some(preset), None) => preset.class_names(),
        (None, Some(strokes)) => strokes.classes.iter().map(|class| class.name.clone()).collect(),
        (None, None) => return Err(CliError::Usage("give --strokes, --preset or both".into())),
    };
    let class_count = class_names.len();
    let mut options = segmentation_options(args);
    if let Some(preset) = &preset {
        options.feature_set = preset.feature_set().unwrap_or(options.feature_set);
    }
    let mut fallback = None;
    if let Some(forest) = pipeline::forest_fallback(&options, class_count) {
        if let Some(choice) = args.classifier {
            return Err(CliError::Usage(format!(
                "{class_count} classes are more than the {MAX_PAIRWISE_CLASSES} the {} classifies (one model per pair of classes); use --classifier forest",
                if choice == ClassifierChoice::Svm { "SVM" } else { "SN-SVM" },
            )));
        }
        let reason = format!(
            "{class_count} classes: more than the {MAX_PAIRWISE_CLASSES} the SN-SVM classifies, so the random forest classified them"
        );
        log::warn!("{reason}");
        let features = match &preset {
            Some(_) => options.feature_set,
            None => args.features.map_or(forest.feature_set, FeatureSet::from),
        };
        options = SegmentationOptions { feature_set: features, ..forest };
        fallback = Some(reason);
    }
    options.correct_shading = args.scan.corrects_shading(modality);
    if let (Some(training), None) = (&training, &preset) {
        pipeline::check_training(&volume, training, &options)
            .map_err(|error| super::pipeline_error(error, &strokes_path))?;
    }
    let mut runs = Vec::new();
    let mut result = None;
    for _ in 0..args.repeat {
        let started = Instant::now();
        let (segmenter, labels) = match (&preset, &training) {
            (Some(preset), training) => {
                let (samples, names) = pipeline::preset_samples(&volume, preset, modality, training.as_ref(), &options)
                    .map_err(|error| super::pipeline_error(error, &strokes_path))?;
                class_names = names;
                let again = |scan: &Volume| {
                    pipeline::preset_samples(scan, preset, modality, training.as_ref(), &options)
                        .map(|(samples, _)| samples)
                };
                pipeline::classify_shaded(&volume, samples, again, &options, RunControl::batch())
                    .map_err(|error| super::pipeline_error(error, &strokes_path))?
            }
            (None, Some(training)) => pipeline::classify_training(&volume, training, &options, RunControl::batch())?,
            (None, None) => unreachable!("checked above"),
        };
        // Labelling is what the run took beyond computing the training features and training.
        let predict_seconds =
            (started.elapsed().as_secs_f64() - segmenter.summary.features_seconds - segmenter.summary.train_seconds)
                .max(0.0);
        runs.push([segmenter.summary.features_seconds, segmenter.summary.train_seconds, predict_seconds]);
        result = Some((segmenter, labels));
    }
    let Some((segmenter, labels)) = result else {
        return Err(CliError::Usage("--repeat must be at least 1".into()));
    };
    if segmenter.report().is_some_and(|r| r.hit_cap()) {
        log::warn!("the SVM solver hit its iteration cap; the result may be less accurate");
    }
    let median = |k: usize| {
        let mut values: Vec<f64> = runs.iter().map(|r| r[k]).collect();
        values.sort_by(f64::total_cmp);
        values[values.len() / 2]
    };
    let (features_seconds, train_seconds, predict_seconds) = (median(0), median(1), median(2));

    // Colours (§3.5): the class table is kept beside the labels, so the renderer can classify
    // after interpolation and restyle without classifying again.
    let template = preset.as_ref().map_or_else(|| HueTemplate::default_for(class_count), |preset| preset.template);
    let mut table = ClassTable::compute(&volume, &labels.labels, class_count, template)?;
    if let Some(preset) = &preset {
        preset.restyle(&mut table);
    }
    let run = run_id();
    let trained_from: Vec<String> =
        args.strokes.iter().chain(&args.preset).map(|path| path.display().to_string()).collect();
    let comment =
        format!("volasso labels of {} from {}\nvolasso run {run}", volume.source.display(), trained_from.join(" and "));
    // Every output is staged (written whole beside its target) before the first is renamed.
    fn output(path: &Path) -> impl FnOnce(std::io::Error) -> CliError + '_ {
        move |source| CliError::Output { source, path: path.to_path_buf() }
    }
    let header = nrrd::header_text(
        labels.dims,
        volume.spacing_mm,
        volume.orientation.as_ref(),
        VoxelType::U8,
        ByteOrder::Little,
        &comment,
    );
    let staged_labels = stage(&args.out, |file| {
        file.write_all(header.as_bytes())?;
        file.write_all(&labels.labels)
    })
    .map_err(output(&args.out))?;
    let class_names: Vec<&str> = class_names.iter().map(String::as_str).collect();
    let table_text = serde_json::to_string_pretty(&TableOfRun { table: &table, classes: &class_names, run: &run })
        .map_err(|source| TransferError::TableJson { source, path: table_path.clone() })?;
    let staged_table = stage(&table_path, |file| file.write_all(table_text.as_bytes())).map_err(output(&table_path))?;
    let mut staged = Vec::new();
    if let Some(path) = &args.rgba {
        staged.push(transfer::stage_rgba_nrrd(path, &volume, &labels.labels, &table.styles, &comment)?);
    }
    let saved_preset = match &args.save_preset {
        Some(path) => {
            let name = path.file_stem().map_or_else(|| "preset".into(), |stem| stem.to_string_lossy().to_string());
            let names: Vec<String> = class_names.iter().map(|name| name.to_string()).collect();
            let saved = Preset::of(&name, &segmenter, &volume, modality, &names, &table)?;
            let text = saved.to_json().map_err(output(path))?;
            staged.push(stage(path, |file| file.write_all(text.as_bytes())).map_err(output(path))?);
            Some(saved)
        }
        None => None,
    };
    staged.extend([staged_table, staged_labels]);
    commit_in_order(staged).map_err(|(source, path)| CliError::Output { source, path })?;
    let total_seconds = load_seconds + features_seconds + train_seconds + predict_seconds;

    let summary = &segmenter.summary;
    let report = segmenter.report();
    let line = json!({
        "voxels": volume.voxel_count(),
        "classified_voxels": labels.classified_voxels,
        "evaluated_voxels": labels.evaluated_voxels,
        "classes": class_names,
        "modality": modality.name(),
        "shading_divided_out": segmenter.corrected_scan.is_some(),
        "preset": preset.as_ref().map(|preset| json!({
            "name": preset.name,
            "path": args.preset.as_ref().map(|path| path.display().to_string()),
            "modality": preset.modality.name(),
            "training_vectors": preset.samples.len(),
        })),
        "saved_preset": saved_preset.as_ref().map(|saved| json!({
            "name": saved.name,
            "path": args.save_preset.as_ref().map(|path| path.display().to_string()),
            "scale": saved.scale,
            "training_vectors": saved.samples.len(),
        })),
        "training_voxels": summary.used_per_class,
        "training_voxels_dropped_by_cap": summary.dropped_per_class,
        "training_cap_per_class": summary.cap_per_class,
        "contested_voxels": summary.contested_voxels,
        "background_threshold": summary.background_threshold,
        "classifier": match summary.classifier_kind {
            ClassifierKind::SnSvm if summary.classifier.eta == 0.0 => "svm",
            ClassifierKind::SnSvm => "snsvm",
            ClassifierKind::Forest(_) => "forest",
        },
        "classifier_fallback": fallback,
        "features": segmenter.feature_set.name(),
        "refinement": match options.refinement { Refinement::Exact => "exact", Refinement::CoarseToFine => "coarse-to-fine" },
        "parameters": parameters_json(&summary.classifier),
        "support_vectors": report.map(|r| r.pairs.iter().map(|p| p.support_vectors).sum::<usize>()),
        // The kernel terms per evaluated voxel after merging and pruning (SN-SVM's γ is dense).
        "expansion_points": report.map(|r| r.expansion_points),
        "solver_hit_iteration_cap": report.map(|r| r.hit_cap()),
        "seconds": {
            "load": load_seconds,
            "features": features_seconds,
            "train": train_seconds,
            "predict": predict_seconds,
            "total": total_seconds,
        },
        "repeats": args.repeat,
    });
    if let (Some(folder), Some(training)) = (&args.export_features, &training) {
        export_features(folder, segmenter.scan(&volume), &segmenter, training, &options, &labels, &line)?;
    }
    println!("{line}");
    Ok(())
}

/// The files `--export-features DIR` writes into DIR.
const EXPORTED: [&str; 5] =
    ["train_features.npy", "train_labels.npy", "predict_features.npy", "volasso_labels.npy", "volasso.json"];

/// The class table as written beside the labels: its fields, the class names (in id order:
/// `volasso export` names the segments after them), then the run that wrote it.
#[derive(serde::Serialize)]
struct TableOfRun<'a> {
    #[serde(flatten)]
    table: &'a ClassTable,
    classes: &'a [&'a str],
    run: &'a str,
}

/// `NANOSECONDS-PID`: when this run started its outputs, and which process it is.
fn run_id() -> String {
    let nanoseconds = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
    format!("{nanoseconds}-{}", std::process::id())
}

/// Removes what killed runs left beside this run's outputs (temporaries of dead processes).
fn remove_stale_outputs(args: &ClassifyArgs) {
    let outputs = [Some(args.out.clone()), Some(class_table_path(&args.out)), args.rgba.clone()];
    for path in outputs.iter().flatten() {
        for removed in remove_stale_temporaries(path) {
            log::info!("removed {}, left by a run that was stopped", removed.display());
        }
    }
}

pub(super) fn segmentation_options(args: &ClassifyArgs) -> SegmentationOptions {
    let defaults = SegmentationOptions::default();
    let mut classifier = match args.classifier {
        Some(ClassifierChoice::Svm) => SnSvmParams::plain_svm(),
        _ => SnSvmParams::default(),
    };
    let (classifier_kind, default_features) = match args.classifier {
        None => (defaults.classifier_kind, defaults.feature_set),
        Some(ClassifierChoice::Snsvm | ClassifierChoice::Svm) => (ClassifierKind::SnSvm, FeatureSet::Paper5),
        Some(ClassifierChoice::Forest) => (ClassifierKind::Forest(ForestParams::default()), FeatureSet::MultiscaleFine),
    };
    let classifier_kind = match (classifier_kind, args.trees) {
        (ClassifierKind::Forest(params), Some(trees)) => {
            ClassifierKind::Forest(ForestParams { tree_count: trees as usize, ..params })
        }
        (kind, _) => kind,
    };
    let mut kernel_width = KernelWidth::Automatic;
    if let Some(width) = args.kernel_width {
        classifier.kernel = Kernel::Rbf { width };
        kernel_width = KernelWidth::AsGiven;
    }
    if let Some(c) = args.c {
        classifier.c = c;
    }
    if let (Some(eta), Some(ClassifierChoice::Snsvm)) = (args.eta, args.classifier) {
        classifier.eta = eta;
    }
    SegmentationOptions {
        feature_set: args.features.map_or(default_features, FeatureSet::from),
        classifier_kind,
        classifier,
        kernel_width,
        max_training_per_class: args.cap,
        background: args.background,
        refinement: if args.exact { Refinement::Exact } else { Refinement::CoarseToFine },
        coherence: match args.coherence {
            CoherenceChoice::None => Coherence::None,
            CoherenceChoice::Majority => Coherence::Majority,
            CoherenceChoice::Potts => Coherence::Potts,
        },
        ..defaults
    }
}

fn parameters_json(params: &SnSvmParams) -> serde_json::Value {
    let kernel_width = match params.kernel {
        Kernel::Rbf { width } => width,
        Kernel::Polynomial { .. } => f64::NAN,
    };
    json!({
        "kernel_width": kernel_width,
        "c": params.c,
        "eta": params.eta,
        "kappa": params.kappa,
        "beta_relative": params.beta_relative,
    })
}

/// Writes the `.npy` files `scripts/compare_sklearn.py` reads (see its doc).
fn export_features(
    folder: &Path,
    volume: &Volume,
    segmenter: &Segmenter,
    training: &TrainingSet,
    options: &SegmentationOptions,
    labels: &LabelVolume,
    line: &serde_json::Value,
) -> Result<(), CliError> {
    let output = |source: std::io::Error, name: &str| CliError::Output { source, path: folder.join(name) };
    std::fs::create_dir_all(folder).map_err(|e| output(e, ""))?;
    let dim = segmenter.feature_set.dim();
    let capped = training.capped(options.max_training_per_class, options.seed);
    let (voxels, classes) = capped.labelled_voxels();
    let mut train = crate::features::features_of_voxels(volume, segmenter.feature_set, &voxels)
        .map_err(segmentation::SegmentationError::from)?;
    standardise(&segmenter.standardiser, &mut train)?;
    super::npy::write(&folder.join("train_features.npy"), &[voxels.len(), dim], &train)
        .map_err(|e| output(e, "train_features.npy"))?;
    super::npy::write(&folder.join("train_labels.npy"), &[classes.len()], &classes)
        .map_err(|e| output(e, "train_labels.npy"))?;

    let threshold = segmenter.summary.background_threshold.unwrap_or(f64::NEG_INFINITY) as f32;
    let plane = volume.dims[0] * volume.dims[1];
    let mut reader = FeatureSlabReader::new(volume, segmenter.feature_set);
    let (mut features, mut predicted, mut block, mut values) = (Vec::new(), Vec::new(), Vec::new(), vec![0f32; plane]);
    for z in 0..volume.dims[2] {
        volume.read_z_slice_f32(z, &mut values);
        let selected: Vec<usize> = (0..plane).filter(|&i| values[i] >= threshold).collect();
        reader.compute_selected(z, &selected, &mut block).map_err(segmentation::SegmentationError::from)?;
        standardise(&segmenter.standardiser, &mut block)?;
        features.extend_from_slice(&block);
        predicted.extend(selected.iter().map(|&i| labels.labels[z * plane + i]));
    }
    super::npy::write(&folder.join("predict_features.npy"), &[predicted.len(), dim], &features)
        .map_err(|e| output(e, "predict_features.npy"))?;
    super::npy::write(&folder.join("volasso_labels.npy"), &[predicted.len()], &predicted)
        .map_err(|e| output(e, "volasso_labels.npy"))?;
    crate::atomic_file::write_atomically(&folder.join("volasso.json"), |file| {
        std::io::Write::write_all(file, line.to_string().as_bytes())
    })
    .map_err(|e| output(e, "volasso.json"))
}

fn standardise(standardiser: &Standardiser, block: &mut [f32]) -> Result<(), CliError> {
    standardiser.apply_in_place(block).map_err(|e| CliError::Segmentation(e.into()))
}
