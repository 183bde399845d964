//! Segmentation: from a training set to a label volume, end to end (paper §3.2-§3.4 joined).
//!
//! [`train`] caps the training voxels per class (stratified over strokes), computes their
//! features, standardises them and trains the classifier ([`ClassifierKind`]: the SN-SVM on the
//! paper's features by default, or a random forest) into a [`Segmenter`]. [`label_volume`]
//! classifies every voxel that is not background in parallel z slabs, with progress and
//! cancellation; [`Refinement::CoarseToFine`] evaluates every second voxel along each axis and
//! then only where those disagree or the voxel's intensity leaves their range
//! (`docs/decisions/0014-coarse-to-fine.md`). The kernel sums are the only hot part.
//!
//! Before training, what the loops mean:
//! * **The body and the world** (`background`, `crate::volume::body`). The face air (the dark
//!   region joined to the volume's faces that the body does not ring in its axial slices), and what is
//!   darker than every loop inside the body, is background: label 0, never evaluated. Lungs,
//!   sinuses and bowel gas are inside the body however dark. A class drawn mostly in the face
//!   air is the air: the air around the body is that class.
//! * **A loop's voxels are noisy labels** ([`gate`]). A class's band is its drawn intensities,
//!   trimmed; a voxel one band holds is that class, else only the nearest bands' classes vote.
//!   A loop whose rim holds another class's intensities leaked: its core alone gives the band
//!   and the training voxels. A clean loop's enclosed voxels of another class are set aside.
//!
//! After labelling, the spatial step: the majority filter ([`coherence`]), then the Potts
//! sweeps ([`potts`]), where a border voxel takes the label whose nearby intensities it is
//! nearest, weighed against the border's length, then the partial-volume layers
//! ([`partial_volume`]): a class's one-voxel layer between two classes that bracket its
//! intensity, apart from its loops, is their blurred border; last the undrawn tissues
//! ([`undrawn`]): a piece of a class apart from its loops, many times their size, whose
//! intensity is another class's drawn pieces' more than its own, or no drawn piece's, is a
//! tissue nobody drew: it goes to that class, or to none; where a tenth of such a piece lies
//! outside the drawn range, those voxels go to none.
//!
//! Never: reads files, or knows about the UI (progress and cancellation are plain callbacks).

mod background;
mod coarse_grid;
pub mod coherence;
pub mod gate;
mod neighbours;
pub mod pairwise;
pub mod partial_volume;
pub mod potts;
mod refine;
pub mod undrawn;

#[cfg(test)]
mod tests;

pub use background::{Background, BackgroundPlan};

use crate::classify::{
    self, ClassifyError, Forest, ForestParams, Kernel, Model, SampleMatrix, SnSvmParams, TrainReport,
};
use crate::features::{FeatureError, FeatureSet, Standardiser, features_of_voxels};
use crate::strokes::{StrokesError, TrainingSet};
use crate::volume::Volume;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// Training voxels per class after the cap: keeps training (O(N^3) per pair) and prediction
/// (N kernel terms per voxel) within the interactive budget; the paper's sets are 97-401
/// voxels in all.
pub const DEFAULT_TRAINING_CAP: usize = 256;

/// Default pruning of SN-SVM's expansion ([`Model::pruned`]): with the benchmark lassos it makes
/// prediction about a quarter faster and changes about a tenth of a percent of the labels
/// (`docs/decisions/0015-pruning.md`).
pub const DEFAULT_PRUNE_RELATIVE: f64 = 0.01;

/// Which classifier [`train`] fits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClassifierKind {
    /// The SN-SVM (plain SVM at eta = 0) with the parameters in
    /// `SegmentationOptions::classifier`.
    SnSvm,
    /// A random forest ([`crate::classify::Forest`]).
    Forest(ForestParams),
}

