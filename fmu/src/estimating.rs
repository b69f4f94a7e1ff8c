//! What an estimator FMU's instance does: the filter, its inputs and its
//! outputs, the life cycle's estimator part. The shell (`instance.rs`) keeps
//! the values, the state and the logging, and calls in here.
//!
//! Time semantics (which sample takes which inputs, what a read shows) are
//! `timing.rs`; this file keeps what an estimator adds to the shell.
//! Outputs are computed on demand: setting an input, a tunable parameter or
//! stepping marks them stale, and the next get computes them (as the
//! Reference-FMUs do), so a read after new inputs has direct feedthrough.

use estimator::{Event, Outside, RowOutcome, StateEstimator, Supervisor, SupervisorSettings, UnscentedParams};

use crate::estimators::{self, status_value, Descriptor, MAX_DERIVED};
use crate::ffi::Fmi2Status;
use crate::input_timing_check::{InputTimingCheck, Phase};
use crate::instance::Shell;
use crate::plausibility;
use crate::state::ModelState;
use crate::timing::{Estimation, InputTiming, Reading};
use crate::variables::{Parameters, Role, Variability};

/// An estimator FMU's part of an instance.
pub struct Estimating {
    pub(crate) descriptor: Descriptor,
    /// The filter and its clock, from `fmi2ExitInitializationMode` on.
    pub(crate) estimation: Option<Estimation>,
    /// The inputs as they stand, by measurement row (non-finite: missing).
    measurement: Vec<f64>,
    /// The controls as they stand, by component of `u` (always finite).
    controls: Vec<f64>,
    /// Per measurement row: the importer has set this input at least once.
    pub(crate) input_ever_set: Vec<bool>,
    /// An input was set at the current communication point.
    pub(crate) inputs_set: bool,
    /// The output values are not those of the current time and inputs.
    outputs_stale: bool,
    /// Per measurement row: a non-finite value, or the input never being set, was already reported.
    pub(crate) missing_reported: Vec<bool>,
    pub(crate) off_grid_reported: bool,
    /// Whether the master's ordering fits `input_timing` (`input_timing_check.rs`).
    pub(crate) timing_check: InputTimingCheck,
    /// The values of the last plausible reading: what the outputs show while the filter is lost.
    last_plausible: Vec<f64>,
    /// The estimate is outside its plausible range (reported once per episode).
    pub(crate) lost: bool,
}

impl Estimating {
    /// Before `reset`: the instance's start values are set there.
    pub fn new(descriptor: Descriptor) -> Self {
        let (m, k) = (descriptor.measurement_dim(), descriptor.control_dim());
        Self {
            descriptor,
            estimation: None,
            measurement: vec![f64::NAN; m],
            controls: vec![0.0; k],
            input_ever_set: vec![false; m],
            inputs_set: false,
            outputs_stale: false,
            missing_reported: vec![false; m],
            off_grid_reported: false,
            timing_check: InputTimingCheck::new(m),
            last_plausible: Vec::new(),
            lost: false,
        }
    }

    /// Back to the state after `fmi2Instantiate`, over the start values in `shell`.
    pub fn reset(&mut self, shell: &mut Shell) {
        self.set_role(shell, Role::SkippedMeasurements, 0.0);
        self.set_role(shell, Role::FilterHealthy, 1.0);
        // No update has been made: no input has entered one.
        for row in 0..self.descriptor.measurement_dim() {
            self.set_role(shell, Role::InputStatus(row), f64::from(status_value(RowOutcome::Missing)));
        }
        self.estimation = None;
        self.input_ever_set.iter_mut().for_each(|s| *s = false);
        self.inputs_set = false;
        self.outputs_stale = false;
        self.missing_reported.iter_mut().for_each(|r| *r = false);
        self.off_grid_reported = false;
        self.timing_check.reset();
        self.lost = false;
        self.set_role(shell, Role::InputTimingCheck, f64::from(crate::input_timing_check::UNDECIDED));
    }

