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
        let scale: Vec<f32> = self.std.iter().map(|s| (1.0 / s) as f32).collect();
        let shift: Vec<f32> = self.mean.iter().map(|&m| m as f32).collect();
        let low: Vec<f32> = self.training_low.iter().map(|&l| l as f32).collect();
        let high: Vec<f32> = self.training_high.iter().map(|&h| h as f32).collect();
        for row in vectors.chunks_exact_mut(dim) {
            for (k, v) in row.iter_mut().enumerate() {
                *v = (v.clamp(low[k], high[k]) - shift[k]) * scale[k];
            }
        }
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
