//! Gross measurement errors and an honest health report, around any filter:
//! innovation gating, per-channel fault flags, re-acquisition and a windowed
//! consistency test. Real sensors saturate, drop out, stick and drift; one
//! such sample must not become a silent wrong number.
//!
//! * **Gate.** Each row `i` of an update is tested on its normalised
//!   innovation `νᵢ²/Sᵢᵢ` against the χ²(1) quantile of
//!   [`SupervisorSettings::gate_probability`], and the rows kept together on
//!   their NIS against the χ²(rows) quantile. A failing row is left out of
//!   that update exactly like a missing one (the update is redone without it
//!   from the belief before it); when only the vector test fails, the row
//!   with the largest normalised innovation goes.
//! * **Implausible rows.** A row more than
//!   [`SupervisorSettings::implausible_sigmas`] σ of its innovation away (a
//!   saturated ADC, a cable fault) is left out and never used, not even to
//!   re-acquire: no state the model can reach explains it.
//! * **Stuck channels.** A live sensor has noise: a channel that repeats
//!   its value bit for bit [`SupervisorSettings::stuck_after`] times in a row
//!   is stuck, and left out (as rejected) until its value changes.
//! * **Faults.** A channel whose last [`SupervisorSettings::fault_after`]
//!   samples were all rejected, stuck or missing is faulty, until one passes again.
//! * **Re-acquisition.** A channel that fails the gate
//!   [`SupervisorSettings::reacquire_after`] samples in a row says either
//!   that it is broken or that the filter lost the state (a true jump, a bad
//!   prior, a state pulled away during a fault); a gate alone would lock the
//!   filter out of a real change for ever. So the filter re-acquires: the
//!   covariance is inflated by four times the largest normalised innovation
//!   over the gate (at most 1e4), which brings that innovation inside the
//!   gate, and the update is made with every row that is not stuck; no second
//!   re-acquisition follows within `reacquire_after` samples. That is
//!   a hypothesis, and the next samples test it: if the channel fails the
//!   gate again within the consistency window, the channel is broken (a
//!   drifting sensor) and triggers no re-acquisition until it passes the gate
//!   again; if it passes, the state had moved (a true jump) and is followed.
//!   (Retrying a suspended channel once per window was tried: during a drift
//!   each retry pulls the state towards the drifting sensor, and the S1 load
//!   is lost; see the note of issue 17.)
//!   When every available channel has failed for `reacquire_after` samples
//!   the filter re-acquires whatever the channels' past: it is lost.
//! * **Inflation budget.** Re-acquisitions multiply the covariance by at most
//!   [`SupervisorSettings::max_inflation`] in total until a sample passes the
//!   gate with none of its rows rejected. When no inflation makes the filter
//!   agree with its sensors for good (their noise far above what `R` says:
//!   each update collapses `P` onto the told `R` and the next innovations
//!   fail again), repeated re-acquisitions would multiply the unobserved
//!   directions of `P` by 1e4 each time, until `P` loses its definiteness or
//!   overflows (S5, `R` told 1000× too small: every filter kind failed within
//!   0.1–2.7 s). With the budget spent the filter stays lost, predicting
//!   only, its `P` finite and its health false ([`Supervisor::exhausted`]),
//!   until its sensors pass the gate again (the user corrects `R`).
//! * **Quantised bias steps** (optional, [`Supervisor::with_steps`]). Some
//!   channels fail in steps of a known size that stay: a long-stator position
//!   channel that miscounts one slot reads 86 mm off from then on. When a
//!   channel whose bias is a state of the model is rejected
//!   [`QuantizedSteps::after`] samples in a row (its missing and stuck samples
//!   skipped) with its innovation each time within [`QuantizedSteps::tolerance`]
//!   of the same non-zero multiple of [`QuantizedSteps::quantum`], the bias
//!   state's mean is moved by that multiple (its covariance kept: the quantum
//!   is exact) and the step reported ([`Outcome::steps`]). A spike fails one
//!   sample and the next passes; re-acquisition instead would inflate every
//!   state, the unobservable ones too (S4: a slip shared out over the other
//!   channels, the position's σ from 0.025 to 4,100 m).
//! * **Consistency.** Each available row's normalised innovation `νᵢ²/Sᵢᵢ`
//!   (before the gate, clipped at the gate's threshold so that one glitch
//!   cannot flag a window), summed over the last
//!   [`SupervisorSettings::window`] samples, has the number of those rows as
//!   mean for a consistent filter, and is close to χ² with that many degrees
//!   of freedom. Above [`SupervisorSettings::consistency_margin`] times its
//!   `1 − consistency_probability` quantile the filter's σ no longer covers
//!   the errors its innovations reveal: it is inconsistent (diverging). The
//!   margin allows the model mismatch a real tuning leaves (S1, random load:
//!   mean NIS per row 1.25, one-second windows up to 2.1). Rejected rows
//!   count: a channel that fails the gate for a whole window makes the filter
//!   inconsistent too, since from the data alone it cannot tell whether the
//!   sensor or the estimate is wrong (a drifting load sensor pulls the load
//!   estimate with it); the channel flags say which channel disagrees.
//!
//! The gate and the bookkeeping are apart: [`Supervisor::gate`] makes the
//! update on a filter and keeps the outcome pending, [`Supervisor::commit`]
//! counts it. A driver that computes an update only to show it (an FMU's read
//! between steps) gates on a copy of the filter and never commits.

