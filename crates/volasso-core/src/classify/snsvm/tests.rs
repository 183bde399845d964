//! Properties of one binary SN-SVM (snsvm.md §4.9, §12).

use faer::linalg::solvers::Solve;
use faer::{Mat, Side};

use super::*;
use crate::classify::kernel::{Kernel, row};
use crate::classify::params::SnSvmParams;
use crate::classify::smo::dual_objective;
use crate::classify::test_support::{SplitMix64, blobs};

struct Owned {
    points: Vec<f64>,
    first_class: Vec<bool>,
    dim: usize,
}

impl Owned {
    fn generate(seed: u64, per_class: usize, dim: usize, separation: f64) -> Owned {
        let mut rng = SplitMix64::new(seed);
        let (points, labels) = blobs(&mut rng, 2, per_class, dim, separation);
        Owned { points, first_class: labels.iter().map(|&l| l == 1).collect(), dim }
    }

    fn problem(&self) -> BinaryProblem<'_> {
        BinaryProblem { points: &self.points, dim: self.dim, first_class: &self.first_class, class_ids: (1, 2) }
    }

    fn permuted(&self, order: &[usize]) -> Owned {
        let mut points = Vec::with_capacity(self.points.len());
        for &i in order {
            points.extend_from_slice(row(&self.points, self.dim, i));
        }
        Owned { points, first_class: order.iter().map(|&i| self.first_class[i]).collect(), dim: self.dim }
    }
}

fn decision(owned: &Owned, kernel: &Kernel, model: &BinaryModel, x: &[f64]) -> f64 {
    owned.points.chunks_exact(owned.dim).zip(&model.gamma).map(|(p, g)| g * kernel.value(p, x)).sum::<f64>()
        + model.bias
}

fn test_points(seed: u64, count: usize, dim: usize) -> Vec<Vec<f64>> {
    let mut rng = SplitMix64::new(seed);
    (0..count).map(|_| (0..dim).map(|_| 2.0 * rng.normal()).collect()).collect()
}

fn eigenvalues(m: &Mat<f64>) -> Vec<f64> {
    m.self_adjoint_eigenvalues(Side::Lower).unwrap()
}

fn checked(params: SnSvmParams) -> SnSvmValidParams {
    params.check().unwrap()
}

#[test]
fn eta_zero_through_the_scatter_code_is_the_plain_svm() {
    let owned = Owned::generate(21, 40, 5, 1.2);
    let params = checked(SnSvmParams::plain_svm());
    let plain = train_binary(&owned.problem(), &params, ScatterPath::SkipWhenEtaIsZero).unwrap();
    let full = train_binary(&owned.problem(), &params, ScatterPath::AlwaysCompute).unwrap();
    let kernel = params.kernel;
    // The full path really ran: it found the scatter scales.
    assert!(full.spectra.nabla_largest_eigenvalue > 0.0);
    assert!(full.spectra.penalty_largest_eigenvalue > 0.0);
    assert_eq!(plain.spectra, PenaltySpectra::default());
    for x in test_points(3, 30, 5) {
        let (a, b) = (decision(&owned, &kernel, &plain, &x), decision(&owned, &kernel, &full, &x));
        assert!((a - b).abs() < 1e-9, "{a} vs {b}");
    }
    // And a vanishing eta tends to the plain SVM continuously.
    let tight = |eta| checked(SnSvmParams { eta, tolerance: 1e-10, ..SnSvmParams::default() });
    let reference = train_binary(&owned.problem(), &tight(0.0), ScatterPath::SkipWhenEtaIsZero).unwrap();
    let tiny = train_binary(&owned.problem(), &tight(1e-10), ScatterPath::SkipWhenEtaIsZero).unwrap();
    for x in test_points(4, 30, 5) {
        let (a, b) = (decision(&owned, &kernel, &reference, &x), decision(&owned, &kernel, &tiny, &x));
        assert!((a - b).abs() < 1e-7, "{a} vs {b}");
    }
}

