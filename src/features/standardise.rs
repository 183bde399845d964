//! Standardisation of feature vectors: each feature shifted and scaled to zero mean and unit
//! standard deviation over the training vectors, so that a kernel width means the same in
//! every feature whatever its unit (HU, HU/mm).

use super::FeatureError;

/// Per-feature mean and standard deviation of the training vectors (population deviation;
/// a feature that is constant in training gets deviation 1, so it passes through centred).
#[derive(Clone, Debug, PartialEq)]
pub struct Standardiser {
    pub mean: Vec<f64>,
    pub std: Vec<f64>,
    /// The smallest and largest training value of each feature (before standardising).
    pub training_low: Vec<f64>,
    pub training_high: Vec<f64>,
}

impl Standardiser {
    /// Fits on row-major `vectors` of `dim` features. Refuses no vectors, a length that is not
    /// a multiple of `dim`, and NaN or infinite features (naming the vector and feature).
    pub fn fit(vectors: &[f32], dim: usize) -> Result<Standardiser, FeatureError> {
        if dim == 0 || vectors.is_empty() {
            return Err(FeatureError::NoVectors);
        }
        if vectors.len() % dim != 0 {
            return Err(FeatureError::Ragged { length: vectors.len(), dim });
        }
        if let Some(position) = vectors.iter().position(|v| !v.is_finite()) {
            return Err(FeatureError::NonFinite {
                vector: position / dim,
                feature: position % dim,
                value: vectors[position],
            });
        }
        let count = (vectors.len() / dim) as f64;
        let mut mean = vec![0f64; dim];
        for row in vectors.chunks_exact(dim) {
            for (m, &v) in mean.iter_mut().zip(row) {
                *m += v as f64;
            }
        }
        mean.iter_mut().for_each(|m| *m /= count);
        // Two passes: the centred sum of squares does not cancel catastrophically.
        let mut variance = vec![0f64; dim];
        for row in vectors.chunks_exact(dim) {
            for ((s, &v), m) in variance.iter_mut().zip(row).zip(&mean) {
                *s += (v as f64 - m).powi(2);
            }
        }
        let std = variance
            .into_iter()
            .map(|s| {
                let deviation = (s / count).sqrt();
                if deviation > 0.0 { deviation } else { 1.0 }
            })
            .collect();
        let mut training_low = vec![f64::INFINITY; dim];
        let mut training_high = vec![f64::NEG_INFINITY; dim];
        for row in vectors.chunks_exact(dim) {
            for (k, &v) in row.iter().enumerate() {
                training_low[k] = training_low[k].min(v as f64);
                training_high[k] = training_high[k].max(v as f64);
            }
        }
        Ok(Standardiser { mean, std, training_low, training_high })
    }

    /// Features per vector.
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// Standardised copies of row-major `vectors`, as `f64` (the classifier's training matrix).
    pub fn apply(&self, vectors: &[f32]) -> Result<Vec<f64>, FeatureError> {
        self.check(vectors)?;
        Ok(vectors
            .chunks_exact(self.dim())
            .flat_map(|row| row.iter().zip(&self.mean).zip(&self.std).map(|((&v, m), s)| (v as f64 - m) / s))
            .collect())
    }

    /// Standardises row-major `vectors` in place (prediction blocks), first clamping each
    /// feature to its training range. An RBF classifier cannot extrapolate: far from every
    /// training vector its decision falls back to the bias, so a voxel darker (or brighter)
    /// than anything lassoed would get an arbitrary class. Clamped, it goes with the class
    /// whose training vectors are the most extreme along that feature (measured on the demo
    /// phantom: soft tissue Dice 0.96 -> 0.98 and bone 0.89 -> 0.94, issue 3).
    pub fn apply_in_place(&self, vectors: &mut [f32]) -> Result<(), FeatureError> {
        self.check(vectors)?;
        let dim = self.dim();
        // The per-feature constants repeated over a run of rows, so that the loop over a run is
        // one flat, vectorisable pass (per-row loops of `dim` are not).
        const ROWS_PER_RUN: usize = 16;
        let repeat = |per_feature: &[f64], map: fn(f64) -> f32| -> Vec<f32> {
            per_feature.iter().map(|&v| map(v)).cycle().take(dim * ROWS_PER_RUN).collect()
        };
        let scale = repeat(&self.std, |s| (1.0 / s) as f32);
        let shift = repeat(&self.mean, |m| m as f32);
        let low = repeat(&self.training_low, |l| l as f32);
        let high = repeat(&self.training_high, |h| h as f32);
        let standardise = |run: &mut [f32]| {
            for (((v, low), high), (shift, scale)) in run.iter_mut().zip(&low).zip(&high).zip(shift.iter().zip(&scale))
            {
                *v = (v.clamp(*low, *high) - shift) * scale;
            }
        };
        let mut runs = vectors.chunks_exact_mut(dim * ROWS_PER_RUN);
        runs.by_ref().for_each(standardise);
        standardise(runs.into_remainder());
        Ok(())
    }

    fn check(&self, vectors: &[f32]) -> Result<(), FeatureError> {
        let dim = self.dim();
        if dim == 0 || vectors.len() % dim != 0 {
            return Err(FeatureError::Ragged { length: vectors.len(), dim });
        }
        Ok(())
    }
}
