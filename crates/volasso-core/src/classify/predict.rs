//! Block prediction (snsvm.md §7, "prediction for every voxel"): decision values
//! F = k(V, X) Γ + w0 for a block V of m feature vectors, and one-vs-one voting.
//!
//! The RBF path is the hot loop of the product. It is vectorised across voxels: 16 feature
//! vectors, one per lane, walk the expansion points together, computing ||v − xⱼ||² directly
//! (no norm trick, so no cancellation in f32), exp by [`exp_nonpositive`] (a vectorisable
//! Cephes-style expf, accuracy tested against f64), and the P decision values in f32 lanes.
//! Unlike a layout with expansion points in the lanes, a model with few of them (a clean
//! two-class lasso can leave seven) wastes no lanes and needs no horizontal sums. On x86-64
//! CPUs with AVX2 and FMA the same code is compiled a second time for 256-bit vectors with
//! fused multiply-adds and chosen at run time; the two paths differ only by rounding (tested).
//!
//! Voting: pair (a, b) votes for a when f > 0, else for b. The label is the class with the most
//! votes; a tie goes to the tied class whose winning votes have the larger summed |f|, then to
//! the smallest class id. A feature vector with a non-finite component gets label 0
//! (background) and NaN decision values.
//! Never: decides which voxels to classify (masking, deduplication are the caller's).

use rayon::prelude::*;

use super::error::ClassifyError;
use super::kernel::Kernel;
use super::model::Model;

/// Voxels per tile of [`Model::predict_block`]: the decision values of a tile stay in L1.
const TILE_VOXELS: usize = 64;
/// Voxels per task of [`Model::predict_block_parallel`].
const PARALLEL_CHUNK_VOXELS: usize = 4096;

/// a * b + c, either as two rounded operations or fused into one (where the CPU has FMA).
pub(crate) trait MultiplyAdd {
    fn multiply_add(a: f32, b: f32, c: f32) -> f32;
}

/// Two roundings; what every x86-64 and every other target can do fast.
pub(crate) struct Separate;

impl MultiplyAdd for Separate {
    #[inline(always)]
    fn multiply_add(a: f32, b: f32, c: f32) -> f32 {
        a * b + c
    }
}

/// One rounding; only fast inside functions compiled with the `fma` target feature (elsewhere
/// it becomes a library call).
pub(crate) struct Fused;

impl MultiplyAdd for Fused {
    #[inline(always)]
    fn multiply_add(a: f32, b: f32, c: f32) -> f32 {
        a.mul_add(b, c)
    }
}

/// e^x for x <= 0 in f32, vectorisable: Cody-Waite reduction x = n ln2 + r, |r| <= ln2/2,
/// Cephes' degree-5 minimax polynomial for e^r, and 2^n assembled from its exponent bits.
/// Inputs below −87 return e^−87 ≈ 1.6e−38 (absolute error below 2e−38); x > 0 is clamped to 0.
#[inline(always)]
pub(crate) fn exp_nonpositive<A: MultiplyAdd>(x: f32) -> f32 {
    // 1.5 * 2^23: adding it rounds to an integer held in the low mantissa bits.
    const ROUNDING: f32 = 12_582_912.0;
    // Exactly 0.693359375 in f32 (few mantissa bits, so n * LN2_HIGH is exact).
    const LN2_HIGH: f32 = 0.693_359_4;
    const LN2_LOW: f32 = -2.121_944_4e-4;
    let x = x.clamp(-87.0, 0.0);
    let shifted = A::multiply_add(x, std::f32::consts::LOG2_E, ROUNDING);
    let n = shifted - ROUNDING;
    let r = A::multiply_add(-n, LN2_LOW, A::multiply_add(-n, LN2_HIGH, x));
    let mut p = 1.987_569_1e-4_f32;
    p = A::multiply_add(p, r, 1.398_199_9e-3);
    p = A::multiply_add(p, r, 8.333_452e-3);
    p = A::multiply_add(p, r, 4.166_579_6e-2);
    p = A::multiply_add(p, r, 1.666_666_5e-1);
    p = A::multiply_add(p, r, 0.5);
    let exp_r = A::multiply_add(p, r * r, r + 1.0);
    let exponent = shifted.to_bits().wrapping_sub(ROUNDING.to_bits());
    let scale = f32::from_bits(exponent.wrapping_add(127) << 23);
    exp_r * scale
}

/// Which compiled variant of the RBF loop runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SimdPath {
    /// The target's baseline (SSE2 on x86-64), separate multiply and add.
    Portable,
    /// 256-bit vectors and fused multiply-add.
    #[cfg(target_arch = "x86_64")]
    Avx2Fma,
}

impl SimdPath {
    pub(crate) fn best() -> SimdPath {
        #[cfg(target_arch = "x86_64")]
        if Self::avx2_fma_available() {
            return SimdPath::Avx2Fma;
        }
        SimdPath::Portable
    }

