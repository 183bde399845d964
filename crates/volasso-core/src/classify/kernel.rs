//! Kernels k(x, y) and the f64 Gram matrices training needs (snsvm.md §1).
//!
//! The product uses the RBF k(x, y) = exp(-g ||x - y||^2) (g is LIBSVM's "gamma", here
//! `width`). The polynomial kernel (x.y + offset)^degree has an explicit finite feature map and
//! serves the independent check of snsvm.md §12. Never: evaluates kernels in f32 for voxels
//! (that is `predict`), or knows about classes.

use faer::Mat;

/// A positive semi-definite kernel on R^dim.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kernel {
    /// k(x, y) = exp(-width ||x - y||^2).
    Rbf {
        /// The factor on the squared distance; larger values make the kernel more local.
        width: f64,
    },
    /// k(x, y) = (x.y + offset)^degree.
    Polynomial {
        /// The exponent.
        degree: u32,
        /// The constant added to the dot product.
        offset: f64,
    },
}

pub(crate) fn squared_distance(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| (a - b) * (a - b)).sum()
}

fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

impl Kernel {
    /// k(x, y) in f64.
    pub fn value(&self, x: &[f64], y: &[f64]) -> f64 {
        match *self {
            Kernel::Rbf { width } => (-width * squared_distance(x, y)).exp(),
            Kernel::Polynomial { degree, offset } => {
                (dot(x, y) + offset).powi(i32::try_from(degree).unwrap_or(i32::MAX))
            }
        }
    }

    /// A distance whose order is the order of D^2(x, y), for ranking neighbours: for the RBF the
    /// squared input distance (D^2 is monotone in it and needs an exp), otherwise D^2 itself.
    pub fn neighbour_rank_distance(&self, x: &[f64], y: &[f64]) -> f64 {
        match *self {
            Kernel::Rbf { .. } => squared_distance(x, y),
            Kernel::Polynomial { .. } => self.feature_distance_squared(x, y),
        }
    }

    /// Squared feature-space distance D^2(x, y) = k(x,x) + k(y,y) - 2 k(x,y) (snsvm.md §1).
    ///
    /// For the RBF it is computed as -2 expm1(-g ||x-y||^2), which keeps full relative precision
    /// for close points, where 2 - 2 k(x, y) would cancel; it stays monotone in the input
    /// distance, so feature-space and input-space neighbours agree.
    pub fn feature_distance_squared(&self, x: &[f64], y: &[f64]) -> f64 {
        match *self {
            Kernel::Rbf { width } => -2.0 * (-width * squared_distance(x, y)).exp_m1(),
            Kernel::Polynomial { .. } => {
                let d2 = self.value(x, x) + self.value(y, y) - 2.0 * self.value(x, y);
                d2.max(0.0)
            }
        }
    }
}

/// Row `index` of a row-major point matrix.
pub(crate) fn row(points: &[f64], dim: usize, index: usize) -> &[f64] {
    &points[index * dim..(index + 1) * dim]
}

/// The N x N Gram matrix K_ij = k(x_i, x_j), exactly symmetric (the upper triangle is mirrored)
/// so that every later "symmetrise" starts from a symmetric matrix.
pub(crate) fn gram(kernel: &Kernel, points: &[f64], dim: usize) -> Mat<f64> {
    let count = points.len() / dim;
    let mut gram = Mat::<f64>::zeros(count, count);
    for j in 0..count {
        let x_j = row(points, dim, j);
        for i in 0..=j {
            let value = kernel.value(row(points, dim, i), x_j);
            gram[(i, j)] = value;
            gram[(j, i)] = value;
        }
    }
    gram
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rbf_and_polynomial_values() {
        let rbf = Kernel::Rbf { width: 0.5 };
        assert_eq!(rbf.value(&[1.0, 2.0], &[1.0, 2.0]), 1.0);
        let expected = (-0.5f64 * 5.0).exp();
        assert!((rbf.value(&[0.0, 0.0], &[1.0, 2.0]) - expected).abs() < 1e-15);
        let poly = Kernel::Polynomial { degree: 2, offset: 1.0 };
        assert_eq!(poly.value(&[1.0, 2.0], &[3.0, -1.0]), 4.0);
    }

    #[test]
    fn feature_distance_matches_the_kernel_identity() {
        let points = [[0.3, -1.2, 0.5], [0.31, -1.2, 0.5], [2.0, 0.0, -1.0]];
        for kernel in [Kernel::Rbf { width: 0.7 }, Kernel::Polynomial { degree: 2, offset: 0.5 }] {
            for x in &points {
                for y in &points {
                    let identity = kernel.value(x, x) + kernel.value(y, y) - 2.0 * kernel.value(x, y);
                    let d2 = kernel.feature_distance_squared(x, y);
                    assert!((d2 - identity).abs() < 1e-12 * (1.0 + identity.abs()), "{d2} {identity}");
                    assert!(d2 >= 0.0);
                }
            }
        }
    }

    #[test]
    fn gram_is_exactly_symmetric() {
        let points = [0.1, 0.2, -0.4, 1.0, 2.5, -3.0, 0.0, 0.7];
        let gram = gram(&Kernel::Rbf { width: 0.3 }, &points, 2);
        for i in 0..4 {
            assert_eq!(gram[(i, i)], 1.0);
            for j in 0..4 {
                assert_eq!(gram[(i, j)].to_bits(), gram[(j, i)].to_bits());
            }
        }
    }
}