    fn set_role(&self, shell: &mut Shell, role: Role, value: f64) {
        for (v, x) in self.descriptor.variables.iter().zip(shell.values.iter_mut()) {
            if v.role == role {
                *x = value;
            }
        }
    }

    /// After the shell applied new values (`old`: those they replaced): refuses the
    /// whole call, restoring `old`, when a tunable parameter would make the noise
    /// invalid while the filter runs.
    pub fn values_set(&mut self, shell: &mut Shell, updates: &[(usize, f64)], old: &[(usize, f64)]) -> Fmi2Status {
        let tunable_changed =
            updates.iter().any(|&(i, _)| self.descriptor.variables[i].variability == Variability::Tunable);
        if shell.state == ModelState::StepComplete && tunable_changed {
            let p = Parameters::new(&self.descriptor.variables, &shell.values);
            let noise = p.positive("sample_time").and_then(|dt| (self.descriptor.build_noise)(&p, dt));
            let applied = noise.and_then(|n| match self.estimation.as_mut() {
                Some(e) => e.set_noise(n).map_err(|e| e.to_string()),
                None => Ok(()),
            });
            if let Err(why) = applied {
                for &(i, v) in old {
                    shell.values[i] = v;
                }
                return shell.error(&format!("tunable parameters refused, values unchanged: {why}"));
            }
            self.outputs_stale = true;
            shell.log(Fmi2Status::Ok, "logEvents", "tunable parameters applied to the filter noise");
        }
        for &(i, _) in updates {
            match self.descriptor.variables[i].role {
                Role::Measurement(row) => {
                    self.input_ever_set[row] = true;
                    self.inputs_set = true;
                    self.outputs_stale = true;
                }
                Role::Control(_) => {
                    self.inputs_set = true;
                    self.outputs_stale = true;
                }
                _ => {}
            }
        }
        Fmi2Status::Ok
    }

    /// `fmi2ExitInitializationMode`: builds the filter from the parameters.
    pub fn exit_initialization(&mut self, shell: &mut Shell) -> Fmi2Status {
        self.load_controls(&shell.values);
        let noise_checked = build_filter(&self.descriptor, &shell.values, shell.start_time)
            .and_then(|mut fresh| plausibility::check_noise(&self.descriptor, fresh.as_mut()));
        if let Err(why) = noise_checked {
            return shell.error(&format!("fmi2ExitInitializationMode: cannot build the estimator: {why}"));
        }
        match build_estimation(&self.descriptor, &shell.values, shell.start_time, &self.controls) {
            Ok(estimation) => {
                let kind = estimation.filter().kind();
                self.last_plausible.clone_from(&shell.values);
                self.lost = false;
                // The inputs set in initialisation mode, kept for the first step to compare.
                self.standing_measurement(&shell.values);
                self.timing_check.at_exit(&self.measurement, &self.input_ever_set);
                self.estimation = Some(estimation);
                shell.state = ModelState::StepComplete;
                self.outputs_stale = true;
                shell.log(Fmi2Status::Ok, "logEvents", &format!("initialised: {kind} at t = {}", shell.time));
                Fmi2Status::Ok
            }
            Err(why) => shell.error(&format!("fmi2ExitInitializationMode: cannot build the estimator: {why}")),
        }
    }

    /// In initialisation mode the outputs show the prior of the current
    /// parameters (left as they were while the parameters do not build a filter).
    pub fn refresh_initial_outputs(&mut self, shell: &mut Shell) {
        if let Ok(filter) = build_filter(&self.descriptor, &shell.values, shell.start_time) {
            let m = self.descriptor.measurement_dim();
            let (faulty, statuses) = (vec![false; m], vec![RowOutcome::Missing; m]);
            let nis = filter.innovation().nis();
            let prior = Reading {
                belief: filter.as_ref(),
                nis,
                skipped: 0,
                rejected: 0,
                faulty: &faulty,
                statuses: &statuses,
                healthy: true,
                process_noise_scale: 1.0,
                plausible: true,
                smoothed: None,
            };
            write_outputs(&self.descriptor, &mut shell.values, Some(&prior));
        }
    }

