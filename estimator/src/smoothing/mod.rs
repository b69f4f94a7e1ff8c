//! Smoothing a filter's run: the estimate of an instant given the measurements
//! after it too.
//!
//! - [`fixed_interval`]: the backward pass over a whole run (offline review);
//! - [`fixed_lag`]: the estimate `L` samples back, step by step (online, in a
//!   simulator's step).
//!
//! Both take of each filter step the same three things, a [`Transition`]: the
//! cross-covariance of the prediction by the filter's own rule
//! ([`StateEstimator::keep_cross_covariance`](crate::StateEstimator::keep_cross_covariance)),
//! the predicted Gaussian its update started from, and the filtered one after it.

pub mod fixed_interval;
pub mod fixed_lag;
