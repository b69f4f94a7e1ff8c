//! The gate: each update is made, its rows tested, and the update redone
//! without the rows that fail, from the belief before it.
//!
//! * **Row test.** Each row `i` is tested on its normalised innovation
//!   `νᵢ²/Sᵢᵢ` against the χ²(1) quantile of
//!   [`SupervisorSettings::gate_probability`](crate::SupervisorSettings::gate_probability).
//! * **Vector test.** The rows kept are tested together on their NIS against
//!   the χ²(rows) quantile; when only that test fails, the row with the
//!   largest normalised innovation goes.
//! * **Implausible rows.** A row more than
//!   [`SupervisorSettings::implausible_sigmas`](crate::SupervisorSettings::implausible_sigmas)
//!   σ away (a saturated ADC, a cable fault) is left out first and never
//!   used, not even to re-acquire: no state the model can reach explains it.
//! * **Stuck rows.** A live sensor has noise: a value repeated bit for bit
//!   [`SupervisorSettings::stuck_after`](crate::SupervisorSettings::stuck_after)
//!   times in a row is left out before any update, until it changes.
//!
//! A row left out is exactly a missing one. Until the gate has left out a row
//! of its own (implausible ones aside), a failure may instead call for a
//! re-acquisition (see `reacquisition.rs`) or be explained by a jump of the
//! unknown inputs (see `jump.rs`); a jump under review from the last sample is
//! decided before any pass.

use super::consistency::WindowEntry;
use super::jump::empty_snapshot;
use super::outcome::{Outcome, Revision, RowOutcome};
use super::settings::SupervisorSettings;
use super::Supervisor;
use crate::error::FilterError;
use crate::filter::{Snapshot, StateEstimator};
use nalgebra::DMatrix;

/// The gate's thresholds on normalised innovations, from the settings.
#[derive(Debug, Clone)]
pub(super) struct Thresholds {
    /// The χ²(1) quantile: a row above it fails.
    pub row: f64,
    /// `implausible_sigmas²`: a row above it is never used.
    implausible: f64,
    /// χ²(k) quantiles, `k = 1 … m` at index `k` (infinite at 0).
    vector: Vec<f64>,
    /// The clip of a row's normalised innovation in the adaptation's
    /// evidence: the χ²(1) quantile of `1 − 1e-6`, gate or no gate.
    pub adaptation_clip: f64,
}

impl Thresholds {
    /// The thresholds for `m` rows; all infinite when the gate is off.
    pub fn new(settings: &SupervisorSettings, m: usize) -> Self {
        let gate_on = settings.gate_probability < 1.0;
        let quantile = |dof: usize| {
            if gate_on {
                chi_square::quantile(dof as f64, settings.gate_probability)
            } else {
                f64::INFINITY
            }
        };
        Self {
            row: quantile(1),
            implausible: settings.implausible_sigmas * settings.implausible_sigmas,
            vector: (0..=m).map(|k| if k == 0 { f64::INFINITY } else { quantile(k) }).collect(),
            adaptation_clip: chi_square::quantile(1.0, 1.0 - 1e-6),
        }
    }
}

