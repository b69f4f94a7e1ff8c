//! The packaged estimator FMUs driven through a second importer, the `fmi`
//! crate (rust-fmi): the `.fmu` is unzipped, its `modelDescription.xml` parsed
//! and its shared library loaded with `dlopen`, as any co-simulation master
//! does. Each check runs on S1 (`kalfmu_s1_load`, several parameters off their
//! defaults, so that every one is seen to reach the filter) and on S2
//! (`kalfmu_s2_wheel_rail`, its default parameters, whose vehicle is checked
//! to be the library's catalogue car, `VerticalVehicle::zhai_passenger`);
//! the reference is the SRCKF built here from the estimator crate — the
//! study's model, RK4, `Q`, `R` and prior from the parameter values as the
//! FMU's documentation gives them — behind the same `Supervisor`:
//!
//! * `*_outputs_equal_the_library_run_in_process`: 1000 samples of synthetic
//!   accelerations (a seeded sum of sines about the static equilibrium, every
//!   97th sample of the second input missing) through the FMU as a master
//!   drives it (set the inputs of t, read, step, read); the read after the
//!   inputs equals the reference after its update at t, the read after the
//!   step its prediction to t + dt, every estimate, deviation and the NIS bit
//!   for bit; the counts and flags at the end are the supervisor's;
//! * `*_communication_steps_shorter_and_longer_than_the_sample_time`: a master
//!   stepping by a fifth of the sample time and by two sample times (S1: 1 and
//!   10 ms at 5 ms); every read equals the reference run by the rules of
//!   `fmu/src/timing.rs`, bit for bit;
//! * `*_fmu_state_get_set_serialize_through_the_importer`: saved, restored and
//!   serialised states replay the same outputs, in the same instance and in a
//!   fresh one; garbage, truncated and foreign bytes are refused.
//!
//! The FMUs are packaged in-process the way `package-fmus` does it, from the
//! `libkalfmu_fmu.so` that cargo builds for this very test run (under
//! `cargo test` the cdylib is only in `target/<profile>/deps/`). Set
//! `KALFMU_FMU_DIR=path/to/dir` (holding `<modelIdentifier>.fmu`, as
//! `package-fmus --out` writes them) to test released FMUs instead.
#![cfg(target_os = "linux")]

use std::collections::HashMap;
use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use estimator::models::{Oscillator2Dof, Oscillator2DofLoad, PiecewiseLinear, VerticalVehicle, WheelRailVertical};
use estimator::{
    build_filter, Discretized, FilterKind, Gaussian, Noise, StateEstimator, Supervisor, SupervisorSettings,
    UnscentedParams,
};
use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::traits::{FmiImport, FmiInstance, FmiStatus};
use kalfmu_fmu::estimators::{self, Descriptor};
use kalfmu_fmu::model_description::{documentation, model_description};
use kalfmu_fmu::variables::Role;
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const SAMPLES: usize = 1000;

/// The `.fmu` of `model` under test: in `KALFMU_FMU_DIR`, or packaged once per
/// test process (under a lock: the tests run in parallel).
fn fmu_path(model: &str) -> PathBuf {
    static PACKAGED: Mutex<Vec<(String, PathBuf)>> = Mutex::new(Vec::new());
    if let Some(dir) = std::env::var_os("KALFMU_FMU_DIR") {
        return Path::new(&dir).join(format!("{model}.fmu"));
    }
    let mut packaged = PACKAGED.lock().expect("the packaged FMUs");
    if let Some((_, path)) = packaged.iter().find(|(m, _)| m == model) {
        return path.clone();
    }
    let path = package(model);
    packaged.push((model.to_owned(), path.clone()));
    path
}

