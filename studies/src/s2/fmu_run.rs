//! One S2 case through the packaged estimator FMU (`kalfmu_s2_wheel_rail`), driven as a
//! co-simulation master drives it ([`cosim::master`]). The FMU gets the user's
//! vehicle and the study's tuning as parameters, by name, as a user would set them in
//! their simulator; the log has the seven accelerations and the four true forces, and the
//! FMU's fixed-lag smoothed forces (`/smoothed`).

use std::collections::BTreeMap;
use std::path::Path;

use estimator::FilterKind;
use log_format::write::SignalSpec;
use start_values::StartValues;

use super::study::Tuning;
use cosim::fmu_driver::ImportedFmu;
use cosim::master::{self, Counts, Setup};
use truth::s2::cases::{Measurements, Scenario, Settings, Truth};
use truth::s2::parameters::Vehicle;

/// The FMU's identifier.
pub const IDENTIFIER: &str = "kalfmu_s2_wheel_rail";

/// The FMU's inputs, in the order of the measurement vector of eq. (7).
const INPUTS: [(&str, &str); 7] = [
    ("z_c_ddot", "measured bounce acceleration (up) of the car body, with sensor noise"),
    ("z_t1_ddot", "measured bounce acceleration (up) of the front bogie frame, with sensor noise"),
    ("z_t2_ddot", "measured bounce acceleration (up) of the rear bogie frame, with sensor noise"),
    ("z_w1_ddot", "measured acceleration (up) of the axle box of wheelset 1, with sensor noise"),
    ("z_w2_ddot", "measured acceleration (up) of the axle box of wheelset 2, with sensor noise"),
    ("z_w3_ddot", "measured acceleration (up) of the axle box of wheelset 3, with sensor noise"),
    ("z_w4_ddot", "measured acceleration (up) of the axle box of wheelset 4, with sensor noise"),
];

/// The FMU's outputs that are logged; the forces have their namesakes in the truth.
const OUTPUTS: [&str; 9] = ["F_N1", "F_N2", "F_N3", "F_N4", "F_N1_std", "F_N2_std", "F_N3_std", "F_N4_std", "nis"];

/// The FMU's forces, whose fixed-lag smoothed values are logged on `/smoothed`.
const SMOOTHED: [&str; 4] = ["F_N1", "F_N2", "F_N3", "F_N4"];

/// What the user sets in the FMU: their catalogue vehicle, the static wheel load as weighed,
/// the sample time, the smoothing lag ([`crate::smoothed::SMOOTHING_LAG`]) and the study's
/// tuning (its Real parameters; [`Tuning::fmu_integers`] has the others).
pub fn parameters(catalogue: &Vehicle, weighed: f64, tuning: &Tuning) -> Vec<(&'static str, f64)> {
    let mut p = catalogue.fmu_parameters().to_vec();
    p.extend([("static_wheel_load", weighed), ("sample_time", tuning.dt)]);
    p.push(("smoothing_lag", crate::smoothed::SMOOTHING_LAG));
    p.extend(tuning.fmu_parameters());
    p
}

/// One simulated case and how the user set up the FMU for it.
pub struct Simulated<'a> {
    /// The case on its track (`random`, `random/german-low`, …).
    pub scenario: Scenario,
    /// The study settings.
    pub settings: &'a Settings,
    /// The truth at the sample times.
    pub truth: &'a Truth,
    /// The noisy accelerations.
    pub measurements: &'a Measurements,
    /// The FMU's parameters ([`parameters`]).
    pub parameters: &'a [(&'static str, f64)],
    /// Its Integer parameters ([`Tuning::fmu_integers`]).
    pub integers: &'a [(&'static str, i32)],
    /// The user's start values over them.
    pub start_values: &'a StartValues,
}

/// Runs `kind` on a simulated case through the FMU and writes the log to `log`.
pub fn run(fmu: &ImportedFmu, kind: FilterKind, sim: &Simulated<'_>, log: &Path) -> anyhow::Result<Counts> {
    let Simulated { scenario, settings, truth, measurements, parameters, integers, start_values } = *sim;
    let forces: Vec<SignalSpec> = OUTPUTS[..4]
        .iter()
        .map(|n| {
            SignalSpec::new(
                n,
                &fmu.unit(n),
                "true wheel-rail force, as an instrumented wheelset's acquisition records it",
            )
        })
        .collect();
    let metadata = BTreeMap::from([
        ("study".to_string(), "S2".to_string()),
        ("case".to_string(), scenario.to_string()),
        ("seed".to_string(), settings.seed.to_string()),
        ("speed_km_h".to_string(), format!("{}", settings.speed * 3.6)),
        ("rate_hz".to_string(), settings.rate.to_string()),
        ("noise_fraction".to_string(), settings.noise_fraction.to_string()),
    ]);
    let setup = Setup {
        fmu,
        filter: kind,
        parameters,
        integers,
        start_values,
        inputs: &INPUTS,
        outputs: &OUTPUTS,
        smoothed: &SMOOTHED,
        truth: &forces,
        metadata,
    };
    master::run(
        &setup,
        &truth.time,
        1.0 / settings.rate,
        |k| measurements.accelerations[k].to_vec(),
        |k| truth.contact[k].to_vec(),
        log,
        |_| {},
    )
}
