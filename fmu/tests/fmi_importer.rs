//! The packaged S1 FMU driven through a second importer, the `fmi` crate
//! (rust-fmi): the `.fmu` is unzipped, its `modelDescription.xml` parsed and
//! its shared library loaded with `dlopen`, as any co-simulation master does.
//!
//! * `outputs_equal_the_library_run_in_process`: 1000 samples of synthetic
//!   accelerations (a seeded sum of sines, a few samples missing) through the
//!   FMU as a master drives it (set the inputs of t, read, step, read); the
//!   read after the inputs equals the same SRCKF built here from the
//!   estimator crate (behind the same `Supervisor`) after its update at t,
//!   the read after the step its prediction to t + dt, bit for bit.
//! * `communication_steps_of_1_and_10_ms_follow_the_timing_rules`: at a 5 ms
//!   sample time, every read of a 1 ms and a 10 ms master equals the
//!   library's filter run by the rules of `fmu/src/timing.rs`, bit for bit.
//! * `fmu_state_get_set_serialize_through_the_importer`: saved, restored and
//!   serialised states replay the same outputs, in the same instance and in a
//!   fresh one.
//!
//! The FMU is packaged in-process the way `package-fmus` does it, from the
//! `libkalfmu_fmu.so` that cargo builds for this very test run (under
//! `cargo test` the cdylib is only in `target/<profile>/deps/`). Set
//! `KALFMU_FMU=path/to/kalfmu_s1_load.fmu` to test a released FMU instead.
#![cfg(target_os = "linux")]

use std::collections::HashMap;
use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use estimator::models::{Oscillator2Dof, Oscillator2DofLoad, PiecewiseLinear};
use estimator::{
    build_filter, Discretized, FilterKind, Gaussian, Noise, StateEstimator, Supervisor, SupervisorSettings,
    UnscentedParams,
};
use fmi::fmi2::import::Fmi2Import;
use fmi::fmi2::instance::{CoSimulation, Common, InstanceCS};
use fmi::traits::{FmiImport, FmiInstance, FmiStatus};
use kalfmu_fmu::estimators;
use kalfmu_fmu::model_description::{documentation, model_description};
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const MODEL: &str = "kalfmu_s1_load";
const SAMPLES: usize = 1000;

/// The `.fmu` under test: `KALFMU_FMU`, or packaged once per test process.
fn fmu_path() -> &'static Path {
    static PATH: OnceLock<PathBuf> = OnceLock::new();
    PATH.get_or_init(|| match std::env::var_os("KALFMU_FMU") {
        Some(path) => PathBuf::from(path),
        None => package(),
    })
}

/// Writes `kalfmu_s1_load.fmu` with the layout `package-fmus` writes; stored
/// rather than deflated (deflating a 10 MB debug library in a debug build
/// takes seconds; importers read both).
fn package() -> PathBuf {
    let exe = std::env::current_exe().expect("the test executable's path");
    let deps = exe.parent().expect("the test executable is in target/<profile>/deps");
    let library = deps.join("libkalfmu_fmu.so");
    let binary = fs::read(&library)
        .unwrap_or_else(|e| panic!("{}: {e} (cargo builds the cdylib next to the test executable)", library.display()));
    let d = estimators::all().into_iter().find(|d| d.model_identifier == MODEL).expect("the S1 estimator");
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fmi_importer");
    fs::create_dir_all(&dir).expect("a directory for the packaged FMU");
    let path = dir.join(format!("{MODEL}.fmu"));
    let mut zip = zip::ZipWriter::new(File::create(&path).expect("the .fmu file"));
    let options = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Stored);
    let (xml, html) = (model_description(&d), documentation(&d));
    let entries: [(String, &[u8]); 3] = [
        ("modelDescription.xml".into(), xml.as_bytes()),
        (format!("binaries/linux64/{MODEL}.so"), &binary),
        ("documentation/index.html".into(), html.as_bytes()),
    ];
    for (name, bytes) in entries {
        zip.start_file(name.as_str(), options).expect("a zip entry");
        zip.write_all(bytes).expect("the zip entry's bytes");
    }
    zip.finish().expect("the finished .fmu");
    path
}