    #[cfg(target_arch = "x86_64")]
    pub(crate) fn avx2_fma_available() -> bool {
        crate::cpu::has_avx2_fma()
    }
}

/// Vectors per group of [`rbf_block`], one SIMD lane each (two 256-bit vectors of f32).
const VOXEL_LANES: usize = 16;

/// Per-call buffers of [`rbf_block`], kept by the caller across tiles so that the hot loop
/// allocates nothing.
#[derive(Default)]
pub(crate) struct RbfScratch {
    /// One row of lanes per coordinate of the current group of vectors.
    coordinates: Vec<[f32; VOXEL_LANES]>,
    /// One row of lanes per pair.
    accumulators: Vec<[f32; VOXEL_LANES]>,
}

/// RBF decision values for a block: the shared body of every SIMD path. Groups of
/// [`VOXEL_LANES`] vectors, transposed so that each coordinate is one row of lanes, walk the
/// expansion points one at a time: ‖v − xⱼ‖² (directly, no norm trick, so no cancellation in
/// f32), then exp, then the P decision values. Every lane runs the same operations on its own
/// vector (a short group is padded with zeros), so a voxel's values do not depend on its
/// neighbours in the block. A non-finite component enters as NaN, which every later step
/// carries (NaN distance, NaN kernel value, NaN sums), so the vector gets NaN values without a
/// test per lane; an infinity alone would not do, since exp clamps it to a finite value.
#[inline(always)]
fn rbf_block<A: MultiplyAdd>(model: &Model, width: f32, features: &[f32], out: &mut [f32], scratch: &mut RbfScratch) {
    let dim = model.dim;
    let pair_count = model.pairs.len();
    let RbfScratch { coordinates, accumulators } = scratch;
    coordinates.resize(dim, [0.0; VOXEL_LANES]);
    accumulators.resize(pair_count, [0.0; VOXEL_LANES]);
    for (x, values) in features.chunks(dim * VOXEL_LANES).zip(out.chunks_mut(pair_count * VOXEL_LANES)) {
        if x.len() < dim * VOXEL_LANES {
            coordinates.fill([0.0; VOXEL_LANES]);
        }
        for (lane, vector) in x.chunks_exact(dim).enumerate() {
            for (lanes, &value) in coordinates.iter_mut().zip(vector) {
                lanes[lane] = if value.is_finite() { value } else { f32::NAN };
            }
        }
        accumulators.fill([0.0; VOXEL_LANES]);
        let points = model.training_points.chunks_exact(dim).zip(model.coefficients.chunks_exact(pair_count));
        for (point, gammas) in points {
            let mut distance = [0f32; VOXEL_LANES];
            for (lanes, &p) in coordinates.iter().zip(point) {
                for lane in 0..VOXEL_LANES {
                    let d = lanes[lane] - p;
                    distance[lane] = A::multiply_add(d, d, distance[lane]);
                }
            }
            let mut kernel = [0f32; VOXEL_LANES];
            for lane in 0..VOXEL_LANES {
                kernel[lane] = exp_nonpositive::<A>(-width * distance[lane]);
            }
            for (accumulator, &gamma) in accumulators.iter_mut().zip(gammas) {
                for lane in 0..VOXEL_LANES {
                    accumulator[lane] = A::multiply_add(kernel[lane], gamma, accumulator[lane]);
                }
            }
        }
        for (lane, values) in values.chunks_exact_mut(pair_count).enumerate() {
            for ((value, accumulator), bias) in values.iter_mut().zip(accumulators.iter()).zip(&model.biases) {
                *value = accumulator[lane] + bias;
            }
        }
    }
}

fn rbf_block_portable(model: &Model, width: f32, features: &[f32], out: &mut [f32], scratch: &mut RbfScratch) {
    rbf_block::<Separate>(model, width, features, out, scratch);
}

/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn rbf_block_avx2_fma(model: &Model, width: f32, features: &[f32], out: &mut [f32], scratch: &mut RbfScratch) {
    rbf_block::<Fused>(model, width, features, out, scratch);
}

/// Any kernel, scalar: (x.y + offset)^degree for the polynomial kernel of the tests.
fn general_block(model: &Model, features: &[f32], out: &mut [f32]) {
    let dim = model.dim;
    let pair_count = model.pairs.len();
    for (x, values) in features.chunks_exact(dim).zip(out.chunks_exact_mut(pair_count)) {
        values.copy_from_slice(&model.biases);
        for (point, row) in model.training_points.chunks_exact(dim).zip(model.coefficients.chunks_exact(pair_count)) {
            let k = match model.kernel {
                Kernel::Rbf { width } => {
                    let d2: f32 = x.iter().zip(point).map(|(a, b)| (a - b) * (a - b)).sum();
                    (-(width as f32) * d2).exp()
                }
                Kernel::Polynomial { degree, offset } => {
                    let dot: f32 = x.iter().zip(point).map(|(a, b)| a * b).sum();
                    (dot + offset as f32).powi(i32::try_from(degree).unwrap_or(i32::MAX))
                }
            };
            for (v, g) in values.iter_mut().zip(row) {
                *v += k * g;
            }
        }
    }
}