    /// `fmi2DoStep(t, h)`, checked by the shell; on `fmi2OK` the shell moves the time to `t + h`.
    pub fn do_step(&mut self, shell: &mut Shell, t: f64, h: f64) -> Fmi2Status {
        self.load_measurement(shell);
        self.load_controls(&shell.values);
        self.check_input_timing(shell);
        let Some(estimation) = self.estimation.as_mut() else {
            return shell.error("fmi2DoStep: no filter (internal state lost)");
        };
        let end = t + h;
        let stepped = estimation.step(t, h, &self.measurement, &self.controls);
        self.report_events(shell);
        let Some(estimation) = self.estimation.as_mut() else {
            return shell.error("fmi2DoStep: no filter (internal state lost)");
        };
        if let Err(failure) = stepped {
            // Show the last good estimate, as it is, and say when it was.
            let mut last = estimation.last_reading();
            last.healthy = false;
            write_outputs(&self.descriptor, &mut shell.values, Some(&last));
            self.outputs_stale = false;
            shell.state = ModelState::StepFailed;
            shell.last_successful_time = failure.last_good;
            shell.log(
                Fmi2Status::Discard,
                "logStatusError",
                &format!(
                    "filter failed at t = {} s (sample {}): {}; the outputs are the last good estimate, at t = {} s",
                    failure.time, failure.sample, failure.error, failure.last_good
                ),
            );
            return Fmi2Status::Discard;
        }
        let off_grid = !estimation.at_current_sample(end);
        let timing = estimation.timing();
        let outside = estimation.outside();
        if off_grid && !self.off_grid_reported {
            self.off_grid_reported = true;
            let ts = self.sample_time(shell);
            let rule = match timing {
                InputTiming::AtCommunicationPoint => "inputs set there are not measurements",
                InputTiming::AtStepEnd => "inputs set for it are not measurements",
            };
            shell.log(
                Fmi2Status::Warning,
                "logStatusWarning",
                &format!(
                    "communication point t = {end} s is not a sample instant (start + k·{ts} s): {rule}, and the outputs there are predictions; use a step that is a multiple of sample_time to use every sample (reported once)"
                ),
            );
        }
        self.inputs_set = false;
        self.outputs_stale = true;
        self.judge_plausibility(shell, outside, end)
    }

    /// After a step to `time`: a lost filter (`plausibility.rs`) makes the
    /// step fmi2Warning, said once per episode, as is its end.
    fn judge_plausibility(&mut self, shell: &Shell, outside: Option<Outside>, time: f64) -> Fmi2Status {
        match (outside, self.lost) {
            (Some(bad), lost) => {
                if !lost {
                    let name = self.state_name(bad.range.state);
                    shell.log(
                        Fmi2Status::Warning,
                        "logStatusWarning",
                        &format!(
                            "the filter is lost at t = {time} s: {name} is {:e} ± {:e}, beyond its plausible range \
                             {:e} ± {:e}; the outputs hold the last plausible estimate and filter_healthy is \
                             false until it is plausible again (are the noise parameters right?)",
                            bad.value, bad.std, bad.range.centre, bad.range.bound,
                        ),
                    );
                }
                self.lost = true;
                Fmi2Status::Warning
            }
            (None, true) => {
                self.lost = false;
                shell.log(Fmi2Status::Ok, "logEvents", &format!("the estimate is plausible again at t = {time} s"));
                Fmi2Status::Ok
            }
            (None, false) => Fmi2Status::Ok,
        }
    }

    /// The name of the output of state `i`'s estimate.
    fn state_name(&self, i: usize) -> String {
        self.descriptor
            .variables
            .iter()
            .find(|v| v.role == Role::Estimate(i))
            .map_or_else(|| format!("state {i}"), |v| v.name.to_string())
    }

