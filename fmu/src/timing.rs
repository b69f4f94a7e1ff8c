//! When the filter takes a measurement, and what the outputs are when they
//! are read: the FMU's time semantics, apart from the FMI calls.
//!
//! The filter runs on the sample grid `tₖ = start + k·sample_time` (from `k`,
//! never accumulated). With the default input timing, the FMI meaning of an
//! input ([`InputTiming::AtCommunicationPoint`]):
//!
//! ```text
//!  master:  set u(t)     get y          doStep(t, h)                 get y          set u(t+h)     get y
//!  FMU:        │       x̂(t | t)    update at t with u(t),       x̂(t+h | t)           │        x̂(t+h | t+h)
//!              └──────────┘        predict to t + h                                 └──────────────┘
//!                 direct feedthrough                                                   direct feedthrough
//! ```
//!
//! 1. A sample instant that is a communication point takes the inputs as they
//!    stand there as its measurement, once: when the master steps on from it,
//!    or earlier, for a read after an input was set at that point (direct
//!    feedthrough; a later set before the step recomputes it from the
//!    prediction, so a measurement never enters twice).
//! 2. Sample instants strictly inside a communication step are predictions:
//!    the inputs held over the step are the measurement of its start, not of
//!    later instants.
//! 3. Inputs set at a communication point off the grid are not measurements
//!    (the sensor samples on the grid); a read there gives the prediction from
//!    the last sample to that time, with the process noise of that interval.
//! 4. So a read at `t` always gives the estimate at `t`: given the
//!    measurements up to `t` once an input was set at `t`, and predicted from
//!    the earlier ones before that.
//!
//! What became of each measurement row ([`Reading::statuses`]) is that of the
//! update the belief read includes: the feedthrough update at a read after
//! inputs were set at a sample instant, else the latest committed one (at a
//! prediction off the grid too: no measurement enters there); before the
//! first update every row is missing, as none has entered.
//!
//! Every update, at a step or for a read, goes through the instance's
//! `estimator::SupervisedFilter`, the loop every study runs too (gate, fault
//! flags, re-acquisition, consistency): these rules only say when it predicts,
//! holds controls and updates. A read previews an update on a copy; the step
//! commits it.
//!
//! With [`InputTiming::AtStepEnd`] (masters that step the plant first and
//! hand its outputs of `t + h` over before our step, Gauss–Seidel) the inputs
//! set before `fmi2DoStep(t, h)` are the measurement of `t + h`: the step
//! predicts to `t + h` and updates there when it is a sample instant, and the
//! outputs after the step are `x̂(t+h | t+h)`. The outputs do not change when
//! inputs are set.
//!
//! Controls (known inputs `u` of the model, e.g. rudder deflections, the inputs of
//! `Role::Control`) are held, as a control computer outputs them (zero-order hold):
//! the controls of time `τ` are in force over `[τ, τ')`, `τ'` the communication
//! point whose controls come next. The filter samples them on its grid, as it does
//! the measurements: the controls in force at sample instant `tₖ` enter the update
//! at `tₖ` (the observation `h(x, u(tₖ))`) and the prediction from `tₖ` to `tₖ₊₁`.
//!
//! 5. With [`InputTiming::AtCommunicationPoint`] the controls set at `t` are
//!    those of `t`, held over `[t, t + h)`: they enter the update at `t` (at the
//!    step, or at a read after inputs were set there) and the prediction from
//!    every sample in `[t, t + h)`. The prediction from a sample before `t`
//!    (a step that starts off the grid) keeps the controls in force at that
//!    sample, those of the step it fell in.
//! 6. With [`InputTiming::AtStepEnd`] everything set before `fmi2DoStep(t, h)` is
//!    of `t + h`: the controls too. They enter the update at `t + h` (when it is
//!    a sample instant) and the predictions from the samples in `[t + h, …)`,
//!    at the next step; the predictions inside this step use the controls of
//!    `t`, set before the previous step (at the first step: those standing at
//!    `fmi2ExitInitializationMode`, set in initialisation mode or 0).
//! 7. A control is never missing: a non-finite value is refused by `fmi2SetReal`
//!    (the instance keeps the previous one), and one never set is its start
//!    value, 0. Setting a control at `t` counts as setting an input there (a
//!    read makes the update at `t` with the inputs as they stand).
//! 8. The controls in force are part of the FMU state: the instance's input
//!    values, the filter's held input (the controls of its current sample) and
//!    [`Progress::controls`] (those in force from the FMU's time on).
//!
//! Smoothed outputs (`smoothing_lag` > 0; `estimator::SupervisedFilter::smooth_with_lag`):
//!
//! 9. A read shows, beside the belief at `t`, the fixed-lag smoothed estimate of
//!    the sample `L = round(smoothing_lag / sample_time)` samples before the
//!    filter's newest one, given everything the belief read includes: after a
//!    feedthrough update at `t` that update too (the pending step on a copy of
//!    the oldest instant needed; the step commits it), after a step the
//!    prediction to the new sample (the smoother's open step). Its time is the
//!    output `smoothed_time` (the start until `L` samples have passed). The
//!    smoother's instants and its open step are part of the FMU state.

