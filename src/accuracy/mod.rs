//! The accuracy harness: how well each classification method recovers known
//! materials from the lassos a simulated user draws.
//!
//! A [`Case`] is a procedural phantom with ground truth (8- and 16-bit, CT- and MRI-like: the
//! demo foot, [`crate::phantom::procedural`]); a [`Method`] is a feature set and classifier. For
//! each case, seed and method, [`evaluate`] draws lassos ([`user::draw_training`]: every truth
//! class lassoed, class id k + 1 for truth k), trains through the public pipeline
//! ([`segmentation::train`], [`segmentation::label_volume`]) and reports per-class and macro
//! Dice and the time from training to labels. Voxels left at label 0 (below the background
//! threshold) count as truth class 0, which is the darkest background in every phantom.
//!
//! Cases are split into those the defaults were tuned on ([`CaseRole::Tune`]) and held-out
//! ones ([`CaseRole::Check`]): other phantoms, and the tuning phantoms with noise and lasso
//! seeds never used while tuning.
//!
//! Never: changes what the pipeline does, or reads files.

pub mod report;
pub mod user;

use crate::classify::ForestParams;
use crate::features::FeatureSet;
use crate::phantom::{self, Phantom, procedural};
use crate::segmentation::{self, ClassifierKind, SegmentationError, SegmentationOptions};
use crate::volume::VolumeError;
use std::sync::atomic::AtomicBool;
use std::time::Instant;
pub use user::{UserModel, draw_training};

/// A phantom kind of the harness.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhantomKind {
    /// The demo foot, 16-bit CT: air, soft tissue, bone, joint space.
    Foot,
    /// 8-bit CT: air, soft tissue, organ, vessels, bone.
    Vessels,
    /// 16-bit MRI: background, scalp, skull, CSF, grey and white matter.
    Brain,
    /// 8-bit MRI: background, rind, flesh, membrane, core, seeds.
    Shells,
}

impl PhantomKind {
    pub const ALL: [PhantomKind; 4] =
        [PhantomKind::Foot, PhantomKind::Vessels, PhantomKind::Brain, PhantomKind::Shells];

    pub fn name(self) -> &'static str {
        match self {
            PhantomKind::Foot => "foot16",
            PhantomKind::Vessels => "vessels8",
            PhantomKind::Brain => "brain16",
            PhantomKind::Shells => "shells8",
        }
    }

    pub fn from_name(name: &str) -> Option<PhantomKind> {
        PhantomKind::ALL.into_iter().find(|kind| kind.name() == name)
    }

    /// Voxels of the full and of the quick (CI) version.
    pub fn dims(self, quick: bool) -> [usize; 3] {
        match (self, quick) {
            (PhantomKind::Foot, false) => phantom::DEMO_FOOT_DIMS,
            (PhantomKind::Foot, true) => [96, 64, 48],
            (PhantomKind::Vessels, false) => [160, 128, 96],
            (PhantomKind::Vessels, true) => [80, 64, 48],
            (PhantomKind::Brain, false) => [110, 130, 100],
            (PhantomKind::Brain, true) => [66, 78, 60],
            (PhantomKind::Shells, false) => [112, 112, 96],
            (PhantomKind::Shells, true) => [56, 56, 48],
        }
    }

    pub fn generate(self, dims: [usize; 3], seed: u64) -> Result<Phantom, VolumeError> {
        match self {
            PhantomKind::Foot => phantom::demo_foot_with(dims, seed),
            PhantomKind::Vessels => procedural::vessels_ct(dims, seed),
            PhantomKind::Brain => procedural::brain_mri(dims, seed),
            PhantomKind::Shells => procedural::shells_mri(dims, seed),
        }
    }
}

/// Whether a case served to choose the defaults or only to check them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CaseRole {
    Tune,
    Check,
}

/// One phantom at one seed (the seed drives both the phantom's noise and the lassos).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Case {
    pub kind: PhantomKind,
    pub seed: u64,
}

impl Case {
    /// Tuning used the foot and the vessels at seeds 1 to 4; everything else is held out.
    pub fn role(&self) -> CaseRole {
        match (self.kind, self.seed) {
            (PhantomKind::Foot | PhantomKind::Vessels, 1..=4) => CaseRole::Tune,
            _ => CaseRole::Check,
        }
    }
}

/// A feature set and classifier to compare.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The paper: SN-SVM (eta = 0.3) on the 5-D features.
    SnSvmPaper5,
    /// Plain RBF SVM on the 5-D features.
    SvmPaper5,
    /// Random forest on the 5-D features.
    ForestPaper5,
    /// Plain RBF SVM on the multi-scale features.
    SvmMultiscale,
    /// SN-SVM on the multi-scale features.
    SnSvmMultiscale,
    /// Random forest on the multi-scale features.
    ForestMultiscale,
    /// Random forest on the fine multi-scale features.
    ForestMultiscaleFine,
    /// `SegmentationOptions::default()`, whatever it is.
    Default,
}