#[test]
fn modified_kernel_is_symmetric_psd_and_below_k() {
    let owned = Owned::generate(8, 60, 5, 1.0);
    for (eta, scale_mode) in [(0.3, ScaleMode::Spectral), (3.0, ScaleMode::Spectral), (0.3, ScaleMode::Sum)] {
        let params = checked(SnSvmParams { eta, scale_mode, ..SnSvmParams::default() });
        let kernels = modified_kernel(&owned.problem(), &params, ScatterPath::SkipWhenEtaIsZero).unwrap();
        let (k, kt) = (&kernels.gram, &kernels.modified);
        let n = k.nrows();
        let mut largest_change = 0.0f64;
        for i in 0..n {
            assert!(kt[(i, i)] <= 1.0 + 1e-12, "diag(K~) <= k(x,x) = 1");
            for j in 0..n {
                assert_eq!(kt[(i, j)].to_bits(), kt[(j, i)].to_bits());
                largest_change = largest_change.max((k[(i, j)] - kt[(i, j)]).abs());
            }
        }
        assert!(largest_change > 1e-3, "the KND term must act (eta {eta}, {scale_mode:?})");
        let scale = eigenvalues(k).last().copied().unwrap();
        let smallest = eigenvalues(kt)[0];
        assert!(smallest >= -1e-9 * scale, "K~ PSD: smallest eigenvalue {smallest}");
        let difference = k - kt;
        assert!(eigenvalues(&difference)[0] >= -1e-9 * scale, "K~ <= K");
        if scale_mode == ScaleMode::Spectral {
            // T <= (1 + eta) I after spectral scaling, so K~ >= K / (1 + eta).
            let lower = kt - k * faer::Scale(1.0 / (1.0 + eta));
            assert!(eigenvalues(&lower)[0] >= -1e-9 * scale, "K~ >= K/(1+eta)");
        }
    }
}

#[test]
fn result_does_not_depend_on_the_order_of_training_points() {
    let owned = Owned::generate(31, 50, 5, 1.0);
    let params = checked(SnSvmParams { eta: 3.0, tolerance: 1e-10, ..SnSvmParams::default() });
    let original = train_binary(&owned.problem(), &params, ScatterPath::SkipWhenEtaIsZero).unwrap();
    let order = SplitMix64::new(99).permutation(owned.first_class.len());
    let permuted = owned.permuted(&order);
    let shuffled = train_binary(&permuted.problem(), &params, ScatterPath::SkipWhenEtaIsZero).unwrap();
    assert!(
        (original.spectra.penalty_largest_eigenvalue - shuffled.spectra.penalty_largest_eigenvalue).abs()
            < 1e-9 * original.spectra.penalty_largest_eigenvalue
    );
    for x in test_points(5, 40, 5) {
        let a = decision(&owned, &params.kernel, &original, &x);
        let b = decision(&permuted, &params.kernel, &shuffled, &x);
        assert!((a - b).abs() < 1e-6, "{a} vs {b}");
    }
}

/// The degree-2 polynomial feature map with (x.y + offset)^2 = Phi(x).Phi(y).
fn explicit_map(x: &[f64], offset: f64) -> Vec<f64> {
    let mut features = Vec::new();
    features.extend(x.iter().map(|v| v * v));
    for k in 0..x.len() {
        for l in k + 1..x.len() {
            features.push(std::f64::consts::SQRT_2 * x[k] * x[l]);
        }
    }
    features.extend(x.iter().map(|v| (2.0 * offset).sqrt() * v));
    features.push(offset);
    features
}