/// Writes `<model>.fmu` with the layout `package-fmus` writes; stored rather
/// than deflated (deflating a 10 MB debug library in a debug build takes
/// seconds; importers read both).
fn package(model: &str) -> PathBuf {
    let exe = std::env::current_exe().expect("the test executable's path");
    let deps = exe.parent().expect("the test executable is in target/<profile>/deps");
    let library = deps.join("libkalfmu_fmu.so");
    let binary = fs::read(&library)
        .unwrap_or_else(|e| panic!("{}: {e} (cargo builds the cdylib next to the test executable)", library.display()));
    let d = descriptor(model);
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fmi_importer");
    fs::create_dir_all(&dir).expect("a directory for the packaged FMU");
    let path = dir.join(format!("{model}.fmu"));
    let mut zip = zip::ZipWriter::new(File::create(&path).expect("the .fmu file"));
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    let (xml, html) = (model_description(&d), documentation(&d));
    let entries: [(String, &[u8]); 3] = [
        ("modelDescription.xml".into(), xml.as_bytes()),
        (format!("binaries/linux64/{model}.so"), &binary),
        ("documentation/index.html".into(), html.as_bytes()),
    ];
    for (name, bytes) in entries {
        zip.start_file(name.as_str(), options).expect("a zip entry");
        zip.write_all(bytes).expect("the zip entry's bytes");
    }
    zip.finish().expect("the finished .fmu");
    path
}

fn descriptor(model: &str) -> Descriptor {
    estimators::all().into_iter().find(|d| d.model_identifier == model).unwrap_or_else(|| panic!("no FMU {model}"))
}

/// One FMU under test: the parameters this test sets, and the filter the FMU
/// should run with them.
struct Setup {
    /// The FMU's variable table: its names, roles and defaults.
    descriptor: Descriptor,
    /// Real parameters set in initialisation mode; the others keep their defaults.
    reals: Vec<(&'static str, f64)>,
    substeps: i32,
    /// The SRCKF the FMU should run, with the process noise of a prediction over `dt`.
    reference: fn(&Setup, f64) -> Box<dyn StateEstimator>,
}

impl Setup {
    /// S1 with the chain, prior and noise off their defaults.
    fn s1() -> Self {
        let reals = vec![
            ("m1", 4.0),
            ("m2", 8.0),
            ("k11", 5.0),
            ("k12", 20.0),
            ("k13", 30.0),
            ("delta1", 0.1),
            ("delta2", 0.2),
            ("c11", 5.0),
            ("c12", 6.0),
            ("c13", 7.5),
            ("eps1", 0.05),
            ("eps2", 0.1),
            ("k2", 15.0),
            ("c2", 3.0),
            ("x0_z1", 0.0),
            ("x0_z2", 0.0),
            ("x0_F", 1.5),
            ("x0_z1_dot", 0.0),
            ("x0_z2_dot", 0.0),
            ("x0_F_dot", 0.0),
            ("p0_z1_std", 1e-3),
            ("p0_z2_std", 1e-3),
            ("p0_F_std", 20.0),
            ("p0_z1_dot_std", 1e-3),
            ("p0_z2_dot_std", 1e-3),
            ("p0_F_dot_std", 500.0),
            ("q_z_std", 1e-6),
            ("q_z_dot_std", 1e-5),
            ("load_noise_intensity", 1.0e6),
            ("r_z1_ddot_std", 0.01),
            ("r_z2_ddot_std", 0.02),
            ("sample_time", 0.005),
        ];
        Self { descriptor: descriptor("kalfmu_s1_load"), reals, substeps: 2, reference: s1_reference }
    }

    /// S2 with its defaults.
    fn s2() -> Self {
        Self { descriptor: descriptor("kalfmu_s2_wheel_rail"), reals: Vec::new(), substeps: 1, reference: s2_reference }
    }

    fn model(&self) -> &'static str {
        self.descriptor.model_identifier
    }

    /// A Real parameter's value: as set here, or the FMU's default.
    fn get(&self, name: &str) -> f64 {
        let set = self.reals.iter().find(|(n, _)| *n == name).map(|(_, v)| *v);
        let default = || self.descriptor.variables.iter().find(|v| v.name == name).and_then(|v| v.start);
        set.or_else(default).unwrap_or_else(|| panic!("no parameter {name}"))
    }

    fn sample_time(&self) -> f64 {
        self.get("sample_time")
    }

