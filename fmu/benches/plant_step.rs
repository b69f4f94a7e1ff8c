//! Speed of the plant FMUs through their C ABI, as a master steps them: per communication
//! step, `fmi2DoStep` and `fmi2GetReal` of every Real output, at the default parameters
//! (S1's chain at 200 Hz with RK4 at 1e-4 s; S2's vehicle on its random track at 80 km/h,
//! Zhai's method at 1e-4 s, recorded at 1 kHz; S5's missile flying the study's manoeuvre at
//! 200 Hz with RK4 at 5e-4 s).
//!
//! Before criterion, the real-time factor of each over its default experiment's step, on
//! one core (simulated time / wall-clock time over 2 s of simulated time), is printed as
//! `real-time factor: <model identifier> = <factor>`. `plant_step/<id>` is one
//! communication step.
//!
//! ```text
//! cargo bench -p fmu --bench plant_step
//! ```

// Calling the exported `extern "C"` functions needs unsafe; nothing else here is.
#![allow(unsafe_code)]

use std::ffi::CString;
use std::hint::black_box;
use std::ptr;
use std::time::Instant;

use criterion::Criterion;
use kalfmu_fmu as fmu;
use kalfmu_fmu::catalogue::{self, Fmu};
use kalfmu_fmu::ffi::{Fmi2CallbackFunctions, Fmi2CallbackLogger, Fmi2Component, Fmi2Status, FMI2_COSIMULATION};
use kalfmu_fmu::variables::{Causality, Kind};

/// An initialised instance of `guid` with its default parameters and no stop time.
fn instance(name: &CString, guid: &CString, callbacks: &Fmi2CallbackFunctions) -> Fmi2Component {
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

/// One communication step from `t`: the step, then every Real output read.
fn step(c: Fmi2Component, t: f64, h: f64, outputs: &[u32], values: &mut [f64]) {
    // SAFETY: a live instance; `outputs` and `values` have the same length.
    unsafe {
        assert_eq!(fmu::fmi2DoStep(c, t, h, 1), Fmi2Status::Ok);
        assert_eq!(fmu::fmi2GetReal(c, outputs.as_ptr(), outputs.len(), values.as_mut_ptr()), Fmi2Status::Ok);
    }
    black_box(values);
}

fn main() {
    // fmi-sys's variadic C logger (never called: no logging, no errors).
    let c_logger: fmi::fmi2::binding::fmi2CallbackLogger = Some(fmi::fmi2::binding::logger::callback_logger_handler);
    // SAFETY: the same C-variadic signature but for the status, a C enum (`u32` in
    // bindgen) there and `int` here: the same register on every C ABI.
    let logger = unsafe { std::mem::transmute::<fmi::fmi2::binding::fmi2CallbackLogger, Fmi2CallbackLogger>(c_logger) };
    let callbacks = Fmi2CallbackFunctions {
        logger,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: ptr::null_mut(),
    };
    let mut criterion = Criterion::default().configure_from_args();
    for plant in catalogue::all().into_iter().filter(|f| matches!(f, Fmu::Plant(_))) {
        let d = plant.description();
        let outputs: Vec<u32> = (0..d.variables().len() as u32)
            .filter(|&r| {
                let v = &d.variables()[r as usize];
                v.causality == Causality::Output && v.kind == Kind::Real
            })
            .collect();
        let mut values = vec![0.0; outputs.len()];
        let h = d.default_experiment().step;
        let (name, guid) =
            (CString::new(d.model_identifier()).expect("a name"), CString::new(d.guid()).expect("a GUID"));
        let c = instance(&name, &guid, &callbacks);
        let steps = (2.0 / h).round() as usize;
        let start = Instant::now();
        for k in 0..steps {
            step(c, k as f64 * h, h, &outputs, &mut values);
        }
        let factor = steps as f64 * h / start.elapsed().as_secs_f64();
        println!("real-time factor: {} = {factor:.2}", d.model_identifier());
        let mut k = steps;
        criterion.bench_function(&format!("plant_step/{}", d.model_identifier()), |b| {
            b.iter(|| {
                step(c, k as f64 * h, h, &outputs, &mut values);
                k += 1;
            })
        });
        // SAFETY: the instance is live and freed once.
        unsafe { fmu::fmi2FreeInstance(c) };
    }
    criterion.final_summary();
}
