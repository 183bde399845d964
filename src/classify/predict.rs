//! Block prediction (snsvm.md §7, "prediction for every voxel"): decision values
//! F = k(V, X) Γ + w0 for a block V of m feature vectors, and one-vs-one voting.
//!
//! The RBF path is the hot loop of the product. It walks the packed panels of the model
//! (16 expansion points with their coordinates and coefficients side by side), computes
//! ||v − xⱼ||² directly (no norm trick, so no cancellation in f32), exp by [`exp_nonpositive`]
//! (a vectorisable Cephes-style expf, accuracy tested against f64), and accumulates the P
//! decision values in 16-lane f32 accumulators, two voxels per walk. On x86-64 CPUs with AVX2
//! and FMA the same code is compiled a second time for 256-bit vectors with fused
//! multiply-adds and chosen at run time; the two paths differ only by rounding (tested).
//!
//! Voting: pair (a, b) votes for a when f > 0, else for b. The label is the class with the most
//! votes; a tie goes to the tied class whose winning votes have the larger summed |f|, then to
//! the smallest class id. A feature vector with a non-finite component gets label 0
//! (background) and NaN decision values.
//! Never: decides which voxels to classify (masking, deduplication are the caller's).

use rayon::prelude::*;

use super::error::ClassifyError;
use super::kernel::Kernel;
use super::model::{Model, PANEL_WIDTH};

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
        std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
    }
}

/// The lanes at the start of `slice` as an array, so that the lane loops below have a length
/// the compiler can see (one bounds check per row instead of one per lane).
#[inline(always)]
fn lanes(slice: &[f32]) -> [f32; PANEL_WIDTH] {
    let mut out = [0.0; PANEL_WIDTH];
    out.copy_from_slice(&slice[..PANEL_WIDTH]);
    out
}

/// Sum of the lanes in a fixed pairwise order, the same in every path.
#[inline(always)]
fn horizontal_sum(lanes: &[f32; PANEL_WIDTH]) -> f32 {
    let mut partial = *lanes;
    let mut width = PANEL_WIDTH / 2;
    while width > 0 {
        for lane in 0..width {
            partial[lane] += partial[lane + width];
        }
        width /= 2;
    }
    partial[0]
}

/// Voxels that share one walk over the panels: their coordinate and coefficient loads are
/// shared and their exp chains interleave.
const VOXELS_PER_PASS: usize = 2;

/// Per pair, per voxel of a pass, the 16 partial sums of k(x, xⱼ) Γⱼₚ.
type Accumulators<const V: usize> = Vec<[[f32; PANEL_WIDTH]; V]>;

/// Decision values of the V finite feature vectors in `x` (V x dim) into `values` (V x P).
#[inline(always)]
fn rbf_pass<A: MultiplyAdd, const V: usize>(
    model: &Model,
    width: f32,
    x: &[f32],
    values: &mut [f32],
    accumulators: &mut Accumulators<V>,
) {
    let dim = model.dim;
    let pair_count = model.pairs.len();
    let panel_size = (dim + pair_count) * PANEL_WIDTH;
    for accumulator in accumulators.iter_mut() {
        *accumulator = [[0.0; PANEL_WIDTH]; V];
    }
    for panel in model.packed_panels.chunks_exact(panel_size) {
        let (coordinates, coefficients) = panel.split_at(dim * PANEL_WIDTH);
        let mut distance = [[0.0f32; PANEL_WIDTH]; V];
        for (k, row) in coordinates.chunks_exact(PANEL_WIDTH).enumerate() {
            let row = lanes(row);
            for (voxel, distance) in distance.iter_mut().enumerate() {
                let x_k = x[voxel * dim + k];
                for lane in 0..PANEL_WIDTH {
                    let d = x_k - row[lane];
                    distance[lane] = A::multiply_add(d, d, distance[lane]);
                }
            }
        }
        let mut kernel = [[0.0f32; PANEL_WIDTH]; V];
        for (kernel, distance) in kernel.iter_mut().zip(&distance) {
            for lane in 0..PANEL_WIDTH {
                kernel[lane] = exp_nonpositive::<A>(-width * distance[lane]);
            }
        }
        for (accumulator, row) in accumulators.iter_mut().zip(coefficients.chunks_exact(PANEL_WIDTH)) {
            let row = lanes(row);
            for (accumulator, kernel) in accumulator.iter_mut().zip(&kernel) {
                for lane in 0..PANEL_WIDTH {
                    accumulator[lane] = A::multiply_add(kernel[lane], row[lane], accumulator[lane]);
                }
            }
        }
    }
    for (voxel, values) in values.chunks_exact_mut(pair_count).enumerate() {
        for ((value, accumulator), bias) in values.iter_mut().zip(accumulators.iter()).zip(&model.biases) {
            *value = horizontal_sum(&accumulator[voxel]) + bias;
        }
    }
}

