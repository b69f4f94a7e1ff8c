//! The sensor noise learnt online: a Sage–Husa estimate of the diagonal of
//! `R` with a forgetting factor (Sage & Husa 1969; the fading-memory form of
//! e.g. Narasimhappa et al. 2019). The `R` a user sets is often a guess; this
//! corrects it from the innovations of the updates actually made.
//!
//! For each row `i` used by an update, with innovation `νᵢ` and innovation
//! variance `Sᵢᵢ = (HPHᵀ)ᵢᵢ + rᵢ` (the `rᵢ` the update used):
//!
//! ```text
//! dₖ = (1 − b) / (1 − bᵏ)           (b: forgetting factor; dₖ → 1 − b)
//! rᵢ ← (1 − dₖ)·rᵢ + dₖ·(νᵢ² − (Sᵢᵢ − rᵢ))
//! ```
//!
//! `νᵢ² − (HPHᵀ)ᵢᵢ` is an unbiased sample of `rᵢ` when the rest of the model
//! is right, but it can be negative; the estimate is kept above a floor (a
//! fraction of the initial guess). Rows left out (missing, rejected by a
//! gate) teach nothing: a glitch must not widen `R`, which is why this runs
//! on the updates a supervisor let through.

use crate::error::FilterError;
use crate::filter::Innovation;

/// A Sage–Husa estimate of the measurement variances.
#[derive(Debug, Clone)]
pub struct SageHusa {
    forgetting: f64,
    /// `bᵏ` after `k` updates.
    power: f64,
    variances: Vec<f64>,
    floor: Vec<f64>,
}

impl SageHusa {
    /// Starts from the variances `initial` (the user's guess), forgetting
    /// with factor `forgetting` in `(0, 1)` (0.99 at 200 Hz: a memory of
    /// about half a second), never below `floor_fraction` of the guess.
    pub fn new(initial: &[f64], forgetting: f64, floor_fraction: f64) -> Result<Self, FilterError> {
        if !(forgetting > 0.0 && forgetting < 1.0) {
            return Err(FilterError::InvalidSetting(format!("forgetting factor must be in (0, 1), got {forgetting}")));
        }
        if !(floor_fraction > 0.0 && floor_fraction <= 1.0) {
            return Err(FilterError::InvalidSetting(format!("floor fraction must be in (0, 1], got {floor_fraction}")));
        }
        if let Some(v) = initial.iter().find(|v| !(**v > 0.0 && v.is_finite())) {
            return Err(FilterError::InvalidSetting(format!("initial variances must be positive, got {v}")));
        }
        Ok(Self {
            forgetting,
            power: 1.0,
            variances: initial.to_vec(),
            floor: initial.iter().map(|v| v * floor_fraction).collect(),
        })
    }

    /// Learns from an update's innovation (made with the current estimate as
    /// `R`'s diagonal) and returns the new estimate, to be set on the filter
    /// before its next update. Rows the update did not use are left as they are.
    pub fn learn(&mut self, innovation: &Innovation) -> &[f64] {
        if innovation.rows_used() == 0 {
            return &self.variances;
        }
        self.power *= self.forgetting;
        let d = (1.0 - self.forgetting) / (1.0 - self.power);
        for &row in innovation.rows() {
            let r = self.variances[row];
            let spread = innovation.covariance()[(row, row)] - r;
            let sample = innovation.residual()[row].powi(2) - spread;
            self.variances[row] = ((1.0 - d) * r + d * sample).max(self.floor[row]);
        }
        &self.variances
    }

    /// The current estimate.
    pub fn variances(&self) -> &[f64] {
        &self.variances
    }
}
