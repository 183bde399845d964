//! One-vs-one training over all pairs of classes (snsvm.md §7): checks the samples, trains one
//! binary SN-SVM per pair (in parallel), and assembles the [`Model`].
//!
//! Sign convention: t = +1 for the smaller class id of a pair, so f > 0 votes for it.
//! Entry points: [`train`] (the classes present) and [`train_with_classes`] (a defined class
//! list, which may reveal an empty class). Never: subsamples, standardises, or reads voxels;
//! the caller hands in standardised, subsampled samples.

use rayon::prelude::*;

use super::SampleMatrix;
use super::error::ClassifyError;
use super::model::{Model, ModelParts};
use super::params::SnSvmValidParams;
use super::snsvm::{BinaryProblem, PenaltySpectra, ScatterPath, train_binary};

/// Largest N = n_a + n_b of one pair. Training holds about six dense N x N f64 matrices
/// (snsvm.md §10): 8000 points is about 3 GB, the most a kiosk should attempt.
pub const MAX_POINTS_PER_PAIR: usize = 8000;

/// Two classes of one binary problem; f > 0 votes for `first` (the smaller id).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClassPair {
    /// The smaller class id; a positive decision value votes for it.
    pub first: u8,
    /// The larger class id.
    pub second: u8,
}

/// How one pair's training went.
#[derive(Debug, Clone, PartialEq)]
pub struct PairReport {
    /// The two classes of this binary problem.
    pub pair: ClassPair,
    /// N = n_first + n_second.
    pub points: usize,
    /// Training points with a non-zero dual coefficient (α > 0).
    pub support_vectors: usize,
    /// Support vectors strictly inside the box (0 < α < C).
    pub free_support_vectors: usize,
    /// SMO iterations run.
    pub iterations: usize,
    /// SMO stopped at the iteration cap before reaching the tolerance.
    pub hit_cap: bool,
    /// Dual objective at exit.
    pub objective: f64,
    /// w0.
    pub bias: f64,
    /// The spectral scales and β found while building this pair's penalty.
    pub spectra: PenaltySpectra,
}

/// How training went, per pair.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainReport {
    /// One report per class pair, in the model's pair order.
    pub pairs: Vec<PairReport>,
    /// Samples handed in.
    pub samples: usize,
    /// N_tot of the model after merging duplicates and dropping zero coefficients.
    pub expansion_points: usize,
}

impl TrainReport {
    /// Whether any pair's solver stopped at the iteration cap.
    pub fn hit_cap(&self) -> bool {
        self.pairs.iter().any(|pair| pair.hit_cap)
    }
}

/// Trains on the classes present in `labels` (ids >= 1).
pub fn train(samples: &SampleMatrix, labels: &[u8], params: &SnSvmValidParams) -> Result<Model, ClassifyError> {
    check_samples(samples, labels)?;
    let mut class_ids = labels.to_vec();
    class_ids.sort_unstable();
    class_ids.dedup();
    train_checked(samples, labels, class_ids, params)
}

/// Trains on a defined list of classes; a listed class without samples is an error.
pub fn train_with_classes(
    samples: &SampleMatrix,
    labels: &[u8],
    class_ids: &[u8],
    params: &SnSvmValidParams,
) -> Result<Model, ClassifyError> {
    check_samples(samples, labels)?;
    let mut sorted = class_ids.to_vec();
    sorted.sort_unstable();
    if sorted.first() == Some(&0) {
        return Err(ClassifyError::BackgroundClass);
    }
    if let Some(twin) = sorted.windows(2).find(|w| w[0] == w[1]) {
        return Err(ClassifyError::DuplicateClass { class_id: twin[0] });
    }
    if let Some((sample, &label)) = labels.iter().enumerate().find(|(_, label)| sorted.binary_search(label).is_err()) {
        return Err(ClassifyError::UnknownLabel { sample, label, class_ids: sorted });
    }
    train_checked(samples, labels, sorted, params)
}

fn check_samples(samples: &SampleMatrix, labels: &[u8]) -> Result<(), ClassifyError> {
    let dim = samples.dim;
    if dim == 0 {
        return Err(ClassifyError::ZeroDimension);
    }
    if samples.values.len() % dim != 0 {
        return Err(ClassifyError::RaggedSamples { values: samples.values.len(), dim });
    }
    let count = samples.values.len() / dim;
    if labels.len() != count {
        return Err(ClassifyError::LabelCount { labels: labels.len(), samples: count });
    }
    if let Some(sample) = labels.iter().position(|&label| label == 0) {
        return Err(ClassifyError::BackgroundLabel { sample });
    }
    if let Some(index) = samples.values.iter().position(|v| !v.is_finite()) {
        return Err(ClassifyError::NonFiniteSample {
            sample: index / dim,
            feature: index % dim,
            value: samples.values[index],
        });
    }
    Ok(())
}