use crate::chi_square;
use crate::error::FilterError;
use crate::filter::{Snapshot, StateEstimator};

/// The supervisor's settings; `Default` is what the studies use.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupervisorSettings {
    /// Probability of the gate quantiles: a row of a consistent filter is
    /// rejected with probability `1 − gate_probability`. Default `1 − 1e-6`
    /// (a row beyond about 4.9σ). `1` turns the gate off.
    pub gate_probability: f64,
    /// Consecutive rejected or missing samples that make a channel faulty. Default 3.
    pub fault_after: u32,
    /// Consecutive gate failures of a channel before the filter re-acquires. Default 10.
    pub reacquire_after: u32,
    /// Consecutive bit-identical values that make a channel stuck. Default 5.
    pub stuck_after: u32,
    /// A row this many σ of its innovation away is never used, not even to
    /// re-acquire: no state the model can reach explains it (a 100 N step of
    /// the S1 load is about 250σ). Default 1e5.
    pub implausible_sigmas: f64,
    /// Samples in the consistency window. Default 200.
    pub window: usize,
    /// The consistency test's false-alarm probability per sample for a
    /// consistent filter. Default 1e-6.
    pub consistency_probability: f64,
    /// How far above its χ² bound the windowed NIS may go before the filter
    /// is inconsistent. Default 3 (the σ understate the errors by more than √3).
    pub consistency_margin: f64,
    /// The most the re-acquisitions may multiply the covariance by in total
    /// between two samples that pass the gate whole. Default 1e8: two full
    /// re-acquisitions (S1's load step and S5's change of every coefficient
    /// each take one).
    pub max_inflation: f64,
}

impl Default for SupervisorSettings {
    fn default() -> Self {
        Self {
            gate_probability: 1.0 - 1e-6,
            fault_after: 3,
            reacquire_after: 10,
            stuck_after: 5,
            implausible_sigmas: 1e5,
            window: 200,
            consistency_probability: 1e-6,
            consistency_margin: 3.0,
            max_inflation: 1e8,
        }
    }
}

