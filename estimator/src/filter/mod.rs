//! The filters, each running any [`Model`](crate::Model), behind one trait.
//!
//! | type | method | square root of P |
//! |---|---|---|
//! | [`CubatureKalman`] | CKF, 2n cubature points | Cholesky |
//! | [`SquareRootCubature`] | SRCKF, propagates `S` with `Tria` | QR (never re-factorises P) |
//! | [`SvdCubature`] | SVD-CKF | `U·√Σ` from the SVD of P |
//! | [`UnscentedKalman`] | scaled UKF, 2n+1 points | Cholesky |
//! | [`ExtendedKalman`] | EKF, central finite-difference Jacobians | — |

mod core;
mod correction;
mod covariance_root;
mod ekf;
mod innovation;
mod point_blocks;
mod point_rule;
mod sigma_point;
mod sr_ckf;

mod ckf;
mod svd_ckf;
mod ukf;

use std::fmt;
use std::str::FromStr;

use nalgebra::{DMatrix, DVector};

pub use covariance_root::{CholeskyRoot, CovarianceRoot, SvdRoot};
pub use ekf::ExtendedKalman;
pub use innovation::Innovation;
pub use point_rule::{CubaturePoints, PointRule, UnscentedPoints};
pub use sigma_point::SigmaPointKalman;
pub use sr_ckf::SquareRootCubature;

pub use ckf::CubatureKalman;
pub use svd_ckf::SvdCubature;
pub use ukf::UnscentedKalman;

use crate::error::FilterError;
use crate::gaussian::Gaussian;
use crate::noise::Noise;

/// What every filter offers a driver (a study runner, an FMU): one
/// predict/update cycle per sample and read access to the belief.
///
/// `predict` and `update` are transactional: on `Err` the belief is unchanged.
pub trait StateEstimator {
    /// Which method this is.
    fn kind(&self) -> FilterKind;
    /// State dimension `n`.
    fn state_dim(&self) -> usize;
    /// Measurement dimension `m`.
    fn measurement_dim(&self) -> usize;
    /// The time of the current belief.
    fn time(&self) -> f64;
    /// Time update over `dt > 0` with input `u` (held for the next `update`).
    fn predict(&mut self, u: &[f64], dt: f64) -> Result<(), FilterError>;
    /// Holds the known input `u` for the next `update` in place of the last
    /// prediction's: a control computer's output changes at a sample, and the
    /// measurement of that sample (`h(t, x, u)`) sees the new one. The belief is
    /// otherwise unchanged; a non-finite `u` is refused and changes nothing.
    fn hold_input(&mut self, u: &[f64]) -> Result<(), FilterError>;
    /// Measurement update. Non-finite entries of `z` (NaN: missing) are left
    /// out and only the other rows are used; a fully missing `z` changes nothing.
    fn update(&mut self, z: &[f64]) -> Result<&Innovation, FilterError>;
    /// The state estimate `x̂`.
    fn mean(&self) -> &DVector<f64>;
    /// Writes the covariance `P` into `out` (`n × n`), without allocating.
    fn write_covariance(&self, out: &mut DMatrix<f64>);
    /// The variance `P[i, i]`.
    fn variance(&self, i: usize) -> f64;
    /// The model's response to state offsets, for a test that follows a
    /// fault's effect through the filter: each column `δ` of `offsets` is
    /// replaced by `φ(x̂ + δ) − φ(x̂)`, one transition over `dt` with input
    /// `u` from the current mean `x̂` (`F·δ` where the model is linear over
    /// `δ`); a column of zeros stays zero, uncomputed. The belief is untouched.
    fn transition_differences(&mut self, u: &[f64], dt: f64, offsets: &mut DMatrix<f64>) -> Result<(), FilterError>;
    /// `h(x̂ + δ) − h(x̂)` at the current mean and held input for each column
    /// `δ` of `offsets`, into the columns of `out` (`m` rows). The belief is
    /// untouched.
    fn observation_differences(&mut self, offsets: &DMatrix<f64>, out: &mut DMatrix<f64>) -> Result<(), FilterError>;
    /// The square root of `P` the filter propagates, if it propagates one.
    fn sqrt_covariance(&self) -> Option<&DMatrix<f64>> {
        None
    }
    /// Diagnostics of the last measurement update.
    fn innovation(&self) -> &Innovation;
    /// From now on, each prediction from `t` to `t + dt` also keeps
    /// `Cov(x(t), x(t + dt))` given the measurements up to `t`, by the filter's
    /// own rule (its points before and after the transition, or the EKF's
    /// `P·Fᵀ`): a smoother's link between the two instants. Allocates once, here.
    fn keep_cross_covariance(&mut self);
    /// That cross-covariance of the last prediction, once kept (a restore or
    /// an update leaves it as it was).
    fn cross_covariance(&self) -> Option<&DMatrix<f64>>;
    /// The noise covariances in use.
    fn noise(&self) -> &Noise;
    /// Replaces `Q` and `R` (tuning between steps).
    fn set_noise(&mut self, noise: Noise) -> Result<(), FilterError>;
    /// Sets the variances of a diagonal `R` in place, without allocating
    /// ([`Noise::set_r_diagonal`]).
    fn set_measurement_variances(&mut self, variances: &[f64]) -> Result<(), FilterError>;
    /// Scales the `Q` it was given by `scale` on the states `states` selects
    /// and those their noise couples to (all when empty; see
    /// [`Noise::set_q_scale`]), in place, from the next prediction on; on error
    /// nothing changes.
    fn set_process_noise_scale(&mut self, scale: f64, states: &[bool]) -> Result<(), FilterError>;
    /// Restarts from `prior` at time `t0`, keeping the buffers.
    fn reset(&mut self, t0: f64, prior: &Gaussian) -> Result<(), FilterError>;
    /// Scales the covariance: `P ← factor·P` (`factor ≥ 1`, finite), to open the
    /// belief again when the measurements show it has lost the state.
    fn scale_covariance(&mut self, factor: f64) -> Result<(), FilterError>;
    /// Adds process noise to the states `states` selects (all when empty):
    /// `P ← P + factor·D·Q·D`, `D` the diagonal 0/1 selection (`factor ≥ 0`,
    /// finite): the uncertainty a jump of the unknown inputs adds (the
    /// supervisor's jump hypothesis). On error the belief is unchanged.
    fn add_process_noise(&mut self, factor: f64, states: &[bool]) -> Result<(), FilterError>;
    /// Replaces the belief by the Gaussian with the moments of the mixture
    /// `weight·(this belief) + (1 − weight)·other` (`other` a snapshot of a
    /// filter of the same kind and size, at the same time; `weight` in
    /// `[0, 1]`): mean `w·x + (1 − w)·x_o`, covariance
    /// `w·P + (1 − w)·P_o + w·(1 − w)·d·dᵀ` with `d = x − x_o`. The
    /// supervisor shows two hypotheses it cannot yet tell apart this way. On
    /// error the belief is unchanged.
    fn mix_with(&mut self, other: &Snapshot, weight: f64) -> Result<(), FilterError>;

