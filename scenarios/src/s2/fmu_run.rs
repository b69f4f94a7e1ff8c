//! One S2 case through the packaged estimator FMU (`kalfmu_s2_wheel_rail`), driven as a
//! co-simulation master drives it: at each sample instant `t` the seven noisy accelerations
//! of `t` are set, the outputs read (the forces at `t` given the measurements up to `t`),
//! `fmi2DoStep(t, dt)` called and the outputs read again (the forces at `t + dt` predicted
//! from the measurements up to `t`). The FMU gets the user's vehicle and the study's tuning
//! as parameters, by name, as a user would set them in their simulator. The run is logged in
//! the kalfmu MCAP format (`docs/log-format.md`): the measurements, the true forces, both
//! readings (`/estimate`, `/prediction`).

use std::collections::BTreeMap;
use std::path::Path;

use analyzer::log::{LogWriter, SignalSpec, ESTIMATE, MEASUREMENTS, PREDICTION, TRUTH};
use anyhow::Context;
use estimator::FilterKind;

use super::parameters::Vehicle;
use super::study::{Case, Measurements, Settings, Truth, Tuning};
use crate::fmu_driver::{filter_enumeration, ImportedFmu};

/// The FMU's identifier.
pub const IDENTIFIER: &str = "kalfmu_s2_wheel_rail";

/// The FMU's inputs, in the order of the measurement vector of eq. (7).
const INPUTS: [&str; 7] = ["z_c_ddot", "z_t1_ddot", "z_t2_ddot", "z_w1_ddot", "z_w2_ddot", "z_w3_ddot", "z_w4_ddot"];

/// The true forces' names: the FMU's force outputs.
const FORCES: [&str; 4] = ["F_N1", "F_N2", "F_N3", "F_N4"];

/// The FMU's outputs that are logged on `/estimate`; the forces have their namesakes on
/// `/truth`.
const OUTPUTS: [&str; 9] = ["F_N1", "F_N2", "F_N3", "F_N4", "F_N1_std", "F_N2_std", "F_N3_std", "F_N4_std", "nis"];

/// The FMU's counters read at the end of a run.
const COUNTERS: [&str; 2] = ["skipped_measurements", "rejected_measurements"];

/// What the user sets in the FMU: their catalogue vehicle, the static wheel load as weighed,
/// the sample time and the study's tuning.
pub fn parameters(catalogue: &Vehicle, weighed: f64, tuning: &Tuning) -> Vec<(&'static str, f64)> {
    let v = catalogue;
    let mut p = vec![
        ("car_body_mass", v.car_body_mass),
        ("car_body_pitch_inertia", v.car_body_pitch_inertia),
        ("bogie_mass", v.bogie_mass),
        ("bogie_pitch_inertia", v.bogie_pitch_inertia),
        ("wheelset_mass", v.wheelset_mass),
        ("primary_stiffness", v.primary_stiffness),
        ("primary_damping", v.primary_damping),
        ("primary_damping_beyond", v.primary_damping_beyond),
        ("primary_damper_knee", v.primary_damper_knee),
        ("secondary_stiffness", v.secondary_stiffness),
        ("secondary_damping", v.secondary_damping),
        ("half_bogie_spacing", v.half_bogie_spacing),
        ("half_wheelbase", v.half_wheelbase),
        ("static_wheel_load", weighed),
        ("sample_time", tuning.dt),
        ("p0_motion_std", tuning.prior_std),
        ("p0_force_std", tuning.prior_std),
        ("q_body_std", tuning.body_std),
        ("q_wheelset_std", tuning.wheelset_std),
        ("force_noise_intensity", tuning.force_intensity),
        // The library's cubature rule, as in the study's in-process runs.
        ("ukf_alpha", 1.0),
        ("ukf_beta", 2.0),
        ("ukf_kappa", 0.0),
    ];
    let sensors = ["r_z_c_ddot_std", "r_z_t1_ddot_std", "r_z_t2_ddot_std", "r_z_w1_ddot_std"];
    let sensors = sensors.into_iter().chain(["r_z_w2_ddot_std", "r_z_w3_ddot_std", "r_z_w4_ddot_std"]);
    p.extend(sensors.zip(tuning.sensor_std));
    p
}

