//! Cost of one filter sample through the FMU's C ABI against the same filter
//! sample in-process:
//!
//! * `do_step/fmi2_c_abi`: what an importer does per communication step of
//!   one sample (`h = sample_time`): `fmi2SetReal` of the two inputs,
//!   `fmi2DoStep`, `fmi2GetReal` of `F` — the exported functions called
//!   directly (no dlopen; a call through a function pointer costs the same);
//!   (the FMU updates at `t` with the inputs and predicts to `t + h`; `F` is
//!   read after the step);
//! * `do_step/fmi2_c_abi_all_outputs`: the same, reading all 13 Real outputs;
//! * `do_step/fmi2_c_abi_feedthrough`: `fmi2SetReal`, `fmi2GetReal` of `F`
//!   (the estimate at `t` given the inputs: the update, made on the FMU's
//!   twin filter), `fmi2DoStep` (which takes that update over by a copy and
//!   predicts);
//! * `do_step/library`: the SRCKF built from the estimator crate with the
//!   FMU's default parameters, behind the same supervisor: gate and commit
//!   the update with `z`, `predict(&[], dt)`, read `F`.
//!
//! Both run on the same seeded accelerations (a sum of sines), cycled; the FMU
//! has no stop time, so neither ever resets. Every status is checked.
//!
//! Before criterion, an interleaved comparison robust to a busy machine:
//! blocks of 500 steps alternate between the FMU (`fmi2_c_abi`) and the
//! library, 200 blocks each; it prints the median and minimum per step of
//! both and the overhead of the C ABI.
//!
//! ```text
//! cargo bench -p fmu --bench do_step
//! ```

// Calling the exported `extern "C"` functions needs unsafe; nothing else here is.
#![allow(unsafe_code)]

use std::ffi::CString;
use std::hint::black_box;
use std::ptr;
use std::time::{Duration, Instant};

use criterion::Criterion;
use estimator::models::{Oscillator2Dof, Oscillator2DofLoad, PiecewiseLinear};
use estimator::{
    build_filter, Discretized, FilterKind, Gaussian, Noise, StateEstimator, Supervisor, SupervisorSettings,
    UnscentedParams,
};
use kalfmu_fmu as fmu;
use kalfmu_fmu::estimators::Descriptor;
use kalfmu_fmu::ffi::{Fmi2CallbackFunctions, Fmi2CallbackLogger, Fmi2Component, Fmi2Status, FMI2_COSIMULATION};
use kalfmu_fmu::variables::{Causality, Kind};
use nalgebra::{DMatrix, DVector};

const SAMPLES: usize = 4000;

/// The S1 estimator's description, built once for the whole benchmark.
static S1: std::sync::LazyLock<Descriptor> = std::sync::LazyLock::new(|| {
    fmu::estimators::all().into_iter().find(|d| d.model_identifier == "kalfmu_s1_load").expect("the S1 FMU")
});

fn descriptor() -> &'static Descriptor {
    &S1
}

fn vr(name: &str) -> u32 {
    descriptor().variables.iter().position(|v| v.name == name).unwrap_or_else(|| panic!("no variable {name}")) as u32
}

/// A parameter's default (its start value).
fn default(name: &str) -> f64 {
    descriptor().variables[vr(name) as usize].start.expect("a parameter has a start value")
}

/// Seeded accelerations: two sums of sines.
fn accelerations(dt: f64) -> Vec<[f64; 2]> {
    (0..SAMPLES)
        .map(|k| {
            let t = (k + 1) as f64 * dt;
            [0.3 * (1.7 * t).sin() + 0.1 * (6.1 * t + 0.4).sin(), 0.5 * (0.9 * t + 1.0).sin() + 0.2 * (11.3 * t).cos()]
        })
        .collect()
}

