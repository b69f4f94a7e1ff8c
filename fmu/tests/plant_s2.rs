//! The packaged S2 plant FMU (`kalfmu_s2_track`) through the `fmi` crate's importer, as a
//! master drives it:
//!
//! * given the study's track, seed, speed, rate and noise σ and stepped at the study's
//!   sample time, it gives the study's recorded truth and measurements
//!   (`truth::s2::cases::simulate`, `measure`) bit for bit, on a random track and a weld;
//! * its FMU state replays the same outputs, restored in the same instance and
//!   deserialised in a fresh one, noise included;
//! * a step that is no whole number of samples is refused with nothing changed.
#![cfg(target_os = "linux")]

mod support {
    pub mod packaged;
}

use std::collections::HashMap;

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::traits::{FmiImport, FmiInstance, FmiStatus};
use support::packaged;
use truth::s2::cases::{measure, simulate, Case, Settings};

const MODEL: &str = "kalfmu_s2_track";
const CHANNELS: [&str; 7] = ["z_c_ddot", "z_t1_ddot", "z_t2_ddot", "z_w1_ddot", "z_w2_ddot", "z_w3_ddot", "z_w4_ddot"];

/// The outputs compared: the seven measured, the seven true, the four forces.
fn outputs() -> Vec<String> {
    let measured = CHANNELS.iter().map(|c| c.to_string());
    let true_ones = CHANNELS.iter().map(|c| format!("{c}_true"));
    measured.chain(true_ones).chain((1..=4).map(|j| format!("F_N{j}"))).collect()
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

    fn initialise(&mut self, reals: &[(String, f64)], integers: &[(&str, i32)], stop: f64) {
        FmiInstance::enter_initialization_mode(&mut self.instance, None, 0.0, Some(stop)).expect("initialisation");
        let (vrs, values): (Vec<u32>, Vec<f64>) = reals.iter().map(|(n, v)| (self.vr[n], *v)).unzip();
        Common::set_real(&mut self.instance, &vrs, &values).expect("fmi2SetReal of the parameters");
        let (vrs, values): (Vec<u32>, Vec<i32>) = integers.iter().map(|(n, v)| (self.vr[*n], *v)).unzip();
        Common::set_integer(&mut self.instance, &vrs, &values).expect("fmi2SetInteger of the parameters");
        Common::exit_initialization_mode(&mut self.instance).expect("fmi2ExitInitializationMode");
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
    fmi::import::from_path(packaged::fmu_path(MODEL, "plant_s2")).expect("importing the .fmu")
}

/// The study's run of `case` through the plant FMU, every output bit for bit.
fn the_studys_run(case: Case, track: i32, seed: u64) {
    let settings = Settings { duration: 0.3, seed, ..Settings::default() };
    let truth = simulate(case, &settings);
    let measured = measure(&truth, settings.noise_fraction, settings.seed);
    let mut reals = vec![
        ("speed".to_string(), settings.speed),
        ("sample_rate".to_string(), settings.rate),
        ("track_length".to_string(), settings.speed * settings.duration),
    ];
    for (c, s) in CHANNELS.iter().zip(measured.noise_std) {
        reals.push((format!("{c}_noise_std"), s));
    }
    let seed = seed as i32;
    let integers = [("track", track), ("track_spectrum", 1), ("track_seed", seed), ("noise_seed", seed)];
    let import = import();
    let mut plant = Plant::new(&import, case.name());
    plant.initialise(&reals, &integers, settings.duration);
    let dt = 1.0 / settings.rate;
    for k in 0..truth.time.len() {
        if k > 0 {
            plant.step((k - 1) as f64 * dt, dt).expect("fmi2DoStep");
        }
        let y = plant.read();
        let expected: Vec<f64> =
            measured.accelerations[k].iter().chain(&truth.accelerations[k]).chain(&truth.contact[k]).copied().collect();
        for (name, (a, b)) in outputs().iter().zip(y.iter().zip(&expected)) {
            assert_eq!(a.to_bits(), b.to_bits(), "{} {name} at sample {k}: {a} vs {b}", case.name());
        }
    }
}

#[test]
fn with_the_studys_settings_it_gives_the_studys_random_track_run_bit_for_bit() {
    the_studys_run(Case::Random, 1, 5);
}

#[test]
fn with_the_studys_settings_it_gives_the_studys_weld_run_bit_for_bit() {
    the_studys_run(Case::Weld, 3, 2);
}

#[test]
fn its_fmu_state_replays_the_same_outputs_noise_included_and_an_off_grid_step_is_refused() {
    let import = import();
    let mut a = Plant::new(&import, "a");
    a.initialise(&[], &[("track_seed", 3)], 1.0);
    let dt = 0.002;
    let run = |p: &mut Plant, from: usize, to: usize| -> Vec<Vec<f64>> {
        (from..to)
            .map(|k| {
                p.step(k as f64 * dt, dt).expect("fmi2DoStep");
                p.read()
            })
            .collect()
    };
    run(&mut a, 0, 30);
    let saved = a.instance.get_fmu_state().expect("fmi2GetFMUstate");
    let bytes = a.instance.serialize_fmu_state(&saved).expect("fmi2SerializeFMUstate");
    let first = run(&mut a, 30, 60);
    a.instance.set_fmu_state(&saved).ok().expect("fmi2SetFMUstate");
    assert_eq!(run(&mut a, 30, 60), first, "restored in the same instance");
    let mut b = Plant::new(&import, "b");
    b.initialise(&[], &[("track_seed", 3)], 1.0);
    let restored = b.instance.deserialize_fmu_state(&bytes).expect("fmi2DeSerializeFMUstate");
    b.instance.set_fmu_state(&restored).ok().expect("fmi2SetFMUstate in a fresh instance");
    assert_eq!(run(&mut b, 30, 60), first, "deserialised in a fresh instance");
    assert!(b.instance.deserialize_fmu_state(&bytes[..bytes.len() - 8]).is_err(), "truncated");
    let before = b.read();
    assert!(b.step(60.0 * dt, 0.0015).is_err(), "1.5 samples at 1 kHz");
    assert_eq!(b.read(), before, "the plant is where it was");
    b.step(60.0 * dt, 0.001).expect("and goes on from there");
}
