//! The pipeline in one call: training voxels per class, trained and applied to the whole
//! volume (§3.3-3.4), then coloured (§3.5). The command line (`classify`, `render`), the
//! kiosk's classification worker and the accuracy harness all run it through here, so a
//! change to the method reaches every one of them.
//!
//! [`classify_training`] takes a training set (from a strokes file, or drawn by the accuracy
//! harness' simulated user) and gives the trained model and the label volume (an MR scan's
//! shading divided out after the first look, `crate::volume::shading`);
//! [`classify_strokes`] starts from a strokes file and adds the class table;
//! [`classify_array`] is the same for a program that holds its scan and its scribbles as
//! `ndarray` arrays.
//!
//! Never: reads or writes files, or knows who called it (UI, CLI or harness).

use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use ndarray::{Array3, ArrayView3};

use crate::classify::Inseparable;
use crate::preset::{self, Modality, Preset, PresetError};
use crate::segmentation::{
    self, ClassifierKind, LabelVolume, SegmentationError, SegmentationOptions, Segmenter, TrainingSamples,
};
use crate::strokes::{ClassSamples, StrokesError, StrokesFile, TrainingSet};
use crate::transfer::{ClassTable, HueTemplate, TransferError};
use crate::volume::shading::Shading;
use crate::volume::{Volume, VolumeError};

/// Why the pipeline stopped; each variant keeps the stage's own error.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// The strokes do not make a training set (no class, a class without voxels...).
    #[error(transparent)]
    Strokes(#[from] StrokesError),
    /// Training or labelling failed, or was cancelled.
    #[error(transparent)]
    Segmentation(#[from] SegmentationError),
    /// The class table could not be computed.
    #[error(transparent)]
    Transfer(#[from] TransferError),
    /// The array could not be made into a volume (empty, bad spacing).
    #[error(transparent)]
    Volume(#[from] VolumeError),
    /// The preset does not fit the scan.
    #[error(transparent)]
    Preset(#[from] PresetError),
    /// The training set cannot teach the classifier anything ([`check_training`]).
    #[error(transparent)]
    Training(#[from] TrainingError),
    /// The scribbles array has another shape than the intensities.
    #[error("the scribbles are {scribbles:?} voxels (z, y, x) but the volume is {volume:?}")]
    ScribbleShape {
        /// Shape of the scribbles array.
        scribbles: (usize, usize, usize),
        /// Shape of the intensity array.
        volume: (usize, usize, usize),
    },
}

/// Classes the SN-SVM classifies at most: it trains one binary SN-SVM per pair of classes and
/// asks them at every voxel, so its work grows with the square of the classes. 32 classes are
/// 496 pairs, trained and applied in seconds; 128 classes (8,128 pairs) took 152 s and 255
/// (32,385 pairs) ran for many minutes, while the random forest labels 255 classes in under a
/// second. More classes than this go to the forest ([`forest_fallback`]).
pub const MAX_PAIRWISE_CLASSES: usize = 32;

/// For `class_count` classes, more than [`MAX_PAIRWISE_CLASSES`], where `options` train the
/// SN-SVM: the random forest on its own features, the seed and everything else as in
/// `options`. `None` where `options` stand.
pub fn forest_fallback(options: &SegmentationOptions, class_count: usize) -> Option<SegmentationOptions> {
    if class_count <= MAX_PAIRWISE_CLASSES || options.classifier_kind != ClassifierKind::SnSvm {
        return None;
    }
    let forest = SegmentationOptions::forest();
    Some(SegmentationOptions {
        feature_set: forest.feature_set,
        classifier_kind: forest.classifier_kind,
        ..options.clone()
    })
}

/// Why the training voxels cannot train a classifier, found by [`check_training`] before any
/// training: each names the class and, where one voxel is at fault, the voxel (x, y, z).
#[derive(Debug, thiserror::Error)]
pub enum TrainingError {
    /// A lassoed voxel is NaN or infinite.
    #[error(
        "voxel ({}, {}, {}) of class '{class}' is {value:?}: NaN or infinite voxels cannot be trained on (draw the loop around valid voxels)",
        voxel[0], voxel[1], voxel[2]
    )]
    NonFiniteVoxel {
        /// The class whose lassos select it.
        class: String,
        /// The voxel.
        voxel: [usize; 3],
        /// Its value.
        value: f32,
    },
    /// A feature of a finite voxel overflows f32.
    #[error(
        "the {feature} of voxel ({}, {}, {}) of class '{class}' (value {value:?}) is not a finite number: values this large, or a spacing this small ({:?} x {:?} x {:?} mm), overflow single precision",
        voxel[0], voxel[1], voxel[2], spacing_mm[0], spacing_mm[1], spacing_mm[2]
    )]
    FeatureOverflow {
        /// The class whose lassos select the voxel.
        class: String,
        /// The voxel.
        voxel: [usize; 3],
        /// Its value.
        value: f32,
        /// The feature's name ([`crate::features::FeatureSet::names`]).
        feature: &'static str,
        /// The volume's spacing.
        spacing_mm: [f64; 3],
    },
    /// Every lassoed voxel has the same features.
    #[error(
        "the classes cannot be told apart: every voxel the lassos select has the same features (value {value:?}); is the volume constant?"
    )]
    AllEqual {
        /// The value of the voxels.
        value: f32,
    },
    /// Two classes' voxels all have one and the same features.
    #[error(
        "classes '{first}' and '{second}' cannot be told apart: every voxel their lassos select has the same features (value {value:?})"
    )]
    SameFeatures {
        /// The first class's name.
        first: String,
        /// The second class's name.
        second: String,
        /// The value of their voxels.
        value: f32,
    },
}