    /// At `fmi2DoStep`, with the measurements standing: compares them with
    /// those set in initialisation mode (`input_timing_check.rs`), shows the
    /// verdict in `input_timing_check`, and warns, once, when the master's
    /// ordering fits the other `input_timing`.
    fn check_input_timing(&mut self, shell: &mut Shell) {
        let Some(verdict) = self.timing_check.at_step(&self.measurement) else { return };
        let Some(timing) = self.estimation.as_ref().map(Estimation::timing) else { return };
        let value = self.timing_check.value(timing);
        self.set_role(shell, Role::InputTimingCheck, f64::from(value));
        if value != crate::input_timing_check::OTHER_FITS {
            return;
        }
        let message = match verdict {
            Phase::NextInstant => {
                "input_timing = 1 (communication_point), but the inputs set before the first fmi2DoStep differ from \
                 those set in initialisation mode: the master seems to step the plant first and hand over its outputs \
                 of t + h (Gauss–Seidel); set input_timing = 2 (step_end) (input_timing_check is 2)"
            }
            _ => {
                "input_timing = 2 (step_end), but the inputs set before the first fmi2DoStep are those set in \
                 initialisation mode, bit for bit, and change at the next step: the master seems to hand over the \
                 plant's outputs of t before fmi2DoStep(t, h) (Jacobi); set input_timing = 1 (communication_point) \
                 (input_timing_check is 2)"
            }
        };
        shell.log(Fmi2Status::Warning, "logStatusWarning", message);
    }