/// The gate's buffers, sized once: a gate allocates nothing.
#[derive(Debug, Clone)]
pub(super) struct Workspace {
    /// The belief before the gate, restored before each new pass.
    pub before: Snapshot,
    /// `z` with the rows left out so far set to NaN.
    pub z_gated: Vec<f64>,
    /// The rows the last pass used.
    pub rows: Vec<usize>,
    /// Their normalised innovations `νᵢ²/Sᵢᵢ`, by row of `z`.
    pub ratios: Vec<f64>,
    /// Their innovation variances `Sᵢᵢ`, by row of `z`.
    pub variances: Vec<f64>,
    /// `Gᵢ = (H·Q·Hᵀ)ᵢᵢ` from a jump's probe, by row.
    pub gains: Vec<f64>,
    /// The first pass's residual per row (NaN where not available).
    pub residuals: Vec<f64>,
    /// The first pass's normalised innovations, by row (NaN where not available).
    first_ratios: Vec<f64>,
    /// The first pass's innovation variances `Sᵢᵢ`, by row (NaN where not
    /// available); with `residuals`, what the wiring checks learn from.
    pub first_variances: Vec<f64>,
    /// Each channel's wiring score at the last commit (`wiring.rs`, with its
    /// signature's where those are followed).
    pub wiring_scores: Vec<f64>,
    /// `z` with only the inconsistent channels' rows, for their prediction (`wiring.rs`).
    pub z_probe: Vec<f64>,
    /// The first pass's shares `(Sᵢᵢ − rᵢ)/Sᵢᵢ`, by row.
    shares: Vec<f64>,
    /// Rows whose failure a jump explains, and failing rows it does not (`jump.rs`).
    pub explained: Vec<bool>,
    pub unexplained: Vec<bool>,
    /// `z` of the fault hypothesis.
    pub z_hypothesis: Vec<f64>,
    /// The jump states a jump opens (`jump.rs`).
    pub jump_open: Vec<bool>,
    /// Scratch of their selection: a probe offset per state (`n × n`) and
    /// what it does to each row (`m × n`). Sized at the first jump.
    pub jump_offsets: DMatrix<f64>,
    pub jump_effects: DMatrix<f64>,
    /// The belief of the fault hypothesis of a jump taken at this sample.
    pub hypothesis: Snapshot,
    /// The belief of the jump hypothesis of a jump taken at this sample.
    pub jumped: Snapshot,
    /// The other belief of a review; scratch for a rival's prediction.
    pub alternative: Snapshot,
    /// The rival's belief after this sample's update (`rival.rs`), or the
    /// rival a re-acquisition forks.
    pub rival_next: Snapshot,
    /// What became of each row in the rival's update.
    pub rival_rows: Vec<RowOutcome>,
    /// The rival's NIS and rows used in that update.
    pub rival_update: (f64, usize),
    /// The rival's consistency-window entry for this sample.
    pub rival_entry: WindowEntry,
    /// The robust log-likelihoods of this sample's first pass: the rival's and the filter's own.
    pub rival_score: f64,
    pub main_score: f64,
    /// The row neither score counts at this sample (`rival.rs`).
    pub unscored: Option<usize>,
    /// The mean the update ends with (what a healthy sample teaches `restart.rs`).
    pub posterior: Vec<f64>,
    /// Its variance per state.
    pub posterior_variance: Vec<f64>,
}

impl Workspace {
    /// Buffers for `m` rows.
    pub fn new(m: usize) -> Self {
        Self {
            before: empty_snapshot(),
            z_gated: vec![f64::NAN; m],
            wiring_scores: vec![0.0; m],
            rows: Vec::with_capacity(m),
            ratios: vec![f64::NAN; m],
            variances: vec![f64::NAN; m],
            gains: vec![f64::NAN; m],
            residuals: vec![f64::NAN; m],
            first_ratios: vec![f64::NAN; m],
            first_variances: vec![f64::NAN; m],
            z_probe: vec![f64::NAN; m],
            shares: vec![0.0; m],
            explained: vec![false; m],
            unexplained: vec![false; m],
            z_hypothesis: vec![f64::NAN; m],
            jump_open: Vec::new(),
            jump_offsets: DMatrix::zeros(0, 0),
            jump_effects: DMatrix::zeros(0, 0),
            hypothesis: empty_snapshot(),
            jumped: empty_snapshot(),
            alternative: empty_snapshot(),
            rival_next: empty_snapshot(),
            rival_rows: vec![RowOutcome::Missing; m],
            rival_update: (0.0, 0),
            rival_entry: WindowEntry::default(),
            rival_score: 0.0,
            main_score: 0.0,
            unscored: None,
            posterior: Vec::new(),
            posterior_variance: Vec::new(),
        }
    }

    /// The rows of the last pass with their normalised innovations.
    pub fn tested(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.rows.iter().map(|&r| (r, self.ratios[r]))
    }

    /// Leaves the tested rows `which` selects out of the next pass, as rejected.
    fn leave_out(&mut self, rows: &mut [RowOutcome], which: impl Fn(usize, f64) -> bool) {
        for &r in &self.rows {
            if which(r, self.ratios[r]) {
                self.z_gated[r] = f64::NAN;
                rows[r] = RowOutcome::Rejected;
            }
        }
    }
}

