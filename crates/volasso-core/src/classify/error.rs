//! The one error type of the classify stage. Variants carry the facts as fields, so that the CLI
//! can print one sentence and a test can match on what went wrong.

/// Why training or prediction refused its input or failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ClassifyError {
    /// A classifier parameter is out of its allowed range.
    #[error("classifier parameter {name} = {value} is invalid: it must be {requirement}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// The value given.
        value: f64,
        /// What it must be, in words.
        requirement: &'static str,
    },
    /// The feature vectors have no components.
    #[error("feature vectors must have at least one dimension, found 0")]
    ZeroDimension,
    /// The sample values do not divide into whole feature vectors.
    #[error("{values} sample values are not a whole number of feature vectors of dimension {dim}")]
    RaggedSamples {
        /// Number of values given.
        values: usize,
        /// Feature dimension.
        dim: usize,
    },
    /// The number of labels differs from the number of samples.
    #[error("{labels} labels were given for {samples} samples")]
    LabelCount {
        /// Labels given.
        labels: usize,
        /// Samples given.
        samples: usize,
    },
    /// A sample is labelled 0, the id reserved for background.
    #[error("sample {sample} has class id 0, which is reserved for background; class ids start at 1")]
    BackgroundLabel {
        /// Index of the sample.
        sample: usize,
    },
    /// Class id 0 (background) was listed as a defined class.
    #[error("class id 0 is reserved for background and cannot be a defined class")]
    BackgroundClass,
    /// A class id appears twice in the class list.
    #[error("class id {class_id} is listed twice among the defined classes")]
    DuplicateClass {
        /// The repeated id.
        class_id: u8,
    },
    /// A sample's label is not among the defined classes.
    #[error("sample {sample} has class id {label}, which is not among the defined classes {class_ids:?}")]
    UnknownLabel {
        /// Index of the sample.
        sample: usize,
        /// Its label.
        label: u8,
        /// The defined class ids.
        class_ids: Vec<u8>,
    },
    /// A feature value is NaN or infinite.
    #[error("feature {feature} of sample {sample} is {value}; features must be finite")]
    NonFiniteSample {
        /// Index of the sample.
        sample: usize,
        /// Index of the feature within the vector.
        feature: usize,
        /// The value found.
        value: f64,
    },
    /// Fewer than two classes have samples.
    #[error("training needs at least 2 classes with samples, found {found} (class ids {class_ids:?})")]
    TooFewClasses {
        /// Number of classes with samples.
        found: usize,
        /// Their ids.
        class_ids: Vec<u8>,
    },
    /// A defined class has no samples.
    #[error("class {class_id} has no samples; paint at least one voxel of it or remove it")]
    EmptyClass {
        /// The class's id.
        class_id: u8,
    },
    /// Two classes together have more training points than one binary problem may hold.
    #[error(
        "classes {class_a} and {class_b} have {points} training points together, more than the \
         limit of {limit}; subsample each class first (snsvm.md §9, n_max)"
    )]
    PairTooLarge {
        /// The first class's id.
        class_a: u8,
        /// The second class's id.
        class_b: u8,
        /// Training points of the two classes together.
        points: usize,
        /// The most points a pair may have.
        limit: usize,
    },
    /// Training a pair produced NaN or infinite values.
    #[error("training classes {class_a} vs {class_b} produced non-finite values in {stage}")]
    NumericalFailure {
        /// The first class's id.
        class_a: u8,
        /// The second class's id.
        class_b: u8,
        /// The quantity that went non-finite.
        stage: &'static str,
    },
    /// A block of features handed to prediction does not divide into whole vectors.
    #[error("feature block of {values} values is not a whole number of feature vectors of dimension {dim}")]
    FeatureBlockShape {
        /// Number of values in the block.
        values: usize,
        /// The model's feature dimension.
        dim: usize,
    },
    /// The output buffer handed to prediction has the wrong length.
    #[error("output block holds {found} values but {expected} are needed")]
    OutputBlockShape {
        /// Values needed (one per vector).
        expected: usize,
        /// Values the buffer holds.
        found: usize,
    },
}