/// The FMU's filter with its default parameters, from the estimator crate.
fn library_filter() -> Box<dyn StateEstimator> {
    let p = default;
    let chain = Oscillator2Dof {
        m1: p("m1"),
        m2: p("m2"),
        k1: PiecewiseLinear::new([p("k11"), p("k12"), p("k13")], [p("delta1"), p("delta2")]).expect("k1"),
        c1: PiecewiseLinear::new([p("c11"), p("c12"), p("c13")], [p("eps1"), p("eps2")]).expect("c1"),
        k2: p("k2"),
        c2: p("c2"),
    };
    let model = Discretized::rk4(Oscillator2DofLoad::new(chain), p("rk4_substeps") as usize);
    let (dt, q) = (p("sample_time"), p("load_noise_intensity"));
    let mut qm = DMatrix::zeros(6, 6);
    for i in [0, 1] {
        qm[(i, i)] = p("q_z_std").powi(2);
        qm[(i + 3, i + 3)] = p("q_z_dot_std").powi(2);
    }
    qm[(2, 2)] = q * dt.powi(3) / 3.0;
    qm[(2, 5)] = q * dt.powi(2) / 2.0;
    qm[(5, 2)] = qm[(2, 5)];
    qm[(5, 5)] = q * dt;
    let r = DVector::from_column_slice(&[p("r_z1_ddot_std").powi(2), p("r_z2_ddot_std").powi(2)]);
    let noise = Noise::new(qm, DMatrix::from_diagonal(&r)).expect("the default noise");
    let names = ["z1", "z2", "F", "z1_dot", "z2_dot", "F_dot"];
    let mean: Vec<f64> = names.iter().map(|n| p(&format!("x0_{n}"))).collect();
    let variances: Vec<f64> = names.iter().map(|n| p(&format!("p0_{n}_std")).powi(2)).collect();
    let ukf = UnscentedParams { alpha: p("ukf_alpha"), beta: p("ukf_beta"), kappa: p("ukf_kappa") };
    assert_eq!(p("filter"), 2.0, "the default filter is the SRCKF");
    build_filter(FilterKind::SrCkf, model, noise, &Gaussian::diagonal(&mean, &variances), ukf).expect("the filter")
}

/// An initialised instance with the default parameters and no stop time.
fn fmu_instance(name: &CString, guid: &CString, callbacks: &Fmi2CallbackFunctions) -> Fmi2Component {
    // SAFETY: valid strings and callbacks that outlive the instance.
    unsafe {
        let c = fmu::fmi2Instantiate(name.as_ptr(), FMI2_COSIMULATION, guid.as_ptr(), ptr::null(), callbacks, 0, 0);
        assert!(!c.is_null(), "fmi2Instantiate");
        assert_eq!(fmu::fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), Fmi2Status::Ok);
        assert_eq!(fmu::fmi2EnterInitializationMode(c), Fmi2Status::Ok);
        assert_eq!(fmu::fmi2ExitInitializationMode(c), Fmi2Status::Ok);
        c
    }
}

fn main() {
    let dt = default("sample_time");
    let z = accelerations(dt);
    let guid = CString::new(descriptor().guid()).expect("a GUID");
    // fmi-sys's variadic C logger (never called: no logging, no errors).
    let c_logger: fmi::fmi2::binding::fmi2CallbackLogger = Some(fmi::fmi2::binding::logger::callback_logger_handler);
    // SAFETY: the same C-variadic signature but for the status, a C enum
    // (`u32` in bindgen) there and `int` here: the same register on every C ABI.
    let logger = unsafe { std::mem::transmute::<fmi::fmi2::binding::fmi2CallbackLogger, Fmi2CallbackLogger>(c_logger) };
    let callbacks = Fmi2CallbackFunctions {
        logger,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: ptr::null_mut(),
    };
    let inputs = [vr("z1_ddot"), vr("z2_ddot")];
    let load = [vr("F")];
    let outputs: Vec<u32> = (0..descriptor().variables.len() as u32)
        .filter(|&r| {
            let v = &descriptor().variables[r as usize];
            v.causality == Causality::Output && v.kind == Kind::Real
        })
        .collect();

    interleaved(&z, dt, &guid, &callbacks, &inputs, &load);

    let mut criterion = Criterion::default().configure_from_args();
    let mut group = criterion.benchmark_group("do_step");
    group.sample_size(50).warm_up_time(Duration::from_millis(500)).measurement_time(Duration::from_secs(3));

    for (bench, read, feedthrough) in [
        ("fmi2_c_abi", &load[..], false),
        ("fmi2_c_abi_all_outputs", &outputs[..], false),
        ("fmi2_c_abi_feedthrough", &load[..], true),
    ] {
        let name = CString::new(bench).expect("a name");
        let c = fmu_instance(&name, &guid, &callbacks);
        let mut k = 0u64;
        let mut out = vec![0.0; read.len()];
        group.bench_function(bench, |b| {
            b.iter(|| {
                let zk = &z[k as usize % SAMPLES];
                // SAFETY: a live instance; arrays of the lengths given.
                unsafe {
                    let set = fmu::fmi2SetReal(c, inputs.as_ptr(), 2, zk.as_ptr());
                    let mut read_at = |when: bool| {
                        if when {
                            fmu::fmi2GetReal(c, read.as_ptr(), read.len(), out.as_mut_ptr())
                        } else {
                            Fmi2Status::Ok
                        }
                    };
                    let get_before = read_at(feedthrough);
                    let step = fmu::fmi2DoStep(c, k as f64 * dt, dt, 1);
                    let get = read_at(!feedthrough);
                    let ok = (Fmi2Status::Ok, Fmi2Status::Ok, Fmi2Status::Ok, Fmi2Status::Ok);
                    assert_eq!((set, get_before, step, get), ok, "sample {k}");
                }
                k += 1;
                black_box(out[0])
            })
        });
        // SAFETY: freed once.
        unsafe { fmu::fmi2FreeInstance(c) };
    }

    let mut filter = library_filter();
    let mut k = 0usize;
    let mut supervisor = Supervisor::new(SupervisorSettings::default(), 2).expect("the supervisor");
    group.bench_function("library", |b| {
        b.iter(|| {
            let zk = &z[k % SAMPLES];
            supervisor.gate(filter.as_mut(), black_box(zk)).expect("update");
            supervisor.commit(|_| {});
            filter.predict(&[], dt).expect("predict");
            k += 1;
            black_box(filter.mean()[2])
        })
    });
    group.finish();
    criterion.final_summary();
}

