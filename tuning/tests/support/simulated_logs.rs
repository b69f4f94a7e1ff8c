//! Logs laid out as the studies write them (`cosim::master`, `studies/src/s1/fmu_run.rs`,
//! `studies/src/s2/fmu_run.rs`), made from the truth simulators directly instead of a run
//! of the packaged FMU: the channel `/measurements` with the FMU's inputs, `/truth`, and the
//! metadata `kalfmu` with `parameters`, the FMU parameters the study sets (the chain or the
//! user's vehicle, the sample time, the study's tuning). There is no `/estimate`: tuning
//! reads only the measurements. Shared by the tests and `examples/simulate_log.rs`.
// Each includer uses a part.
#![allow(dead_code)]

use std::collections::BTreeMap;
use std::path::Path;

use log_format::write::{LogWriter, SignalSpec, MEASUREMENTS, TRUTH};

/// The unit of an FMU variable, as the FMU declares it.
fn unit_of(model_identifier: &str, name: &str) -> String {
    let descriptor =
        kalfmu_fmu::estimators::all().into_iter().find(|d| d.model_identifier == model_identifier).expect("an FMU");
    descriptor.variables.iter().find(|v| v.name == name).and_then(|v| v.unit).unwrap_or("").to_string()
}

/// Writes a log: the inputs `inputs` with their rows, the truth `truth` with its rows.
#[allow(clippy::too_many_arguments)]
fn write(
    path: &Path,
    model_identifier: &str,
    metadata: BTreeMap<String, String>,
    inputs: &[&str],
    truth_names: &[&str],
    time: &[f64],
    measured: &dyn Fn(usize) -> Vec<f64>,
    truth: &dyn Fn(usize) -> Vec<f64>,
) -> Result<(), String> {
    let mut w = LogWriter::create(path, &metadata).map_err(|e| e.to_string())?;
    let specs: Vec<SignalSpec> = inputs
        .iter()
        .map(|n| SignalSpec::new(n, &unit_of(model_identifier, n), "measured input, with sensor noise"))
        .collect();
    let ch_m = w.add_channel(MEASUREMENTS, &specs).map_err(|e| e.to_string())?;
    let specs: Vec<SignalSpec> = truth_names
        .iter()
        .map(|n| SignalSpec::new(n, &unit_of(model_identifier, n), "true value (truth simulator)"))
        .collect();
    let ch_t = w.add_channel(TRUTH, &specs).map_err(|e| e.to_string())?;
    for (k, &t) in time.iter().enumerate() {
        w.write(ch_m, t, &measured(k)).map_err(|e| e.to_string())?;
        w.write(ch_t, t, &truth(k)).map_err(|e| e.to_string())?;
    }
    w.finish().map_err(|e| e.to_string())
}

/// The metadata the studies write, with `parameters` as a JSON object.
fn metadata(
    study: &str,
    case: &str,
    seed: u64,
    noise_fraction: f64,
    parameters: &[(&str, f64)],
) -> BTreeMap<String, String> {
    let json: BTreeMap<String, f64> = parameters.iter().map(|(n, v)| (n.to_string(), *v)).collect();
    BTreeMap::from([
        ("study".to_string(), study.to_string()),
        ("case".to_string(), case.to_string()),
        ("seed".to_string(), seed.to_string()),
        ("noise_fraction".to_string(), noise_fraction.to_string()),
        ("filter".to_string(), "SRCKF".to_string()),
        ("parameters".to_string(), serde_json::to_string(&json).expect("numbers")),
        ("software".to_string(), "kalfmu tuning tests".to_string()),
    ])
}

