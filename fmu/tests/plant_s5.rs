//! The packaged S5 plant FMU (`kalfmu_s5_flight`) through the `fmi` crate's importer,
//! as a master drives it:
//!
//! * given the study's coefficients, start, seed, integration step and noise σ and stepped
//!   at the study's sample time, it gives the study's truth and measurements
//!   (`truth::s5::flight`) bit for bit, on a manoeuvre the estimators were not tuned on;
//! * with the deflections as its inputs, it is the truth's plant under them held over
//!   each step, bit for bit, and a deflection set at `t` shows in the overloads read at `t`;
//! * its FMU state replays the same outputs, restored in the same instance and
//!   deserialised in a fresh one, noise included;
//! * a step that is no whole number of integration steps, a NaN deflection and a flight
//!   that diverges are refused with nothing changed.
#![cfg(target_os = "linux")]

mod support {
    pub mod packaged;
}

use std::collections::HashMap;

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::traits::{FmiImport, FmiInstance, FmiStatus};
use support::packaged;
use truth::s5::flight::{flight, measure, simulate_named, Settings};
use truth::s5::manoeuvre::Manoeuvre;
use truth::s5::parameters::{start, NAMES, SENSOR_STD};
use truth::s5::plant::FlyingPlant;

const MODEL: &str = "kalfmu_s5_flight";

/// The measurements, in the estimator's order.
const MEASURED: [&str; 12] =
    ["omega_x", "omega_y", "omega_z", "Nx", "Ny", "Nz", "phi", "psi", "gamma", "h", "alpha", "beta"];

/// Every output: the measurements, the deflections, the coefficients, the measurements
/// without noise and the body velocities.
fn outputs() -> Vec<String> {
    let mut names: Vec<String> = MEASURED.iter().map(|n| n.to_string()).collect();
    names.extend(["delta_x", "delta_y", "delta_z"].map(String::from));
    names.extend(NAMES.iter().map(|n| n.to_string()));
    names.extend(MEASURED.iter().map(|n| format!("{n}_true")));
    names.extend(["Vx", "Vy", "Vz"].map(String::from));
    names
}

struct Plant {
    instance: InstanceCS,
    vr: HashMap<String, u32>,
    outputs: Vec<u32>,
}

impl Plant {
    fn new(import: &Fmi2Import, name: &str) -> Self {
        let vr: HashMap<String, u32> = import
            .model_description()
            .model_variables
            .variables
            .iter()
            .map(|v| (v.name.clone(), v.value_reference))
            .collect();
        let outputs = outputs().iter().map(|n| vr[n]).collect();
        Self { instance: import.instantiate_cs(name, false, true).expect("fmi2Instantiate"), vr, outputs }
    }

    /// Initialises with these parameters, to run until `stop`.
    fn initialise(&mut self, reals: &[(&str, f64)], integers: &[(&str, i32)], stop: f64) {
        FmiInstance::enter_initialization_mode(&mut self.instance, None, 0.0, Some(stop)).expect("initialisation");
        let (vrs, values): (Vec<u32>, Vec<f64>) = reals.iter().map(|(n, v)| (self.vr[*n], *v)).unzip();
        Common::set_real(&mut self.instance, &vrs, &values).expect("fmi2SetReal of the parameters");
        let (vrs, values): (Vec<u32>, Vec<i32>) = integers.iter().map(|(n, v)| (self.vr[*n], *v)).unzip();
        Common::set_integer(&mut self.instance, &vrs, &values).expect("fmi2SetInteger of the parameters");
        Common::exit_initialization_mode(&mut self.instance).expect("fmi2ExitInitializationMode");
    }

    fn set_deflections(&mut self, delta: [f64; 3]) -> Result<(), String> {
        let vrs = ["delta_x_command", "delta_y_command", "delta_z_command"].map(|n| self.vr[n]);
        Common::set_real(&mut self.instance, &vrs, &delta).map(|_| ()).map_err(|e| e.to_string())
    }

    fn read(&mut self) -> Vec<f64> {
        let mut out = vec![0.0; self.outputs.len()];
        Common::get_real(&mut self.instance, &self.outputs, &mut out).expect("fmi2GetReal");
        out
    }

    fn step(&mut self, t: f64, h: f64) -> Result<(), String> {
        self.instance.do_step(t, h, true).map(|_| ()).map_err(|e| e.to_string())
    }
}

fn import() -> Fmi2Import {
    fmi::import::from_path(packaged::fmu_path(MODEL, "plant_s5")).expect("importing the .fmu")
}

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn with_the_studys_settings_it_gives_the_studys_truth_and_measurements_bit_for_bit() {
    // The roll-turn manoeuvre, which the estimators were not tuned on, with another seed
    // than the study's default and the sensors' noise twice the study's.
    let settings = Settings { seed: 3, noise_scale: 2.0, ..Settings::default() };
    let truth = simulate_named("roll-turn", &settings).unwrap();
    let measured = measure(&truth, settings.noise_scale, settings.seed);
    let dt = settings.sample_time;
    let noise: Vec<(String, f64)> =
        MEASURED.iter().zip(SENSOR_STD).map(|(n, s)| (format!("{n}_noise_std"), settings.noise_scale * s)).collect();
    let mut reals: Vec<(&str, f64)> = noise.iter().map(|(n, s)| (n.as_str(), *s)).collect();
    reals.push(("integration_step", dt / settings.truth_substeps as f64));
    let import = import();
    let mut plant = Plant::new(&import, "study");
    plant.initialise(&reals, &[("manoeuvre", 3), ("noise_seed", settings.seed as i32)], 20.0);
    for (k, z) in measured.iter().enumerate() {
        if k > 0 {
            plant.step((k - 1) as f64 * dt, dt).expect("fmi2DoStep");
        }
        let expected: Vec<f64> = z
            .iter()
            .chain(&truth.deflections[k])
            .chain(&truth.coefficients[k])
            .chain(&truth.measurements[k])
            .chain(&truth.motion[k][..3])
            .copied()
            .collect();
        let y = plant.read();
        for (i, name) in outputs().iter().enumerate() {
            assert_eq!(y[i].to_bits(), expected[i].to_bits(), "{name} at sample {k}: {} vs {}", y[i], expected[i]);
        }
    }
    assert!(truth.coefficients.first() != truth.coefficients.last(), "the coefficients changed in the run");
}