    /// The names of the variables of this role, in table order.
    fn names(&self, role: impl Fn(Role) -> bool) -> Vec<&'static str> {
        self.descriptor.variables.iter().filter(|v| role(v.role)).map(|v| v.name).collect()
    }

    /// The inputs, in measurement-row order.
    fn inputs(&self) -> Vec<&'static str> {
        (0..self.descriptor.measurement_dim()).flat_map(|row| self.names(|r| r == Role::Measurement(row))).collect()
    }

    /// The outputs compared: every estimate and standard deviation as
    /// `(name, state index, standard deviation?)`, in table order; then `nis`.
    fn estimates(&self) -> Vec<(&'static str, usize, bool)> {
        let of = |role: Role| match role {
            Role::Estimate(i) => Some((i, false)),
            Role::EstimateStd(i) => Some((i, true)),
            _ => None,
        };
        self.descriptor.variables.iter().filter_map(|v| of(v.role).map(|(i, std)| (v.name, i, std))).collect()
    }

    fn reference_filter(&self) -> Box<dyn StateEstimator> {
        (self.reference)(self, self.sample_time())
    }

    fn reference_filter_over(&self, dt: f64) -> Box<dyn StateEstimator> {
        (self.reference)(self, dt)
    }

    /// What the FMU's outputs should be for a filter's belief: the estimates, then the NIS.
    fn expected_outputs(&self, belief: &dyn StateEstimator, nis: f64) -> Vec<f64> {
        self.estimates()
            .iter()
            .map(|(_, i, std)| if *std { belief.variance(*i).max(0.0).sqrt() } else { belief.mean()[*i] })
            .chain([nis])
            .collect()
    }
}

const UKF: UnscentedParams = UnscentedParams { alpha: 1e-3, beta: 2.0, kappa: 0.0 };

/// S1's SRCKF: the chain, RK4, `F̈` white with the given intensity discretised
/// exactly over `dt`, the per-sample position and velocity variances scaled
/// by `dt / sample_time`, a diagonal prior.
fn s1_reference(s: &Setup, dt: f64) -> Box<dyn StateEstimator> {
    let p = |n: &str| s.get(n);
    let chain = Oscillator2Dof {
        m1: p("m1"),
        m2: p("m2"),
        k1: PiecewiseLinear::new([p("k11"), p("k12"), p("k13")], [p("delta1"), p("delta2")]).unwrap(),
        c1: PiecewiseLinear::new([p("c11"), p("c12"), p("c13")], [p("eps1"), p("eps2")]).unwrap(),
        k2: p("k2"),
        c2: p("c2"),
    };
    let model = Discretized::rk4(Oscillator2DofLoad::new(chain), s.substeps as usize);
    let q = p("load_noise_intensity");
    let fraction = dt / p("sample_time");
    let mut qm = DMatrix::zeros(6, 6);
    for i in [0, 1] {
        qm[(i, i)] = p("q_z_std") * p("q_z_std") * fraction;
        qm[(i + 3, i + 3)] = p("q_z_dot_std") * p("q_z_dot_std") * fraction;
    }
    qm[(2, 2)] = q * dt.powi(3) / 3.0;
    qm[(2, 5)] = q * dt.powi(2) / 2.0;
    qm[(5, 2)] = qm[(2, 5)];
    qm[(5, 5)] = q * dt;
    let r =
        DMatrix::from_diagonal(&DVector::from_column_slice(&[p("r_z1_ddot_std").powi(2), p("r_z2_ddot_std").powi(2)]));
    let noise = Noise::new(qm, r).unwrap();
    let names = ["z1", "z2", "F", "z1_dot", "z2_dot", "F_dot"];
    let mean: Vec<f64> = names.iter().map(|n| p(&format!("x0_{n}"))).collect();
    let variances: Vec<f64> = names.iter().map(|n| p(&format!("p0_{n}_std")).powi(2)).collect();
    let prior = Gaussian::diagonal(&mean, &variances);
    build_filter(FilterKind::SrCkf, model, noise, &prior, UKF).unwrap()
}

/// S2's vehicle: half of the vehicle given whole, with the weighed static wheel load.
fn s2_vehicle(s: &Setup) -> VerticalVehicle {
    let p = |n: &str| s.get(n);
    let beyond = p("primary_damping_beyond");
    let damper = PiecewiseLinear::new([p("primary_damping"), beyond, beyond], [p("primary_damper_knee"); 2]).unwrap();
    VerticalVehicle {
        static_wheel_load: p("static_wheel_load"),
        ..VerticalVehicle::half_of(
            (p("car_body_mass"), p("car_body_pitch_inertia")),
            (p("bogie_mass"), p("bogie_pitch_inertia")),
            p("wheelset_mass"),
            (p("primary_stiffness"), damper),
            (p("secondary_stiffness"), p("secondary_damping")),
            p("half_bogie_spacing"),
            p("half_wheelbase"),
        )
    }
}

