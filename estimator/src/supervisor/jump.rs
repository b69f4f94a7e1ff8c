//! Model mismatch or sensor fault: the jump hypothesis, and its review one
//! sample later.
//!
//! A row that fails the gate is either a gross error of its sensor or the
//! sign that the state moved more than `Q` allows (a load step, a weld, a
//! spectrum wider than the tuning). The two are told apart by what the
//! unknown inputs can do:
//!
//! * **Explained by a jump.** Adding process noise `c·Q` to `P`, in the
//!   states of the unknown inputs ([`Supervisor::with_jump_states`]; all by
//!   default; with `local_jumps`, only those a failing row sees), raises the
//!   innovation variance of row `i` by `c·Gᵢ`, `Gᵢ = (H·Q·Hᵀ)ᵢᵢ`, found
//!   from one probe update with `P + Q`. A failing row is explained when some
//!   `c ≤ implausible_sigmas²` brings its innovation to one σ; a row no jump
//!   of the unknown inputs reaches (`Gᵢ ≈ 0`: in S1 the acceleration of the
//!   mass the load does not act on) is a fault, and rejected. Only the
//!   unknown inputs jump: a drifting sensor that the motion states' small
//!   process noise could follow, one large jump after another, must not be.
//!   Nor does the row of a refuted channel (a jump it alone explained was
//!   undone, `rival.rs`) at the sample its probation ends: until it passes
//!   the gate again its failures are its own.
//! * **Not contradicted by the other rows.** The row is then predicted from
//!   the update with the other rows under `P + c·Q` (leave one out): where
//!   they see the same directions of the state, they pin what it can be, and
//!   a row that still fails disagrees with them: a fault. The update is
//!   then made from `P + c·Q` with the largest such `c` and every row not
//!   rejected: the change is followed at once, its σ widened as it must be.
//!   The rows that fail even so are faults.
//! * **Confirmed** when two or more rows explain the same jump: two sensors
//!   failing at once, and agreeing, is not the likely reading.
//! * **Reviewed at the next sample** when one row alone explains it. Where
//!   only the jumping directions see a row (S1's load acts on one
//!   accelerometer alone), one sample cannot tell a spike from a step. The
//!   belief shown has the mean of the fault hypothesis (the update without
//!   the row: data in doubt moves nothing until it is confirmed) and the
//!   covariance of the half-and-half mixture of both hypotheses, so that its
//!   σ covers the jump should it be one (its error is then within 2σ). Both
//!   beliefs are kept; at the next sample both are
//!   predicted and the one whose innovation is the likelier for the new
//!   measurement is followed. A step persists and keeps the jump; a spike is
//!   undone, and its row counts as rejected, one sample late.
//!
//! A jump never re-acquires (it does not inflate every direction of `P`), so
//! it spends nothing of the inflation budget.

use super::outcome::RowOutcome;
use super::signature::{state_scale, PROBE};
use super::Supervisor;
use crate::error::FilterError;
use crate::filter::{FilterKind, Snapshot, StateEstimator};
use nalgebra::DMatrix;

/// A row sees a jump state whose probe moves it by more than this share of
/// what the row's most visible jump state's probe does (not rounding).
const SEEN: f64 = 1e-6;

/// The jump taken at the last committed sample, under review at the next.
#[derive(Debug, Clone)]
pub(super) struct Review {
    /// A jump awaits its review.
    pub active: bool,
    /// The rows its failure explained.
    pub explained: Vec<bool>,
    /// The belief after the jump's sample without the explained rows (the fault hypothesis).
    pub hypothesis: Snapshot,
    /// The belief after the jump (the jump hypothesis).
    pub jumped: Snapshot,
}

impl Review {
    /// None pending, for `m` rows.
    pub fn new(m: usize) -> Self {
        Self { active: false, explained: vec![false; m], hypothesis: empty_snapshot(), jumped: empty_snapshot() }
    }
}

/// The counts of jumps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) struct Jumps {
    /// Jumps taken so far.
    pub taken: u64,
    /// Jumps a review found to be gross errors.
    pub retracted: u64,
}

/// A snapshot with no buffers yet.
pub(super) fn empty_snapshot() -> Snapshot {
    Snapshot { kind: FilterKind::Ckf, time: 0.0, input: Vec::new(), mean: Vec::new(), covariance: Vec::new() }
}

