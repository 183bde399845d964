//! Largest eigenvalues of products of two symmetric PSD matrices, λmax(XY), as the scatter
//! scales of snsvm.md §9 need: λmax(QK) for β and λmax(KR) for the spectral normalisation.
//!
//! Entry point: [`largest_eigenvalue_of_product`] (Lanczos in the Y inner product), with
//! [`point_dependent_start`] for an order-independent start. Never: forms XY, or computes
//! more than the top of the spectrum.

use faer::Mat;

use super::scatter::{add_scaled, dot};

/// Krylov dimension cap; the largest eigenvalue converges long before in practice.
const LANCZOS_STEPS: usize = 100;
const LANCZOS_TOLERANCE: f64 = 1e-14;

/// Largest eigenvalue of the symmetric tridiagonal matrix with this diagonal and off-diagonal.
fn tridiagonal_largest_eigenvalue(diagonal: &[f64], off_diagonal: &[f64]) -> f64 {
    let size = diagonal.len();
    let t = Mat::from_fn(size, size, |i, j| {
        if i == j {
            diagonal[i]
        } else if i == j + 1 {
            off_diagonal[j]
        } else if j == i + 1 {
            off_diagonal[i]
        } else {
            0.0
        }
    });
    t.self_adjoint_eigenvalues(faer::Side::Lower).ok().and_then(|values| values.last().copied()).unwrap_or(f64::NAN)
}

/// Largest eigenvalue of X Y for symmetric PSD X and Y, by Lanczos on X Y.
///
/// X Y is self-adjoint in the (semi-)inner product <u, v>_Y = uᵀYv, so Lanczos in that inner
/// product (with full re-orthogonalisation, applied twice) builds a symmetric tridiagonal
/// matrix whose largest eigenvalue converges from below to λmax(XY), typically in a few dozen
/// products where power iteration needs hundreds. `start` should depend only on the points
/// themselves (not on their order), so that the result is order-independent. Returns 0 when
/// X Y vanishes on the start vector.
pub(crate) fn largest_eigenvalue_of_product(
    apply_x: impl Fn(&[f64], &mut [f64]),
    apply_y: impl Fn(&[f64], &mut [f64]),
    start: &[f64],
) -> f64 {
    let count = start.len();
    let mut v = start.to_vec();
    let mut y_v = vec![0.0; count];
    apply_y(&v, &mut y_v);
    let norm_squared = dot(&v, &y_v);
    // Also catches NaN.
    if norm_squared.is_nan() || norm_squared <= 0.0 {
        return 0.0;
    }
    let scale = 1.0 / norm_squared.sqrt();
    v.iter_mut().chain(y_v.iter_mut()).for_each(|value| *value *= scale);
    let mut basis: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    let (mut diagonal, mut off_diagonal) = (Vec::new(), Vec::new());
    let mut estimate = 0.0f64;
    for _ in 0..LANCZOS_STEPS.min(count) {
        let mut w = vec![0.0; count];
        apply_x(&y_v, &mut w);
        diagonal.push(dot(&w, &y_v));
        basis.push((v, y_v));
        for _ in 0..2 {
            for (b, y_b) in &basis {
                add_scaled(-dot(&w, y_b), b, &mut w);
            }
        }
        let latest = tridiagonal_largest_eigenvalue(&diagonal, &off_diagonal);
        if !latest.is_finite() {
            break;
        }
        let converged = (latest - estimate).abs() <= LANCZOS_TOLERANCE * latest.abs();
        estimate = estimate.max(latest);
        let mut y_w = vec![0.0; count];
        apply_y(&w, &mut y_w);
        let beta_squared = dot(&w, &y_w);
        // An (almost) invariant Krylov space holds the eigenvalue exactly.
        if converged || beta_squared.is_nan() || beta_squared <= (1e-14 * estimate).powi(2) {
            break;
        }
        let beta = beta_squared.sqrt();
        off_diagonal.push(beta);
        v = w.iter().map(|value| value / beta).collect();
        y_v = y_w.iter().map(|value| value / beta).collect();
    }
    estimate.max(0.0)
}

/// A start vector for [`largest_eigenvalue_of_product`] that is a function of each point alone:
/// generic enough not to be orthogonal to the top eigenvector, and order-independent.
pub(crate) fn point_dependent_start(points: &[f64], dim: usize) -> Vec<f64> {
    points
        .chunks_exact(dim)
        .map(|x| {
            let phase: f64 = x.iter().enumerate().map(|(k, v)| (k as f64 + 1.0) * v).sum();
            1.0 + 0.25 * (phase + 0.5).cos()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::classify::scatter::symmetric_times;
    use crate::classify::test_support::SplitMix64;

    #[test]
    fn lanczos_finds_the_largest_eigenvalue_of_a_psd_product() {
        let mut rng = SplitMix64::new(5);
        let n = 12;
        let f = Mat::from_fn(n, n, |_, _| rng.normal());
        let g = Mat::from_fn(n, 4, |_, _| rng.normal());
        let x = &f * f.transpose();
        let y = &g * g.transpose(); // rank 4: singular, like a scatter matrix
        let xy = &x * &y;
        let exact = xy.eigenvalues().unwrap().iter().map(|c| c.re).fold(f64::MIN, f64::max);
        let start: Vec<f64> = (0..n).map(|i| 1.0 + 0.1 * i as f64).collect();
        let estimate = largest_eigenvalue_of_product(
            |v, out| symmetric_times(&x, v, out),
            |v, out| symmetric_times(&y, v, out),
            &start,
        );
        assert!((estimate - exact).abs() < 1e-12 * exact, "{estimate} vs {exact}");
        let zero = largest_eigenvalue_of_product(|_, out| out.fill(0.0), |v, out| out.copy_from_slice(v), &start);
        assert_eq!(zero, 0.0);
    }
}
