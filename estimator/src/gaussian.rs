//! A Gaussian belief `N(mean, covariance)`: what a filter starts from.

use nalgebra::{DMatrix, DVector};

use crate::error::FilterError;
use crate::noise::check_symmetric;

/// The initial state estimate `x̂₀` and its covariance `P₀`.
#[derive(Debug, Clone, PartialEq)]
pub struct Gaussian {
    /// The mean.
    pub mean: DVector<f64>,
    /// The covariance (symmetric positive semi-definite).
    pub covariance: DMatrix<f64>,
}

impl Gaussian {
    /// A belief with a diagonal covariance.
    pub fn diagonal(mean: &[f64], variances: &[f64]) -> Self {
        Self {
            mean: DVector::from_column_slice(mean),
            covariance: DMatrix::from_diagonal(&DVector::from_column_slice(variances)),
        }
    }

    /// Checks sizes against the state dimension `n`, finiteness and symmetry.
    pub(crate) fn validate(&self, n: usize) -> Result<(), FilterError> {
        crate::error::check_len("initial mean", n, self.mean.len())?;
        crate::error::check_len("initial covariance", n, self.covariance.nrows())?;
        if self.mean.iter().any(|v| !v.is_finite()) {
            return Err(FilterError::InvalidSetting("initial mean has a non-finite entry".into()));
        }
        check_symmetric("initial covariance", &self.covariance)
    }
}