impl Supervisor {
    /// Tries the jump hypothesis on a failing pass (`work` holds its rows,
    /// ratios and variances; `work.before` the belief before the gate).
    /// Returns whether a jump was taken; when not, the filter holds the belief
    /// before the gate and neither the outcome nor `z_gated` changed.
    pub(super) fn try_jump(
        &mut self,
        filter: &mut dyn StateEstimator,
        failing: impl Fn(usize, f64) -> bool,
    ) -> Result<bool, FilterError> {
        let limit = self.settings.implausible_sigmas * self.settings.implausible_sigmas;
        filter.restore(&self.work.before)?;
        if !self.open_jump_states(filter, &failing)? {
            return Ok(false);
        }
        // The probe: G from the innovation variances with P + Q.
        let probed = filter
            .add_process_noise(1.0, &self.work.jump_open)
            .and_then(|()| filter.update(&self.work.z_gated).map(|_| ()));
        if probed.is_err() {
            filter.restore(&self.work.before)?;
            return Ok(false);
        }
        let mut factor = 0.0_f64;
        let mut explained_any = false;
        {
            let innovation = filter.innovation();
            let work = &mut self.work;
            work.explained.fill(false);
            work.unexplained.fill(false);
            for &r in &work.rows {
                if !failing(r, work.ratios[r]) {
                    continue;
                }
                if self.channels[r].refuted {
                    work.unexplained[r] = true;
                    continue;
                }
                let g = innovation.covariance()[(r, r)] - work.variances[r];
                work.gains[r] = g;
                let need = (innovation_squared(work, r) - work.variances[r]) / g;
                if g > 0.0 && need.is_finite() && need <= limit {
                    work.explained[r] = true;
                    explained_any = true;
                    factor = factor.max(need);
                } else {
                    work.unexplained[r] = true;
                }
            }
        }
        // The other rows may contradict it: row r, predicted from the update
        // with the rest under P + c·Q, still fails (leave one out).
        if explained_any && self.work.rows.len() > 1 {
            factor = self.contradicted(filter, factor)?;
            explained_any = self.work.explained.iter().any(|&e| e);
        }
        if !explained_any {
            filter.restore(&self.work.before)?;
            return Ok(false);
        }
        // The fault hypothesis, kept for the review: the update without the failing rows.
        for r in 0..self.work.z_gated.len() {
            let out = self.work.explained[r] || self.work.unexplained[r];
            self.work.z_hypothesis[r] = if out { f64::NAN } else { self.work.z_gated[r] };
        }
        filter.restore(&self.work.before)?;
        if filter.update(&self.work.z_hypothesis).is_err() {
            filter.restore(&self.work.before)?;
            return Ok(false);
        }
        filter.snapshot_into(&mut self.work.hypothesis);
        // The jump: the unexplained rows rejected, the rest used from P + c·Q;
        // a row failing even so is a fault too, and the update is made again without it.
        for r in 0..self.work.z_gated.len() {
            if self.work.unexplained[r] {
                self.work.z_gated[r] = f64::NAN;
            }
        }
        let mut settled = false;
        for _ in 0..2 {
            filter.restore(&self.work.before)?;
            let jumped = filter
                .add_process_noise(factor, &self.work.jump_open)
                .and_then(|()| filter.update(&self.work.z_gated).map(|_| ()));
            if jumped.is_err() {
                filter.restore(&self.work.before)?;
                self.restore_gated();
                return Ok(false);
            }
            let threshold = self.thresholds.row;
            let innovation = filter.innovation();
            let mut again = false;
            for &r in innovation.rows() {
                if fails(innovation, r, threshold) {
                    self.work.z_gated[r] = f64::NAN;
                    self.work.explained[r] = false;
                    self.work.unexplained[r] = true;
                    again = true;
                }
            }
            if !again {
                settled = true;
                break;
            }
        }
        if !settled || !self.work.explained.contains(&true) {
            // Rows still fail from P + c·Q, or nothing the jump explains is left: it is no jump.
            filter.restore(&self.work.before)?;
            self.restore_gated();
            return Ok(false);
        }
        let innovation = filter.innovation();
        (self.pending.nis, self.pending.dof) = (innovation.nis(), innovation.rows_used());
        let alone = self.work.explained.iter().filter(|&&e| e).count() == 1;
        let continued = alone && self.work.explained.iter().enumerate().any(|(r, &e)| e && self.change_under_way(r));
        if alone {
            filter.snapshot_into(&mut self.work.jumped);
        }
        if alone && !continued {
            // The belief shown: the mixture's covariance, with the fault hypothesis's
            // mean (the row moves nothing until its review) or, where such jumps are
            // shown at once, the jump's.
            let show = self.settings.show_single_row_jumps;
            let shown = filter.mix_with(&self.work.hypothesis, 0.5).and_then(|()| {
                filter.snapshot_into(&mut self.work.alternative);
                let mean = if show { &self.work.jumped.mean } else { &self.work.hypothesis.mean };
                self.work.alternative.mean.copy_from_slice(mean);
                filter.restore(&self.work.alternative)
            });
            if shown.is_err() {
                filter.restore(&self.work.before)?;
                self.restore_gated();
                return Ok(false);
            }
        }
        self.pending.ambiguous = alone;
        self.pending.continued = continued;
        for r in 0..self.pending.rows.len() {
            if self.work.unexplained[r] {
                self.pending.rows[r] = RowOutcome::Rejected;
            }
            self.pending.explained[r] = self.work.explained[r];
        }
        self.pending.jump = factor;
        Ok(true)
    }

