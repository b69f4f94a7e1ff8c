//! The `input_timing_check` output and its warning, through the packaged FMU
//! driven by the `fmi` crate as a co-simulation master drives it
//! (`fmu/src/input_timing_check.rs`, `docs/fmu-interface.md`).
//!
//! Two plants: S1's chain (`kalfmu_s1_load`, the FMU's default chain under the
//! paper's harmonic load, RK4 at a fifth of the sample time, both accelerations
//! with 2 % noise) and S4's train (`kalfmu_s4_maglev`, 5 m/s past four position
//! channels at their levers with offsets and 1.5 mm of noise, and a marker
//! reading every 50th sample from the 25th: NaN at the start, so that the
//! comparison meets NaN on both sides). The masters set the plant's outputs of
//! the start time in initialisation mode, then before each `fmi2DoStep(t, h)`:
//! * Jacobi: the plant's outputs of `t`;
//! * Gauss–Seidel: those of `t + h` (it has stepped the plant first).
//!
//! Checked on each plant, under both `input_timing` values: the verdict
//! (0 undecided, 1 fits, 2 the other fits) after every step, and that exactly
//! the mismatched runs log one warning naming `input_timing` and the value to
//! set while the matched ones log no warning at all; without inputs in
//! initialisation mode, or with a plant at rest, the check stays undecided and
//! silent; a state saved before the first step and restored (in the same
//! instance and, serialised, in a fresh one) decides again the same, bit for bit.
//!
//! Messages reach the test through fmi-sys's C logger, which forwards them to
//! the `log` crate with the instance name as target. The FMU is packaged as
//! `fmu/tests/fmi_importer.rs` does it (or taken from `KALFMU_FMU_DIR`).
#![cfg(target_os = "linux")]

mod support {
    pub mod packaged;
}

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{LazyLock, Mutex, Once};

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::traits::{FmiImport, FmiInstance, FmiStatus};
use kalfmu_fmu::estimators::{self, Descriptor};
use kalfmu_fmu::variables::Role;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use support::packaged;

/// Communication steps per run.
const STEPS: usize = 300;

// ----- the packaged FMU (as fmi_importer.rs finds it) -----

/// The `.fmu` of `model` under test (`support/packaged.rs`).
fn fmu_path(model: &str) -> PathBuf {
    packaged::fmu_path(model, "input_timing_check")
}

fn descriptor(model: &str) -> Descriptor {
    estimators::all().into_iter().find(|d| d.model_identifier == model).unwrap_or_else(|| panic!("no FMU {model}"))
}

// ----- the messages, per instance name -----

type Messages = Vec<(log::Level, String)>;

static MESSAGES: LazyLock<Mutex<HashMap<String, Messages>>> = LazyLock::new(|| Mutex::new(HashMap::new()));

/// Receives what fmi-sys's C logger forwards: target = instance name.
struct Recorder;

impl log::Log for Recorder {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, record: &log::Record) {
        if let Ok(mut all) = MESSAGES.lock() {
            all.entry(record.target().to_owned()).or_default().push((record.level(), record.args().to_string()));
        }
    }
    fn flush(&self) {}
}

fn install_recorder() {
    static INSTALL: Once = Once::new();
    INSTALL.call_once(|| {
        log::set_logger(&Recorder).expect("no other logger in this test binary");
        log::set_max_level(log::LevelFilter::Trace);
    });
}

/// The warnings (fmi2Warning) instance `name` logged since the last call.
fn take_warnings(name: &str) -> Vec<String> {
    let messages = MESSAGES.lock().expect("the message table").remove(name).unwrap_or_default();
    messages.into_iter().filter(|(level, _)| *level == log::Level::Warn).map(|(_, m)| m).collect()
}

// ----- the plants -----