/// Refuses a training set that cannot teach a classifier anything, before any training: a
/// lassoed voxel that is NaN or infinite (any of them), a feature that overflows f32 (values
/// near the float range's limit, a spacing of 10^-30 mm), or classes that cannot be told apart
/// ([`crate::classify::find_inseparable`]: a constant volume, two classes drawn on one flat
/// material). The features are those of the voxels `options`' cap keeps, as training takes
/// them.
pub fn check_training(
    volume: &Volume,
    training: &TrainingSet,
    options: &SegmentationOptions,
) -> Result<(), PipelineError> {
    let position = |voxel: usize| {
        let [nx, ny, _] = volume.dims;
        [voxel % nx, (voxel / nx) % ny, voxel / (nx * ny)]
    };
    // Voxel values are f32 when read for features; the f64 of `Volume::value` holds them exactly.
    let value_of = |voxel: usize| volume.value(voxel) as f32;
    for class in &training.classes {
        if let Some(&voxel) = class.voxels.iter().find(|&&voxel| !value_of(voxel).is_finite()) {
            let value = value_of(voxel);
            return Err(
                TrainingError::NonFiniteVoxel { class: class.name.clone(), voxel: position(voxel), value }.into()
            );
        }
    }
    let capped = training.capped(options.max_training_per_class, options.seed);
    let (voxels, labels) = capped.labelled_voxels();
    let dim = options.feature_set.dim();
    let features =
        crate::features::features_of_voxels(volume, options.feature_set, &voxels).map_err(SegmentationError::from)?;
    let class_name = |id: u8| capped.classes[id as usize - 1].name.clone();
    let error = match crate::classify::find_inseparable(&features, dim, &labels) {
        None => return Ok(()),
        Some(Inseparable::NotFinite { sample, feature }) => TrainingError::FeatureOverflow {
            class: class_name(labels[sample]),
            voxel: position(voxels[sample]),
            value: value_of(voxels[sample]),
            feature: options.feature_set.names().get(feature).copied().unwrap_or("feature"),
            spacing_mm: volume.spacing_mm,
        },
        Some(Inseparable::AllEqual) => TrainingError::AllEqual { value: value_of(voxels[0]) },
        Some(Inseparable::SameVectors { first, second }) => {
            let sample = labels.iter().position(|&label| label == first).unwrap_or(0);
            TrainingError::SameFeatures {
                first: class_name(first),
                second: class_name(second),
                value: value_of(voxels[sample]),
            }
        }
    };
    Err(error.into())
}

