//! A full simulation of a packaged estimator FMU through the `fmi` crate
//! (rust-fmi) as importer — unzip, parse `modelDescription.xml`, `dlopen` the
//! binary — meant to run under valgrind (`scripts/valgrind-fmu`, on every FMU
//! `package-fmus` writes), so it walks through every kind of call an importer
//! makes. It knows no FMU: the inputs, outputs and parameters are found by
//! causality in the model description, the step is its default experiment's;
//! an input with a sensor noise parameter (`r_<input>_std`) is a measurement, one
//! without is a control (a known input of the model, never missing).
//!
//! 1. instance `a`: set-up with a stop time, parameters in initialisation
//!    mode (every tunable at 1.2 times its start value, `rk4_substeps` 2 where
//!    the FMU integrates with RK4),
//!    `STEPS` communication steps of one sample with synthetic accelerations
//!    (some missing, logged as warnings) and controls of a few tenths of a
//!    degree, every Real output read every step;
//!    half way an FMU state is saved, serialised, and a refused
//!    `fmi2SetReal` (of an output) logs an error; at the end the state is
//!    restored and the second half replayed (it must give the same outputs);
//! 2. instance `b`: restores the serialised state, steps on (the same outputs
//!    again), resets, initialises again and steps;
//! 3. both terminated and freed (with their FMU states).
//!
//! Usage:
//!
//! ```text
//! cargo build --release -p fmu --example simulate_fmu && ./target/release/package-fmus --out target/fmu
//! ./target/release/examples/simulate_fmu [target/fmu/kalfmu_s1_load.fmu] [STEPS]
//! ```

use std::process::ExitCode;

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::schema::fmi2::{Causality, ScalarVariable, ScalarVariableElement, Variability};
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

/// The measurements of sample `k` for the inputs `about` (`(offset, scale)` each): a sum
/// of two sines each, every 50th value of the last input missing.
fn accelerations(k: usize, dt: f64, about: &[(f64, f64)]) -> Vec<f64> {
    let (t, m) = ((k + 1) as f64 * dt, about.len());
    about
        .iter()
        .enumerate()
        .map(|(i, (offset, scale))| {
            let i = i as f64;
            offset + scale * (0.3 * ((1.7 + 0.8 * i) * t).sin() + 0.1 * ((6.1 + 1.3 * i) * t + 0.4 * i).sin())
        })
        .enumerate()
        .map(|(i, z)| if i == m - 1 && k % 50 == 49 { f64::NAN } else { z })
        .collect()
}

/// The variables of the FMU by causality, from its model description.
struct Run {
    inputs: Vec<u32>,
    /// Per input: the offset and scale of its measurements (`accelerations`).
    about: Vec<(f64, f64)>,
    controls: Vec<u32>,
    /// Every Real output, with its name.
    outputs: Vec<(String, u32)>,
    /// Every Real tunable parameter and its start value.
    tunables: Vec<(u32, f64)>,
    /// `rk4_substeps`, where the FMU has it.
    substeps: Option<u32>,
    dt: f64,
}

impl Run {
    fn initialise(&self, inst: &mut InstanceCS, stop: f64) -> Result<(), String> {
        FmiInstance::enter_initialization_mode(inst, None, 0.0, Some(stop)).map_err(|e| format!("initialise: {e}"))?;
        let (vrs, values): (Vec<u32>, Vec<f64>) = self.tunables.iter().map(|&(vr, start)| (vr, 1.2 * start)).unzip();
        Common::set_real(inst, &vrs, &values).map_err(|e| format!("parameters: {e}"))?;
        if let Some(substeps) = self.substeps {
            Common::set_integer(inst, &[substeps], &[2]).map_err(|e| format!("rk4_substeps: {e}"))?;
        }
        Common::exit_initialization_mode(inst).map_err(|e| format!("exit initialisation: {e}"))?;
        Ok(())
    }

    /// Steps `from..to`; returns the outputs after the last step.
    /// Steps from sample `from` to `to` and returns the outputs after the last step, and
    /// the step at which the FMU discarded, if it did. The synthetic measurements need not
    /// fit the FMU's model (S5's missile is measured as if it hung at its prior while its
    /// model flies on); a filter that gives up on them says so with `fmi2Discard`, and a
    /// master stops stepping there, as here, keeping the outputs it last read.
    fn steps(&self, inst: &mut InstanceCS, from: usize, to: usize) -> Result<(Vec<f64>, Option<usize>), String> {
        let outputs: Vec<u32> = self.outputs.iter().map(|(_, vr)| *vr).collect();
        let mut out = vec![0.0; outputs.len()];
        for k in from..to {
            let z = accelerations(k, self.dt, &self.about);
            Common::set_real(inst, &self.inputs, &z).map_err(|e| format!("inputs {k}: {e}"))?;
            let t = k as f64 * self.dt;
            let u: Vec<f64> = (0..self.controls.len()).map(|j| 0.005 * ((1.3 + j as f64) * t).sin()).collect();
            Common::set_real(inst, &self.controls, &u).map_err(|e| format!("controls {k}: {e}"))?;
            match inst.do_step(k as f64 * self.dt, self.dt, true) {
                Ok(_) => {}
                Err(fmi::fmi2::Fmi2Error::Discard) => {
                    Common::get_real(inst, &outputs, &mut out).map_err(|e| format!("outputs at the discard: {e}"))?;
                    return Ok((out, Some(k)));
                }
                Err(e) => return Err(format!("step {k}: {e}")),
            }
            Common::get_real(inst, &outputs, &mut out).map_err(|e| format!("outputs {k}: {e}"))?;
        }
        Ok((out, None))
    }
}

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|x| x.to_bits()).collect()
}

