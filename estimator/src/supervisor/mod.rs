//! Gross measurement errors and an honest health report, around any filter.
//! Real sensors saturate, drop out, stick and drift; one such sample must not
//! become a silent wrong number, and a filter that has lost the state must
//! say so.
//!
//! * **Gate** (`gate.rs`): a row whose normalised innovation fails its χ²
//!   test is left out of the update exactly like a missing one; implausible
//!   rows and stuck channels are left out too.
//! * **Faults**: a channel whose last [`SupervisorSettings::fault_after`]
//!   samples were all rejected, stuck or missing is faulty, until one passes
//!   again ([`Channel::faulty`], reported once per change as a [`FaultChange`]).
//! * **Re-acquisition** (`reacquisition.rs`): a channel that keeps failing
//!   means either a broken sensor or a filter that lost the state; the
//!   covariance is inflated once, within a budget, and the next samples tell
//!   the two apart.
//! * **Revision** (`rival.rs`): the update the gate alone would have made
//!   is kept beside a re-acquisition as its rival, and the next samples'
//!   data decide which belief stays: a burst of gross errors taken in is
//!   undone.
//! * **Probation** (`channel.rs`): a channel whose jump the data undid is
//!   left out until its row agrees with the belief without it for a while,
//!   then used again with that belief as its rival.
//! * **Restart** (`restart.rs`): a filter that has used no row for a whole
//!   window, or whose belief has left its plausible range, starts again from
//!   where its states have been while it was healthy; an inconsistent one is
//!   challenged by a belief started there, which replaces it if the data
//!   favour it (`rival.rs`).
//! * **Quantised bias steps** (optional, [`Supervisor::with_steps`],
//!   `steps.rs`): a bias that jumps by a known quantum is taken into its bias
//!   state instead of inflating every state.
//! * **Consistency** (`consistency.rs`): the clipped normalised innovations
//!   over a window, against their χ² bound: is `P` still honest?
//! * **Jumps** (`jump.rs`): a failing row that a jump of the unknown inputs
//!   explains is model mismatch, not a fault: it is used, from `P + c·Q`, and
//!   the next sample reviews whether it was a spike after all.
//! * **Wiring** (`wiring.rs`): a channel whose innovations follow its own
//!   prediction (a sign, a unit) or sit off zero (gravity left in) is
//!   inconsistent: left out where the channels contradict each other
//!   directly, otherwise named with the filter inconsistent.
//!   Where an unknown input follows a channel, a fault's signature through
//!   the filter's dynamics tells which channel the others contradict
//!   (`signature.rs`).
//! * **Adaptation** (`adaptation.rs`): a bounded, forgetting scale on `Q`
//!   learnt from the normalised innovations of the rows used.
//!
//! The gate and the bookkeeping are apart: [`Supervisor::gate`] makes the
//! update on a filter and keeps the outcome pending, [`Supervisor::commit`]
//! counts it. A driver that computes an update only to show it (an FMU's read
//! between steps) gates on a copy of the filter and never commits. What is
//! counted is the supervisor's memory, which [`Supervisor::save`] writes as
//! self-describing words (`memory.rs`).

mod adaptation;
mod channel;
mod consistency;
mod gate;
mod jump;
mod memory;
mod outcome;
mod plausible;
mod reacquisition;
mod restart;
mod rival;
mod settings;
mod signature;
mod smoothing_prior;
mod steps;
mod wiring;

pub use channel::Channel;
pub use outcome::{FaultChange, Outcome, Revision, RowOutcome};
pub use plausible::{Outside, PlausibleBound, PlausibleRange};
pub use settings::SupervisorSettings;
pub use steps::QuantizedSteps;

use adaptation::Adaptation;
use consistency::{ConsistencyWindow, WindowEntry};
use gate::{Thresholds, Workspace};
use jump::{Jumps, Review};
use reacquisition::Reacquisition;
use restart::Climate;
use rival::Rival;
use signature::{SignatureWork, Signatures};