use estimator::{Event, FilterError, Noise, RowOutcome, Snapshot, StateEstimator, SupervisedFilter, Supervisor};

/// How the inputs set before `fmi2DoStep(t, h)` are timed (the `input_timing` parameter).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputTiming {
    /// The measurement at `t` (FMI's meaning; Jacobi masters). The default.
    AtCommunicationPoint,
    /// The measurement at `t + h` (Gauss–Seidel masters that step the plant first).
    AtStepEnd,
}

impl InputTiming {
    /// The timing for an `input_timing` enumeration value.
    pub fn from_value(value: f64) -> Result<Self, String> {
        if value == 1.0 {
            Ok(Self::AtCommunicationPoint)
        } else if value == 2.0 {
            Ok(Self::AtStepEnd)
        } else {
            Err(format!("parameter input_timing must be 1 (communication_point) or 2 (step_end), got {value}"))
        }
    }
}

/// A filter failure inside a communication step.
#[derive(Debug, Clone, PartialEq)]
pub struct StepFailure {
    /// The sample instant whose predict or update failed (s).
    pub time: f64,
    /// Its index on the grid.
    pub sample: u64,
    /// Which stage failed and why.
    pub error: FilterError,
    /// The time of the last good estimate (s).
    pub last_good: f64,
}

/// What a read shows: the belief at the time read and the counts that go with it.
pub struct Reading<'a> {
    /// The belief at the time read.
    pub belief: &'a dyn StateEstimator,
    /// NIS of the latest update the belief includes.
    pub nis: f64,
    /// Measurement rows left out so far as missing, including those of an update only this read made.
    pub skipped: u64,
    /// Measurement rows rejected by the gate so far, likewise.
    pub rejected: u64,
    /// Per measurement row: the channel is faulty, likewise.
    pub faulty: &'a [bool],
    /// Per measurement row: what became of it in the latest update the belief
    /// includes (all missing before the first update).
    pub statuses: &'a [RowOutcome],
    /// The filter is consistent and not lost (`estimator::Supervisor::healthy`).
    pub healthy: bool,
    /// The adapted scale on `Q` the belief was predicted with.
    pub process_noise_scale: f64,
    /// The belief is inside its plausible range (`estimator::Supervisor::outside`).
    pub plausible: bool,
    /// The fixed-lag smoothed estimate that goes with the belief (rule 9),
    /// when the instance smooths.
    pub smoothed: Option<Smoothed<'a>>,
}

/// A fixed-lag smoothed estimate, as a read shows it.
#[derive(Debug, Clone, Copy)]
pub struct Smoothed<'a> {
    /// The time it describes (s).
    pub time: f64,
    /// The smoothed states' means, in the descriptor's order.
    pub means: &'a [f64],
    /// Their variances.
    pub variances: &'a [f64],
}

/// The buffers a read copies the smoothed estimate into.
struct SmoothedCopy {
    time: f64,
    means: Vec<f64>,
    variances: Vec<f64>,
}

