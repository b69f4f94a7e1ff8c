//! What the supervisor remembers of one measurement channel, and how a
//! committed sample changes it.

use super::outcome::{FaultChange, RowOutcome};
use super::settings::SupervisorSettings;

/// The state of one measurement channel.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Channel {
    /// Consecutive samples rejected, stuck or missing.
    pub bad_run: u32,
    /// Consecutive samples rejected by the gate.
    pub rejected_run: u32,
    /// Faulty: the last `fault_after` samples were rejected, stuck or missing.
    pub faulty: bool,
    /// Samples rejected by the gate so far.
    pub rejected: u64,
    /// Samples left out as stuck so far.
    pub stuck: u64,
    /// Samples since this channel last triggered a re-acquisition (`u32::MAX`: never).
    pub(super) since_reacquisition: u32,
    /// The data found the channel, not the state, wrong: it failed again
    /// right after its re-acquisition, that re-acquisition was undone, or a
    /// jump it alone explained was undone while the filter was consistent
    /// (`rival.rs`). Until it passes the gate again it triggers no
    /// re-acquisition.
    pub suspended: bool,
    /// A jump it alone explained was undone while the filter was consistent
    /// (`rival.rs`): the sensor, not the state, changed. It is on probation:
    /// left out of the updates (status inconsistent) while its row, scored
    /// against the belief without it, has not passed the gate for
    /// [`SupervisorSettings::reacquire_after`] samples in a row (as many as
    /// make its failures persistent), for at most a consistency window; then
    /// it is used again with the belief without it as the rival, so that a
    /// sensor still off (a flipped accelerometer near a zero crossing agrees
    /// for a while) is refuted again and what it dragged is undone. Used
    /// wherever it passed the gate, S1's flipped `z2_ddot` was taken in at
    /// every crossing and the load never came back; on probation the flip
    /// costs what the same samples missing cost. Its failures explain no
    /// jump either. A channel suspended
    /// for its re-acquisition still may: once its fault has ended, the
    /// belief has drifted while it was left out, and a jump it explains
    /// (reviewed, with its own rival) is how it comes back at once. Barred
    /// from that, S1's `z2_ddot` after a 12-sample burst was rejected for
    /// 16 clean samples, the load 5 N off, where the same samples missing
    /// cost nothing after their end.
    pub refuted: bool,
    /// Samples since a jump that this channel's row explained was confirmed:
    /// by another row at its sample, or by its review at the next
    /// (`jump.rs`; `u32::MAX`: never). While it is below
    /// [`SupervisorSettings::change_memory`] the change is under way, and a
    /// further jump this row alone explains is shown at its sample.
    pub(super) since_change: u32,
    /// The bits of the last finite value.
    pub(super) last_value: u64,
    /// How many times in a row that value came.
    pub(super) repeats: u32,
    /// The multiple of the step quantum its rejected innovations sit at.
    pub(super) step_multiple: i64,
    /// How many samples in a row they sat there.
    pub(super) step_run: u32,
    /// Consecutive samples a refuted channel's probe passed the gate.
    pub(super) probation_run: u32,
    /// Its wiring is inconsistent with the other channels (`wiring.rs`)
    /// until its scores are back: left out of the updates, or named with
    /// the filter inconsistent ([`SupervisorSettings::wiring_leaves_out`]).
    pub inconsistent: bool,
    /// Consecutive samples its wiring score has been above the threshold.
    pub(super) wiring_run: u32,
    // The wiring scores' forgetting sums (`wiring.rs`): the bias score's
    // evidence and weight, the scale score's, its `Σλ·g²`, the mean
    // normalised innovation's sum and weight; the faster fit's six sums;
    // the mean prediction and how many predictions it has seen.
    pub(super) bias_evidence: f64,
    pub(super) bias_weight: f64,
    pub(super) scale_evidence: f64,
    pub(super) scale_weight: f64,
    pub(super) scale_norm: f64,
    pub(super) offset_sum: f64,
    pub(super) offset_weight: f64,
    pub(super) fit_evidence: f64,
    pub(super) fit_e: f64,
    pub(super) fit_g: f64,
    pub(super) fit_norm: f64,
    pub(super) fit_offset: f64,
    pub(super) fit_weight: f64,
    pub(super) prediction_mean: f64,
    pub(super) predictions: u64,
}

impl Channel {
    /// A channel before its first sample.
    pub(super) fn new() -> Self {
        Self { since_reacquisition: u32::MAX, since_change: u32::MAX, ..Self::default() }
    }

    /// Refuted, its probe has not yet passed the gate `probation` samples in
    /// a row, and it has been left out for less than `longest` samples: left
    /// out of the updates.
    pub(super) fn on_probation(&self, probation: u32, longest: usize) -> bool {
        self.refuted && self.probation_run < probation && (self.bad_run as usize) < longest
    }

    /// `value` repeats the last one bit for bit often enough to be stuck.
    pub(super) fn is_stuck_at(&self, value: f64, stuck_after: u32) -> bool {
        value.to_bits() == self.last_value && self.repeats.saturating_add(1) >= stuck_after
    }

    /// `row`, its outcome at the sample just counted, is a gross error: rejected,
    /// its run of rejections shorter than a re-acquisition's trigger (a burst,
    /// no wiring; a flipped telegram that fails the gate for good is).
    pub(super) fn gross_error(&self, row: RowOutcome, reacquire_after: u32) -> bool {
        row == RowOutcome::Rejected && self.rejected_run < reacquire_after
    }

    /// Its gate failures have lasted long enough to ask for a re-acquisition,
    /// if this sample fails too, and it is not suspended.
    pub(super) fn may_trigger_reacquisition(&self, reacquire_after: u32) -> bool {
        !self.suspended && self.rejected_run.saturating_add(1) >= reacquire_after
    }

    /// Counts one committed sample: what became of the row, the value
    /// offered (`z`), whether this channel triggered the sample's
    /// re-acquisition and the step watch. Returns the fault flag's change, if any.
    pub(super) fn count(
        &mut self,
        index: usize,
        row: RowOutcome,
        z: f64,
        triggered: bool,
        watch: (i64, u32),
        settings: &SupervisorSettings,
    ) -> Option<FaultChange> {
        let bad = row != RowOutcome::Used;
        let rejected = row == RowOutcome::Rejected;
        self.rejected = self.rejected.saturating_add(u64::from(rejected));
        self.stuck = self.stuck.saturating_add(u64::from(row == RowOutcome::Stuck));
        self.rejected_run = if rejected { self.rejected_run.saturating_add(1) } else { 0 };
        // Failing again within a window of its own re-acquisition: the channel, not the state, is wrong.
        if rejected && (self.since_reacquisition as usize) < settings.window {
            self.suspended = true;
        } else if row == RowOutcome::Used {
            self.suspended = false;
        }
        if row == RowOutcome::Used {
            self.refuted = false;
        }
        self.since_reacquisition = if triggered { 0 } else { self.since_reacquisition.saturating_add(1) };
        self.bad_run = if bad { self.bad_run.saturating_add(1) } else { 0 };
        if z.is_finite() {
            let same = z.to_bits() == self.last_value;
            self.repeats = if same { self.repeats.saturating_add(1) } else { 1 };
            self.last_value = z.to_bits();
        }
        (self.step_multiple, self.step_run) = watch;
        let faulty = self.bad_run >= settings.fault_after;
        (faulty != self.faulty).then(|| {
            self.faulty = faulty;
            FaultChange { channel: index, faulty }
        })
    }
}
