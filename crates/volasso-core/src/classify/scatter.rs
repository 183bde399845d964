//! KND scatter operators of one binary problem (snsvm.md §2): kappa-nearest-neighbour
//! coefficient vectors a_i, b_i, the boundary weights omega_i, and the sparse-times-dense
//! products that turn them into P = A A^T and Q = B Omega B^T without forming either densely.
//!
//! Nouns: column i of A is a_i = e_i - mean_{j in W(i)} e_j (own-class neighbours, i excluded),
//! column i of B is b_i = e_i - mean_{j in B(i)} e_j (other-class neighbours). Each has at most
//! kappa + 1 nonzeros, so every product with A or B costs O(N^2 kappa), not O(N^3).
//! Entry point: [`neighbourhoods`]. Never: inverts anything or solves the QP.

use faer::Mat;

use super::kernel::{Kernel, row};

/// An N x N matrix stored by columns, each a short list of (row, value).
#[derive(Debug, Clone)]
pub(crate) struct SparseColumns {
    pub columns: Vec<Vec<(usize, f64)>>,
}

/// A, B and omega of one binary problem.
#[derive(Debug, Clone)]
pub(crate) struct Neighbourhoods {
    /// A: within-class deviation coefficients a_i.
    pub within: SparseColumns,
    /// B: between-class deviation coefficients b_i.
    pub between: SparseColumns,
    /// omega_i in [0, 1/2]: about 1/2 near the class boundary, towards 0 far from it.
    pub boundary_weights: Vec<f64>,
}

/// Orders neighbour candidates by feature-space distance, then by the feature vector itself.
/// Breaking ties by the vector rather than by the index keeps the choice independent of the
/// order of the training points (uint8 volumes give many exactly equal distances); candidates
/// equal in both are identical points, so which one is taken does not matter.
fn closer(points: &[f64], dim: usize) -> impl Fn(&(f64, usize), &(f64, usize)) -> std::cmp::Ordering + '_ {
    move |a, b| {
        a.0.total_cmp(&b.0).then_with(|| {
            let (x, y) = (row(points, dim, a.1), row(points, dim, b.1));
            x.iter().zip(y).map(|(p, q)| p.total_cmp(q)).find(|o| o.is_ne()).unwrap_or(std::cmp::Ordering::Equal)
        })
    }
}

/// Keeps the `count` nearest candidates (unsorted) and returns the index of the farthest kept
/// one, or `None` when `count` is 0.
fn keep_nearest(candidates: &mut Vec<(f64, usize)>, count: usize, points: &[f64], dim: usize) -> Option<usize> {
    if count == 0 {
        candidates.clear();
        return None;
    }
    if count < candidates.len() {
        candidates.select_nth_unstable_by(count - 1, closer(points, dim));
        candidates.truncate(count);
    }
    candidates.iter().copied().max_by(closer(points, dim)).map(|(_, j)| j)
}

/// Deviation coefficients e_i - mean over `neighbours` of e_j.
fn deviation(index: usize, neighbours: &[(f64, usize)]) -> Vec<(usize, f64)> {
    if neighbours.is_empty() {
        // A class with a single point has no local spread: a_i = 0 rather than 0/0.
        return Vec::new();
    }
    let share = -1.0 / neighbours.len() as f64;
    let mut coefficients = Vec::with_capacity(neighbours.len() + 1);
    coefficients.push((index, 1.0));
    coefficients.extend(neighbours.iter().map(|&(_, j)| (j, share)));
    coefficients
}

/// Fukunaga's NDA weight from the squared neighbourhood radii (snsvm.md §2).
fn boundary_weight(within_radius_squared: Option<f64>, between_radius_squared: f64, exponent: f64) -> f64 {
    let Some(within_radius_squared) = within_radius_squared else {
        // No own-class neighbour: nothing says the point is far from the boundary.
        return 0.5;
    };
    let within = within_radius_squared.sqrt().powf(exponent);
    let between = between_radius_squared.sqrt().powf(exponent);
    let total = within + between;
    if total > 0.0 { within.min(between) / total } else { 0.5 }
}