/// The running estimator of an instance: the filter on its grid, and a
/// second filter of the same build that answers reads which must not touch it.
pub struct Estimation {
    /// The belief at sample `samples`, behind its supervisor.
    supervised: SupervisedFilter,
    /// Scratch for reads: the feedthrough update, the prediction off the grid.
    reader: Box<dyn StateEstimator>,
    /// The interval whose process noise the reader holds (s).
    reader_interval: f64,
    /// The reader holds the filter's belief updated with the supervisor's
    /// pending measurement (a feedthrough read), and the supervisor that
    /// update's outcome: the step commits both by a copy, not a second update.
    posterior_ready: bool,
    /// Buffers for copying the filter's belief into the reader.
    copy: Snapshot,
    /// The controls in force from the FMU's current time on, as far as known
    /// (the controls of the last communication point with `AtStepEnd`; with
    /// `AtCommunicationPoint` those of the step being made).
    standing: Vec<f64>,
    /// The controls in force at the filter's current sample once they are
    /// known: the input the filter holds (`StateEstimator::predict`), which its
    /// update uses.
    sample_controls: Vec<f64>,
    /// The controls of the pending feedthrough update (`posterior_ready`).
    read_controls: Vec<f64>,
    start: f64,
    sample_time: f64,
    timing: InputTiming,
    samples: u64,
    /// Sample `samples` had its measurement (or is past without one).
    measured: bool,
    /// Per measurement row, for readings: the fault flags shown.
    faulty: Vec<bool>,
    /// Per measurement row: its outcome in the latest committed update. Kept
    /// apart from the supervisor's pending outcome, which a feedthrough read
    /// or a failed update overwrites and an FMU state does not hold.
    committed_statuses: Vec<RowOutcome>,
    /// The statuses a read before the commit shows.
    read_statuses: Vec<RowOutcome>,
    /// The smoothed estimate of the last read, when the instance smooths.
    smoothed: Option<SmoothedCopy>,
}

/// The part of an [`Estimation`] an FMU state saves: the rest comes from the parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Progress {
    /// Samples done since the start.
    pub samples: u64,
    /// The current sample had its measurement.
    pub measured: bool,
    /// Measurement rows left out so far.
    pub skipped: u64,
    /// NIS of the latest update.
    pub nis: f64,
    /// The supervisor's memory (`estimator::Supervisor::save`).
    pub supervisor: Vec<u64>,
    /// The controls in force from the FMU's time on (`AtStepEnd`: those of that
    /// time, needed by the next step's predictions).
    pub controls: Vec<f64>,
    /// Per measurement row: its outcome in the latest committed update (the
    /// supervisor's memory does not hold it, the status outputs show it).
    pub statuses: Vec<RowOutcome>,
    /// The filter's belief at the current sample (its held input: the controls
    /// of that sample).
    pub belief: Snapshot,
    /// The smoothing's words (`estimator::SupervisedFilter::save_smoothing`;
    /// empty when the instance does not smooth).
    pub smoothing: Vec<f64>,
}