    /// Writes the belief into `out` as plain numbers, reusing its buffers: no
    /// allocation once they have the capacity (copying a belief between two
    /// filters of one kind every step, as an FMU's reads do).
    fn snapshot_into(&self, out: &mut Snapshot);
    /// Restores a belief saved by [`StateEstimator::snapshot`] of a filter of the
    /// same kind and size; continuing from it is bit-identical. Allocates nothing.
    fn restore(&mut self, snapshot: &Snapshot) -> Result<(), FilterError>;

    /// The belief as plain numbers, to save and restore (e.g. FMU state).
    fn snapshot(&self) -> Snapshot {
        let mut out =
            Snapshot { kind: self.kind(), time: 0.0, input: Vec::new(), mean: Vec::new(), covariance: Vec::new() };
        self.snapshot_into(&mut out);
        out
    }

    /// The covariance `P` as a new matrix.
    fn covariance(&self) -> DMatrix<f64> {
        let n = self.state_dim();
        let mut p = DMatrix::zeros(n, n);
        self.write_covariance(&mut p);
        p
    }
}

/// A filter's belief: its time, the held input, the mean and the covariance in
/// the form the filter propagates (`P`, or the square root `S` for the SRCKF),
/// column-major. Plain data: no pointers, so it can be serialised.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// The filter kind it was taken from.
    pub kind: FilterKind,
    /// Time of the belief.
    pub time: f64,
    /// The input held from the last `predict`.
    pub input: Vec<f64>,
    /// The mean `x̂` (`n`).
    pub mean: Vec<f64>,
    /// `P`, or `S` for the SRCKF (`n × n`, column-major).
    pub covariance: Vec<f64>,
}

impl Snapshot {
    /// Checks that the snapshot fits a filter of `kind` with `n` states and `n_u` inputs.
    pub(crate) fn check(&self, kind: FilterKind, n: usize, n_u: usize) -> Result<(), FilterError> {
        if self.kind != kind {
            return Err(FilterError::InvalidSetting(format!("snapshot of a {} cannot restore a {kind}", self.kind)));
        }
        crate::error::check_len("snapshot mean", n, self.mean.len())?;
        crate::error::check_len("snapshot covariance", n * n, self.covariance.len())?;
        crate::error::check_len("snapshot input", n_u, self.input.len())?;
        let finite = self.mean.iter().chain(&self.covariance).chain(&self.input).all(|v| v.is_finite());
        if !finite || !self.time.is_finite() {
            return Err(FilterError::InvalidSetting("snapshot has non-finite values".into()));
        }
        Ok(())
    }
}

