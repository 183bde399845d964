//! Sequential minimal optimisation for the dual QP shared by SVM and SN-SVM
//! (snsvm.md §4.5, §8).
//!
//! Solves min ½αᵀQα − 1ᵀα s.t. tᵀα = 0, 0 ≤ α ≤ C with Qᵢⱼ = tᵢtⱼK̃ᵢⱼ, as LIBSVM's C-SVC
//! does: WSS2 working sets (Fan, Chen & Lin 2005), curvature clamped to τ = 1e-12, stop when
//! m(α) − M(α) < tolerance, bias from the free support vectors or the midpoint of the feasible
//! interval. The whole kernel matrix is in memory, so there is no cache and no shrinking.
//! Entry point: [`solve`] → alphas, bias w0 and a [`SolveReport`].
//!
//! Never: builds kernels, knows about classes or voxels, or allocates per iteration.

use faer::Mat;

/// LIBSVM's TAU: the curvature used when a_ij = K̃ii + K̃jj − 2K̃ij is not positive.
const CURVATURE_FLOOR: f64 = 1e-12;

/// How one solve went.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveReport {
    /// SMO steps taken.
    pub iterations: usize,
    /// The iteration cap stopped the solver before the tolerance was met.
    pub hit_cap: bool,
    /// Dual objective ½αᵀQα − 1ᵀα at exit (LIBSVM's "obj"; lower is better).
    pub objective: f64,
    /// Points with α > 0.
    pub support_vectors: usize,
    /// Points with 0 < α < C.
    pub free_support_vectors: usize,
}

/// The optimum: α, and the bias w0 of f(x) = Σⱼ αⱼtⱼK̃(xⱼ, x) + w0.
#[derive(Debug, Clone)]
pub struct Solution {
    pub alpha: Vec<f64>,
    pub bias: f64,
    pub report: SolveReport,
}

/// Solver state handed to an observer after every step (tests check the objective with it).
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) struct SolverState<'a> {
    pub alpha: &'a [f64],
    /// ∇ = Qα − 1.
    pub gradient: &'a [f64],
}

/// Solves the C-SVC dual for the symmetric kernel matrix `kernel` and targets t ∈ {+1, −1}.
pub fn solve(kernel: &Mat<f64>, targets: &[f64], c: f64, tolerance: f64, max_iterations: usize) -> Solution {
    solve_observed(kernel, targets, c, tolerance, max_iterations, |_| {})
}

pub(crate) fn solve_observed(
    kernel: &Mat<f64>,
    targets: &[f64],
    c: f64,
    tolerance: f64,
    max_iterations: usize,
    mut observer: impl FnMut(&SolverState),
) -> Solution {
    let count = targets.len();
    let diagonal: Vec<f64> = (0..count).map(|i| kernel[(i, i)]).collect();
    let mut alpha = vec![0.0; count];
    // ∇ = Qα − 1 is −1 at α = 0.
    let mut gradient = vec![-1.0; count];
    let mut iterations = 0;
    let mut hit_cap = false;
    while let Some((i, j)) = select_working_set(kernel, &diagonal, targets, &alpha, &gradient, c, tolerance) {
        if iterations == max_iterations {
            hit_cap = true;
            break;
        }
        iterations += 1;
        let (old_i, old_j) = (alpha[i], alpha[j]);
        let (new_i, new_j) = two_variable_step(kernel, &diagonal, targets, &alpha, &gradient, c, i, j);
        alpha[i] = new_i;
        alpha[j] = new_j;
        let (delta_i, delta_j) = (new_i - old_i, new_j - old_j);
        // ∇ₖ += Qₖᵢ Δαᵢ + Qₖⱼ Δαⱼ with Qₖᵢ = tₖtᵢK̃ₖᵢ; K̃ is symmetric, so its columns are rows.
        let (column_i, column_j) = (kernel.col_as_slice(i), kernel.col_as_slice(j));
        let (scale_i, scale_j) = (targets[i] * delta_i, targets[j] * delta_j);
        for (k, g) in gradient.iter_mut().enumerate() {
            *g += targets[k] * (scale_i * column_i[k] + scale_j * column_j[k]);
        }
        observer(&SolverState { alpha: &alpha, gradient: &gradient });
    }
    let bias = bias(targets, &alpha, &gradient, c);
    let report = SolveReport {
        iterations,
        hit_cap,
        objective: dual_objective(&alpha, &gradient),
        support_vectors: alpha.iter().filter(|&&a| a > 0.0).count(),
        free_support_vectors: alpha.iter().filter(|&&a| a > 0.0 && a < c).count(),
    };
    Solution { alpha, bias, report }
}