/// One pass of the gate, tested: the update made with the rows not left out yet.
#[derive(Debug, Clone, Copy)]
pub(super) struct Pass {
    /// The rows used.
    pub dof: usize,
    /// The row with the largest normalised innovation, and that innovation.
    pub worst_row: usize,
    pub worst: f64,
    /// How many rows fail the row test.
    failing: usize,
    /// The NIS fails the vector test.
    vector_fails: bool,
    row_threshold: f64,
    implausible: f64,
}

impl Pass {
    /// Every row passes, and the vector too.
    fn passes(&self) -> bool {
        self.failing == 0 && !self.vector_fails
    }

    /// A row of normalised innovation `ratio` no state the model reaches explains.
    fn implausible(&self, ratio: f64) -> bool {
        ratio > self.implausible || ratio.is_nan()
    }

    /// The row fails the gate: on its own, or as the worst row when only the vector fails.
    pub fn fails(&self, row: usize, ratio: f64) -> bool {
        ratio > self.row_threshold || (self.failing == 0 && row == self.worst_row)
    }

    /// Every row fails the gate.
    pub fn all_fail(&self) -> bool {
        self.failing == self.dof || (self.dof == 1 && self.vector_fails)
    }

    /// The row threshold the pass was tested against.
    pub fn row_threshold(&self) -> f64 {
        self.row_threshold
    }
}

impl Supervisor {
    /// Updates `filter` with `z` through the gate and keeps the outcome
    /// pending (see [`Supervisor::commit`]). On `Err` the filter's belief is
    /// as before the call.
    pub fn gate(&mut self, filter: &mut dyn StateEstimator, z: &[f64]) -> Result<&Outcome, FilterError> {
        crate::error::check_len("measurement z", self.channels.len(), z.len())?;
        if !self.jump_states.is_empty() {
            crate::error::check_len("jump states", filter.state_dim(), self.jump_states.len())?;
        }
        self.offer(z);
        filter.snapshot_into(&mut self.work.before);
        self.reserve_beliefs();
        self.prepare_signatures(filter);
        self.review(filter)?;
        if self.restart_due(filter) {
            self.restart(filter)?;
        }
        self.probe_inconsistent(filter)?;
        self.work.unscored = self.rival.disputed();
        let rival = !self.pending.restarted && self.rival.active && self.settings.revise && self.step_rival(filter)?;
        if self.rival.active && !rival {
            // A rival that cannot be predicted or updated is dropped.
            self.pending.revision = Revision::Confirmed;
        }
        if !self.pending.restarted {
            self.fork_challenger(filter)?;
        }
        if let Some(channel) = self.pending.released {
            self.fork_fault_hypothesis(filter, channel, true)?;
        }
        let mut first_pass = true;
        // No row has been left out by the gate's own tests yet: a re-acquisition
        // may still be decided, or a jump taken.
        let mut may_reacquire = true;
        let mut may_jump = true;
        while let Some(pass) = self.update_and_test(filter, first_pass)? {
            first_pass = false;
            if pass.passes() {
                break;
            }
            if self.work.tested().any(|(_, ratio)| pass.implausible(ratio)) {
                self.work.leave_out(&mut self.pending.rows, |_, ratio| pass.implausible(ratio));
                filter.restore(&self.work.before)?;
                continue;
            }
            if may_reacquire {
                let decision = self.reacquisition.decide(&pass, self.work.tested(), &self.channels, &self.settings);
                if let Some((trigger, factor)) = decision {
                    self.fork_rival(filter, |r, ratio| pass.fails(r, ratio))?;
                    self.reacquire(filter, trigger, factor)?;
                    break;
                }
            }
            let jumps = self.settings.jumps;
            if std::mem::take(&mut may_jump) && jumps && self.try_jump(filter, |r, ratio| pass.fails(r, ratio))? {
                break;
            }
            self.work.leave_out(&mut self.pending.rows, |r, ratio| pass.fails(r, ratio));
            filter.restore(&self.work.before)?;
            may_reacquire = false;
        }
        if let Some(steps) = &self.steps {
            steps.take(&self.channels, &self.work.residuals, &mut self.pending, &mut self.work.before, filter)?;
        }
        // A rival forked at this sample (a re-acquisition's or a challenger) has
        // replaced a confirmed jump's fault hypothesis, which is not weighed.
        if rival && !self.pending.forked {
            self.weigh_rival(filter)?;
        }
        self.work.posterior.clear();
        self.work.posterior.extend_from_slice(filter.mean().as_slice());
        self.work.posterior_variance.clear();
        self.work.posterior_variance.extend((0..filter.state_dim()).map(|i| filter.variance(i)));
        self.gather_adaptation_evidence();
        Ok(&self.pending)
    }