/// `class_ids` sorted, unique, non-zero, and covering every label.
fn train_checked(
    samples: &SampleMatrix,
    labels: &[u8],
    class_ids: Vec<u8>,
    params: &SnSvmValidParams,
) -> Result<Model, ClassifyError> {
    let dim = samples.dim;
    let members: Vec<Vec<usize>> =
        class_ids.iter().map(|&id| (0..labels.len()).filter(|&i| labels[i] == id).collect()).collect();
    let present: Vec<u8> = class_ids.iter().zip(&members).filter(|(_, m)| !m.is_empty()).map(|(&id, _)| id).collect();
    if present.len() < 2 {
        return Err(ClassifyError::TooFewClasses { found: present.len(), class_ids: present });
    }
    if let Some(position) = members.iter().position(|m| m.is_empty()) {
        return Err(ClassifyError::EmptyClass { class_id: class_ids[position] });
    }
    let mut pair_positions = Vec::new();
    for a in 0..class_ids.len() {
        for b in a + 1..class_ids.len() {
            let points = members[a].len() + members[b].len();
            if points > MAX_POINTS_PER_PAIR {
                return Err(ClassifyError::PairTooLarge {
                    class_a: class_ids[a],
                    class_b: class_ids[b],
                    points,
                    limit: MAX_POINTS_PER_PAIR,
                });
            }
            pair_positions.push((a, b));
        }
    }
    let trained: Vec<(Vec<usize>, super::snsvm::BinaryModel)> = pair_positions
        .par_iter()
        .map(|&(a, b)| {
            let indices: Vec<usize> = members[a].iter().chain(&members[b]).copied().collect();
            let mut points = Vec::with_capacity(indices.len() * dim);
            for &i in &indices {
                points.extend_from_slice(&samples.values[i * dim..(i + 1) * dim]);
            }
            let first_class: Vec<bool> = (0..indices.len()).map(|k| k < members[a].len()).collect();
            let problem = BinaryProblem {
                points: &points,
                dim,
                first_class: &first_class,
                class_ids: (class_ids[a], class_ids[b]),
            };
            train_binary(&problem, params, ScatterPath::SkipWhenEtaIsZero).map(|model| (indices, model))
        })
        .collect::<Result<_, _>>()?;
    let pair_count = pair_positions.len();
    let mut coefficients = vec![0.0; labels.len() * pair_count];
    let mut biases = Vec::with_capacity(pair_count);
    let mut pairs = Vec::with_capacity(pair_count);
    let mut reports = Vec::with_capacity(pair_count);
    for (p, ((indices, model), &(a, b))) in trained.iter().zip(&pair_positions).enumerate() {
        for (&i, &g) in indices.iter().zip(&model.gamma) {
            coefficients[i * pair_count + p] = g;
        }
        let pair = ClassPair { first: class_ids[a], second: class_ids[b] };
        if model.report.hit_cap {
            log::warn!(
                "SMO for classes {} vs {} stopped at the iteration cap ({} steps) before reaching the tolerance; the model may be inaccurate",
                pair.first,
                pair.second,
                model.report.iterations
            );
        }
        log::debug!(
            "classes {} vs {}: {} points, {} support vectors, {} SMO steps, lambda_max(Nabla) {:.3e}, lambda_max(KR) {:.3e}",
            pair.first,
            pair.second,
            indices.len(),
            model.report.support_vectors,
            model.report.iterations,
            model.spectra.nabla_largest_eigenvalue,
            model.spectra.penalty_largest_eigenvalue
        );
        biases.push(model.bias);
        pairs.push(pair);
        reports.push(PairReport {
            pair,
            points: indices.len(),
            support_vectors: model.report.support_vectors,
            free_support_vectors: model.report.free_support_vectors,
            iterations: model.report.iterations,
            hit_cap: model.report.hit_cap,
            objective: model.report.objective,
            bias: model.bias,
            spectra: model.spectra,
        });
    }
    Ok(Model::assemble(ModelParts {
        dim,
        kernel: params.kernel,
        class_ids,
        pairs,
        points: samples.values.clone(),
        coefficients,
        biases,
        report: TrainReport { pairs: reports, samples: labels.len(), expansion_points: 0 },
    }))
}

/// One voxel's one-vs-one votes: each pair's decision value `values[p]` votes for the first
/// class of `pair_positions[p]` when positive, else for the second; `votes` and `strength`
/// (per class position, the votes won and the summed |f| of them) are overwritten.
pub fn tally_votes(pair_positions: &[(usize, usize)], values: &[f32], votes: &mut [u32], strength: &mut [f32]) {
    tally_votes_among(pair_positions, values, ClassSet::MAX, votes, strength);
}

/// A set of class positions: bit p is position p. Positions from [`CLASS_SET_CAPACITY`] up
/// are in every set.
pub type ClassSet = u64;

/// Class positions a [`ClassSet`] can tell apart.
pub const CLASS_SET_CAPACITY: usize = ClassSet::BITS as usize;

/// Whether class position `position` is in `set`.
pub fn class_set_contains(set: ClassSet, position: usize) -> bool {
    position >= CLASS_SET_CAPACITY || set >> position & 1 == 1
}

/// [`tally_votes`] with only the pairs of which both classes are in `allowed` voting.
pub fn tally_votes_among(
    pair_positions: &[(usize, usize)],
    values: &[f32],
    allowed: ClassSet,
    votes: &mut [u32],
    strength: &mut [f32],
) {
    votes.fill(0);
    strength.fill(0.0);
    for (&(first, second), &f) in pair_positions.iter().zip(values) {
        if !(class_set_contains(allowed, first) && class_set_contains(allowed, second)) {
            continue;
        }
        let winner = if f > 0.0 { first } else { second };
        votes[winner] += 1;
        strength[winner] += f.abs();
    }
}

/// Whether class position `a` ranks above `b` in the vote: more votes, or as many and a larger
/// summed |f|.
pub fn ranks_above(votes: &[u32], strength: &[f32], a: usize, b: usize) -> bool {
    votes[a] > votes[b] || votes[a] == votes[b] && strength[a] > strength[b]
}

/// The position of the class that wins the vote: the first that no later class ranks above.
pub fn vote_winner(votes: &[u32], strength: &[f32]) -> usize {
    (1..votes.len()).fold(0, |best, class| if ranks_above(votes, strength, class, best) { class } else { best })
}

#[cfg(test)]
mod tests;