/// One simulated case and how the user set up the FMU for it.
pub struct Simulated<'a> {
    /// The case.
    pub case: Case,
    /// The study settings.
    pub settings: &'a Settings,
    /// The truth at the sample times.
    pub truth: &'a Truth,
    /// The noisy accelerations.
    pub measurements: &'a Measurements,
    /// The FMU's parameters ([`parameters`]).
    pub parameters: &'a [(&'static str, f64)],
}

/// What the FMU counted over a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Counts {
    /// Measurement rows left out as missing.
    pub skipped: i32,
    /// Measurement rows rejected by the innovation gate.
    pub rejected: i32,
}

/// Runs `kind` on a simulated case through the FMU and writes the log to `log`.
pub fn run(fmu: &ImportedFmu, kind: FilterKind, sim: &Simulated<'_>, log: &Path) -> anyhow::Result<Counts> {
    let Simulated { case, settings, truth, measurements, parameters } = *sim;
    let dt = 1.0 / settings.rate;
    let instants = truth.time.len();
    let mut instance = fmu.instantiate(
        &format!("s2-{}-{kind}", case.name()),
        truth.time[0],
        truth.time[instants - 1],
        parameters,
        &[("filter", filter_enumeration(kind)), ("rk4_substeps", 1)],
    )?;
    let inputs: Vec<u32> = INPUTS.iter().map(|n| fmu.vr(n)).collect::<anyhow::Result<_>>()?;
    let outputs: Vec<u32> = OUTPUTS.iter().map(|n| fmu.vr(n)).collect::<anyhow::Result<_>>()?;
    let counters: Vec<u32> = COUNTERS.iter().map(|n| fmu.vr(n)).collect::<anyhow::Result<_>>()?;

    let parameters_json =
        serde_json::to_string(&parameters.iter().map(|(n, v)| (n.to_string(), *v)).collect::<BTreeMap<_, _>>())?;
    let metadata = BTreeMap::from([
        ("study".to_string(), "S2".to_string()),
        ("case".to_string(), case.name().to_string()),
        ("seed".to_string(), settings.seed.to_string()),
        ("filter".to_string(), kind.name().to_string()),
        ("speed_km_h".to_string(), format!("{}", settings.speed * 3.6)),
        ("rate_hz".to_string(), settings.rate.to_string()),
        ("noise_fraction".to_string(), settings.noise_fraction.to_string()),
        ("parameters".to_string(), parameters_json),
        ("software".to_string(), format!("kalfmu {}", env!("CARGO_PKG_VERSION"))),
    ]);
    let mut w = LogWriter::create(log, &metadata)?;
    let unit = |n: &str| fmu.unit(n);
    let measured: Vec<SignalSpec> =
        INPUTS.iter().map(|n| SignalSpec::new(n, &unit(n), "measured acceleration (up), with sensor noise")).collect();
    let ch_m = w.add_channel(MEASUREMENTS, &measured)?;
    let true_forces: Vec<SignalSpec> = FORCES
        .iter()
        .map(|n| SignalSpec::new(n, &unit(n), "true wheel-rail force (vehicle-track truth, Hertz contact)"))
        .collect();
    let ch_t = w.add_channel(TRUTH, &true_forces)?;
    let specs =
        |what: &str| -> Vec<SignalSpec> { OUTPUTS.iter().map(|n| SignalSpec::new(n, &unit(n), what)).collect() };
    let ch_e = w.add_channel(ESTIMATE, &specs("FMU output read at t after the inputs of t were set"))?;
    let ch_p = w.add_channel(PREDICTION, &specs("FMU output read right after fmi2DoStep(t - dt, dt)"))?;

    let mut out = vec![0.0; outputs.len()];
    for k in 0..instants {
        let (t, z) = (truth.time[k], measurements.accelerations[k]);
        let context = || format!("S2 {} {kind} at t = {t} s", case.name());
        instance.set_inputs(&inputs, &z).with_context(context)?;
        instance.read(&outputs, &mut out).with_context(context)?;
        w.write(ch_m, t, &z)?;
        w.write(ch_t, t, &truth.contact[k])?;
        w.write(ch_e, t, &out)?;
        if k + 1 < instants {
            instance.do_step(dt).with_context(context)?;
            instance.read(&outputs, &mut out).with_context(context)?;
            w.write(ch_p, truth.time[k + 1], &out)?;
        }
    }
    let mut counts = [0; 2];
    instance.read_integers(&counters, &mut counts)?;
    instance.terminate()?;
    w.finish()?;
    Ok(Counts { skipped: counts[0], rejected: counts[1] })
}