/// ½αᵀQα − 1ᵀα = ½ Σ αᵢ(∇ᵢ − 1), since ∇ = Qα − 1.
pub(crate) fn dual_objective(alpha: &[f64], gradient: &[f64]) -> f64 {
    0.5 * alpha.iter().zip(gradient).map(|(a, g)| a * (g - 1.0)).sum::<f64>()
}

/// WSS2 (LIBSVM `Solver::select_working_set`): i maximises −tᵢ∇ᵢ over I_up, j minimises the
/// second-order gain −b²/a over I_low among the violating partners. `None` once
/// m(α) − M(α) < tolerance.
fn select_working_set(
    kernel: &Mat<f64>,
    diagonal: &[f64],
    targets: &[f64],
    alpha: &[f64],
    gradient: &[f64],
    c: f64,
    tolerance: f64,
) -> Option<(usize, usize)> {
    let mut largest_up = f64::NEG_INFINITY;
    let mut chosen_i = None;
    for t in 0..targets.len() {
        let in_up = if targets[t] > 0.0 { alpha[t] < c } else { alpha[t] > 0.0 };
        let value = -targets[t] * gradient[t];
        if in_up && value >= largest_up {
            largest_up = value;
            chosen_i = Some(t);
        }
    }
    let i = chosen_i?;
    let column_i = kernel.col_as_slice(i);
    let mut largest_low = f64::NEG_INFINITY;
    let mut best_gain = f64::INFINITY;
    let mut chosen_j = None;
    for t in 0..targets.len() {
        let in_low = if targets[t] > 0.0 { alpha[t] > 0.0 } else { alpha[t] < c };
        if !in_low {
            continue;
        }
        let value = targets[t] * gradient[t];
        largest_low = largest_low.max(value);
        let difference = largest_up + value;
        if difference > 0.0 {
            let curvature = diagonal[i] + diagonal[t] - 2.0 * column_i[t];
            let gain = -(difference * difference) / positive_curvature(curvature);
            if gain <= best_gain {
                best_gain = gain;
                chosen_j = Some(t);
            }
        }
    }
    if largest_up + largest_low < tolerance {
        return None;
    }
    chosen_j.map(|j| (i, j))
}

fn positive_curvature(curvature: f64) -> f64 {
    if curvature > 0.0 { curvature } else { CURVATURE_FLOOR }
}