/// S2's SRCKF: its vehicle, RK4; the motion states' per-sample variances
/// scaled by `dt / sample_time`, the forces' random walk `intensity·dt`; `R`
/// from the sensors' deviations; the prior at equilibrium with the forces at
/// the static wheel load.
fn s2_reference(s: &Setup, dt: f64) -> Box<dyn StateEstimator> {
    let p = |n: &str| s.get(n);
    let vehicle = s2_vehicle(s);
    let model = Discretized::rk4(WheelRailVertical { vehicle }, s.substeps as usize);
    let fraction = dt / p("sample_time");
    let (body, wheelset) = (p("q_body_std").powi(2) * fraction, p("q_wheelset_std").powi(2) * fraction);
    // Positions, then velocities: car body and bogies (6) before the wheelsets (4).
    let mut q = [[body; 6].as_slice(), &[wheelset; 4], &[body; 6], &[wheelset; 4]].concat();
    q.extend([p("force_noise_intensity") * dt; 4]);
    let r: Vec<f64> = s.inputs().iter().map(|n| p(&format!("r_{n}_std")).powi(2)).collect();
    let noise = Noise::diagonal(&q, &r).unwrap();
    let mut mean = [0.0; 24];
    mean[WheelRailVertical::FORCES..].fill(vehicle.static_wheel_load);
    let mut variances = [p("p0_motion_std").powi(2); 24];
    variances[WheelRailVertical::FORCES..].fill(p("p0_force_std").powi(2));
    let prior = Gaussian::diagonal(&mean, &variances);
    build_filter(FilterKind::SrCkf, model, noise, &prior, UKF).unwrap()
}

/// Measured accelerations of `m` inputs about the static equilibrium (the
/// models' coordinates): per input a seeded sum of four sines plus white noise
/// of 0.01·(i + 1) m/s²; every 97th sample of the second input is missing (NaN).
fn accelerations(m: usize, n: usize, dt: f64, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let tones: Vec<Vec<(f64, f64, f64)>> = (0..m)
        .map(|_| {
            (0..4)
                .map(|_| {
                    let amplitude = rng.random_range(0.05..0.5);
                    (amplitude, rng.random_range(0.5..12.0), rng.random_range(0.0..std::f64::consts::TAU))
                })
                .collect()
        })
        .collect();
    let signal =
        |tones: &[(f64, f64, f64)], t: f64| tones.iter().map(|(amp, w, phi)| amp * (w * t + phi).sin()).sum::<f64>();
    (0..n)
        .map(|k| {
            let t = (k + 1) as f64 * dt;
            let mut z: Vec<f64> = tones
                .iter()
                .enumerate()
                .map(|(i, tones)| signal(tones, t) + 0.01 * (i + 1) as f64 * (rng.random::<f64>() - 0.5))
                .collect();
            if k % 97 == 96 {
                z[1] = f64::NAN;
            }
            z
        })
        .collect()
}

/// One instance of the imported FMU with the value references by name.
struct Fmu {
    instance: InstanceCS,
    vr: HashMap<String, u32>,
    inputs: Vec<u32>,
    outputs: Vec<u32>,
}

impl Fmu {
    fn new(import: &Fmi2Import, setup: &Setup, name: &str) -> Self {
        let vr: HashMap<String, u32> = import
            .model_description()
            .model_variables
            .variables
            .iter()
            .map(|v| (v.name.clone(), v.value_reference))
            .collect();
        let inputs = setup.inputs().iter().map(|n| vr[*n]).collect();
        let outputs = setup.estimates().iter().map(|(n, _, _)| vr[*n]).chain([vr["nis"]]).collect();
        let instance = import.instantiate_cs(name, false, true).expect("fmi2Instantiate");
        Self { instance, vr, inputs, outputs }
    }

    /// SetupExperiment + EnterInitializationMode, the parameters, ExitInitializationMode.
    fn initialise(&mut self, setup: &Setup, stop: f64) {
        FmiInstance::enter_initialization_mode(&mut self.instance, None, 0.0, Some(stop)).expect("initialisation");
        let (vrs, values): (Vec<u32>, Vec<f64>) = setup.reals.iter().map(|(n, v)| (self.vr[*n], *v)).unzip();
        Common::set_real(&mut self.instance, &vrs, &values).expect("fmi2SetReal of the parameters");
        let (filter, substeps) = (self.vr["filter"], self.vr["rk4_substeps"]);
        Common::set_integer(&mut self.instance, &[filter, substeps], &[2, setup.substeps])
            .expect("fmi2SetInteger of filter and rk4_substeps");
        Common::exit_initialization_mode(&mut self.instance).expect("fmi2ExitInitializationMode");
    }