    /// Logs what the supervisor reported during the last step, once per
    /// episode: an input becoming faulty or good again, a re-acquisition, the
    /// filter becoming inconsistent or consistent again.
    fn report_events(&mut self, shell: &Shell) {
        let mut events = Vec::new();
        if let Some(estimation) = self.estimation.as_mut() {
            estimation.take_events(|e| events.push(e));
        }
        let input = |row: usize| {
            self.descriptor.variables.iter().find(|v| v.role == Role::Measurement(row)).map_or("?", |v| &v.name)
        };
        let unit = |row: usize| {
            self.descriptor.variables.iter().find(|v| v.role == Role::Measurement(row)).and_then(|v| v.unit)
        };
        // An intermittent input (a marker) is missing most of the time: its flag says nothing.
        let intermittent =
            |row: usize| self.descriptor.variables.iter().any(|v| v.role == Role::Measurement(row) && v.intermittent);
        for event in events {
            if let Event::Fault { channel, .. } = event {
                if intermittent(channel) {
                    continue;
                }
            }
            let (status, category, text) = match event {
                Event::Fault { channel, faulty: true, time } => (
                    Fmi2Status::Warning,
                    "logStatusWarning",
                    format!("input {} is faulty from t = {time} s: rejected by the gate, stuck or missing for fault_after samples in a row; it is left out of the updates", input(channel)),
                ),
                Event::Fault { channel, faulty: false, time } => {
                    (Fmi2Status::Ok, "logEvents", format!("input {} is good again at t = {time} s", input(channel)))
                }
                Event::Reacquired { channel, time } => (
                    Fmi2Status::Warning,
                    "logStatusWarning",
                    format!("re-acquired at t = {time} s: input {} failed the gate reacquire_after samples in a row; the covariance was inflated and every input used", input(channel)),
                ),
                Event::ReacquisitionUndone { channel, time } => (
                    Fmi2Status::Warning,
                    "logStatusWarning",
                    format!("the re-acquisition triggered by input {} is undone at t = {time} s: the belief that left that input out explains the samples since better, so it was the sensor; the outputs are that belief's", input(channel)),
                ),
                Event::JumpUndone { channel, time } => (
                    Fmi2Status::Warning,
                    "logStatusWarning",
                    format!("the jump that input {} alone showed is undone at t = {time} s: the belief that left that input out explains the samples since better, so it was the sensor; the outputs are that belief's", input(channel)),
                ),
                Event::Restarted { time } => (
                    Fmi2Status::Warning,
                    "logStatusWarning",
                    format!("the filter restarted at t = {time} s: no input had passed the gate for consistency_window samples, its estimate had left its plausible range, or it was inconsistent and a belief started from where its states have been while it was healthy explained the samples better; it goes on from there"),
                ),
                Event::Wiring { channel, inconsistent: true, left_out: true, scale, offset, time } => (
                    Fmi2Status::Warning,
                    "logStatusWarning",
                    format!("input {} is inconsistent with the other inputs from t = {time} s and is left out of the updates (its status is 5, inconsistent): {}; check its wiring", input(channel), crate::wiring_cause::likely_cause(scale, offset, unit(channel))),
                ),
                Event::Wiring { channel, inconsistent: true, left_out: false, scale, offset, time } => (
                    Fmi2Status::Warning,
                    "logStatusWarning",
                    format!("the innovations of input {} disagree with the other inputs from t = {time} s: {}; its wiring is likely wrong, or that of an input beside it whose mistake shows in it; its status is 5 (inconsistent) where the FMU names only the likeliest input, it stays in the updates, and the filter is inconsistent (filter_healthy is false) until they agree; check the wiring of {} and of the inputs beside it", input(channel), crate::wiring_cause::likely_cause(scale, offset, unit(channel)), input(channel)),
                ),
                Event::Wiring { channel, inconsistent: false, left_out: true, time, .. } => (
                    Fmi2Status::Ok,
                    "logEvents",
                    format!("input {} agrees with the other inputs again at t = {time} s and is used again", input(channel)),
                ),
                Event::Wiring { channel, inconsistent: false, left_out: false, time, .. } => (
                    Fmi2Status::Ok,
                    "logEvents",
                    format!("the innovations of input {} agree with the other inputs again at t = {time} s", input(channel)),
                ),
                Event::Consistent { consistent: false, time } => (
                    Fmi2Status::Warning,
                    "logStatusWarning",
                    format!("the filter is inconsistent from t = {time} s: its innovations over the last consistency_window samples exceed their bound (filter_healthy is false)"),
                ),
                Event::Consistent { consistent: true, time } => {
                    (Fmi2Status::Ok, "logEvents", format!("the filter is consistent again at t = {time} s"))
                }
                Event::Exhausted { exhausted: true, time } => (
                    Fmi2Status::Warning,
                    "logStatusWarning",
                    format!("no more re-acquisitions from t = {time} s: they have inflated the covariance by max_inflation since a sample last passed the gate whole; the filter predicts only while its inputs fail the gate (is a sensor's noise far above its r_<input>_std?)"),
                ),
                Event::Exhausted { exhausted: false, time } => (
                    Fmi2Status::Ok,
                    "logEvents",
                    format!("every input passed the gate at t = {time} s: re-acquisitions are possible again"),
                ),
                Event::SmoothingRestarted { time } => (
                    Fmi2Status::Warning,
                    "logStatusWarning",
                    format!("the fixed-lag smoother starts again at t = {time} s (a singular prediction or a non-finite term): the smoothed outputs describe smoothed_time, later than smoothing_lag says until that lag has passed"),
                ),
            };
            shell.log(status, category, &text);
        }
    }

    /// The outputs are computed afresh at the next get (after a restored FMU state).
    pub(crate) fn mark_outputs_stale(&mut self) {
        self.outputs_stale = true;
    }

