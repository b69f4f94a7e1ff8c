//! The estimator FMUs. Each is a [`Descriptor`]: its variable table and the
//! two functions that turn parameter values into a filter. The C ABI and the
//! instance never change for a new estimator: adding one is adding a file
//! here and a line in [`all`].

pub(crate) mod s1_load;
mod s2_wheel_rail;
mod s3_wheel_rail_lr;
mod s4_maglev;
mod s5_missile;
mod wheel_rail;

use estimator::{FilterKind, Noise, QuantizedSteps, RowOutcome, StateEstimator, SupervisorSettings, UnscentedParams};

use crate::model_description;
use crate::timing::Reading;
use crate::variables::{check_table, EnumerationType, Kind, Parameters, Role, Variable};

/// `<DefaultExperiment>`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DefaultExperiment {
    /// Start time (s).
    pub start: f64,
    /// Stop time (s).
    pub stop: f64,
    /// Communication step (s).
    pub step: f64,
}

/// Builds the filter from the parameter values: `(parameters, kind, unscented, noise)`.
pub type BuildFilter = fn(&Parameters, FilterKind, UnscentedParams, Noise) -> Result<Box<dyn StateEstimator>, String>;
/// Builds `Q` for a prediction over `dt` seconds and `R` from the (tunable)
/// parameter values: `dt` is `sample_time` for the filter, and shorter for the
/// prediction to a communication point between two samples.
pub type BuildNoise = fn(&Parameters, f64) -> Result<Noise, String>;
/// Computes the outputs beyond the states and their σ (`Role::Derived(k)` is
/// `out[k]`) at each read, from what the read shows and the parameter values.
pub type Derive = fn(&Parameters, &Reading<'_>, &mut [f64]);

/// The most derived outputs an estimator may have: a read computes them on the stack.
pub const MAX_DERIVED: usize = 16;

/// For an estimator whose outputs are its states and their σ only.
pub fn no_derived_outputs(_: &Parameters, _: &Reading<'_>, _: &mut [f64]) {}

/// The quantised bias steps the supervisor takes in, from the parameter values
/// (`estimator::QuantizedSteps`), if the estimator's channels have any.
pub type BuildSteps = fn(&Parameters) -> Result<Option<QuantizedSteps>, String>;

/// The largest plausible magnitude of the estimator's unknown inputs (and of
/// their σ) from the parameter values; `None`: the prior says it
/// (`plausibility.rs`).
pub type PlausibleBound = fn(&Parameters) -> Result<Option<f64>, String>;

/// For an estimator whose parameters hold no scale of its unknown inputs.
pub fn bound_from_prior(_: &Parameters) -> Result<Option<f64>, String> {
    Ok(None)
}

/// For an estimator whose channels take no quantised steps.
pub fn no_quantized_steps(_: &Parameters) -> Result<Option<QuantizedSteps>, String> {
    Ok(None)
}

/// Everything that makes one estimator FMU.
#[derive(Debug)]
pub struct Descriptor {
    /// `modelIdentifier` (also the name of the binary in the FMU).
    pub model_identifier: &'static str,
    /// `modelName`.
    pub model_name: &'static str,
    /// `description`.
    pub description: &'static str,
    /// HTML paragraphs on the study behind the estimator, for `documentation/index.html`;
    /// a default is stated as `{name}` only, written out from the variable's start value
    /// (`model_description::mentioned_variables`).
    pub documentation: &'static str,
    /// The variables; value reference = position.
    pub variables: Vec<Variable>,
    /// `<DefaultExperiment>`.
    pub default_experiment: DefaultExperiment,
    /// Filter construction.
    pub build_filter: BuildFilter,
    /// Noise construction.
    pub build_noise: BuildNoise,
    /// The start value of the `filter` parameter.
    pub default_filter: FilterKind,
    /// The start values of the supervisor's parameters (gate, fault flags, re-acquisition, consistency).
    pub supervision: SupervisorSettings,
    /// The derived outputs.
    pub derive: Derive,
    /// The quantised bias steps.
    pub build_steps: BuildSteps,
    /// The states of the model's unknown inputs (its augmented states): the
    /// only ones a jump moves (`estimator::Supervisor::with_jump_states`).
    pub unknown_inputs: &'static [usize],
    /// How large the unknown inputs can plausibly be (`plausibility.rs`).
    pub plausible_bound: PlausibleBound,
    /// The states the FMU also gives smoothed (`smoothing_lag`): what it is
    /// there to estimate. Each has an estimate output, whose name the smoothed
    /// outputs take with `_smoothed` and `_smoothed_std`.
    pub smoothed_states: &'static [usize],
    guid: String,
}

impl Descriptor {
    /// Completes a description: appends the variables every estimator has (an
    /// `<input>_status` per measurement input last, so that the value
    /// references of the rest do not depend on how many inputs there are) and
    /// derives the GUID from the whole table.
    fn finish(mut self) -> Self {
        self.variables.extend(common_variables(self.default_experiment.step, self.default_filter, &self.supervision));
        let smoothed: Vec<Variable> =
            self.smoothed_states.iter().enumerate().flat_map(|(a, &i)| self.smoothed_outputs(a, i)).collect();
        self.variables.extend(smoothed);
        let statuses: Vec<Variable> = self.variables.iter().filter_map(status_variable).collect();
        self.variables.extend(statuses);
        self.guid = guid_of(self.model_identifier, &self.variables);
        self
    }

    /// The outputs of the `a`-th smoothed state, state `i`, named after its
    /// estimate output (none if it has none: [`check`] refuses that).
    fn smoothed_outputs(&self, a: usize, i: usize) -> Vec<Variable> {
        let Some(estimate) = self.variables.iter().find(|v| v.role == Role::Estimate(i)) else { return Vec::new() };
        let unit = estimate.unit.unwrap_or("1");
        let named = |suffix: &str, role: Role, description: &'static str| Variable {
            name: format!("{}{suffix}", estimate.name).into(),
            ..Variable::output("", unit, role, description)
        };
        vec![
            named(
                "_smoothed",
                Role::Smoothed(a),
                "the estimate of this quantity at smoothed_time (smoothing_lag before the time read, on the sample \
                 grid) given the measurements up to the time read: the fixed-lag smoother's; the filter's own \
                 estimate when smoothing_lag is 0",
            ),
            named("_smoothed_std", Role::SmoothedStd(a), "standard deviation of the smoothed estimate"),
        ]
    }

    /// The GUID: a hash of the identifier, the crate version and the whole
    /// variable table, so any change of the interface changes it.
    pub fn guid(&self) -> &str {
        &self.guid
    }

    /// Number of measurement inputs.
    pub fn measurement_dim(&self) -> usize {
        self.variables.iter().filter(|v| matches!(v.role, Role::Measurement(_))).count()
    }

    /// Number of control inputs (the model's known input `u`).
    pub fn control_dim(&self) -> usize {
        self.variables.iter().filter(|v| matches!(v.role, Role::Control(_))).count()
    }
}

/// Every estimator FMU, built afresh: each instance owns its description, so
/// the library keeps no state at all between calls (not even a table it
/// would never free when an importer unloads it).
pub fn all() -> Vec<Descriptor> {
    vec![
        s1_load::descriptor(),
        s2_wheel_rail::descriptor(),
        s3_wheel_rail_lr::descriptor(),
        s4_maglev::descriptor(),
        s5_missile::descriptor(),
    ]
}

/// The estimator with this GUID.
pub fn by_guid(guid: &str) -> Option<Descriptor> {
    all().into_iter().find(|d| d.guid() == guid)
}

/// The filter kinds as an FMI enumeration (set and got with `fmi2SetInteger`).
pub static FILTER_KIND: EnumerationType = EnumerationType {
    name: "FilterKind",
    items: &[
        (1, "CKF", "cubature Kalman filter (Cholesky)"),
        (2, "SRCKF", "square-root cubature Kalman filter"),
        (3, "SVD_CKF", "cubature Kalman filter with the SVD as square root"),
        (4, "UKF", "scaled unscented Kalman filter (ukf_alpha, ukf_beta, ukf_kappa)"),
        (5, "EKF", "extended Kalman filter with finite-difference Jacobians"),
    ],
};

/// When the inputs set before `fmi2DoStep(t, h)` were measured (`timing.rs`).
pub static INPUT_TIMING: EnumerationType = EnumerationType {
    name: "InputTiming",
    items: &[
        (
            1,
            "communication_point",
            "at t: the plant's outputs of t set at communication point t (FMI's meaning; outputs have direct feedthrough)",
        ),
        (2, "step_end", "at t + h: for masters that step the plant first and hand over its outputs of t + h"),
    ],
};

/// Whether the master's call pattern fits `input_timing` (`input_timing_check.rs`),
/// the type of the `input_timing_check` output.
pub static INPUT_TIMING_CHECK: EnumerationType = EnumerationType {
    name: "InputTimingCheck",
    items: &[
        (
            0,
            "undecided",
            "no verdict (yet): no input set before fmi2ExitInitializationMode, or inputs that stood still over the \
             first two steps",
        ),
        (1, "fits", "the master's ordering fits the input_timing set"),
        (2, "other_fits", "the master's ordering fits the other input_timing (a warning says which to set)"),
    ],
};

/// What became of a measurement input in an update (`estimator::RowOutcome`), the
/// type of the `<input>_status` outputs.
pub static INPUT_STATUS: EnumerationType = EnumerationType {
    name: "InputStatus",
    items: &[
        (1, "used", "the update used the input"),
        (2, "rejected", "the innovation gate rejected the input: left out of the update, a gross error"),
        (3, "missing", "the input was NaN, infinite or never set (or no update has been made yet): left out"),
        (4, "stuck", "the input repeated its value bit for bit stuck_after times: left out as stuck"),
        (
            5,
            "inconsistent",
            "the input's innovations follow its own prediction or sit off zero where the other inputs contradict it \
             (a flipped sign, a unit, gravity left in, a swapped channel): left out until it agrees again",
        ),
    ],
};

/// The [`INPUT_STATUS`] value of a row outcome.
pub fn status_value(outcome: RowOutcome) -> i32 {
    match outcome {
        RowOutcome::Used => 1,
        RowOutcome::Rejected => 2,
        RowOutcome::Missing => 3,
        RowOutcome::Stuck => 4,
        RowOutcome::Inconsistent => 5,
    }
}

/// The row outcome of an [`INPUT_STATUS`] value, if it is one.
pub fn status_outcome(value: i32) -> Option<RowOutcome> {
    [RowOutcome::Used, RowOutcome::Rejected, RowOutcome::Missing, RowOutcome::Stuck, RowOutcome::Inconsistent]
        .into_iter()
        .find(|&outcome| status_value(outcome) == value)
}

/// The `<input>_status` output of a measurement input (`None` for any other variable).
fn status_variable(input: &Variable) -> Option<Variable> {
    let Role::Measurement(row) = input.role else { return None };
    Some(Variable::enumeration_output(
        format!("{}_status", input.name),
        &INPUT_STATUS,
        Role::InputStatus(row),
        "what became of the input in the update the outputs show: 1 used, 2 rejected by the gate, 3 missing \
         (NaN, infinite or never set), 4 stuck, 5 inconsistent with the other inputs (its wiring); read between \
         samples, that of the latest update; 3 before the first",
    ))
}

/// The filter kinds in the order of [`FILTER_KIND`]'s items.
const KINDS: [FilterKind; 5] =
    [FilterKind::Ckf, FilterKind::SrCkf, FilterKind::SvdCkf, FilterKind::Ukf, FilterKind::Ekf];

/// The filter kind for an enumeration value.
pub fn filter_kind(value: f64) -> Result<FilterKind, String> {
    KINDS
        .into_iter()
        .zip(FILTER_KIND.items)
        .find(|(_, (v, _, _))| f64::from(*v) == value)
        .map(|(k, _)| k)
        .ok_or_else(|| format!("parameter filter must be 1 (CKF) … 5 (EKF), got {value}"))
}

/// The enumeration value of a filter kind.
fn filter_value(kind: FilterKind) -> f64 {
    KINDS.iter().zip(FILTER_KIND.items).find(|(k, _)| **k == kind).map_or(f64::NAN, |(_, (v, _, _))| f64::from(*v))
}

/// The parameters and outputs every estimator FMU has; `sample_time` starts at the
/// estimator's default communication step, `filter` at its default method, the
/// supervisor's parameters at the estimator's `supervision`.
fn common_variables(sample_time: f64, filter: FilterKind, supervision: &SupervisorSettings) -> Vec<Variable> {
    let filter = filter_value(filter);
    vec![
        Variable {
            kind: Kind::Enumeration(&FILTER_KIND),
            start: Some(filter),
            unit: None,
            ..Variable::parameter("filter", "1", filter, "filter method: 1 CKF, 2 SRCKF, 3 SVD-CKF, 4 UKF, 5 EKF")
        },
        Variable::parameter("sample_time", "s", sample_time, "filter sample time: one predict + update per sample")
            .bounded(Some(1e-9), None),
        Variable {
            kind: Kind::Enumeration(&INPUT_TIMING),
            start: Some(1.0),
            unit: None,
            ..Variable::parameter(
                "input_timing",
                "1",
                1.0,
                "which time the inputs set before fmi2DoStep(t, h) are measured at: 1 t, 2 t + h (Gauss-Seidel masters)",
            )
        },
        Variable::parameter(
            "gate_probability",
            "1",
            supervision.gate_probability,
            "innovation gate: a measurement row of a consistent filter is rejected with probability 1 - this (1: no gate)",
        )
        .bounded(Some(0.5), Some(1.0)),
        Variable::integer_parameter(
            "fault_after",
            supervision.fault_after,
            (1, 1_000_000),
            "consecutive samples rejected, stuck or missing that make an input faulty",
        ),
        Variable::integer_parameter(
            "reacquire_after",
            supervision.reacquire_after,
            (1, 1_000_000),
            "consecutive gate failures of an input before the filter re-acquires (inflates its covariance)",
        ),
        Variable::integer_parameter(
            "stuck_after",
            supervision.stuck_after,
            (2, 1_000_000),
            "consecutive bit-identical values that make an input stuck (left out until it changes)",
        ),
        Variable::integer_parameter(
            "consistency_window",
            supervision.window as u32,
            (1, 1_000_000),
            "samples over which the normalised innovations are summed for filter_healthy",
        ),
        Variable::parameter(
            "consistency_margin",
            "1",
            supervision.consistency_margin,
            "how far above its chi-square bound the windowed innovation may go before the filter is inconsistent",
        )
        .bounded(Some(1.0), None),
        Variable::parameter(
            "max_inflation",
            "1",
            supervision.max_inflation,
            "the most re-acquisitions may multiply the covariance by in total until a sample passes the gate whole",
        )
        .bounded(Some(1.0), None),
        Variable::integer_parameter(
            "take_jumps",
            u32::from(supervision.jumps),
            (0, 1),
            "1: a failing input that a jump of the unknown inputs explains, and the other inputs do not contradict, \
             is used (the covariance opened in their directions) instead of rejected, and reviewed at the next sample",
        ),
        Variable::integer_parameter(
            "show_single_row_jumps",
            u32::from(supervision.show_single_row_jumps),
            (0, 1),
            "1: a jump that one input alone explains is shown at its sample (the review at the next sample still \
             retracts a spike); 0: the estimate holds until that review confirms it, so a spike moves nothing",
        ),
        Variable::integer_parameter(
            "change_memory",
            supervision.change_memory,
            (0, 1_000_000),
            "samples after a confirmed jump of an input during which a further jump that input alone explains is \
             shown at its sample (the change under way goes on, as an impact rings)",
        ),
        Variable::integer_parameter(
            "adaptation_window",
            supervision.adaptation_window as u32,
            (0, 1_000_000),
            "samples over which the scale on the process noise Q adapts to the innovations (0: no adaptation)",
        ),
        Variable::parameter(
            "min_process_noise_scale",
            "1",
            supervision.min_process_noise_scale,
            "the least the adaptation may scale the process noise given by",
        )
        .bounded(Some(1e-300), Some(1.0)),
        Variable::parameter(
            "max_process_noise_scale",
            "1",
            supervision.max_process_noise_scale,
            "the most the adaptation may scale the process noise given by",
        )
        .bounded(Some(1.0), None),
        Variable::parameter("ukf_alpha", "1", 1e-3, "UKF spread alpha (UKF only)").bounded(Some(1e-9), None),
        Variable::parameter("ukf_beta", "1", 2.0, "UKF prior-knowledge parameter beta (UKF only)"),
        Variable::parameter("ukf_kappa", "1", 0.0, "UKF secondary scaling kappa (UKF only)"),
        Variable::parameter(
            "smoothing_lag",
            "s",
            0.0,
            "how far back the <name>_smoothed outputs look: the estimate of that much earlier (rounded to whole \
             samples) given the measurements up to the time read, a fixed-lag smoother; 0: off, they are the filter's",
        )
        .bounded(Some(0.0), None),
        Variable::output(
            "smoothed_time",
            "s",
            Role::SmoothedTime,
            "the time the <name>_smoothed outputs describe: smoothing_lag before the time read, on the sample grid \
             (the start until that much has passed; the time read when smoothing_lag is 0)",
        ),
        Variable::output("nis", "1", Role::Nis, "normalised innovation squared of the last update"),
        Variable::output(
            "process_noise_scale",
            "1",
            Role::ProcessNoiseScale,
            "the scale the adaptation puts on the process noise Q given (1 without adaptation)",
        ),
        Variable::count(
            "skipped_measurements",
            Role::SkippedMeasurements,
            "measurement rows left out so far because the input was NaN, infinite or never set",
        ),
        Variable::count(
            "rejected_measurements",
            Role::RejectedMeasurements,
            "measurement rows left out so far by the innovation gate",
        ),
        Variable::flag(
            "filter_healthy",
            Role::FilterHealthy,
            "false while the filter is inconsistent (its windowed innovations exceed their bound) or lost (every input rejected), and once it has failed",
        ),
        Variable::enumeration_output(
            "input_timing_check".to_string(),
            &INPUT_TIMING_CHECK,
            Role::InputTimingCheck,
            "whether the master's ordering fits input_timing, from the inputs set in initialisation mode and before \
             the first two fmi2DoStep: 0 undecided, 1 it fits, 2 the other input_timing fits (a warning says so)",
        ),
    ]
}

/// `{xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx}` from two FNV-1a hashes of the interface.
pub(crate) fn guid_of(identifier: &str, variables: &[Variable]) -> String {
    let mut text = format!("{identifier}|{}", env!("CARGO_PKG_VERSION"));
    for v in variables {
        text.push_str(&format!(
            "|{}:{:?}:{:?}:{:?}:{:?}:{:?}",
            v.name, v.kind, v.causality, v.variability, v.unit, v.role
        ));
    }
    let fnv = |seed: u64| text.bytes().fold(seed, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3));
    let (a, b) = (fnv(0xcbf2_9ce4_8422_2325), fnv(0x8422_2325_cbf2_9ce4));
    format!(
        "{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}",
        a >> 32,
        (a >> 16) & 0xffff,
        a & 0xffff,
        b >> 48,
        b & 0xffff_ffff_ffff
    )
}