/// kappa-NN neighbourhoods of every point in feature-space distance (snsvm.md §2, §7), ranked
/// by [`Kernel::neighbour_rank_distance`] (the same order, cheaper for the RBF).
/// `first_class[i]` says whether point i has t_i = +1; both classes must be non-empty.
pub(crate) fn neighbourhoods(
    kernel: &Kernel,
    points: &[f64],
    dim: usize,
    first_class: &[bool],
    kappa: usize,
    weight_exponent: f64,
) -> Neighbourhoods {
    let count = first_class.len();
    let first_count = first_class.iter().filter(|&&f| f).count();
    let mut within = Vec::with_capacity(count);
    let mut between = Vec::with_capacity(count);
    let mut boundary_weights = Vec::with_capacity(count);
    let mut same = Vec::with_capacity(count);
    let mut other = Vec::with_capacity(count);
    for i in 0..count {
        let x_i = row(points, dim, i);
        same.clear();
        other.clear();
        for (j, &first) in first_class.iter().enumerate() {
            if j == i {
                continue;
            }
            let candidate = (kernel.neighbour_rank_distance(x_i, row(points, dim, j)), j);
            if first == first_class[i] {
                same.push(candidate);
            } else {
                other.push(candidate);
            }
        }
        let own_count = if first_class[i] { first_count } else { count - first_count };
        let within_count = kappa.min(own_count - 1);
        let between_count = kappa.min(count - own_count);
        let radius_squared = |farthest: usize| kernel.feature_distance_squared(x_i, row(points, dim, farthest));
        let within_radius = keep_nearest(&mut same, within_count, points, dim).map(radius_squared);
        let between_radius = keep_nearest(&mut other, between_count, points, dim).map_or(0.0, radius_squared);
        within.push(deviation(i, &same));
        between.push(deviation(i, &other));
        boundary_weights.push(boundary_weight(within_radius, between_radius, weight_exponent));
    }
    Neighbourhoods {
        within: SparseColumns { columns: within },
        between: SparseColumns { columns: between },
        boundary_weights,
    }
}

pub(crate) fn add_scaled(scale: f64, source: &[f64], target: &mut [f64]) {
    for (t, s) in target.iter_mut().zip(source) {
        *t += scale * s;
    }
}

pub(crate) fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

/// X S: column i is sum over (j, v) in s_i of v X[:, j].
pub(crate) fn dense_times_sparse(x: &Mat<f64>, s: &SparseColumns) -> Mat<f64> {
    let mut out = Mat::<f64>::zeros(x.nrows(), s.columns.len());
    for (i, column) in s.columns.iter().enumerate() {
        let target = out.col_as_slice_mut(i);
        for &(j, v) in column {
            add_scaled(v, x.col_as_slice(j), target);
        }
    }
    out
}

/// X diag(w) S^T (w = 1 when `weights` is `None`): column j gathers w_i v X[:, i] for every
/// entry (j, v) of every s_i.
pub(crate) fn dense_times_sparse_transposed(x: &Mat<f64>, s: &SparseColumns, weights: Option<&[f64]>) -> Mat<f64> {
    let mut out = Mat::<f64>::zeros(x.nrows(), s.columns.len());
    for (i, column) in s.columns.iter().enumerate() {
        let weight = weights.map_or(1.0, |w| w[i]);
        if weight == 0.0 {
            continue;
        }
        for &(j, v) in column {
            add_scaled(weight * v, x.col_as_slice(i), out.col_as_slice_mut(j));
        }
    }
    out
}

/// S X: column c is sum over k of X[k, c] s_k.
pub(crate) fn sparse_times_dense(s: &SparseColumns, x: &Mat<f64>) -> Mat<f64> {
    let mut out = Mat::<f64>::zeros(s.columns.len(), x.ncols());
    for c in 0..x.ncols() {
        let source = x.col_as_slice(c);
        let target = out.col_as_slice_mut(c);
        for (k, column) in s.columns.iter().enumerate() {
            let scale = source[k];
            if scale == 0.0 {
                continue;
            }
            for &(r, v) in column {
                target[r] += scale * v;
            }
        }
    }
    out
}

/// S^T X: entry (i, c) is s_i . X[:, c].
pub(crate) fn sparse_transposed_times_dense(s: &SparseColumns, x: &Mat<f64>) -> Mat<f64> {
    let mut out = Mat::<f64>::zeros(s.columns.len(), x.ncols());
    for c in 0..x.ncols() {
        let source = x.col_as_slice(c);
        let target = out.col_as_slice_mut(c);
        for (i, column) in s.columns.iter().enumerate() {
            target[i] = column.iter().map(|&(r, v)| v * source[r]).sum();
        }
    }
    out
}

/// out = Q v = B Omega B^T v in O(N kappa).
pub(crate) fn between_scatter_times(hoods: &Neighbourhoods, v: &[f64], out: &mut [f64]) {
    out.fill(0.0);
    for (column, &weight) in hoods.between.columns.iter().zip(&hoods.boundary_weights) {
        let projection: f64 = column.iter().map(|&(r, value)| value * v[r]).sum();
        for &(r, value) in column {
            out[r] += weight * projection * value;
        }
    }
}

/// out = M v for a symmetric M, reading columns (contiguous in faer) as rows.
pub(crate) fn symmetric_times(m: &Mat<f64>, v: &[f64], out: &mut [f64]) {
    for (i, o) in out.iter_mut().enumerate() {
        *o = dot(m.col_as_slice(i), v);
    }
}