/// T = I + eta Delta (Nabla + beta I)^-1 Delta built from explicit features, with its own
/// kappa-NN search (snsvm.md §2, §3, §9), independent of `scatter`.
fn explicit_t(phi: &Mat<f64>, first_class: &[bool], kappa: usize, eta: f64, beta_relative: f64) -> Mat<f64> {
    let (h, n) = (phi.nrows(), phi.ncols());
    let distance = |i: usize, j: usize| (0..h).map(|r| (phi[(r, i)] - phi[(r, j)]).powi(2)).sum::<f64>();
    let mut delta = Mat::<f64>::zeros(h, h);
    let mut nabla = Mat::<f64>::zeros(h, h);
    for i in 0..n {
        let mut same: Vec<(f64, usize)> =
            (0..n).filter(|&j| j != i && first_class[j] == first_class[i]).map(|j| (distance(i, j), j)).collect();
        let mut other: Vec<(f64, usize)> =
            (0..n).filter(|&j| first_class[j] != first_class[i]).map(|j| (distance(i, j), j)).collect();
        same.sort_by(|a, b| a.0.total_cmp(&b.0));
        other.sort_by(|a, b| a.0.total_cmp(&b.0));
        same.truncate(kappa);
        other.truncate(kappa);
        let deviation = |hood: &[(f64, usize)]| -> Vec<f64> {
            (0..h)
                .map(|r| phi[(r, i)] - hood.iter().map(|&(_, j)| phi[(r, j)]).sum::<f64>() / hood.len() as f64)
                .collect()
        };
        let (dw, db) = (deviation(&same), deviation(&other));
        let (rho_w, rho_b) = (same.last().unwrap().0.sqrt(), other.last().unwrap().0.sqrt());
        let omega = rho_w.min(rho_b) / (rho_w + rho_b);
        for r in 0..h {
            for s in 0..h {
                delta[(r, s)] += dw[r] * dw[s];
                nabla[(r, s)] += omega * db[r] * db[s];
            }
        }
    }
    let beta = beta_relative * eigenvalues(&nabla).last().copied().unwrap();
    let shifted = &nabla + Mat::<f64>::identity(h, h) * faer::Scale(beta);
    let mut penalty = &delta * shifted.partial_piv_lu().solve(&delta);
    penalty = (&penalty + penalty.transpose()) * faer::Scale(0.5);
    let largest = eigenvalues(&penalty).last().copied().unwrap();
    Mat::<f64>::identity(h, h) + penalty * faer::Scale(eta / largest)
}

