//! One FMU instance: everything per instance, nothing global. The C ABI layer
//! (`lib.rs`) checks pointers and the call order and then calls in here.
//!
//! Time: the filter runs one predict + update per `sample_time`, on the grid
//! `start + k·sample_time` (never accumulated, so it does not drift). A
//! communication step from `t` to `t + h` runs every sample of that grid in
//! `(t, t + h]` on the inputs as they were set for the step (held). When `h` is
//! not a multiple of the sample time the last samples do not coincide with the
//! communication points: the step still runs, the outputs are those of the
//! latest sample, and a warning says so once per instance.

use std::ffi::CString;

use estimator::{StateEstimator, UnscentedParams};

use crate::estimators::{self, Descriptor};
use crate::ffi::{Fmi2CallbackLogger, Fmi2ComponentEnvironment, Fmi2Status};
use crate::state::ModelState;
use crate::variables::{Causality, Parameters, Role, Variability};

/// The log categories of `<LogCategories>`.
pub const LOG_CATEGORIES: [(&str, &str); 4] = [
    ("logEvents", "initialisation, resets, FMU state, and notes on the inputs"),
    ("logStatusWarning", "messages with status fmi2Warning"),
    ("logStatusError", "messages with status fmi2Error or fmi2Discard"),
    ("logStatusFatal", "messages with status fmi2Fatal"),
];

/// One instance of an estimator FMU.
pub struct Instance {
    pub(crate) descriptor: Descriptor,
    name: CString,
    env: Fmi2ComponentEnvironment,
    logger: Fmi2CallbackLogger,
    debug_logging: bool,
    categories: [bool; LOG_CATEGORIES.len()],
    pub(crate) state: ModelState,
    pub(crate) values: Vec<f64>,
    pub(crate) start_time: f64,
    pub(crate) stop_time: Option<f64>,
    pub(crate) time: f64,
    /// Filter samples done since the start time.
    pub(crate) samples: u64,
    pub(crate) last_successful_time: f64,
    pub(crate) filter: Option<Box<dyn StateEstimator>>,
    measurement: Vec<f64>,
    /// Per measurement channel: a non-finite input was already reported.
    pub(crate) missing_reported: Vec<bool>,
    pub(crate) off_grid_reported: bool,
}

// SAFETY: the environment pointer is only handed back to the importer's logger;
// FMI requires the importer to call one instance from one thread at a time.
unsafe impl Send for Instance {}

impl Instance {
    pub fn new(
        descriptor: Descriptor,
        name: CString,
        env: Fmi2ComponentEnvironment,
        logger: Fmi2CallbackLogger,
        logging_on: bool,
    ) -> Self {
        let m = descriptor.measurement_dim();
        let mut instance = Self {
            descriptor,
            name,
            env,
            logger,
            debug_logging: logging_on,
            categories: [true; LOG_CATEGORIES.len()],
            state: ModelState::Instantiated,
            values: Vec::new(),
            start_time: 0.0,
            stop_time: None,
            time: 0.0,
            samples: 0,
            last_successful_time: 0.0,
            filter: None,
            measurement: vec![0.0; m],
            missing_reported: vec![false; m],
            off_grid_reported: false,
        };
        instance.reset();
        instance
    }

    /// Back to the state after `fmi2Instantiate` (logging settings kept).
    pub fn reset(&mut self) {
        self.state = ModelState::Instantiated;
        self.values = self.descriptor.variables.iter().map(|v| v.start.unwrap_or(f64::NAN)).collect();
        self.set_role(Role::SkippedMeasurements, 0.0);
        self.set_role(Role::FilterHealthy, 1.0);
        self.start_time = 0.0;
        self.stop_time = None;
        self.time = 0.0;
        self.samples = 0;
        self.last_successful_time = 0.0;
        self.filter = None;
        self.missing_reported.iter_mut().for_each(|r| *r = false);
        self.off_grid_reported = false;
    }

    // ----- logging: the one path every message takes -----

    /// Sends a message to the importer's logger, if its category is enabled
    /// (failures — discard, error, fatal — are always sent: they say what
    /// failed and when).
    pub fn log(&self, status: Fmi2Status, category: &str, message: &str) {
        let enabled = status >= Fmi2Status::Discard
            || (self.debug_logging
                && LOG_CATEGORIES.iter().zip(self.categories).any(|((name, _), on)| on && *name == category));
        let Some(logger) = self.logger else { return };
        if !enabled {
            return;
        }
        let category = CString::new(category).unwrap_or_default();
        let message = CString::new(message.replace('\0', " ")).unwrap_or_default();
        // SAFETY: the logger was given by the importer for this instance; all
        // strings are NUL-terminated and outlive the call; "%s" consumes exactly
        // the one argument passed.
        unsafe {
            logger(self.env, self.name.as_ptr(), status as i32, category.as_ptr(), c"%s".as_ptr(), message.as_ptr());
        }
    }

    /// Logs an error and returns `fmi2Error`.
    pub fn error(&self, message: &str) -> Fmi2Status {
        self.log(Fmi2Status::Error, "logStatusError", message);
        Fmi2Status::Error
    }

