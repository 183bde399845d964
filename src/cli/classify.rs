//! `volasso classify VOLUME --strokes S.json --out LABELS.nrrd [--rgba RGBA.nrrd]`: the paper's
//! pipeline on the command line. Beside the labels it writes `LABELS.classes.json`, the
//! per-class colour table (§3.5, `transfer::ClassTable`). Prints one JSON line (`interfaces.md`); writes the label volume only when the
//! whole result is valid, through a temporary file and a rename.
//!
//! Timings in the JSON: `load` opens the volume and rasterises the lassos; `features` computes
//! and standardises the training voxels' features; `train` fits the classifier; `predict`
//! classifies the volume, including the features of every voxel it evaluates (they are
//! computed on the fly, slab by slab, never stored); `total` is their sum (writing the label
//! file is not timed). With `--repeat N` each is the median over N runs: the benchmark of
//! issue 3 (`benches/README.md`).

use super::CliError;
use super::args::{ClassifierChoice, ClassifyArgs};
use crate::classify::ForestParams;
use crate::classify::{Kernel, SnSvmParams};
use crate::features::{FeatureSet, FeatureSlabReader, Standardiser};
use crate::segmentation::{self, ClassifierKind, KernelWidth, LabelVolume, Refinement, SegmentationOptions, Segmenter};
use crate::strokes::{StrokesFile, TrainingSet};
use crate::transfer::{self, ClassTable, HueTemplate, class_table_path};
use crate::volume::{ByteOrder, Volume, VoxelType, nrrd};
use serde_json::json;
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

pub fn run(args: &ClassifyArgs) -> Result<(), CliError> {
    let total = Instant::now();
    let volume = super::open_volume(&args.volume, &args.open)?;
    let strokes = StrokesFile::read_for_volume(&args.strokes, volume.dims)?;
    let training = TrainingSet::from_strokes(&strokes, volume.dims).map_err(|e| e.with_path(&args.strokes))?;
    if training.contested_voxels > 0 {
        log::warn!("{} voxels were lassoed for two classes and are not used", training.contested_voxels);
    }
    // A property of the volume, computed once when it is opened (as the app does), not on
    // every training: it belongs to the load time.
    volume.otsu_threshold();
    let load_seconds = total.elapsed().as_secs_f64();

    let options = segmentation_options(args);
    let mut runs = Vec::new();
    let mut result = None;
    for _ in 0..args.repeat {
        let segmenter = segmentation::train(&volume, &training, &options)?;
        let predict_started = Instant::now();
        let cancel = AtomicBool::new(false);
        let labels = segmentation::label_volume(&volume, &segmenter, options.refinement, &|_| {}, &cancel)?;
        let predict_seconds = predict_started.elapsed().as_secs_f64();
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
    let class_count = strokes.classes.len();
    let table = ClassTable::compute(&volume, &labels.labels, class_count, HueTemplate::default_for(class_count))?;
    let rgba = match &args.rgba {
        Some(_) => Some(transfer::rgba_volume(&volume, &labels.labels, &table.styles)?),
        None => None,
    };
    // Every output is complete before the first is written.
    let comment = format!("volasso labels of {} from {}", volume.source.display(), args.strokes.display());
    nrrd::write(&args.out, labels.dims, volume.spacing_mm, VoxelType::U8, ByteOrder::Little, &labels.labels, &comment)?;
    table.write(&class_table_path(&args.out))?;
    if let (Some(path), Some(rgba)) = (&args.rgba, &rgba) {
        transfer::write_rgba_nrrd(path, volume.dims, volume.spacing_mm, rgba, &comment)?;
    }
    let total_seconds = load_seconds + features_seconds + train_seconds + predict_seconds;

    let summary = &segmenter.summary;
    let report = segmenter.report();
    let line = json!({
        "voxels": volume.voxel_count(),
        "classified_voxels": labels.classified_voxels,
        "evaluated_voxels": labels.evaluated_voxels,
        "classes": strokes.classes.iter().map(|c| c.name.as_str()).collect::<Vec<_>>(),
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
    if let Some(folder) = &args.export_features {
        export_features(folder, &volume, &segmenter, &training, &options, &labels, &line)?;
    }
    println!("{line}");
    Ok(())
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
        Some(ClassifierChoice::Forest) => (ClassifierKind::Forest(ForestParams::default()), defaults.feature_set),
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