/// Checks the table invariants the rest of the crate relies on.
pub fn check(descriptor: &Descriptor) -> Result<(), String> {
    let vars = &descriptor.variables;
    check_table(vars)?;
    let m = descriptor.measurement_dim();
    for row in 0..m {
        let Some(input) = vars.iter().find(|v| v.role == Role::Measurement(row)) else {
            return Err(format!("measurement row {row} has no input"));
        };
        // An intermittent input is missing most of the time: a fault flag would say nothing.
        let flagged = vars.iter().any(|v| v.role == Role::ChannelFault(row));
        if flagged == input.intermittent {
            return Err(format!("measurement row {row} must have a fault flag output unless it is intermittent"));
        }
        if vars.iter().filter(|v| v.role == Role::InputStatus(row)).count() != 1 {
            return Err(format!("measurement row {row} must have exactly one status output"));
        }
    }
    for j in 0..descriptor.control_dim() {
        if !vars.iter().any(|v| v.role == Role::Control(j)) {
            return Err(format!("control {j} has no input"));
        }
    }
    for &i in descriptor.smoothed_states {
        if !vars.iter().any(|v| v.role == Role::Estimate(i)) {
            return Err(format!("smoothed state {i} has no estimate output to name its smoothed outputs after"));
        }
    }
    if vars.iter().any(|v| matches!(v.role, Role::Derived(k) if k >= MAX_DERIVED)) {
        return Err(format!("at most {MAX_DERIVED} derived outputs"));
    }
    for name in model_description::mentioned_variables(descriptor.documentation) {
        if !vars.iter().any(|v| v.name == name && v.start.is_some()) {
            return Err(format!("the documentation states the default of {name}, which is no parameter or input"));
        }
    }
    if !filter_value(descriptor.default_filter).is_finite() {
        return Err(format!("default filter {} is not a value of FilterKind", descriptor.default_filter));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_guid_changes_with_any_change_of_the_interface() {
        let d = &all()[0];
        assert_eq!(guid_of(d.model_identifier, &d.variables), d.guid());
        let mut renamed = d.variables.clone();
        renamed[0].name = "renamed".into();
        let mut retyped = d.variables.clone();
        retyped[0].unit = Some("m/s");
        let mut reordered = d.variables.clone();
        reordered.swap(0, 1);
        for changed in [renamed, retyped, reordered, d.variables[1..].to_vec()] {
            assert_ne!(guid_of(d.model_identifier, &changed), d.guid());
        }
        assert_ne!(guid_of("other_identifier", &d.variables), d.guid());
    }
}
