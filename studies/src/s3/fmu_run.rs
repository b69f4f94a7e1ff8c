//! One S3 run through the packaged estimator FMU (`kalfmu_s3_wheel_rail_lr`), driven as a
//! co-simulation master drives it ([`cosim::master`]). The FMU gets the user's car and the
//! study's tuning as parameters, by name, as a user would set them in their simulator; a
//! user without deflection transducers never sets those inputs. The log has the inputs
//! set, the eight true forces and each wheelset's true sum and difference, which the FMU's
//! namesake outputs are compared with, and, when the run asks for them, the FMU's
//! fixed-lag smoothed forces (`/smoothed`).

use std::collections::BTreeMap;
use std::path::Path;

use estimator::models::{RollVehicle, WheelRailRoll};
use estimator::FilterKind;
use log_format::write::SignalSpec;
use start_values::StartValues;

use super::study::{forces_in_model_order, in_model_order, Sensors, Tuning};
use cosim::fmu_driver::ImportedFmu;
use cosim::master::{self, Counts, Setup};
use truth::s3::cases::{Case, Measurements, Settings, Truth, ACCELERATIONS, DEFLECTIONS};

/// The FMU's identifier.
pub const IDENTIFIER: &str = "kalfmu_s3_wheel_rail_lr";

/// The forces' outputs, each with its σ, then each wheelset's sum and difference with
/// theirs, and the run's NIS: what the log keeps of the FMU.
pub const OUTPUTS: [&str; 33] = [
    "F_NL1",
    "F_NR1",
    "F_NL2",
    "F_NR2",
    "F_NL3",
    "F_NR3",
    "F_NL4",
    "F_NR4",
    "F_NL1_std",
    "F_NR1_std",
    "F_NL2_std",
    "F_NR2_std",
    "F_NL3_std",
    "F_NR3_std",
    "F_NL4_std",
    "F_NR4_std",
    "F_sum1",
    "F_sum1_std",
    "F_diff1",
    "F_diff1_std",
    "F_sum2",
    "F_sum2_std",
    "F_diff2",
    "F_diff2_std",
    "F_sum3",
    "F_sum3_std",
    "F_diff3",
    "F_diff3_std",
    "F_sum4",
    "F_sum4_std",
    "F_diff4",
    "F_diff4_std",
    "nis",
];

/// The forces whose fixed-lag smoothed values are logged on `/smoothed`: the eight the FMU
/// smooths (it gives no smoothed sum or difference).
pub const SMOOTHED: [&str; 8] = ["F_NL1", "F_NR1", "F_NL2", "F_NR2", "F_NL3", "F_NR3", "F_NL4", "F_NR4"];

/// The true signals logged beside the estimates: the eight forces in the model's order
/// (`F_NL1, F_NR1, …`), then each wheelset's `F_sum<j>` and `F_diff<j>` (left minus right).
pub const TRUE_SIGNALS: [&str; 16] = [
    "F_NL1", "F_NR1", "F_NL2", "F_NR2", "F_NL3", "F_NR3", "F_NL4", "F_NR4", "F_sum1", "F_diff1", "F_sum2", "F_diff2",
    "F_sum3", "F_diff3", "F_sum4", "F_diff4",
];

/// The inputs a user with `sensors` sets, in the model's row order, with the logs'
/// descriptions.
fn inputs(sensors: Sensors) -> Vec<(&'static str, &'static str)> {
    let rows = match sensors {
        Sensors::Accelerations => WheelRailRoll::ACCELERATIONS,
        Sensors::WithDeflections => WheelRailRoll::ACCELERATIONS.start..WheelRailRoll::DEFLECTIONS.end,
    };
    rows.map(|row| {
        let description = if WheelRailRoll::DEFLECTIONS.contains(&row) {
            "measured primary deflection (compression positive), with sensor noise"
        } else {
            "measured vertical acceleration (up), with sensor noise"
        };
        (WheelRailRoll::MEASUREMENT_NAMES[row], description)
    })
    .collect()
}