/// How a long run reports and stops: `progress` gets the fraction of labelling done (0..=1,
/// from worker threads); setting `cancel` stops at the next slab with
/// [`SegmentationError::Cancelled`].
#[derive(Clone, Copy)]
pub struct RunControl<'a> {
    /// Called with the fraction of the labelling done.
    pub progress: &'a (dyn Fn(f32) + Sync),
    /// Set to stop the run.
    pub cancel: &'a AtomicBool,
    /// Called once with a first, coarse label volume before the exact one is computed
    /// ([`segmentation::label_volume_with_preview`]): what a screen shows while it waits.
    pub preview: Option<&'a (dyn Fn(&LabelVolume) + Sync)>,
}

static NEVER_CANCELLED: AtomicBool = AtomicBool::new(false);

impl RunControl<'static> {
    /// No progress reports, never cancelled: a batch run.
    pub fn batch() -> RunControl<'static> {
        RunControl { progress: &|_| {}, cancel: &NEVER_CANCELLED, preview: None }
    }
}

/// Trains on `training` and labels every voxel of `volume`: the trained model (its summary
/// says what was trained on and how long it took) and the label volume (0 background, k class
/// k). An MR scan's shading is divided out as [`classify_shaded`] says.
pub fn classify_training(
    volume: &Volume,
    training: &TrainingSet,
    options: &SegmentationOptions,
    control: RunControl<'_>,
) -> Result<(Segmenter, LabelVolume), SegmentationError> {
    let samples = segmentation::samples(volume, training, options)?;
    classify_shaded(volume, samples, |scan| segmentation::samples(scan, training, options), options, control)
}

/// Fits the classifier to `samples` (read off `volume`) and labels `volume`, as
/// [`classify_samples`] does. With [`SegmentationOptions::correct_shading`] (MR scans), the
/// first look (the coarse labels) gives the scan's shading ([`Shading::estimate`]); where there
/// is one, the first labelling stops there, the samples `samples_of` reads off the scan divided
/// by the shading are trained on and that scan labelled, and the segmenter keeps it
/// ([`Segmenter::corrected_scan`]). Progress runs to one half on the first labelling.
pub fn classify_shaded<E>(
    volume: &Volume,
    samples: TrainingSamples,
    samples_of: impl FnOnce(&Volume) -> Result<TrainingSamples, E>,
    options: &SegmentationOptions,
    control: RunControl<'_>,
) -> Result<(Segmenter, LabelVolume), E>
where
    E: From<SegmentationError>,
{
    if !options.correct_shading {
        return Ok(classify_samples(volume, samples, options, control)?);
    }
    if volume.voxel_count() > MAX_CORRECTED_VOXELS {
        log::info!(
            "the scan's shading is not looked for: {} voxels are more than a corrected copy may hold ({MAX_CORRECTED_VOXELS})",
            volume.voxel_count()
        );
        return Ok(classify_samples(volume, samples, options, control)?);
    }
    let segmenter = segmentation::fit(samples, options)?;
    let found: Mutex<Option<Shading>> = Mutex::new(None);
    let (stop, looked) = (AtomicBool::new(false), AtomicBool::new(false));
    let first_half = |fraction: f32| {
        if control.cancel.load(Ordering::Relaxed) {
            stop.store(true, Ordering::Relaxed);
        }
        (control.progress)(0.5 * fraction);
    };
    let first_look = |coarse: &LabelVolume| {
        if let Some(preview) = control.preview {
            preview(coarse);
        }
        looked.store(true, Ordering::Relaxed);
        if let Some(shading) = Shading::estimate(volume, &coarse.labels) {
            if let Ok(mut found) = found.lock() {
                *found = Some(shading);
            }
            stop.store(true, Ordering::Relaxed);
        }
    };
    let first = segmentation::label_volume_with_preview(
        volume,
        &segmenter,
        options.refinement,
        &first_half,
        &stop,
        &first_look,
    );
    let cancelled = control.cancel.load(Ordering::Relaxed);
    let shading = found.into_inner().ok().flatten();
    let shading = match (first, shading) {
        (Err(error), _) if cancelled => return Err(error.into()),
        (_, Some(shading)) => shading,
        (Err(error), None) => return Err(error.into()),
        // No first look (exact labelling, multi-scale features): the exact labels tell.
        (Ok(labels), None) if !looked.load(Ordering::Relaxed) => match Shading::estimate(volume, &labels.labels) {
            Some(shading) => shading,
            None => return Ok((segmenter, labels)),
        },
        (Ok(labels), None) => return Ok((segmenter, labels)),
    };
    let started = std::time::Instant::now();
    let corrected = std::sync::Arc::new(shading.corrected(volume).map_err(SegmentationError::from)?);
    log::info!(
        "the scan's shading (up to {:.0} %) divided out in {:.0} ms; classifying again",
        100.0 * shading.largest_departure(),
        started.elapsed().as_secs_f64() * 1000.0
    );
    let second_half = |fraction: f32| (control.progress)(0.5 + 0.5 * fraction);
    let second_pass = RunControl { progress: &second_half, cancel: control.cancel, preview: None };
    let samples = samples_of(&corrected)?;
    let (mut segmenter, labels) = classify_samples(&corrected, samples, options, second_pass)?;
    segmenter.corrected_scan = Some(corrected);
    Ok((segmenter, labels))
}

