//! The accuracy harness: how well each classification method recovers known materials from
//! the lassos a simulated user draws.
//!
//! A [`Case`] is a procedural phantom with ground truth at one seed (8- and 16-bit, CT- and
//! MRI-like, thin vessels and large organs, air around bodies and bodies cut by the volume's
//! faces: the demo foot, [`crate::phantom::procedural`], [`crate::phantom::bodies`]); a
//! [`Method`] is a feature set and classifier; a [`Hand`] is how precisely the simulated user
//! draws: cleanly inside each structure, or leaking over its border by a finger's width. For
//! each case, hand and method, [`evaluate`] draws lassos ([`user::draw_training`]), trains
//! through the public pipeline ([`pipeline::classify_training`]) and
//! reports per-class and macro Dice and the time from training to labels.
//!
//! Every truth class is lassoed, air included (class id k + 1 for truth k), unless the user
//! model says the air is left alone (then truth k >= 1 is class id k, and the air must come out
//! as background, label 0). Voxels left at label 0 count as truth class 0, the darkest
//! background in every phantom.
//!
//! Cases are split by seed ([`Case::role`]): seeds 1 to 4 are [`CaseRole::Tune`] (free to look
//! at while choosing constants), seeds 5 and above are [`CaseRole::Check`] (they decide the
//! defaults and are not looked at while tuning).
//!
//! Never: changes what the pipeline does, or reads files.

pub mod report;
pub mod user;

use crate::classify::ForestParams;
use crate::features::FeatureSet;
use crate::phantom::{self, Phantom, bodies, procedural};
use crate::pipeline::{self, RunControl};
use crate::segmentation::{self, ClassifierKind, SegmentationError, SegmentationOptions};
use crate::strokes::TrainingSet;
use crate::volume::VolumeError;
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
    /// 16-bit CT: air, soft tissue, liver, vessels, bone, lungs; the body cut by the faces.
    Torso,
    /// 8-bit MRI with a strong bias: background, scalp, skull, CSF, brain, a neck cut by a face.
    Head,
}

impl PhantomKind {
    /// Every phantom, in report order.
    pub const ALL: [PhantomKind; 6] = [
        PhantomKind::Foot,
        PhantomKind::Vessels,
        PhantomKind::Brain,
        PhantomKind::Shells,
        PhantomKind::Torso,
        PhantomKind::Head,
    ];

    /// The phantom's name in reports and on the command line (`foot16`, `head8`, ...).
    pub fn name(self) -> &'static str {
        match self {
            PhantomKind::Foot => "foot16",
            PhantomKind::Vessels => "vessels8",
            PhantomKind::Brain => "brain16",
            PhantomKind::Shells => "shells8",
            PhantomKind::Torso => "torso16",
            PhantomKind::Head => "head8",
        }
    }

    /// Whether the phantom is an MRI scan (its shading is divided out, as the kiosk does for an
    /// MR series: `crate::volume::shading`).
    pub fn is_mr(self) -> bool {
        matches!(self, PhantomKind::Brain | PhantomKind::Shells | PhantomKind::Head)
    }

    /// The phantom of a [`name`](Self::name), if any.
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
            (PhantomKind::Torso, false) => [160, 128, 96],
            (PhantomKind::Torso, true) => [80, 64, 48],
            (PhantomKind::Head, false) => [120, 144, 136],
            (PhantomKind::Head, true) => [60, 72, 68],
        }
    }

    /// The phantom of `dims` voxels with its noise drawn from `seed`.
    pub fn generate(self, dims: [usize; 3], seed: u64) -> Result<Phantom, VolumeError> {
        match self {
            PhantomKind::Foot => phantom::demo_foot_with(dims, seed),
            PhantomKind::Vessels => procedural::vessels_ct(dims, seed),
            PhantomKind::Brain => procedural::brain_mri(dims, seed),
            PhantomKind::Shells => procedural::shells_mri(dims, seed),
            PhantomKind::Torso => bodies::torso_ct(dims, seed),
            PhantomKind::Head => bodies::head_mri(dims, seed),
        }
    }
}

/// Whether a case served to choose the defaults or only to check them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CaseRole {
    /// Seed at most [`LAST_TUNING_SEED`]: the defaults were chosen on such cases.
    Tune,
    /// A later seed: such cases never chose anything, they only check.
    Check,
}

/// One phantom at one seed (the seed drives both the phantom's noise and the lassos).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Case {
    /// The phantom.
    pub kind: PhantomKind,
    /// Seed of the phantom's noise and of the simulated lassos.
    pub seed: u64,
}

impl Case {
    /// Seeds 1 to 4 (and 0) are for tuning; seeds 5 and above check (module doc).
    pub fn role(&self) -> CaseRole {
        if self.seed <= LAST_TUNING_SEED { CaseRole::Tune } else { CaseRole::Check }
    }
}

