//! Revisable re-acquisitions: the belief a re-acquisition set aside is kept
//! as a rival, predicted and scored against the re-acquired one until the
//! data decide between them.
//!
//! A re-acquisition (`reacquisition.rs`) bets that the state moved: it
//! inflates the covariance and takes in every row, the failing ones too. A
//! burst of gross errors long enough to trigger it (S1: ten samples of a
//! glitching accelerometer) makes that bet wrong, and with two channels
//! nothing outvotes it: the garbage is in the state, the clean samples that
//! follow fail the gate, and before this module the estimate never came back.
//!
//! So the bet is not final. At a re-acquisition the supervisor also makes
//! the update the gate alone would have made (the failing rows left out) and
//! keeps it as the rival. At every later sample the rival is predicted,
//! gated on its own (a row failing its χ²(1) test is left out) and both
//! beliefs are scored on the same rows by a robust log-likelihood of their
//! predictions, each row's `−½(ln Sᵢᵢ + min(νᵢ²/Sᵢᵢ, c))` with `c` the
//! χ²(1) quantile of `1 − 1e-6`: a row that neither belief explains (the
//! burst still going) costs both about the same, a row one belief explains
//! and the other does not moves the evidence by up to `c/2` nats. The first
//! belief whose lead reaches `c` nats (two rows' worth, odds of about 10¹⁰)
//! is kept; at the consistency window's end the one ahead is. The rival
//! never re-acquires itself and there is one at a time: the belief kept
//! aside is the one from before the episode.
//!
//! The rival stands for the trigger's sensor having been off. Where that
//! row alone fails the rival's gate, the sensor is still off under the
//! rival's hypothesis, and its sample says nothing about which belief is
//! right: it is scored for neither, and the other rows decide. Scored, it
//! favoured the re-acquired belief, which follows the faulty channel, by
//! up to `c/2` nats a sample (S1's z₁ read ×9.81: the re-acquisition was
//! kept within three samples, and the clean z₁ after the episode failed
//! the gate against the state it had dragged for most of a second). Where
//! other rows fail the rival's gate too, the rival's hypothesis is itself
//! in doubt and every row counts (S4's swapped telegrams were recovered
//! less often without that rule).
//!
//! * **The rival wins** (the garbage was in): the filter takes the rival's
//!   belief at this sample, the rows are those of its update, the channel
//!   that triggered the re-acquisition is suspended (it was the sensor: it
//!   triggers no re-acquisition until it passes the gate, though a jump it
//!   explains is still taken and reviewed), and the consistency window's
//!   samples since the fork become the rival's.
//! * **The re-acquired belief wins** (the state had moved): the rival is
//!   dropped, nothing else changes.
//!
//! **Challengers.** Some episodes never trigger a re-acquisition: the gate
//! lets a unit error through (S1's z₂ read ×9.81 for 0.1 s), or a jump takes
//! it; the state is dragged and, once the inputs are clean, one channel fails
//! the gate for good while the filter stays inconsistent. No re-acquisition's
//! rival holds the belief from before. So an inconsistent filter (its
//! windowed NIS beyond its bound) is challenged, at most once per window: a
//! belief started from where the states have been while the filter was
//! healthy (`restart.rs`, the restart's belief), updated with the sample's
//! rows under its own gate, becomes the rival, and is weighed in the same
//! way. It must lead by `c` nats to win; on a near tie at the window's end
//! the filter is kept. If it wins the filter restarts at its belief
//! ([`Revision::Restarted`]): the filter, not its sensors, was wrong, so
//! every suspended channel is taken back.
//!
//! **A confirmed jump's fault hypothesis.** A jump that one row alone
//! explains is reviewed at the next sample (`jump.rs`); a fault of a few
//! samples on that row passes the review as a step and back, and the jump
//! drags the states its unknown input drives, so that the other rows fail
//! the gate afterwards. So a review that confirms such a jump keeps the
//! belief without that row as the rival. That row is neither scored nor
//! used by the rival: the jumped belief follows it by construction, so it
//! would favour the jump for as long as the sensor is off (S2, an axle box
//! read ×9.81 for 14 samples: the jump was kept after 7), and a rival that
//! took it in where it happened to pass its own gate (S1's flipped
//! `z2_ddot` near its zero crossings) was dragged as the filter was. The
//! other rows decide, through the states the jump dragged. The jumped
//! belief is kept only once it leads by `c` nats with no row of its own
//! rejected, or at the window's end; the rival must lead clearly, as a
//! challenger must, and its win is [`Revision::JumpUndone`]: the sensor was
//! wrong, so its channel is suspended and refuted: on probation, left out
//! until its row agrees with the belief without it for a while, then used
//! again with that belief as its rival, a fault hypothesis of the same kind
//! (`channel.rs`); without that the sensor, still off, was followed again
//! at the next sample. All this provided the rival's window is consistent
//! and the filter has been healthy for a window (`restart.rs`, settled;
//! before that no row is left out of the fault hypothesis either). An
//! inconsistent or unsettled filter may be what is wrong: the S5 EKF, its start-up jumps on `Nz`
//! undone and `Nz` suspended, lost `Nz` for 0.6 s and ended a flight with
//! `Cz_δ` 5.7 % off, against 0.4 % with `Nz` kept. It is a precaution, kept
//! after most confirmed jumps, so a re-acquisition's rival or a challenger
//! replaces it, and the restart goes on learning while it lives
//! (`restart.rs`).
//!
//! The cost is a second predict and update per sample while a rival lives
//! (at most a window), none otherwise.

