//! One FMU instance: everything per instance, nothing global. The C ABI layer
//! (`lib.rs`) checks pointers and the call order and then calls in here.
//!
//! An instance is the shell every FMU of the binary shares ([`Shell`]: the
//! values, the life-cycle state, the times and the one logging path) and what
//! the FMU does ([`Behaviour`]): estimate (`estimating.rs`) or simulate a plant
//! (`simulating.rs`). The shell checks what is the same for both (the call
//! order, value references, types, bounds, the communication points) before
//! the behaviour sees a call.

use std::ffi::CString;

use crate::catalogue::Fmu;
use crate::estimating::Estimating;
use crate::ffi::{Fmi2CallbackLogger, Fmi2ComponentEnvironment, Fmi2Status};
use crate::simulating::Simulating;
use crate::state::ModelState;
use crate::variables::{Causality, Variability, Variable};

/// The log categories of `<LogCategories>`.
pub const LOG_CATEGORIES: [(&str, &str); 4] = [
    ("logEvents", "initialisation, resets, FMU state, and notes on the inputs"),
    ("logStatusWarning", "messages with status fmi2Warning"),
    ("logStatusError", "messages with status fmi2Error or fmi2Discard"),
    ("logStatusFatal", "messages with status fmi2Fatal"),
];

/// What every instance has, whatever the FMU does.
pub struct Shell {
    name: CString,
    env: Fmi2ComponentEnvironment,
    logger: Fmi2CallbackLogger,
    debug_logging: bool,
    categories: [bool; LOG_CATEGORIES.len()],
    pub(crate) state: ModelState,
    /// One per variable, by value reference.
    pub(crate) values: Vec<f64>,
    pub(crate) start_time: f64,
    pub(crate) stop_time: Option<f64>,
    pub(crate) time: f64,
    pub(crate) last_successful_time: f64,
}

/// What the FMU does.
pub enum Behaviour {
    /// An estimator FMU.
    Estimator(Box<Estimating>),
    /// A plant FMU.
    Plant(Box<Simulating>),
}

/// One instance of an FMU of this binary.
pub struct Instance {
    pub(crate) shell: Shell,
    pub(crate) behaviour: Behaviour,
    /// In initialisation mode: the outputs are not those of the current parameters and
    /// inputs (computed at the next get, not at every set: building a plant can take long).
    initial_outputs_stale: bool,
}

// SAFETY: the environment pointer is only handed back to the importer's logger;
// FMI requires the importer to call one instance from one thread at a time.
unsafe impl Send for Instance {}

impl Shell {
    /// Sends a message to the importer's logger, if its category is enabled
    /// (failures — discard, error, fatal — are always sent: they say what
    /// failed and when). The one path every message takes.
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
}

impl Instance {
    pub fn new(
        fmu: Fmu,
        name: CString,
        env: Fmi2ComponentEnvironment,
        logger: Fmi2CallbackLogger,
        logging_on: bool,
    ) -> Self {
        let shell = Shell {
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
            last_successful_time: 0.0,
        };
        let behaviour = match fmu {
            Fmu::Estimator(d) => Behaviour::Estimator(Box::new(Estimating::new(d))),
            Fmu::Plant(d) => Behaviour::Plant(Box::new(Simulating::new(d))),
        };
        let mut instance = Self { shell, behaviour, initial_outputs_stale: false };
        instance.reset();
        instance
    }

    /// The variables; value reference = position.
    pub fn variables(&self) -> &[Variable] {
        match &self.behaviour {
            Behaviour::Estimator(e) => &e.descriptor.variables,
            Behaviour::Plant(p) => &p.descriptor.variables,
        }
    }

    /// The GUID of the FMU.
    pub fn guid(&self) -> &str {
        match &self.behaviour {
            Behaviour::Estimator(e) => e.descriptor.guid(),
            Behaviour::Plant(p) => p.descriptor.guid(),
        }
    }

    pub fn log(&self, status: Fmi2Status, category: &str, message: &str) {
        self.shell.log(status, category, message);
    }

    pub fn error(&self, message: &str) -> Fmi2Status {
        self.shell.error(message)
    }

    /// Back to the state after `fmi2Instantiate` (logging settings kept).
    pub fn reset(&mut self) {
        let shell = &mut self.shell;
        shell.state = ModelState::Instantiated;
        shell.start_time = 0.0;
        shell.stop_time = None;
        shell.time = 0.0;
        shell.last_successful_time = 0.0;
        match &mut self.behaviour {
            Behaviour::Estimator(e) => {
                shell.values = e.descriptor.variables.iter().map(|v| v.start.unwrap_or(f64::NAN)).collect();
                e.reset(shell);
            }
            Behaviour::Plant(p) => {
                shell.values = p.descriptor.variables.iter().map(|v| v.start.unwrap_or(f64::NAN)).collect();
                p.reset();
            }
        }
    }

    /// `fmi2SetDebugLogging`.
    pub fn set_debug_logging(&mut self, on: bool, categories: &[&str]) -> Fmi2Status {
        if let Some(unknown) = categories.iter().find(|c| !LOG_CATEGORIES.iter().any(|(n, _)| n == *c)) {
            let known: Vec<&str> = LOG_CATEGORIES.iter().map(|(n, _)| *n).collect();
            return self
                .error(&format!("fmi2SetDebugLogging: unknown log category '{unknown}'; known: {}", known.join(", ")));
        }
        self.shell.debug_logging = on;
        for (i, (name, _)) in LOG_CATEGORIES.iter().enumerate() {
            if categories.is_empty() || categories.contains(name) {
                self.shell.categories[i] = on;
            }
        }
        Fmi2Status::Ok
    }

