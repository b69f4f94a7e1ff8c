//! The scaled unscented Kalman filter (Wan & van der Merwe 2000): `2n + 1`
//! points `x̂, x̂ ± √(n + λ)·L·eⱼ` with the weights of the scaled unscented
//! transform (see `points/unscented.rs`), `L` the Cholesky factor of `P`.

use crate::error::FilterError;
use crate::filter::covariance_root::CholeskyRoot;
use crate::filter::point_rule::UnscentedPoints;
use crate::filter::{FilterKind, SigmaPointKalman};
use crate::gaussian::Gaussian;
use crate::model::Model;
use crate::noise::Noise;
use crate::points::{SigmaPoints, UnscentedParams};

/// UKF. With `α = 1, β = 0, κ = 0` its points are the CKF's, and it agrees
/// with the CKF to rounding; it is still a UKF (its kind and type say so).
pub type UnscentedKalman<M> = SigmaPointKalman<M, CholeskyRoot, UnscentedPoints>;

impl<M: Model> UnscentedKalman<M> {
    /// A UKF starting from `prior` at time 0.
    pub fn unscented(model: M, noise: Noise, prior: &Gaussian, params: UnscentedParams) -> Result<Self, FilterError> {
        let points = SigmaPoints::unscented(model.state_dim(), params)?;
        Self::with_points(FilterKind::Ukf, model, noise, prior, points)
    }
}
