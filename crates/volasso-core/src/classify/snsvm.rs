//! One binary SN-SVM (snsvm.md §3-§6): the modified kernel K̃ = (I + ηKR)⁻¹K, the dual solved
//! by SMO, and the expansion coefficients γ = (I + ηRK)⁻¹(α∘t) of f(x) = k(x)ᵀγ + w0.
//!
//! Steps of [`modified_kernel`], numbered as in the code:
//! 1. K, the kappa-NN neighbourhoods A, B and the boundary weights ω (snsvm.md §2).
//! 2. β = β_rel · λmax(QK) by Lanczos.
//! 3. G = (βI + KQ)⁻¹K by LU, symmetrised (§4.3 step 1).
//! 4. R = A(AᵀGA)Aᵀ with sparse A, symmetrised (§4.3 step 2).
//! 5. Spectral scale: R /= λmax(KR) by Lanczos (§9).
//! 6. M = I + ηKR, one LU; K̃ = M⁻¹K, symmetrised (§4.4).
//!
//! [`train_binary`] then runs SMO on K̃ and solves Mᵀγ = α∘t with the same LU (§4.6).
//! K is never inverted: every factorised matrix is cI + (PSD)(PSD), eigenvalues ≥ c.
//! With η = 0 every scatter stage is skipped and K̃ = K, γ = α∘t exactly.
//! Never: sees class ids beyond error messages, or f32 voxel data.

use faer::Mat;
use faer::linalg::solvers::{PartialPivLu, Solve};

use super::error::ClassifyError;
use super::kernel::gram;
use super::params::{ScaleMode, SnSvmValidParams};
use super::scatter::{
    between_scatter_times, dense_times_sparse, dense_times_sparse_transposed, neighbourhoods, sparse_times_dense,
    sparse_transposed_times_dense, symmetric_times, symmetrise,
};
use super::smo::{self, SolveReport};
use super::spectrum::{largest_eigenvalue_of_product, point_dependent_start};

/// One binary problem: points of the first class have t = +1.
pub(crate) struct BinaryProblem<'a> {
    /// N x dim, row-major.
    pub points: &'a [f64],
    pub dim: usize,
    pub first_class: &'a [bool],
    /// For error messages only.
    pub class_ids: (u8, u8),
}

/// Whether η = 0 may skip the scatter stages (the product) or must run them (a test of §4.9).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ScatterPath {
    SkipWhenEtaIsZero,
    #[cfg_attr(not(test), allow(dead_code))]
    AlwaysCompute,
}

/// K̃ of one problem and the LU of M that also yields γ.
pub(crate) struct ModifiedKernel {
    #[cfg_attr(not(test), allow(dead_code))]
    pub gram: Mat<f64>,
    pub modified: Mat<f64>,
    factor: Option<PartialPivLu<f64>>,
    pub spectra: PenaltySpectra,
}

/// Scales found on the way; reported so that a user can see whether the KND term acted.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PenaltySpectra {
    /// λmax(Nabla) = λmax(QK); 0 when the scatter stages were skipped.
    pub nabla_largest_eigenvalue: f64,
    /// The β actually used.
    pub beta: f64,
    /// λmax(KR) before any spectral scaling; 0 when the penalty vanished.
    pub penalty_largest_eigenvalue: f64,
}

/// The trained binary model: f(x) = Σⱼ γⱼ k(xⱼ, x) + bias.
pub(crate) struct BinaryModel {
    pub gamma: Vec<f64>,
    pub bias: f64,
    #[cfg_attr(not(test), allow(dead_code))]
    pub alpha: Vec<f64>,
    pub report: SolveReport,
    pub spectra: PenaltySpectra,
}

fn targets(problem: &BinaryProblem) -> Vec<f64> {
    problem.first_class.iter().map(|&first| if first { 1.0 } else { -1.0 }).collect()
}

fn all_finite(m: &Mat<f64>) -> bool {
    (0..m.ncols()).all(|j| m.col_as_slice(j).iter().all(|v| v.is_finite()))
}

fn add_to_diagonal(m: &mut Mat<f64>, value: f64) {
    for i in 0..m.nrows() {
        m[(i, i)] += value;
    }
}