    /// Marks in `work.jump_open` the jump states a jump opens: every one, or,
    /// with [`SupervisorSettings::local_jumps`](crate::SupervisorSettings::local_jumps),
    /// those a failing row (not refuted) sees, its observation moving with
    /// them at the belief before the gate. False if none.
    fn open_jump_states(
        &mut self,
        filter: &mut dyn StateEstimator,
        failing: &impl Fn(usize, f64) -> bool,
    ) -> Result<bool, FilterError> {
        let (n, m) = (filter.state_dim(), self.work.z_gated.len());
        let work = &mut self.work;
        if work.jump_open.len() != n {
            work.jump_open = vec![false; n];
        }
        if !self.settings.local_jumps {
            for (i, open) in work.jump_open.iter_mut().enumerate() {
                *open = self.jump_states.get(i).copied().unwrap_or(true);
            }
            return Ok(true);
        }
        if work.jump_offsets.nrows() != n {
            work.jump_offsets = DMatrix::zeros(n, n);
            work.jump_effects = DMatrix::zeros(m, n);
        }
        work.jump_offsets.fill(0.0);
        for i in 0..n {
            if self.jump_states.get(i).copied().unwrap_or(true) {
                work.jump_offsets[(i, i)] = PROBE * state_scale(filter, i);
            }
        }
        filter.observation_differences(&work.jump_offsets, &mut work.jump_effects)?;
        work.jump_open.fill(false);
        for &r in &work.rows {
            if !failing(r, work.ratios[r]) || self.channels[r].refuted {
                continue;
            }
            let row = work.jump_effects.row(r);
            let largest = row.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
            for (open, effect) in work.jump_open.iter_mut().zip(row.iter()) {
                *open |= largest > 0.0 && effect.abs() > SEEN * largest;
            }
        }
        Ok(work.jump_open.contains(&true))
    }

    /// A jump of row `r` was confirmed within the last
    /// [`SupervisorSettings::change_memory`](crate::SupervisorSettings::change_memory)
    /// samples, this one's review included.
    fn change_under_way(&self, r: usize) -> bool {
        let confirmed_now = self.pending.reviewed && self.review.explained[r] && !self.pending.retracted[r];
        confirmed_now || self.channels[r].since_change < self.settings.change_memory
    }

