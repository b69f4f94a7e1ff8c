//! Symmetric sigma-point sets: an optional centre point and `2n` points at
//! `x̂ ± c·A·eⱼ`, where `A` is a square root of the covariance.
//!
//! The cubature rule and the scaled unscented transform are both of this form;
//! they differ in the spread `c` and the weights.

mod cubature;
mod unscented;

pub use unscented::UnscentedParams;

/// A symmetric point set and its mean and covariance weights.
#[derive(Debug, Clone, PartialEq)]
pub struct SigmaPoints {
    n: usize,
    spread: f64,
    center: Option<CenterWeights>,
    weight: f64,
}

/// Weights of the centre point, which may differ for the mean and the covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CenterWeights {
    /// Weight of the centre in the mean.
    pub mean: f64,
    /// Weight of the centre in the covariance.
    pub covariance: f64,
}

impl SigmaPoints {
    /// The state dimension the set is for.
    pub fn state_dim(&self) -> usize {
        self.n
    }

    /// Number of points: `2n`, plus one with a centre.
    pub fn len(&self) -> usize {
        2 * self.n + usize::from(self.center.is_some())
    }

    /// Always false: a set for `n ≥ 1` has points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The factor `c` in `x̂ ± c·A·eⱼ`.
    pub fn spread(&self) -> f64 {
        self.spread
    }

    /// The centre's weights, if the set has a centre point.
    pub fn center(&self) -> Option<CenterWeights> {
        self.center
    }

    /// The weight of each of the `2n` off-centre points (mean and covariance alike).
    pub fn weight(&self) -> f64 {
        self.weight
    }

    /// Mean weight of point `i` in the order the filters use:
    /// `+A·e₀ … +A·e_{n−1}, −A·e₀ … −A·e_{n−1}`, then the centre.
    pub fn mean_weight(&self, i: usize) -> f64 {
        if i < 2 * self.n {
            self.weight
        } else {
            self.center.map_or(0.0, |c| c.mean)
        }
    }

    /// Whether every covariance weight is ≥ 0 (the unscented centre's is negative for a
    /// small α).
    pub fn covariance_weights_nonnegative(&self) -> bool {
        self.weight >= 0.0 && self.center.is_none_or(|c| c.covariance >= 0.0)
    }

    /// Covariance weight of point `i` (same order as [`Self::mean_weight`]).
    #[inline]
    pub fn covariance_weight(&self, i: usize) -> f64 {
        if i < 2 * self.n {
            self.weight
        } else {
            self.center.map_or(0.0, |c| c.covariance)
        }
    }
}