/// A plant and the FMU that estimates from its outputs.
struct Plant {
    /// Names the runs' instances.
    label: &'static str,
    model: &'static str,
    /// The communication step: the FMU's default sample time.
    h: f64,
    /// Real parameters set in initialisation mode (the sensors' noise).
    reals: Vec<(&'static str, f64)>,
    /// The plant's outputs at `k·h`, `k = 0 … STEPS + 1`, in measurement-row order.
    rows: Vec<Vec<f64>>,
}

/// A parameter's default, the start value in the FMU's table.
fn default_of(d: &Descriptor, name: &str) -> f64 {
    d.variables.iter().find(|v| v.name == name).and_then(|v| v.start).unwrap_or_else(|| panic!("no {name}"))
}

/// S1's chain as the FMU's defaults have it (the ground spring and damper
/// piecewise linear), the paper's harmonic load on m2, RK4 at h / 5; both
/// accelerations sampled every h with noise of 2 % of their RMS, which the
/// FMU's sensor noise is set to.
fn s1_chain() -> Plant {
    let model = "kalfmu_s1_load";
    let d = descriptor(model);
    let p = |name: &str| default_of(&d, name);
    let h = d.default_experiment.step;
    let law = |x: f64, slopes: [f64; 3], breaks: [f64; 2]| {
        let a = x.abs();
        let force = slopes[0] * a.min(breaks[0])
            + slopes[1] * (a.min(breaks[1]) - breaks[0]).max(0.0)
            + slopes[2] * (a - breaks[1]).max(0.0);
        force.copysign(x)
    };
    let (k1, delta) = ([p("k11"), p("k12"), p("k13")], [p("delta1"), p("delta2")]);
    let (c1, eps) = ([p("c11"), p("c12"), p("c13")], [p("eps1"), p("eps2")]);
    let (m1, m2, k2, c2) = (p("m1"), p("m2"), p("k2"), p("c2"));
    let load = |t: f64| {
        [(8.0, 1.0), (6.0, 2.0), (5.0, 3.0), (4.0, 5.0), (3.0, 7.0)]
            .iter()
            .map(|(amplitude, f)| amplitude * (std::f64::consts::TAU * f * t).sin())
            .sum::<f64>()
    };
    // x = [z1, z2, z1_dot, z2_dot]
    let accelerations = |t: f64, x: [f64; 4]| {
        let coupling = k2 * (x[1] - x[0]) + c2 * (x[3] - x[2]);
        [(coupling - law(x[0], k1, delta) - law(x[2], c1, eps)) / m1, (load(t) - coupling) / m2]
    };
    let derivative = |t: f64, x: [f64; 4]| {
        let [a1, a2] = accelerations(t, x);
        [x[2], x[3], a1, a2]
    };
    let along = |x: [f64; 4], d: [f64; 4], s: f64| std::array::from_fn(|i| x[i] + s * d[i]);
    let mut x = [0.0; 4];
    let mut clean = Vec::with_capacity(STEPS + 2);
    for k in 0..STEPS + 2 {
        let t = k as f64 * h;
        clean.push(accelerations(t, x));
        let dt = h / 5.0;
        for i in 0..5 {
            let s = t + i as f64 * dt;
            let k1 = derivative(s, x);
            let k2 = derivative(s + dt / 2.0, along(x, k1, dt / 2.0));
            let k3 = derivative(s + dt / 2.0, along(x, k2, dt / 2.0));
            let k4 = derivative(s + dt, along(x, k3, dt));
            x = std::array::from_fn(|j| x[j] + dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]));
        }
    }
    let rms = |j: usize| (clean.iter().map(|a| a[j] * a[j]).sum::<f64>() / clean.len() as f64).sqrt();
    let noise = [0.02 * rms(0), 0.02 * rms(1)];
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let rows = clean
        .iter()
        .map(|a| (0..2).map(|j| a[j] + noise[j] * (rng.random::<f64>() - 0.5) * 12f64.sqrt()).collect())
        .collect();
    Plant { label: "s1-chain", model, h, reals: vec![("r_z1_ddot_std", noise[0]), ("r_z2_ddot_std", noise[1])], rows }
}

/// S4's train: 5 m/s from 0.3 m past the four channels at their default levers,
/// with offsets and 1.5 mm of noise (the channels' default `r_<input>_std`); a
/// marker reading every 50th sample from the 25th, NaN between (and at the start).
fn s4_train() -> Plant {
    let model = "kalfmu_s4_maglev";
    let d = descriptor(model);
    let h = d.default_experiment.step;
    let levers =
        ["lever_head_left", "lever_head_right", "lever_tail_left", "lever_tail_right"].map(|l| default_of(&d, l));
    let offsets = [0.03, -0.02, 0.01, -0.04];
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let rows = (0..STEPS + 2)
        .map(|k| {
            let position = 0.3 + 5.0 * h * k as f64;
            let mut z: Vec<f64> = (0..4)
                .map(|c| position + levers[c] + offsets[c] + 1.5e-3 * (rng.random::<f64>() - 0.5) * 12f64.sqrt())
                .collect();
            z.push(if k % 50 == 25 { position + 0.01 * (rng.random::<f64>() - 0.5) * 12f64.sqrt() } else { f64::NAN });
            z
        })
        .collect();
    Plant { label: "s4-train", model, h, reals: Vec::new(), rows }
}