use super::consistency::WindowEntry;
use super::jump::empty_snapshot;
use super::outcome::{Revision, RowOutcome};
use super::Supervisor;
use crate::error::FilterError;
use crate::filter::{Innovation, Snapshot, StateEstimator};

/// What a rival stands for (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Hypothesis {
    /// The update the gate alone would have made, kept at a re-acquisition.
    Reacquisition,
    /// A belief started from where the states have been, against an
    /// inconsistent filter.
    Challenger,
    /// The belief without the row that a confirmed single-row jump followed.
    JumpFault,
    /// The belief without a channel released from probation (`channel.rs`):
    /// a fault hypothesis that no settled change drops early, since the
    /// released sensor may still be off.
    Release,
}

impl Hypothesis {
    /// Every hypothesis, in the order the memory numbers them.
    pub const ALL: [Hypothesis; 4] =
        [Hypothesis::Reacquisition, Hypothesis::Challenger, Hypothesis::JumpFault, Hypothesis::Release];

    /// The belief without one row (its trigger), which the other rows judge.
    pub fn without_trigger(self) -> bool {
        matches!(self, Hypothesis::JumpFault | Hypothesis::Release)
    }
}

/// The belief a re-acquisition set aside, while the data decide.
#[derive(Debug, Clone)]
pub(super) struct Rival {
    /// A rival is alive.
    pub active: bool,
    /// What it stands for.
    pub hypothesis: Hypothesis,
    /// Samples in a row, up to the last committed one, in which the filter's
    /// own update rejected no row.
    pub clean_run: u32,
    /// The channel whose failures triggered the re-acquisition, or whose
    /// failure the jump explained.
    pub trigger: usize,
    /// The evidence so far for the rival over the re-acquired belief (nats).
    pub evidence: f64,
    /// The rival's belief after its last committed update.
    pub belief: Snapshot,
    /// Its consistency-window entries since the fork, oldest first (at most a window).
    pub entries: Vec<WindowEntry>,
}

impl Rival {
    /// None, for a window of `window` samples.
    pub fn new(window: usize) -> Self {
        Self {
            active: false,
            hypothesis: Hypothesis::Reacquisition,
            clean_run: 0,
            trigger: 0,
            evidence: 0.0,
            belief: empty_snapshot(),
            entries: Vec::with_capacity(window),
        }
    }

    /// The row the two beliefs disagree about by construction: a confirmed
    /// jump's row, which the jumped belief follows and its fault hypothesis
    /// leaves out. It is not scored (see the module documentation).
    pub fn disputed(&self) -> Option<usize> {
        (self.active && self.hypothesis.without_trigger()).then_some(self.trigger)
    }
}

/// The robust log-likelihood of an update's predictions on its rows but the
/// `disputed` one (see the module documentation); every row's clipped
/// normalised innovation is summed into `clipped` at the gate's own clip.
pub(super) fn score(
    innovation: &Innovation,
    clip: f64,
    gate_clip: f64,
    disputed: Option<usize>,
    clipped: &mut f64,
) -> f64 {
    let mut score = 0.0;
    for &r in innovation.rows() {
        let variance = innovation.covariance()[(r, r)];
        let ratio = innovation.residual()[r].powi(2) / variance;
        let ratio = if ratio.is_nan() { f64::INFINITY } else { ratio };
        if disputed != Some(r) {
            score -= 0.5 * (crate::math::ln(variance) + ratio.min(clip));
        }
        *clipped += ratio.min(gate_clip);
    }
    score
}

