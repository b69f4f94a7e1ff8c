//! The packaged S1 plant FMU (`kalfmu_s1_chain`) through the `fmi` crate's importer,
//! as a master drives it:
//!
//! * given the study's chain, load, seed, integration step and noise σ and stepped at
//!   the study's sample time, it gives the study's truth and measurements
//!   (`truth::s1::simulate`) bit for bit (the load to rounding: the law on the
//!   RK4 stage grid, where the study records it at the sample time);
//! * with the load as its input, it is the truth's plant under that load held over
//!   each step, bit for bit, and an input set at `t` shows in the outputs read at `t`;
//! * its FMU state replays the same outputs, restored in the same instance and
//!   deserialised in a fresh one, noise included;
//! * a step that is no whole number of integration steps, and a NaN load, are
//!   refused with nothing changed.
#![cfg(target_os = "linux")]

mod support {
    pub mod packaged;
}

use std::collections::HashMap;

use estimator::models::Oscillator2Dof;
use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::traits::{FmiImport, FmiInstance, FmiStatus};
use support::packaged;
use truth::s1::load::Load;
use truth::s1::plant::{ChainPlant, LoadSource};
use truth::s1::{chain_parameters, Case, LoadKind, Nonlinearity, Settings};

const MODEL: &str = "kalfmu_s1_chain";

/// What the plant outputs, in this order.
const OUTPUTS: [&str; 9] = ["z1_ddot", "z2_ddot", "F", "z1", "z2", "z1_dot", "z2_dot", "z1_ddot_true", "z2_ddot_true"];

struct Plant {
    instance: InstanceCS,
    vr: HashMap<String, u32>,
}

impl Plant {
    fn new(import: &Fmi2Import, name: &str) -> Self {
        let vr = import
            .model_description()
            .model_variables
            .variables
            .iter()
            .map(|v| (v.name.clone(), v.value_reference))
            .collect();
        Self { instance: import.instantiate_cs(name, false, true).expect("fmi2Instantiate"), vr }
    }

    /// Initialises with these parameters and the load input `load`, to run until `stop`.
    fn initialise(&mut self, reals: &[(&str, f64)], integers: &[(&str, i32)], load: f64, stop: f64) {
        FmiInstance::enter_initialization_mode(&mut self.instance, None, 0.0, Some(stop)).expect("initialisation");
        let (vrs, values): (Vec<u32>, Vec<f64>) = reals.iter().map(|(n, v)| (self.vr[*n], *v)).unzip();
        Common::set_real(&mut self.instance, &vrs, &values).expect("fmi2SetReal of the parameters");
        let (vrs, values): (Vec<u32>, Vec<i32>) = integers.iter().map(|(n, v)| (self.vr[*n], *v)).unzip();
        Common::set_integer(&mut self.instance, &vrs, &values).expect("fmi2SetInteger of the parameters");
        self.set_load(load).expect("the load");
        Common::exit_initialization_mode(&mut self.instance).expect("fmi2ExitInitializationMode");
    }

    fn set_load(&mut self, load: f64) -> Result<(), String> {
        Common::set_real(&mut self.instance, &[self.vr["load"]], &[load]).map(|_| ()).map_err(|e| e.to_string())
    }

    fn read(&mut self) -> [f64; 9] {
        let vrs: Vec<u32> = OUTPUTS.iter().map(|n| self.vr[*n]).collect();
        let mut out = [0.0; 9];
        Common::get_real(&mut self.instance, &vrs, &mut out).expect("fmi2GetReal");
        out
    }

    fn step(&mut self, t: f64, h: f64) -> Result<(), String> {
        self.instance.do_step(t, h, true).map(|_| ()).map_err(|e| e.to_string())
    }
}

fn import() -> Fmi2Import {
    fmi::import::from_path(packaged::fmu_path(MODEL, "plant_s1")).expect("importing the .fmu")
}