impl SupervisorSettings {
    /// Checks the ranges, saying what is wrong.
    pub fn validate(&self) -> Result<(), FilterError> {
        let bad = |why: String| Err(FilterError::InvalidSetting(why));
        if !(self.gate_probability > 0.0 && self.gate_probability <= 1.0) {
            return bad(format!("gate probability must be in (0, 1], got {}", self.gate_probability));
        }
        if self.fault_after == 0 || self.reacquire_after == 0 || self.window == 0 || self.stuck_after < 2 {
            return bad("fault_after, reacquire_after and window must be at least 1, stuck_after at least 2".into());
        }
        if !(self.consistency_probability > 0.0 && self.consistency_probability < 1.0) {
            return bad(format!("consistency probability must be in (0, 1), got {}", self.consistency_probability));
        }
        if self.implausible_sigmas <= 0.0 || self.implausible_sigmas.is_nan() {
            return bad(format!("implausible_sigmas must be positive, got {}", self.implausible_sigmas));
        }
        if !(self.consistency_margin >= 1.0 && self.consistency_margin.is_finite()) {
            return bad(format!("consistency margin must be at least 1, got {}", self.consistency_margin));
        }
        if !(self.max_inflation >= 1.0 && self.max_inflation.is_finite()) {
            return bad(format!("max_inflation must be finite and at least 1, got {}", self.max_inflation));
        }
        Ok(())
    }
}

/// The steps of a known size some channels' biases take (see the module documentation).
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

/// What became of one measurement row in an update.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowOutcome {
    /// Not finite in `z`: left out.
    Missing,
    /// Used.
    Used,
    /// Failed the gate: left out.
    Rejected,
    /// Repeated its value `stuck_after` times: left out.
    Stuck,
}

/// The outcome of one gated update.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Per row of `z`.
    pub rows: Vec<RowOutcome>,
    /// The covariance was inflated and every row used; the channel whose
    /// persistent failure triggered it.
    pub reacquired: Option<usize>,
    /// The factor the covariance was inflated by (1 without a re-acquisition).
    pub inflation: f64,
    /// NIS of the update made (0 without rows).
    pub nis: f64,
    /// Its degrees of freedom: the rows used.
    pub dof: usize,
    /// The largest normalised innovation `νᵢ²/Sᵢᵢ` of the first pass (all
    /// available rows), 0 without rows.
    pub worst_ratio: f64,
    /// The first pass's normalised innovations, each clipped at the gate, summed.
    pub clipped_ratios: f64,
    /// How many rows that sum has.
    pub gated_rows: usize,
    /// Per row: the bias step taken (0 for none; see [`QuantizedSteps`]).
    pub steps: Vec<f64>,
    /// Per row: the multiple its rejected innovations sit at and how many in a row,
    /// once committed.
    watch: Vec<(i64, u32)>,
}

/// The state of one measurement channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
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
    since_reacquisition: u32,
    /// It failed again right after its re-acquisition: broken, it triggers
    /// none until it passes the gate.
    pub suspended: bool,
    /// The last finite value and how many times in a row it came.
    last_value: u64,
    repeats: u32,
    /// The multiple of the quantum its rejected innovations sit at, and how many in a row.
    step_multiple: i64,
    step_run: u32,
}

/// A change of a channel's fault flag, for a driver to report once per episode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FaultChange {
    /// The channel (row of `z`).
    pub channel: usize,
    /// Faulty from now on (`true`) or again good (`false`).
    pub faulty: bool,
}

/// Gate, fault flags, re-acquisition and consistency for one filter.
#[derive(Debug, Clone)]
pub struct Supervisor {
    settings: SupervisorSettings,
    row_threshold: f64,
    implausible_ratio: f64,
    /// χ²(k) gate quantiles, `k = 1 … m` at index `k`.
    vector_threshold: Vec<f64>,
    channels: Vec<Channel>,
    all_rejected_run: u32,
    reacquisitions: u64,
    /// Samples since the last re-acquisition: none within `reacquire_after` of another.
    since_reacquisition: u32,
    /// The product of the re-acquisitions' factors since a sample last passed the gate whole.
    inflation: f64,
    /// Ring of `(nis, dof)` of the last `window` samples.
    ring: Vec<(f64, usize)>,
    ring_at: usize,
    ring_len: usize,
    /// Upper consistency bounds by total degrees of freedom, computed when first needed.
    upper_bound: Vec<f64>,
    consistent: bool,
    window_nis: f64,
    pending: Outcome,
    /// Quantised bias steps, when the model has them.
    steps: Option<QuantizedSteps>,
    /// The first pass's residual per row (NaN where not available).
    residuals: Vec<f64>,
    before: Snapshot,
    /// The measurement of the pending outcome, as offered.
    z_offered: Vec<f64>,
    z_gated: Vec<f64>,
}