/// The last seed of the tuning cases.
pub const LAST_TUNING_SEED: u64 = 4;

/// How precisely the simulated user draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hand {
    /// Lassos stay two pixels inside each structure ([`UserModel::default`]).
    Clean,
    /// Loops drawn around a structure at a finger's precision: they reach up to
    /// [`LEAK_PIXELS`] beyond its border, into its neighbours and the air.
    Leaky,
}

/// How far a leaky lasso reaches beyond a structure's border: a fingertip's wobble on a
/// 256-voxel slice is one to two voxels.
pub const LEAK_PIXELS: u32 = 2;

impl Hand {
    /// Both hands, in report order.
    pub const ALL: [Hand; 2] = [Hand::Clean, Hand::Leaky];

    /// The hand's name in reports and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Hand::Clean => "clean",
            Hand::Leaky => "leaky",
        }
    }

    /// The hand of a [`name`](Self::name), if any.
    pub fn from_name(name: &str) -> Option<Hand> {
        Hand::ALL.into_iter().find(|hand| hand.name() == name)
    }

    /// `base` drawn by this hand.
    pub fn user(self, base: &UserModel) -> UserModel {
        match self {
            Hand::Clean => UserModel { sloppy_pixels: 0, ..*base },
            Hand::Leaky => UserModel { sloppy_pixels: LEAK_PIXELS, ..*base },
        }
    }
}

/// A feature set and classifier to compare.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The paper: SN-SVM (eta = 0.3) on the 5-D features, each pair of classes standardised on
    /// its own ([`SegmentationOptions::paper`]).
    SnSvmPaper5,
    /// The same with one standardisation for all classes.
    SnSvmPaper5Global,
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
    /// `SegmentationOptions::default()`, whatever it is (the paper's method with a majority
    /// pass after labelling).
    Default,
    /// The default without its majority pass: the classifier's vote voxel by voxel.
    DefaultVoxelwise,
    /// The default (SN-SVM, majority pass) on the fine multi-scale features.
    DefaultFine,
}

impl Method {
    /// Every method, in report order.
    pub const ALL: [Method; 11] = [
        Method::SnSvmPaper5,
        Method::SnSvmPaper5Global,
        Method::SvmPaper5,
        Method::ForestPaper5,
        Method::SvmMultiscale,
        Method::SnSvmMultiscale,
        Method::ForestMultiscale,
        Method::ForestMultiscaleFine,
        Method::Default,
        Method::DefaultVoxelwise,
        Method::DefaultFine,
    ];

    /// The method's name in reports and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::SnSvmPaper5 => "snsvm-paper5",
            Method::SnSvmPaper5Global => "snsvm-global",
            Method::SvmPaper5 => "svm-paper5",
            Method::ForestPaper5 => "forest-paper5",
            Method::SvmMultiscale => "svm-multiscale",
            Method::SnSvmMultiscale => "snsvm-multiscale",
            Method::ForestMultiscale => "forest-multiscale",
            Method::ForestMultiscaleFine => "forest-fine",
            Method::Default => "default",
            Method::DefaultVoxelwise => "default-voxelwise",
            Method::DefaultFine => "default-fine",
        }
    }

    /// The method of a [`name`](Self::name), if any.
    pub fn from_name(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The segmentation options that run this method.
    pub fn options(self) -> SegmentationOptions {
        let svm = |feature_set, eta| SegmentationOptions {
            feature_set,
            classifier_kind: ClassifierKind::SnSvm,
            classifier: crate::classify::SnSvmParams { eta, ..crate::classify::SnSvmParams::default() },
            coherence: segmentation::Coherence::None,
            ..SegmentationOptions::default()
        };
        let forest = |feature_set| SegmentationOptions {
            feature_set,
            classifier_kind: ClassifierKind::Forest(ForestParams::default()),
            coherence: segmentation::Coherence::None,
            ..SegmentationOptions::default()
        };
        match self {
            Method::SnSvmPaper5 => SegmentationOptions::paper(),
            Method::SnSvmPaper5Global => SegmentationOptions {
                standardisation: segmentation::Standardisation::Global,
                ..SegmentationOptions::paper()
            },
            Method::SvmPaper5 => svm(FeatureSet::Paper5, 0.0),
            Method::ForestPaper5 => forest(FeatureSet::Paper5),
            Method::SvmMultiscale => svm(FeatureSet::Multiscale, 0.0),
            Method::SnSvmMultiscale => svm(FeatureSet::Multiscale, 0.3),
            Method::ForestMultiscale => forest(FeatureSet::Multiscale),
            Method::ForestMultiscaleFine => forest(FeatureSet::MultiscaleFine),
            Method::Default => SegmentationOptions::default(),
            Method::DefaultVoxelwise => {
                SegmentationOptions { coherence: segmentation::Coherence::None, ..SegmentationOptions::default() }
            }
            Method::DefaultFine => {
                SegmentationOptions { feature_set: FeatureSet::MultiscaleFine, ..SegmentationOptions::default() }
            }
        }
    }
}