    /// Sets the inputs at the current communication point.
    fn set_inputs(&mut self, z: &[f64]) {
        Common::set_real(&mut self.instance, &self.inputs, z).expect("fmi2SetReal of the inputs");
    }

    /// The outputs compared (`Setup::estimates`, then `nis`).
    fn read(&mut self) -> Vec<f64> {
        let mut out = vec![0.0; self.outputs.len()];
        Common::get_real(&mut self.instance, &self.outputs, &mut out).expect("fmi2GetReal");
        out
    }

    fn do_step(&mut self, t: f64, h: f64) {
        self.instance.do_step(t, h, true).unwrap_or_else(|e| panic!("fmi2DoStep({t}, {h}): {e}"));
    }

    /// A master's sample `k`: the inputs of `t_k`, `fmi2DoStep(t_k, dt)`; the outputs after it.
    fn step(&mut self, k: usize, dt: f64, z: &[f64]) -> Vec<f64> {
        self.set_inputs(z);
        self.do_step(k as f64 * dt, dt);
        self.read()
    }
}

/// The FMU driven as a master drives it, sample by sample, against the
/// reference behind its own supervisor (see the module documentation).
fn outputs_equal_the_library_run_in_process(setup: &Setup) {
    let model = setup.model();
    let dt = setup.sample_time();
    let m = setup.inputs().len();
    let z = accelerations(m, SAMPLES + 1, dt, 20240611);
    let import: Fmi2Import = fmi::import::from_path(fmu_path(model)).expect("importing the .fmu");
    let md = import.model_description();
    assert_eq!(md.fmi_version, "2.0");
    assert_eq!(md.co_simulation.as_ref().map(|cs| cs.model_identifier.as_str()), Some(model));
    let mut fmu = Fmu::new(&import, setup, model);
    assert_eq!(Common::get_version(&fmu.instance), "2.0");
    assert_eq!(Common::get_types_platform(&fmu.instance), "default");
    fmu.initialise(setup, SAMPLES as f64 * dt);

    let mut reference = setup.reference_filter();
    let mut supervisor = Supervisor::new(SupervisorSettings::default(), m).unwrap();
    for (k, zk) in z.iter().enumerate() {
        let t = k as f64 * dt;
        if k > 0 {
            // The read right after the step to t: the prediction from the measurements before t.
            reference.predict(&[], dt).unwrap();
            let after_step = fmu.read();
            let expected = setup.expected_outputs(reference.as_ref(), reference.innovation().nis());
            assert_eq!(bits(&[after_step]), bits(&[expected]), "{model}: after the step to sample {k}");
        }
        fmu.set_inputs(zk);
        let nis = supervisor.gate(reference.as_mut(), zk).unwrap().nis;
        supervisor.commit(|_| {});
        let expected = setup.expected_outputs(reference.as_ref(), nis);
        assert_eq!(bits(&[fmu.read()]), bits(&[expected]), "{model}: at sample {k}");
        if k < SAMPLES {
            fmu.do_step(t, dt);
        }
    }

    // The counts and flags are the supervisor's. (These sums of sines are no
    // trajectory of the model: the filter may rightly find them inconsistent.)
    let missing = z.iter().filter(|zk| zk.iter().any(|v| v.is_nan())).count();
    let names = ["skipped_measurements", "rejected_measurements"];
    let mut counts = [0; 2];
    Common::get_integer(&mut fmu.instance, &names.map(|n| fmu.vr[n]), &mut counts).expect("fmi2GetInteger");
    assert_eq!(counts, [missing as i32, supervisor.rejected() as i32], "{model}: {names:?}");
    let flags: Vec<&str> =
        ["filter_healthy"].into_iter().chain(setup.names(|r| matches!(r, Role::ChannelFault(_)))).collect();
    let vrs: Vec<u32> = flags.iter().map(|n| fmu.vr[*n]).collect();
    let mut got = vec![0; flags.len()];
    Common::get_boolean(&mut fmu.instance, &vrs, &mut got).expect("fmi2GetBoolean");
    let channels = supervisor.channels().iter().map(|c| c.faulty);
    let expected: Vec<i32> = [supervisor.healthy()].into_iter().chain(channels).map(i32::from).collect();
    assert_eq!(got, expected, "{model}: {flags:?}");
    let last = fmu.instance.last_successful_time().expect("fmi2GetRealStatus");
    assert!((last - SAMPLES as f64 * dt).abs() < 1e-9, "{model}: last successful time {last}");
    // A step past the stop time is refused (and the instance still answers).
    assert!(fmu.instance.do_step(SAMPLES as f64 * dt, dt, true).is_err(), "{model}: a step past the stop time");
    Common::terminate(&mut fmu.instance).expect("fmi2Terminate");
}