/// M <- (M + M^T) / 2. Round-off leaves tiny asymmetries that would upset SMO (snsvm.md §6).
pub(crate) fn symmetrise(m: &mut Mat<f64>) {
    for j in 0..m.ncols() {
        for i in 0..j {
            let mean = 0.5 * (m[(i, j)] + m[(j, i)]);
            m[(i, j)] = mean;
            m[(j, i)] = mean;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::classify::test_support::SplitMix64;

    fn dense(s: &SparseColumns) -> Mat<f64> {
        let n = s.columns.len();
        let mut m = Mat::<f64>::zeros(n, n);
        for (i, column) in s.columns.iter().enumerate() {
            for &(r, v) in column {
                m[(r, i)] += v;
            }
        }
        m
    }

    fn max_difference(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
        let mut worst = 0.0f64;
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                worst = worst.max((a[(i, j)] - b[(i, j)]).abs());
            }
        }
        worst
    }

    #[test]
    fn neighbourhoods_follow_the_definition() {
        // 1-D points: class + at 0, 1, 3; class - at 10, 11.
        let points = [0.0, 1.0, 3.0, 10.0, 11.0];
        let first = [true, true, true, false, false];
        let kernel = Kernel::Rbf { width: 0.01 };
        let hoods = neighbourhoods(&kernel, &points, 1, &first, 1, 1.0);
        // Point 2 (at 3): own nearest is 1 (at 1), other nearest is 3 (at 10).
        let mut a2 = hoods.within.columns[2].clone();
        a2.sort_by_key(|e| e.0);
        assert_eq!(a2, vec![(1, -1.0), (2, 1.0)]);
        let mut b2 = hoods.between.columns[2].clone();
        b2.sort_by_key(|e| e.0);
        assert_eq!(b2, vec![(2, 1.0), (3, -1.0)]);
        let rho_w = kernel.feature_distance_squared(&[3.0], &[1.0]).sqrt();
        let rho_b = kernel.feature_distance_squared(&[3.0], &[10.0]).sqrt();
        let expected = rho_w.min(rho_b) / (rho_w + rho_b);
        assert!((hoods.boundary_weights[2] - expected).abs() < 1e-15);
        // kappa larger than the class: clipped to n_class - 1 and n_other.
        let hoods = neighbourhoods(&kernel, &points, 1, &first, 9, 1.0);
        assert_eq!(hoods.within.columns[3].len(), 2);
        assert_eq!(hoods.between.columns[3].len(), 4);
        for column in hoods.within.columns.iter().chain(&hoods.between.columns) {
            let sum: f64 = column.iter().map(|e| e.1).sum();
            assert!(sum.abs() < 1e-15, "deviation coefficients sum to 0");
        }
        for &omega in &hoods.boundary_weights {
            assert!((0.0..=0.5).contains(&omega));
        }
    }

    #[test]
    fn duplicates_give_half_weight_and_zero_deviation() {
        let points = [2.0, 2.0, 2.0, 2.0];
        let first = [true, true, false, false];
        let hoods = neighbourhoods(&Kernel::Rbf { width: 0.5 }, &points, 1, &first, 5, 1.0);
        assert!(hoods.boundary_weights.iter().all(|&w| w == 0.5));
        // A single-point class has no within-class deviation and weight 1/2.
        let hoods = neighbourhoods(&Kernel::Rbf { width: 0.5 }, &[0.0, 1.0, 2.0], 1, &[true, false, false], 5, 1.0);
        assert!(hoods.within.columns[0].is_empty());
        assert_eq!(hoods.boundary_weights[0], 0.5);
    }

    #[test]
    fn sparse_products_match_dense_products() {
        let mut rng = SplitMix64::new(11);
        let n = 9;
        let x = Mat::from_fn(n, n, |_, _| rng.normal());
        let points: Vec<f64> = (0..n * 2).map(|_| rng.normal()).collect();
        let first: Vec<bool> = (0..n).map(|i| i % 3 != 0).collect();
        let hoods = neighbourhoods(&Kernel::Rbf { width: 0.4 }, &points, 2, &first, 2, 1.0);
        let a = dense(&hoods.within);
        let omega = Mat::from_fn(n, n, |i, j| if i == j { hoods.boundary_weights[i] } else { 0.0 });
        let tol = 1e-12;
        assert!(max_difference(&dense_times_sparse(&x, &hoods.within), &(&x * &a)) < tol);
        let xs_t = dense_times_sparse_transposed(&x, &hoods.within, None);
        assert!(max_difference(&xs_t, &(&x * a.transpose())) < tol);
        let b = dense(&hoods.between);
        let weighted = dense_times_sparse_transposed(&x, &hoods.between, Some(&hoods.boundary_weights));
        assert!(max_difference(&weighted, &(&x * &omega * b.transpose())) < tol);
        assert!(max_difference(&sparse_times_dense(&hoods.within, &x), &(&a * &x)) < tol);
        let st_x = sparse_transposed_times_dense(&hoods.within, &x);
        assert!(max_difference(&st_x, &(a.transpose() * &x)) < tol);
        let v: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
        let mut qv = vec![0.0; n];
        between_scatter_times(&hoods, &v, &mut qv);
        let q = &b * &omega * b.transpose();
        for i in 0..n {
            let expected: f64 = (0..n).map(|j| q[(i, j)] * v[j]).sum();
            assert!((qv[i] - expected).abs() < tol);
        }
    }
}