/// How to segment.
#[derive(Clone, Debug)]
pub struct SegmentationOptions {
    /// The features each voxel is classified on.
    pub feature_set: FeatureSet,
    /// Which classifier to train; the default is `docs/decisions/0001-default-classifier.md`'s.
    pub classifier_kind: ClassifierKind,
    /// The SN-SVM's parameters (used when `classifier_kind` is [`ClassifierKind::SnSvm`]); its
    /// RBF width is replaced by the data's when `kernel_width` is [`KernelWidth::Automatic`].
    pub classifier: SnSvmParams,
    /// The RBF width: the median heuristic or a fixed value.
    pub kernel_width: KernelWidth,
    /// How the SN-SVM's features are standardised.
    pub standardisation: Standardisation,
    /// The spatial step after classification.
    pub coherence: Coherence,
    /// Training voxels kept per class (stratified over the class's strokes).
    pub max_training_per_class: usize,
    /// Which voxels are background and never classified.
    pub background: Background,
    /// Every voxel, or coarse-to-fine.
    pub refinement: Refinement,
    /// Expansion points whose coefficients are all at most this fraction of their pair's
    /// largest are dropped before prediction ([`Model::pruned`]); 0 keeps every one.
    pub prune_relative: f64,
    /// Seeds the training cap's random choice.
    pub seed: u64,
    /// Divide an MRI scan's shading out and classify it again (`crate::volume::shading`); for MR scans
    /// only (`crate::pipeline::classify_training`).
    pub correct_shading: bool,
}

impl SegmentationOptions {
    /// The paper's method: SN-SVM on the 5-D features (`--classifier snsvm --features paper5`).
    pub fn paper() -> SegmentationOptions {
        SegmentationOptions {
            feature_set: FeatureSet::Paper5,
            classifier_kind: ClassifierKind::SnSvm,
            ..Self::default()
        }
    }

    /// A random forest on the fine multi-scale features (`--classifier forest`).
    pub fn forest() -> SegmentationOptions {
        SegmentationOptions {
            feature_set: FeatureSet::MultiscaleFine,
            classifier_kind: ClassifierKind::Forest(ForestParams::default()),
            ..Self::default()
        }
    }
}

impl Default for SegmentationOptions {
    fn default() -> Self {
        // The paper's SN-SVM on its 5-D features and the gap depth: on phantoms nobody tuned it
        // for it generalises better than the forest on the multi-scale features, and the gap
        // depth tells a joint space from a bone's blurred edge
        // (docs/decisions/0001-default-classifier.md, docs/decisions/0011-gap-depth.md).
        SegmentationOptions {
            feature_set: FeatureSet::Paper5Gap,
            classifier_kind: ClassifierKind::SnSvm,
            classifier: SnSvmParams::default(),
            kernel_width: KernelWidth::Automatic,
            standardisation: Standardisation::PerPair,
            coherence: Coherence::Potts,
            max_training_per_class: DEFAULT_TRAINING_CAP,
            background: Background::Automatic,
            refinement: Refinement::CoarseToFine,
            prune_relative: DEFAULT_PRUNE_RELATIVE,
            seed: 0x5eed,
            correct_shading: false,
        }
    }
}

/// The RBF kernel width g in exp(-g |x - y|^2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum KernelWidth {
    /// The median heuristic: sigma^2 = median |x_i - x_j|^2 over training pairs and
    /// g = 1 / (2 sigma^2), so the kernel is neither flat nor a spike on whatever the lassos
    /// sampled (CT or MRI, 8 or 16 bit), where a fixed width suits one scale of data only
    /// (`docs/decisions/0003-kernel-width.md`).
    Automatic,
    /// The width in `SegmentationOptions::classifier` as given.
    AsGiven,
}

/// How the SN-SVM's features are standardised (a forest is indifferent).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Standardisation {
    /// Each pair of classes on its own training voxels, as the paper's code does
    /// ([`pairwise`]); the automatic RBF width is the pair's own.
    PerPair,
    /// One standardisation and one RBF width for all classes.
    Global,
}

/// The spatial step after classification.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coherence {
    /// Labels as the classifier gave them.
    None,
    /// [`coherence::DEFAULT_PASSES`] passes of the majority filter
    /// ([`coherence::majority_passes`]), within each slice on a scan cut in thick slices
    /// ([`coherence::Neighbourhood::for_spacing`]).
    Majority,
    /// The majority filter, then the Potts model's sweeps over the borders between classes
    /// ([`potts::potts_sweeps`]; the default).
    Potts,
}

/// Which voxels the classifier evaluates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refinement {
    /// Every voxel above the background threshold.
    Exact,
    /// A coarse grid, then only where it is not conclusive (see the module doc).
    CoarseToFine,
}