    /// Before a get: computes the outputs of the current time and inputs if
    /// anything changed since they were last computed. A read that cannot be
    /// computed sets the estimates to NaN and says why.
    pub fn refresh_outputs(&mut self, shell: &mut Shell) {
        if !self.outputs_stale || shell.state != ModelState::StepComplete {
            return;
        }
        self.outputs_stale = false;
        self.load_measurement(shell);
        self.load_controls(&shell.values);
        let Some(estimation) = self.estimation.as_mut() else { return };
        let p = Parameters::new(&self.descriptor.variables, &shell.values);
        let build_noise = self.descriptor.build_noise;
        let noise_over = |dt: f64| build_noise(&p, dt);
        let inputs = self.inputs_set.then_some((self.measurement.as_slice(), self.controls.as_slice()));
        let failed = match estimation.read(shell.time, inputs, &noise_over) {
            Ok(reading) => {
                write_outputs(&self.descriptor, &mut shell.values, Some(&reading));
                if reading.plausible {
                    // Sized once, at the first read: later reads allocate nothing.
                    self.last_plausible.clone_from(&shell.values);
                } else {
                    hold_last_plausible(&self.descriptor, &mut shell.values, &self.last_plausible);
                }
                None
            }
            Err(why) => Some(why),
        };
        if let Some(why) = failed {
            write_outputs(&self.descriptor, &mut shell.values, None);
            shell.log(
                Fmi2Status::Warning,
                "logStatusWarning",
                &format!("the outputs at t = {} s are NaN: {why}", shell.time),
            );
        }
    }

    fn sample_time(&self, shell: &Shell) -> f64 {
        Parameters::new(&self.descriptor.variables, &shell.values).get("sample_time").unwrap_or(f64::NAN)
    }

    /// Copies the control inputs into the controls vector (`fmi2SetReal` keeps them finite).
    fn load_controls(&mut self, values: &[f64]) {
        for (v, &x) in self.descriptor.variables.iter().zip(values) {
            if let Role::Control(j) = v.role {
                self.controls[j] = x;
            }
        }
    }

    /// Copies the inputs into the measurement vector: NaN for an input never
    /// set (its start value is no measurement).
    fn standing_measurement(&mut self, values: &[f64]) {
        for (v, &x) in self.descriptor.variables.iter().zip(values) {
            if let Role::Measurement(row) = v.role {
                self.measurement[row] = if self.input_ever_set[row] { x } else { f64::NAN };
            }
        }
    }

    /// [`Estimating::standing_measurement`], reporting each channel's first missing value.
    fn load_measurement(&mut self, shell: &Shell) {
        self.standing_measurement(&shell.values);
        for v in &self.descriptor.variables {
            if let Role::Measurement(row) = v.role {
                let (ever_set, z) = (self.input_ever_set[row], self.measurement[row]);
                if !z.is_finite() && !self.missing_reported[row] && !v.intermittent {
                    self.missing_reported[row] = true;
                    let what = if ever_set { format!("is {z}") } else { "has never been set".to_string() };
                    shell.log(
                        Fmi2Status::Warning,
                        "logStatusWarning",
                        &format!(
                            "input {} {what} at t = {}: treated as missing (reported once per input)",
                            v.name, shell.time
                        ),
                    );
                }
            }
        }
    }
}

/// Puts the estimates of the last plausible reading back into the output
/// values (the counts, flags and statuses stay the reading's), the filter not healthy.
fn hold_last_plausible(descriptor: &Descriptor, values: &mut [f64], last: &[f64]) {
    for ((v, x), &held) in descriptor.variables.iter().zip(values.iter_mut()).zip(last) {
        match v.role {
            Role::Estimate(_)
            | Role::EstimateStd(_)
            | Role::Smoothed(_)
            | Role::SmoothedStd(_)
            | Role::SmoothedTime
            | Role::Derived(_) => *x = held,
            Role::FilterHealthy => *x = 0.0,
            _ => {}
        }
    }
}

