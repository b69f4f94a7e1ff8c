//! Each estimator FMU's bench: its study's truth and set-up, as `reproduce`
//! runs it (the study's default case, its tuning, no smoothing), long enough
//! for a warm-up, the longest episode and the horizon after it.

use estimator::models::WheelRailRoll;

use start_values::StartValues;

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
        start_values: StartValues::none(),
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
        start_values: StartValues::none(),
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
        start_values: StartValues::none(),
    }
}

/// The first `samples` rows of a table.
fn first<T: Clone>(rows: &[T], samples: usize) -> Vec<T> {
    rows[..samples.min(rows.len())].to_vec()
}

/// S4: the paper's run (no injected telegram faults: the episodes are the
/// faults), the four position channels every 20 ms (the marker never set);
/// the speed and the position scored.
pub fn s4(duration: f64, seed: u64) -> Bench {
    use truth::s4::channels::simulate;
    use truth::s4::faults::Faults;
    use truth::s4::profile::Profile;
    let recording = simulate(&Profile::paper(), &Faults::none(), seed);
    let tuning = crate::s4::ours::Tuning::paper();
    let dt = recording.telegram_interval;
    let samples = (duration / dt).ceil() as usize;
    let z: Vec<Vec<f64>> = (0..recording.n_telegrams())
        .map(|k| (0..4).map(|c| if recording.received[c][k] { recording.position[c][k] } else { f64::NAN }).collect())
        .collect();
    Bench {
        study: "S4",
        identifier: crate::s4::fmu_run::IDENTIFIER,
        inputs: vec!["P_head_left", "P_head_right", "P_tail_left", "P_tail_right"],
        controls: Vec::new(),
        dt,
        z: first(&z, samples),
        u: Vec::new(),
        targets: vec!["speed", "position"],
        truth: first(&recording.truth, samples).iter().map(|t| vec![t.speed, t.position]).collect(),
        parameters: crate::s4::fmu_run::parameters(&recording, &tuning),
        integers: Vec::new(),
        bound: 2.0,
        start_values: StartValues::none(),
    }
}

/// S5: the paper's manoeuvre on its 6-DOF, the twelve sensors every 5 ms and
/// the three deflections as controls; the ten coefficients scored.
pub fn s5(duration: f64, seed: u64) -> Bench {
    use truth::s5::flight::{measure, simulate_named, Settings};
    let settings = Settings { seed, ..Settings::default() };
    let truth = simulate_named("standard", &settings).expect("the S5 truth of the study's settings");
    let measurements = measure(&truth, settings.noise_scale, settings.seed);
    let tuning = crate::s5::study::Tuning::new(settings.noise_scale);
    let samples = (duration / settings.sample_time).ceil() as usize;
    Bench {
        study: "S5",
        identifier: crate::s5::fmu_run::IDENTIFIER,
        inputs: vec!["omega_x", "omega_y", "omega_z", "Nx", "Ny", "Nz", "phi", "psi", "gamma", "h", "alpha", "beta"],
        controls: vec!["delta_x", "delta_y", "delta_z"],
        dt: settings.sample_time,
        z: first(&measurements, samples).iter().map(|z| z.to_vec()).collect(),
        u: first(&truth.deflections, samples).iter().map(|u| u.to_vec()).collect(),
        targets: truth::s5::parameters::NAMES.to_vec(),
        truth: first(&truth.coefficients, samples).iter().map(|c| c.to_vec()).collect(),
        parameters: crate::s5::fmu_run::parameters(&settings, &tuning),
        integers: crate::s5::fmu_run::integers(&tuning),
        bound: 2.0,
        start_values: StartValues::none(),
    }
}