fn simulate(path: &str, steps: usize) -> Result<String, String> {
    let import: Fmi2Import = fmi::import::from_path(path).map_err(|e| format!("{path}: {e}"))?;
    let md = import.model_description();
    let variables = &md.model_variables.variables;
    let real = |v: &&ScalarVariable| matches!(v.elem, ScalarVariableElement::Real(_));
    let measured = |v: &&ScalarVariable| variables.iter().any(|f| f.name == format!("r_{}_std", v.name));
    let (inputs, controls): (Vec<&ScalarVariable>, Vec<&ScalarVariable>) =
        variables.iter().filter(|v| v.causality == Causality::Input).filter(real).partition(measured);
    // Measurements about the prior (`prior_<input>`) at a few times the sensor's noise
    // (`r_<input>_std`) where the FMU has them (S5: a missile at 10 km and 1 km/s, whose
    // filter diverges on sines about 0), else sines about 0 (S1, S2: oscillators).
    let start = |name: String| {
        variables.iter().find(|v| v.name == name).and_then(|v| match &v.elem {
            ScalarVariableElement::Real(r) => r.start,
            _ => None,
        })
    };
    let about: Vec<(f64, f64)> = inputs
        .iter()
        .map(|v| match start(format!("prior_{}", v.name)) {
            Some(offset) => (offset, 3.0 * start(format!("r_{}_std", v.name)).unwrap_or(1.0)),
            None if controls.is_empty() => (0.0, 1.0),
            None => (f64::NAN, 0.0),
        })
        .collect();
    let (inputs, controls): (Vec<u32>, Vec<u32>) =
        (inputs.iter().map(|v| v.value_reference).collect(), controls.iter().map(|v| v.value_reference).collect());
    let outputs: Vec<(String, u32)> = variables
        .iter()
        .filter(|v| v.causality == Causality::Output)
        .filter(real)
        .map(|v| (v.name.clone(), v.value_reference))
        .collect();
    let tunables: Vec<(u32, f64)> = variables
        .iter()
        .filter(|v| v.causality == Causality::Parameter && v.variability == Some(Variability::Tunable))
        .filter_map(|v| match &v.elem {
            ScalarVariableElement::Real(r) => r.start.map(|start| (v.value_reference, start)),
            _ => None,
        })
        .collect();
    let substeps = variables.iter().find(|v| v.name == "rk4_substeps").map(|v| v.value_reference);
    if inputs.is_empty() || outputs.is_empty() || tunables.is_empty() {
        return Err(format!("{path}: no Real inputs, outputs or tunable parameters in the model description"));
    }
    let dt = md.default_experiment.as_ref().and_then(|d| d.step_size).ok_or("no default step size")?;
    let run = Run { inputs, about, controls, outputs, tunables, substeps, dt };
    let half = steps / 2;

    let mut a = import.instantiate_cs("a", false, true).map_err(|e| format!("instantiate a: {e}"))?;
    Common::set_debug_logging(&mut a, true, &[]).map_err(|e| format!("debug logging: {e}"))?;
    run.initialise(&mut a, steps as f64 * dt)?;
    if let (_, Some(k)) = run.steps(&mut a, 0, half)? {
        return Err(format!("the FMU discarded at step {k}, before the state is saved at {half}: use fewer steps"));
    }
    let saved = a.get_fmu_state().map_err(|e| format!("get state: {e}"))?;
    let bytes = a.serialize_fmu_state(&saved).map_err(|e| format!("serialise: {e}"))?;
    // Refused (an output): logs an error, changes nothing.
    if Common::set_real(&mut a, &[run.outputs[0].1], &[1.0]).is_ok() {
        return Err("setting an output was accepted".into());
    }
    let first = run.steps(&mut a, half, steps)?;
    a.set_fmu_state(&saved).ok().map_err(|e| format!("set state: {e}"))?;
    let replay = run.steps(&mut a, half, steps)?;
    if bits(&first.0) != bits(&replay.0) || first.1 != replay.1 {
        return Err(format!("the replay differs: {first:?} vs {replay:?}"));
    }
    let last = a.last_successful_time().map_err(|e| format!("last successful time: {e}"))?;
    Common::terminate(&mut a).map_err(|e| format!("terminate a: {e}"))?;

    let mut b = import.instantiate_cs("b", false, false).map_err(|e| format!("instantiate b: {e}"))?;
    let restored = b.deserialize_fmu_state(&bytes).map_err(|e| format!("deserialise: {e}"))?;
    b.set_fmu_state(&restored).ok().map_err(|e| format!("set state in b: {e}"))?;
    let in_b = run.steps(&mut b, half, steps)?;
    if bits(&in_b.0) != bits(&first.0) || in_b.1 != first.1 {
        return Err(format!("the restored instance differs: {in_b:?} vs {first:?}"));
    }
    Common::reset(&mut b).map_err(|e| format!("reset b: {e}"))?;
    run.initialise(&mut b, steps as f64 * dt)?;
    run.steps(&mut b, 0, half)?;
    Common::terminate(&mut b).map_err(|e| format!("terminate b: {e}"))?;
    drop((a, b));
    let (name, value) = (&run.outputs[0].0, first.0[0]);
    let discarded = first
        .1
        .map_or(String::new(), |k| format!(" (the filter gave up on the synthetic data at step {k}: fmi2Discard)"));
    Ok(format!(
        "{path}: {steps} steps of {dt} s to t = {last}{discarded} with {} inputs and {} controls; {name} = {value:.6}; {} outputs replayed bit for bit from a state of {} bytes in both instances",
        run.inputs.len(),
        run.controls.len(),
        run.outputs.len(),
        bytes.len()
    ))
}