/// Alternating blocks of FMU and library steps; prints median and minimum per step.
fn interleaved(
    z: &[[f64; 2]],
    dt: f64,
    guid: &CString,
    callbacks: &Fmi2CallbackFunctions,
    inputs: &[u32; 2],
    load: &[u32; 1],
) {
    const BLOCK: usize = 500;
    const BLOCKS: usize = 200;
    let name = CString::new("interleaved").expect("a name");
    let c = fmu_instance(&name, guid, callbacks);
    let mut filter = library_filter();
    let mut supervisor = Supervisor::new(SupervisorSettings::default(), 2).expect("the supervisor");
    let (mut fmu_times, mut library_times) = (Vec::with_capacity(BLOCKS), Vec::with_capacity(BLOCKS));
    let mut out = [0.0];
    for block in 0..=BLOCKS {
        let start = Instant::now();
        for j in 0..BLOCK {
            let k = block * BLOCK + j;
            // SAFETY: a live instance; arrays of the lengths given.
            unsafe {
                let set = fmu::fmi2SetReal(c, inputs.as_ptr(), 2, z[k % SAMPLES].as_ptr());
                let step = fmu::fmi2DoStep(c, k as f64 * dt, dt, 1);
                let get = fmu::fmi2GetReal(c, load.as_ptr(), 1, out.as_mut_ptr());
                assert_eq!((set, step, get), (Fmi2Status::Ok, Fmi2Status::Ok, Fmi2Status::Ok), "sample {k}");
            }
            black_box(out[0]);
        }
        let fmu_time = start.elapsed();
        let start = Instant::now();
        for j in 0..BLOCK {
            let k = block * BLOCK + j;
            supervisor.gate(filter.as_mut(), black_box(&z[k % SAMPLES])).expect("update");
            supervisor.commit(|_| {});
            filter.predict(&[], dt).expect("predict");
            black_box(filter.mean()[2]);
        }
        let library_time = start.elapsed();
        // Block 0 is the warm-up.
        if block > 0 {
            fmu_times.push(fmu_time.as_secs_f64() / BLOCK as f64);
            library_times.push(library_time.as_secs_f64() / BLOCK as f64);
        }
    }
    assert_eq!(out[0].to_bits(), filter.mean()[2].to_bits(), "the FMU and the library estimate the same F");
    // SAFETY: freed once.
    unsafe { fmu::fmi2FreeInstance(c) };
    let stats = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        (v[v.len() / 2] * 1e6, v[0] * 1e6)
    };
    let ((fmu_median, fmu_min), (lib_median, lib_min)) = (stats(&mut fmu_times), stats(&mut library_times));
    println!(
        "interleaved, {BLOCKS} blocks of {BLOCK} steps: fmi2_c_abi median {fmu_median:.3} µs (min {fmu_min:.3}), \
         library median {lib_median:.3} µs (min {lib_min:.3}); C ABI overhead median {:.3} µs ({:+.1} %), min {:.3} µs ({:+.1} %)",
        fmu_median - lib_median,
        100.0 * (fmu_median / lib_median - 1.0),
        fmu_min - lib_min,
        100.0 * (fmu_min / lib_min - 1.0),
    );
}