/// Writes a reading into the output values: the estimates, their standard
/// deviations, the NIS, the counts and the flags; without one (a read that
/// could not be computed) the estimates and the NIS are NaN and the filter is
/// not healthy, the counts stay.
fn write_outputs(descriptor: &Descriptor, values: &mut [f64], reading: Option<&Reading<'_>>) {
    let mut derived = [f64::NAN; MAX_DERIVED];
    if let Some(r) = reading {
        (descriptor.derive)(&Parameters::new(&descriptor.variables, values), r, &mut derived);
    }
    for (v, x) in descriptor.variables.iter().zip(values.iter_mut()) {
        match (v.role, reading) {
            (Role::Estimate(i), Some(r)) => *x = r.belief.mean()[i],
            (Role::EstimateStd(i), Some(r)) => *x = r.belief.variance(i).max(0.0).sqrt(),
            (Role::Nis, Some(r)) => *x = r.nis,
            (Role::ProcessNoiseScale, Some(r)) => *x = r.process_noise_scale,
            (Role::SkippedMeasurements, Some(r)) => *x = r.skipped as f64,
            (Role::RejectedMeasurements, Some(r)) => *x = r.rejected as f64,
            (Role::ChannelFault(row), Some(r)) => *x = f64::from(u8::from(r.faulty[row])),
            (Role::InputStatus(row), Some(r)) => {
                *x = f64::from(status_value(r.statuses.get(row).copied().unwrap_or(RowOutcome::Missing)));
            }
            (Role::FilterHealthy, Some(r)) => *x = f64::from(u8::from(r.healthy)),
            (Role::Smoothed(a), Some(r)) => {
                *x = r.smoothed.map_or_else(|| r.belief.mean()[descriptor.smoothed_states[a]], |s| s.means[a]);
            }
            (Role::SmoothedStd(a), Some(r)) => {
                let variance =
                    r.smoothed.map_or_else(|| r.belief.variance(descriptor.smoothed_states[a]), |s| s.variances[a]);
                *x = variance.max(0.0).sqrt();
            }
            (Role::SmoothedTime, Some(r)) => *x = r.smoothed.map_or_else(|| r.belief.time(), |s| s.time),
            (Role::Derived(k), _) => *x = derived.get(k).copied().unwrap_or(f64::NAN),
            (
                Role::Estimate(_)
                | Role::EstimateStd(_)
                | Role::Nis
                | Role::ProcessNoiseScale
                | Role::Smoothed(_)
                | Role::SmoothedStd(_)
                | Role::SmoothedTime,
                None,
            ) => *x = f64::NAN,
            (Role::FilterHealthy, None) => *x = 0.0,
            _ => {}
        }
    }
}

/// Builds the filter an instance with these parameter values runs, its
/// belief at `start_time` (also what tools that run an FMU's estimator on a log
/// build: the tuning command).
pub fn build_filter(
    descriptor: &Descriptor,
    values: &[f64],
    start_time: f64,
) -> Result<Box<dyn StateEstimator>, String> {
    let p = Parameters::new(&descriptor.variables, values);
    let kind = estimators::filter_kind(p.get("filter")?)?;
    let sample_time = p.positive("sample_time")?;
    let ukf = UnscentedParams { alpha: p.get("ukf_alpha")?, beta: p.get("ukf_beta")?, kappa: p.get("ukf_kappa")? };
    let noise = (descriptor.build_noise)(&p, sample_time)?;
    let mut filter = (descriptor.build_filter)(&p, kind, ukf, noise)?;
    // Move the belief to the start time without touching its numbers.
    let mut at_start = filter.snapshot();
    at_start.time = start_time;
    filter.restore(&at_start).map_err(|e| e.to_string())?;
    Ok(filter)
}

