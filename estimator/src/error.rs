//! The one error type of the library: what failed, and where.

use std::fmt;

/// Where in a filter cycle an error arose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Building a filter, or changing its settings.
    Setup,
    /// The time update (`predict`).
    Predict,
    /// The measurement update (`update`).
    Update,
    /// A smoother's step (the filter's belief is not touched).
    Smooth,
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Stage::Setup => "setup",
            Stage::Predict => "predict",
            Stage::Update => "update",
            Stage::Smooth => "smooth",
        })
    }
}

/// A filter failure. After an error from `predict` or `update` the filter
/// keeps the state it had before the call, so the caller may skip the sample,
/// retune or reset and go on.
#[derive(Debug, Clone, PartialEq)]
pub enum FilterError {
    /// A matrix that must be positive definite is not (its factorisation failed).
    NotPositiveDefinite {
        /// The cycle stage.
        stage: Stage,
        /// Which matrix, e.g. "state covariance P".
        matrix: &'static str,
    },
    /// A state, covariance or model output became NaN or infinite.
    NonFinite {
        /// The cycle stage.
        stage: Stage,
        /// Which quantity, e.g. "predicted state".
        quantity: &'static str,
    },
    /// A vector or matrix of the wrong size was passed.
    Dimension {
        /// What was passed.
        what: &'static str,
        /// The size the model requires.
        expected: usize,
        /// The size given.
        got: usize,
    },
    /// A setting is out of its legal range; the text says which and why.
    InvalidSetting(String),
}

impl fmt::Display for FilterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FilterError::NotPositiveDefinite { stage, matrix } => {
                write!(f, "{stage}: {matrix} is not positive definite (its factorisation failed)")
            }
            FilterError::NonFinite { stage, quantity } => write!(f, "{stage}: {quantity} is not finite"),
            FilterError::Dimension { what, expected, got } => {
                write!(f, "{what} has length {got}, the model needs {expected}")
            }
            FilterError::InvalidSetting(why) => write!(f, "invalid setting: {why}"),
        }
    }
}

impl std::error::Error for FilterError {}

pub(crate) fn check_len(what: &'static str, expected: usize, got: usize) -> Result<(), FilterError> {
    if expected == got {
        Ok(())
    } else {
        Err(FilterError::Dimension { what, expected, got })
    }
}
