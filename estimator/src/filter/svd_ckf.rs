//! The SVD cubature Kalman filter (the CKF with `P = U·Σ·Vᵀ` in place of the
//! Cholesky factorisation; points `x̂ ± √n·U·√Σ·eⱼ`), as used for online
//! aerodynamic identification in study S5.
//!
//! In exact arithmetic its points are a rotation of the CKF's: the two filters
//! agree wherever the cubature rule is exact (affine models, or a covariance
//! whose eigenvectors are the coordinate axes) and differ by the rule's
//! truncation error elsewhere. Its value is robustness: `Σ = |Λ|` exists for
//! every symmetric `P`, so rounding that makes `P` indefinite does not stop it.

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
