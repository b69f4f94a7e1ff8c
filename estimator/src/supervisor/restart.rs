//! The last resort: a filter that has used no row for a whole consistency
//! window, or whose belief has left its plausible range, starts again from
//! where its states have been.
//!
//! Re-acquisitions and their rivals (`reacquisition.rs`, `rival.rs`) repair a
//! belief that one episode moved. An episode on every input at once (S1's two
//! accelerometers both offset by 3000 m/s² for a second) can drag the whole
//! state so far that, once the inputs are clean again, every row fails the
//! gate, every re-acquisition is spent, and the filter predicts on for ever.
//! Nothing the supervisor kept is worth more than the data then.
//!
//! A belief outside the plausible range the user gave
//! ([`Supervisor::with_plausible_range`]: S2's forces beyond 100 static wheel
//! loads) has lost the state too, whatever its innovations say: S1's chain
//! balances a static load of 20 kN with a static stretch of its springs, and
//! accelerometers see neither, so a filter dragged there by an offset on both
//! channels stays there, consistent, after the offset ends.
//!
//! So the supervisor remembers, from the samples it judged healthy
//! (consistent, every row offered used, nothing under revision), where the
//! states have been: a forgetting mean and variance of each state's estimate,
//! and the filter's mean variance of it (its memory is [`MEMORY_WINDOWS`]
//! consistency windows). When no row has been used for a whole window
//! (`SupervisorSettings::window` samples), or the belief is implausible, it
//! restarts at that mean, each state's variance four times its spread plus
//! the filter's own mean variance of it over those samples (not the lost
//! belief's, which a long prediction has blown up), the covariance diagonal,
//! and the gate goes on from there. The restarted belief meets the data the
//! next samples bring; if they are still bad, the filter is lost again and
//! the next restart comes a window later, so that the cost of an episode on
//! every input is a window after its end plus the filter's own convergence
//! from the restart.
//!
//! What it cannot do: a state that moves on (a position along a guideway)
//! restarts where it was on average, behind where it is, and only its spread
//! says how far: S4 with its slips left to re-acquisitions runs 200 m off
//! before the telegrams pull it back (`studies/tests/s4_ours.rs`).
//!
//! A restart also ends any re-acquisition rival and jump review, and gives
//! the re-acquisitions their budget back.
//!
//! The same belief challenges a filter that is inconsistent while it still
//! uses rows (`rival.rs`): there the data, not a rule, decide whether the
//! filter restarts.

use nalgebra::{DMatrix, DVector};

use super::Supervisor;
use crate::error::FilterError;
use crate::filter::StateEstimator;
use crate::gaussian::Gaussian;

/// The restart's memory, in consistency windows.
pub const MEMORY_WINDOWS: usize = 10;

/// Where the states have been while the filter was healthy.
#[derive(Debug, Clone)]
pub(super) struct Climate {
    /// Healthy samples learnt from (saturating).
    pub learnt: u64,
    /// Each state's forgetting mean and variance, and the forgetting mean of
    /// the filter's own variance of it.
    pub mean: Vec<f64>,
    pub variance: Vec<f64>,
    pub doubt: Vec<f64>,
    /// The restart's belief, sized once.
    restart: Gaussian,
}

impl Climate {
    /// Nothing learnt yet.
    pub fn new() -> Self {
        Self {
            learnt: 0,
            mean: Vec::new(),
            variance: Vec::new(),
            doubt: Vec::new(),
            restart: Gaussian { mean: DVector::zeros(0), covariance: DMatrix::zeros(0, 0) },
        }
    }

    /// Sizes the buffers for `n` states (the first gate's; no later one allocates).
    pub fn reserve(&mut self, n: usize) {
        if self.mean.len() != n {
            self.mean = vec![0.0; n];
            self.variance = vec![0.0; n];
            self.doubt = vec![0.0; n];
            self.learnt = 0;
        }
        if self.restart.mean.len() != n {
            self.restart = Gaussian { mean: DVector::zeros(n), covariance: DMatrix::zeros(n, n) };
        }
    }

