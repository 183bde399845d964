//! SN-SVM hyper-parameters (snsvm.md §9) and their one-time check.
//!
//! [`SnSvmParams`] is what a caller fills in; [`SnSvmParams::check`] turns it into
//! [`SnSvmValidParams`], the only form training accepts, so that no training stage has to
//! re-validate. Never: reads a file or the command line.

use super::error::ClassifyError;
use super::kernel::Kernel;

/// How the KND penalty operator R is normalised (snsvm.md §9, "scale").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ScaleMode {
    /// R /= lambda_max(K R): eta is then the largest extra penalty relative to ||w||^2,
    /// independent of the number of points and of the kernel width. Recommended.
    #[default]
    Spectral,
    /// Plain sums over the neighbourhoods (s_w = s_b = 1), no normalisation.
    Sum,
}

/// Everything that defines one SN-SVM training run. `Default` is snsvm.md §9.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SnSvmParams {
    /// The kernel k(x, y); the product uses the RBF.
    pub kernel: Kernel,
    /// Box constraint C of the dual (0 <= alpha <= C).
    pub c: f64,
    /// Weight eta of the KND term in T = I + eta Delta (Nabla + beta I)^-1 Delta; 0 is the
    /// plain kernel SVM and skips all scatter work.
    pub eta: f64,
    /// Number of nearest neighbours kappa for the local means (clipped per class).
    pub kappa: usize,
    /// Exponent p of the boundary weight omega = min(rho_w^p, rho_b^p) / (rho_w^p + rho_b^p).
    pub weight_exponent: f64,
    /// beta = beta_relative * lambda_max(Nabla), so that beta is scale-free.
    pub beta_relative: f64,
    /// Normalisation of the penalty operator.
    pub scale_mode: ScaleMode,
    /// SMO stops when m(alpha) - M(alpha) < tolerance (LIBSVM's eps).
    pub tolerance: f64,
    /// SMO iteration cap; hitting it is reported, not an error.
    pub max_iterations: usize,
}

impl Default for SnSvmParams {
    fn default() -> Self {
        Self {
            kernel: Kernel::Rbf { width: 0.5 },
            c: 1.0,
            eta: 0.3,
            kappa: 5,
            weight_exponent: 1.0,
            beta_relative: 0.1,
            scale_mode: ScaleMode::Spectral,
            tolerance: 1e-3,
            max_iterations: 1_000_000,
        }
    }
}

impl SnSvmParams {
    /// The plain RBF SVM (`--classifier svm`): the defaults with eta = 0.
    pub fn plain_svm() -> Self {
        Self { eta: 0.0, ..Self::default() }
    }

    /// Checks every value once, before any work, and names the first bad one.
    pub fn check(self) -> Result<SnSvmValidParams, ClassifyError> {
        let invalid = |name, value: f64, requirement| Err(ClassifyError::InvalidParameter { name, value, requirement });
        match self.kernel {
            Kernel::Rbf { width } if !(width.is_finite() && width > 0.0) => {
                return invalid("kernel width", width, "a finite number > 0");
            }
            Kernel::Polynomial { degree: 0, .. } => {
                return invalid("polynomial degree", 0.0, "an integer >= 1");
            }
            // A negative offset makes (x.y + offset)^degree indefinite, and SMO needs a PSD kernel.
            Kernel::Polynomial { offset, .. } if !(offset.is_finite() && offset >= 0.0) => {
                return invalid("polynomial offset", offset, "a finite number >= 0");
            }
            _ => {}
        }
        if !(self.c.is_finite() && self.c > 0.0) {
            return invalid("C", self.c, "a finite number > 0");
        }
        if !(self.eta.is_finite() && self.eta >= 0.0) {
            return invalid("eta", self.eta, "a finite number >= 0");
        }
        if self.kappa == 0 {
            return invalid("kappa", 0.0, "an integer >= 1");
        }
        if !(self.weight_exponent.is_finite() && self.weight_exponent >= 0.0) {
            return invalid("weight exponent", self.weight_exponent, "a finite number >= 0");
        }
        if !(self.beta_relative.is_finite() && self.beta_relative > 0.0) {
            return invalid("beta (relative)", self.beta_relative, "a finite number > 0");
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return invalid("tolerance", self.tolerance, "a finite number > 0");
        }
        if self.max_iterations == 0 {
            return invalid("max iterations", 0.0, "an integer >= 1");
        }
        Ok(SnSvmValidParams(self))
    }
}

/// Parameters that passed [`SnSvmParams::check`]; the only form [`super::train`] accepts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SnSvmValidParams(SnSvmParams);

impl SnSvmValidParams {
    /// The checked parameters.
    pub fn get(&self) -> &SnSvmParams {
        &self.0
    }
}

impl std::ops::Deref for SnSvmValidParams {
    type Target = SnSvmParams;
    fn deref(&self) -> &SnSvmParams {
        &self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bad(params: SnSvmParams) -> &'static str {
        match params.check() {
            Err(ClassifyError::InvalidParameter { name, .. }) => name,
            other => panic!("expected InvalidParameter, got {other:?}"),
        }
    }

    #[test]
    fn defaults_are_the_spec_defaults_and_valid() {
        let params = SnSvmParams::default();
        assert_eq!(params.kernel, Kernel::Rbf { width: 0.5 });
        assert_eq!((params.c, params.eta, params.kappa), (1.0, 0.3, 5));
        assert_eq!((params.weight_exponent, params.beta_relative), (1.0, 0.1));
        assert_eq!(params.scale_mode, ScaleMode::Spectral);
        assert!(params.check().is_ok());
        let plain = SnSvmParams::plain_svm();
        assert_eq!(plain.eta, 0.0);
        assert!(plain.check().is_ok());
    }

    #[test]
    fn each_bad_value_is_named() {
        let base = SnSvmParams::default();
        let rbf = |width| SnSvmParams { kernel: Kernel::Rbf { width }, ..base };
        assert_eq!(bad(rbf(0.0)), "kernel width");
        assert_eq!(bad(rbf(f64::NAN)), "kernel width");
        assert_eq!(bad(rbf(-1.0)), "kernel width");
        let poly = |degree, offset| SnSvmParams { kernel: Kernel::Polynomial { degree, offset }, ..base };
        assert_eq!(bad(poly(0, 1.0)), "polynomial degree");
        assert_eq!(bad(poly(2, -1.0)), "polynomial offset");
        assert_eq!(bad(SnSvmParams { c: 0.0, ..base }), "C");
        assert_eq!(bad(SnSvmParams { c: f64::INFINITY, ..base }), "C");
        assert_eq!(bad(SnSvmParams { eta: -0.1, ..base }), "eta");
        assert_eq!(bad(SnSvmParams { kappa: 0, ..base }), "kappa");
        let exponent = SnSvmParams { weight_exponent: f64::NAN, ..base };
        assert_eq!(bad(exponent), "weight exponent");
        let beta = SnSvmParams { beta_relative: 0.0, ..base };
        assert_eq!(bad(beta), "beta (relative)");
        let tolerance = SnSvmParams { tolerance: 0.0, ..base };
        assert_eq!(bad(tolerance), "tolerance");
        let iterations = SnSvmParams { max_iterations: 0, ..base };
        assert_eq!(bad(iterations), "max iterations");
    }
}