/// S1's chain at rest: no load, every acceleration exactly 0 at every sample.
fn s1_at_rest() -> Plant {
    Plant { label: "s1-at-rest", rows: vec![vec![0.0; 2]; STEPS + 2], ..s1_chain() }
}

// ----- the masters -----

#[derive(Debug, Clone, Copy, PartialEq)]
enum Master {
    /// Sets the plant's outputs of t before fmi2DoStep(t, h).
    Jacobi,
    /// Steps the plant first: sets its outputs of t + h before fmi2DoStep(t, h).
    GaussSeidel,
}

impl Master {
    /// The plant's row a master sets before fmi2DoStep(k·h, h).
    fn row(self, k: usize) -> usize {
        match self {
            Master::Jacobi => k,
            Master::GaussSeidel => k + 1,
        }
    }
}

/// One instance of the imported FMU with the value references it needs.
struct Fmu {
    instance: InstanceCS,
    vr: HashMap<String, u32>,
    inputs: Vec<u32>,
    /// The estimates and their deviations: what a rollback must replay bit for bit.
    estimates: Vec<u32>,
}

impl Fmu {
    fn new(import: &Fmi2Import, name: &str) -> Self {
        install_recorder();
        let vr: HashMap<String, u32> = import
            .model_description()
            .model_variables
            .variables
            .iter()
            .map(|v| (v.name.clone(), v.value_reference))
            .collect();
        let d = descriptor(&import.model_description().co_simulation.as_ref().expect("Co-Simulation").model_identifier);
        let names = |pick: &dyn Fn(Role) -> bool| -> Vec<u32> {
            d.variables.iter().filter(|v| pick(v.role)).map(|v| vr[&*v.name]).collect()
        };
        let inputs = (0..d.measurement_dim()).flat_map(|row| names(&|r| r == Role::Measurement(row))).collect();
        let estimates = names(&|r| matches!(r, Role::Estimate(_) | Role::EstimateStd(_)));
        let instance = import.instantiate_cs(name, false, true).expect("fmi2Instantiate");
        Self { instance, vr, inputs, estimates }
    }

    /// Initialises with `input_timing` = `timing` and the plant's parameters;
    /// sets the plant's outputs of the start time in initialisation mode if `with_inputs`.
    fn initialise(&mut self, plant: &Plant, timing: i32, with_inputs: bool) {
        FmiInstance::enter_initialization_mode(&mut self.instance, None, 0.0, Some(10.0 * STEPS as f64 * plant.h))
            .expect("initialisation");
        Common::set_integer(&mut self.instance, &[self.vr["input_timing"]], &[timing]).expect("input_timing");
        let (vrs, values): (Vec<u32>, Vec<f64>) = plant.reals.iter().map(|(n, v)| (self.vr[*n], *v)).unzip();
        Common::set_real(&mut self.instance, &vrs, &values).expect("fmi2SetReal of the parameters");
        if with_inputs {
            self.set_inputs(&plant.rows[0]);
        }
        assert_eq!(self.check(), 0, "in initialisation mode");
        Common::exit_initialization_mode(&mut self.instance).expect("fmi2ExitInitializationMode");
        assert_eq!(self.check(), 0, "before the first step");
    }

    fn set_inputs(&mut self, z: &[f64]) {
        Common::set_real(&mut self.instance, &self.inputs, z).expect("fmi2SetReal of the inputs");
    }

    /// `input_timing_check`.
    fn check(&mut self) -> i32 {
        let mut value = [-1];
        Common::get_integer(&mut self.instance, &[self.vr["input_timing_check"]], &mut value)
            .expect("fmi2GetInteger of input_timing_check");
        value[0]
    }

    /// The master's steps `from … to - 1`: the check after each and the
    /// estimates after the last, as bits.
    fn run(&mut self, plant: &Plant, master: Master, from: usize, to: usize) -> (Vec<i32>, Vec<u64>) {
        let mut checks = Vec::with_capacity(to - from);
        for k in from..to {
            self.set_inputs(&plant.rows[master.row(k)]);
            let t = k as f64 * plant.h;
            self.instance.do_step(t, plant.h, true).unwrap_or_else(|e| panic!("fmi2DoStep({t}, {}): {e}", plant.h));
            checks.push(self.check());
        }
        let mut estimates = vec![0.0; self.estimates.len()];
        Common::get_real(&mut self.instance, &self.estimates, &mut estimates).expect("fmi2GetReal");
        (checks, estimates.iter().map(|x| x.to_bits()).collect())
    }
}