#[test]
fn with_the_studys_settings_it_gives_the_studys_truth_and_measurements_bit_for_bit() {
    // The study's stiffness-nonlinear chain (its damper linear: 1e300 breakpoints keep it
    // so to the bit) under its random load of another seed than its default, over 10 s.
    let case = Case { nonlinearity: Nonlinearity::Stiffness, load: LoadKind::Random, unseen: None };
    let settings = Settings { duration: 10.0, seed: 3, ..Settings::default() };
    let (truth, measured) = truth::s1::simulate(&case, &settings);
    let dt = settings.dt();
    let mut reals: Vec<(&str, f64)> = chain_parameters(&case.chain()).to_vec();
    reals.extend([
        ("integration_step", dt / settings.truth_substeps() as f64),
        ("load_rms", settings.load_rms),
        ("z1_ddot_noise_std", measured.noise_std[0]),
        ("z2_ddot_noise_std", measured.noise_std[1]),
    ]);
    let seed = settings.seed as i32;
    let integers = [("load_source", 2), ("load_seed", seed), ("noise_seed", seed)];
    let import = import();
    let mut plant = Plant::new(&import, "study");
    plant.initialise(&reals, &integers, 0.0, settings.duration);
    for k in 0..=settings.samples() {
        if k > 0 {
            plant.step((k - 1) as f64 * dt, dt).expect("fmi2DoStep");
        }
        let y = plant.read();
        let [z1, z2, z1_dot, z2_dot] = truth.motion[k];
        let expected = [
            measured.acceleration[k][0],
            measured.acceleration[k][1],
            truth.load[k],
            z1,
            z2,
            z1_dot,
            z2_dot,
            truth.acceleration[k][0],
            truth.acceleration[k][1],
        ];
        for (i, name) in OUTPUTS.iter().enumerate() {
            if *name == "F" {
                // The load that acted on the chain is the law on the RK4 stage grid (tabulated
                // by a recurrence, re-anchored every `Load::ANCHOR` half steps); the study
                // records the law evaluated at the sample time: the same to rounding.
                let tolerance = 1e-10 * settings.load_rms;
                assert!((y[i] - expected[i]).abs() <= tolerance, "F at sample {k}: {} vs {}", y[i], expected[i]);
                continue;
            }
            assert_eq!(y[i].to_bits(), expected[i].to_bits(), "{name} at sample {k}: {} vs {}", y[i], expected[i]);
        }
    }
}

#[test]
fn a_load_input_is_held_over_each_step_and_read_through_at_once() {
    let chain = Oscillator2Dof::stiffness_nonlinear();
    let h = 1e-4;
    let mut reference = ChainPlant::new(chain, LoadSource::Held(0.0), h).unwrap();
    let import = import();
    let mut plant = Plant::new(&import, "input");
    let noiseless = [("integration_step", h), ("z1_ddot_noise_std", 0.0), ("z2_ddot_noise_std", 0.0)];
    plant.initialise(&noiseless, &[("load_source", 1)], 3.0, 1.0);
    reference.set_load(3.0).unwrap();
    let dt = 0.005;
    for k in 0..100 {
        let load = 10.0 * (0.3 * k as f64).sin();
        let before = plant.read();
        plant.set_load(load).expect("the load");
        reference.set_load(load).unwrap();
        let after = plant.read();
        assert_eq!(after[2], load, "F is the load set at t, read at t");
        if k > 0 && load != before[2] {
            assert_ne!(after[1], before[1], "z2_ddot reads the new load through at t");
        }
        assert_eq!(after[1].to_bits(), reference.accelerations()[1].to_bits(), "z2_ddot at sample {k}");
        plant.step(k as f64 * dt, dt).expect("fmi2DoStep");
        reference.advance(50);
        let y = plant.read();
        assert_eq!(y[3..7].iter().map(|x| x.to_bits()).collect::<Vec<_>>(), reference.motion().map(f64::to_bits));
        assert_eq!(y[0].to_bits(), y[7].to_bits(), "no noise: z1_ddot is the true one");
    }
}

#[test]
fn its_fmu_state_replays_the_same_outputs_noise_included() {
    let import = import();
    let mut a = Plant::new(&import, "a");
    a.initialise(&[], &[("load_source", 4), ("load_seed", 3)], 0.0, 1.0);
    let dt = 0.005;
    let run = |p: &mut Plant, from: usize, to: usize| -> Vec<[f64; 9]> {
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
    b.initialise(&[], &[("load_source", 4), ("load_seed", 3)], 0.0, 1.0);
    let restored = b.instance.deserialize_fmu_state(&bytes).expect("fmi2DeSerializeFMUstate");
    b.instance.set_fmu_state(&restored).ok().expect("fmi2SetFMUstate in a fresh instance");
    assert_eq!(run(&mut b, 40, 80), first, "deserialised in a fresh instance");
    assert!(first.windows(2).all(|w| w[0][0] != w[1][0]), "the noise is drawn anew at each step");
    assert!(b.instance.deserialize_fmu_state(&bytes[..bytes.len() - 1]).is_err(), "truncated");
}

#[test]
fn a_step_off_the_integration_grid_and_a_nan_load_are_refused_with_nothing_changed() {
    let import = import();
    let mut plant = Plant::new(&import, "refusals");
    plant.initialise(&[("integration_step", 1e-3)], &[("load_source", 1)], 1.0, 1.0);
    plant.step(0.0, 0.002).expect("two integration steps");
    let before = plant.read();
    assert!(plant.step(0.002, 0.0025).is_err(), "2.5 integration steps");
    assert!(plant.set_load(f64::NAN).is_err(), "a NaN load");
    assert_eq!(plant.read(), before);
    plant.step(0.002, 0.001).expect("the plant goes on from where it was");
    // The load of a law is the law's: the input is ignored.
    let mut law = Plant::new(&import, "law");
    law.initialise(&[], &[("load_source", 3)], 0.0, 1.0);
    law.set_load(5.0).expect("accepted");
    assert_eq!(law.read()[2], Load::harmonic().value(0.0));
}