    /// Learns from one healthy belief, its `mean` and `variance` per state,
    /// forgetting over `memory` samples.
    pub fn learn(&mut self, mean: &[f64], variance: &[f64], memory: usize) {
        if mean.len() != self.mean.len() || variance.len() != self.mean.len() {
            return;
        }
        self.learnt = self.learnt.saturating_add(1);
        let weight = 1.0 / (self.learnt.min(memory as u64)) as f64;
        for (i, (&x, &p)) in mean.iter().zip(variance).enumerate() {
            let d = x - self.mean[i];
            self.mean[i] += weight * d;
            self.variance[i] = (1.0 - weight) * (self.variance[i] + weight * d * d);
            self.doubt[i] += weight * (p.max(0.0) - self.doubt[i]);
        }
    }
}

impl Climate {
    /// The belief a restart starts from: each state at its mean, its variance
    /// four times its spread plus the filter's mean variance of it, no
    /// correlation (sized by [`Climate::reserve`]).
    pub fn restart_belief(&mut self) -> &Gaussian {
        let restart = &mut self.restart;
        restart.covariance.fill(0.0);
        for i in 0..self.mean.len() {
            restart.mean[i] = self.mean[i];
            restart.covariance[(i, i)] = 4.0 * self.variance[i] + self.doubt[i];
        }
        &self.restart
    }
}

impl Supervisor {
    /// Counts a restart of the pending outcome, or learns from its belief when
    /// the sample is healthy (before the consistency window takes the sample).
    pub(super) fn commit_restart(&mut self) {
        if self.pending.restarted {
            let reacquisition = &mut self.reacquisition;
            reacquisition.restarts = reacquisition.restarts.saturating_add(1);
            reacquisition.lost_run = u32::from(self.pending.nothing_used());
            reacquisition.inflation = 1.0;
            self.rival.active = false;
            self.review.active = false;
            return;
        }
        // Healthy: consistent, every row offered used, nothing under revision but a
        // confirmed jump's fault hypothesis (a precaution kept after most jumps; a
        // belief that the jump dragged rejects rows, and is not learnt from).
        let whole = self.pending.rejected_none();
        let doubted = self.rival.active && !self.rival.hypothesis.without_trigger();
        let healthy = self.window.consistent() && self.pending.dof > 0 && whole && !doubted;
        let settled = match self.pending.revision {
            super::outcome::Revision::None => true,
            super::outcome::Revision::Weighed(_) => self.rival.hypothesis.without_trigger(),
            _ => false,
        };
        if healthy && settled {
            let work = &self.work;
            self.climate.learn(&work.posterior, &work.posterior_variance, MEMORY_WINDOWS * self.settings.window);
        }
    }

    /// The filter has been healthy for a whole window (the climate has
    /// learnt that much): before that, at start-up, the filter may itself be
    /// what is wrong, and no sensor is judged against it (`rival.rs`).
    pub(super) fn settled(&self) -> bool {
        self.climate.learnt >= self.settings.window as u64
    }

    /// Whether the filter restarts at this gate: no row used for a whole
    /// window or a belief outside its plausible range, and a window of healthy
    /// samples learnt.
    pub(super) fn restart_due(&self, filter: &dyn StateEstimator) -> bool {
        let lost = self.reacquisition.lost_run as usize >= self.settings.window || self.outside(filter).is_some();
        self.settings.revise && lost && self.settled()
    }

    /// Restarts `filter` at the belief before the gate's time and input from
    /// the climate (see the module documentation); that belief becomes `before`.
    pub(super) fn restart(&mut self, filter: &mut dyn StateEstimator) -> Result<(), FilterError> {
        let time = self.work.before.time;
        let restart = self.climate.restart_belief();
        let restarted = filter.reset(time, restart).and_then(|()| filter.hold_input(&self.work.before.input));
        if let Err(e) = restarted {
            filter.restore(&self.work.before)?;
            return Err(e);
        }
        filter.snapshot_into(&mut self.work.before);
        self.pending.restarted = true;
        Ok(())
    }
}