/// The analytic two-variable update of LIBSVM's `Solver::Solve`, clipped to the box.
#[allow(clippy::too_many_arguments)]
fn two_variable_step(
    kernel: &Mat<f64>,
    diagonal: &[f64],
    targets: &[f64],
    alpha: &[f64],
    gradient: &[f64],
    c: f64,
    i: usize,
    j: usize,
) -> (f64, f64) {
    let (mut alpha_i, mut alpha_j) = (alpha[i], alpha[j]);
    let kernel_ij = kernel[(i, j)];
    if targets[i] != targets[j] {
        let curvature = positive_curvature(diagonal[i] + diagonal[j] + 2.0 * (-kernel_ij));
        let delta = (-gradient[i] - gradient[j]) / curvature;
        let difference = alpha_i - alpha_j;
        alpha_i += delta;
        alpha_j += delta;
        if difference > 0.0 {
            if alpha_j < 0.0 {
                alpha_j = 0.0;
                alpha_i = difference;
            }
        } else if alpha_i < 0.0 {
            alpha_i = 0.0;
            alpha_j = -difference;
        }
        // Equal boxes (C_i = C_j) make LIBSVM's "difference > C_i - C_j" read "difference > 0".
        if difference > 0.0 {
            if alpha_i > c {
                alpha_i = c;
                alpha_j = c - difference;
            }
        } else if alpha_j > c {
            alpha_j = c;
            alpha_i = c + difference;
        }
    } else {
        let curvature = positive_curvature(diagonal[i] + diagonal[j] - 2.0 * kernel_ij);
        let delta = (gradient[i] - gradient[j]) / curvature;
        let sum = alpha_i + alpha_j;
        alpha_i -= delta;
        alpha_j += delta;
        if sum > c {
            if alpha_i > c {
                alpha_i = c;
                alpha_j = sum - c;
            }
        } else if alpha_j < 0.0 {
            alpha_j = 0.0;
            alpha_i = sum;
        }
        if sum > c {
            if alpha_j > c {
                alpha_j = c;
                alpha_i = sum - c;
            }
        } else if alpha_i < 0.0 {
            alpha_i = 0.0;
            alpha_j = sum;
        }
    }
    (alpha_i, alpha_j)
}

