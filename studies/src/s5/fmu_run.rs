//! One S5 flight through the packaged estimator FMU (`kalfmu_s5_missile`), driven as a
//! flight simulator drives it ([`cosim::master`]): at each 5 ms instant the twelve
//! measurements and the three deflections the control computer holds from then on. The
//! user sets the sample time and the study's tuning (the sensors' and the process noise,
//! the prior, the UKF's spread, the model's RK4 steps); the rest is the FMU's defaults,
//! the study's set-up (`tests/s5_fmu_defaults.rs`), and the user's start values go over
//! both. The log has the true coefficients, and the FMU's fixed-lag smoothed coefficients
//! (`/smoothed`, `smoothing_lag` [`crate::smoothed::SMOOTHING_LAG`]: 20 samples).

use std::collections::BTreeMap;
use std::path::Path;

use estimator::FilterKind;
use log_format::write::SignalSpec;
use start_values::StartValues;

use super::study::{Tuning, MOTION_NOISE_PARAMETERS, PRIOR_PARAMETERS, PRIOR_STD_PARAMETERS, SENSOR_NOISE_PARAMETERS};
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

/// What the user sets: the sample time, and every number of `tuning` but its RK4 steps
/// (an Integer, [`integers`]): the UKF's spread, each sensor's noise, the process noise and
/// the prior. The FMU's defaults are the same (`tests/s5_fmu_defaults.rs`); written here,
/// a start value the in-process filter takes ([`Tuning::set`]) changes both alike.
pub fn parameters(settings: &Settings, tuning: &Tuning) -> Vec<(&'static str, f64)> {
    let u = tuning.unscented;
    let mut p = vec![("sample_time", settings.sample_time), ("ukf_alpha", u.alpha), ("ukf_beta", u.beta)];
    p.push(("ukf_kappa", u.kappa));
    p.extend(SENSOR_NOISE_PARAMETERS.into_iter().zip(tuning.sensor_std));
    p.extend(MOTION_NOISE_PARAMETERS.into_iter().zip(tuning.motion_std));
    p.push(("q_coefficient_relative_std", tuning.coefficient_relative_std));
    p.extend(PRIOR_PARAMETERS.into_iter().zip(tuning.prior_mean));
    p.extend(PRIOR_STD_PARAMETERS.into_iter().zip(tuning.prior_std));
    p
}

/// The Integer parameters of `tuning`: the filter model's RK4 steps per sample.
pub fn integers(tuning: &Tuning) -> Vec<(&'static str, i32)> {
    // `Tuning::set` keeps it a positive integer below u32::MAX; the FMU's bound is i32's.
    vec![("rk4_substeps", i32::try_from(tuning.rk4_substeps).unwrap_or(i32::MAX))]
}

/// The flight an FMU run is of: its truth, its measurements, the manoeuvre's name and the
/// case (the stem of its logs).
pub struct Flown<'a> {
    /// The truth.
    pub truth: &'a Truth,
    /// The truth measured.
    pub measurements: &'a [[f64; 12]],
    /// The manoeuvre's name (`truth::s5::manoeuvre::Manoeuvre::NAMES`).
    pub manoeuvre: &'a str,
    /// The case, the log's metadata `case`: `6dof`, `6dof_roll_turn`.
    pub case: &'a str,
}

/// Runs `kind` with `tuning` through the FMU on the flight `flown` and writes the log to
/// `log`, with the FMU's smoothed coefficients (`smoothing_lag` set beside [`parameters`]:
/// not a number of the tuning, the in-process filter has none).
pub fn run(
    fmu: &ImportedFmu,
    kind: FilterKind,
    settings: &Settings,
    tuning: &Tuning,
    flown: &Flown<'_>,
    start_values: &StartValues,
    log: &Path,
) -> anyhow::Result<Counts> {
    let Flown { truth, measurements, manoeuvre, case } = *flown;
    let mut parameters = parameters(settings, tuning);
    parameters.push(("smoothing_lag", crate::smoothed::SMOOTHING_LAG));
    let integers = integers(tuning);
    let coefficients: Vec<SignalSpec> =
        NAMES.iter().map(|n| SignalSpec::new(n, &fmu.unit(n), "true force coefficient in force")).collect();
    let metadata = BTreeMap::from([
        ("study".to_string(), "S5".to_string()),
        ("case".to_string(), case.to_string()),
        ("manoeuvre_name".to_string(), manoeuvre.to_string()),
        ("seed".to_string(), settings.seed.to_string()),
        ("noise_scale".to_string(), settings.noise_scale.to_string()),
    ]);
    let setup = Setup {
        fmu,
        filter: kind,
        parameters: &parameters,
        integers: &integers,
        start_values,
        inputs: &INPUTS,
        outputs: &OUTPUTS,
        smoothed: &NAMES,
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

#[cfg(test)]
mod tests {
    use super::*;
    use estimator::models::Missile6Dof;
    use start_values::SetByName;

    #[test]
    fn the_parameter_names_are_the_fmus_of_the_states_and_measurements() {
        for (i, state) in Missile6Dof::STATE_NAMES.iter().enumerate() {
            assert_eq!(PRIOR_PARAMETERS[i], format!("prior_{state}"));
            assert_eq!(PRIOR_STD_PARAMETERS[i], format!("prior_{state}_std"));
        }
        for (i, measurement) in Missile6Dof::MEASUREMENT_NAMES.iter().enumerate() {
            assert_eq!(SENSOR_NOISE_PARAMETERS[i], format!("r_{measurement}_std"));
        }
    }

    /// Every number the FMU runs are given but the flight's clock is one the in-process
    /// filter takes by the same name, so that a start value reaches both.
    #[test]
    fn set_changes_exactly_the_parameter_of_its_name() {
        let settings = Settings::default();
        let tuning = Tuning::new(1.0);
        let written = |t: &Tuning| -> Vec<(&'static str, f64)> {
            let integers = integers(t).into_iter().map(|(n, v)| (n, f64::from(v)));
            parameters(&settings, t).into_iter().chain(integers).collect()
        };
        let study = written(&tuning);
        for &(name, old) in &study {
            let mut changed = tuning.clone();
            if name == "sample_time" {
                assert!(!Tuning::takes(name) && changed.set(name, 2.0 * old).is_err(), "the clock is the flight's");
                continue;
            }
            assert!(Tuning::takes(name), "{name}");
            let new = if name == "rk4_substeps" { old + 2.0 } else { 1.5 * old + 0.25 };
            changed.set(name, new).unwrap();
            for (&(n, before), (m, after)) in study.iter().zip(written(&changed)) {
                assert_eq!(n, m);
                assert_eq!(after, if n == name { new } else { before }, "{n} after setting {name}");
            }
        }
        assert_eq!(study.len(), 1 + 3 + 12 + 5 + 40 + 1, "sample time, UKF, R, Q, prior, RK4 steps");
    }

    #[test]
    fn set_refuses_names_it_does_not_have_and_values_the_fmu_refuses() {
        let mut tuning = Tuning::new(1.0);
        let unknown = tuning.set("mass", 1000.0).unwrap_err();
        assert!(unknown.contains("'mass'") && unknown.contains("q_rate_std"), "{unknown}");
        assert!(tuning.set("r_Nx_std", -1e-3).is_err());
        assert!(tuning.set("rk4_substeps", 1.5).is_err() && tuning.set("rk4_substeps", 0.0).is_err());
        assert!(tuning.set("prior_Cx0", f64::INFINITY).is_err());
        assert_eq!(tuning, Tuning::new(1.0), "a refused value changes nothing");
    }
}
