//! Quantised bias steps: biases that jump by a known size and stay.
//!
//! A long-stator position channel that miscounts one slot reads 86 mm off
//! from then on. When a channel whose bias is a state of the model is
//! rejected [`QuantizedSteps::after`] samples in a row (its missing and stuck
//! samples skipped), each time within [`QuantizedSteps::tolerance`] of the
//! same non-zero multiple of [`QuantizedSteps::quantum`], the bias state's
//! mean is moved by that multiple and the step reported
//! ([`Outcome::steps`](crate::Outcome::steps)). The covariance is kept: the
//! quantum is exact. A spike fails one sample and the next passes. A
//! re-acquisition instead would inflate every state, the unobservable ones
//! too (S4: a slip shared out over the other channels, the speed off by
//! 99 m/s and the filter unhealthy for 2811 telegrams before the restarts of
//! `restart.rs` bring it back; `studies/tests/s4_ours.rs`).

use super::channel::Channel;
use super::outcome::{Outcome, RowOutcome};
use crate::error::FilterError;
use crate::filter::{Snapshot, StateEstimator};

/// The steps of a known size some channels' biases take: a row rejected
/// [`after`](Self::after) samples in a row at the same non-zero multiple of
/// the [`quantum`](Self::quantum) moves its bias state's mean by that
/// multiple (see [`Supervisor::with_steps`](crate::Supervisor::with_steps)).
#[derive(Debug, Clone, PartialEq)]
pub struct QuantizedSteps {
    /// The size of one step (the measurement's unit).
    pub quantum: f64,
    /// Consecutive rejected samples at the same multiple before the step is taken (≥ 2:
    /// a spike lasts one).
    pub after: u32,
    /// How close to the multiple the innovation must come (less than half the quantum).
    pub tolerance: f64,
    /// Per measurement row: the state that carries its bias, if it has one.
    pub bias_states: Vec<Option<usize>>,
}

impl QuantizedSteps {
    /// Checks the ranges and that there is a bias entry for each of the `m` rows.
    pub(super) fn validate(&self, m: usize) -> Result<(), FilterError> {
        let bad = |why: String| Err(FilterError::InvalidSetting(why));
        if !(self.quantum > 0.0 && self.quantum.is_finite()) {
            return bad(format!("the step quantum must be positive, got {}", self.quantum));
        }
        if !(self.tolerance > 0.0 && self.tolerance < self.quantum / 2.0) {
            return bad(format!("the step tolerance must be in (0, quantum/2), got {}", self.tolerance));
        }
        if self.after < 2 {
            return bad("a step must be seen on at least 2 samples: a spike lasts one".into());
        }
        crate::error::check_len("bias states", m, self.bias_states.len())
    }

    /// The watch of one row after this sample, from the channel's committed
    /// one: the multiple its rejected innovation (`residual`) sits at and how
    /// many samples in a row.
    fn watch(&self, row: RowOutcome, residual: f64, channel: &Channel) -> (i64, u32) {
        let committed = (channel.step_multiple, channel.step_run);
        match row {
            RowOutcome::Used => (0, 0),
            RowOutcome::Missing | RowOutcome::Stuck | RowOutcome::Inconsistent => committed,
            RowOutcome::Rejected => {
                let multiple = (residual / self.quantum).round();
                let near = (residual - multiple * self.quantum).abs() <= self.tolerance;
                match (near && multiple != 0.0 && multiple.abs() < 1e9, committed) {
                    (false, _) => (0, 0),
                    (true, (m, run)) if m == multiple as i64 => (m, run.saturating_add(1)),
                    (true, _) => (multiple as i64, 1),
                }
            }
        }
    }

    /// Watches the rows of the pending outcome (with the first pass's
    /// `residuals`) and takes the steps seen often enough into their bias
    /// states, through `scratch` (which holds the belief before the gate).
    pub(super) fn take(
        &self,
        channels: &[Channel],
        residuals: &[f64],
        pending: &mut Outcome,
        scratch: &mut Snapshot,
        filter: &mut dyn StateEstimator,
    ) -> Result<(), FilterError> {
        // `scratch` still holds the belief before the gate: on this error it is restored.
        let n = filter.state_dim();
        if let Some((row, state)) =
            self.bias_states.iter().enumerate().find_map(|(r, s)| s.filter(|&s| s >= n).map(|s| (r, s)))
        {
            filter.restore(scratch)?;
            return Err(FilterError::InvalidSetting(format!(
                "the bias state {state} of row {row} is not one of the filter's {n} states"
            )));
        }
        let mut moved = false;
        for (c, channel) in channels.iter().enumerate() {
            pending.watch[c] = self.watch(pending.rows[c], residuals[c], channel);
            let (multiple, run) = pending.watch[c];
            if let (Some(state), true) = (self.bias_states[c], run >= self.after) {
                if !moved {
                    filter.snapshot_into(scratch);
                    moved = true;
                }
                let step = multiple as f64 * self.quantum;
                scratch.mean[state] += step;
                pending.steps[c] = step;
                pending.watch[c] = (0, 0);
            }
        }
        if moved {
            filter.restore(scratch)?;
        }
        Ok(())
    }
}
