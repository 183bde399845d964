//! The one error type of the classify stage. Variants carry the facts as fields, so that the CLI
//! can print one sentence and a test can match on what went wrong.

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ClassifyError {
    #[error("classifier parameter {name} = {value} is invalid: it must be {requirement}")]
    InvalidParameter { name: &'static str, value: f64, requirement: &'static str },
    #[error("feature vectors must have at least one dimension, found 0")]
    ZeroDimension,
    #[error("{values} sample values are not a whole number of feature vectors of dimension {dim}")]
    RaggedSamples { values: usize, dim: usize },
    #[error("{labels} labels were given for {samples} samples")]
    LabelCount { labels: usize, samples: usize },
    #[error("sample {sample} has class id 0, which is reserved for background; class ids start at 1")]
    BackgroundLabel { sample: usize },
    #[error("class id 0 is reserved for background and cannot be a defined class")]
    BackgroundClass,
    #[error("class id {class_id} is listed twice among the defined classes")]
    DuplicateClass { class_id: u8 },
    #[error("sample {sample} has class id {label}, which is not among the defined classes {class_ids:?}")]
    UnknownLabel { sample: usize, label: u8, class_ids: Vec<u8> },
    #[error("feature {feature} of sample {sample} is {value}; features must be finite")]
    NonFiniteSample { sample: usize, feature: usize, value: f64 },
    #[error("training needs at least 2 classes with samples, found {found} (class ids {class_ids:?})")]
    TooFewClasses { found: usize, class_ids: Vec<u8> },
    #[error("class {class_id} has no samples; paint at least one voxel of it or remove it")]
    EmptyClass { class_id: u8 },
    #[error(
        "classes {class_a} and {class_b} have {points} training points together, more than the \
         limit of {limit}; subsample each class first (snsvm.md §9, n_max)"
    )]
    PairTooLarge { class_a: u8, class_b: u8, points: usize, limit: usize },
    #[error("training classes {class_a} vs {class_b} produced non-finite values in {stage}")]
    NumericalFailure { class_a: u8, class_b: u8, stage: &'static str },
    #[error("feature block of {values} values is not a whole number of feature vectors of dimension {dim}")]
    FeatureBlockShape { values: usize, dim: usize },
    #[error("output block holds {found} values but {expected} are needed")]
    OutputBlockShape { expected: usize, found: usize },
}
