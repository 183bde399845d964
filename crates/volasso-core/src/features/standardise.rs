//! Standardisation of feature vectors: each feature shifted and scaled to zero mean and unit
//! standard deviation over the training vectors, so that a kernel width means the same in
//! every feature whatever its unit (HU, HU/mm).

use super::FeatureError;

/// Per-feature mean and standard deviation of the training vectors (population deviation;
/// a feature that is constant in training gets deviation 1, so it passes through centred).
#[derive(Clone, Debug, PartialEq)]
pub struct Standardiser {
    /// Mean of each feature over the training vectors.
    pub mean: Vec<f64>,
    /// Population standard deviation of each feature (1 where the feature is constant).
    pub std: Vec<f64>,
    /// The smallest training value of each feature (before standardising).
    pub training_low: Vec<f64>,
    /// The largest training value of each feature (before standardising).
    pub training_high: Vec<f64>,
}

/// How a feature set's vectors are standardised for the classifier's distance: each feature's
/// weight, and the feature whose deviation is its unit ([`Standardiser::in_units_of`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Scaling {
    /// Each feature's weight in the distance between standardised vectors
    /// ([`Standardiser::weighted`]).
    pub weights: Vec<f64>,
    /// For each feature, the feature whose deviation scales it (its own index for most).
    pub unit_of: Vec<usize>,
}

impl Scaling {
    /// Each feature at `weights[k]`, scaled by its own deviation.
    pub fn weighted(weights: Vec<f64>) -> Scaling {
        let unit_of = (0..weights.len()).collect();
        Scaling { weights, unit_of }
    }

    /// Features per vector.
    pub fn dim(&self) -> usize {
        self.weights.len()
    }

    /// Fits a [`Standardiser`] on row-major `vectors` of [`dim`](Self::dim) features (as
    /// [`Standardiser::fit`]), with this scaling's units and weights.
    pub fn fit(&self, vectors: &[f32]) -> Result<Standardiser, FeatureError> {
        Ok(Standardiser::fit(vectors, self.dim())?.in_units_of(&self.unit_of).weighted(&self.weights))
    }
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

    /// The same standardisation with feature k scaled by the deviation of feature
    /// `unit_of[k]` instead of its own: for a feature that is measured in another's units and
    /// should keep their scale (the gap depth is a difference of intensities). Indices of
    /// another length than the features, or out of range, leave it as it is.
    pub fn in_units_of(mut self, unit_of: &[usize]) -> Standardiser {
        if unit_of.len() == self.std.len() && unit_of.iter().all(|&unit| unit < self.std.len()) {
            let own = self.std.clone();
            for (deviation, &unit) in self.std.iter_mut().zip(unit_of) {
                *deviation = own[unit];
            }
        }
        self
    }

