//! The scaled unscented transform (Julier 2002; Wan & van der Merwe 2000):
//! `λ = α²(n + κ) − n`, points `x̂` and `x̂ ± √(n + λ)·A·eⱼ`, mean weights
//! `λ/(n + λ)` and `1/(2(n + λ))`, centre covariance weight `λ/(n + λ) + 1 − α² + β`.
//!
//! With `α = 1, β = 0, κ = 0` the centre weights vanish and the set is the
//! cubature rule (see `SigmaPoints::cubature`).

use super::{CenterWeights, SigmaPoints};
use crate::error::FilterError;

/// The three parameters of the scaled unscented transform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UnscentedParams {
    /// Spread of the points around the mean, `0 < α ≤ 1` usually (default 1e-3).
    pub alpha: f64,
    /// Prior knowledge of the distribution; 2 is optimal for Gaussians (default).
    pub beta: f64,
    /// Secondary scaling, often `0` or `3 − n` (default 0).
    pub kappa: f64,
}

impl Default for UnscentedParams {
    fn default() -> Self {
        Self { alpha: 1e-3, beta: 2.0, kappa: 0.0 }
    }
}

impl SigmaPoints {
    /// The scaled unscented points for an `n`-dimensional state. Fails unless
    /// `α > 0` and `n + λ > 0` (the spread must be real and positive).
    pub fn unscented(n: usize, params: UnscentedParams) -> Result<Self, FilterError> {
        let UnscentedParams { alpha, beta, kappa } = params;
        if !(alpha > 0.0 && alpha.is_finite() && beta.is_finite() && kappa.is_finite()) {
            return Err(FilterError::InvalidSetting(format!(
                "unscented parameters must be finite with alpha > 0 (alpha = {alpha}, beta = {beta}, kappa = {kappa})"
            )));
        }
        let nf = n as f64;
        let lambda = alpha * alpha * (nf + kappa) - nf;
        let scale = nf + lambda;
        if scale <= 0.0 {
            return Err(FilterError::InvalidSetting(format!(
                "unscented transform needs n + lambda = alpha^2 (n + kappa) > 0; got {scale:e} (n = {n}, alpha = {alpha}, kappa = {kappa})"
            )));
        }
        let center_mean = lambda / scale;
        Ok(Self {
            n,
            spread: scale.sqrt(),
            center: Some(CenterWeights { mean: center_mean, covariance: center_mean + 1.0 - alpha * alpha + beta }),
            weight: 0.5 / scale,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_weights_sum_to_one_and_default_is_documented() {
        let p = SigmaPoints::unscented(4, UnscentedParams::default()).unwrap();
        assert_eq!(p.len(), 9);
        let total: f64 = (0..p.len()).map(|i| p.mean_weight(i)).sum();
        assert!((total - 1.0).abs() < 1e-9);
        assert_eq!(UnscentedParams::default(), UnscentedParams { alpha: 1e-3, beta: 2.0, kappa: 0.0 });
    }

    #[test]
    fn a_small_alpha_gives_the_centre_a_negative_covariance_weight() {
        let small = SigmaPoints::unscented(4, UnscentedParams::default()).unwrap();
        assert!(small.center().unwrap().covariance < 0.0);
        assert!(!small.covariance_weights_nonnegative());
        let one = SigmaPoints::unscented(4, UnscentedParams { alpha: 1.0, beta: 2.0, kappa: 0.0 }).unwrap();
        assert!(one.covariance_weights_nonnegative());
        assert!(SigmaPoints::cubature(4).covariance_weights_nonnegative());
    }

    #[test]
    fn alpha_one_beta_zero_kappa_zero_is_the_cubature_rule_plus_a_zero_weight_centre() {
        let u = SigmaPoints::unscented(5, UnscentedParams { alpha: 1.0, beta: 0.0, kappa: 0.0 }).unwrap();
        let c = SigmaPoints::cubature(5);
        assert_eq!(u.spread(), c.spread());
        assert_eq!(u.weight(), c.weight());
        assert_eq!(u.center(), Some(CenterWeights { mean: 0.0, covariance: 0.0 }));
    }

    #[test]
    fn degenerate_spread_is_refused_with_the_reason() {
        let err = SigmaPoints::unscented(3, UnscentedParams { alpha: 1.0, beta: 2.0, kappa: -3.0 }).unwrap_err();
        assert!(err.to_string().contains("n + lambda"), "{err}");
    }
}