/// Builds the supervisor an instance with these parameter values runs over a filter of
/// `state_dim` states: the gate, the fault flags, the jumps and the adaptation as set.
/// `prior` is the instance's filter at the start, whose prior gives the plausible range
/// (`plausibility.rs`) where the estimator's parameters do not.
pub fn build_supervisor(
    descriptor: &Descriptor,
    values: &[f64],
    prior: &dyn StateEstimator,
) -> Result<Supervisor, String> {
    let state_dim = prior.state_dim();
    let plausible = plausibility::plausible_range(descriptor, values, prior)?;
    let p = Parameters::new(&descriptor.variables, values);
    let count = |name: &str| -> Result<u32, String> { Ok(p.get(name)? as u32) };
    let settings = SupervisorSettings {
        gate_probability: p.get("gate_probability")?,
        fault_after: count("fault_after")?,
        reacquire_after: count("reacquire_after")?,
        stuck_after: count("stuck_after")?,
        window: count("consistency_window")? as usize,
        consistency_margin: p.get("consistency_margin")?,
        max_inflation: p.get("max_inflation")?,
        jumps: p.get("take_jumps")? != 0.0,
        show_single_row_jumps: p.get("show_single_row_jumps")? != 0.0,
        change_memory: count("change_memory")?,
        adaptation_window: count("adaptation_window")? as usize,
        min_process_noise_scale: p.get("min_process_noise_scale")?,
        max_process_noise_scale: p.get("max_process_noise_scale")?,
        // Not parameters: each FMU's own (S4 leaves an inconsistent telegram out, the others name it;
        // S2 and S3, whose unknown inputs are each a wheel's own force, open only those a failing row sees).
        wiring_sigmas: descriptor.supervision.wiring_sigmas,
        wiring_leaves_out: descriptor.supervision.wiring_leaves_out,
        wiring_signatures: descriptor.supervision.wiring_signatures,
        local_jumps: descriptor.supervision.local_jumps,
        ..SupervisorSettings::default()
    };
    let mut supervisor = Supervisor::new(settings, descriptor.measurement_dim())
        .and_then(|s| s.with_jump_states(state_dim, descriptor.unknown_inputs))
        .map_err(|e| e.to_string())?
        .with_plausible_range(plausible);
    if let Some(steps) = (descriptor.build_steps)(&p)? {
        supervisor = supervisor.with_steps(steps).map_err(|e| e.to_string())?;
    }
    Ok(supervisor)
}

/// The estimation of an instance with these parameter values from `start_time`:
/// the filter, its twin for reads, the grid and the input timing.
/// `controls`: those standing at the start.
pub(crate) fn build_estimation(
    descriptor: &Descriptor,
    values: &[f64],
    start_time: f64,
    controls: &[f64],
) -> Result<Estimation, String> {
    let p = Parameters::new(&descriptor.variables, values);
    let timing = InputTiming::from_value(p.get("input_timing")?)?;
    let sample_time = p.positive("sample_time")?;
    let filter = build_filter(descriptor, values, start_time)?;
    let n = filter.state_dim();
    let supervisor = build_supervisor(descriptor, values, filter.as_ref())?;
    let reader = build_filter(descriptor, values, start_time)?;
    if filter.snapshot().input.len() != controls.len() {
        return Err(format!(
            "the model has {} known inputs, the FMU {} controls",
            filter.snapshot().input.len(),
            controls.len()
        ));
    }
    let lag = smoothing_lag_samples(&p, sample_time, n, descriptor.smoothed_states.len())?;
    let smoothing = (lag > 0).then_some((descriptor.smoothed_states, lag));
    Estimation::new(filter, reader, start_time, sample_time, timing, supervisor, controls, smoothing)
        .map_err(|e| e.to_string())
}

/// The most memory the fixed-lag smoother of an instance may hold (bytes).
const MAX_SMOOTHING_MEMORY: f64 = 256.0 * 1024.0 * 1024.0;

/// `smoothing_lag` in whole samples (at least one when it is not 0), refused
/// when the smoother of `p` of the `n` states would hold more than
/// [`MAX_SMOOTHING_MEMORY`].
fn smoothing_lag_samples(p: &Parameters, sample_time: f64, n: usize, smoothed: usize) -> Result<usize, String> {
    let lag = p.non_negative("smoothing_lag")?;
    if lag == 0.0 {
        return Ok(0);
    }
    let samples = (lag / sample_time).round().max(1.0);
    let bytes = (samples + 1.0) * ((n + 2) * smoothed + 1) as f64 * 8.0;
    if bytes > MAX_SMOOTHING_MEMORY {
        return Err(format!(
            "smoothing_lag = {lag} s is {samples} samples, whose smoother would hold {:.0} MiB (at most {:.0})",
            bytes / 1048576.0,
            MAX_SMOOTHING_MEMORY / 1048576.0
        ));
    }
    Ok(samples as usize)
}