/// Checks a covariance scale factor.
pub(crate) fn check_scale(factor: f64) -> Result<(), FilterError> {
    if factor >= 1.0 && factor.is_finite() {
        Ok(())
    } else {
        Err(FilterError::InvalidSetting(format!("covariance scale factor must be finite and at least 1, got {factor}")))
    }
}

/// Checks the weight of [`StateEstimator::mix_with`].
pub(crate) fn check_weight(weight: f64) -> Result<(), FilterError> {
    if (0.0..=1.0).contains(&weight) {
        Ok(())
    } else {
        Err(FilterError::InvalidSetting(format!("a mixture weight must be in [0, 1], got {weight}")))
    }
}

/// Checks the arguments of [`StateEstimator::add_process_noise`] for `n` states.
pub(crate) fn check_process_noise_factor(factor: f64, states: &[bool], n: usize) -> Result<(), FilterError> {
    if !(factor >= 0.0 && factor.is_finite()) {
        return Err(FilterError::InvalidSetting(format!("process-noise factor must be finite and ≥ 0, got {factor}")));
    }
    if !states.is_empty() {
        crate::error::check_len("process-noise state selection", n, states.len())?;
    }
    Ok(())
}

/// Whether state `i` is selected (all are when `states` is empty).
pub(crate) fn selected(states: &[bool], i: usize) -> bool {
    states.get(i).copied().unwrap_or(true)
}

/// Builds a filter of `kind` on `model`, starting from `prior` at time 0, for
/// drivers that choose the method at run time (`unscented` is used by the UKF only).
pub fn build_filter<M: crate::Model + 'static>(
    kind: FilterKind,
    model: M,
    noise: Noise,
    prior: &Gaussian,
    unscented: crate::UnscentedParams,
) -> Result<Box<dyn StateEstimator>, FilterError> {
    Ok(match kind {
        FilterKind::Ckf => Box::new(CubatureKalman::cubature(model, noise, prior)?),
        FilterKind::SrCkf => Box::new(SquareRootCubature::new(model, noise, prior)?),
        FilterKind::SvdCkf => Box::new(SvdCubature::svd_cubature(model, noise, prior)?),
        FilterKind::Ukf => Box::new(UnscentedKalman::unscented(model, noise, prior, unscented)?),
        FilterKind::Ekf => Box::new(ExtendedKalman::new(model, noise, prior)?),
    })
}

/// The filter methods, for configuration by name (`"srckf"`, …).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FilterKind {
    /// Cubature Kalman filter (Cholesky).
    Ckf,
    /// Square-root cubature Kalman filter.
    SrCkf,
    /// Cubature Kalman filter with the SVD as square root.
    SvdCkf,
    /// Scaled unscented Kalman filter.
    Ukf,
    /// Extended Kalman filter with finite-difference Jacobians.
    Ekf,
}

impl FilterKind {
    /// Every kind, in a fixed order.
    pub const ALL: [FilterKind; 5] =
        [FilterKind::Ckf, FilterKind::SrCkf, FilterKind::SvdCkf, FilterKind::Ukf, FilterKind::Ekf];

    /// The short name used in tables and settings.
    pub fn name(self) -> &'static str {
        match self {
            FilterKind::Ckf => "CKF",
            FilterKind::SrCkf => "SRCKF",
            FilterKind::SvdCkf => "SVD-CKF",
            FilterKind::Ukf => "UKF",
            FilterKind::Ekf => "EKF",
        }
    }
}

impl fmt::Display for FilterKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for FilterKind {
    type Err = FilterError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let key: String = s.chars().filter(|c| c.is_ascii_alphanumeric()).collect::<String>().to_ascii_lowercase();
        Self::ALL.into_iter().find(|k| k.name().replace('-', "").to_ascii_lowercase() == key).ok_or_else(|| {
            FilterError::InvalidSetting(format!("unknown filter '{s}'; expected one of CKF, SRCKF, SVD-CKF, UKF, EKF"))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_parse_from_their_names_in_any_case() {
        for kind in FilterKind::ALL {
            assert_eq!(kind.name().parse::<FilterKind>().unwrap(), kind);
            assert_eq!(kind.name().to_lowercase().parse::<FilterKind>().unwrap(), kind);
        }
        assert_eq!("svd_ckf".parse::<FilterKind>().unwrap(), FilterKind::SvdCkf);
        assert!("kalman".parse::<FilterKind>().unwrap_err().to_string().contains("expected one of"));
    }
}