/// An S1 log (stiffness-nonlinear chain, random load) of `seconds` at 200 Hz, with the
/// study's tuning as the logged parameters; returns the sensors' true noise std.
pub fn write_s1(path: &Path, seconds: f64, seed: u64, noise_fraction: f64) -> Result<[f64; 2], String> {
    use truth::s1::{simulate, Case, Settings};
    // The paper's first case: stiffness-nonlinear chain, random load.
    let case = Case::ALL[0];
    let settings = Settings { duration: seconds, seed, noise_fraction, ..Settings::default() };
    let (truth, measurements) = simulate(&case, &settings);
    let dt = settings.dt();
    // The study's tuning (studies/src/s1/mod.rs, Tuning::new): a 10 N, 10 Hz load.
    let load_intensity = 10.0_f64.powi(2) * (std::f64::consts::TAU * 10.0).powi(4) / 5.0 * dt;
    // The chain under the FMU's names, as the study writes them (truth::s1::chain_parameters).
    let mut parameters = truth::s1::chain_parameters(&case.chain()).to_vec();
    parameters.extend([
        ("sample_time", dt),
        ("ukf_alpha", 1.0),
        ("ukf_beta", 2.0),
        ("ukf_kappa", 0.0),
        ("q_z_std", 1e-6),
        ("q_z_dot_std", 1e-5),
        ("load_noise_intensity", load_intensity),
        ("r_z1_ddot_std", measurements.noise_std[0]),
        ("r_z2_ddot_std", measurements.noise_std[1]),
    ]);
    write(
        path,
        "kalfmu_s1_load",
        metadata("S1", &case.to_string(), seed, noise_fraction, &parameters),
        &["z1_ddot", "z2_ddot"],
        &["F", "z1", "z2"],
        &truth.time,
        &|k| measurements.acceleration[k].to_vec(),
        &|k| vec![truth.load[k], truth.motion[k][0], truth.motion[k][1]],
    )?;
    Ok(measurements.noise_std)
}

/// An S2 log (random track, 1 kHz, the as-built car under the catalogue car's parameters
/// and the weighed wheel load, as `studies/src/s2/fmu_run.rs` sets them) of `seconds`.
pub fn write_s2(path: &Path, seconds: f64, seed: u64, noise_fraction: f64) -> Result<[f64; 7], String> {
    use truth::s2::cases::{as_built, measure, simulate, Case, Settings};
    use truth::s2::parameters::Vehicle;
    let settings = Settings { duration: seconds, seed, noise_fraction, ..Settings::default() };
    settings.validate()?;
    let truth = simulate(Case::Random, &settings);
    let measurements = measure(&truth, settings.noise_fraction, settings.seed);
    let dt = 1.0 / settings.rate;
    // The user's catalogue car under the FMU's names, as the study writes them
    // (truth::s2::parameters::Vehicle::fmu_parameters), and the weighed wheel load.
    let mut parameters = Vehicle::ZHAI_PASSENGER.fmu_parameters().to_vec();
    parameters.extend([
        ("static_wheel_load", as_built().static_wheel_load()),
        ("sample_time", dt),
        ("p0_motion_std", 0.1),
        ("p0_force_std", 0.1),
        // The study's tuning (studies/src/s2/study.rs, Tuning::new).
        ("q_body_std", (9e-7 * dt).sqrt()),
        ("q_wheelset_std", (1e-7 * dt).sqrt()),
        ("force_noise_intensity", 1e13),
        ("ukf_alpha", 1.0),
        ("ukf_beta", 2.0),
        ("ukf_kappa", 0.0),
    ]);
    let sensors = ["r_z_c_ddot_std", "r_z_t1_ddot_std", "r_z_t2_ddot_std", "r_z_w1_ddot_std"];
    let sensors = sensors.into_iter().chain(["r_z_w2_ddot_std", "r_z_w3_ddot_std", "r_z_w4_ddot_std"]);
    parameters.extend(sensors.zip(measurements.noise_std));
    write(
        path,
        "kalfmu_s2_wheel_rail",
        metadata("S2", Case::Random.name(), seed, noise_fraction, &parameters),
        &["z_c_ddot", "z_t1_ddot", "z_t2_ddot", "z_w1_ddot", "z_w2_ddot", "z_w3_ddot", "z_w4_ddot"],
        &["F_N1", "F_N2", "F_N3", "F_N4"],
        &truth.time,
        &|k| measurements.accelerations[k].to_vec(),
        &|k| truth.contact[k].to_vec(),
    )?;
    Ok(measurements.noise_std)
}
