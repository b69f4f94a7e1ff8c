//! How a covariance-form sigma-point filter takes the square root of `P`
//! before it spreads its points: Cholesky (CKF, UKF) or the symmetric root
//! from the SVD (SVD-CKF).

use nalgebra::DMatrix;

use crate::linalg::{cholesky_in_place, SymmetricEigen};

/// A method that writes some `A` with `A·Aᵀ = P`.
pub trait CovarianceRoot {
    /// Buffers for `n × n` covariances.
    fn new(n: usize) -> Self;
    /// Writes a square root of `p` into `out`; `Err` when `p` has none by this method.
    fn factor(&mut self, p: &DMatrix<f64>, out: &mut DMatrix<f64>) -> Result<(), RootFailed>;
}

/// The square root could not be taken (P not positive definite, or not finite).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RootFailed;

/// The lower Cholesky factor `L`: fails as soon as `P` is not numerically positive definite.
#[derive(Debug, Clone, Default)]
pub struct CholeskyRoot;

impl CovarianceRoot for CholeskyRoot {
    fn new(_n: usize) -> Self {
        CholeskyRoot
    }

    #[inline(always)]
    fn factor(&mut self, p: &DMatrix<f64>, out: &mut DMatrix<f64>) -> Result<(), RootFailed> {
        let n = p.nrows();
        out.copy_from(p);
        cholesky_in_place(out.as_mut_slice(), n, n).map_err(|_| RootFailed)
    }
}

/// `U·√Σ·Uᵀ` from the SVD `P = U·Σ·Vᵀ` (Jacobi on the symmetric `P`, see
/// [`SymmetricEigen`]: one-sided on a pivoted Cholesky factor while `P` is
/// positive definite, two-sided on `P` otherwise). Defined for every finite
/// symmetric `P`: rounding that makes `P` slightly indefinite costs accuracy in
/// that direction instead of stopping the filter. It depends on `P` alone, so
/// the filter's state is still its mean and covariance; and, unlike `U·√Σ`, not
/// on which basis of an eigenspace the rotations reach, so it is the same on
/// every CPU to rounding (see [`SymmetricEigen::write_symmetric_square_root`]).
#[derive(Debug, Clone)]
pub struct SvdRoot {
    eigen: SymmetricEigen,
}

impl CovarianceRoot for SvdRoot {
    fn new(n: usize) -> Self {
        Self { eigen: SymmetricEigen::new(n) }
    }

    fn factor(&mut self, p: &DMatrix<f64>, out: &mut DMatrix<f64>) -> Result<(), RootFailed> {
        self.eigen.decompose(p).map_err(|_| RootFailed)?;
        self.eigen.write_symmetric_square_root(out);
        Ok(())
    }
}