    /// Moves each explained row that the other rows contradict (see
    /// [`Supervisor::try_jump`]) to the unexplained ones; returns the factor
    /// the remaining explained rows need. `z_hypothesis` is scratch here.
    fn contradicted(&mut self, filter: &mut dyn StateEstimator, factor: f64) -> Result<f64, FilterError> {
        let m = self.work.z_gated.len();
        let mut needed = 0.0_f64;
        for r in 0..m {
            if !self.work.explained[r] {
                continue;
            }
            for j in 0..m {
                self.work.z_hypothesis[j] =
                    if j == r || self.work.unexplained[j] { f64::NAN } else { self.work.z_gated[j] };
            }
            filter.restore(&self.work.before)?;
            let rest = filter
                .add_process_noise(factor, &self.work.jump_open)
                .and_then(|()| filter.update(&self.work.z_hypothesis).map(|_| ()));
            self.work.z_hypothesis.fill(f64::NAN);
            self.work.z_hypothesis[r] = self.work.z_gated[r];
            let alone = rest.and_then(|()| {
                filter.update(&self.work.z_hypothesis).map(|i| i.residual()[r].powi(2) / i.covariance()[(r, r)])
            });
            match alone {
                Ok(ratio) if ratio <= self.thresholds.row => needed = needed.max(self.need(r)),
                _ => {
                    self.work.explained[r] = false;
                    self.work.unexplained[r] = true;
                }
            }
        }
        Ok(needed)
    }

    /// The factor `c` that brings row `r`'s innovation to one σ (`work.gains` from the probe).
    fn need(&self, r: usize) -> f64 {
        (innovation_squared(&self.work, r) - self.work.variances[r]) / self.work.gains[r]
    }

    /// Puts back the rows the jump left out, when it is not taken.
    fn restore_gated(&mut self) {
        for r in 0..self.work.z_gated.len() {
            if self.work.unexplained[r] {
                self.work.z_gated[r] = self.z_offered[r];
            }
        }
        self.work.explained.fill(false);
        self.work.unexplained.fill(false);
    }

    /// Reviews the jump of the last sample against the measurement offered:
    /// predicts both hypotheses to this sample (the filter's own prediction,
    /// of their mixture, is set aside) and keeps, as the new `before`, the
    /// one whose innovation is the likelier. Leaves the filter at `before`.
    pub(super) fn review(&mut self, filter: &mut dyn StateEstimator) -> Result<(), FilterError> {
        if !self.review.active {
            return Ok(());
        }
        self.pending.reviewed = true;
        let (time, work, review) = (self.work.before.time, &mut self.work, &self.review);
        let mut likelihood = |belief: &Snapshot, predicted: &mut Snapshot| {
            let dt = time - belief.time;
            filter
                .restore(belief)
                .and_then(|()| if dt > 0.0 { filter.predict(&belief.input, dt) } else { Ok(()) })
                .and_then(|()| filter.hold_input(&work.before.input))
                .map(|()| filter.snapshot_into(predicted))
                .and_then(|()| filter.update(&work.z_gated).map(|i| (i.log_likelihood(), i.rows_used())))
        };
        let jumped = likelihood(&review.jumped, &mut work.alternative);
        let faulted = likelihood(&review.hypothesis, &mut work.hypothesis);
        let faulty = match (jumped, faulted) {
            (Ok((jumped, rows)), Ok((faulted, same_rows))) => rows > 0 && rows == same_rows && faulted > jumped,
            (Err(_), Ok(_)) => true,
            (Ok(_), Err(_)) => false,
            // Neither can be predicted: the mixture's prediction stands.
            (Err(_), Err(_)) => return filter.restore(&self.work.before),
        };
        let winner = if faulty { &mut self.work.hypothesis } else { &mut self.work.alternative };
        std::mem::swap(&mut self.work.before, winner);
        if faulty {
            self.pending.retracted.copy_from_slice(&self.review.explained);
        } else if let Some(trigger) = self.review.explained.iter().position(|&e| e) {
            // Confirmed: the fault hypothesis, predicted here, stays as the rival.
            self.fork_fault_hypothesis(filter, trigger, false)?;
        }
        filter.restore(&self.work.before)
    }
}

/// Row `r` of an update fails the row test (a NaN ratio fails too).
fn fails(innovation: &crate::filter::Innovation, r: usize, threshold: f64) -> bool {
    let ratio = innovation.residual()[r].powi(2) / innovation.covariance()[(r, r)];
    ratio > threshold || ratio.is_nan()
}

/// `νᵣ²` of the pass the ratios were taken from.
fn innovation_squared(work: &super::gate::Workspace, r: usize) -> f64 {
    work.ratios[r] * work.variances[r]
}
