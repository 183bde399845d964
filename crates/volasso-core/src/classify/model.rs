//! The trained one-vs-one model in the shape prediction wants (snsvm.md §7, "prediction"):
//! the union of expansion points X (N_tot x dim), the coefficient matrix Γ (N_tot x P, column p
//! holding pair p's γ, zero where a point is not in the pair) and the biases w0 (P). Every
//! decision value of every voxel is then one row of k(voxels, X) Γ + w0, a block product that a
//! GPU can take over unchanged.
//!
//! Identical training vectors are merged (their Γ rows summed, exact because their kernel
//! columns are equal) and points with an all-zero Γ row (non-support vectors of the plain SVM)
//! are dropped, so N_tot can be well below the number of samples.
//! Never: trains, or knows about volumes or voxel indices.

use std::collections::HashMap;

use super::error::ClassifyError;
use super::kernel::Kernel;
use super::ovo::{ClassPair, TrainReport};

/// A trained one-vs-one SN-SVM. `Send + Sync`: prediction only reads it.
#[derive(Debug, Clone)]
pub struct Model {
    pub(crate) dim: usize,
    pub(crate) kernel: Kernel,
    /// Sorted class ids; pair votes index into this.
    pub(crate) class_ids: Vec<u8>,
    pub(crate) pairs: Vec<ClassPair>,
    /// For each pair, the positions of its two classes in `class_ids`.
    pub(crate) pair_positions: Vec<(usize, usize)>,
    /// f64 originals of `training_points`, `coefficients`, `biases` (for exact evaluation).
    pub(crate) points_exact: Vec<f64>,
    pub(crate) coefficients_exact: Vec<f64>,
    pub(crate) biases_exact: Vec<f64>,
    /// N_tot x dim, row-major.
    pub(crate) training_points: Vec<f32>,
    /// N_tot x P, row-major (Γ).
    pub(crate) coefficients: Vec<f32>,
    /// P.
    pub(crate) biases: Vec<f32>,
    pub(crate) report: TrainReport,
}

/// What training hands to [`Model::assemble`]: per-sample coefficients before merging.
pub(crate) struct ModelParts {
    pub dim: usize,
    pub kernel: Kernel,
    pub class_ids: Vec<u8>,
    pub pairs: Vec<ClassPair>,
    /// n x dim samples.
    pub points: Vec<f64>,
    /// n x P, row-major.
    pub coefficients: Vec<f64>,
    pub biases: Vec<f64>,
    pub report: TrainReport,
}

/// Bits of a coordinate with -0.0 folded onto 0.0, so that equal values hash equal.
fn key_bits(value: f64) -> u64 {
    (value + 0.0).to_bits()
}

impl Model {
    pub(crate) fn assemble(parts: ModelParts) -> Model {
        let ModelParts { dim, kernel, class_ids, pairs, points, coefficients, biases, mut report } = parts;
        let pair_count = pairs.len();
        let mut unique_of: HashMap<Vec<u64>, usize> = HashMap::new();
        let mut points_exact = Vec::new();
        let mut coefficients_exact: Vec<f64> = Vec::new();
        for (point, row) in points.chunks_exact(dim).zip(coefficients.chunks_exact(pair_count)) {
            if row.iter().all(|&g| g == 0.0) {
                continue;
            }
            let key: Vec<u64> = point.iter().map(|&v| key_bits(v)).collect();
            let next = unique_of.len();
            let index = *unique_of.entry(key).or_insert(next);
            if index == next {
                points_exact.extend_from_slice(point);
                coefficients_exact.extend_from_slice(row);
            } else {
                let target = &mut coefficients_exact[index * pair_count..(index + 1) * pair_count];
                for (t, g) in target.iter_mut().zip(row) {
                    *t += g;
                }
            }
        }
        let count = unique_of.len();
        report.expansion_points = count;
        let training_points: Vec<f32> = points_exact.iter().map(|&v| v as f32).collect();
        let coefficients_f32: Vec<f32> = coefficients_exact.iter().map(|&v| v as f32).collect();
        let position = |id: u8| class_ids.iter().position(|&c| c == id).unwrap_or(0);
        let pair_positions = pairs.iter().map(|pair| (position(pair.first), position(pair.second))).collect();
        Model {
            dim,
            kernel,
            pair_positions,
            class_ids,
            pairs,
            biases: biases.iter().map(|&b| b as f32).collect(),
            biases_exact: biases,
            points_exact,
            coefficients_exact,
            training_points,
            coefficients: coefficients_f32,
            report,
        }
    }