use crate::error::FilterError;
use crate::filter::StateEstimator;

/// Gate, fault flags, re-acquisition and consistency for one filter.
#[derive(Debug, Clone)]
pub struct Supervisor {
    settings: SupervisorSettings,
    thresholds: Thresholds,
    /// Quantised bias steps, when the model has them.
    steps: Option<QuantizedSteps>,
    /// The states a jump moves (`jump.rs`): the unknown inputs; empty for all.
    jump_states: Vec<bool>,
    // The memory: what a commit changes and `save` writes.
    channels: Vec<Channel>,
    reacquisition: Reacquisition,
    window: ConsistencyWindow,
    adaptation: Adaptation,
    jumps: Jumps,
    review: Review,
    rival: Rival,
    climate: Climate,
    signatures: Signatures,
    /// A belief outside it is lost and restarts (`restart.rs`).
    plausible: PlausibleRange,
    // The pending sample.
    pending: Outcome,
    /// The measurement of the pending outcome, as offered.
    z_offered: Vec<f64>,
    work: Workspace,
    signature_work: SignatureWork,
}

impl Supervisor {
    /// A supervisor for a filter with `m` measurement rows.
    pub fn new(settings: SupervisorSettings, m: usize) -> Result<Self, FilterError> {
        settings.validate()?;
        Ok(Self {
            settings,
            thresholds: Thresholds::new(&settings, m),
            steps: None,
            jump_states: Vec::new(),
            channels: vec![Channel::new(); m],
            reacquisition: Reacquisition::new(),
            window: ConsistencyWindow::new(&settings, m),
            adaptation: Adaptation::new(),
            jumps: Jumps::default(),
            review: Review::new(m),
            rival: Rival::new(settings.window),
            climate: Climate::new(),
            signatures: Signatures::default(),
            plausible: PlausibleRange::default(),
            pending: Outcome::none(m),
            z_offered: vec![f64::NAN; m],
            work: Workspace::new(m),
            signature_work: SignatureWork::default(),
        })
    }

    /// With quantised bias steps for the rows that have a bias state.
    pub fn with_steps(mut self, steps: QuantizedSteps) -> Result<Self, FilterError> {
        steps.validate(self.channels.len())?;
        self.steps = Some(steps);
        Ok(self)
    }

    /// With jumps (`jump.rs`) made in the states `states` (indices of an
    /// `n`-state model) only: the model's unknown inputs (S1's load and its
    /// rate, S2's wheel–rail forces), whose process noise stands for what the
    /// model does not know. Without this call, every state may jump.
    pub fn with_jump_states(mut self, n: usize, states: &[usize]) -> Result<Self, FilterError> {
        if let Some(i) = states.iter().find(|&&i| i >= n) {
            return Err(FilterError::InvalidSetting(format!("jump state {i} is not a state of an {n}-state model")));
        }
        self.jump_states = (0..n).map(|i| states.contains(&i)).collect();
        Ok(self)
    }

    /// With a plausible range of some states: a belief outside it has lost
    /// the state, and restarts (`restart.rs`) once it has learnt where the
    /// states go. Without this call only a window without any row used makes
    /// the filter restart.
    pub fn with_plausible_range(mut self, range: PlausibleRange) -> Self {
        self.plausible = range;
        self
    }

    /// The first state of `filter`'s belief outside its plausible range
    /// ([`Supervisor::with_plausible_range`]), if any.
    pub fn outside(&self, filter: &dyn StateEstimator) -> Option<Outside> {
        self.plausible.first_outside(filter)
    }

    /// The settings.
    pub fn settings(&self) -> &SupervisorSettings {
        &self.settings
    }

    /// The channels, by row of `z`.
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// Measurement rows rejected by the gate so far, over all channels.
    pub fn rejected(&self) -> u64 {
        self.channels.iter().map(|c| c.rejected).sum()
    }

    /// The scale on the `Q` given that the adaptation has learnt (1 when it is
    /// off); the filter predicts with it from the next sample on.
    pub fn process_noise_scale(&self) -> f64 {
        self.adaptation.scale()
    }

