//! Eigenvalues of symmetric 3 x 3 matrices, for the Hessian features of [`super::multiscale`]:
//! the trigonometric closed form (Smith 1961), one matrix at a time or a group side by side.
//!
//! Both forms run the same operations in the same order, so a matrix gets the same bits either
//! way (the features use the group form only); the group form lets the compiler keep several matrices in one vector register, and the
//! processor overlap their long chains of dependent square roots and divisions.

/// Eigenvalues, ascending, of the symmetric 3x3 matrix [[a, d, e], [d, b, f], [e, f, c]] given
/// as [a, b, c, d, e, f]: the one-matrix reference for the group form.
#[cfg(test)]
pub fn symmetric_eigenvalues(matrix: [f64; 6]) -> [f32; 3] {
    if is_diagonal(matrix) { sorted_diagonal(matrix) } else { closed_form(matrix) }
}

/// [`symmetric_eigenvalues`] of `LANES` matrices given entry by entry: `matrices[k][lane]` is
/// entry k of matrix `lane`. Returns `values[k][lane]`, the k-th smallest eigenvalue of each.
#[inline(always)]
pub fn symmetric_eigenvalues_lanes<const LANES: usize>(matrices: &[[f64; LANES]; 6]) -> [[f32; LANES]; 3] {
    let matrix = |lane: usize| -> [f64; 6] { std::array::from_fn(|k| matrices[k][lane]) };
    let mut values = [[0f32; LANES]; 3];
    // Branch-free over every lane first (a diagonal lane's result is discarded), so that the
    // loop vectorises; then the rare diagonal lanes one by one.
    for lane in 0..LANES {
        let lane_values = closed_form(matrix(lane));
        for (column, value) in values.iter_mut().zip(lane_values) {
            column[lane] = value;
        }
    }
    for lane in 0..LANES {
        if is_diagonal(matrix(lane)) {
            for (column, value) in values.iter_mut().zip(sorted_diagonal(matrix(lane))) {
                column[lane] = value;
            }
        }
    }
    values
}

/// Whether the off-diagonal entries are negligible, where the closed form divides by ~0.
#[inline(always)]
fn is_diagonal([a, b, c, d, e, f]: [f64; 6]) -> bool {
    d * d + e * e + f * f <= 1e-30 * (a * a + b * b + c * c).max(1e-300)
}

fn sorted_diagonal([a, b, c, ..]: [f64; 6]) -> [f32; 3] {
    let mut values = [a as f32, b as f32, c as f32];
    values.sort_by(f32::total_cmp);
    values
}

/// The closed form for a matrix that is not diagonal.
#[inline(always)]
fn closed_form([a, b, c, d, e, f]: [f64; 6]) -> [f32; 3] {
    let off = d * d + e * e + f * f;
    let q = (a + b + c) / 3.0;
    let p2 = (a - q).powi(2) + (b - q).powi(2) + (c - q).powi(2) + 2.0 * off;
    let p = (p2 / 6.0).sqrt();
    // B = (A - qI) / p; r = det(B) / 2 lies in [-1, 1] up to rounding.
    let inverse_p = 1.0 / p;
    let (ba, bb, bc, bd, be, bf) =
        ((a - q) * inverse_p, (b - q) * inverse_p, (c - q) * inverse_p, d * inverse_p, e * inverse_p, f * inverse_p);
    let determinant = ba * (bb * bc - bf * bf) - bd * (bd * bc - bf * be) + be * (bd * bf - bb * be);
    // phi = acos(r) / 3 lies in [0, pi / 3]; cos(phi + 2 pi / 3) = -cos(phi) / 2 -
    // sin(phi) sqrt(3) / 2. Polynomials instead of libm's acos and cos: this runs for every
    // classified voxel, and 1e-7 relative error is far below what the classifier resolves.
    let phi = acos_polynomial((determinant / 2.0).clamp(-1.0, 1.0)) / 3.0;
    let cos_phi = cos_polynomial(phi);
    let sin_phi = (1.0 - cos_phi * cos_phi).max(0.0).sqrt();
    let high = q + 2.0 * p * cos_phi;
    let low = q + 2.0 * p * (-0.5 * cos_phi - 0.5 * 3f64.sqrt() * sin_phi);
    let middle = 3.0 * q - high - low;
    [low as f32, middle as f32, high as f32]
}

/// acos(x) for x in [-1, 1], absolute error below 1e-7 (Abramowitz and Stegun 4.4.46:
/// sqrt(1 - x) times a degree-7 polynomial on [0, 1], and acos(-x) = pi - acos(x)).
#[inline(always)]
pub fn acos_polynomial(x: f64) -> f64 {
    const COEFFICIENTS: [f64; 8] = [
        1.570_796_305_0,
        -0.214_598_801_6,
        0.088_978_987_4,
        -0.050_174_304_6,
        0.030_891_881_0,
        -0.017_088_125_6,
        0.006_670_090_1,
        -0.001_262_491_1,
    ];
    let magnitude = x.abs().min(1.0);
    let polynomial = COEFFICIENTS.iter().rev().fold(0.0, |sum, &c| sum * magnitude + c);
    let angle = (1.0 - magnitude).sqrt() * polynomial;
    if x < 0.0 { std::f64::consts::PI - angle } else { angle }
}