    /// The same standardisation with feature k multiplied by `weights[k]` after it: the
    /// feature's weight in a distance between standardised vectors (the RBF kernel's). The
    /// training range (for clamping) stays in raw units. Weights of another length than the
    /// features, or not finite and positive, leave it as it is.
    pub fn weighted(mut self, weights: &[f64]) -> Standardiser {
        if weights.len() == self.std.len() && weights.iter().all(|w| w.is_finite() && *w > 0.0) {
            for (deviation, weight) in self.std.iter_mut().zip(weights) {
                *deviation /= weight;
            }
        }
        self
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
    /// whose training vectors are the most extreme along that feature
    /// (`docs/decisions/0002-per-pair-standardisation.md`).
    pub fn apply_in_place(&self, vectors: &mut [f32]) -> Result<(), FeatureError> {
        self.check(vectors)?;
        let dim = self.dim();
        // The per-feature constants repeated over a run of rows, so that the loop over a run is
        // one flat, vectorisable pass (per-row loops of `dim` are not).
        const ROWS_PER_RUN: usize = 16;
        let repeat = |per_feature: &[f64], map: fn(f64) -> f32| -> Vec<f32> {
            per_feature.iter().map(|&v| map(v)).cycle().take(dim * ROWS_PER_RUN).collect()
        };
        let scale = repeat(&self.std, inverse_as_f32);
        let shift = repeat(&self.mean, as_f32);
        let low = repeat(&self.training_low, as_f32);
        let high = repeat(&self.training_high, as_f32);
        let standardise = |run: &mut [f32]| {
            for (((v, &low), &high), (&shift, &scale)) in
                run.iter_mut().zip(&low).zip(&high).zip(shift.iter().zip(&scale))
            {
                *v = standardise_value(*v, [low, high], shift, scale);
            }
        };
        let mut runs = vectors.chunks_exact_mut(dim * ROWS_PER_RUN);
        runs.by_ref().for_each(standardise);
        standardise(runs.into_remainder());
        Ok(())
    }

    /// The largest raw value of feature `feature` that [`Self::apply_in_place`] maps to at most
    /// `standardised`, or NaN when none does: a raw vector `v` then has
    /// `v <= threshold` exactly when its standardised form has `s <= standardised` (the map
    /// is non-decreasing, rounding included). This moves a tree's splits into raw units, so
    /// that a forest needs no standardising at all. Found by bisection over the `f32` values
    /// in order (32 steps).
    pub fn raw_threshold(&self, feature: usize, standardised: f32) -> f32 {
        let range = [as_f32(self.training_low[feature]), as_f32(self.training_high[feature])];
        let (shift, scale) = (as_f32(self.mean[feature]), inverse_as_f32(self.std[feature]));
        let at_or_below = |key: i64| standardise_value(from_order_key(key), range, shift, scale) <= standardised;
        let (mut low, mut high) = (order_key(f32::NEG_INFINITY), order_key(f32::INFINITY));
        if !at_or_below(low) || standardised.is_nan() {
            return f32::NAN;
        }
        if at_or_below(high) {
            return f32::INFINITY;
        }
        // at_or_below(low) holds and at_or_below(high) does not.
        while high - low > 1 {
            let middle = low + (high - low) / 2;
            if at_or_below(middle) {
                low = middle;
            } else {
                high = middle;
            }
        }
        from_order_key(low)
    }

    fn check(&self, vectors: &[f32]) -> Result<(), FeatureError> {
        let dim = self.dim();
        if dim == 0 || vectors.len() % dim != 0 {
            return Err(FeatureError::Ragged { length: vectors.len(), dim });
        }
        Ok(())
    }
}

/// One standardised value, as [`Standardiser::apply_in_place`] computes it (in `f32`, so that
/// [`Standardiser::raw_threshold`] can invert it exactly).
#[inline(always)]
fn standardise_value(value: f32, [low, high]: [f32; 2], shift: f32, scale: f32) -> f32 {
    (value.clamp(low, high) - shift) * scale
}

fn as_f32(value: f64) -> f32 {
    value as f32
}

fn inverse_as_f32(value: f64) -> f32 {
    (1.0 / value) as f32
}

/// A key that orders non-NaN `f32` values as numbers (-0 just below +0), one step per value.
fn order_key(value: f32) -> i64 {
    let bits = value.to_bits();
    let magnitude = i64::from(bits & 0x7fff_ffff);
    if bits >> 31 == 1 { -magnitude - 1 } else { magnitude }
}

/// The value of an [`order_key`].
fn from_order_key(key: i64) -> f32 {
    if key < 0 { f32::from_bits((-(key + 1)) as u32 | 0x8000_0000) } else { f32::from_bits(key as u32) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_keys_order_floats_as_numbers_and_invert() {
        let values =
            [f32::NEG_INFINITY, -3.5, -f32::MIN_POSITIVE, -1e-45, -0.0, 0.0, 1e-45, 2.0, f32::MAX, f32::INFINITY];
        let keys: Vec<i64> = values.iter().map(|&v| order_key(v)).collect();
        assert!(keys.windows(2).all(|pair| pair[0] < pair[1]), "{keys:?}");
        for &v in &values {
            assert_eq!(from_order_key(order_key(v)).to_bits(), v.to_bits());
        }
        assert_eq!(order_key(1e-45) - order_key(0.0), 1, "one step per value");
        assert_eq!(order_key(0.0) - order_key(-0.0), 1);
    }

    #[test]
    fn raw_thresholds_split_raw_values_as_standardised_ones_split() {
        let mut state = 99u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let vectors: Vec<f32> =
            (0..2 * 50).map(|k| if k % 2 == 0 { 1000.0 * next() - 300.0 } else { 0.01 * next() }).collect();
        let standardiser = Standardiser::fit(&vectors, 2).unwrap();
        for feature in 0..2 {
            let low = standardiser.training_low[feature] as f32;
            let high = standardiser.training_high[feature] as f32;
            let mut raw: Vec<f32> = (0..300).map(|_| low + (high - low) * (1.4 * next() - 0.2)).collect();
            raw.extend([f32::NEG_INFINITY, f32::INFINITY, f32::NAN, low, high, 0.0, -0.0]);
            let standardise = |v: f32| {
                let mut row = [0.0f32; 2];
                row[feature] = v;
                standardiser.apply_in_place(&mut row).unwrap();
                row[feature]
            };
            let mut thresholds: Vec<f32> = raw.iter().map(|&v| standardise(v)).collect();
            thresholds.extend([-1e9, 1e9, 0.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY]);
            for &t in &thresholds {
                let r = standardiser.raw_threshold(feature, t);
                // The values next to the threshold too, where rounding decides.
                let near = [r, r.next_down(), r.next_up()];
                for &v in raw.iter().chain(near.iter().filter(|v| v.is_finite())) {
                    assert_eq!(standardise(v) <= t, v <= r, "feature {feature}, value {v}, threshold {t} -> {r}");
                }
            }
        }
    }
}