/// A whole run: the check after every step and every warning.
fn run(plant: &Plant, master: Master, timing: i32, with_inputs: bool) -> (Vec<i32>, Vec<String>) {
    let import: Fmi2Import = fmi::import::from_path(fmu_path(plant.model)).expect("importing the .fmu");
    let name = format!("{}-{master:?}-timing{timing}-init{with_inputs}", plant.label);
    let mut fmu = Fmu::new(&import, &name);
    fmu.initialise(plant, timing, with_inputs);
    let (checks, _) = fmu.run(plant, master, 0, STEPS);
    Common::terminate(&mut fmu.instance).expect("fmi2Terminate");
    (checks, take_warnings(&name))
}

/// The check over a run: `first` after the first step, `then` after every later one.
fn checks(first: i32, then: i32) -> Vec<i32> {
    std::iter::once(first).chain(std::iter::repeat_n(then, STEPS - 1)).collect()
}

/// The four runs of a plant: each master under each timing.
fn the_verdict_fits_the_master(plant: &Plant) {
    let model = plant.model;
    // A Jacobi master is told at the second step (its first row repeats the
    // initialisation's), a Gauss–Seidel one at the first.
    for (master, timing, expected, advice) in [
        (Master::Jacobi, 1, checks(0, 1), None),
        (Master::GaussSeidel, 1, checks(2, 2), Some("set input_timing = 2 (step_end)")),
        (Master::GaussSeidel, 2, checks(1, 1), None),
        (Master::Jacobi, 2, checks(0, 2), Some("set input_timing = 1 (communication_point)")),
    ] {
        let (got, warnings) = run(plant, master, timing, true);
        let what = format!("{model}, {master:?} master, input_timing = {timing}");
        assert_eq!(got, expected, "{what}: input_timing_check after each step");
        match advice {
            // A fitting timing: no warning at all (these plants keep the filter healthy).
            None => assert!(warnings.is_empty(), "{what}: {warnings:?}"),
            Some(advice) => {
                let about: Vec<&String> = warnings.iter().filter(|w| w.contains("input_timing")).collect();
                assert_eq!(about.len(), 1, "{what}: one warning on input_timing: {warnings:?}");
                assert!(about[0].contains(advice), "{what}: the warning says `{advice}`: {}", about[0]);
            }
        }
    }
}

#[test]
fn s1_the_verdict_fits_the_master() {
    the_verdict_fits_the_master(&s1_chain());
}

#[test]
fn s4_the_verdict_fits_the_master() {
    the_verdict_fits_the_master(&s4_train());
}

/// Without inputs set in initialisation mode nothing is compared: undecided and
/// silent under either master and timing (the fitting runs log nothing but the
/// inputs never set at the read before the first step).
fn without_inputs_in_initialisation_mode_the_check_stays_undecided(plant: &Plant) {
    for (master, timing) in
        [(Master::Jacobi, 1), (Master::GaussSeidel, 1), (Master::GaussSeidel, 2), (Master::Jacobi, 2)]
    {
        let (got, warnings) = run(plant, master, timing, false);
        let what = format!("{}, {master:?} master, input_timing = {timing}", plant.model);
        assert_eq!(got, checks(0, 0), "{what}");
        assert!(!warnings.iter().any(|w| w.contains("input_timing")), "{what}: {warnings:?}");
        // The read after fmi2ExitInitializationMode meets inputs never set: that is reported, nothing else.
        let fitting = matches!((master, timing), (Master::Jacobi, 1) | (Master::GaussSeidel, 2));
        let others: Vec<&String> = warnings.iter().filter(|w| !w.contains("has never been set")).collect();
        assert!(!fitting || others.is_empty(), "{what}: {others:?}");
    }
}

#[test]
fn s1_without_inputs_in_initialisation_mode_the_check_stays_undecided() {
    without_inputs_in_initialisation_mode_the_check_stays_undecided(&s1_chain());
}

#[test]
fn s4_without_inputs_in_initialisation_mode_the_check_stays_undecided() {
    without_inputs_in_initialisation_mode_the_check_stays_undecided(&s4_train());
}