    // ----- values -----

    /// Checks that variable `vr` may be set now, returning its index.
    pub fn check_settable(&self, vr: u32) -> Result<usize, String> {
        let index = vr as usize;
        let var = self.variables().get(index).ok_or_else(|| self.unknown(vr))?;
        match (var.causality, var.variability, self.shell.state) {
            (Causality::Output, _, _) => Err(format!("variable {} (vr {vr}) is an output and cannot be set", var.name)),
            (Causality::Parameter, Variability::Fixed, ModelState::StepComplete) => Err(format!(
                "variable {} (vr {vr}) is a fixed parameter: set it before fmi2ExitInitializationMode",
                var.name
            )),
            _ => Ok(index),
        }
    }

    pub fn unknown(&self, vr: u32) -> String {
        let n = self.shell.values.len();
        format!("unknown value reference {vr} (the FMU has {n} variables, 0 … {})", n - 1)
    }

    /// Applies a set of new values at once (already checked by type, bounds and
    /// role): the behaviour may refuse the whole call, and then nothing changes.
    pub fn set_values(&mut self, updates: &[(usize, f64)]) -> Fmi2Status {
        let old: Vec<(usize, f64)> = updates.iter().map(|&(i, _)| (i, self.shell.values[i])).collect();
        for &(i, v) in updates {
            self.shell.values[i] = v;
        }
        match &mut self.behaviour {
            Behaviour::Estimator(e) => e.values_set(&mut self.shell, updates, &old),
            Behaviour::Plant(p) => p.values_set(&mut self.shell, updates, &old),
        }
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
        let shell = &mut self.shell;
        shell.start_time = start;
        shell.stop_time = stop;
        shell.time = start;
        shell.last_successful_time = start;
        Fmi2Status::Ok
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_initialization(&mut self) {
        self.shell.state = ModelState::InitializationMode;
        self.shell.time = self.shell.start_time;
        self.initial_outputs_stale = true;
    }

    /// `fmi2ExitInitializationMode`: the behaviour builds what it runs from the parameters.
    pub fn exit_initialization(&mut self) -> Fmi2Status {
        match &mut self.behaviour {
            Behaviour::Estimator(e) => e.exit_initialization(&mut self.shell),
            Behaviour::Plant(p) => p.exit_initialization(&mut self.shell),
        }
    }

    /// In initialisation mode, after a set: the outputs are computed afresh at the next get.
    pub fn mark_initial_outputs_stale(&mut self) {
        self.initial_outputs_stale = true;
    }

    /// In initialisation mode the outputs show what the current parameters start from.
    fn refresh_initial_outputs(&mut self) {
        self.initial_outputs_stale = false;
        match &mut self.behaviour {
            Behaviour::Estimator(e) => e.refresh_initial_outputs(&mut self.shell),
            Behaviour::Plant(p) => p.refresh_initial_outputs(&mut self.shell),
        }
    }

    /// `fmi2DoStep`: the communication point must be the FMU's time, the step
    /// positive and within the stop time; the behaviour steps, and on `fmi2OK`
    /// the time moves to `t + h`.
    pub fn do_step(&mut self, t: f64, h: f64) -> Fmi2Status {
        let time = self.shell.time;
        let tolerance = 1e-9 * time.abs().max(1.0);
        if !t.is_finite() || (t - time).abs() > tolerance {
            return self.error(&format!("fmi2DoStep: communication point {t} does not match the FMU time {time}"));
        }
        if !(h > 0.0 && h.is_finite()) {
            return self.error(&format!("fmi2DoStep: communication step size must be positive and finite, got {h}"));
        }
        if let Some(stop) = self.shell.stop_time {
            if t + h > stop + 1e-9 * stop.abs().max(1.0) {
                return self.error(&format!("fmi2DoStep: step to {} passes the stop time {stop}", t + h));
            }
        }
        let status = match &mut self.behaviour {
            Behaviour::Estimator(e) => e.do_step(&mut self.shell, t, h),
            Behaviour::Plant(p) => p.do_step(&mut self.shell, t, h),
        };
        // A warning (a lost filter: `plausibility.rs`) is a step made.
        if matches!(status, Fmi2Status::Ok | Fmi2Status::Warning) {
            self.shell.time = t + h;
            self.shell.last_successful_time = t + h;
        }
        status
    }

    /// `fmi2Terminate`: the outputs stay those of the final time.
    pub fn terminate(&mut self) {
        self.refresh_outputs();
        self.shell.state = ModelState::Terminated;
    }

    /// Before a get: the outputs of the current time and inputs (in initialisation mode,
    /// those the current parameters and inputs start from).
    pub fn refresh_outputs(&mut self) {
        if self.shell.state == ModelState::InitializationMode {
            if self.initial_outputs_stale {
                self.refresh_initial_outputs();
            }
            return;
        }
        match &mut self.behaviour {
            Behaviour::Estimator(e) => e.refresh_outputs(&mut self.shell),
            Behaviour::Plant(p) => p.refresh_outputs(&mut self.shell),
        }
    }

    /// `fmi2GetBooleanStatus(fmi2Terminated)`: the slave cannot go on (a failed estimator).
    pub fn asks_to_terminate(&self) -> bool {
        self.shell.state == ModelState::StepFailed
    }
}