/// The parameters this test sets (several differ from the FMU's defaults, so
/// the comparison also checks that every parameter reaches the filter).
struct Setup {
    reals: Vec<(&'static str, f64)>,
    substeps: i32,
}

impl Setup {
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
        Self { reals, substeps: 2 }
    }

    fn get(&self, name: &str) -> f64 {
        self.reals.iter().find(|(n, _)| *n == name).map(|(_, v)| *v).unwrap_or_else(|| panic!("no parameter {name}"))
    }

    /// The SRCKF the FMU should run, built from the estimator crate directly:
    /// the S1 chain, RK4, `F̈` white with the given intensity discretised
    /// exactly over the sample time, a diagonal prior.
    fn reference_filter(&self) -> Box<dyn StateEstimator> {
        self.reference_filter_over(self.get("sample_time"))
    }

    /// The same filter with the process noise of a prediction over `dt`: the
    /// per-sample position and velocity variances scaled by `dt / sample_time`.
    fn reference_filter_over(&self, dt: f64) -> Box<dyn StateEstimator> {
        let p = |n: &str| self.get(n);
        let chain = Oscillator2Dof {
            m1: p("m1"),
            m2: p("m2"),
            k1: PiecewiseLinear::new([p("k11"), p("k12"), p("k13")], [p("delta1"), p("delta2")]).unwrap(),
            c1: PiecewiseLinear::new([p("c11"), p("c12"), p("c13")], [p("eps1"), p("eps2")]).unwrap(),
            k2: p("k2"),
            c2: p("c2"),
        };
        let model = Discretized::rk4(Oscillator2DofLoad::new(chain), self.substeps as usize);
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
        let r = DMatrix::from_diagonal(&DVector::from_column_slice(&[
            p("r_z1_ddot_std").powi(2),
            p("r_z2_ddot_std").powi(2),
        ]));
        let noise = Noise::new(qm, r).unwrap();
        let names = ["z1", "z2", "F", "z1_dot", "z2_dot", "F_dot"];
        let mean: Vec<f64> = names.iter().map(|n| p(&format!("x0_{n}"))).collect();
        let variances: Vec<f64> = names.iter().map(|n| p(&format!("p0_{n}_std")).powi(2)).collect();
        let prior = Gaussian::diagonal(&mean, &variances);
        let ukf = UnscentedParams { alpha: 1e-3, beta: 2.0, kappa: 0.0 };
        build_filter(FilterKind::SrCkf, model, noise, &prior, ukf).unwrap()
    }
}

/// Measured accelerations: a seeded sum of sines plus noise; every 97th
/// sample of `z2_ddot` is missing (NaN).
fn accelerations(n: usize, dt: f64, seed: u64) -> Vec<[f64; 2]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut tones = || -> Vec<(f64, f64, f64)> {
        (0..4)
            .map(|_| {
                (rng.random_range(0.05..0.5), rng.random_range(0.5..12.0), rng.random_range(0.0..std::f64::consts::TAU))
            })
            .collect()
    };
    let (a, b) = (tones(), tones());
    let signal =
        |tones: &[(f64, f64, f64)], t: f64| tones.iter().map(|(amp, w, phi)| amp * (w * t + phi).sin()).sum::<f64>();
    (0..n)
        .map(|k| {
            let t = (k + 1) as f64 * dt;
            let z1 = signal(&a, t) + 0.01 * (rng.random::<f64>() - 0.5);
            let z2 = signal(&b, t) + 0.02 * (rng.random::<f64>() - 0.5);
            [z1, if k % 97 == 96 { f64::NAN } else { z2 }]
        })
        .collect()
}