/// RBF decision values for a block: the shared body of every SIMD path. Groups of
/// [`VOXELS_PER_PASS`] finite vectors go through one pass; the rest one by one, so that every
/// voxel's value is computed by the same operations whatever its neighbours in the block.
#[inline(always)]
fn rbf_block<A: MultiplyAdd>(model: &Model, width: f32, features: &[f32], out: &mut [f32]) {
    let dim = model.dim;
    let pair_count = model.pairs.len();
    let mut group_accumulators: Accumulators<VOXELS_PER_PASS> = vec![[[0.0; PANEL_WIDTH]; VOXELS_PER_PASS]; pair_count];
    let mut single_accumulators: Accumulators<1> = vec![[[0.0; PANEL_WIDTH]; 1]; pair_count];
    let mut groups = features.chunks_exact(dim * VOXELS_PER_PASS);
    let mut group_values = out.chunks_exact_mut(pair_count * VOXELS_PER_PASS);
    for (x, values) in (&mut groups).zip(&mut group_values) {
        if x.iter().all(|v| v.is_finite()) {
            rbf_pass::<A, VOXELS_PER_PASS>(model, width, x, values, &mut group_accumulators);
        } else {
            for (x, values) in x.chunks_exact(dim).zip(values.chunks_exact_mut(pair_count)) {
                rbf_single::<A>(model, width, x, values, &mut single_accumulators);
            }
        }
    }
    let rest = groups.remainder().chunks_exact(dim);
    for (x, values) in rest.zip(group_values.into_remainder().chunks_exact_mut(pair_count)) {
        rbf_single::<A>(model, width, x, values, &mut single_accumulators);
    }
}

#[inline(always)]
fn rbf_single<A: MultiplyAdd>(
    model: &Model,
    width: f32,
    x: &[f32],
    values: &mut [f32],
    accumulators: &mut Accumulators<1>,
) {
    if x.iter().all(|v| v.is_finite()) {
        rbf_pass::<A, 1>(model, width, x, values, accumulators);
    } else {
        values.fill(f32::NAN);
    }
}

fn rbf_block_portable(model: &Model, width: f32, features: &[f32], out: &mut [f32]) {
    rbf_block::<Separate>(model, width, features, out);
}

/// # Safety
/// The CPU must support AVX2 and FMA.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn rbf_block_avx2_fma(model: &Model, width: f32, features: &[f32], out: &mut [f32]) {
    rbf_block::<Fused>(model, width, features, out);
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
    // Two classes (the common case): the one pair's sign decides, as the general count would.
    if let ([(first, second)], [f]) = (model.pair_positions.as_slice(), values) {
        return model.class_ids[if *f > 0.0 { *first } else { *second }];
    }
    votes.fill(0);
    strength.fill(0.0);
    for (&(first, second), &f) in model.pair_positions.iter().zip(values) {
        let winner = if f > 0.0 { first } else { second };
        votes[winner] += 1;
        strength[winner] += f.abs();
    }
    let mut best = 0;
    for class in 1..votes.len() {
        let more = votes[class] > votes[best];
        let stronger = votes[class] == votes[best] && strength[class] > strength[best];
        if more || stronger {
            best = class;
        }
    }
    model.class_ids[best]
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
        match (self.kernel, path) {
            #[cfg(target_arch = "x86_64")]
            (Kernel::Rbf { width }, SimdPath::Avx2Fma) => {
                // SAFETY: `SimdPath::Avx2Fma` is only chosen (by `best` or a test) after
                // `avx2_fma_available` found both features on this CPU.
                unsafe { rbf_block_avx2_fma(self, width as f32, features, out) }
            }
            (Kernel::Rbf { width }, SimdPath::Portable) => rbf_block_portable(self, width as f32, features, out),
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
        for (tile, labels) in features.chunks(TILE_VOXELS * self.dim).zip(labels_out.chunks_mut(TILE_VOXELS)) {
            let values = &mut values[..labels.len() * pair_count];
            self.decision_values_with(path, tile, values);
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
