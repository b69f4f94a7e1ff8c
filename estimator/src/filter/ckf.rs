//! The cubature Kalman filter (Arasaratnam & Haykin, IEEE TAC 54(6), 2009):
//! `2n` equally weighted points `x̂ ± √n·L·eⱼ`, `L` the Cholesky factor of `P`.

use crate::error::FilterError;
use crate::filter::covariance_root::CholeskyRoot;
use crate::filter::point_rule::CubaturePoints;
use crate::filter::{FilterKind, SigmaPointKalman};
use crate::gaussian::Gaussian;
use crate::model::Model;
use crate::noise::Noise;
use crate::points::SigmaPoints;

/// CKF: fails with [`FilterError::NotPositiveDefinite`] when rounding has made
/// `P` indefinite (use [`SquareRootCubature`](crate::SquareRootCubature) or
/// [`SvdCubature`](crate::SvdCubature) where that happens).
pub type CubatureKalman<M> = SigmaPointKalman<M, CholeskyRoot, CubaturePoints>;

impl<M: Model> CubatureKalman<M> {
    /// A CKF starting from `prior` at time 0.
    pub fn cubature(model: M, noise: Noise, prior: &Gaussian) -> Result<Self, FilterError> {
        let points = SigmaPoints::cubature(model.state_dim());
        Self::with_points(FilterKind::Ckf, model, noise, prior, points)
    }
}