impl Method {
    pub const ALL: [Method; 8] = [
        Method::SnSvmPaper5,
        Method::SvmPaper5,
        Method::ForestPaper5,
        Method::SvmMultiscale,
        Method::SnSvmMultiscale,
        Method::ForestMultiscale,
        Method::ForestMultiscaleFine,
        Method::Default,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Method::SnSvmPaper5 => "snsvm-paper5",
            Method::SvmPaper5 => "svm-paper5",
            Method::ForestPaper5 => "forest-paper5",
            Method::SvmMultiscale => "svm-multiscale",
            Method::SnSvmMultiscale => "snsvm-multiscale",
            Method::ForestMultiscale => "forest-multiscale",
            Method::ForestMultiscaleFine => "forest-fine",
            Method::Default => "default",
        }
    }

    pub fn from_name(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }

    pub fn options(self) -> SegmentationOptions {
        let svm = |feature_set, eta| SegmentationOptions {
            feature_set,
            classifier_kind: ClassifierKind::SnSvm,
            classifier: crate::classify::SnSvmParams { eta, ..crate::classify::SnSvmParams::default() },
            ..SegmentationOptions::default()
        };
        let forest = |feature_set| SegmentationOptions {
            feature_set,
            classifier_kind: ClassifierKind::Forest(ForestParams::default()),
            ..SegmentationOptions::default()
        };
        match self {
            Method::SnSvmPaper5 => SegmentationOptions::paper(),
            Method::SvmPaper5 => svm(FeatureSet::Paper5, 0.0),
            Method::ForestPaper5 => forest(FeatureSet::Paper5),
            Method::SvmMultiscale => svm(FeatureSet::Multiscale, 0.0),
            Method::SnSvmMultiscale => svm(FeatureSet::Multiscale, 0.3),
            Method::ForestMultiscale => forest(FeatureSet::Multiscale),
            Method::ForestMultiscaleFine => forest(FeatureSet::MultiscaleFine),
            Method::Default => SegmentationOptions::default(),
        }
    }
}

/// One method's result on one case.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub case: Case,
    pub method: Method,
    pub class_names: Vec<&'static str>,
    /// Dice per truth class.
    pub dice: Vec<f64>,
    /// Training voxels per class.
    pub training_voxels: Vec<usize>,
    /// Training (features included) and labelling the whole phantom.
    pub seconds: f64,
}

impl Outcome {
    pub fn macro_dice(&self) -> f64 {
        self.dice.iter().sum::<f64>() / self.dice.len().max(1) as f64
    }
}

/// What can stop the harness.
#[derive(Debug, thiserror::Error)]
pub enum AccuracyError {
    #[error("cannot generate phantom {phantom}: {source}")]
    Phantom { phantom: &'static str, source: VolumeError },
    #[error("{method} on {phantom} seed {seed}: {source}")]
    Segmentation { method: &'static str, phantom: &'static str, seed: u64, source: SegmentationError },
}

/// Runs every method on every case; `quick` uses the small phantoms. Cases run one after
/// another (each method is itself parallel), so timings are comparable.
pub fn evaluate(
    cases: &[Case],
    methods: &[Method],
    user: &UserModel,
    quick: bool,
    mut on_outcome: impl FnMut(&Outcome),
) -> Result<Vec<Outcome>, AccuracyError> {
    let mut outcomes = Vec::new();
    for case in cases {
        let phantom = case
            .kind
            .generate(case.kind.dims(quick), case.seed)
            .map_err(|source| AccuracyError::Phantom { phantom: case.kind.name(), source })?;
        let training = draw_training(&phantom, user, crate::rng::hash64(case.seed, 0x0001_A550));
        // Computed once per volume, as when a volume is opened: every method's time then
        // leaves it out alike.
        phantom.volume.otsu_threshold();
        for &method in methods {
            let error = |source| AccuracyError::Segmentation {
                method: method.name(),
                phantom: case.kind.name(),
                seed: case.seed,
                source,
            };
            let options = method.options();
            let started = Instant::now();
            let segmenter = segmentation::train(&phantom.volume, &training, &options).map_err(error)?;
            let cancel = AtomicBool::new(false);
            let labels = segmentation::label_volume(&phantom.volume, &segmenter, options.refinement, &|_| {}, &cancel)
                .map_err(error)?;
            let seconds = started.elapsed().as_secs_f64();
            // Label k is truth class k - 1; unclassified voxels are background.
            let predicted: Vec<u8> = labels.labels.iter().map(|&l| l.saturating_sub(1)).collect();
            let dice =
                (0..phantom.class_names.len() as u8).map(|c| phantom::dice(&phantom.truth, &predicted, c)).collect();
            let outcome = Outcome {
                case: *case,
                method,
                class_names: phantom.class_names.clone(),
                dice,
                training_voxels: training.classes.iter().map(|c| c.voxels.len()).collect(),
                seconds,
            };
            on_outcome(&outcome);
            outcomes.push(outcome);
        }
    }
    Ok(outcomes)
}