impl Supervisor {
    /// A supervisor for a filter with `m` measurement rows.
    pub fn new(settings: SupervisorSettings, m: usize) -> Result<Self, FilterError> {
        settings.validate()?;
        let gate_on = settings.gate_probability < 1.0;
        let quantile = |dof: usize| {
            if gate_on {
                chi_square::quantile(dof as f64, settings.gate_probability)
            } else {
                f64::INFINITY
            }
        };
        Ok(Self {
            settings,
            row_threshold: quantile(1),
            implausible_ratio: settings.implausible_sigmas * settings.implausible_sigmas,
            vector_threshold: (0..=m).map(|k| if k == 0 { f64::INFINITY } else { quantile(k) }).collect(),
            channels: vec![Channel { since_reacquisition: u32::MAX, ..Channel::default() }; m],
            all_rejected_run: 0,
            reacquisitions: 0,
            since_reacquisition: u32::MAX,
            inflation: 1.0,
            ring: vec![(0.0, 0); settings.window],
            ring_at: 0,
            ring_len: 0,
            upper_bound: vec![f64::NAN; settings.window * m + 1],
            consistent: true,
            window_nis: f64::NAN,
            pending: Outcome {
                rows: vec![RowOutcome::Missing; m],
                reacquired: None,
                inflation: 1.0,
                nis: 0.0,
                dof: 0,
                worst_ratio: 0.0,
                clipped_ratios: 0.0,
                gated_rows: 0,
                steps: vec![0.0; m],
                watch: vec![(0, 0); m],
            },
            steps: None,
            residuals: vec![f64::NAN; m],
            before: Snapshot {
                kind: crate::FilterKind::Ckf,
                time: 0.0,
                input: Vec::new(),
                mean: Vec::new(),
                covariance: Vec::new(),
            },
            z_offered: vec![f64::NAN; m],
            z_gated: vec![f64::NAN; m],
        })
    }

    /// With quantised bias steps for the rows that have a bias state.
    pub fn with_steps(mut self, steps: QuantizedSteps) -> Result<Self, FilterError> {
        let bad = |why: String| Err(FilterError::InvalidSetting(why));
        if !(steps.quantum > 0.0 && steps.quantum.is_finite()) {
            return bad(format!("the step quantum must be positive, got {}", steps.quantum));
        }
        if !(steps.tolerance > 0.0 && steps.tolerance < steps.quantum / 2.0) {
            return bad(format!("the step tolerance must be in (0, quantum/2), got {}", steps.tolerance));
        }
        if steps.after < 2 {
            return bad("a step must be seen on at least 2 samples: a spike lasts one".into());
        }
        crate::error::check_len("bias states", self.channels.len(), steps.bias_states.len())?;
        self.steps = Some(steps);
        Ok(self)
    }

    /// The settings.
    pub fn settings(&self) -> &SupervisorSettings {
        &self.settings
    }