    /// Gives the belief buffers their size at the first gate, so that no
    /// later one allocates (a jump, a review copy beliefs).
    fn reserve_beliefs(&mut self) {
        let n = self.work.before.mean.len();
        self.climate.reserve(n);
        self.work.posterior.reserve(n.saturating_sub(self.work.posterior.len()));
        self.work.posterior_variance.reserve(n.saturating_sub(self.work.posterior_variance.len()));
        let before = &self.work.before;
        let beliefs = [
            &mut self.work.hypothesis,
            &mut self.work.jumped,
            &mut self.work.alternative,
            &mut self.review.hypothesis,
            &mut self.review.jumped,
            &mut self.work.rival_next,
            &mut self.rival.belief,
        ];
        for belief in beliefs {
            for (buffer, len) in [
                (&mut belief.input, before.input.len()),
                (&mut belief.mean, before.mean.len()),
                (&mut belief.covariance, before.covariance.len()),
            ] {
                buffer.reserve(len.saturating_sub(buffer.len()));
            }
        }
    }

    /// The adaptation's evidence: the first pass's clipped normalised
    /// innovations and shares of the rows finally used (`adaptation.rs`).
    fn gather_adaptation_evidence(&mut self) {
        if self.pending.replaced() {
            // The update is the rival's: the filter's own first pass says nothing of it.
            (self.pending.adaptation_ratios, self.pending.adaptation_share, self.pending.adaptation_rows) =
                (0.0, 0.0, 0);
            return;
        }
        let clip = self.thresholds.adaptation_clip;
        let (mut ratios, mut share, mut rows) = (0.0, 0.0, 0);
        for (r, outcome) in self.pending.rows.iter().enumerate() {
            let ratio = self.work.first_ratios[r];
            if *outcome == RowOutcome::Used && ratio.is_finite() {
                ratios += ratio.min(clip);
                share += self.work.shares[r];
                rows += 1;
            }
        }
        (self.pending.adaptation_ratios, self.pending.adaptation_share, self.pending.adaptation_rows) =
            (ratios, share, rows);
    }

    /// Takes `z` as the pending measurement: the missing rows, the stuck ones
    /// left out, the rest to be used; the rest of the outcome cleared.
    fn offer(&mut self, z: &[f64]) {
        self.z_offered.copy_from_slice(z);
        self.work.z_gated.copy_from_slice(z);
        self.work.z_probe.fill(f64::NAN);
        let stuck_after = self.settings.stuck_after;
        let (probation, window) = (self.settings.reacquire_after, self.settings.window);
        // A refuted channel whose probation has passed is used again, with
        // the belief without it as its rival (`rival.rs`), one at a time.
        self.pending.released = None;
        if !self.rival.active {
            self.pending.released = self.channels.iter().position(|c| c.refuted && !c.on_probation(probation, window));
        }
        for (c, (row, &v)) in self.pending.rows.iter_mut().zip(z).enumerate() {
            *row = if !v.is_finite() {
                RowOutcome::Missing
            } else if self.channels[c].is_stuck_at(v, stuck_after) {
                self.work.z_gated[c] = f64::NAN;
                RowOutcome::Stuck
            } else if (self.channels[c].refuted && self.pending.released != Some(c))
                || (self.channels[c].inconsistent && self.settings.wiring_leaves_out)
            {
                // On probation (`channel.rs`) or with its wiring inconsistent
                // (`wiring.rs`): the other rows contradicted it; scored against
                // the belief without it, not used.
                self.work.z_gated[c] = f64::NAN;
                self.work.z_probe[c] = v;
                RowOutcome::Inconsistent
            } else {
                RowOutcome::Used
            };
        }
        let pending = &mut self.pending;
        pending.reacquired = None;
        pending.inflation = 1.0;
        pending.worst_ratio = 0.0;
        pending.clipped_ratios = 0.0;
        pending.gated_rows = 0;
        pending.steps.fill(0.0);
        pending.jump = 0.0;
        pending.explained.fill(false);
        pending.ambiguous = false;
        pending.continued = false;
        pending.reviewed = false;
        pending.retracted.fill(false);
        pending.forked = false;
        pending.challenged = false;
        pending.jump_forked = None;
        pending.revision = Revision::None;
        pending.restarted = false;
        self.work.main_score = 0.0;
        self.work.residuals.fill(f64::NAN);
        self.work.first_ratios.fill(f64::NAN);
        self.work.first_variances.fill(f64::NAN);
    }

