//! The scaled unscented Kalman filter (Wan & van der Merwe 2000): `2n + 1`
//! points `x̂, x̂ ± √(n + λ)·L·eⱼ` with the weights of the scaled unscented
//! transform (see `points/unscented.rs`), `L` the Cholesky factor of `P`.

use crate::error::FilterError;
use crate::filter::covariance_root::CholeskyRoot;
use crate::filter::{FilterKind, SigmaPointKalman};
use crate::gaussian::Gaussian;
use crate::model::Model;
use crate::noise::Noise;
use crate::points::{SigmaPoints, UnscentedParams};

/// UKF; with `α = 1, β = 0, κ = 0` it is the CKF.
pub type UnscentedKalman<M> = SigmaPointKalman<M, CholeskyRoot>;

impl<M: Model> SigmaPointKalman<M, CholeskyRoot> {
    /// A UKF starting from `prior` at time 0.
    pub fn unscented(model: M, noise: Noise, prior: &Gaussian, params: UnscentedParams) -> Result<Self, FilterError> {
        let points = SigmaPoints::unscented(model.state_dim(), params)?;
        Self::with_points(FilterKind::Ukf, model, noise, prior, points)
    }
}