impl Supervisor {
    /// Keeps, at a re-acquisition, the update the gate would have made
    /// instead (the rows `failing` selects left out) as the rival to be;
    /// leaves the filter at `before`. Without a rival (one is alive, or the
    /// update fails) the re-acquisition is simply final.
    pub(super) fn fork_rival(
        &mut self,
        filter: &mut dyn StateEstimator,
        failing: impl Fn(usize, f64) -> bool,
    ) -> Result<(), FilterError> {
        // A re-acquisition's rival replaces a confirmed jump's fault hypothesis.
        if !self.settings.revise
            || (self.rival.active && !self.rival.hypothesis.without_trigger())
            || self.pending.forked
        {
            return Ok(());
        }
        let work = &mut self.work;
        work.z_hypothesis.copy_from_slice(&work.z_gated);
        for &r in &work.rows {
            if failing(r, work.ratios[r]) {
                work.z_hypothesis[r] = f64::NAN;
            }
        }
        filter.restore(&work.before)?;
        if filter.update(&work.z_hypothesis).is_ok() {
            filter.snapshot_into(&mut work.rival_next);
            self.pending.forked = true;
        }
        filter.restore(&self.work.before)
    }

    /// Predicts the rival to this sample and makes its gated update into
    /// `work.rival_next`, scoring it (`work.rival_score`, `work.rival_entry`);
    /// leaves the filter at `before`. `false` when it cannot be predicted or
    /// updated: it is then dropped.
    pub(super) fn step_rival(&mut self, filter: &mut dyn StateEstimator) -> Result<bool, FilterError> {
        let work = &mut self.work;
        let belief = &self.rival.belief;
        let dt = work.before.time - belief.time;
        let predicted = filter
            .restore(belief)
            .and_then(|()| if dt > 0.0 { filter.predict(&belief.input, dt) } else { Ok(()) })
            .and_then(|()| filter.hold_input(&work.before.input));
        if predicted.is_err() {
            filter.restore(&work.before)?;
            return Ok(false);
        }
        let disputed = self.rival.disputed().filter(|_| self.settled());
        self.update_rival(filter, disputed)
    }

    /// Keeps a belief without row `row`, updated with this sample's other
    /// rows, as the rival to be, a fault hypothesis of that row (see the
    /// module documentation); leaves the filter at `before`. The belief is
    /// either the fault hypothesis of a jump that `row` alone explained, which
    /// its review has just confirmed (in `work.hypothesis`, predicted to this
    /// sample: a spike of a few samples looks like a step and back, and only
    /// the samples after it tell, through the other rows, whether the state
    /// moved), or, when `released`, `before` itself: `row`'s channel is used
    /// again, its probation passed, and may still be off where it happened to
    /// agree for a while (a flipped accelerometer near a zero crossing).
    pub(super) fn fork_fault_hypothesis(
        &mut self,
        filter: &mut dyn StateEstimator,
        row: usize,
        released: bool,
    ) -> Result<(), FilterError> {
        if !self.settings.revise || self.rival.active || self.pending.forked {
            return Ok(());
        }
        filter.restore(if released { &self.work.before } else { &self.work.hypothesis })?;
        // Only a settled filter leaves the row out (a channel is refuted only then).
        let left_out = self.settled().then_some(row);
        if self.update_rival(filter, left_out)? {
            self.pending.forked = true;
            self.pending.jump_forked = Some(row);
        }
        Ok(())
    }

    /// Starts a challenger (see the module documentation) at this sample when
    /// one is due: its belief from where the states have been, updated with
    /// this sample's rows (its own gate), becomes the rival to be. Leaves the
    /// filter at `before`.
    pub(super) fn fork_challenger(&mut self, filter: &mut dyn StateEstimator) -> Result<(), FilterError> {
        let due = self.settings.revise
            && (!self.rival.active || self.rival.hypothesis.without_trigger())
            && !self.pending.forked
            && !self.window.consistent()
            && !self.channels.iter().any(|c| c.suspended)
            && self.reacquisition.since_challenge as usize >= self.settings.window
            && self.settled();
        if !due {
            return Ok(());
        }
        let restart = self.climate.restart_belief();
        let started =
            filter.reset(self.work.before.time, restart).and_then(|()| filter.hold_input(&self.work.before.input));
        if started.is_err() {
            return filter.restore(&self.work.before);
        }
        if self.update_rival(filter, None)? {
            self.pending.forked = true;
            self.pending.challenged = true;
        }
        Ok(())
    }

