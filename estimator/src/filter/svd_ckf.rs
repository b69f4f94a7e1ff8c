//! The SVD cubature Kalman filter (the CKF with the SVD `P = U·Σ·Vᵀ` in place of
//! the Cholesky factorisation), as used for online aerodynamic identification in
//! study S5.
//!
//! Its points are `x̂ ± √n·U·√Σ·Uᵀ·eⱼ`, from the symmetric square root, where the
//! published filter (`[Jiang2024]`) takes the columns of `U·√Σ`. Both are square
//! roots of `P` from the same SVD, so the cubature rule and its robustness are the
//! same; but `U·√Σ` is not unique: where eigenvalues are equal or nearly so (a
//! diagonal prior), the roundings of the Jacobi rotations pick the basis, and with
//! it the points. With `U·√Σ`, S2's estimates on a CPU that fuses multiply-adds
//! differed from those on one that does not by about one σ; `U·√Σ·Uᵀ` is the same
//! for every basis. For a diagonal `P` it is the Cholesky factor: the SVD-CKF
//! starts with the CKF's points.
//!
//! In exact arithmetic its points are a rotation of the CKF's: the two filters
//! agree wherever the cubature rule is exact (affine models, or a diagonal
//! covariance) and differ by the rule's truncation error elsewhere. Its value is
//! robustness: `Σ = |Λ|` exists for every symmetric `P`, so rounding that makes
//! `P` indefinite does not stop it.

use crate::error::FilterError;
use crate::filter::covariance_root::SvdRoot;
use crate::filter::point_rule::CubaturePoints;
use crate::filter::{FilterKind, SigmaPointKalman};
use crate::gaussian::Gaussian;
use crate::model::Model;
use crate::noise::Noise;
use crate::points::SigmaPoints;

/// SVD-CKF.
pub type SvdCubature<M> = SigmaPointKalman<M, SvdRoot, CubaturePoints>;

impl<M: Model> SvdCubature<M> {
    /// An SVD-CKF starting from `prior` at time 0.
    pub fn svd_cubature(model: M, noise: Noise, prior: &Gaussian) -> Result<Self, FilterError> {
        let points = SigmaPoints::cubature(model.state_dim());
        Self::with_points(FilterKind::SvdCkf, model, noise, prior, points)
    }
}