#[test]
fn decision_values_match_an_explicit_feature_map() {
    let offset = 1.0;
    let kernel = Kernel::Polynomial { degree: 2, offset };
    for (dim, seed) in [(2, 41), (3, 42)] {
        let owned = Owned::generate(seed, 15, dim, 1.5);
        let n = owned.first_class.len();
        let maps: Vec<Vec<f64>> = owned.points.chunks_exact(dim).map(|x| explicit_map(x, offset)).collect();
        let h = maps[0].len();
        assert_eq!(h, if dim == 2 { 6 } else { 10 });
        let phi = Mat::from_fn(h, n, |r, i| maps[i][r]);
        let (kappa, eta, beta_relative, c) = (3, 3.0, 0.1, 10.0);
        let t = explicit_t(&phi, &owned.first_class, kappa, eta, beta_relative);
        let t_lu = t.partial_piv_lu();
        let t_inverse_phi = t_lu.solve(&phi);
        let explicit_modified = phi.transpose() * &t_inverse_phi;

        let params =
            checked(SnSvmParams { kernel, c, eta, kappa, beta_relative, tolerance: 1e-10, ..SnSvmParams::default() });
        let kernels = modified_kernel(&owned.problem(), &params, ScatterPath::SkipWhenEtaIsZero).unwrap();
        let scale = (0..n).map(|i| kernels.gram[(i, i)]).fold(0.0, f64::max);
        for i in 0..n {
            for j in 0..n {
                let (ours, theirs) = (kernels.modified[(i, j)], explicit_modified[(i, j)]);
                assert!((ours - theirs).abs() < 1e-9 * scale, "K~[{i},{j}]: {ours} vs {theirs}");
            }
        }
        let model = train_binary(&owned.problem(), &params, ScatterPath::SkipWhenEtaIsZero).unwrap();
        let targets: Vec<f64> = owned.first_class.iter().map(|&f| if f { 1.0 } else { -1.0 }).collect();

        // w = T^-1 Phi (alpha .* t) from our alphas, and an SVM solved on the explicit Gram.
        let weight_of = |alpha: &[f64]| -> Vec<f64> {
            (0..h).map(|r| (0..n).map(|i| t_inverse_phi[(r, i)] * alpha[i] * targets[i]).sum()).collect()
        };
        let explicit = smo::solve(&explicit_modified, &targets, c, 1e-10, 1_000_000);
        let primal = |w: &[f64], bias: f64| -> f64 {
            let tw: Vec<f64> = (0..h).map(|r| (0..h).map(|s| t[(r, s)] * w[s]).sum()).collect();
            let regulariser = 0.5 * w.iter().zip(&tw).map(|(a, b)| a * b).sum::<f64>();
            let hinge: f64 = (0..n)
                .map(|i| (1.0 - targets[i] * (maps[i].iter().zip(w).map(|(p, q)| p * q).sum::<f64>() + bias)).max(0.0))
                .sum();
            regulariser + c * hinge
        };
        let ours_w = weight_of(&model.alpha);
        let explicit_w = weight_of(&explicit.alpha);
        let ours_primal = primal(&ours_w, model.bias);
        assert!((ours_primal - primal(&explicit_w, explicit.bias)).abs() < 1e-6 * ours_primal);
        // Zero duality gap: primal objective = -(LIBSVM objective).
        assert!((ours_primal + model.report.objective).abs() < 1e-6 * ours_primal);
        let mut gradient = vec![0.0; n];
        for i in 0..n {
            gradient[i] =
                (0..n).map(|j| targets[i] * targets[j] * explicit_modified[(i, j)] * model.alpha[j]).sum::<f64>() - 1.0;
        }
        assert!((dual_objective(&model.alpha, &gradient) - model.report.objective).abs() < 1e-8 * ours_primal);

        for x in test_points(seed + 100, 25, dim) {
            let map = explicit_map(&x, offset);
            let explicit_value = map.iter().zip(&explicit_w).map(|(p, q)| p * q).sum::<f64>() + explicit.bias;
            let from_alpha = map.iter().zip(&ours_w).map(|(p, q)| p * q).sum::<f64>() + model.bias;
            let ours = decision(&owned, &kernel, &model, &x);
            let tolerance = 1e-6 * (1.0 + ours.abs());
            assert!((ours - from_alpha).abs() < tolerance, "gamma form {ours} vs w form {from_alpha}");
            assert!((ours - explicit_value).abs() < tolerance, "ours {ours} vs explicit SVM {explicit_value}");
        }
    }
}

#[test]
fn vanishing_within_class_spread_leaves_the_kernel_unchanged() {
    // Every own-class neighbour is a duplicate: Delta = 0, so T = I and K~ = K. The zero
    // within-class radius also makes every boundary weight 0, so Nabla = 0 and beta falls back
    // to the kernel's scale (mean diagonal 1 for the RBF).
    let mut points = Vec::new();
    for _ in 0..6 {
        points.extend_from_slice(&[0.0, 1.0]);
    }
    for _ in 0..6 {
        points.extend_from_slice(&[1.5, -0.5]);
    }
    let owned = Owned { points, first_class: (0..12).map(|i| i < 6).collect(), dim: 2 };
    let params = checked(SnSvmParams::default());
    let kernels = modified_kernel(&owned.problem(), &params, ScatterPath::SkipWhenEtaIsZero).unwrap();
    assert_eq!(kernels.spectra.penalty_largest_eigenvalue, 0.0);
    assert_eq!(kernels.spectra.nabla_largest_eigenvalue, 0.0);
    assert_eq!(kernels.spectra.beta, 0.1);
    for i in 0..12 {
        for j in 0..12 {
            assert_eq!(kernels.modified[(i, j)], kernels.gram[(i, j)]);
        }
    }
    let model = train_binary(&owned.problem(), &params, ScatterPath::SkipWhenEtaIsZero).unwrap();
    assert!(decision(&owned, &params.kernel, &model, &[0.0, 1.0]) > 0.0);
    assert!(decision(&owned, &params.kernel, &model, &[1.5, -0.5]) < 0.0);
}