/// cos(x) for x in [0, pi / 3] (Taylor series to x^12: error below 1e-10 there).
#[inline(always)]
pub fn cos_polynomial(x: f64) -> f64 {
    // 1 - x^2/2! + x^4/4! - ... + x^12/12!, by Horner in x^2: 1 - x^2/(2*1) (1 - x^2/(4*3) (...)).
    const INVERSE_STEPS: [f64; 6] = [1.0 / 2.0, 1.0 / 12.0, 1.0 / 30.0, 1.0 / 56.0, 1.0 / 90.0, 1.0 / 132.0];
    let x2 = x * x;
    INVERSE_STEPS.iter().rev().fold(1.0, |sum, &inverse| 1.0 - sum * x2 * inverse)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigenvalues_of_diagonal_and_rotated_matrices() {
        assert_eq!(symmetric_eigenvalues([3.0, -1.0, 2.0, 0.0, 0.0, 0.0]), [-1.0, 2.0, 3.0]);
        // [[2, 1, 0], [1, 2, 0], [0, 0, 5]] has eigenvalues 1, 3, 5.
        let values = symmetric_eigenvalues([2.0, 2.0, 5.0, 1.0, 0.0, 0.0]);
        for (v, expected) in values.iter().zip([1.0, 3.0, 5.0]) {
            assert!((v - expected).abs() < 1e-5, "{values:?}");
        }
        // A rank-one matrix u u^T with |u|^2 = 14: eigenvalues 0, 0, 14.
        let u = [1.0, 2.0, 3.0];
        let values = symmetric_eigenvalues([1.0, 4.0, 9.0, u[0] * u[1], u[0] * u[2], u[1] * u[2]]);
        for (v, expected) in values.iter().zip([0.0, 0.0, 14.0]) {
            assert!((v - expected).abs() < 1e-4, "{values:?}");
        }
    }

    #[test]
    fn polynomial_acos_and_cos_match_the_library() {
        for k in 0..=2000 {
            let x = -1.0 + k as f64 / 1000.0;
            assert!((acos_polynomial(x) - x.acos()).abs() < 1e-7, "acos({x})");
        }
        for k in 0..=1000 {
            let x = k as f64 / 1000.0 * std::f64::consts::FRAC_PI_3;
            assert!((cos_polynomial(x) - x.cos()).abs() < 1e-10, "cos({x})");
        }
    }

    /// Entry `k` of random matrix `seed`, in [-10, 10].
    fn entry(seed: u64, k: u64) -> f64 {
        (crate::rng::hash64(seed, k) % 2001) as f64 / 100.0 - 10.0
    }

    #[test]
    fn eigenvalues_of_random_symmetric_matrices_match_their_invariants() {
        // Trace, the sum of principal 2x2 minors and the determinant are the elementary
        // symmetric functions of the eigenvalues.
        for seed in 0..200u64 {
            let [a, b, c, d, e, f] = std::array::from_fn(|k| entry(seed, k as u64));
            let [l0, l1, l2] = symmetric_eigenvalues([a, b, c, d, e, f]).map(f64::from);
            assert!(l0 <= l1 && l1 <= l2);
            let scale = 1.0 + a.abs() + b.abs() + c.abs() + d.abs() + e.abs() + f.abs();
            let trace = a + b + c;
            let minors = a * b + a * c + b * c - d * d - e * e - f * f;
            let determinant = a * (b * c - f * f) - d * (d * c - f * e) + e * (d * f - b * e);
            assert!((l0 + l1 + l2 - trace).abs() < 1e-4 * scale, "seed {seed}");
            assert!((l0 * l1 + l0 * l2 + l1 * l2 - minors).abs() < 1e-4 * scale * scale, "seed {seed}");
            assert!((l0 * l1 * l2 - determinant).abs() < 1e-4 * scale * scale * scale, "seed {seed}");
        }
    }

    #[test]
    fn lanes_give_the_bits_of_one_matrix_at_a_time() {
        // Random matrices, with diagonal, zero, infinite and NaN ones among them.
        let mut matrices = [[0f64; 8]; 6];
        for lane in 0..8 {
            for (k, row) in matrices.iter_mut().enumerate() {
                row[lane] = entry(lane as u64 + 1000, k as u64);
            }
        }
        for off_diagonal in &mut matrices[3..] {
            off_diagonal[2] = 0.0;
            off_diagonal[5] = 0.0;
        }
        matrices[0][5] = f64::INFINITY;
        matrices[0][6] = f64::NAN;
        let values = symmetric_eigenvalues_lanes(&matrices);
        for lane in 0..8 {
            let alone = symmetric_eigenvalues(std::array::from_fn(|k| matrices[k][lane]));
            let together = [values[0][lane], values[1][lane], values[2][lane]];
            assert_eq!(together.map(f32::to_bits), alone.map(f32::to_bits), "lane {lane}");
        }
    }
}