/// The outputs compared: `(name, state index, standard deviation?)`, and `nis`.
const ESTIMATES: [(&str, usize, bool); 12] = [
    ("z1", 0, false),
    ("z1_std", 0, true),
    ("z2", 1, false),
    ("z2_std", 1, true),
    ("F", 2, false),
    ("F_std", 2, true),
    ("z1_dot", 3, false),
    ("z1_dot_std", 3, true),
    ("z2_dot", 4, false),
    ("z2_dot_std", 4, true),
    ("F_dot", 5, false),
    ("F_dot_std", 5, true),
];

/// One instance of the imported FMU with the value references by name.
struct Fmu {
    instance: InstanceCS,
    vr: HashMap<String, u32>,
    inputs: [u32; 2],
    outputs: Vec<u32>,
}

impl Fmu {
    fn new(import: &Fmi2Import, name: &str) -> Self {
        let vr: HashMap<String, u32> = import
            .model_description()
            .model_variables
            .variables
            .iter()
            .map(|v| (v.name.clone(), v.value_reference))
            .collect();
        let inputs = [vr["z1_ddot"], vr["z2_ddot"]];
        let outputs = ESTIMATES.iter().map(|(n, _, _)| vr[*n]).chain([vr["nis"]]).collect();
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
    fn set_inputs(&mut self, z: [f64; 2]) {
        Common::set_real(&mut self.instance, &self.inputs, &z).expect("fmi2SetReal of the inputs");
    }

    /// The outputs compared (`ESTIMATES`, then `nis`).
    fn read(&mut self) -> Vec<f64> {
        let mut out = vec![0.0; self.outputs.len()];
        Common::get_real(&mut self.instance, &self.outputs, &mut out).expect("fmi2GetReal");
        out
    }

    fn do_step(&mut self, t: f64, h: f64) {
        self.instance.do_step(t, h, true).unwrap_or_else(|e| panic!("fmi2DoStep({t}, {h}): {e}"));
    }

    /// A master's sample `k`: the inputs of `t_k`, `fmi2DoStep(t_k, dt)`; the outputs after it.
    fn step(&mut self, k: usize, dt: f64, z: [f64; 2]) -> Vec<f64> {
        self.set_inputs(z);
        self.do_step(k as f64 * dt, dt);
        self.read()
    }
}

/// What the FMU's outputs should be for a filter's belief: `ESTIMATES`, then the NIS.
fn expected_outputs(belief: &dyn StateEstimator, nis: f64) -> Vec<f64> {
    ESTIMATES
        .iter()
        .map(|(_, i, std)| if *std { belief.variance(*i).max(0.0).sqrt() } else { belief.mean()[*i] })
        .chain([nis])
        .collect()
}

#[test]
fn outputs_equal_the_library_run_in_process() {
    let setup = Setup::s1();
    let dt = setup.get("sample_time");
    let z = accelerations(SAMPLES + 1, dt, 20240611);
    let import: Fmi2Import = fmi::import::from_path(fmu_path()).expect("importing the .fmu");
    let md = import.model_description();
    assert_eq!(md.fmi_version, "2.0");
    assert_eq!(md.co_simulation.as_ref().map(|cs| cs.model_identifier.as_str()), Some(MODEL));
    let mut fmu = Fmu::new(&import, "s1");
    assert_eq!(Common::get_version(&fmu.instance), "2.0");
    assert_eq!(Common::get_types_platform(&fmu.instance), "default");
    fmu.initialise(&setup, SAMPLES as f64 * dt);

    let mut reference = setup.reference_filter();
    let mut supervisor = Supervisor::new(SupervisorSettings::default(), 2).unwrap();
    for (k, zk) in z.iter().enumerate() {
        let t = k as f64 * dt;
        if k > 0 {
            // The read right after the step to t: the prediction from the measurements before t.
            reference.predict(&[], dt).unwrap();
            let after_step = fmu.read();
            let expected = expected_outputs(reference.as_ref(), reference.innovation().nis());
            assert_eq!(bits(&[after_step]), bits(&[expected]), "after the step to sample {k}");
        }
        fmu.set_inputs(*zk);
        let nis = supervisor.gate(reference.as_mut(), zk).unwrap().nis;
        supervisor.commit(|_| {});
        assert_eq!(bits(&[fmu.read()]), bits(&[expected_outputs(reference.as_ref(), nis)]), "at sample {k}");
        if k < SAMPLES {
            fmu.do_step(t, dt);
        }
    }

    // The counts and flags are the supervisor's. (These sums of sines are no
    // trajectory of the chain: the filter is rightly found inconsistent.)
    let missing = z.iter().filter(|zk| zk.iter().any(|v| v.is_nan())).count();
    let names = ["skipped_measurements", "rejected_measurements"];
    let mut counts = [0; 2];
    Common::get_integer(&mut fmu.instance, &names.map(|n| fmu.vr[n]), &mut counts).expect("fmi2GetInteger");
    assert_eq!(counts, [missing as i32, supervisor.rejected() as i32], "{names:?}");
    let flags = ["filter_healthy", "z1_ddot_fault", "z2_ddot_fault"];
    let mut got = [0; 3];
    Common::get_boolean(&mut fmu.instance, &flags.map(|n| fmu.vr[n]), &mut got).expect("fmi2GetBoolean");
    let channels = supervisor.channels();
    let expected = [supervisor.healthy(), channels[0].faulty, channels[1].faulty].map(i32::from);
    assert_eq!(got, expected, "{flags:?}");
    let last = fmu.instance.last_successful_time().expect("fmi2GetRealStatus");
    assert!((last - SAMPLES as f64 * dt).abs() < 1e-9, "last successful time {last}");
    // A step past the stop time is refused (and the instance still answers).
    assert!(fmu.instance.do_step(SAMPLES as f64 * dt, dt, true).is_err(), "a step past the stop time");
    Common::terminate(&mut fmu.instance).expect("fmi2Terminate");
}

/// A master stepping by `h` at the 5 ms sample time over `duration`, setting
/// the plant's outputs (`signal`) at every communication point and reading
/// before and after each step; every read must equal the library filter run
/// by the rules of `fmu/src/timing.rs`:
/// * at a sample instant that is a communication point, the update with the
///   inputs there (read after them) — once;
/// * samples inside a step: prediction only;
/// * a read off the grid: the prediction from the last sample to that time,
///   with the process noise of that interval.
fn check_master(h: f64, duration: f64) {
    let setup = Setup::s1();
    let ts = setup.get("sample_time");
    let signal = |t: f64| -> [f64; 2] { [(7.0 * t).sin() + 0.1 * (53.0 * t).cos(), 0.5 * (11.0 * t).sin()] };
    let import: Fmi2Import = fmi::import::from_path(fmu_path()).expect("importing the .fmu");
    let mut fmu = Fmu::new(&import, &format!("master-{h}"));
    fmu.initialise(&setup, duration);
    let mut reference = setup.reference_filter();
    let mut supervisor = Supervisor::new(SupervisorSettings::default(), 2).unwrap();
    let steps = (duration / h).round() as usize;
    let mut k = 0; // the reference's sample
    let on_grid = |t: f64| ((t / ts).round() * ts - t).abs() < 1e-9;
    let expected_at = |reference: &dyn StateEstimator, t: f64, k: usize| -> Vec<f64> {
        let dt = t - k as f64 * ts;
        if dt.abs() < 1e-9 {
            return expected_outputs(reference, reference.innovation().nis());
        }
        let mut ahead = setup.reference_filter_over(dt);
        ahead.restore(&reference.snapshot()).unwrap();
        ahead.predict(&[], dt).unwrap();
        expected_outputs(ahead.as_ref(), reference.innovation().nis())
    };
    // The master's clock, as masters keep it and the FMU follows it: t += h.
    let mut t = 0.0;
    for j in 0..=steps {
        let z = signal(t);
        fmu.set_inputs(z);
        if on_grid(t) {
            supervisor.gate(reference.as_mut(), &z).unwrap();
            supervisor.commit(|_| {});
        }
        assert_eq!(bits(&[fmu.read()]), bits(&[expected_at(reference.as_ref(), t, k)]), "h {h}: read at t = {t}");
        if j == steps {
            break;
        }
        fmu.do_step(t, h);
        while ((k + 1) as f64 * ts) <= (t + h) + 1e-9 {
            reference.predict(&[], ts).unwrap();
            k += 1;
        }
        t += h;
        assert_eq!(
            bits(&[fmu.read()]),
            bits(&[expected_at(reference.as_ref(), t, k)]),
            "h {h}: read after the step to t = {t}"
        );
    }
    Common::terminate(&mut fmu.instance).expect("fmi2Terminate");
}

#[test]
fn communication_steps_of_1_and_10_ms_follow_the_timing_rules() {
    check_master(0.001, 0.5);
    check_master(0.010, 0.5);
}

#[test]
fn fmu_state_get_set_serialize_through_the_importer() {
    let setup = Setup::s1();
    let dt = setup.get("sample_time");
    let (first, second) = (400, 300);
    let z = accelerations(first + second, dt, 77);
    let import: Fmi2Import = fmi::import::from_path(fmu_path()).expect("importing the .fmu");
    let mut a = Fmu::new(&import, "a");
    a.initialise(&setup, 100.0);
    for (k, zk) in z[..first].iter().enumerate() {
        a.step(k, dt, *zk);
    }
    let saved = a.instance.get_fmu_state().expect("fmi2GetFMUstate");
    let bytes = a.instance.serialize_fmu_state(&saved).expect("fmi2SerializeFMUstate");
    assert_eq!(a.instance.serialize_fmu_state(&saved).expect("again"), bytes, "serialising is deterministic");
    let run = |fmu: &mut Fmu| -> Vec<Vec<f64>> {
        z[first..].iter().enumerate().map(|(j, zk)| fmu.step(first + j, dt, *zk)).collect()
    };
    let original = run(&mut a);

    // Back in the same instance: the same outputs, bit for bit.
    a.instance.set_fmu_state(&saved).ok().expect("fmi2SetFMUstate");
    assert_eq!(bits(&run(&mut a)), bits(&original), "replay after fmi2SetFMUstate");

    // fmi2GetFMUstate into an existing state overwrites it.
    a.instance.update_fmu_state(&saved).ok().expect("fmi2GetFMUstate into an existing state");
    let later = a.instance.serialize_fmu_state(&saved).expect("fmi2SerializeFMUstate");
    assert_ne!(later, bytes, "the updated state is the later one");
    let again = a.instance.deserialize_fmu_state(&bytes).expect("fmi2DeSerializeFMUstate");
    a.instance.set_fmu_state(&again).ok().expect("fmi2SetFMUstate of the deserialised state");
    assert_eq!(bits(&run(&mut a)), bits(&original), "replay after deserialising in the same instance");

    // A fresh instance, never initialised, restores the serialised bytes.
    let mut b = Fmu::new(&import, "b");
    let restored = b.instance.deserialize_fmu_state(&bytes).expect("fmi2DeSerializeFMUstate");
    b.instance.set_fmu_state(&restored).ok().expect("fmi2SetFMUstate in a fresh instance");
    assert_eq!(bits(&run(&mut b)), bits(&original), "replay in a fresh instance");

    // Garbage, truncated or foreign bytes are refused.
    assert!(b.instance.deserialize_fmu_state(&vec![0x5a; bytes.len()]).is_err(), "garbage of the right length");
    assert!(b.instance.deserialize_fmu_state(&bytes[..bytes.len() - 1]).is_err(), "truncated");
    let mut other = bytes.clone();
    other[20] ^= 0x01; // inside the GUID
    assert!(b.instance.deserialize_fmu_state(&other).is_err(), "another FMU's GUID");
    Common::terminate(&mut a.instance).expect("fmi2Terminate a");
    Common::terminate(&mut b.instance).expect("fmi2Terminate b");
}

fn bits(rows: &[Vec<f64>]) -> Vec<Vec<u64>> {
    rows.iter().map(|r| r.iter().map(|x| x.to_bits()).collect()).collect()
}