/// The most voxels whose shading is divided out: the corrected copy holds 4 bytes a voxel
/// (512 MiB here), beside the scan itself.
pub const MAX_CORRECTED_VOXELS: usize = 1 << 27;

/// Fits the classifier to `samples` (read off lassos, a preset's, or both: [`preset_samples`])
/// and labels every voxel of `volume`, as [`classify_training`] does.
pub fn classify_samples(
    volume: &Volume,
    samples: TrainingSamples,
    options: &SegmentationOptions,
    control: RunControl<'_>,
) -> Result<(Segmenter, LabelVolume), SegmentationError> {
    let segmenter = segmentation::fit(samples, options)?;
    let labels = match control.preview {
        Some(preview) => segmentation::label_volume_with_preview(
            volume,
            &segmenter,
            options.refinement,
            control.progress,
            control.cancel,
            preview,
        )?,
        None => segmentation::label_volume(volume, &segmenter, options.refinement, control.progress, control.cancel)?,
    };
    Ok((segmenter, labels))
}

/// A preset's training on `volume` (of `modality`), with the loops of `training` added where
/// given (drawn on this scan: they correct the preset), and every class's name in class order
/// (the preset's, then drawn classes it lacks). The features are the preset's; the drawn
/// loops are read with them and capped as any training set. `training`'s class `k` is class
/// `drawn_ids[k]` of the result.
pub fn preset_samples(
    volume: &Volume,
    preset: &Preset,
    modality: Modality,
    training: Option<&TrainingSet>,
    options: &SegmentationOptions,
) -> Result<(TrainingSamples, Vec<String>), PipelineError> {
    let from_preset = preset.samples_for(volume, modality)?;
    let Some(training) = training.filter(|training| !training.classes.is_empty()) else {
        return Ok((from_preset, preset.class_names()));
    };
    let drawn_names: Vec<String> = training.classes.iter().map(|class| class.name.clone()).collect();
    let (names, drawn_ids) = preset::joined_classes(&preset.class_names(), &drawn_names);
    let options = SegmentationOptions { feature_set: from_preset.feature_set, ..options.clone() };
    check_training(volume, training, &options)?;
    let drawn = segmentation::samples(volume, training, &options)?;
    let joined = preset::join_samples(
        from_preset,
        preset.air_class,
        drawn,
        &drawn_ids,
        names.len(),
        options.max_training_per_class,
    );
    Ok((joined, names))
}

