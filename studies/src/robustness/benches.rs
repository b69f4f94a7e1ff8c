//! Each estimator FMU's bench: its study's truth and set-up, as `reproduce`
//! runs it (the study's default case, its tuning, no smoothing), long enough
//! for a warm-up, the longest episode and the horizon after it.

use estimator::models::WheelRailRoll;

use super::bench::Bench;
use crate::s3::study::{in_model_order, user_vehicle, ForceModel, Tuning as S3Tuning};
use truth::s3::cases::ACCELERATIONS;

/// The study's parameters without the smoothing (the robustness runs score the filter).
fn unsmoothed(parameters: Vec<(&'static str, f64)>) -> Vec<(&'static str, f64)> {
    parameters.into_iter().filter(|(name, _)| *name != "smoothing_lag").collect()
}

/// S1: stiffness/random, the accelerations at 2 % noise, 200 Hz; the load scored.
pub fn s1(duration: f64, seed: u64) -> Bench {
    use truth::s1::{simulate, Case, Settings};
    let case: Case = "stiffness/random".parse().expect("a case of S1");
    let settings = Settings { duration, seed, ..Settings::default() };
    let (truth, measurements) = simulate(&case, &settings);
    let tuning = crate::s1::Tuning::new(&settings, measurements.noise_std);
    Bench {
        study: "S1",
        identifier: "kalfmu_s1_load",
        inputs: vec!["z1_ddot", "z2_ddot"],
        controls: Vec::new(),
        dt: settings.dt(),
        z: measurements.acceleration.iter().map(|z| z.to_vec()).collect(),
        u: Vec::new(),
        targets: vec!["F"],
        truth: truth.load.iter().map(|&f| vec![f]).collect(),
        parameters: unsmoothed(crate::s1::fmu_run::parameters(&tuning, &case, &settings)),
        integers: tuning.fmu_integers(),
        bound: 2.0,
    }
}

/// S2: the random track (FRA class 5), the seven accelerations at 1 kHz; the four forces scored.
pub fn s2(duration: f64, seed: u64) -> Bench {
    use truth::s2::cases::{as_built, measure, simulate, Case, Settings};
    use truth::s2::parameters::Vehicle;
    let settings = Settings { duration, seed, ..Settings::default() };
    let truth = simulate(Case::Random, &settings);
    let measurements = measure(&truth, settings.noise_fraction, settings.seed);
    let tuning = crate::s2::study::Tuning::new(&settings, measurements.noise_std);
    let parameters = crate::s2::fmu_run::parameters(&Vehicle::ZHAI_PASSENGER, as_built().static_wheel_load(), &tuning);
    Bench {
        study: "S2",
        identifier: crate::s2::fmu_run::IDENTIFIER,
        inputs: vec!["z_c_ddot", "z_t1_ddot", "z_t2_ddot", "z_w1_ddot", "z_w2_ddot", "z_w3_ddot", "z_w4_ddot"],
        controls: Vec::new(),
        dt: 1.0 / settings.rate,
        z: measurements.accelerations.iter().map(|z| z.to_vec()).collect(),
        u: Vec::new(),
        targets: vec!["F_N1", "F_N2", "F_N3", "F_N4"],
        truth: truth.contact.iter().map(|f| f.to_vec()).collect(),
        parameters: unsmoothed(parameters),
        integers: tuning.fmu_integers(),
        bound: 0.5,
    }
}

/// S3: the random track, the twenty accelerations at 1 kHz, forces returning
/// (the FMU's default); the eight left and right forces scored.
pub fn s3(duration: f64, seed: u64) -> Bench {
    use truth::s3::cases::{measure, simulate, Case, Settings};
    let settings = Settings { duration, seed, ..Settings::default() };
    let truth = simulate(Case::Random, &settings).expect("the S3 truth of the study's settings");
    let measurements = measure(&truth, settings.noise_fraction, settings.seed);
    let vehicle = user_vehicle(settings.vehicle.static_wheel_load());
    let tuning = S3Tuning::new(&settings, &measurements, ForceModel::Returning(S3Tuning::FORCE_RETURN_RATE));
    let names = &WheelRailRoll::MEASUREMENT_NAMES[WheelRailRoll::ACCELERATIONS];
    Bench {
        study: "S3",
        identifier: "kalfmu_s3_wheel_rail_lr",
        inputs: names.to_vec(),
        controls: Vec::new(),
        dt: 1.0 / settings.rate,
        z: measurements.accelerations.iter().map(|a| in_model_order(&ACCELERATIONS, a, 0).to_vec()).collect(),
        u: Vec::new(),
        targets: crate::s3::fmu_run::SMOOTHED.to_vec(),
        truth: (0..truth.time.len()).map(|k| crate::s3::fmu_run::true_signals(&truth, k)[..8].to_vec()).collect(),
        parameters: unsmoothed(crate::s3::fmu_run::parameters(&vehicle, &tuning)),
        integers: Vec::new(),
        bound: 0.5,
    }
}