    /// The states the scale on `Q` is for ([`Supervisor::with_jump_states`], a
    /// flag per state; empty: all), as [`StateEstimator::set_process_noise_scale`]
    /// takes them. The adaptation learns the unknown inputs' noise: the motion
    /// states' noise stands for the model's own error, which the innovations
    /// do not show where the states are not observed (a scale on it would
    /// shrink the σ of those states with nothing to say it should).
    pub fn scaled_states(&self) -> &[bool] {
        &self.jump_states
    }

    /// Puts the adapted scale on `filter`'s `Q` (see [`Supervisor::scaled_states`]).
    pub fn scale_process_noise_of(&self, filter: &mut dyn StateEstimator) -> Result<(), FilterError> {
        filter.set_process_noise_scale(self.process_noise_scale(), &self.jump_states)
    }

    /// Jumps of the unknown inputs taken so far (`jump.rs`).
    pub fn jumps(&self) -> u64 {
        self.jumps.taken
    }

    /// Jumps that their review found to be gross errors.
    pub fn retracted_jumps(&self) -> u64 {
        self.jumps.retracted
    }

    /// Re-acquisitions so far.
    pub fn reacquisitions(&self) -> u64 {
        self.reacquisition.count
    }

    /// Re-acquisitions that their rival's evidence undid (`rival.rs`).
    pub fn undone_reacquisitions(&self) -> u64 {
        self.reacquisition.undone
    }

    /// Restarts so far (`restart.rs`).
    pub fn restarts(&self) -> u64 {
        self.reacquisition.restarts
    }

    /// A re-acquisition's rival is being weighed against it (`rival.rs`).
    pub fn revising(&self) -> bool {
        self.rival.active
    }

    /// The windowed normalised innovations are within their bound (see the
    /// module documentation), and no channel kept in the updates has an
    /// inconsistent wiring (`wiring.rs`). The supervisor's own decisions
    /// (challengers, what a restart learns) follow the window alone, so that
    /// a wiring check that only names changes no estimate.
    pub fn consistent(&self) -> bool {
        self.window.consistent() && (self.settings.wiring_leaves_out || !self.channels.iter().any(|c| c.inconsistent))
    }

    /// Every available row has been rejected for the last samples: the filter
    /// and all its sensors disagree (it re-acquires after `reacquire_after`).
    pub fn lost(&self) -> bool {
        self.reacquisition.lost_run > 0
    }

    /// The re-acquisitions have spent [`SupervisorSettings::max_inflation`]
    /// since a sample last passed the gate whole: no more until one does.
    pub fn exhausted(&self) -> bool {
        self.reacquisition.inflation >= self.settings.max_inflation
    }

    /// Consistent and not lost.
    pub fn healthy(&self) -> bool {
        self.consistent() && !self.lost()
    }

    /// The mean normalised innovation per row over the window, each clipped
    /// at the gate (about 1 for a consistent filter; NaN before any row).
    pub fn windowed_nis(&self) -> f64 {
        self.window.windowed_nis()
    }

    /// Whether `channel` would be faulty once the pending outcome is committed
    /// (what a read between a gate and its commit shows).
    pub fn faulty_with_pending(&self, channel: usize) -> bool {
        let bad = self.pending.rows[channel] != RowOutcome::Used;
        bad && self.channels[channel].bad_run.saturating_add(1) >= self.settings.fault_after
    }

    /// [`Supervisor::healthy`] as it will be once the pending outcome is
    /// committed, as far as being lost goes (the window moves at the commit).
    pub fn healthy_with_pending(&self) -> bool {
        self.consistent() && !self.pending.nothing_used()
    }

    /// Gate rejections so far plus those of the pending outcome.
    pub fn rejected_with_pending(&self) -> u64 {
        let rejected = self.pending.rows.iter().filter(|r| **r == RowOutcome::Rejected).count();
        let retracted = self.pending.retracted.iter().filter(|r| **r).count();
        self.rejected() + (rejected + retracted) as u64
    }