    /// `fmi2SetDebugLogging`.
    pub fn set_debug_logging(&mut self, on: bool, categories: &[&str]) -> Fmi2Status {
        if let Some(unknown) = categories.iter().find(|c| !LOG_CATEGORIES.iter().any(|(n, _)| n == *c)) {
            let known: Vec<&str> = LOG_CATEGORIES.iter().map(|(n, _)| *n).collect();
            return self
                .error(&format!("fmi2SetDebugLogging: unknown log category '{unknown}'; known: {}", known.join(", ")));
        }
        self.debug_logging = on;
        for (i, (name, _)) in LOG_CATEGORIES.iter().enumerate() {
            if categories.is_empty() || categories.contains(name) {
                self.categories[i] = on;
            }
        }
        Fmi2Status::Ok
    }

    // ----- values -----

    fn set_role(&mut self, role: Role, value: f64) {
        for (v, x) in self.descriptor.variables.iter().zip(self.values.iter_mut()) {
            if v.role == role {
                *x = value;
            }
        }
    }

    fn role_value(&self, role: Role) -> f64 {
        self.descriptor.variables.iter().zip(&self.values).find(|(v, _)| v.role == role).map_or(f64::NAN, |(_, x)| *x)
    }

    /// Checks that variable `vr` may be set now, returning its index.
    pub fn check_settable(&self, vr: u32) -> Result<usize, String> {
        let index = vr as usize;
        let var = self.descriptor.variables.get(index).ok_or_else(|| self.unknown(vr))?;
        match (var.causality, var.variability, self.state) {
            (Causality::Output, _, _) => Err(format!("variable {} (vr {vr}) is an output and cannot be set", var.name)),
            (Causality::Parameter, Variability::Fixed, ModelState::StepComplete) => Err(format!(
                "variable {} (vr {vr}) is a fixed parameter: set it before fmi2ExitInitializationMode",
                var.name
            )),
            _ => Ok(index),
        }
    }

    pub fn unknown(&self, vr: u32) -> String {
        format!(
            "unknown value reference {vr} (the FMU has {} variables, 0 … {})",
            self.values.len(),
            self.values.len() - 1
        )
    }

    /// Applies a set of new values at once (already type-checked): refuses the
    /// whole call, changing nothing, when a tunable parameter would make the
    /// noise invalid while the filter runs.
    pub fn set_values(&mut self, updates: &[(usize, f64)]) -> Fmi2Status {
        let old: Vec<(usize, f64)> = updates.iter().map(|&(i, _)| (i, self.values[i])).collect();
        for &(i, v) in updates {
            self.values[i] = v;
        }
        let tunable_changed =
            updates.iter().any(|&(i, _)| self.descriptor.variables[i].variability == Variability::Tunable);
        if self.state == ModelState::StepComplete && tunable_changed {
            let noise = (self.descriptor.build_noise)(&Parameters::new(&self.descriptor.variables, &self.values));
            let applied = noise.and_then(|n| match self.filter.as_mut() {
                Some(f) => f.set_noise(n).map_err(|e| e.to_string()),
                None => Ok(()),
            });
            if let Err(why) = applied {
                for (i, v) in old {
                    self.values[i] = v;
                }
                return self.error(&format!("tunable parameters refused, values unchanged: {why}"));
            }
            self.log(Fmi2Status::Ok, "logEvents", "tunable parameters applied to the filter noise");
        }
        Fmi2Status::Ok
    }

    // ----- life cycle -----

    /// `fmi2SetupExperiment`.
    pub fn setup_experiment(&mut self, start: f64, stop: Option<f64>) -> Fmi2Status {
        if !start.is_finite() {
            return self.error(&format!("fmi2SetupExperiment: start time must be finite, got {start}"));
        }
        if let Some(stop) = stop {
            if stop < start || stop.is_nan() {
                return self.error(&format!("fmi2SetupExperiment: stop time {stop} is before start time {start}"));
            }
        }
        self.start_time = start;
        self.stop_time = stop;
        self.time = start;
        self.last_successful_time = start;
        Fmi2Status::Ok
    }

    /// `fmi2ExitInitializationMode`: builds the filter from the parameters.
    pub fn exit_initialization(&mut self) -> Fmi2Status {
        match self.build_filter() {
            Ok(filter) => {
                self.filter = Some(filter);
                self.write_outputs();
                self.state = ModelState::StepComplete;
                self.log(
                    Fmi2Status::Ok,
                    "logEvents",
                    &format!(
                        "initialised: {} at t = {}",
                        self.filter.as_ref().map_or("", |f| f.kind().name()),
                        self.time
                    ),
                );
                Fmi2Status::Ok
            }
            Err(why) => self.error(&format!("fmi2ExitInitializationMode: cannot build the estimator: {why}")),
        }
    }

    fn build_filter(&self) -> Result<Box<dyn StateEstimator>, String> {
        build_filter(&self.descriptor, &self.values, self.start_time)
    }