    /// Updates the rival's belief, which the filter holds predicted to this
    /// sample, with this sample's rows and scores it: its first pass's robust
    /// log-likelihood and window entry, then its own gate (a row failing its
    /// χ²(1) test is left out); the result in `work.rival_next`. Leaves the
    /// filter at `before`; `false` when the update fails.
    fn update_rival(&mut self, filter: &mut dyn StateEstimator, disputed: Option<usize>) -> Result<bool, FilterError> {
        let (clip, row) = (self.thresholds.adaptation_clip, self.thresholds.row);
        let gate_clip = row.min(1e6);
        // Scored on the rows the main belief is scored on: without the
        // disputed one even where the rival still takes it in (before the
        // filter has settled).
        let unscored = self.rival.disputed();
        let work = &mut self.work;
        filter.snapshot_into(&mut work.alternative);
        work.z_hypothesis.copy_from_slice(&work.z_gated);
        if let Some(r) = disputed {
            work.z_hypothesis[r] = f64::NAN;
        }
        if filter.update(&work.z_hypothesis).is_err() {
            filter.restore(&work.before)?;
            return Ok(false);
        }
        let innovation = filter.innovation();
        // A re-acquisition's trigger is not scored where it alone fails the
        // rival's gate (see the module documentation).
        let trigger = self.rival.trigger;
        let fails = |r: usize| innovation.residual()[r].powi(2) / innovation.covariance()[(r, r)] > row;
        let unscored = if self.rival.active
            && self.rival.hypothesis == Hypothesis::Reacquisition
            && innovation.rows().contains(&trigger)
            && innovation.rows().iter().all(|&r| fails(r) == (r == trigger))
        {
            work.unscored = Some(trigger);
            Some(trigger)
        } else {
            unscored
        };
        let mut clipped = 0.0;
        work.rival_score = score(innovation, clip, gate_clip, unscored, &mut clipped);
        work.rival_entry = WindowEntry { clipped_ratios: clipped, rows: innovation.rows_used() };
        work.rival_rows.copy_from_slice(&self.pending.rows);
        if let Some(r) = disputed.filter(|&r| work.z_gated[r].is_finite()) {
            work.rival_rows[r] = RowOutcome::Rejected;
        }
        let mut left_out = false;
        for &r in innovation.rows() {
            let ratio = innovation.residual()[r].powi(2) / innovation.covariance()[(r, r)];
            if ratio > row || ratio.is_nan() {
                work.z_hypothesis[r] = f64::NAN;
                work.rival_rows[r] = RowOutcome::Rejected;
                left_out = true;
            }
        }
        let updated = if left_out {
            filter.restore(&work.alternative).and_then(|()| filter.update(&work.z_hypothesis).map(|_| ()))
        } else {
            Ok(())
        };
        if updated.is_err() {
            filter.restore(&work.before)?;
            return Ok(false);
        }
        let innovation = filter.innovation();
        work.rival_update = (innovation.nis(), innovation.rows_used());
        filter.snapshot_into(&mut work.rival_next);
        filter.restore(&work.before)?;
        Ok(true)
    }

    /// Weighs this sample's evidence (the main belief's score from its first
    /// pass) and, when it decides for the rival, puts the rival's update on
    /// the filter and in the outcome.
    pub(super) fn weigh_rival(&mut self, filter: &mut dyn StateEstimator) -> Result<(), FilterError> {
        let delta = self.work.rival_score - self.work.main_score;
        let evidence = self.rival.evidence + delta;
        let threshold = self.thresholds.adaptation_clip;
        let horizon = self.rival.entries.len() + 1 >= self.settings.window;
        // A challenger, and a confirmed jump's fault hypothesis, must lead
        // clearly: the incumbent is kept on a near tie.
        let hypothesis = self.rival.hypothesis;
        let clearly = hypothesis != Hypothesis::Reacquisition;
        let ahead = evidence >= threshold || (horizon && evidence > 0.0 && !clearly);
        self.pending.revision = if ahead && hypothesis == Hypothesis::Challenger {
            Revision::Restarted
        } else if ahead && hypothesis.without_trigger() {
            Revision::JumpUndone { trigger: self.rival.trigger }
        } else if ahead {
            Revision::Undone { trigger: self.rival.trigger }
        } else if (evidence <= -threshold && self.incumbent_explains_all()) || self.jump_settled(evidence) || horizon {
            Revision::Confirmed
        } else {
            Revision::Weighed(delta)
        };
        if !self.pending.replaced() {
            return Ok(());
        }
        filter.restore(&self.work.rival_next)?;
        let pending = &mut self.pending;
        pending.rows.copy_from_slice(&self.work.rival_rows);
        (pending.nis, pending.dof) = self.work.rival_update;
        (pending.clipped_ratios, pending.gated_rows) =
            (self.work.rival_entry.clipped_ratios, self.work.rival_entry.rows);
        pending.reacquired = None;
        pending.inflation = 1.0;
        pending.jump = 0.0;
        pending.ambiguous = false;
        pending.continued = false;
        pending.explained.fill(false);
        pending.steps.fill(0.0);
        Ok(())
    }