    /// The measurement the last [`Supervisor::gate`] was given, as offered.
    pub fn pending_measurement(&self) -> &[f64] {
        &self.z_offered
    }

    /// The outcome of the last [`Supervisor::gate`].
    pub fn pending(&self) -> &Outcome {
        &self.pending
    }

    /// Each row's status as a user reads it: its outcome at the last gate,
    /// but `Inconsistent` where it was used and its channel's wiring is named
    /// inconsistent and kept in the updates (`wiring.rs`; the verdict of the
    /// last commit).
    pub fn statuses(&self) -> impl Iterator<Item = RowOutcome> + '_ {
        self.pending.rows.iter().zip(&self.channels).map(|(&row, channel)| {
            if row == RowOutcome::Used && channel.inconsistent {
                RowOutcome::Inconsistent
            } else {
                row
            }
        })
    }

    /// Counts, for each refuted channel on probation, the samples in a row
    /// its probe (its row against the belief without it) passed the gate
    /// (`channel.rs`).
    fn commit_probation(&mut self) {
        let row = self.thresholds.row;
        for (c, channel) in self.channels.iter_mut().enumerate() {
            if !channel.refuted || self.pending.released == Some(c) {
                channel.probation_run = 0;
                continue;
            }
            let ratio = self.work.residuals[c].powi(2) / self.work.first_variances[c];
            channel.probation_run = if ratio <= row { channel.probation_run.saturating_add(1) } else { 0 };
        }
    }

    /// Counts the pending outcome: channel runs and faults, the
    /// re-acquisition run, the consistency window. Calls `changed` for every
    /// channel whose fault flag changes.
    pub fn commit(&mut self, mut changed: impl FnMut(FaultChange)) {
        let outcome = &self.pending;
        let rows = outcome.rows.iter().zip(&self.z_offered).zip(&outcome.watch);
        for (index, (channel, ((&row, &z), &watch))) in self.channels.iter_mut().zip(rows).enumerate() {
            let triggered = outcome.reacquired == Some(index);
            if let Some(change) = channel.count(index, row, z, triggered, watch, &self.settings) {
                changed(change);
            }
        }
        for (c, channel) in self.channels.iter_mut().enumerate() {
            let reviewed = outcome.reviewed && self.review.explained[c] && !outcome.retracted[c];
            let confirmed_at_once = outcome.jump > 0.0 && !outcome.ambiguous && outcome.explained[c];
            channel.since_change =
                if reviewed || confirmed_at_once { 0 } else { channel.since_change.saturating_add(1) };
        }
        self.commit_probation();
        let flux = self.in_flux();
        self.commit_signatures(flux);
        self.commit_wiring(flux);
        self.reacquisition.count(&self.pending, self.settings.max_inflation);
        self.commit_rival();
        self.commit_restart();
        let outcome = &self.pending;
        self.window.push(WindowEntry { clipped_ratios: outcome.clipped_ratios, rows: outcome.gated_rows });
        if outcome.retracted.contains(&true) {
            // The spike the review found counts as rejected, one sample late.
            for (channel, _) in self.channels.iter_mut().zip(&outcome.retracted).filter(|(_, r)| **r) {
                channel.rejected = channel.rejected.saturating_add(1);
            }
            self.jumps.retracted = self.jumps.retracted.saturating_add(1);
        }
        if outcome.reviewed {
            self.review.active = false;
        }
        if outcome.jump > 0.0 {
            self.jumps.taken = self.jumps.taken.saturating_add(1);
        }
        if outcome.ambiguous {
            self.review.active = true;
            std::mem::swap(&mut self.review.hypothesis, &mut self.work.hypothesis);
            std::mem::swap(&mut self.review.jumped, &mut self.work.jumped);
            self.review.explained.copy_from_slice(&outcome.explained);
        }
        self.adaptation.learn(outcome, &self.settings);
    }
}
