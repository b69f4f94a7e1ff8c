//! One S5 flight through the packaged estimator FMU (`kalfmu_s5_missile`), driven as a
//! flight simulator drives it ([`cosim::master`]): at each 5 ms instant the twelve
//! measurements and the three deflections the control computer holds from then on. The
//! user sets the sensors' noise, the sample time and the UKF's spread; the rest is the
//! FMU's defaults, the study's set-up (`tests/s5_fmu_defaults.rs`). The log has the true
//! coefficients.

use std::collections::BTreeMap;
use std::path::Path;

use estimator::FilterKind;
use log_format::write::SignalSpec;
use start_values::StartValues;

use super::study::Tuning;
use cosim::fmu_driver::ImportedFmu;
use cosim::master::{self, Counts, Setup};
use truth::s5::flight::{Settings, Truth};
use truth::s5::parameters::NAMES;

/// The FMU's identifier.
pub const IDENTIFIER: &str = "kalfmu_s5_missile";

/// The FMU's inputs: the measurements of eq. (2), then the deflections.
const INPUTS: [(&str, &str); 15] = [
    ("omega_x", "measured roll rate, with sensor noise"),
    ("omega_y", "measured yaw rate, with sensor noise"),
    ("omega_z", "measured pitch rate, with sensor noise"),
    ("Nx", "measured axial overload (g), with sensor noise"),
    ("Ny", "measured normal overload (g), with sensor noise"),
    ("Nz", "measured lateral overload (g), with sensor noise"),
    ("phi", "measured pitch angle, with sensor noise"),
    ("psi", "measured yaw angle, with sensor noise"),
    ("gamma", "measured roll angle, with sensor noise"),
    ("h", "measured altitude, with sensor noise"),
    ("alpha", "measured angle of attack, with sensor noise"),
    ("beta", "measured sideslip, with sensor noise"),
    ("delta_x", "roll rudder deflection held from this instant"),
    ("delta_y", "pitch rudder deflection held from this instant"),
    ("delta_z", "yaw rudder deflection held from this instant"),
];

/// The FMU's outputs that are logged: the coefficients, their σ, and the NIS.
const OUTPUTS: [&str; 21] = [
    "Cx0", "Cx_a", "Cx_b", "Cx_d", "Cy0", "Cy_a", "Cy_d", "Cz0", "Cz_b", "Cz_d", "Cx0_std", "Cx_a_std", "Cx_b_std",
    "Cx_d_std", "Cy0_std", "Cy_a_std", "Cy_d_std", "Cz0_std", "Cz_b_std", "Cz_d_std", "nis",
];

/// What the user sets: the sample time, the UKF's spread and each sensor's noise.
pub fn parameters(settings: &Settings, tuning: &Tuning) -> Vec<(&'static str, f64)> {
    const SENSORS: [&str; 12] = [
        "r_omega_x_std",
        "r_omega_y_std",
        "r_omega_z_std",
        "r_Nx_std",
        "r_Ny_std",
        "r_Nz_std",
        "r_phi_std",
        "r_psi_std",
        "r_gamma_std",
        "r_h_std",
        "r_alpha_std",
        "r_beta_std",
    ];
    // The library's cubature rule for the UKF, as the study's in-process runs have it.
    let mut p = vec![("sample_time", settings.sample_time), ("ukf_alpha", 1.0), ("ukf_beta", 2.0), ("ukf_kappa", 0.0)];
    p.extend(SENSORS.into_iter().zip(tuning.sensor_std));
    p
}

/// Runs `kind` through the FMU on the flight `truth`, measured as `measurements`, and
/// writes the log to `log`.
pub fn run(
    fmu: &ImportedFmu,
    kind: FilterKind,
    settings: &Settings,
    truth: &Truth,
    measurements: &[[f64; 12]],
    start_values: &StartValues,
    log: &Path,
) -> anyhow::Result<Counts> {
    let tuning = Tuning::new(settings.noise_scale);
    let parameters = parameters(settings, &tuning);
    let coefficients: Vec<SignalSpec> =
        NAMES.iter().map(|n| SignalSpec::new(n, &fmu.unit(n), "true force coefficient in force")).collect();
    let metadata = BTreeMap::from([
        ("study".to_string(), "S5".to_string()),
        ("case".to_string(), "6dof".to_string()),
        ("seed".to_string(), settings.seed.to_string()),
        ("noise_scale".to_string(), settings.noise_scale.to_string()),
    ]);
    let setup = Setup {
        fmu,
        filter: kind,
        parameters: &parameters,
        integers: &[("rk4_substeps", 1)],
        start_values,
        inputs: &INPUTS,
        outputs: &OUTPUTS,
        truth: &coefficients,
        metadata,
    };
    master::run(
        &setup,
        &truth.time,
        settings.sample_time,
        |k| measurements[k].iter().chain(&truth.deflections[k]).copied().collect(),
        |k| truth.coefficients[k].to_vec(),
        log,
        |_| {},
    )
}