    /// Updates `filter` with `z` through the gate and keeps the outcome
    /// pending (see [`Supervisor::commit`]). On `Err` the filter's belief is
    /// as before the call.
    pub fn gate(&mut self, filter: &mut dyn StateEstimator, z: &[f64]) -> Result<&Outcome, FilterError> {
        let m = self.channels.len();
        crate::error::check_len("measurement z", m, z.len())?;
        self.z_offered.copy_from_slice(z);
        self.z_gated.copy_from_slice(z);
        let stuck_after = self.settings.stuck_after;
        for (c, (row, v)) in self.pending.rows.iter_mut().zip(z).enumerate() {
            let channel = &self.channels[c];
            *row = if !v.is_finite() {
                RowOutcome::Missing
            } else if v.to_bits() == channel.last_value && channel.repeats + 1 >= stuck_after {
                self.z_gated[c] = f64::NAN;
                RowOutcome::Stuck
            } else {
                RowOutcome::Used
            };
        }
        self.pending.reacquired = None;
        self.pending.inflation = 1.0;
        self.pending.worst_ratio = 0.0;
        self.pending.clipped_ratios = 0.0;
        self.pending.gated_rows = 0;
        self.pending.steps.fill(0.0);
        self.residuals.fill(f64::NAN);
        filter.snapshot_into(&mut self.before);
        // `first`: no row was left out by the gate yet (implausible ones aside),
        // so a re-acquisition may still be decided; the ratios are taken once.
        let (mut first, mut ratios_taken) = (true, false);
        loop {
            let innovation = filter.update(&self.z_gated)?;
            let (dof, nis) = (innovation.rows_used(), innovation.nis());
            self.pending.dof = dof;
            self.pending.nis = nis;
            if dof == 0 {
                break;
            }
            let ratio = |row: usize| innovation.residual()[row].powi(2) / innovation.covariance()[(row, row)];
            let rows = innovation.rows();
            let (worst_row, worst) =
                rows.iter()
                    .map(|&r| (r, ratio(r)))
                    .fold((rows[0], f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
            let failing = rows.iter().filter(|&&r| ratio(r) > self.row_threshold).count();
            let vector_fails = nis > self.vector_threshold[dof];
            if !ratios_taken {
                ratios_taken = true;
                self.pending.worst_ratio = worst;
                let clip = self.row_threshold.min(1e6);
                self.pending.clipped_ratios = rows.iter().map(|&r| ratio(r).min(clip)).sum();
                self.pending.gated_rows = dof;
                for &r in rows {
                    self.residuals[r] = innovation.residual()[r];
                }
            }
            if failing == 0 && !vector_fails {
                break;
            }
            // No state the model reaches explains these: never used, not even to re-acquire.
            let implausible_ratio = self.implausible_ratio;
            let implausible = |r: usize| ratio(r) > implausible_ratio || ratio(r).is_nan();
            if rows.iter().any(|&r| implausible(r)) {
                let (z_gated, outcome) = (&mut self.z_gated, &mut self.pending.rows);
                for &r in rows {
                    if implausible(r) {
                        z_gated[r] = f64::NAN;
                        outcome[r] = RowOutcome::Rejected;
                    }
                }
                filter.restore(&self.before)?;
                continue;
            }
            let threshold = self.row_threshold;
            let cooled = self.since_reacquisition >= self.settings.reacquire_after;
            let persistent = rows.iter().copied().filter(|_| cooled).find(|&r| {
                let fails = ratio(r) > threshold || (failing == 0 && r == worst_row);
                let channel = &self.channels[r];
                fails && !channel.suspended && channel.rejected_run + 1 >= self.settings.reacquire_after
            });
            // Every channel failing for a while: lost, whatever the channels' past.
            let all_fail = failing == dof || (dof == 1 && vector_fails);
            let lost =
                (cooled && all_fail && self.all_rejected_run + 1 >= self.settings.reacquire_after).then_some(worst_row);
            let persistent = persistent.or(lost);
            // Within the budget: what is left of it, if less than this re-acquisition asks.
            let factor = (4.0 * worst / threshold).clamp(1.0, 1e4).min(self.settings.max_inflation / self.inflation);
            if let (true, Some(trigger), true) = (first, persistent, factor > 1.0) {
                // A channel has disagreed with the filter again and again: re-acquire.
                filter.restore(&self.before)?;
                let reacquired = filter
                    .scale_covariance(factor)
                    .and_then(|()| filter.update(&self.z_gated).map(|i| (i.nis(), i.rows_used())));
                match reacquired {
                    Ok((nis, dof)) => (self.pending.nis, self.pending.dof) = (nis, dof),
                    Err(e) => {
                        // The inflated covariance must not outlive a failed update.
                        filter.restore(&self.before)?;
                        return Err(e);
                    }
                }
                self.pending.reacquired = Some(trigger);
                self.pending.inflation = factor;
                break;
            }
            // Leave the failing rows out (the worst one when only the vector fails) and redo.
            let (z_gated, outcome) = (&mut self.z_gated, &mut self.pending.rows);
            for &r in rows {
                if ratio(r) > threshold || (failing == 0 && r == worst_row) {
                    z_gated[r] = f64::NAN;
                    outcome[r] = RowOutcome::Rejected;
                }
            }
            filter.restore(&self.before)?;
            first = false;
        }
        self.take_steps(filter)?;
        Ok(&self.pending)
    }

    /// Watches the rejected rows for a quantised bias step and takes the steps seen
    /// often enough (see [`QuantizedSteps`]).
    fn take_steps(&mut self, filter: &mut dyn StateEstimator) -> Result<(), FilterError> {
        let Some(steps) = &self.steps else { return Ok(()) };
        let mut moved = false;
        for (c, channel) in self.channels.iter().enumerate() {
            let committed = (channel.step_multiple, channel.step_run);
            self.pending.watch[c] = match self.pending.rows[c] {
                RowOutcome::Used => (0, 0),
                RowOutcome::Missing | RowOutcome::Stuck => committed,
                RowOutcome::Rejected => {
                    let multiple = (self.residuals[c] / steps.quantum).round();
                    let near = (self.residuals[c] - multiple * steps.quantum).abs() <= steps.tolerance;
                    match (near && multiple != 0.0 && multiple.abs() < 1e9, committed) {
                        (false, _) => (0, 0),
                        (true, (m, run)) if m == multiple as i64 => (m, run + 1),
                        (true, _) => (multiple as i64, 1),
                    }
                }
            };
            let (multiple, run) = self.pending.watch[c];
            if let (Some(state), true) = (steps.bias_states[c], run >= steps.after) {
                if !moved {
                    filter.snapshot_into(&mut self.before);
                    moved = true;
                }
                let step = multiple as f64 * steps.quantum;
                self.before.mean[state] += step;
                self.pending.steps[c] = step;
                self.pending.watch[c] = (0, 0);
            }
        }
        if moved {
            filter.restore(&self.before)?;
        }
        Ok(())
    }

    /// The channels, by row of `z`.
    pub fn channels(&self) -> &[Channel] {
        &self.channels
    }

    /// Measurement rows rejected by the gate so far, over all channels.
    pub fn rejected(&self) -> u64 {
        self.channels.iter().map(|c| c.rejected).sum()
    }

    /// Re-acquisitions so far.
    pub fn reacquisitions(&self) -> u64 {
        self.reacquisitions
    }

    /// The windowed normalised innovations are within their bound (see the module documentation).
    pub fn consistent(&self) -> bool {
        self.consistent
    }

    /// Every available row has been rejected for the last samples: the filter
    /// and all its sensors disagree (it re-acquires after `reacquire_after`).
    pub fn lost(&self) -> bool {
        self.all_rejected_run > 0
    }

    /// The re-acquisitions have spent [`SupervisorSettings::max_inflation`]
    /// since a sample last passed the gate whole: no more until one does.
    pub fn exhausted(&self) -> bool {
        self.inflation >= self.settings.max_inflation
    }

    /// Consistent and not lost.
    pub fn healthy(&self) -> bool {
        self.consistent && !self.lost()
    }

    /// The mean normalised innovation per row over the window, each clipped
    /// at the gate (about 1 for a consistent filter; NaN before any row).
    pub fn windowed_nis(&self) -> f64 {
        self.window_nis
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
        let available = self.pending.rows.iter().any(|r| *r != RowOutcome::Missing);
        self.consistent && !(available && self.pending.dof == 0)
    }

    /// Gate rejections so far plus those of the pending outcome.
    pub fn rejected_with_pending(&self) -> u64 {
        self.rejected() + self.pending.rows.iter().filter(|r| **r == RowOutcome::Rejected).count() as u64
    }

    /// What the supervisor remembers between samples, as words (counters,
    /// and floats by their bits), for a driver's saved state; the pending
    /// outcome is not part of it. [`Supervisor::load`] takes it back.
    pub fn save(&self, out: &mut Vec<u64>) {
        out.clear();
        for c in &self.channels {
            out.extend([
                u64::from(c.bad_run),
                u64::from(c.rejected_run),
                u64::from(c.faulty),
                c.rejected,
                c.stuck,
                u64::from(c.since_reacquisition),
                u64::from(c.suspended),
                c.last_value,
                u64::from(c.repeats),
                c.step_multiple as u64,
                u64::from(c.step_run),
            ]);
        }
        out.extend([
            u64::from(self.all_rejected_run),
            self.reacquisitions,
            u64::from(self.since_reacquisition),
            self.ring_at as u64,
            self.ring_len as u64,
            u64::from(self.consistent),
            self.window_nis.to_bits(),
            self.inflation.to_bits(),
        ]);
        for &(sum, rows) in &self.ring {
            out.extend([sum.to_bits(), rows as u64]);
        }
    }

    /// Takes back what [`Supervisor::save`] wrote for a supervisor of the same
    /// settings and size; on error nothing changes.
    pub fn load(&mut self, words: &[u64]) -> Result<(), FilterError> {
        let m = self.channels.len();
        let w = self.ring.len();
        let expected = 11 * m + 8 + 2 * w;
        crate::error::check_len("supervisor memory", expected, words.len())?;
        let small = |v: u64| {
            u32::try_from(v).map_err(|_| FilterError::InvalidSetting(format!("supervisor memory: {v} is out of range")))
        };
        let flag = |v: u64| match v {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(FilterError::InvalidSetting(format!("supervisor memory: {v} is not a flag"))),
        };
        let mut channels = self.channels.clone();
        for (c, chunk) in channels.iter_mut().zip(words.chunks_exact(11)) {
            *c = Channel {
                bad_run: small(chunk[0])?,
                rejected_run: small(chunk[1])?,
                faulty: flag(chunk[2])?,
                rejected: chunk[3],
                stuck: chunk[4],
                since_reacquisition: small(chunk[5])?,
                suspended: flag(chunk[6])?,
                last_value: chunk[7],
                repeats: small(chunk[8])?,
                step_multiple: chunk[9] as i64,
                step_run: small(chunk[10])?,
            };
        }
        let rest = &words[11 * m..];
        let (ring_at, ring_len) = (rest[3] as usize, rest[4] as usize);
        if ring_at >= w || ring_len > w {
            return Err(FilterError::InvalidSetting("supervisor memory: window position out of range".into()));
        }
        let ring: Vec<(f64, usize)> =
            rest[8..].chunks_exact(2).map(|p| (f64::from_bits(p[0]), p[1] as usize)).collect();
        if ring.iter().any(|&(sum, rows)| !sum.is_finite() || rows > m) {
            return Err(FilterError::InvalidSetting("supervisor memory: a window entry is out of range".into()));
        }
        let (all_rejected_run, since_reacquisition, consistent) = (small(rest[0])?, small(rest[2])?, flag(rest[5])?);
        let inflation = f64::from_bits(rest[7]);
        if !(inflation >= 1.0 && inflation <= self.settings.max_inflation) {
            return Err(FilterError::InvalidSetting(format!(
                "supervisor memory: inflation {inflation} is out of range"
            )));
        }
        self.channels = channels;
        self.all_rejected_run = all_rejected_run;
        self.reacquisitions = rest[1];
        self.since_reacquisition = since_reacquisition;
        self.ring_at = ring_at;
        self.ring_len = ring_len;
        self.consistent = consistent;
        self.window_nis = f64::from_bits(rest[6]);
        self.inflation = inflation;
        self.ring.copy_from_slice(&ring);
        Ok(())
    }

    /// The measurement the last [`Supervisor::gate`] was given, as offered.
    pub fn pending_measurement(&self) -> &[f64] {
        &self.z_offered
    }

    /// The outcome of the last [`Supervisor::gate`].
    pub fn pending(&self) -> &Outcome {
        &self.pending
    }

    /// Counts the pending outcome: channel runs and faults, the
    /// re-acquisition run, the consistency window. Calls `changed` for every
    /// channel whose fault flag changes.
    pub fn commit(&mut self, mut changed: impl FnMut(FaultChange)) {
        let outcome = &self.pending;
        for (channel, ((state, row), z)) in self.channels.iter_mut().zip(&outcome.rows).zip(&self.z_offered).enumerate()
        {
            let bad = *row != RowOutcome::Used;
            let rejected = *row == RowOutcome::Rejected;
            state.rejected += u64::from(rejected);
            state.stuck += u64::from(*row == RowOutcome::Stuck);
            state.rejected_run = if rejected { state.rejected_run.saturating_add(1) } else { 0 };
            if rejected && (state.since_reacquisition as usize) < self.settings.window {
                state.suspended = true;
            } else if *row == RowOutcome::Used {
                state.suspended = false;
            }
            state.since_reacquisition =
                if outcome.reacquired == Some(channel) { 0 } else { state.since_reacquisition.saturating_add(1) };
            state.bad_run = if bad { state.bad_run.saturating_add(1) } else { 0 };
            if z.is_finite() {
                let same = z.to_bits() == state.last_value;
                state.repeats = if same { state.repeats.saturating_add(1) } else { 1 };
                state.last_value = z.to_bits();
            }
            (state.step_multiple, state.step_run) = outcome.watch[channel];
            let faulty = state.bad_run >= self.settings.fault_after;
            if faulty != state.faulty {
                state.faulty = faulty;
                changed(FaultChange { channel, faulty });
            }
        }
        let any_available = outcome.rows.iter().any(|r| *r != RowOutcome::Missing);
        self.all_rejected_run = if any_available && outcome.dof == 0 { self.all_rejected_run + 1 } else { 0 };
        self.reacquisitions += u64::from(outcome.reacquired.is_some());
        self.since_reacquisition =
            if outcome.reacquired.is_some() { 0 } else { self.since_reacquisition.saturating_add(1) };
        let passed_whole = outcome.dof > 0 && !outcome.rows.contains(&RowOutcome::Rejected);
        self.inflation = if outcome.reacquired.is_some() {
            (self.inflation * outcome.inflation).min(self.settings.max_inflation)
        } else if passed_whole {
            1.0
        } else {
            self.inflation
        };
        let (sum, rows) = (outcome.clipped_ratios, outcome.gated_rows);
        self.push(sum, rows);
    }

    fn push(&mut self, clipped_ratios: f64, rows: usize) {
        let w = self.ring.len();
        self.ring[self.ring_at] = (clipped_ratios, rows);
        self.ring_at = (self.ring_at + 1) % w;
        self.ring_len = (self.ring_len + 1).min(w);
        // Summed afresh (w additions): no drift of a running sum.
        let (sum, total): (f64, usize) =
            self.ring[..self.ring_len].iter().fold((0.0, 0), |(s, d), &(n, k)| (s + n, d + k));
        self.consistent = total == 0 || sum <= self.settings.consistency_margin * self.bound(total);
        self.window_nis = if total == 0 { f64::NAN } else { sum / total as f64 };
    }

    fn bound(&mut self, dof: usize) -> f64 {
        if dof >= self.upper_bound.len() {
            self.upper_bound.resize(dof + 1, f64::NAN);
        }
        if self.upper_bound[dof].is_nan() {
            self.upper_bound[dof] = chi_square::quantile(dof as f64, 1.0 - self.settings.consistency_probability);
        }
        self.upper_bound[dof]
    }
}