/// Everything that can go wrong while segmenting.
#[derive(Debug, thiserror::Error)]
pub enum SegmentationError {
    /// The volume's mapped file shrank since it was opened (see `Volume::check_still_mapped`).
    #[error(transparent)]
    Volume(#[from] crate::volume::VolumeError),
    /// The strokes do not fit the volume or give no training voxels.
    #[error(transparent)]
    Strokes(#[from] StrokesError),
    /// Computing or standardising features failed.
    #[error(transparent)]
    Features(#[from] FeatureError),
    /// Training or evaluating the classifier failed.
    #[error(transparent)]
    Classify(#[from] ClassifyError),
    /// A training voxel's value is NaN or infinite.
    #[error(
        "training voxel {voxel} of class '{class}' has the value {value}; NaN or infinite voxels cannot be classified"
    )]
    NonFiniteTraining {
        /// The voxel's index (x fastest).
        voxel: usize,
        /// The class that lassoed it.
        class: String,
        /// Its value.
        value: f64,
    },
    /// The caller's cancel flag was set.
    #[error("the classification was cancelled")]
    Cancelled,
}

/// What training used and decided, for reports (the `classify` JSON line).
#[derive(Clone, Debug)]
pub struct TrainingSummary {
    /// The SN-SVM's parameters as trained (with the automatic kernel width filled in); unused
    /// by a forest.
    pub classifier: SnSvmParams,
    /// The classifier trained.
    pub classifier_kind: ClassifierKind,
    /// Training voxels used per class, after the cap.
    pub used_per_class: Vec<usize>,
    /// Training voxels the cap removed per class.
    pub dropped_per_class: Vec<usize>,
    /// The cap on training voxels per class.
    pub cap_per_class: usize,
    /// Voxels claimed by two classes and dropped from both.
    pub contested_voxels: usize,
    /// Voxels below this value are background; `None` when every voxel is classified.
    pub background_threshold: Option<f64>,
    /// Voxels outside this body (the world around it) get `region_label` without being
    /// classified.
    pub body: Option<std::sync::Arc<crate::volume::body::Body>>,
    /// The label of the voxels outside `body`: 0 (background), or the class drawn in the air.
    pub region_label: u8,
    /// Training voxels the background rule dropped per class (in the air around the body, when
    /// another class was drawn in it).
    pub dropped_as_air_per_class: Vec<usize>,
    /// A class was drawn in the air around the body, so the air is classified.
    pub air_is_a_class: bool,
    /// Time spent on the training voxels: the background rule, their features (and
    /// standardising them).
    pub features_seconds: f64,
    /// Time spent training the classifier.
    pub train_seconds: f64,
}

/// A trained classifier.
pub enum TrainedClassifier {
    /// Classifies feature vectors standardised over all classes.
    SnSvm(Box<Model>),
    /// One SN-SVM per pair of classes, each on its own standardisation.
    SnSvmPerPair(Box<pairwise::PairwiseSnSvm>),
    /// Classifies raw feature vectors: trained on standardised ones, its thresholds were moved
    /// into raw units ([`Standardiser::raw_threshold`]), which gives the same labels without
    /// standardising every voxel's features.
    Forest(Forest),
}

/// A trained classifier with everything needed to classify a volume.
pub struct Segmenter {
    /// The lassoed voxels (after the background rule, before the cap) with their class ids:
    /// [`label_volume`] gives them their class whatever the classifier says (the user said
    /// what they are).
    pub lassoed: Vec<(usize, u8)>,
    /// The features the classifier was trained on.
    pub feature_set: FeatureSet,
    /// The spatial step [`label_volume`] ends with.
    pub coherence: Coherence,
    /// The standardisation over all classes' training features.
    pub standardiser: Standardiser,
    /// The trained classifier.
    pub classifier: TrainedClassifier,
    /// What training used and decided.
    pub summary: TrainingSummary,
    /// What it was fitted on (a preset keeps them: `crate::preset`).
    pub samples: TrainingSamples,
    /// The scan divided by its shading (`crate::volume::shading`) that it was trained on and labels, where
    /// the pipeline corrected it; `None`: the scan as read.
    pub corrected_scan: Option<std::sync::Arc<Volume>>,
}

impl Segmenter {
    /// The scan this segmenter classifies for `volume`: the one divided by its shading where
    /// it was trained on that ([`Segmenter::corrected_scan`]), else `volume` itself.
    pub fn scan<'a>(&'a self, volume: &'a Volume) -> &'a Volume {
        match &self.corrected_scan {
            Some(corrected) if corrected.dims == volume.dims => corrected,
            _ => volume,
        }
    }

    /// Class ids of a block of raw feature vectors (row-major, `out.len() x dim`), into `out`;
    /// `features` is scratch (standardised in place where the classifier needs it).
    pub fn classify_block(&self, features: &mut [f32], out: &mut [u8]) -> Result<(), SegmentationError> {
        let dim = self.feature_set.dim();
        // Runs of equal vectors (air in an 8-bit scan, saturated regions) are classified once:
        // the kernel sums are the whole cost of prediction.
        let repeats =
            features.chunks_exact(dim).zip(features.chunks_exact(dim).skip(1)).filter(|(a, b)| a == b).count();
        if repeats * 4 < out.len() {
            return self.classify_distinct(features, out);
        }
        let mut distinct: Vec<f32> = Vec::with_capacity(features.len() - repeats * dim);
        let mut run_lengths: Vec<usize> = Vec::with_capacity(out.len() - repeats);
        for vector in features.chunks_exact(dim) {
            match run_lengths.last_mut() {
                Some(length) if distinct[distinct.len() - dim..] == *vector => *length += 1,
                _ => {
                    distinct.extend_from_slice(vector);
                    run_lengths.push(1);
                }
            }
        }
        let mut labels = vec![0u8; run_lengths.len()];
        self.classify_distinct(&mut distinct, &mut labels)?;
        let mut start = 0;
        for (&label, &length) in labels.iter().zip(&run_lengths) {
            out[start..start + length].fill(label);
            start += length;
        }
        Ok(())
    }

    fn classify_distinct(&self, features: &mut [f32], out: &mut [u8]) -> Result<(), SegmentationError> {
        match &self.classifier {
            TrainedClassifier::SnSvm(model) => {
                self.standardiser.apply_in_place(features)?;
                model.predict_block(features, out)?;
            }
            TrainedClassifier::SnSvmPerPair(model) => model.classify_block(features, out)?,
            TrainedClassifier::Forest(forest) => forest.predict_block(features, out)?,
        }
        Ok(())
    }

    /// The class a voxel of `intensity` gets whatever its other features (the intensity gate
    /// allows one class only), so that its features need not be computed; `None` when the
    /// classifier must see them. Only for a voxel whose features are all finite: one with a
    /// non-finite feature is not classified (label 0) by [`classify_block`](Self::classify_block).
    pub fn class_by_intensity(&self, intensity: f32) -> Option<u8> {
        match &self.classifier {
            TrainedClassifier::SnSvmPerPair(model) => model.class_by_intensity(intensity),
            _ => None,
        }
    }

    /// The band of intensities drawn for label `label` (the intensity gate's); `None` for a
    /// classifier without a gate, or a label it does not give.
    pub fn band(&self, label: u8) -> Option<gate::Band> {
        match &self.classifier {
            TrainedClassifier::SnSvmPerPair(model) => model.band(label),
            _ => None,
        }
    }

    /// The SN-SVM's training report; `None` for a forest.
    pub fn report(&self) -> Option<&TrainReport> {
        match &self.classifier {
            TrainedClassifier::SnSvm(model) => Some(model.report()),
            TrainedClassifier::SnSvmPerPair(model) => Some(&model.report),
            TrainedClassifier::Forest(_) => None,
        }
    }
}

/// Trains a [`Segmenter`] on `training` voxels of `volume`: [`samples`], then [`fit`].
pub fn train(
    volume: &Volume,
    training: &TrainingSet,
    options: &SegmentationOptions,
) -> Result<Segmenter, SegmentationError> {
    fit(samples(volume, training, options)?, options)
}

/// What a classifier is fitted on, every value in one volume's units: read off its lassos
/// ([`samples`]) or carried over from another scan by a preset (`crate::preset`).
#[derive(Clone, Debug)]
pub struct TrainingSamples {
    /// Number of classes; class id `k` is the class at position `k - 1`.
    pub class_count: usize,
    /// The features the vectors hold.
    pub feature_set: FeatureSet,
    /// The training vectors' raw features, row-major (`labels.len() x dim`).
    pub features: Vec<f32>,
    /// Each vector's class id.
    pub labels: Vec<u8>,
    /// Each class's band of drawn intensities, in class order; `None` for an open gate (a
    /// class without a finite value, more classes than a gate tells apart).
    pub bands: Option<Vec<gate::Band>>,
    /// The background decided for the volume.
    pub background: BackgroundPlan,
    /// Lassoed voxels that keep their class whatever the classifier says, with their class ids.
    pub lassoed: Vec<(usize, u8)>,
    /// Training vectors per class.
    pub used_per_class: Vec<usize>,
    /// Training voxels the cap removed per class.
    pub dropped_per_class: Vec<usize>,
    /// Voxels claimed by two classes and dropped from both.
    pub contested_voxels: usize,
    /// Time spent reading them (the background rule, the features).
    pub features_seconds: f64,
}

/// The training samples of `training` on `volume`: the background rule, the gate's bands and
/// the lassos' cleaning, the cap, and the features of what is left.
pub fn samples(
    volume: &Volume,
    training: &TrainingSet,
    options: &SegmentationOptions,
) -> Result<TrainingSamples, SegmentationError> {
    volume.check_still_mapped()?;
    training.check_every_class_has_voxels()?;
    let started = Instant::now();
    let (cleaned, background) = background::plan(volume, training, options.background);
    let drawn = gate::DrawnLassos::read(volume, training);
    let decided = cleaned.restricted(&drawn.decided_voxels());
    let cleaned = cleaned.restricted(&drawn.training_voxels());
    cleaned.check_every_class_has_voxels()?;
    let capped = cleaned.capped(options.max_training_per_class, options.seed);
    let (voxels, labels) = capped.labelled_voxels();
    let dim = options.feature_set.dim();
    let features = features_of_voxels(volume, options.feature_set, &voxels)?;
    if let Some(position) = features.iter().position(|v| !v.is_finite()) {
        let sample = position / dim;
        return Err(SegmentationError::NonFiniteTraining {
            voxel: voxels[sample],
            class: capped.classes[labels[sample] as usize - 1].name.clone(),
            value: volume.value(voxels[sample]),
        });
    }
    let (decided_voxels, decided_ids) = decided.labelled_voxels();
    Ok(TrainingSamples {
        class_count: capped.classes.len(),
        feature_set: options.feature_set,
        features,
        labels,
        bands: drawn.bands(),
        background,
        lassoed: decided_voxels.into_iter().zip(decided_ids).collect(),
        used_per_class: capped.classes.iter().map(|c| c.voxels.len()).collect(),
        dropped_per_class: capped.classes.iter().map(|c| c.dropped_by_cap).collect(),
        contested_voxels: capped.contested_voxels,
        features_seconds: started.elapsed().as_secs_f64(),
    })
}

/// Fits the classifier of `options` to `samples` (their feature set, not `options`').
pub fn fit(samples: TrainingSamples, options: &SegmentationOptions) -> Result<Segmenter, SegmentationError> {
    let started = Instant::now();
    let feature_set = samples.feature_set;
    let dim = feature_set.dim();
    let scaling = feature_set.scaling();
    let standardiser = scaling.fit(&samples.features)?;
    let values = standardiser.apply(&samples.features)?;
    let features_seconds = samples.features_seconds + started.elapsed().as_secs_f64();
    let started = Instant::now();
    let labels = &samples.labels;
    let class_ids: Vec<u8> = (1..=samples.class_count as u8).collect();
    let background = &samples.background;
    let mut classifier = options.classifier;
    let trained = match options.classifier_kind {
        ClassifierKind::SnSvm if options.standardisation == Standardisation::PerPair => {
            // A class drawn in the air is the air around the body by construction (the
            // region's label), never a voxel the classifier labels.
            // More classes than a gate tells apart leave it open (`IntensityGate::from_bands`).
            let drawn = samples
                .bands
                .clone()
                .map_or_else(|| gate::IntensityGate::open(samples.class_count), gate::IntensityGate::from_bands);
            let gate = match background.air_class {
                Some(position) => drawn.without(position),
                None => drawn,
            };
            let model = pairwise::PairwiseSnSvm::train(
                &samples.features,
                &scaling,
                labels,
                &class_ids,
                gate,
                &classifier,
                options.kernel_width,
                options.prune_relative,
            )?
            .with_intensity_features(feature_set.intensity_features());
            // The first pair's parameters stand for the model's (two classes: the only pair).
            if let Some(first) = model.pairs.first() {
                classifier = first.params;
            }
            TrainedClassifier::SnSvmPerPair(Box::new(model))
        }
        ClassifierKind::SnSvm => {
            if options.kernel_width == KernelWidth::Automatic {
                classifier.kernel = Kernel::Rbf { width: median_heuristic_width(&values, dim) };
            }
            let params = classifier.check()?;
            let model = classify::train_with_classes(&SampleMatrix { dim, values }, labels, &class_ids, &params)?
                .pruned(options.prune_relative);
            TrainedClassifier::SnSvm(Box::new(model))
        }
        ClassifierKind::Forest(params) => {
            let samples: Vec<f32> = values.iter().map(|&v| v as f32).collect();
            let params = ForestParams { seed: crate::rng::hash64(params.seed, options.seed), ..params };
            let forest = Forest::train(&samples, dim, labels, &class_ids, &params)?;
            TrainedClassifier::Forest(
                forest.with_thresholds(|feature, threshold| standardiser.raw_threshold(feature, threshold)),
            )
        }
    };
    let summary = TrainingSummary {
        classifier,
        classifier_kind: options.classifier_kind,
        used_per_class: samples.used_per_class.clone(),
        dropped_per_class: samples.dropped_per_class.clone(),
        cap_per_class: options.max_training_per_class,
        contested_voxels: samples.contested_voxels,
        background_threshold: background.threshold,
        body: background.body.clone(),
        region_label: background.air_class.map_or(0, |position| position as u8 + 1),
        dropped_as_air_per_class: background.dropped_per_class.clone(),
        air_is_a_class: background.air_is_a_class,
        features_seconds,
        train_seconds: started.elapsed().as_secs_f64(),
    };
    Ok(Segmenter {
        lassoed: samples.lassoed.clone(),
        feature_set,
        coherence: options.coherence,
        standardiser,
        classifier: trained,
        summary,
        samples,
        corrected_scan: None,
    })
}

/// g = 1 / (2 median of squared distances between distinct training vectors), over up to 4096
/// pairs chosen deterministically; 0.5 (snsvm.md's default) when every vector is the same.
/// Pairs of equal vectors are left out: a lasso in the air of an 8-bit scan holds hundreds of
/// identical vectors, whose zero distances would make the median tiny and the kernel a spike.
pub fn median_heuristic_width(values: &[f64], dim: usize) -> f64 {
    let count = values.len() / dim.max(1);
    if count < 2 {
        return 0.5;
    }
    let mut distances: Vec<f64> = (0..4096usize.min(count * (count - 1) / 2))
        .map(|k| {
            let i = crate::rng::hash64(k as u64, 1) as usize % count;
            let j = (i + 1 + crate::rng::hash64(k as u64, 2) as usize % (count - 1)) % count;
            let (a, b) = (&values[i * dim..(i + 1) * dim], &values[j * dim..(j + 1) * dim]);
            a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>()
        })
        .filter(|&distance| distance > 0.0)
        .collect();
    if distances.is_empty() {
        return 0.5;
    }
    let middle = distances.len() / 2;
    let (_, median, _) = distances.select_nth_unstable_by(middle, f64::total_cmp);
    if *median > 0.0 { 0.5 / *median } else { 0.5 }
}

/// A classified volume: one class id per voxel (0 = background), x fastest.
#[derive(Clone, Debug)]
pub struct LabelVolume {
    /// Size in voxels, (x, y, z).
    pub dims: [usize; 3],
    /// One class id per voxel, x fastest.
    pub labels: Vec<u8>,
    /// Voxels above the background threshold (labelled with a class).
    pub classified_voxels: usize,
    /// Voxels the classifier was evaluated on (fewer than `classified_voxels` when refined
    /// coarse-to-fine).
    pub evaluated_voxels: usize,
}

/// Classifies every voxel of `volume`. `progress` is called with the fraction done (0..=1)
/// from worker threads; setting `cancel` stops the work at the next slab.
pub fn label_volume(
    volume: &Volume,
    segmenter: &Segmenter,
    refinement: Refinement,
    progress: &(dyn Fn(f32) + Sync),
    cancel: &AtomicBool,
) -> Result<LabelVolume, SegmentationError> {
    volume.check_still_mapped()?;
    refine::label_volume(volume, segmenter, refinement, progress, cancel, None)
}

/// [`label_volume`], calling `preview` first with a coarse label volume: the classifier's
/// labels on every second voxel along each axis (the coarse grid coarse-to-fine labelling
/// computes first), each copied to the voxels nearest it, the air joined to the faces left out.
/// With [`Refinement::Exact`] or the multi-scale features, which label no coarse grid first,
/// `preview` is not called.
pub fn label_volume_with_preview(
    volume: &Volume,
    segmenter: &Segmenter,
    refinement: Refinement,
    progress: &(dyn Fn(f32) + Sync),
    cancel: &AtomicBool,
    preview: &(dyn Fn(&LabelVolume) + Sync),
) -> Result<LabelVolume, SegmentationError> {
    volume.check_still_mapped()?;
    refine::label_volume(volume, segmenter, refinement, progress, cancel, Some(preview))
}