impl Estimation {
    /// Starts on the grid `start + k·sample_time` with `filter`'s belief at
    /// `start`; `reader` is a second filter of the same build; every update
    /// goes through `supervisor`; `controls` are those standing at the start
    /// (the controls of the start time with `AtStepEnd`). With `smoothing`,
    /// `(states, lag)`, those states are also smoothed `lag` samples back.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        filter: Box<dyn StateEstimator>,
        reader: Box<dyn StateEstimator>,
        start: f64,
        sample_time: f64,
        timing: InputTiming,
        supervisor: Supervisor,
        controls: &[f64],
        smoothing: Option<(&[usize], usize)>,
    ) -> Result<Self, FilterError> {
        let copy = filter.snapshot();
        let m = filter.measurement_dim();
        let mut supervised = SupervisedFilter::new(filter, supervisor)?;
        let smoothed = match smoothing {
            Some((states, lag)) => {
                supervised.smooth_with_lag(states, lag)?;
                let zeros = vec![0.0; states.len()];
                Some(SmoothedCopy { time: start, means: zeros.clone(), variances: zeros })
            }
            None => None,
        };
        Ok(Self {
            supervised,
            smoothed,
            reader,
            reader_interval: sample_time,
            posterior_ready: false,
            standing: controls.to_vec(),
            sample_controls: copy.input.clone(),
            read_controls: controls.to_vec(),
            copy,
            start,
            sample_time,
            timing,
            samples: 0,
            measured: false,
            faulty: vec![false; m],
            committed_statuses: vec![RowOutcome::Missing; m],
            read_statuses: vec![RowOutcome::Missing; m],
        })
    }

    /// Continues from a saved [`Progress`] instead of the start.
    pub fn resume(mut self, progress: &Progress) -> Result<Self, FilterError> {
        self.supervised.restore(&progress.belief)?;
        if progress.controls.len() != self.standing.len() {
            return Err(FilterError::InvalidSetting(format!(
                "{} controls saved, the model has {}",
                progress.controls.len(),
                self.standing.len()
            )));
        }
        if progress.statuses.len() != self.committed_statuses.len() {
            return Err(FilterError::InvalidSetting(format!(
                "{} input statuses saved, the model has {} measurement rows",
                progress.statuses.len(),
                self.committed_statuses.len()
            )));
        }
        self.standing.copy_from_slice(&progress.controls);
        self.committed_statuses.copy_from_slice(&progress.statuses);
        self.sample_controls.copy_from_slice(&progress.belief.input);
        self.supervised.resume(progress.skipped, progress.nis, &progress.supervisor)?;
        self.supervised.load_smoothing(&progress.smoothing)?;
        self.samples = progress.samples;
        self.measured = progress.measured;
        Ok(self)
    }

    /// What an FMU state saves.
    pub fn progress(&self) -> Progress {
        Progress {
            samples: self.samples,
            measured: self.measured,
            skipped: self.supervised.skipped(),
            nis: self.supervised.nis(),
            supervisor: {
                let mut words = Vec::new();
                self.supervised.supervisor().save(&mut words);
                words
            },
            controls: self.standing.clone(),
            statuses: self.committed_statuses.clone(),
            belief: self.supervised.filter().snapshot(),
            smoothing: {
                let mut words = Vec::new();
                self.supervised.save_smoothing(&mut words);
                words
            },
        }
    }

    /// Takes the events since the last call, oldest first.
    pub fn take_events(&mut self, each: impl FnMut(Event)) {
        self.supervised.take_events(each);
    }

    /// The filter on its grid.
    pub fn filter(&self) -> &dyn StateEstimator {
        self.supervised.filter()
    }

    /// The input timing.
    pub fn timing(&self) -> InputTiming {
        self.timing
    }

    /// Sample instant `k`.
    pub fn sample_instant(&self, k: u64) -> f64 {
        self.start + k as f64 * self.sample_time
    }

    /// The instant of the filter's belief.
    pub fn current_sample(&self) -> f64 {
        self.sample_instant(self.samples)
    }

    /// The tolerance of "at a sample instant": a master's clock may
    /// carry rounding, never a microsecond at a millisecond sample time.
    fn tolerance(&self) -> f64 {
        1e-6 * self.sample_time
    }

    /// Whether `t` is the instant of the filter's belief (a sample instant).
    pub fn at_current_sample(&self, t: f64) -> bool {
        (t - self.current_sample()).abs() <= self.tolerance()
    }

    /// `fmi2DoStep(t, h)` with the measurement inputs `z` (non-finite: missing)
    /// and the controls `u` as they stand.
    pub fn step(&mut self, t: f64, h: f64, z: &[f64], u: &[f64]) -> Result<(), StepFailure> {
        let posterior_ready = std::mem::take(&mut self.posterior_ready);
        let end = t + h;
        if self.timing == InputTiming::AtCommunicationPoint {
            // The controls set at t are held over the step.
            self.standing.copy_from_slice(u);
        }
        if self.at_current_sample(t) {
            self.hold_standing().map_err(|error| self.failure(self.samples, error))?;
        }
        if self.timing == InputTiming::AtCommunicationPoint && self.at_current_sample(t) && !self.measured {
            let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
            let supervisor = self.supervised.supervisor();
            if posterior_ready && same(supervisor.pending_measurement(), z) && same(&self.read_controls, u) {
                // The read already made this update: take its result, bit for bit.
                let time = self.current_sample();
                if let Err(error) = self.supervised.commit_preview(self.reader.as_ref(), &mut self.copy, z, time) {
                    return Err(self.failure(self.samples, error));
                }
                self.commit_statuses();
                self.measured = true;
            } else {
                self.update(z)?;
            }
        }
        while self.sample_instant(self.samples + 1) <= end + self.tolerance() {
            // From a sample inside the step, the controls held over it; from one
            // before it (a step starting off the grid), those recorded there.
            if self.current_sample() >= t - self.tolerance() {
                self.sample_controls.copy_from_slice(&self.standing);
            }
            let result = self.supervised.predict(&self.sample_controls, self.sample_time);
            if let Err(error) = result {
                return Err(self.failure(self.samples + 1, error));
            }
            self.samples += 1;
            self.measured = false;
        }
        if !self.at_current_sample(end) && self.current_sample() >= t - self.tolerance() {
            // A sample strictly inside the step: the controls held over it are its own.
            self.hold_standing().map_err(|error| self.failure(self.samples, error))?;
        }
        if self.timing == InputTiming::AtStepEnd {
            // The controls set for this step are those of t + h.
            self.standing.copy_from_slice(u);
            if self.at_current_sample(end) {
                self.hold_standing().map_err(|error| self.failure(self.samples, error))?;
                self.update(z)?;
            }
        }
        Ok(())
    }

    /// Makes the standing controls those the filter holds for its current
    /// sample (used by its update and its next prediction). Changes nothing
    /// when they already are, as always for a model without controls.
    fn hold_standing(&mut self) -> Result<(), FilterError> {
        let same = self.sample_controls.iter().zip(&self.standing).all(|(a, b)| a.to_bits() == b.to_bits());
        if same {
            return Ok(());
        }
        self.supervised.hold_input(&self.standing)?;
        self.sample_controls.copy_from_slice(&self.standing);
        Ok(())
    }

    fn update(&mut self, z: &[f64]) -> Result<(), StepFailure> {
        let time = self.current_sample();
        match self.supervised.update(z, time) {
            Ok(_) => {
                self.commit_statuses();
                self.measured = true;
                Ok(())
            }
            Err(error) => Err(self.failure(self.samples, error)),
        }
    }

    /// The statuses the outputs show from the update just committed.
    fn commit_statuses(&mut self) {
        copy_statuses(self.supervised.supervisor(), &mut self.committed_statuses);
    }

    fn failure(&self, sample: u64, error: FilterError) -> StepFailure {
        let last_good = self.current_sample();
        StepFailure { time: self.sample_instant(sample), sample, error, last_good }
    }

    /// The belief at time `t` (a communication point, not before the current
    /// sample). `inputs` are the measurement inputs and the controls when some
    /// input was set at `t`; `noise_over(dt)` builds `Q` and `R` for a
    /// prediction over `dt`.
    pub fn read(
        &mut self,
        t: f64,
        inputs: Option<(&[f64], &[f64])>,
        noise_over: &dyn Fn(f64) -> Result<Noise, String>,
    ) -> Result<Reading<'_>, String> {
        self.posterior_ready = false;
        let feedthrough = self.timing == InputTiming::AtCommunicationPoint && !self.measured;
        if self.at_current_sample(t) {
            match inputs {
                Some((z, u)) if feedthrough => {
                    // The update at t with the controls of t (rule 5), with the Q
                    // of a sample: a jump's review predicts over one.
                    self.reader_noise_over(self.sample_time, noise_over)?;
                    self.load_reader(Some(u))?;
                    self.read_controls.copy_from_slice(u);
                    let nis = match self.supervised.preview(self.reader.as_mut(), z) {
                        Ok(outcome) => outcome.nis,
                        Err(e) => return Err(format!("the update with the inputs at t = {t} s failed: {e}")),
                    };
                    self.posterior_ready = true;
                    if let Some(copy) = self.smoothed.as_mut() {
                        copy.take(self.supervised.lagged_estimate_with_pending(self.reader.as_ref()));
                    }
                    let skipped = self.supervised.skipped_with_pending();
                    let supervisor = self.supervised.supervisor();
                    for (c, flag) in self.faulty.iter_mut().enumerate() {
                        *flag = supervisor.faulty_with_pending(c);
                    }
                    copy_statuses(supervisor, &mut self.read_statuses);
                    let rejected = supervisor.rejected_with_pending();
                    let healthy = supervisor.healthy_with_pending();
                    let process_noise_scale = supervisor.process_noise_scale();
                    Ok(Reading {
                        belief: self.reader.as_ref(),
                        nis,
                        skipped,
                        rejected,
                        faulty: &self.faulty,
                        statuses: &self.read_statuses,
                        healthy,
                        process_noise_scale,
                        plausible: supervisor.outside(self.reader.as_ref()).is_none(),
                        smoothed: self.smoothed.as_ref().map(SmoothedCopy::shown),
                    })
                }
                _ => Ok(self.committed_reading(false)),
            }
        } else {
            let dt = t - self.current_sample();
            if !(dt > 0.0 && dt < self.sample_time) {
                return Err(format!(
                    "t = {t} s is not within one sample after the filter's belief at {} s",
                    self.current_sample()
                ));
            }
            self.reader_noise_over(dt, noise_over)?;
            // The prediction keeps the controls in force at the current sample
            // (and the adapted scale on Q, which the reader takes here).
            self.load_reader(None)?;
            self.reader
                .predict(&self.sample_controls, dt)
                .map_err(|e| format!("the prediction from {} s to {t} s failed: {e}", self.current_sample()))?;
            Ok(self.committed_reading(true))
        }
    }

    /// The filter's belief with the committed counts and flags: what a read
    /// shows when no update is pending, and the last good estimate after a failure.
    pub fn last_reading(&mut self) -> Reading<'_> {
        self.committed_reading(false)
    }

    /// A reading of the committed counts, with the filter's belief or the reader's.
    fn committed_reading(&mut self, reader: bool) -> Reading<'_> {
        if let Some(copy) = self.smoothed.as_mut() {
            copy.take(self.supervised.lagged_estimate());
        }
        let supervisor = self.supervised.supervisor();
        for (c, flag) in self.faulty.iter_mut().enumerate() {
            *flag = supervisor.channels()[c].faulty;
        }
        let belief = if reader { self.reader.as_ref() } else { self.supervised.filter() };
        Reading {
            belief,
            nis: self.supervised.nis(),
            skipped: self.supervised.skipped(),
            rejected: supervisor.rejected(),
            faulty: &self.faulty,
            statuses: &self.committed_statuses,
            healthy: supervisor.healthy(),
            process_noise_scale: supervisor.process_noise_scale(),
            plausible: supervisor.outside(belief).is_none(),
            smoothed: self.smoothed.as_ref().map(SmoothedCopy::shown),
        }
    }

    /// The first state of the filter's belief outside its plausible range, if any.
    pub fn outside(&self) -> Option<estimator::Outside> {
        self.supervised.supervisor().outside(self.supervised.filter())
    }

    /// Gives the reader the noise of a prediction over `dt` (built by
    /// `noise_over`), unless it has it already.
    fn reader_noise_over(&mut self, dt: f64, noise_over: &dyn Fn(f64) -> Result<Noise, String>) -> Result<(), String> {
        if dt != self.reader_interval {
            self.reader.set_noise(noise_over(dt)?).map_err(|e| e.to_string())?;
            self.reader_interval = dt;
        }
        Ok(())
    }

    /// Copies the filter's belief and its scale on `Q` into the reader, holding
    /// `controls` instead of the filter's input when given.
    fn load_reader(&mut self, controls: Option<&[f64]>) -> Result<(), String> {
        self.supervised.filter().snapshot_into(&mut self.copy);
        if let Some(u) = controls {
            self.copy.input.copy_from_slice(u);
        }
        self.reader.restore(&self.copy).map_err(|e| format!("cannot copy the belief for the read: {e}"))?;
        // The prediction to a read between samples uses the adapted Q too.
        self.supervised
            .scale_process_noise_of(self.reader.as_mut())
            .map_err(|e| format!("cannot scale the reader's Q: {e}"))
    }

    /// New `Q` and `R` (for one sample time), for the reads too; on error the
    /// filter keeps its noise.
    pub fn set_noise(&mut self, noise: Noise) -> Result<(), FilterError> {
        // The reader first: it is scratch, rebuilt from the filter at every read.
        self.reader.set_noise(noise.clone())?;
        self.reader_interval = self.sample_time;
        // A feedthrough update made with the old R is no longer the one to commit.
        self.posterior_ready = false;
        self.supervised.set_noise(noise)
    }
}

impl SmoothedCopy {
    /// Copies the estimate a read shows.
    fn take(&mut self, estimate: Option<estimator::LaggedEstimate<'_>>) {
        if let Some(estimate) = estimate {
            self.time = estimate.time;
            self.means.copy_from_slice(estimate.means);
            self.variances.copy_from_slice(estimate.variances);
        }
    }

    fn shown(&self) -> Smoothed<'_> {
        Smoothed { time: self.time, means: &self.means, variances: &self.variances }
    }
}

/// The statuses `supervisor` shows now ([`Supervisor::statuses`]), into `into`.
fn copy_statuses(supervisor: &Supervisor, into: &mut [RowOutcome]) {
    for (status, row) in into.iter_mut().zip(supervisor.statuses()) {
        *status = row;
    }
}