#[test]
fn s1_outputs_equal_the_library_run_in_process() {
    outputs_equal_the_library_run_in_process(&Setup::s1());
}

#[test]
fn s2_outputs_equal_the_library_run_in_process() {
    let setup = Setup::s2();
    // The FMU's default vehicle is the library's catalogue car, weight and all.
    assert_eq!(s2_vehicle(&setup), VerticalVehicle::zhai_passenger());
    outputs_equal_the_library_run_in_process(&setup);
}

/// A master stepping by `h` over `samples` sample times, setting the plant's
/// outputs (`signal`) at every communication point and reading before and
/// after each step; every read must equal the library filter run by the rules
/// of `fmu/src/timing.rs`:
/// * at a sample instant that is a communication point, the update with the
///   inputs there (read after them) — once;
/// * samples inside a step: prediction only;
/// * a read off the grid: the prediction from the last sample to that time,
///   with the process noise of that interval.
fn check_master(setup: &Setup, h: f64, samples: usize) {
    let (model, ts, m) = (setup.model(), setup.sample_time(), setup.inputs().len());
    let duration = samples as f64 * ts;
    // Input i: a tone of (7 + 4i) rad/s and a small one of 53 rad/s.
    let signal = |t: f64| -> Vec<f64> {
        (0..m).map(|i| 0.5 * ((7.0 + 4.0 * i as f64) * t).sin() + 0.1 * (53.0 * t + i as f64).cos()).collect()
    };
    let import: Fmi2Import = fmi::import::from_path(fmu_path(model)).expect("importing the .fmu");
    let mut fmu = Fmu::new(&import, setup, &format!("master-{h}"));
    fmu.initialise(setup, duration);
    let mut reference = setup.reference_filter();
    let mut supervisor = Supervisor::new(SupervisorSettings::default(), m).unwrap();
    let steps = (duration / h).round() as usize;
    let mut k = 0; // the reference's sample
    let on_grid = |t: f64| ((t / ts).round() * ts - t).abs() < 1e-9;
    let expected_at = |reference: &dyn StateEstimator, t: f64, k: usize| -> Vec<f64> {
        let dt = t - k as f64 * ts;
        if dt.abs() < 1e-9 {
            return setup.expected_outputs(reference, reference.innovation().nis());
        }
        let mut ahead = setup.reference_filter_over(dt);
        ahead.restore(&reference.snapshot()).unwrap();
        ahead.predict(&[], dt).unwrap();
        setup.expected_outputs(ahead.as_ref(), reference.innovation().nis())
    };
    // The master's clock, as masters keep it and the FMU follows it: t += h.
    let mut t = 0.0;
    for j in 0..=steps {
        let z = signal(t);
        fmu.set_inputs(&z);
        if on_grid(t) {
            supervisor.gate(reference.as_mut(), &z).unwrap();
            supervisor.commit(|_| {});
        }
        let expected = expected_at(reference.as_ref(), t, k);
        assert_eq!(bits(&[fmu.read()]), bits(&[expected]), "{model}, h {h}: read at t = {t}");
        if j == steps {
            break;
        }
        fmu.do_step(t, h);
        while ((k + 1) as f64 * ts) <= (t + h) + 1e-9 {
            reference.predict(&[], ts).unwrap();
            k += 1;
        }
        t += h;
        let expected = expected_at(reference.as_ref(), t, k);
        assert_eq!(bits(&[fmu.read()]), bits(&[expected]), "{model}, h {h}: read after the step to t = {t}");
    }
    Common::terminate(&mut fmu.instance).expect("fmi2Terminate");
}

/// Communication steps of a fifth of the sample time and of two: 1 and 10 ms
/// at S1's 5 ms, 0.2 and 2 ms at S2's 1 ms; 100 samples each.
fn communication_steps_shorter_and_longer_than_the_sample_time(setup: &Setup) {
    let ts = setup.sample_time();
    check_master(setup, ts / 5.0, 100);
    check_master(setup, 2.0 * ts, 100);
}