/// One method's result on one case.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// The phantom and seed.
    pub case: Case,
    /// How the lassos were drawn.
    pub hand: Hand,
    /// The feature set and classifier.
    pub method: Method,
    /// The phantom's truth classes, in label order.
    pub class_names: Vec<&'static str>,
    /// Dice per truth class.
    pub dice: Vec<f64>,
    /// Training voxels per class.
    pub training_voxels: Vec<usize>,
    /// Training (features included) and labelling the whole phantom.
    pub seconds: f64,
}

impl Outcome {
    /// The mean of the per-class Dice scores (0 with no classes).
    pub fn macro_dice(&self) -> f64 {
        self.dice.iter().sum::<f64>() / self.dice.len().max(1) as f64
    }
}

/// What can stop the harness.
#[derive(Debug, thiserror::Error)]
pub enum AccuracyError {
    /// Generating a phantom failed.
    #[error("cannot generate phantom {phantom}: {source}")]
    Phantom {
        /// The phantom's name.
        phantom: &'static str,
        /// Why.
        source: VolumeError,
    },
    /// A method failed to train or label on a case.
    #[error("{method} on {phantom} seed {seed}: {source}")]
    Segmentation {
        /// The method's name.
        method: &'static str,
        /// The phantom's name.
        phantom: &'static str,
        /// The case's seed.
        seed: u64,
        /// Why.
        source: SegmentationError,
    },
}

/// Runs every method on every case with every hand; `quick` uses the small phantoms. Cases
/// run one after another (each method is itself parallel), so timings are comparable.
/// `on_training` sees each phantom and the lassos drawn on it before the methods run (to
/// export them); `on_outcome` sees each result as it comes, with the truth class it predicts
/// for every voxel of the phantom.
pub fn evaluate(
    cases: &[Case],
    methods: &[Method],
    hands: &[Hand],
    user: &UserModel,
    quick: bool,
    mut on_training: impl FnMut(&Case, Hand, &Phantom, &TrainingSet),
    mut on_outcome: impl FnMut(&Outcome, &[u8]),
) -> Result<Vec<Outcome>, AccuracyError> {
    let mut outcomes = Vec::new();
    for case in cases {
        let phantom = case
            .kind
            .generate(case.kind.dims(quick), case.seed)
            .map_err(|source| AccuracyError::Phantom { phantom: case.kind.name(), source })?;
        // Computed once per volume, as when a volume is opened: every method's time then
        // leaves it out alike.
        phantom.volume.otsu_threshold();
        for &hand in hands {
            let user = hand.user(user);
            let training = draw_training(&phantom, &user, crate::rng::hash64(case.seed, 0x0001_A550));
            on_training(case, hand, &phantom, &training);
            for &method in methods {
                let (outcome, predicted) = run_method(&phantom, &training, &user, *case, hand, method)?;
                on_outcome(&outcome, &predicted);
                outcomes.push(outcome);
            }
        }
    }
    Ok(outcomes)
}

/// Truth class of each label: with the air lassoed, label k is truth k - 1 and label 0 (not
/// classified) is the air too; without, label k is truth k.
pub fn truth_of_label(label: u8, user: &UserModel) -> u8 {
    if user.lasso_background { label.saturating_sub(1) } else { label }
}

fn run_method(
    phantom: &Phantom,
    training: &TrainingSet,
    user: &UserModel,
    case: Case,
    hand: Hand,
    method: Method,
) -> Result<(Outcome, Vec<u8>), AccuracyError> {
    let error = |source| AccuracyError::Segmentation {
        method: method.name(),
        phantom: case.kind.name(),
        seed: case.seed,
        source,
    };
    let options = SegmentationOptions { correct_shading: case.kind.is_mr(), ..method.options() };
    let started = Instant::now();
    let (_, labels) =
        pipeline::classify_training(&phantom.volume, training, &options, RunControl::batch()).map_err(error)?;
    let seconds = started.elapsed().as_secs_f64();
    let predicted: Vec<u8> = labels.labels.iter().map(|&l| truth_of_label(l, user)).collect();
    let dice = (0..phantom.class_names.len() as u8).map(|c| phantom::dice(&phantom.truth, &predicted, c)).collect();
    let outcome = Outcome {
        case,
        hand,
        method,
        class_names: phantom.class_names.clone(),
        dice,
        training_voxels: training.classes.iter().map(|c| c.voxels.len()).collect(),
        seconds,
    };
    Ok((outcome, predicted))
}
