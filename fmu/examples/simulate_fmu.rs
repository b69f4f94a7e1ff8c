//! A full simulation of the packaged S1 FMU through the `fmi` crate (rust-fmi)
//! as importer — unzip, parse `modelDescription.xml`, `dlopen` the binary —
//! meant to run under valgrind (`scripts/valgrind-fmu`), so it walks through
//! every kind of call an importer makes:
//!
//! 1. instance `a`: set-up with a stop time, parameters in initialisation
//!    mode, `STEPS` communication steps of one sample with synthetic
//!    accelerations (some missing, logged as warnings), outputs read every
//!    step; half way an FMU state is saved, serialised, and a refused
//!    `fmi2SetReal` logs an error; at the end the state is restored and the
//!    second half replayed (it must give the same estimate);
//! 2. instance `b`: restores the serialised state, steps on, resets,
//!    initialises again and steps;
//! 3. both terminated and freed (with their FMU states).
//!
//! Usage:
//!
//! ```text
//! cargo build --release -p fmu --example simulate_fmu && ./target/release/package-fmus --out target/fmu
//! ./target/release/examples/simulate_fmu [target/fmu/kalfmu_s1_load.fmu] [STEPS]
//! ```

use std::collections::HashMap;
use std::process::ExitCode;

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::traits::{FmiImport, FmiInstance, FmiStatus};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args.first().map_or("target/fmu/kalfmu_s1_load.fmu", String::as_str);
    let steps = match args.get(1).map(|s| s.parse::<usize>()) {
        None => 2000,
        Some(Ok(n)) if n >= 2 => n,
        Some(_) => {
            eprintln!("usage: simulate_fmu [FMU] [STEPS >= 2]");
            return ExitCode::FAILURE;
        }
    };
    match simulate(path, steps) {
        Ok(summary) => {
            println!("{summary}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("simulate_fmu: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The measured accelerations of sample `k` (every 50th `z2_ddot` missing).
fn accelerations(k: usize, dt: f64) -> [f64; 2] {
    let t = (k + 1) as f64 * dt;
    let z1 = 0.3 * (1.7 * t).sin() + 0.1 * (6.1 * t + 0.4).sin();
    let z2 = 0.5 * (0.9 * t + 1.0).sin() + 0.2 * (11.3 * t).cos();
    [z1, if k % 50 == 49 { f64::NAN } else { z2 }]
}

struct Run {
    vr: HashMap<String, u32>,
    dt: f64,
}

impl Run {
    fn vr(&self, name: &str) -> Result<u32, String> {
        self.vr.get(name).copied().ok_or_else(|| format!("the FMU has no variable {name}"))
    }

    fn initialise(&self, inst: &mut InstanceCS, stop: f64) -> Result<(), String> {
        FmiInstance::enter_initialization_mode(inst, None, 0.0, Some(stop)).map_err(|e| format!("initialise: {e}"))?;
        let (vrs, values) = ([self.vr("load_noise_intensity")?, self.vr("p0_F_std")?], [1.2e6, 25.0]);
        Common::set_real(inst, &vrs, &values).map_err(|e| format!("parameters: {e}"))?;
        Common::set_integer(inst, &[self.vr("rk4_substeps")?], &[2]).map_err(|e| format!("rk4_substeps: {e}"))?;
        Common::exit_initialization_mode(inst).map_err(|e| format!("exit initialisation: {e}"))?;
        Ok(())
    }

    /// Steps `from..to`; returns the last `[F, F_std]`.
    fn steps(&self, inst: &mut InstanceCS, from: usize, to: usize) -> Result<[f64; 2], String> {
        let inputs = [self.vr("z1_ddot")?, self.vr("z2_ddot")?];
        let outputs: Vec<u32> = ["F", "F_std", "z1", "z2", "z1_dot", "z2_dot", "F_dot", "nis"]
            .iter()
            .map(|n| self.vr(n))
            .collect::<Result<_, _>>()?;
        let mut out = vec![0.0; outputs.len()];
        for k in from..to {
            Common::set_real(inst, &inputs, &accelerations(k, self.dt)).map_err(|e| format!("inputs {k}: {e}"))?;
            inst.do_step(k as f64 * self.dt, self.dt, true).map_err(|e| format!("step {k}: {e}"))?;
            Common::get_real(inst, &outputs, &mut out).map_err(|e| format!("outputs {k}: {e}"))?;
        }
        Ok([out[0], out[1]])
    }
}

fn simulate(path: &str, steps: usize) -> Result<String, String> {
    let import: Fmi2Import = fmi::import::from_path(path).map_err(|e| format!("{path}: {e}"))?;
    let md = import.model_description();
    let vr = md.model_variables.variables.iter().map(|v| (v.name.clone(), v.value_reference)).collect();
    let dt = md.default_experiment.as_ref().and_then(|d| d.step_size).unwrap_or(0.005);
    let run = Run { vr, dt };
    let half = steps / 2;

    let mut a = import.instantiate_cs("a", false, true).map_err(|e| format!("instantiate a: {e}"))?;
    Common::set_debug_logging(&mut a, true, &[]).map_err(|e| format!("debug logging: {e}"))?;
    run.initialise(&mut a, steps as f64 * dt)?;
    run.steps(&mut a, 0, half)?;
    let saved = a.get_fmu_state().map_err(|e| format!("get state: {e}"))?;
    let bytes = a.serialize_fmu_state(&saved).map_err(|e| format!("serialise: {e}"))?;
    // Refused (an output): logs an error, changes nothing.
    if Common::set_real(&mut a, &[run.vr("F")?], &[1.0]).is_ok() {
        return Err("setting an output was accepted".into());
    }
    let first = run.steps(&mut a, half, steps)?;
    a.set_fmu_state(&saved).ok().map_err(|e| format!("set state: {e}"))?;
    let replay = run.steps(&mut a, half, steps)?;
    if first.map(f64::to_bits) != replay.map(f64::to_bits) {
        return Err(format!("the replay differs: {first:?} vs {replay:?}"));
    }
    let last = a.last_successful_time().map_err(|e| format!("last successful time: {e}"))?;
    Common::terminate(&mut a).map_err(|e| format!("terminate a: {e}"))?;

    let mut b = import.instantiate_cs("b", false, false).map_err(|e| format!("instantiate b: {e}"))?;
    let restored = b.deserialize_fmu_state(&bytes).map_err(|e| format!("deserialise: {e}"))?;
    b.set_fmu_state(&restored).ok().map_err(|e| format!("set state in b: {e}"))?;
    let in_b = run.steps(&mut b, half, steps)?;
    if in_b.map(f64::to_bits) != first.map(f64::to_bits) {
        return Err(format!("the restored instance differs: {in_b:?} vs {first:?}"));
    }
    Common::reset(&mut b).map_err(|e| format!("reset b: {e}"))?;
    run.initialise(&mut b, steps as f64 * dt)?;
    run.steps(&mut b, 0, half)?;
    Common::terminate(&mut b).map_err(|e| format!("terminate b: {e}"))?;
    drop((a, b));
    Ok(format!(
        "{path}: {steps} steps of {dt} s to t = {last}; F = {:.6} N, F_std = {:.6} N; state of {} bytes replayed in both instances",
        first[0],
        first[1],
        bytes.len()
    ))
}