pub(crate) fn modified_kernel(
    problem: &BinaryProblem,
    params: &SnSvmValidParams,
    path: ScatterPath,
) -> Result<ModifiedKernel, ClassifyError> {
    let failure =
        |stage| ClassifyError::NumericalFailure { class_a: problem.class_ids.0, class_b: problem.class_ids.1, stage };
    let (points, dim) = (problem.points, problem.dim);
    let count = problem.first_class.len();
    // 1.
    let gram = gram(&params.kernel, points, dim);
    if !all_finite(&gram) {
        return Err(failure("the kernel matrix"));
    }
    if params.eta == 0.0 && path == ScatterPath::SkipWhenEtaIsZero {
        return Ok(ModifiedKernel { modified: gram.clone(), gram, factor: None, spectra: PenaltySpectra::default() });
    }
    let hoods = neighbourhoods(&params.kernel, points, dim, problem.first_class, params.kappa, params.weight_exponent);
    let start = point_dependent_start(points, dim);
    let times_gram = |v: &[f64], out: &mut [f64]| symmetric_times(&gram, v, out);
    // 2.
    let nabla_largest_eigenvalue =
        largest_eigenvalue_of_product(|v, out| between_scatter_times(&hoods, v, out), times_gram, &start);
    let mean_diagonal = (0..count).map(|i| gram[(i, i)]).sum::<f64>() / count as f64;
    // When Nabla vanishes (all between-class deviations zero) any β > 0 is as good as another
    // up to the penalty scale; tie it to the kernel's scale so that it stays scale-free.
    let beta_scale = if nabla_largest_eigenvalue > 1e-12 * mean_diagonal {
        nabla_largest_eigenvalue
    } else {
        mean_diagonal.max(f64::MIN_POSITIVE)
    };
    let beta = params.beta_relative * beta_scale;
    // 3.
    let mut shifted = dense_times_sparse_transposed(
        &dense_times_sparse(&gram, &hoods.between),
        &hoods.between,
        Some(&hoods.boundary_weights),
    );
    add_to_diagonal(&mut shifted, beta);
    let mut g = shifted.partial_piv_lu().solve(&gram);
    drop(shifted);
    symmetrise(&mut g);
    if !all_finite(&g) {
        return Err(failure("the (Nabla + beta I) solve"));
    }
    // 4.
    let mut inner = sparse_transposed_times_dense(&hoods.within, &dense_times_sparse(&g, &hoods.within));
    drop(g);
    symmetrise(&mut inner);
    let mut penalty = sparse_times_dense(&hoods.within, &dense_times_sparse_transposed(&inner, &hoods.within, None));
    drop(inner);
    symmetrise(&mut penalty);
    // 5.
    let penalty_largest_eigenvalue =
        largest_eigenvalue_of_product(|v, out| symmetric_times(&penalty, v, out), times_gram, &start);
    // trace(Delta)^2 / β bounds λmax(KR) from above; far below it the penalty is round-off.
    let delta_trace: f64 = hoods
        .within
        .columns
        .iter()
        .map(|a| a.iter().map(|&(r, u)| a.iter().map(|&(s, v)| u * v * gram[(r, s)]).sum::<f64>()).sum::<f64>())
        .sum();
    let penalty_vanishes =
        penalty_largest_eigenvalue.is_nan() || penalty_largest_eigenvalue <= 1e-12 * delta_trace * delta_trace / beta;
    let penalty_scale = match params.scale_mode {
        ScaleMode::Spectral => 1.0 / penalty_largest_eigenvalue,
        ScaleMode::Sum => 1.0,
    };
    let spectra = PenaltySpectra {
        nabla_largest_eigenvalue,
        beta,
        penalty_largest_eigenvalue: if penalty_vanishes { 0.0 } else { penalty_largest_eigenvalue },
    };
    if penalty_vanishes {
        // M = I: the KND term has nothing to act on (e.g. every own-class neighbour is a
        // duplicate), so K̃ = K and γ = α∘t exactly.
        return Ok(ModifiedKernel { modified: gram.clone(), gram, factor: None, spectra });
    }
    // 6.
    let mut system = &gram * &penalty;
    drop(penalty);
    let eta_scaled = params.eta * penalty_scale;
    for j in 0..count {
        for value in system.col_as_slice_mut(j) {
            *value *= eta_scaled;
        }
    }
    add_to_diagonal(&mut system, 1.0);
    let factor = system.partial_piv_lu();
    drop(system);
    let mut modified = factor.solve(&gram);
    symmetrise(&mut modified);
    if !all_finite(&modified) {
        return Err(failure("the modified kernel"));
    }
    Ok(ModifiedKernel { gram, modified, factor: Some(factor), spectra })
}

pub(crate) fn train_binary(
    problem: &BinaryProblem,
    params: &SnSvmValidParams,
    path: ScatterPath,
) -> Result<BinaryModel, ClassifyError> {
    let kernels = modified_kernel(problem, params, path)?;
    let targets = targets(problem);
    let solution = smo::solve(&kernels.modified, &targets, params.c, params.tolerance, params.max_iterations);
    let signed: Vec<f64> = solution.alpha.iter().zip(&targets).map(|(a, t)| a * t).collect();
    let gamma = match &kernels.factor {
        None => signed,
        Some(factor) => {
            let right_side = Mat::from_fn(signed.len(), 1, |i, _| signed[i]);
            let solved = factor.solve_transpose(&right_side);
            solved.col_as_slice(0).to_vec()
        }
    };
    if !(gamma.iter().all(|g| g.is_finite()) && solution.bias.is_finite()) {
        return Err(ClassifyError::NumericalFailure {
            class_a: problem.class_ids.0,
            class_b: problem.class_ids.1,
            stage: "the expansion coefficients",
        });
    }
    Ok(BinaryModel {
        gamma,
        bias: solution.bias,
        alpha: solution.alpha,
        report: solution.report,
        spectra: kernels.spectra,
    })
}

#[cfg(test)]
mod tests;