    /// The model without the expansion points whose every coefficient is at most
    /// `relative_threshold` times the largest |coefficient| of its pair (snsvm.md §5, option 3).
    /// SN-SVM's γ is dense (every training point contributes), but most of it is tiny; pruning
    /// it makes prediction cost close to a plain SVM's. The decision changes by at most the
    /// dropped |γ| summed (each kernel value is at most 1); callers report the labels that differ.
    pub fn pruned(&self, relative_threshold: f64) -> Model {
        let pair_count = self.pairs.len();
        let mut column_max = vec![0f64; pair_count];
        for row in self.coefficients_exact.chunks_exact(pair_count.max(1)) {
            for (m, g) in column_max.iter_mut().zip(row) {
                *m = m.max(g.abs());
            }
        }
        let mut points = Vec::new();
        let mut coefficients = Vec::new();
        for (point, row) in
            self.points_exact.chunks_exact(self.dim).zip(self.coefficients_exact.chunks_exact(pair_count.max(1)))
        {
            if row.iter().zip(&column_max).any(|(g, m)| g.abs() > relative_threshold * m) {
                points.extend_from_slice(point);
                coefficients.extend_from_slice(row);
            }
        }
        Model::assemble(ModelParts {
            dim: self.dim,
            kernel: self.kernel,
            class_ids: self.class_ids.clone(),
            pairs: self.pairs.clone(),
            points,
            coefficients,
            biases: self.biases_exact.clone(),
            report: self.report.clone(),
        })
    }

    /// Feature dimension.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The kernel the model was trained with.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// The classes, sorted ascending.
    pub fn class_ids(&self) -> &[u8] {
        &self.class_ids
    }

    /// The P pairs, in the column order of [`Model::coefficients`]; f > 0 votes for `first`.
    pub fn pairs(&self) -> &[ClassPair] {
        &self.pairs
    }

    /// N_tot, the number of expansion points.
    pub fn training_point_count(&self) -> usize {
        self.training_points.len() / self.dim
    }

    /// X: N_tot x dim, row-major, f32.
    pub fn training_points(&self) -> &[f32] {
        &self.training_points
    }

    /// Γ: N_tot x P, row-major, f32.
    pub fn coefficients(&self) -> &[f32] {
        &self.coefficients
    }

    /// w0 per pair.
    pub fn biases(&self) -> &[f32] {
        &self.biases
    }

    /// How training went, per pair.
    pub fn report(&self) -> &TrainReport {
        &self.report
    }

    /// Decision values of one feature vector in f64 from the f64 coefficients, one per pair:
    /// the reference that the f32 block path is tested against.
    pub fn decision_values_exact(&self, x: &[f64]) -> Result<Vec<f64>, ClassifyError> {
        if x.len() != self.dim {
            return Err(ClassifyError::FeatureBlockShape { values: x.len(), dim: self.dim });
        }
        let pair_count = self.pairs.len();
        let mut out = self.biases_exact.clone();
        for (point, row) in
            self.points_exact.chunks_exact(self.dim).zip(self.coefficients_exact.chunks_exact(pair_count))
        {
            let k = self.kernel.value(x, point);
            for (o, g) in out.iter_mut().zip(row) {
                *o += k * g;
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn duplicates_merge_and_zero_rows_drop_exactly() {
        let pairs = vec![
            ClassPair { first: 1, second: 2 },
            ClassPair { first: 1, second: 3 },
            ClassPair { first: 2, second: 3 },
        ];
        let points = vec![0.5, -1.0, 2.0, 0.0, 0.5, -1.0, 3.0, 3.0, 2.0, -0.0];
        let coefficients = vec![
            0.25, 0.0, -1.0, // a
            1.5, 0.5, 0.0, // b
            0.5, -2.0, 0.75, // a again
            0.0, 0.0, 0.0, // never a support vector
            0.0, 1.0, 0.0, // b again, with -0.0
        ];
        let model = Model::assemble(ModelParts {
            dim: 2,
            kernel: Kernel::Rbf { width: 0.3 },
            class_ids: vec![1, 2, 3],
            pairs,
            points: points.clone(),
            coefficients: coefficients.clone(),
            biases: vec![0.1, -0.2, 0.3],
            report: TrainReport { pairs: Vec::new(), samples: 5, expansion_points: 0 },
        });
        assert_eq!(model.training_point_count(), 2);
        assert_eq!(model.report().expansion_points, 2);
        assert_eq!(model.coefficients(), &[0.75, -2.0, -0.25, 1.5, 1.5, 0.0]);
        assert_eq!(model.pair_positions, vec![(0, 1), (0, 2), (1, 2)]);
        let x = [0.1, 0.7];
        let mut expected = vec![0.1, -0.2, 0.3];
        for (point, row) in points.chunks_exact(2).zip(coefficients.chunks_exact(3)) {
            let k = model.kernel().value(&x, point);
            for (e, g) in expected.iter_mut().zip(row) {
                *e += k * g;
            }
        }
        let exact = model.decision_values_exact(&x).unwrap();
        for (a, b) in exact.iter().zip(&expected) {
            assert!((a - b).abs() < 1e-15);
        }
    }
}