#[test]
fn s1_communication_steps_shorter_and_longer_than_the_sample_time() {
    communication_steps_shorter_and_longer_than_the_sample_time(&Setup::s1());
}

#[test]
fn s2_communication_steps_shorter_and_longer_than_the_sample_time() {
    communication_steps_shorter_and_longer_than_the_sample_time(&Setup::s2());
}

/// 400 samples, a saved state, 300 more; the state restored and serialised
/// replays those 300 bit for bit.
fn fmu_state_get_set_serialize_through_the_importer(setup: &Setup) {
    let model = setup.model();
    let dt = setup.sample_time();
    let (first, second) = (400, 300);
    let z = accelerations(setup.inputs().len(), first + second, dt, 77);
    let import: Fmi2Import = fmi::import::from_path(fmu_path(model)).expect("importing the .fmu");
    let mut a = Fmu::new(&import, setup, "a");
    a.initialise(setup, 100.0);
    for (k, zk) in z[..first].iter().enumerate() {
        a.step(k, dt, zk);
    }
    let saved = a.instance.get_fmu_state().expect("fmi2GetFMUstate");
    let bytes = a.instance.serialize_fmu_state(&saved).expect("fmi2SerializeFMUstate");
    assert_eq!(a.instance.serialize_fmu_state(&saved).expect("again"), bytes, "serialising is deterministic");
    let run = |fmu: &mut Fmu| -> Vec<Vec<f64>> {
        z[first..].iter().enumerate().map(|(j, zk)| fmu.step(first + j, dt, zk)).collect()
    };
    let original = run(&mut a);

    // Back in the same instance: the same outputs, bit for bit.
    a.instance.set_fmu_state(&saved).ok().expect("fmi2SetFMUstate");
    assert_eq!(bits(&run(&mut a)), bits(&original), "{model}: replay after fmi2SetFMUstate");

    // fmi2GetFMUstate into an existing state overwrites it.
    a.instance.update_fmu_state(&saved).ok().expect("fmi2GetFMUstate into an existing state");
    let later = a.instance.serialize_fmu_state(&saved).expect("fmi2SerializeFMUstate");
    assert_ne!(later, bytes, "{model}: the updated state is the later one");
    let again = a.instance.deserialize_fmu_state(&bytes).expect("fmi2DeSerializeFMUstate");
    a.instance.set_fmu_state(&again).ok().expect("fmi2SetFMUstate of the deserialised state");
    assert_eq!(bits(&run(&mut a)), bits(&original), "{model}: replay after deserialising in the same instance");

    // A fresh instance, never initialised, restores the serialised bytes.
    let mut b = Fmu::new(&import, setup, "b");
    let restored = b.instance.deserialize_fmu_state(&bytes).expect("fmi2DeSerializeFMUstate");
    b.instance.set_fmu_state(&restored).ok().expect("fmi2SetFMUstate in a fresh instance");
    assert_eq!(bits(&run(&mut b)), bits(&original), "{model}: replay in a fresh instance");

    // Garbage, truncated or foreign bytes are refused.
    assert!(b.instance.deserialize_fmu_state(&vec![0x5a; bytes.len()]).is_err(), "garbage of the right length");
    assert!(b.instance.deserialize_fmu_state(&bytes[..bytes.len() - 1]).is_err(), "truncated");
    let mut other = bytes.clone();
    other[20] ^= 0x01; // inside the GUID
    assert!(b.instance.deserialize_fmu_state(&other).is_err(), "another FMU's GUID");
    Common::terminate(&mut a.instance).expect("fmi2Terminate a");
    Common::terminate(&mut b.instance).expect("fmi2Terminate b");
}

#[test]
fn s1_fmu_state_get_set_serialize_through_the_importer() {
    fmu_state_get_set_serialize_through_the_importer(&Setup::s1());
}

#[test]
fn s2_fmu_state_get_set_serialize_through_the_importer() {
    fmu_state_get_set_serialize_through_the_importer(&Setup::s2());
}

fn bits(rows: &[Vec<f64>]) -> Vec<Vec<u64>> {
    rows.iter().map(|r| r.iter().map(|x| x.to_bits()).collect()).collect()
}