    /// The prediction of the inconsistent channels' rows from the belief
    /// before the update (an update with those rows alone, undone), into the
    /// first pass's residuals and variances: they are left out of the
    /// updates, but the wiring checks go on scoring them (`wiring.rs`).
    fn probe_inconsistent(&mut self, filter: &mut dyn StateEstimator) -> Result<(), FilterError> {
        if self.work.z_probe.iter().all(|v| v.is_nan()) {
            return Ok(());
        }
        if filter.update(&self.work.z_probe).is_ok() {
            let innovation = filter.innovation();
            for &r in innovation.rows() {
                self.work.residuals[r] = innovation.residual()[r];
                self.work.first_variances[r] = innovation.covariance()[(r, r)];
            }
        }
        filter.restore(&self.work.before)
    }

    /// Updates `filter` with the rows not left out and tests the rows used;
    /// `None` when there are none. The first pass (all available rows) also
    /// gives the outcome's ratios and the residuals the step watch reads.
    fn update_and_test(
        &mut self,
        filter: &mut dyn StateEstimator,
        first_pass: bool,
    ) -> Result<Option<Pass>, FilterError> {
        filter.update(&self.work.z_gated)?;
        let innovation = filter.innovation();
        let (dof, nis) = (innovation.rows_used(), innovation.nis());
        self.pending.dof = dof;
        self.pending.nis = nis;
        if dof == 0 {
            return Ok(None);
        }
        let work = &mut self.work;
        work.rows.clear();
        work.rows.extend_from_slice(innovation.rows());
        for &r in &work.rows {
            let variance = innovation.covariance()[(r, r)];
            work.variances[r] = variance;
            work.ratios[r] = innovation.residual()[r].powi(2) / variance;
        }
        let (worst_row, worst) =
            work.tested().fold((work.rows[0], f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
        let row_threshold = self.thresholds.row;
        if first_pass {
            self.pending.worst_ratio = worst;
            let clip = row_threshold.min(1e6);
            let mut clipped = 0.0;
            let disputed = work.unscored;
            work.main_score =
                super::rival::score(innovation, self.thresholds.adaptation_clip, clip, disputed, &mut clipped);
            self.pending.clipped_ratios = clipped;
            self.pending.gated_rows = dof;
            let r_given = filter.noise().r();
            for &r in &work.rows {
                work.residuals[r] = innovation.residual()[r];
                work.first_ratios[r] = work.ratios[r];
                work.first_variances[r] = work.variances[r];
                work.shares[r] = (1.0 - r_given[(r, r)] / work.variances[r]).clamp(0.0, 1.0);
            }
            self.signature_work.keep_first_pass(innovation);
        }
        Ok(Some(Pass {
            dof,
            worst_row,
            worst,
            failing: work.tested().filter(|&(_, ratio)| ratio > row_threshold).count(),
            vector_fails: nis > self.thresholds.vector[dof],
            row_threshold,
            implausible: self.thresholds.implausible,
        }))
    }

    /// Re-acquires: the covariance inflated by `factor` from the belief before
    /// the gate, and the update made with every row not left out so far.
    fn reacquire(&mut self, filter: &mut dyn StateEstimator, trigger: usize, factor: f64) -> Result<(), FilterError> {
        filter.restore(&self.work.before)?;
        let reacquired = filter
            .scale_covariance(factor)
            .and_then(|()| filter.update(&self.work.z_gated).map(|i| (i.nis(), i.rows_used())));
        match reacquired {
            Ok((nis, dof)) => (self.pending.nis, self.pending.dof) = (nis, dof),
            Err(e) => {
                // The inflated covariance must not outlive a failed update.
                filter.restore(&self.work.before)?;
                return Err(e);
            }
        }
        self.pending.reacquired = Some(trigger);
        self.pending.inflation = factor;
        Ok(())
    }
}