/// The FMU's parameters of the user's car `vehicle` (its names for the vehicle's fields).
pub fn vehicle_parameters(vehicle: &RollVehicle) -> Vec<(&'static str, f64)> {
    let [damping, beyond, _] = vehicle.primary_damper.slopes();
    let [knee, _] = vehicle.primary_damper.breaks();
    vec![
        ("car_body_mass", vehicle.car_body_mass),
        ("car_body_pitch_inertia", vehicle.car_body_pitch_inertia),
        ("car_body_roll_inertia", vehicle.car_body_roll_inertia),
        ("bogie_mass", vehicle.bogie_mass),
        ("bogie_pitch_inertia", vehicle.bogie_pitch_inertia),
        ("bogie_roll_inertia", vehicle.bogie_roll_inertia),
        ("wheelset_mass", vehicle.wheelset_mass),
        ("wheelset_roll_inertia", vehicle.wheelset_roll_inertia),
        ("primary_stiffness", vehicle.primary_stiffness),
        ("primary_damping", damping),
        ("primary_damping_beyond", beyond),
        ("primary_damper_knee", knee),
        ("secondary_stiffness", vehicle.secondary_stiffness),
        ("secondary_damping", vehicle.secondary_damping),
        ("half_bogie_spacing", vehicle.half_bogie_spacing),
        ("half_wheelbase", vehicle.half_wheelbase),
        ("primary_half_span", vehicle.primary_half_span),
        ("secondary_half_span", vehicle.secondary_half_span),
        ("contact_half_span", vehicle.contact_half_span),
        ("static_wheel_load", vehicle.static_wheel_load),
    ]
}

/// What the user sets in the FMU: their car, the sample time and the tuning ([`run`] adds
/// the smoothing lag of a run that is smoothed).
pub fn parameters(vehicle: &RollVehicle, tuning: &Tuning) -> Vec<(&'static str, f64)> {
    let mut p = vehicle_parameters(vehicle);
    p.push(("sample_time", tuning.dt));
    p.extend(tuning.fmu_parameters());
    p
}

/// The true signals of [`TRUE_SIGNALS`] at sample `k`.
pub fn true_signals(truth: &Truth, k: usize) -> Vec<f64> {
    let contact = forces_in_model_order(&truth.contact[k]);
    let mut values = contact.to_vec();
    for j in 0..4 {
        values.extend([contact[2 * j] + contact[2 * j + 1], contact[2 * j] - contact[2 * j + 1]]);
    }
    values
}

/// One simulated case and how the user set up the FMU for it.
pub struct Simulated<'a> {
    /// The case.
    pub case: Case,
    /// The study settings.
    pub settings: &'a Settings,
    /// The truth at the sample times.
    pub truth: &'a Truth,
    /// The noisy sensors.
    pub measurements: &'a Measurements,
    /// Which of them the user has.
    pub sensors: Sensors,
    /// The FMU's parameters ([`parameters`]).
    pub parameters: &'a [(&'static str, f64)],
    /// The user's start values over them.
    pub start_values: &'a StartValues,
    /// Whether the FMU also smooths the forces (`smoothing_lag` =
    /// [`crate::smoothed::SMOOTHING_LAG`]), logged on `/smoothed`: a fixed-lag smoother of
    /// 42 states costs several times the filter's step.
    pub smoothed: bool,
}

/// Runs `kind` on a simulated case through the FMU and writes the log to `log`.
pub fn run(fmu: &ImportedFmu, kind: FilterKind, sim: &Simulated<'_>, log: &Path) -> anyhow::Result<Counts> {
    let Simulated { case, settings, truth, measurements, sensors, parameters, start_values, smoothed } = *sim;
    let mut parameters = parameters.to_vec();
    if smoothed {
        parameters.push(("smoothing_lag", crate::smoothed::SMOOTHING_LAG));
    }
    let truth_specs: Vec<SignalSpec> = TRUE_SIGNALS
        .iter()
        .map(|n| SignalSpec::new(n, "N", "true vertical wheel-rail force (sum, left − right difference) as recorded"))
        .collect();
    let metadata = BTreeMap::from([
        ("study".to_string(), "S3".to_string()),
        ("case".to_string(), case.to_string()),
        ("seed".to_string(), settings.seed.to_string()),
        ("speed_km_h".to_string(), format!("{}", settings.speed * 3.6)),
        ("rate_hz".to_string(), settings.rate.to_string()),
        ("noise_fraction".to_string(), settings.noise_fraction.to_string()),
        ("sensors".to_string(), sensors.label().to_string()),
    ]);
    let inputs = inputs(sensors);
    let setup = Setup {
        fmu,
        filter: kind,
        parameters: &parameters,
        integers: &[],
        start_values,
        inputs: &inputs,
        outputs: &OUTPUTS,
        smoothed: if smoothed { &SMOOTHED } else { &[] },
        truth: &truth_specs,
        metadata,
    };
    master::run(
        &setup,
        &truth.time,
        1.0 / settings.rate,
        |k| {
            let accelerations = in_model_order(&ACCELERATIONS, &measurements.accelerations[k], 0);
            let mut values = accelerations.to_vec();
            if sensors == Sensors::WithDeflections {
                values.extend(in_model_order(&DEFLECTIONS, &measurements.deflections[k], 20));
            }
            values
        },
        |k| true_signals(truth, k),
        log,
        |_| {},
    )
}