/// w0 = −ρ, with ρ the mean of tᵢ∇ᵢ over free support vectors, or the midpoint of the
/// feasible interval when there is none (LIBSVM `calculate_rho`).
fn bias(targets: &[f64], alpha: &[f64], gradient: &[f64], c: f64) -> f64 {
    let mut upper = f64::INFINITY;
    let mut lower = f64::NEG_INFINITY;
    let mut free_sum = 0.0;
    let mut free_count = 0usize;
    for t in 0..targets.len() {
        let value = targets[t] * gradient[t];
        let positive = targets[t] > 0.0;
        if alpha[t] >= c {
            if positive {
                lower = lower.max(value);
            } else {
                upper = upper.min(value);
            }
        } else if alpha[t] <= 0.0 {
            if positive {
                upper = upper.min(value);
            } else {
                lower = lower.max(value);
            }
        } else {
            free_sum += value;
            free_count += 1;
        }
    }
    let rho = if free_count > 0 {
        free_sum / free_count as f64
    } else if upper.is_finite() && lower.is_finite() {
        0.5 * (upper + lower)
    } else {
        // Only reachable when every point sits on one bound of one side; any value in the
        // (half-open) feasible interval is optimal, take its finite end.
        if upper.is_finite() {
            upper
        } else if lower.is_finite() {
            lower
        } else {
            0.0
        }
    };
    -rho
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::classify::kernel::{Kernel, gram};
    use crate::classify::test_support::{SplitMix64, blobs};

    fn problem(seed: u64, per_class: usize, separation: f64) -> (Mat<f64>, Vec<f64>) {
        let mut rng = SplitMix64::new(seed);
        let (points, labels) = blobs(&mut rng, 2, per_class, 3, separation);
        let targets = labels.iter().map(|&l| if l == 1 { 1.0 } else { -1.0 }).collect();
        (gram(&Kernel::Rbf { width: 0.5 }, &points, 3), targets)
    }

    /// Largest violation of the KKT conditions of the C-SVC at (α, w0).
    fn kkt_violation(kernel: &Mat<f64>, targets: &[f64], solution: &Solution, c: f64) -> f64 {
        let count = targets.len();
        let mut worst = 0.0f64;
        for i in 0..count {
            let f: f64 =
                (0..count).map(|j| solution.alpha[j] * targets[j] * kernel[(i, j)]).sum::<f64>() + solution.bias;
            let margin = targets[i] * f;
            let alpha = solution.alpha[i];
            let violation = if alpha <= 0.0 {
                (1.0 - margin).max(0.0)
            } else if alpha >= c {
                (margin - 1.0).max(0.0)
            } else {
                (margin - 1.0).abs()
            };
            worst = worst.max(violation);
        }
        worst
    }

    #[test]
    fn solution_meets_kkt_within_tolerance_on_random_problems() {
        let tolerance = 1e-3;
        for (seed, per_class) in [(1, 5), (2, 25), (3, 100)] {
            for c in [0.1, 1.0, 10.0, 100.0] {
                let (kernel, targets) = problem(seed, per_class, 1.5);
                let solution = solve(&kernel, &targets, c, tolerance, 1_000_000);
                assert!(!solution.report.hit_cap);
                let balance: f64 = solution.alpha.iter().zip(&targets).map(|(a, t)| a * t).sum();
                assert!(balance.abs() < 1e-10 * (1.0 + c), "t.alpha = {balance}");
                assert!(solution.alpha.iter().all(|&a| (0.0..=c).contains(&a)));
                let violation = kkt_violation(&kernel, &targets, &solution, c);
                assert!(violation <= tolerance + 1e-12, "n={} C={c}: KKT violation {violation}", 2 * per_class);
                assert!(solution.report.support_vectors > 0);
            }
        }
    }

    #[test]
    fn dual_objective_never_increases() {
        for c in [0.5, 10.0] {
            let (kernel, targets) = problem(7, 60, 1.0);
            let mut objectives = vec![0.0];
            let solution = solve_observed(&kernel, &targets, c, 1e-6, 1_000_000, |state| {
                objectives.push(dual_objective(state.alpha, state.gradient));
            });
            assert_eq!(objectives.len(), solution.report.iterations + 1);
            assert!(objectives.len() > 10, "a real run takes many steps");
            for step in objectives.windows(2) {
                assert!(step[1] <= step[0] + 1e-12 * step[0].abs(), "{} -> {}", step[0], step[1]);
            }
            assert!((objectives[objectives.len() - 1] - solution.report.objective).abs() < 1e-12);
            // The gradient kept incrementally equals Qα − 1 recomputed from scratch.
            let mut recomputed = 0.0;
            for i in 0..targets.len() {
                for j in 0..targets.len() {
                    recomputed +=
                        0.5 * solution.alpha[i] * solution.alpha[j] * targets[i] * targets[j] * kernel[(i, j)];
                }
                recomputed -= solution.alpha[i];
            }
            assert!((recomputed - solution.report.objective).abs() < 1e-9 * recomputed.abs());
        }
    }

    #[test]
    fn two_points_give_the_textbook_answer() {
        // Linear kernel on x = +1 (t = +1) and x = −1 (t = −1): w = 1, w0 = 0, α = 1/2.
        let kernel = Mat::from_fn(2, 2, |i, j| if i == j { 1.0 } else { -1.0 });
        let solution = solve(&kernel, &[1.0, -1.0], 10.0, 1e-9, 100);
        assert!((solution.alpha[0] - 0.5).abs() < 1e-12);
        assert!((solution.alpha[1] - 0.5).abs() < 1e-12);
        assert!(solution.bias.abs() < 1e-12);
        assert!((solution.report.objective + 0.5).abs() < 1e-12);
    }

    #[test]
    fn identical_points_across_classes_terminate() {
        let kernel = Mat::from_fn(40, 40, |_, _| 1.0);
        let targets: Vec<f64> = (0..40).map(|i| if i < 25 { 1.0 } else { -1.0 }).collect();
        let solution = solve(&kernel, &targets, 1.0, 1e-3, 1_000_000);
        assert!(!solution.report.hit_cap);
        assert!(solution.report.iterations <= 40);
        assert!(solution.bias.is_finite());
    }

    #[test]
    fn the_iteration_cap_is_reported() {
        let (kernel, targets) = problem(9, 50, 0.5);
        let solution = solve(&kernel, &targets, 10.0, 1e-3, 3);
        assert!(solution.report.hit_cap);
        assert_eq!(solution.report.iterations, 3);
    }
}