/// A plant at rest hands over the same row under either ordering: a Jacobi
/// master under `input_timing` = 2 is not told to switch (its inputs stood
/// still over the first two steps), nor is a Gauss–Seidel one under 1.
#[test]
fn outputs_that_stand_still_leave_the_check_undecided() {
    let plant = s1_at_rest();
    for (master, timing) in [(Master::Jacobi, 2), (Master::GaussSeidel, 1)] {
        let (got, warnings) = run(&plant, master, timing, true);
        let what = format!("at rest, {master:?} master, input_timing = {timing}");
        assert_eq!(got, checks(0, 0), "{what}");
        // (Inputs that repeat bit for bit are stuck: those warnings are the supervisor's.)
        assert!(!warnings.iter().any(|w| w.contains("input_timing")), "{what}: {warnings:?}");
    }
}

/// A state saved before the first step (after the inputs of initialisation
/// mode) and restored decides again as the first run did, with the same
/// warning and bit for bit the same estimates: in the same instance, and
/// serialised into a fresh one. A state saved after the verdict restores it.
fn a_restored_state_decides_again_the_same(plant: &Plant) {
    let model = plant.model;
    let import: Fmi2Import = fmi::import::from_path(fmu_path(model)).expect("importing the .fmu");
    let (name, fresh_name) = (format!("{}-rollback", plant.label), format!("{}-rollback-fresh", plant.label));
    let mut fmu = Fmu::new(&import, &name);
    // A Gauss–Seidel master under input_timing = 1: decided at the first step, with a warning.
    fmu.initialise(plant, 1, true);
    let before = fmu.instance.get_fmu_state().expect("fmi2GetFMUstate");
    let bytes = fmu.instance.serialize_fmu_state(&before).expect("fmi2SerializeFMUstate");
    let (mut head, _) = fmu.run(plant, Master::GaussSeidel, 0, 10);
    let after = fmu.instance.get_fmu_state().expect("fmi2GetFMUstate after the verdict");
    let (tail, estimates) = fmu.run(plant, Master::GaussSeidel, 10, STEPS);
    head.extend(tail);
    let first = (head, estimates);
    assert_eq!(first.0, checks(2, 2), "{model}: the first run");
    let warned = take_warnings(&name);
    assert_eq!(warned.iter().filter(|w| w.contains("input_timing")).count(), 1, "{model}: {warned:?}");

    fmu.instance.set_fmu_state(&before).ok().expect("fmi2SetFMUstate");
    assert_eq!(fmu.check(), 0, "{model}: restored to before the first step");
    assert_eq!(fmu.run(plant, Master::GaussSeidel, 0, STEPS), first, "{model}: the replay in the same instance");
    assert_eq!(take_warnings(&name), warned, "{model}: the replay warns as the first run did");

    let mut fresh = Fmu::new(&import, &fresh_name);
    let restored = fresh.instance.deserialize_fmu_state(&bytes).expect("fmi2DeSerializeFMUstate");
    fresh.instance.set_fmu_state(&restored).ok().expect("fmi2SetFMUstate in a fresh instance");
    assert_eq!(fresh.check(), 0, "{model}: restored in a fresh instance");
    assert_eq!(fresh.run(plant, Master::GaussSeidel, 0, STEPS), first, "{model}: the replay in a fresh instance");
    assert_eq!(take_warnings(&fresh_name), warned, "{model}: the fresh instance warns as the first run did");

    // After the verdict: restored, it holds, and the steps after it do not warn again.
    fmu.instance.set_fmu_state(&after).ok().expect("fmi2SetFMUstate of the later state");
    assert_eq!(fmu.check(), 2, "{model}: the verdict restored");
    let (later, _) = fmu.run(plant, Master::GaussSeidel, 10, 15);
    assert_eq!(later, vec![2; 5], "{model}: steps after the restored verdict");
    assert!(take_warnings(&name).is_empty(), "{model}: no second warning after the restored verdict");
    Common::terminate(&mut fmu.instance).expect("fmi2Terminate");
    Common::terminate(&mut fresh.instance).expect("fmi2Terminate the fresh instance");
}

#[test]
fn s1_a_restored_state_decides_again_the_same() {
    a_restored_state_decides_again_the_same(&s1_chain());
}

#[test]
fn s4_a_restored_state_decides_again_the_same() {
    a_restored_state_decides_again_the_same(&s4_train());
}