/// What a classification gives: the model, the labels and their colours.
pub struct Classified {
    /// The trained classifier and its training summary.
    pub segmenter: Segmenter,
    /// The label of every voxel (x fastest): 0 background, k class k.
    pub labels: LabelVolume,
    /// Colour and opacity of each class (§3.5).
    pub table: ClassTable,
}

/// The strokes' classes trained and applied to `volume`, coloured with `template` (`None`:
/// the default template for the number of classes). The training set is checked first
/// ([`check_training`]), and more classes than the SN-SVM classifies go to the random forest
/// ([`forest_fallback`]; the segmenter's summary names the classifier trained).
pub fn classify_strokes(
    volume: &Volume,
    strokes: &StrokesFile,
    options: &SegmentationOptions,
    template: Option<HueTemplate>,
    control: RunControl<'_>,
) -> Result<Classified, PipelineError> {
    let training = TrainingSet::from_strokes(strokes, volume.dims)?;
    let fallback = forest_fallback(options, training.classes.len());
    let options = fallback.as_ref().unwrap_or(options);
    check_training(volume, &training, options)?;
    let (segmenter, labels) = classify_training(volume, &training, options, control)?;
    let class_count = strokes.classes.len();
    let template = template.unwrap_or_else(|| HueTemplate::default_for(class_count));
    let table = ClassTable::compute(volume, &labels.labels, class_count, template)?;
    Ok(Classified { segmenter, labels, table })
}

/// [`classify_strokes`] with a learned preset applied to `volume` (of `modality`): the
/// classes of `strokes` that hold lassos join the preset's training by name
/// ([`preset_samples`]); the classes are the preset's, then the drawn ones it lacks, coloured
/// with `template` (`None`: the preset's) in the preset's look. Without a preset, exactly
/// [`classify_strokes`].
pub fn classify_strokes_with_preset(
    volume: &Volume,
    strokes: &StrokesFile,
    preset: Option<(&Preset, Modality)>,
    options: &SegmentationOptions,
    template: Option<HueTemplate>,
    control: RunControl<'_>,
) -> Result<Classified, PipelineError> {
    let Some((preset, modality)) = preset else {
        return classify_strokes(volume, strokes, options, template, control);
    };
    let mut drawn = strokes.clone();
    drawn.classes.retain(|class| !class.strokes.is_empty());
    let training = if drawn.classes.is_empty() { None } else { Some(TrainingSet::from_strokes(&drawn, volume.dims)?) };
    let (samples, names) = preset_samples(volume, preset, modality, training.as_ref(), options)?;
    let options = match forest_fallback(options, names.len()) {
        Some(forest) => {
            SegmentationOptions { feature_set: samples.feature_set, correct_shading: options.correct_shading, ..forest }
        }
        None => options.clone(),
    };
    let samples_of =
        |scan: &Volume| preset_samples(scan, preset, modality, training.as_ref(), &options).map(|(samples, _)| samples);
    let (segmenter, labels) = classify_shaded(volume, samples, samples_of, &options, control)?;
    let mut table = ClassTable::compute(volume, &labels.labels, names.len(), template.unwrap_or(preset.template))?;
    preset.restyle(&mut table);
    Ok(Classified { segmenter, labels, table })
}

/// What [`classify_array`] gives.
pub struct ArrayClassified {
    /// The label of every voxel, indexed `[z, y, x]` like the input: 0 background, k class k.
    pub labels: Array3<u8>,
    /// Colour and opacity of each class (§3.5).
    pub table: ClassTable,
    /// The trained classifier and its training summary.
    pub segmenter: Segmenter,
}