#[test]
fn deflection_inputs_are_held_over_each_step_and_read_through_at_once() {
    let h = 5e-4;
    let f = truth::s5::plant::Flight { manoeuvre: Manoeuvre::quiet(0.0), ..flight() };
    let mut reference = FlyingPlant::new(f, start(), h, Some([0.0; 3])).unwrap();
    let import = import();
    let mut plant = Plant::new(&import, "input");
    let noiseless: Vec<(String, f64)> = MEASURED.iter().map(|n| (format!("{n}_noise_std"), 0.0)).collect();
    let reals: Vec<(&str, f64)> = noiseless.iter().map(|(n, s)| (n.as_str(), *s)).collect();
    plant.initialise(&reals, &[("manoeuvre", 1)], 1.0);
    let dt = 0.005;
    let ny = MEASURED.iter().position(|n| *n == "Ny").unwrap();
    for k in 0..200 {
        let delta = [0.01 * (0.1 * k as f64).sin(), 0.02 * (0.07 * k as f64).cos(), -0.01 * (0.13 * k as f64).sin()];
        let before = plant.read();
        plant.set_deflections(delta).expect("the deflections");
        reference.set_deflections(delta).unwrap();
        let after = plant.read();
        assert_eq!(after[12..15], delta, "the deflections set at t, read at t");
        if before[13] != delta[1] {
            assert_ne!(after[ny], before[ny], "Ny reads the new δy through at t");
        }
        assert_eq!(bits(&after[..12]), bits(&reference.measurements()), "the measurements at sample {k}");
        plant.step(k as f64 * dt, dt).expect("fmi2DoStep");
        reference.advance(10).unwrap();
        let y = plant.read();
        assert_eq!(bits(&y[37..40]), bits(&reference.motion()[..3]), "the body velocities at sample {k}");
        assert_eq!(bits(&y[..12]), bits(&y[25..37]), "no noise: the measurements are the true ones");
    }
}

#[test]
fn its_fmu_state_replays_the_same_outputs_noise_included() {
    let import = import();
    let mut a = Plant::new(&import, "a");
    a.initialise(&[], &[("noise_seed", 3)], 1.0);
    let dt = 0.005;
    let run = |p: &mut Plant, from: usize, to: usize| -> Vec<Vec<f64>> {
        (from..to)
            .map(|k| {
                p.step(k as f64 * dt, dt).expect("fmi2DoStep");
                p.read()
            })
            .collect()
    };
    run(&mut a, 0, 40);
    let saved = a.instance.get_fmu_state().expect("fmi2GetFMUstate");
    let bytes = a.instance.serialize_fmu_state(&saved).expect("fmi2SerializeFMUstate");
    let first = run(&mut a, 40, 80);
    a.instance.set_fmu_state(&saved).ok().expect("fmi2SetFMUstate");
    assert_eq!(run(&mut a, 40, 80), first, "restored in the same instance");
    let mut b = Plant::new(&import, "b");
    b.initialise(&[], &[("noise_seed", 3)], 1.0);
    let restored = b.instance.deserialize_fmu_state(&bytes).expect("fmi2DeSerializeFMUstate");
    b.instance.set_fmu_state(&restored).ok().expect("fmi2SetFMUstate in a fresh instance");
    assert_eq!(run(&mut b, 40, 80), first, "deserialised in a fresh instance");
    assert!(first.windows(2).all(|w| w[0][0] != w[1][0]), "the noise is drawn anew at each step");
    assert!(b.instance.deserialize_fmu_state(&bytes[..bytes.len() - 1]).is_err(), "truncated");
}

#[test]
fn an_off_grid_step_a_nan_deflection_and_a_diverging_flight_are_refused_with_nothing_changed() {
    let import = import();
    let mut plant = Plant::new(&import, "refusals");
    plant.initialise(&[("integration_step", 1e-3)], &[("manoeuvre", 1)], 1.0);
    plant.step(0.0, 0.002).expect("two integration steps");
    let before = plant.read();
    assert!(plant.step(0.002, 0.0025).is_err(), "2.5 integration steps");
    assert!(plant.set_deflections([0.0, f64::NAN, 0.0]).is_err(), "a NaN deflection");
    assert_eq!(bits(&plant.read()), bits(&before));
    plant.step(0.002, 0.001).expect("the plant goes on from where it was");
    // A missile whose pitch coefficient no airframe has: its flight leaves the finite numbers.
    let mut wild = Plant::new(&import, "wild");
    wild.initialise(&[("Cy_a_before", 1e12)], &[], 20.0);
    let (mut t, dt) = (0.0, 0.005);
    let refused = loop {
        let before = wild.read();
        match wild.step(t, dt) {
            Ok(()) => t += dt,
            Err(_) => break before,
        }
        assert!(t < 20.0, "the flight of Cy_a = 1e12 diverges");
    };
    assert_eq!(bits(&wild.read()), bits(&refused), "a refused step changes nothing");
    assert!(wild.read().iter().all(|x| x.is_finite()));
}
