//! Re-acquisition: when the filter, not the sensor, has lost the state.
//!
//! A channel that fails the gate
//! [`SupervisorSettings::reacquire_after`](crate::SupervisorSettings::reacquire_after)
//! samples in a row says either that it is broken or that the filter lost
//! the state (a true jump, a bad prior, a state pulled away during a fault);
//! a gate alone would lock the filter out of a real change for ever. So the
//! filter re-acquires: the covariance is inflated by four times the largest
//! normalised innovation over the gate (at most 1e4), which brings that
//! innovation inside the gate, and the update is made with every row that is
//! not stuck; no second re-acquisition follows within `reacquire_after`
//! samples.
//!
//! That is a hypothesis, and the next samples test it. If the channel fails
//! the gate again within the consistency window, the channel is broken (a
//! drifting sensor): it is suspended, and triggers no re-acquisition until it
//! passes the gate again. It is not retried meanwhile, because during a drift
//! each retry pulls the state towards the drifting sensor (in S1 the load
//! estimate is lost). If it passes, the state had moved and is followed.
//! When every available channel has failed for `reacquire_after` samples the
//! filter re-acquires whatever the channels' past: it is lost.
//!
//! **Inflation budget.** The re-acquisitions multiply the covariance by at
//! most [`SupervisorSettings::max_inflation`](crate::SupervisorSettings::max_inflation)
//! in total until a sample passes the gate with none of its rows rejected.
//! When no inflation makes the filter agree with its sensors for good (their
//! noise far above what `R` says), every update collapses `P` onto the told
//! `R` and the next innovations fail again; unbounded re-acquisitions would
//! multiply the unobserved directions of `P` by 1e4 each time until `P` loses
//! its definiteness or overflows. With the budget spent the filter stays
//! lost, predicting only, its `P` finite and its health false, until its
//! sensors pass the gate again.

use super::channel::Channel;
use super::gate::Pass;
use super::outcome::Outcome;
use super::settings::SupervisorSettings;

/// What the supervisor remembers of its re-acquisitions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Reacquisition {
    /// Consecutive samples in which rows were available and none was used.
    pub lost_run: u32,
    /// Re-acquisitions so far.
    pub count: u64,
    /// Samples since the last re-acquisition (`u32::MAX`: none yet).
    pub since_last: u32,
    /// The product of the re-acquisitions' factors since a sample last passed the gate whole.
    pub inflation: f64,
    /// Re-acquisitions their rival's evidence undid (`rival.rs`).
    pub undone: u64,
    /// Restarts (`restart.rs`), a challenger's won included (`rival.rs`).
    pub restarts: u64,
    /// Samples since a challenger was last alive (`u32::MAX`: none yet).
    pub since_challenge: u32,
}

impl Reacquisition {
    /// Before the first sample.
    pub fn new() -> Self {
        Self {
            lost_run: 0,
            count: 0,
            since_last: u32::MAX,
            inflation: 1.0,
            undone: 0,
            restarts: 0,
            since_challenge: u32::MAX,
        }
    }

    /// Whether a failing pass calls for a re-acquisition, and if so the
    /// channel that triggers it and the factor on the covariance (within
    /// what is left of the budget). `tested` are the pass's rows with their
    /// normalised innovations.
    pub fn decide(
        &self,
        pass: &Pass,
        mut tested: impl Iterator<Item = (usize, f64)>,
        channels: &[Channel],
        settings: &SupervisorSettings,
    ) -> Option<(usize, f64)> {
        let after = settings.reacquire_after;
        if self.since_last < after {
            return None;
        }
        let persistent = tested
            .find(|&(r, ratio)| pass.fails(r, ratio) && channels[r].may_trigger_reacquisition(after))
            .map(|(r, _)| r);
        // Every channel failing for a while: lost, whatever the channels' past.
        let lost = (pass.all_fail() && self.lost_run.saturating_add(1) >= after).then_some(pass.worst_row);
        let trigger = persistent.or(lost)?;
        let wanted = (4.0 * pass.worst / pass.row_threshold()).clamp(1.0, 1e4);
        let factor = wanted.min(settings.max_inflation / self.inflation);
        (factor > 1.0).then_some((trigger, factor))
    }

    /// Counts one committed sample.
    pub fn count(&mut self, outcome: &Outcome, max_inflation: f64) {
        let reacquired = outcome.reacquired.is_some();
        self.lost_run = if outcome.nothing_used() { self.lost_run.saturating_add(1) } else { 0 };
        self.count = self.count.saturating_add(u64::from(reacquired));
        self.since_last = if reacquired { 0 } else { self.since_last.saturating_add(1) };
        let passed_whole = outcome.dof > 0 && outcome.rejected_none();
        self.inflation = if reacquired {
            (self.inflation * outcome.inflation).min(max_inflation)
        } else if passed_whole {
            1.0
        } else {
            self.inflation
        };
    }
}