    /// Whether the filter's own update at this sample rejected no row: a
    /// confirmed jump's fault hypothesis is dropped only then (or at the
    /// window's end). While the sensor the jump followed is still off, each
    /// belief fails one row (the jump the other sensors, the fault hypothesis
    /// that sensor), their scores nearly tie, and the evidence drifts by the
    /// rows' variances alone; the samples after the episode decide.
    fn incumbent_explains_all(&self) -> bool {
        !self.rival.hypothesis.without_trigger() || self.pending.rejected_none()
    }

    /// A confirmed jump's fault hypothesis is dropped, too, once the jumped
    /// belief is ahead and has rejected no row for `change_memory` samples in
    /// a row, this one included: the change it followed has settled, and the
    /// rival would otherwise cost a second predict and update per sample for
    /// a whole window after most jumps.
    fn jump_settled(&self, evidence: f64) -> bool {
        self.rival.hypothesis == Hypothesis::JumpFault
            && self.pending.rejected_none()
            && evidence <= 0.0
            && self.rival.clean_run.saturating_add(1) >= self.settings.change_memory
    }

    /// Counts the pending outcome's fork or revision (before the consistency
    /// window takes the sample).
    pub(super) fn commit_rival(&mut self) {
        let reacquisition = &mut self.reacquisition;
        let challenging = self.rival.active && self.rival.hypothesis == Hypothesis::Challenger;
        reacquisition.since_challenge = if challenging { 0 } else { reacquisition.since_challenge.saturating_add(1) };
        if self.pending.forked {
            let release = self.pending.released.filter(|&c| self.pending.jump_forked == Some(c));
            if release.is_some_and(|c| self.pending.rows[c] != RowOutcome::Used) {
                // The released row failed the gate at once: it stays refuted,
                // on probation, and a belief without it has no rival to be.
                return;
            }
            self.rival.active = true;
            self.rival.hypothesis = if self.pending.challenged {
                Hypothesis::Challenger
            } else if release.is_some() {
                Hypothesis::Release
            } else if self.pending.jump_forked.is_some() {
                Hypothesis::JumpFault
            } else {
                Hypothesis::Reacquisition
            };
            self.rival.clean_run = 0;
            self.rival.trigger = self.pending.reacquired.or(self.pending.jump_forked).unwrap_or(0);
            self.rival.evidence = 0.0;
            self.rival.entries.clear();
            std::mem::swap(&mut self.rival.belief, &mut self.work.rival_next);
            return;
        }
        match self.pending.revision {
            Revision::None => {}
            Revision::Weighed(delta) => {
                let clean_run = self.rival.clean_run.saturating_add(1);
                self.rival.clean_run = if self.pending.rejected_none() { clean_run } else { 0 };
                self.rival.evidence += delta;
                self.rival.entries.push(self.work.rival_entry);
                std::mem::swap(&mut self.rival.belief, &mut self.work.rival_next);
            }
            Revision::Confirmed => self.rival.active = false,
            Revision::Undone { .. } => {
                self.rival.active = false;
                self.window.replace_latest(&self.rival.entries);
                self.channels[self.rival.trigger].suspended = true;
                self.review.active = false;
                self.reacquisition.undone = self.reacquisition.undone.saturating_add(1);
            }
            Revision::JumpUndone { trigger } => {
                self.rival.active = false;
                self.window.replace_latest(&self.rival.entries);
                // Its sensor, not the state, had changed: no change is under
                // way. With the rival's window consistent, that verdict holds:
                // the channel goes on probation (`channel.rs`). An inconsistent
                // filter may itself be what is wrong, so the sensor stays in.
                let settled = self.settled();
                let channel = &mut self.channels[trigger];
                channel.suspended = self.window.consistent();
                channel.refuted = channel.suspended && settled;
                channel.since_change = u32::MAX;
                self.review.active = false;
                self.jumps.retracted = self.jumps.retracted.saturating_add(1);
            }
            Revision::Restarted => {
                // The filter, not its sensors, was wrong: every suspension is lifted.
                self.rival.active = false;
                self.window.replace_latest(&self.rival.entries);
                for channel in &mut self.channels {
                    channel.suspended = false;
                    channel.refuted = false;
                }
                self.review.active = false;
                let reacquisition = &mut self.reacquisition;
                reacquisition.restarts = reacquisition.restarts.saturating_add(1);
                reacquisition.inflation = 1.0;
            }
        }
    }
}