/// Classifies a scan held as an array. `values` are the intensities indexed `[z, y, x]`,
/// `spacing_mm` the voxel size along x, y, z; `scribbles` has the same shape and marks the
/// training voxels: 0 unmarked, k the k-th class (classes 1..=max, each must mark at least one
/// voxel). The same call as [`classify_strokes`] after the scribbles are made a training set.
pub fn classify_array(
    values: ArrayView3<'_, f32>,
    spacing_mm: [f64; 3],
    scribbles: ArrayView3<'_, u8>,
    options: &SegmentationOptions,
) -> Result<ArrayClassified, PipelineError> {
    if scribbles.dim() != values.dim() {
        return Err(PipelineError::ScribbleShape { scribbles: scribbles.dim(), volume: values.dim() });
    }
    let volume = Volume::from_array(values, spacing_mm, Path::new("array"))?;
    let training = training_from_scribbles(scribbles)?;
    let (segmenter, labels) = classify_training(&volume, &training, options, RunControl::batch())?;
    let class_count = training.classes.len();
    let table = ClassTable::compute(&volume, &labels.labels, class_count, HueTemplate::default_for(class_count))?;
    let (nz, ny, nx) = values.dim();
    let labels = Array3::from_shape_vec((nz, ny, nx), labels.labels)
        .map_err(|_| PipelineError::ScribbleShape { scribbles: (nz, ny, nx), volume: (nz, ny, nx) })?;
    Ok(ArrayClassified { labels, table, segmenter })
}