/// The one-vs-one vote of one feature vector (see the module doc for ties).
fn vote(model: &Model, values: &[f32], votes: &mut [u32], strength: &mut [f32]) -> u8 {
    if values.iter().any(|v| v.is_nan()) {
        return 0;
    }
    super::ovo::tally_votes(&model.pair_positions, values, votes, strength);
    model.class_ids[super::ovo::vote_winner(votes, strength)]
}

impl Model {
    fn check_block(&self, features: &[f32], out_len: usize, per_voxel: usize) -> Result<(), ClassifyError> {
        if features.len() % self.dim != 0 {
            return Err(ClassifyError::FeatureBlockShape { values: features.len(), dim: self.dim });
        }
        let expected = features.len() / self.dim * per_voxel;
        if out_len != expected {
            return Err(ClassifyError::OutputBlockShape { expected, found: out_len });
        }
        Ok(())
    }

    pub(crate) fn decision_values_with(&self, path: SimdPath, features: &[f32], out: &mut [f32]) {
        self.decision_values_into(path, features, out, &mut RbfScratch::default());
    }

    fn decision_values_into(&self, path: SimdPath, features: &[f32], out: &mut [f32], scratch: &mut RbfScratch) {
        match (self.kernel, path) {
            #[cfg(target_arch = "x86_64")]
            (Kernel::Rbf { width }, SimdPath::Avx2Fma) => {
                // SAFETY: `SimdPath::Avx2Fma` is only chosen (by `best` or a test) after
                // `avx2_fma_available` found both features on this CPU.
                unsafe { rbf_block_avx2_fma(self, width as f32, features, out, scratch) }
            }
            (Kernel::Rbf { width }, SimdPath::Portable) => {
                rbf_block_portable(self, width as f32, features, out, scratch)
            }
            (Kernel::Polynomial { .. }, _) => general_block(self, features, out),
        }
    }

    /// Decision values of m feature vectors (`features`: m x dim, row-major) into `out`
    /// (m x P, row-major, pair order of [`Model::pairs`]).
    pub fn decision_values_block(&self, features: &[f32], out: &mut [f32]) -> Result<(), ClassifyError> {
        self.check_block(features, out.len(), self.pairs.len())?;
        self.decision_values_with(SimdPath::best(), features, out);
        Ok(())
    }

    /// Labels of m feature vectors by one-vs-one voting, single-threaded.
    pub fn predict_block(&self, features: &[f32], labels_out: &mut [u8]) -> Result<(), ClassifyError> {
        self.check_block(features, labels_out.len(), 1)?;
        self.predict_checked(SimdPath::best(), features, labels_out);
        Ok(())
    }

    pub(crate) fn predict_checked(&self, path: SimdPath, features: &[f32], labels_out: &mut [u8]) {
        let pair_count = self.pairs.len();
        let mut values = vec![0.0f32; TILE_VOXELS * pair_count];
        let mut votes = vec![0u32; self.class_ids.len()];
        let mut strength = vec![0.0f32; self.class_ids.len()];
        let mut scratch = RbfScratch::default();
        for (tile, labels) in features.chunks(TILE_VOXELS * self.dim).zip(labels_out.chunks_mut(TILE_VOXELS)) {
            let values = &mut values[..labels.len() * pair_count];
            self.decision_values_into(path, tile, values, &mut scratch);
            if let [(first, second)] = self.pair_positions.as_slice() {
                // Two classes (the common case): the one pair's sign decides, as `vote`'s count
                // would, without a call per voxel.
                let (first, second) = (self.class_ids[*first], self.class_ids[*second]);
                for (label, &f) in labels.iter_mut().zip(values.iter()) {
                    *label = if f > 0.0 {
                        first
                    } else if f.is_nan() {
                        0
                    } else {
                        second
                    };
                }
                continue;
            }
            for (label, voxel_values) in labels.iter_mut().zip(values.chunks_exact(pair_count)) {
                *label = vote(self, voxel_values, &mut votes, &mut strength);
            }
        }
    }

    /// [`Model::predict_block`] spread over the rayon pool in chunks of 4096 vectors.
    pub fn predict_block_parallel(&self, features: &[f32], labels_out: &mut [u8]) -> Result<(), ClassifyError> {
        self.check_block(features, labels_out.len(), 1)?;
        let path = SimdPath::best();
        features
            .par_chunks(PARALLEL_CHUNK_VOXELS * self.dim)
            .zip(labels_out.par_chunks_mut(PARALLEL_CHUNK_VOXELS))
            .for_each(|(chunk, labels)| self.predict_checked(path, chunk, labels));
        Ok(())
    }
}

#[cfg(test)]
mod tests;