    /// In initialisation mode the outputs show the prior of the current
    /// parameters (left as they were while the parameters do not build a filter).
    pub fn refresh_initial_outputs(&mut self) {
        if let Ok(filter) = self.build_filter() {
            self.filter = Some(filter);
            self.write_outputs();
            self.filter = None;
        }
    }

    pub fn sample_time(&self) -> f64 {
        Parameters::new(&self.descriptor.variables, &self.values).get("sample_time").unwrap_or(f64::NAN)
    }

    /// `fmi2DoStep`.
    pub fn do_step(&mut self, t: f64, h: f64) -> Fmi2Status {
        let tolerance = 1e-9 * self.time.abs().max(1.0);
        if !t.is_finite() || (t - self.time).abs() > tolerance {
            return self
                .error(&format!("fmi2DoStep: communication point {t} does not match the FMU time {}", self.time));
        }
        if !(h > 0.0 && h.is_finite()) {
            return self.error(&format!("fmi2DoStep: communication step size must be positive and finite, got {h}"));
        }
        if let Some(stop) = self.stop_time {
            if t + h > stop + 1e-9 * stop.abs().max(1.0) {
                return self.error(&format!("fmi2DoStep: step to {} passes the stop time {stop}", t + h));
            }
        }
        let ts = self.sample_time();
        let end = t + h;
        let grid_tolerance = 1e-9 * ts;
        self.load_measurement();
        loop {
            let next = self.start_time + (self.samples + 1) as f64 * ts;
            if next > end + grid_tolerance {
                break;
            }
            let filter = self.filter.as_mut().expect("a filter exists from StepComplete on");
            let result = filter.predict(&[], ts).and_then(|_| filter.update(&self.measurement).map(|_| ()));
            if let Err(e) = result {
                self.state = ModelState::StepFailed;
                self.set_role(Role::FilterHealthy, 0.0);
                self.last_successful_time = self.start_time + self.samples as f64 * ts;
                self.log(
                    Fmi2Status::Discard,
                    "logStatusError",
                    &format!(
                        "filter failed at t = {next} s (sample {}): {e}; the last good estimate is at t = {} s",
                        self.samples + 1,
                        self.last_successful_time
                    ),
                );
                return Fmi2Status::Discard;
            }
            self.samples += 1;
            let skipped = self.measurement.iter().filter(|z| !z.is_finite()).count();
            if skipped > 0 {
                let total = self.role_value(Role::SkippedMeasurements) + skipped as f64;
                self.set_role(Role::SkippedMeasurements, total);
            }
            self.write_outputs();
        }
        let last_sample = self.start_time + self.samples as f64 * ts;
        if end - last_sample > grid_tolerance && !self.off_grid_reported {
            self.off_grid_reported = true;
            self.log(
                Fmi2Status::Warning,
                "logStatusWarning",
                &format!(
                    "communication step ends at t = {end}, between filter samples (sample_time {ts}): outputs are those of the sample at t = {last_sample}; reported once"
                ),
            );
        }
        self.time = end;
        self.last_successful_time = end;
        Fmi2Status::Ok
    }

    /// Copies the inputs into the measurement vector, reporting each channel's
    /// first non-finite value.
    fn load_measurement(&mut self) {
        for (i, v) in self.descriptor.variables.iter().enumerate() {
            if let Role::Measurement(row) = v.role {
                let z = self.values[i];
                self.measurement[row] = z;
                if !z.is_finite() && !self.missing_reported[row] {
                    self.missing_reported[row] = true;
                    self.log(
                        Fmi2Status::Warning,
                        "logStatusWarning",
                        &format!(
                            "input {} is {z} at t = {}: treated as missing (reported once per input)",
                            v.name, self.time
                        ),
                    );
                }
            }
        }
    }

    /// Writes the estimates, their deviations and the NIS to the outputs.
    fn write_outputs(&mut self) {
        let Some(filter) = self.filter.as_ref() else { return };
        for (v, x) in self.descriptor.variables.iter().zip(self.values.iter_mut()) {
            match v.role {
                Role::Estimate(i) => *x = filter.mean()[i],
                Role::EstimateStd(i) => *x = filter.variance(i).max(0.0).sqrt(),
                Role::Nis => *x = filter.innovation().nis(),
                _ => {}
            }
        }
    }
}

/// Builds the filter an instance with these parameter values runs, its
/// belief at `start_time`.
pub(crate) fn build_filter(
    descriptor: &Descriptor,
    values: &[f64],
    start_time: f64,
) -> Result<Box<dyn StateEstimator>, String> {
    let p = Parameters::new(&descriptor.variables, values);
    let kind = estimators::filter_kind(p.get("filter")?)?;
    p.positive("sample_time")?;
    let ukf = UnscentedParams { alpha: p.get("ukf_alpha")?, beta: p.get("ukf_beta")?, kappa: p.get("ukf_kappa")? };
    let noise = (descriptor.build_noise)(&p)?;
    let mut filter = (descriptor.build_filter)(&p, kind, ukf, noise)?;
    // Move the belief to the start time without touching its numbers.
    let mut at_start = filter.snapshot();
    at_start.time = start_time;
    filter.restore(&at_start).map_err(|e| e.to_string())?;
    Ok(filter)
}