/// The training set marked by a scribble array: class k's voxels are those marked k, in the
/// volume's x-fastest index order, one "stroke" per class. Refuses no class at all and a class
/// number below the highest that marks nothing.
pub fn training_from_scribbles(scribbles: ArrayView3<'_, u8>) -> Result<TrainingSet, StrokesError> {
    let class_count = scribbles.iter().copied().max().unwrap_or(0) as usize;
    if class_count == 0 {
        return Err(StrokesError::NoClasses);
    }
    let mut voxels: Vec<Vec<usize>> = vec![Vec::new(); class_count];
    // `iter` walks in logical [z, y, x] order, the volume's x-fastest index order.
    for (index, &mark) in scribbles.iter().enumerate() {
        if mark > 0 {
            voxels[mark as usize - 1].push(index);
        }
    }
    let classes = voxels
        .into_iter()
        .enumerate()
        .map(|(k, voxels)| ClassSamples::one_stroke(format!("Class {}", k + 1), voxels))
        .collect();
    let set = TrainingSet { classes, contested_voxels: 0 };
    set.check_every_class_has_voxels()?;
    Ok(set)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ndarray::s;

    /// Two blobs of different brightness in a dark box, one scribble inside each.
    fn two_blobs() -> (Array3<f32>, Array3<u8>) {
        let values = Array3::from_shape_fn((16, 20, 24), |(z, y, x)| {
            let d = |c: [f32; 3]| {
                ((z as f32 - c[0]).powi(2) + (y as f32 - c[1]).powi(2) + (x as f32 - c[2]).powi(2)).sqrt()
            };
            if d([8.0, 10.0, 7.0]) < 5.0 {
                100.0
            } else if d([8.0, 10.0, 17.0]) < 5.0 {
                200.0
            } else {
                0.0
            }
        });
        let mut scribbles = Array3::<u8>::zeros(values.dim());
        scribbles.slice_mut(s![7..10, 9..12, 6..9]).fill(1);
        scribbles.slice_mut(s![7..10, 9..12, 16..19]).fill(2);
        (values, scribbles)
    }

    #[test]
    fn scribbles_become_classes_in_index_order() {
        let (_, scribbles) = two_blobs();
        let set = training_from_scribbles(scribbles.view()).unwrap();
        assert_eq!(set.classes.len(), 2);
        assert_eq!(set.classes[0].voxels.len(), 27);
        let first = set.classes[1].voxels[0];
        assert_eq!((first / (20 * 24), (first / 24) % 20, first % 24), (7, 9, 16));
        assert!(matches!(training_from_scribbles(Array3::<u8>::zeros((2, 2, 2)).view()), Err(StrokesError::NoClasses)));
        let mut gap = Array3::<u8>::zeros((2, 2, 2));
        gap[[0, 0, 0]] = 2;
        assert!(training_from_scribbles(gap.view()).is_err(), "class 1 marks nothing");
    }

    #[test]
    fn an_array_is_classified_into_its_blobs() {
        let (values, scribbles) = two_blobs();
        let result =
            classify_array(values.view(), [1.0; 3], scribbles.view(), &SegmentationOptions::default()).unwrap();
        assert_eq!(result.labels.dim(), values.dim());
        assert_eq!(result.labels[[8, 10, 5]], 1, "inside the dim blob, away from its scribble");
        assert_eq!(result.labels[[8, 10, 19]], 2, "inside the bright blob, away from its scribble");
        assert_eq!(result.labels[[0, 0, 0]], 0, "the dark box is background");
        assert_eq!(result.table.styles.len(), 2);
    }

    /// Two tissues (100 and 150) in blocks of 8 voxels across y and z, so both run the whole
    /// x axis, under a coil's shading from 0.75 to 1.25 along x: the bright tissue's dim end
    /// (112) is nearer the dim tissue's middle than its own. One scribble in each, in the middle
    /// of x; the truth: class 1 or 2 by block.
    fn shaded_blocks() -> (Array3<f32>, Array3<u8>, Array3<u8>) {
        let truth = Array3::from_shape_fn((16, 16, 64), |(z, y, _)| if (y / 8 + z / 8) % 2 == 0 { 1u8 } else { 2 });
        let values = Array3::from_shape_fn(truth.dim(), |(z, y, x)| {
            let tissue = if truth[[z, y, x]] == 1 { 100.0 } else { 150.0 };
            tissue * (0.75 + 0.5 * x as f32 / 63.0)
        });
        let mut scribbles = Array3::<u8>::zeros(truth.dim());
        scribbles.slice_mut(s![2..6, 2..6, 28..36]).fill(1);
        scribbles.slice_mut(s![2..6, 10..14, 28..36]).fill(2);
        (values, scribbles, truth)
    }

    #[test]
    fn an_mr_scan_s_shading_is_divided_out_before_it_is_classified_again() {
        let (values, scribbles, truth) = shaded_blocks();
        let options = SegmentationOptions { background: segmentation::Background::None, ..Default::default() };
        let wrong = |labels: &Array3<u8>| labels.iter().zip(truth.iter()).filter(|(a, b)| a != b).count();
        let as_read = classify_array(values.view(), [1.0; 3], scribbles.view(), &options).unwrap();
        let corrected = SegmentationOptions { correct_shading: true, ..options };
        let divided = classify_array(values.view(), [1.0; 3], scribbles.view(), &corrected).unwrap();
        let (before, after) = (wrong(&as_read.labels), wrong(&divided.labels));
        assert!(as_read.segmenter.corrected_scan.is_none());
        assert!(divided.segmenter.corrected_scan.is_some(), "a 25 % field is divided out");
        assert!(before > values.len() / 20, "the shading mislabels the ends of the scan: {before} voxels");
        assert!(after * 2 < before, "{after} voxels wrong after the correction, {before} before");
    }

    #[test]
    fn a_flat_scan_is_classified_once() {
        let (values, scribbles) = two_blobs();
        let options = SegmentationOptions { correct_shading: true, ..Default::default() };
        let result = classify_array(values.view(), [1.0; 3], scribbles.view(), &options).unwrap();
        assert!(result.segmenter.corrected_scan.is_none(), "no shading: the scan is kept as read");
        assert_eq!(result.labels[[8, 10, 5]], 1);
    }

    #[test]
    fn scribbles_of_another_shape_are_refused() {
        let (values, _) = two_blobs();
        let scribbles = Array3::<u8>::ones((16, 20, 23));
        let error = classify_array(values.view(), [1.0; 3], scribbles.view(), &SegmentationOptions::default());
        assert!(matches!(error, Err(PipelineError::ScribbleShape { .. })));
    }
}
