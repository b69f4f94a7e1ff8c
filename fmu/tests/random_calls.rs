//! Randomised fmi2 call sequences through the C ABI, in-process, on every
//! estimator FMU of `kalfmu_fmu::estimators` (the sequences split evenly
//! between them; the calls pick variables by what they are — an input, an
//! estimate, a fixed or tunable parameter — from each FMU's table): thousands of
//! seeded sequences of the 34 functions with random arguments — NULL
//! pointers, unknown and duplicate value references, NaN and infinities,
//! wrong types, wrong communication points and step sizes, FMU states that
//! are NULL, garbage, truncated or foreign, unknown log categories —
//! interleaved with legal calls.
//!
//! A model of the FMI 2.0 CS state machine (the state table of the FMI 2.0 standard, `[FMI2]` §4.2.4) and of
//! the variable table predicts every status. Checked after every call:
//! * no crash, no hang (a watchdog aborts a sequence that stops progressing),
//!   no panic caught inside the FMU ("internal error");
//! * the status is the predicted one; `fmi2Error` always comes with an error
//!   message; a call in the wrong state logs "illegal call sequence";
//! * a rejected call changes nothing: the instance goes on as predicted
//!   (e.g. after a refused `fmi2SetReal` in StepComplete `fmi2DoStep` works),
//!   and parameters and inputs read back exactly what was last accepted;
//! * getters write no further than `nvr`;
//! * a control (a known input of the model) is never missing: a non-finite
//!   one is refused with `fmi2Error`, the previous value kept.
//!
//! The directed tests after them run on every FMU too (the capture test splits
//! its runs between them), and check that one FMU refuses another's state.
//!
//! Every pointer passed is NULL or valid for the length given (FMI contract).
//! Messages reach the test through fmi-sys's C logger (a real variadic C
//! function that formats with `vsnprintf`, so it also checks that the FMU calls
//! the logger with `"%s"`), which forwards them to the `log` crate with the
//! instance name as target.
// The test calls the exported `extern "C"` functions with raw pointers, as an importer does.
#![allow(unsafe_code)]

use std::collections::HashMap;
use std::ffi::{c_char, c_void, CStr, CString};
use std::ptr;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{LazyLock, Mutex, Once};
use std::time::{Duration, Instant};

use kalfmu_fmu as fmu;
use kalfmu_fmu::estimators::Descriptor;
use kalfmu_fmu::ffi::{
    Fmi2Boolean, Fmi2CallbackFunctions, Fmi2CallbackLogger, Fmi2Component, Fmi2FmuState, Fmi2Integer, Fmi2Status,
    Fmi2String, FMI2_COSIMULATION, FMI2_LAST_SUCCESSFUL_TIME, FMI2_MODEL_EXCHANGE, FMI2_TERMINATED,
};
use kalfmu_fmu::variables::{Causality, Kind, Role, Variability, Variable};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

const SEQUENCES: u64 = 1400;

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

fn take_messages(name: &str) -> Messages {
    MESSAGES.lock().expect("the message table").remove(name).unwrap_or_default()
}

/// The importer's callbacks with fmi-sys's variadic C logger.
fn callbacks() -> Fmi2CallbackFunctions {
    static INSTALL: Once = Once::new();
    INSTALL.call_once(|| {
        log::set_logger(&Recorder).expect("no other logger in this test binary");
        log::set_max_level(log::LevelFilter::Trace);
    });
    let c_logger: fmi::fmi2::binding::fmi2CallbackLogger = Some(fmi::fmi2::binding::logger::callback_logger_handler);
    // SAFETY: both are C-variadic `extern "C"` function pointers with the same
    // parameters except the status, `fmi2Status` (a C enum: `u32` in the
    // bindgen bindings) there and `int` here — the same register on every C
    // ABI; the pun every C importer's callback struct goes through.
    let logger = unsafe { std::mem::transmute::<fmi::fmi2::binding::fmi2CallbackLogger, Fmi2CallbackLogger>(c_logger) };
    Fmi2CallbackFunctions {
        logger,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: ptr::null_mut(),
    }
}

// ----- the interface under test -----

/// Every estimator FMU's description, built once for the whole test binary.
static DESCRIPTORS: LazyLock<Vec<Descriptor>> = LazyLock::new(fmu::estimators::all);

/// One FMU's variable table. The calls pick variables by what they are (an
/// input, an estimate, a fixed parameter), never by an FMU's own names.
#[derive(Debug, Clone, Copy)]
struct Table(&'static Descriptor);

impl Table {
    /// Every estimator FMU in `kalfmu_fmu::estimators`.
    fn all() -> Vec<Table> {
        DESCRIPTORS.iter().map(Table).collect()
    }

    fn id(self) -> &'static str {
        self.0.model_identifier
    }

    fn variables(self) -> &'static [Variable] {
        &self.0.variables
    }

    fn guid(self) -> CString {
        CString::new(self.0.guid()).expect("a GUID without NUL")
    }

    fn vr(self, name: &str) -> u32 {
        self.variables().iter().position(|v| v.name == name).unwrap_or_else(|| panic!("no variable {name}")) as u32
    }

    fn is_output(self, vr: u32) -> bool {
        self.variables()[vr as usize].causality == Causality::Output
    }

    fn is_tunable(self, vr: u32) -> bool {
        self.variables()[vr as usize].variability == Variability::Tunable
    }

    /// The value references of the variables `pick` selects, in table order.
    fn select(self, pick: impl Fn(&Variable) -> bool) -> Vec<u32> {
        (0..self.variables().len() as u32).filter(|&r| pick(&self.variables()[r as usize])).collect()
    }

    /// The measurement inputs, in measurement-row order.
    fn inputs(self) -> Vec<u32> {
        (0..self.0.measurement_dim()).map(|row| self.select(|v| v.role == Role::Measurement(row))[0]).collect()
    }

    /// The controls, in the order of the model's input (none for S1 and S2).
    fn controls(self) -> Vec<u32> {
        (0..self.0.control_dim()).map(|j| self.select(|v| v.role == Role::Control(j))[0]).collect()
    }

    /// A plausible measurement at `t` for the directed runs that must step without a
    /// filter failure, input `i` a tone of `(7 + 4i)` rad/s and a small one of 53 rad/s:
    /// about 0 for the oscillators of S1 and S2; about the measurement of the prior
    /// flight for S5, whose missile flies at 1 km/s at 10 km (the sums of sines about 0
    /// that suit S1 and S2 would make its filter diverge), at the sensors' noise level.
    fn plausible(self, t: f64) -> Vec<f64> {
        let tone = |i: usize| 0.5 * ((7.0 + 4.0 * i as f64) * t).sin() + 0.1 * (53.0 * t + i as f64).cos();
        let Some(prior) = self.prior_flight() else {
            return (0..self.inputs().len()).map(tone).collect();
        };
        let mut z = vec![0.0; 12];
        estimator::models::Airframe::tactical_missile().measure(&prior[..10], &prior[10..], &[0.0; 3], &mut z);
        let scale = [1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 1.0, 2e-3, 2e-3];
        z.iter().enumerate().map(|(i, zi)| zi + scale[i] * tone(i)).collect()
    }

    /// S5's prior mean (the `prior_<state>` parameters), if this is S5.
    fn prior_flight(self) -> Option<Vec<f64>> {
        let names = estimator::models::Missile6Dof::STATE_NAMES;
        let value = |n: &str| self.variables().iter().find(|v| v.name == format!("prior_{n}")).and_then(|v| v.start);
        names.iter().map(|n| value(n)).collect()
    }

    /// The outputs of one kind (`Kind::Real`: the estimates, their deviations and the NIS).
    fn outputs(self, kind: Kind) -> Vec<u32> {
        self.select(|v| v.causality == Causality::Output && v.kind == kind)
    }

    /// The first estimate (S1: F; S2: F_N1).
    fn estimate(self) -> u32 {
        self.select(|v| matches!(v.role, Role::Estimate(_)))[0]
    }

    /// The estimator's own Integer parameter, the first in table order (S1, S2, S5:
    /// rk4_substeps; S4: slip_after).
    fn own_integer(self) -> u32 {
        self.select(|v| v.causality == Causality::Parameter && v.kind == Kind::Integer)[0]
    }

    /// The first fixed Real parameter (S1: m1; S2: car_body_mass).
    fn fixed_real(self) -> u32 {
        self.select(|v| {
            v.causality == Causality::Parameter && v.variability == Variability::Fixed && v.kind == Kind::Real
        })[0]
    }

    /// The tunable parameters, in table order (the process noise first, the sensors' last).
    fn tunables(self) -> Vec<u32> {
        self.select(|v| v.variability == Variability::Tunable)
    }

    /// The default sample time.
    fn sample_time(self) -> f64 {
        self.0.default_experiment.step
    }
}

fn real_kind(k: Kind) -> bool {
    k == Kind::Real
}
fn integer_kind(k: Kind) -> bool {
    matches!(k, Kind::Integer | Kind::Enumeration(_))
}
fn boolean_kind(k: Kind) -> bool {
    k == Kind::Boolean
}
fn no_kind(_: Kind) -> bool {
    false
}

/// NULL or the slice's pointer.
fn ptr_or_null<T>(v: &[T], null: bool) -> *const T {
    if null {
        ptr::null()
    } else {
        v.as_ptr()
    }
}

fn mut_ptr_or_null<T>(v: &mut [T], null: bool) -> *mut T {
    if null {
        ptr::null_mut()
    } else {
        v.as_mut_ptr()
    }
}

fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

// ----- the model: what the FMU should be doing -----

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum St {
    Instantiated,
    Init,
    StepComplete,
    StepFailed,
    Terminated,
}

#[derive(Debug, Clone)]
struct Model {
    t: Table,
    st: St,
    time: f64,
    start: f64,
    stop: Option<f64>,
    /// Every variable's value as set (outputs: unused).
    values: Vec<f64>,
    /// A parameter accepted that may not build a filter: ExitInitializationMode may fail.
    suspect: bool,
}

impl Model {
    fn new(t: Table) -> Self {
        Self {
            t,
            st: St::Instantiated,
            time: 0.0,
            start: 0.0,
            stop: None,
            values: t.variables().iter().map(|v| v.start.unwrap_or(f64::NAN)).collect(),
            suspect: false,
        }
    }

    fn sample_time(&self) -> f64 {
        self.values[self.t.vr("sample_time") as usize]
    }

    /// The status of a setter for these entries (in order; duplicates: last wins).
    fn expect_set(&self, entries: &[(u32, f64)], null: bool, accepts: fn(Kind) -> bool) -> Expect {
        if !matches!(self.st, St::Instantiated | St::Init | St::StepComplete) {
            return Expect::Illegal;
        }
        if null {
            return Expect::Error;
        }
        for &(r, x) in entries {
            let Some(v) = self.t.variables().get(r as usize) else { return Expect::Error };
            if v.causality == Causality::Output
                || (v.variability == Variability::Fixed && self.st == St::StepComplete)
                || !accepts(v.kind)
            {
                return Expect::Error;
            }
            if let Kind::Enumeration(t) = v.kind {
                if !t.items.iter().any(|(value, _, _)| f64::from(*value) == x) {
                    return Expect::Error;
                }
            }
            if v.min.is_some_and(|m| x < m || x.is_nan()) || v.max.is_some_and(|m| x > m || x.is_nan()) {
                return Expect::Error;
            }
            if matches!(v.role, Role::Control(_)) && !x.is_finite() {
                return Expect::Error;
            }
        }
        // While the filter runs, tunables must give a valid noise (finite here).
        if self.st == St::StepComplete {
            let mut values = self.values.clone();
            entries.iter().for_each(|&(r, x)| values[r as usize] = x);
            if entries.iter().any(|&(r, _)| self.t.is_tunable(r))
                && (0..values.len()).any(|i| self.t.is_tunable(i as u32) && !values[i].is_finite())
            {
                return Expect::Error;
            }
        }
        Expect::Ok
    }

    fn apply_set(&mut self, entries: &[(u32, f64)], suspect: bool) {
        for &(r, x) in entries {
            self.values[r as usize] = x;
        }
        self.suspect |= suspect;
    }

    fn expect_get(&self, vrs: &[u32], null: bool, accepts: fn(Kind) -> bool) -> Expect {
        if !matches!(self.st, St::Init | St::StepComplete | St::StepFailed | St::Terminated) {
            return Expect::Illegal;
        }
        if null {
            return Expect::Error;
        }
        let ok = vrs.iter().all(|&r| self.t.variables().get(r as usize).is_some_and(|v| accepts(v.kind)));
        if ok {
            Expect::Ok
        } else {
            Expect::Error
        }
    }

    fn expect_do_step(&self, t: f64, h: f64) -> Expect {
        if self.st != St::StepComplete {
            return Expect::Illegal;
        }
        let tolerance = 1e-9 * self.time.abs().max(1.0);
        if !t.is_finite() || (t - self.time).abs() > tolerance || !(h > 0.0 && h.is_finite()) {
            return Expect::Error;
        }
        if self.stop.is_some_and(|stop| t + h > stop + 1e-9 * stop.abs().max(1.0)) {
            return Expect::Error;
        }
        Expect::OkOrDiscard
    }

    fn status_legal(&self) -> bool {
        matches!(self.st, St::StepComplete | St::StepFailed | St::Terminated)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Expect {
    Ok,
    Error,
    /// fmi2Error with "illegal call sequence".
    Illegal,
    OkOrDiscard,
    OkOrError,
}

/// One instance and the FMU states it owns.
struct Instance {
    c: Fmi2Component,
    name: CString,
    key: String,
    m: Model,
    states: Vec<(Fmi2FmuState, Model)>,
}

// ----- one random sequence -----

struct Sequence {
    rng: ChaCha8Rng,
    seed: u64,
    serial: u32,
    trace: Vec<String>,
    /// `(function, outcome)` → count, for the coverage summary.
    stats: HashMap<(String, String), u64>,
    callbacks: Fmi2CallbackFunctions,
    /// The FMU under test.
    t: Table,
    guid: CString,
    /// Serialised states (any instance of this FMU may restore them).
    blobs: Vec<(Vec<u8>, Model)>,
}

impl Sequence {
    fn new(seed: u64, t: Table) -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(seed),
            seed,
            serial: 0,
            trace: Vec::new(),
            stats: HashMap::new(),
            callbacks: callbacks(),
            t,
            guid: t.guid(),
            blobs: Vec::new(),
        }
    }

    fn fail(&self, why: &str) -> ! {
        let from = self.trace.len().saturating_sub(40);
        panic!("sequence seed {}: {why}\nlast calls:\n  {}", self.seed, self.trace[from..].join("\n  "))
    }

    fn pick<T: Copy>(&mut self, items: &[T]) -> T {
        items[self.rng.random_range(0..items.len())]
    }

    fn chance(&mut self, p: f64) -> bool {
        self.rng.random_bool(p)
    }

    /// Checks a call's status and messages against the expectation.
    fn check(&mut self, key: &str, call: String, status: Fmi2Status, expect: Expect) {
        let messages = take_messages(key);
        let shown: Vec<&str> = messages.iter().map(|(_, m)| m.as_str()).collect();
        self.trace.push(format!("{call} -> {status:?} (expected {expect:?}) {shown:?}"));
        let function = call.split('(').next().unwrap_or_default().trim().to_owned();
        let illegal_call = shown.iter().any(|m| m.contains("illegal call sequence"));
        let outcome = if illegal_call { "Illegal".to_owned() } else { format!("{status:?}") };
        *self.stats.entry((function, outcome)).or_default() += 1;
        if status == Fmi2Status::Error && !messages.iter().any(|(level, _)| *level == log::Level::Error) {
            self.fail("fmi2Error without an error message");
        }
        if messages.iter().any(|(_, m)| m.contains("internal error")) {
            self.fail("the FMU caught a panic");
        }
        let illegal = messages.iter().any(|(_, m)| m.contains("illegal call sequence"));
        let ok = match expect {
            Expect::Ok => status == Fmi2Status::Ok && !illegal,
            Expect::Error => status == Fmi2Status::Error && !illegal,
            Expect::Illegal => status == Fmi2Status::Error && illegal,
            Expect::OkOrDiscard => matches!(status, Fmi2Status::Ok | Fmi2Status::Discard) && !illegal,
            Expect::OkOrError => matches!(status, Fmi2Status::Ok | Fmi2Status::Error) && !illegal,
        };
        if !ok {
            self.fail("unexpected status or message");
        }
    }

    fn run(&mut self) {
        let mut instances: Vec<Instance> = (0..self.rng.random_range(1..=2)).map(|_| self.instantiate()).collect();
        let calls = self.rng.random_range(10..80);
        for _ in 0..calls {
            let i = self.rng.random_range(0..instances.len());
            if self.chance(0.01) {
                let old = instances.swap_remove(i);
                self.free(old);
                instances.push(self.instantiate());
                continue;
            }
            self.random_call(&mut instances[i]);
        }
        for inst in instances {
            self.free(inst);
        }
    }

    // ----- creation and destruction -----

    fn instantiate(&mut self) -> Instance {
        if self.chance(0.15) {
            self.bad_instantiate();
        }
        self.serial += 1;
        let key = format!("rc{}-{}", self.seed, self.serial);
        let name = CString::new(key.clone()).expect("no NUL");
        let resource: Option<&CStr> =
            self.pick(&[Some(c"file:///tmp/kalfmu-resources"), None, Some(c""), Some(c"relative/dir")]);
        let (visible, logging) = (Fmi2Boolean::from(self.chance(0.5)), Fmi2Boolean::from(self.chance(0.5)));
        // SAFETY: valid strings and callbacks that outlive the call.
        let c = unsafe {
            fmu::fmi2Instantiate(
                name.as_ptr(),
                FMI2_COSIMULATION,
                self.guid.as_ptr(),
                resource.map_or(ptr::null(), CStr::as_ptr),
                &self.callbacks,
                visible,
                logging,
            )
        };
        let messages = take_messages(&key);
        self.trace.push(format!("fmi2Instantiate({key}, resource {resource:?}) -> {c:?} {messages:?}"));
        if c.is_null() || messages.iter().any(|(level, _)| *level == log::Level::Error) {
            self.fail("a valid fmi2Instantiate failed");
        }
        Instance { c, name, key, m: Model::new(self.t), states: Vec::new() }
    }

    /// A call of fmi2Instantiate that must return NULL (and say why, if it can).
    fn bad_instantiate(&mut self) {
        self.serial += 1;
        let key = format!("rc{}-{}", self.seed, self.serial);
        let name = CString::new(key.clone()).expect("no NUL");
        let no_logger = Fmi2CallbackFunctions { logger: None, ..self.callbacks };
        let wrong_guid = c"{00000000-0000-0000-0000-000000000000}";
        let case = self.rng.random_range(0..8);
        let (n, kind, g, f, logged_as): (*const c_char, _, *const c_char, *const Fmi2CallbackFunctions, Option<&str>) =
            match case {
                0 => (name.as_ptr(), FMI2_COSIMULATION, self.guid.as_ptr(), ptr::null(), None),
                1 => (name.as_ptr(), FMI2_COSIMULATION, self.guid.as_ptr(), &no_logger, None),
                2 => (ptr::null(), FMI2_COSIMULATION, self.guid.as_ptr(), &self.callbacks, Some("")),
                3 => (c"".as_ptr(), FMI2_COSIMULATION, self.guid.as_ptr(), &self.callbacks, Some("")),
                4 => (name.as_ptr(), FMI2_MODEL_EXCHANGE, self.guid.as_ptr(), &self.callbacks, Some(&key)),
                5 => (name.as_ptr(), 7, self.guid.as_ptr(), &self.callbacks, Some(&key)),
                6 => (name.as_ptr(), FMI2_COSIMULATION, wrong_guid.as_ptr(), &self.callbacks, Some(&key)),
                _ => (name.as_ptr(), FMI2_COSIMULATION, ptr::null(), &self.callbacks, Some(&key)),
            };
        // SAFETY: every pointer is NULL or valid for the call.
        let c = unsafe { fmu::fmi2Instantiate(n, kind, g, c"file:///tmp".as_ptr(), f, 0, 0) };
        self.trace.push(format!("bad fmi2Instantiate case {case} -> {c:?}"));
        if !c.is_null() {
            // SAFETY: just created.
            unsafe { fmu::fmi2FreeInstance(c) };
            self.fail("an invalid fmi2Instantiate returned an instance");
        }
        if let Some(k) = logged_as {
            let messages = take_messages(k);
            if !messages.iter().any(|(level, _)| *level == log::Level::Error) {
                self.fail(&format!("invalid fmi2Instantiate case {case} logged nothing"));
            }
        }
    }

    fn free(&mut self, mut inst: Instance) {
        for (mut s, _) in std::mem::take(&mut inst.states) {
            // SAFETY: a state of this instance, freed once.
            let status = unsafe { fmu::fmi2FreeFMUstate(inst.c, &mut s) };
            self.check(&inst.key, "fmi2FreeFMUstate (cleanup)".into(), status, Expect::Ok);
            assert!(s.is_null(), "fmi2FreeFMUstate sets the state to NULL");
        }
        // SAFETY: the instance is freed once.
        unsafe { fmu::fmi2FreeInstance(inst.c) };
        self.trace.push(format!("fmi2FreeInstance({})", inst.key));
        drop(inst.name);
    }

    // ----- one random call -----

    fn random_call(&mut self, inst: &mut Instance) {
        use St::*;
        let st = inst.m.st;
        let w = |on: bool, yes: u32, no: u32| if on { yes } else { no };
        // (weight, call): legal calls that move the state machine on are likelier.
        let weights: [u32; 30] = [
            w(st == Instantiated, 15, 2),                    // 0 setup
            w(st == Instantiated, 20, 2),                    // 1 enter init
            w(st == Init, 20, 2),                            // 2 exit init
            w(st == StepComplete, 40, 3),                    // 3 do step
            w(st == StepFailed, 10, 2),                      // 4 terminate
            w(matches!(st, StepFailed | Terminated), 15, 2), // 5 reset
            w(st == Init, 25, 15),                           // 6 set real
            4,                                               // 7 set integer
            2,                                               // 8 set boolean
            2,                                               // 9 set string
            10,                                              // 10 get real
            3,                                               // 11 get integer
            3,                                               // 12 get boolean
            2,                                               // 13 get string
            3,                                               // 14 set debug logging
            4,                                               // 15 get FMU state
            4,                                               // 16 set FMU state
            2,                                               // 17 free FMU state
            2,                                               // 18 serialized size
            6,                                               // 19 serialize
            4,                                               // 20 deserialize
            1,                                               // 21 get status
            2,                                               // 22 get real status
            1,                                               // 23 get integer status
            2,                                               // 24 get boolean status
            1,                                               // 25 get string status
            1,                                               // 26 cancel step
            2,                                               // 27 derivatives
            2,                                               // 28 NULL component
            1,                                               // 29 inquiry
        ];
        let mut r = self.rng.random_range(0..weights.iter().sum::<u32>());
        let call = weights.iter().position(|&wt| {
            if r < wt {
                true
            } else {
                r -= wt;
                false
            }
        });
        let call = call.expect("a call");
        match call {
            0 => self.setup_experiment(inst),
            1 => self.enter_initialization_mode(inst),
            2 => self.exit_initialization_mode(inst),
            3 => self.do_step(inst),
            4 => self.terminate(inst),
            5 => self.reset(inst),
            6 => self.set_real(inst),
            7 => self.set_integer(inst),
            8 => self.set_boolean(inst),
            9 => self.set_string(inst),
            10 => self.get_real(inst),
            11 => self.get_integer(inst),
            12 => self.get_boolean(inst),
            13 => self.get_string(inst),
            14 => self.set_debug_logging(inst),
            15 => self.get_fmu_state(inst),
            16 => self.set_fmu_state(inst),
            17 => self.free_fmu_state(inst),
            18 => self.serialized_size(inst),
            19 => self.serialize(inst),
            20 => self.deserialize(inst),
            21..=25 => self.status(inst, call - 21),
            26 => {
                // SAFETY: a live instance.
                let status = unsafe { fmu::fmi2CancelStep(inst.c) };
                self.check(&inst.key, "fmi2CancelStep".into(), status, Expect::Error);
            }
            27 => self.derivatives(inst),
            28 => self.null_component(),
            _ => {
                // SAFETY: static strings.
                let (tp, v) =
                    unsafe { (CStr::from_ptr(fmu::fmi2GetTypesPlatform()), CStr::from_ptr(fmu::fmi2GetVersion())) };
                assert_eq!((tp, v), (c"default", c"2.0"));
            }
        }
    }

    // ----- life cycle -----

    fn setup_experiment(&mut self, inst: &mut Instance) {
        let start = self.pick(&[0.0, 0.0, 1.25, -3.0, 1e6, f64::NAN, f64::INFINITY]);
        let defined = self.chance(0.5);
        let stop = self.pick(&[start + 1.0, start + 0.05, start, start - 1.0, f64::NAN, f64::INFINITY]);
        let expect = if inst.m.st != St::Instantiated {
            Expect::Illegal
        } else if !start.is_finite() || (defined && (stop < start || stop.is_nan())) {
            Expect::Error
        } else {
            Expect::Ok
        };
        // SAFETY: a live instance.
        let status = unsafe {
            fmu::fmi2SetupExperiment(inst.c, self.rng.random_range(0..2), 1e-6, start, Fmi2Boolean::from(defined), stop)
        };
        self.check(&inst.key, format!("fmi2SetupExperiment({start}, {defined}, {stop})"), status, expect);
        if status == Fmi2Status::Ok {
            inst.m.start = start;
            inst.m.time = start;
            inst.m.stop = defined.then_some(stop);
        }
    }

    fn enter_initialization_mode(&mut self, inst: &mut Instance) {
        let expect = if inst.m.st == St::Instantiated { Expect::Ok } else { Expect::Illegal };
        // SAFETY: a live instance.
        let status = unsafe { fmu::fmi2EnterInitializationMode(inst.c) };
        self.check(&inst.key, "fmi2EnterInitializationMode".into(), status, expect);
        if status == Fmi2Status::Ok {
            inst.m.st = St::Init;
            inst.m.time = inst.m.start;
        }
    }

    fn exit_initialization_mode(&mut self, inst: &mut Instance) {
        let expect = match (inst.m.st, inst.m.suspect) {
            (St::Init, false) => Expect::Ok,
            (St::Init, true) => Expect::OkOrError,
            _ => Expect::Illegal,
        };
        // SAFETY: a live instance.
        let status = unsafe { fmu::fmi2ExitInitializationMode(inst.c) };
        self.check(&inst.key, "fmi2ExitInitializationMode".into(), status, expect);
        if status == Fmi2Status::Ok {
            inst.m.st = St::StepComplete;
        }
    }

    fn terminate(&mut self, inst: &mut Instance) {
        let expect = if matches!(inst.m.st, St::StepComplete | St::StepFailed) { Expect::Ok } else { Expect::Illegal };
        // SAFETY: a live instance.
        let status = unsafe { fmu::fmi2Terminate(inst.c) };
        self.check(&inst.key, "fmi2Terminate".into(), status, expect);
        if status == Fmi2Status::Ok {
            inst.m.st = St::Terminated;
        }
    }

    fn reset(&mut self, inst: &mut Instance) {
        // SAFETY: a live instance.
        let status = unsafe { fmu::fmi2Reset(inst.c) };
        self.check(&inst.key, "fmi2Reset".into(), status, Expect::Ok);
        inst.m = Model::new(self.t);
    }

    fn do_step(&mut self, inst: &mut Instance) {
        let time = inst.m.time;
        let tolerance = 1e-9 * time.abs().max(1.0);
        let t = match self.rng.random_range(0..10) {
            0..=6 => time,
            7 => time + 0.3 * tolerance,
            _ => self.pick(&[time + 0.1, time - 0.005, f64::NAN, f64::INFINITY, f64::NEG_INFINITY]),
        };
        let ts = inst.m.sample_time();
        let h = match self.rng.random_range(0..100) {
            0..=59 => self.rng.random_range(1..=4) as f64 * ts,
            60..=69 => 0.0037,
            70..=71 => 50.0 * ts, // many samples in one step
            72..=74 => f64::MIN_POSITIVE,
            _ => self.pick(&[0.0, -ts, f64::NAN, f64::INFINITY, f64::NEG_INFINITY]),
        };
        let expect = inst.m.expect_do_step(t, h);
        // SAFETY: a live instance.
        let status = unsafe { fmu::fmi2DoStep(inst.c, t, h, self.rng.random_range(0..2)) };
        self.check(&inst.key, format!("fmi2DoStep({t}, {h})"), status, expect);
        match status {
            Fmi2Status::Ok => inst.m.time = t + h,
            Fmi2Status::Discard => inst.m.st = St::StepFailed,
            _ => {}
        }
    }

    // ----- values -----

    /// A value reference that is not a variable.
    fn bad_vr(&mut self) -> u32 {
        let n = self.t.variables().len() as u32;
        self.pick(&[n, n + 1, 1000, u32::MAX])
    }

    /// A Real entry for fmi2SetReal and whether it is "suspect" (accepted, but
    /// it may not build a filter).
    fn real_entry(&mut self) -> (u32, f64, bool) {
        let vars = self.t.variables();
        let reals: Vec<u32> = (0..vars.len() as u32).filter(|&r| vars[r as usize].kind == Kind::Real).collect();
        let class = self.rng.random_range(0..100);
        if class < 35 {
            let inputs: Vec<u32> = self.t.inputs().into_iter().chain(self.t.controls()).collect();
            let r = self.pick(&inputs);
            let x = self.pick(&[
                0.0,
                0.3,
                -2.0,
                9.81,
                1e3,
                1e300,
                -1e300,
                f64::NAN,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::MIN_POSITIVE,
                -0.0,
            ]);
            return (r, x, false);
        }
        if class < 55 {
            let tunables: Vec<u32> = reals.iter().copied().filter(|&r| self.t.is_tunable(r)).collect();
            let r = self.pick(&tunables);
            let d = vars[r as usize].start.expect("a start value");
            let x = self.pick(&[d, 2.0 * d, 0.0, 0.5, -1.0, f64::NAN, f64::INFINITY]);
            return (r, x, !(x.is_finite() && x > 0.0));
        }
        if class < 80 {
            let fixed: Vec<u32> = reals
                .iter()
                .copied()
                .filter(|&r| vars[r as usize].causality == Causality::Parameter && !self.t.is_tunable(r))
                .collect();
            let r = self.pick(&fixed);
            let d = vars[r as usize].start.expect("a start value");
            return match &*vars[r as usize].name {
                // Only sample times that keep steps short are accepted; the rest is out of bounds.
                "sample_time" => (r, self.pick(&[d, 2.0 * d, 0.5 * d, 0.0, -1.0, f64::NAN, 1e-12]), false),
                _ => {
                    let good = if d == 0.0 { 0.25 } else { 1.5 * d };
                    let x = self.pick(&[d, good, good, 0.0, -1.0, f64::NAN, f64::INFINITY, 1e300]);
                    (r, x, x != d && x != good)
                }
            };
        }
        if class < 90 {
            // An output, or a variable of another type.
            let others: Vec<u32> = (0..vars.len() as u32)
                .filter(|&r| self.t.is_output(r) || vars[r as usize].kind != Kind::Real)
                .collect();
            return (self.pick(&others), 1.0, false);
        }
        (self.bad_vr(), 1.0, false)
    }

    fn entry_count(&mut self) -> usize {
        self.pick(&[0, 1, 1, 1, 2, 2, 3, 5])
    }

    fn duplicate<T: Copy>(&mut self, entries: &mut [T]) {
        if entries.len() >= 2 && self.chance(0.2) {
            entries[1] = entries[0];
        }
    }

    fn set_real(&mut self, inst: &mut Instance) {
        let n = self.entry_count();
        let mut entries: Vec<(u32, f64, bool)> = (0..n).map(|_| self.real_entry()).collect();
        self.duplicate(&mut entries);
        let (null_vr, null_value) = (self.chance(0.04), self.chance(0.04));
        let vrs: Vec<u32> = entries.iter().map(|e| e.0).collect();
        let values: Vec<f64> = entries.iter().map(|e| e.1).collect();
        let pairs: Vec<(u32, f64)> = entries.iter().map(|e| (e.0, e.1)).collect();
        let expect = inst.m.expect_set(&pairs, n > 0 && (null_vr || null_value), real_kind);
        // SAFETY: NULL or `n` valid elements.
        let status =
            unsafe { fmu::fmi2SetReal(inst.c, ptr_or_null(&vrs, null_vr), n, ptr_or_null(&values, null_value)) };
        self.check(&inst.key, format!("fmi2SetReal({pairs:?}, null {null_vr}/{null_value})"), status, expect);
        if status == Fmi2Status::Ok {
            inst.m.apply_set(&pairs, entries.iter().any(|e| e.2));
        }
    }

    fn set_integer(&mut self, inst: &mut Instance) {
        let n = self.entry_count();
        let mut entries: Vec<(u32, Fmi2Integer)> = Vec::new();
        let mut suspect = false;
        for _ in 0..n {
            let entry = match self.rng.random_range(0..10) {
                0..=3 => (self.t.own_integer(), self.pick(&[1, 2, 3, 0, -1, 1001, i32::MAX, i32::MIN])),
                4..=6 => (self.t.vr("filter"), self.pick(&[1, 2, 3, 4, 5, 0, 6, -2])),
                7 => (self.t.vr("skipped_measurements"), 1),
                8 => {
                    let t = self.t;
                    (self.pick(&[t.estimate(), t.fixed_real(), t.inputs()[0], t.vr("filter_healthy")]), 1)
                }
                _ => (self.bad_vr(), 1),
            };
            // Up to 3 (rk4_substeps, S4's slip_after) and every filter kind build a
            // filter from good parameters.
            suspect |= entry.0 == self.t.own_integer() && entry.1 > 3;
            entries.push(entry);
        }
        self.duplicate(&mut entries);
        let null = self.chance(0.05);
        let vrs: Vec<u32> = entries.iter().map(|e| e.0).collect();
        let values: Vec<Fmi2Integer> = entries.iter().map(|e| e.1).collect();
        let pairs: Vec<(u32, f64)> = entries.iter().map(|e| (e.0, f64::from(e.1))).collect();
        let expect = inst.m.expect_set(&pairs, n > 0 && null, integer_kind);
        // SAFETY: NULL or `n` valid elements.
        let status = unsafe { fmu::fmi2SetInteger(inst.c, vrs.as_ptr(), n, ptr_or_null(&values, null)) };
        self.check(&inst.key, format!("fmi2SetInteger({entries:?}, null {null})"), status, expect);
        if status == Fmi2Status::Ok {
            inst.m.apply_set(&pairs, suspect);
        }
    }

    fn set_boolean(&mut self, inst: &mut Instance) {
        let n = self.entry_count();
        let vrs: Vec<u32> = (0..n)
            .map(|_| match self.rng.random_range(0..10) {
                0..=4 => self.t.vr("filter_healthy"),
                5..=7 => {
                    let t = self.t;
                    self.pick(&[t.inputs()[0], t.tunables()[0], t.vr("filter")])
                }
                _ => self.bad_vr(),
            })
            .collect();
        let values: Vec<Fmi2Boolean> = (0..n).map(|_| self.pick(&[0, 1, 2, -1])).collect();
        let null = self.chance(0.05);
        let pairs: Vec<(u32, f64)> = vrs.iter().zip(&values).map(|(r, b)| (*r, f64::from(*b))).collect();
        let expect = inst.m.expect_set(&pairs, n > 0 && null, boolean_kind);
        // SAFETY: NULL or `n` valid elements.
        let status = unsafe { fmu::fmi2SetBoolean(inst.c, ptr_or_null(&vrs, null), n, values.as_ptr()) };
        self.check(&inst.key, format!("fmi2SetBoolean({pairs:?}, null {null})"), status, expect);
    }

    fn set_string(&mut self, inst: &mut Instance) {
        let n = self.entry_count();
        let vars = self.t.variables().len() as u32;
        let vrs: Vec<u32> = (0..n).map(|_| self.rng.random_range(0..vars + 2)).collect();
        let strings: Vec<Fmi2String> = (0..n).map(|_| self.pick(&[c"".as_ptr(), c"SRCKF".as_ptr()])).collect();
        let null = self.chance(0.1);
        let pairs: Vec<(u32, f64)> = vrs.iter().map(|r| (*r, f64::NAN)).collect();
        let expect = inst.m.expect_set(&pairs, n > 0 && null, no_kind);
        // SAFETY: NULL or `n` valid elements (valid strings).
        let status = unsafe { fmu::fmi2SetString(inst.c, vrs.as_ptr(), n, ptr_or_null(&strings, null)) };
        self.check(&inst.key, format!("fmi2SetString({vrs:?}, null {null})"), status, expect);
    }

    fn get_vrs(&mut self, mostly: &[u32]) -> Vec<u32> {
        let n = self.pick(&[0, 1, 2, 4, 8]);
        let vars = self.t.variables().len() as u32;
        let mut vrs: Vec<u32> = (0..n)
            .map(|_| match self.rng.random_range(0..20) {
                0..=13 => self.pick(mostly),
                14..=17 => self.rng.random_range(0..vars),
                _ => self.bad_vr(),
            })
            .collect();
        self.duplicate(&mut vrs);
        vrs
    }

    fn get_real(&mut self, inst: &mut Instance) {
        let reals: Vec<u32> =
            (0..self.t.variables().len() as u32).filter(|&r| real_kind(self.t.variables()[r as usize].kind)).collect();
        let mut vrs = self.get_vrs(&reals);
        if self.chance(0.1) {
            vrs = reals;
        }
        let null = self.chance(0.04);
        let n = vrs.len();
        let sentinel = -12345.678;
        let mut out = vec![sentinel; n + 1];
        let expect = inst.m.expect_get(&vrs, n > 0 && null, real_kind);
        // SAFETY: NULL or `n` valid elements.
        let status = unsafe { fmu::fmi2GetReal(inst.c, ptr_or_null(&vrs, null), n, out.as_mut_ptr()) };
        self.check(&inst.key, format!("fmi2GetReal({vrs:?}, null {null})"), status, expect);
        if out[n] != sentinel {
            self.fail("fmi2GetReal wrote past nvr");
        }
        if status == Fmi2Status::Ok {
            for (r, x) in vrs.iter().zip(&out) {
                if !self.t.is_output(*r) && !same(*x, inst.m.values[*r as usize]) {
                    let want = inst.m.values[*r as usize];
                    self.fail(&format!("vr {r} reads {x:e}, last accepted {want:e}"));
                }
            }
        }
    }

    fn get_integer(&mut self, inst: &mut Instance) {
        let vrs = self.get_vrs(&[self.t.own_integer(), self.t.vr("filter"), self.t.vr("skipped_measurements")]);
        let null = self.chance(0.05);
        let n = vrs.len();
        let mut out = vec![-777; n + 1];
        let expect = inst.m.expect_get(&vrs, n > 0 && null, integer_kind);
        // SAFETY: NULL or `n` valid elements.
        let status = unsafe { fmu::fmi2GetInteger(inst.c, vrs.as_ptr(), n, mut_ptr_or_null(&mut out, null)) };
        self.check(&inst.key, format!("fmi2GetInteger({vrs:?}, null {null})"), status, expect);
        if out[n] != -777 {
            self.fail("fmi2GetInteger wrote past nvr");
        }
        if status == Fmi2Status::Ok {
            for (r, x) in vrs.iter().zip(&out) {
                let want = inst.m.values[*r as usize];
                if (!self.t.is_output(*r) && f64::from(*x) != want) || (self.t.is_output(*r) && *x < 0) {
                    self.fail(&format!("vr {r} reads {x}, last accepted {want}"));
                }
            }
        }
    }

    fn get_boolean(&mut self, inst: &mut Instance) {
        let vrs = self.get_vrs(&[self.t.vr("filter_healthy")]);
        let null = self.chance(0.05);
        let n = vrs.len();
        let mut out = vec![-777; n + 1];
        let expect = inst.m.expect_get(&vrs, n > 0 && null, boolean_kind);
        // SAFETY: NULL or `n` valid elements.
        let status = unsafe { fmu::fmi2GetBoolean(inst.c, ptr_or_null(&vrs, null), n, out.as_mut_ptr()) };
        self.check(&inst.key, format!("fmi2GetBoolean({vrs:?}, null {null})"), status, expect);
        if out[n] != -777 || (status == Fmi2Status::Ok && out[..n].iter().any(|b| !matches!(b, 0 | 1))) {
            self.fail(&format!("fmi2GetBoolean wrote {out:?}"));
        }
    }

    fn get_string(&mut self, inst: &mut Instance) {
        let vrs = self.get_vrs(&[0, 1, 2]);
        let n = vrs.len();
        let mut out: Vec<Fmi2String> = vec![ptr::null(); n + 1];
        let expect = inst.m.expect_get(&vrs, false, no_kind);
        // SAFETY: `n` valid elements.
        let status = unsafe { fmu::fmi2GetString(inst.c, vrs.as_ptr(), n, out.as_mut_ptr()) };
        self.check(&inst.key, format!("fmi2GetString({vrs:?})"), status, expect);
        if out.iter().any(|p| !p.is_null()) {
            self.fail("fmi2GetString wrote a string though the FMU has none");
        }
    }

    fn set_debug_logging(&mut self, inst: &mut Instance) {
        let pool =
            [c"logEvents", c"logStatusWarning", c"logStatusError", c"logStatusFatal", c"logAll", c"", c"LOGEVENTS"];
        let n = self.pick(&[0, 1, 2, 3]);
        let names: Vec<&CStr> = (0..n).map(|_| self.pick(&pool)).collect();
        let pointers: Vec<Fmi2String> = names.iter().map(|s| s.as_ptr()).collect();
        let null = self.chance(0.05);
        let known = |s: &&CStr| pool[..4].contains(s);
        let expect = if null && n > 0 || !names.iter().all(known) { Expect::Error } else { Expect::Ok };
        let on = self.rng.random_range(0..2);
        // SAFETY: NULL or `n` valid strings.
        let status = unsafe { fmu::fmi2SetDebugLogging(inst.c, on, n, ptr_or_null(&pointers, null)) };
        self.check(&inst.key, format!("fmi2SetDebugLogging({on}, {names:?}, null {null})"), status, expect);
    }

    // ----- FMU state -----

    fn get_fmu_state(&mut self, inst: &mut Instance) {
        let case = self.rng.random_range(0..10);
        if case == 0 {
            // SAFETY: a NULL FMUstate pointer.
            let status = unsafe { fmu::fmi2GetFMUstate(inst.c, ptr::null_mut()) };
            return self.check(&inst.key, "fmi2GetFMUstate(NULL)".into(), status, Expect::Error);
        }
        if case < 4 && !inst.states.is_empty() {
            let i = self.rng.random_range(0..inst.states.len());
            let before = inst.states[i].0;
            // SAFETY: a state this instance got before.
            let status = unsafe { fmu::fmi2GetFMUstate(inst.c, &mut inst.states[i].0) };
            self.check(&inst.key, format!("fmi2GetFMUstate(existing {i})"), status, Expect::Ok);
            assert_eq!(inst.states[i].0, before, "an existing state is updated in place");
            inst.states[i].1 = inst.m.clone();
            return;
        }
        let mut s: Fmi2FmuState = ptr::null_mut();
        // SAFETY: a valid pointer to a NULL state.
        let status = unsafe { fmu::fmi2GetFMUstate(inst.c, &mut s) };
        self.check(&inst.key, "fmi2GetFMUstate(new)".into(), status, Expect::Ok);
        assert!(!s.is_null(), "fmi2GetFMUstate returns a state");
        inst.states.push((s, inst.m.clone()));
    }

    fn set_fmu_state(&mut self, inst: &mut Instance) {
        if inst.states.is_empty() || self.chance(0.1) {
            // SAFETY: NULL state.
            let status = unsafe { fmu::fmi2SetFMUstate(inst.c, ptr::null_mut()) };
            return self.check(&inst.key, "fmi2SetFMUstate(NULL)".into(), status, Expect::Error);
        }
        let i = self.rng.random_range(0..inst.states.len());
        // SAFETY: a state of this instance.
        let status = unsafe { fmu::fmi2SetFMUstate(inst.c, inst.states[i].0) };
        self.check(&inst.key, format!("fmi2SetFMUstate({i})"), status, Expect::Ok);
        inst.m = inst.states[i].1.clone();
    }

    fn free_fmu_state(&mut self, inst: &mut Instance) {
        match self.rng.random_range(0..10) {
            0..=1 => {
                // SAFETY: NULL is allowed (nothing to free).
                let status = unsafe { fmu::fmi2FreeFMUstate(inst.c, ptr::null_mut()) };
                self.check(&inst.key, "fmi2FreeFMUstate(NULL)".into(), status, Expect::Ok);
            }
            2 => {
                let mut s: Fmi2FmuState = ptr::null_mut();
                // SAFETY: a pointer to a NULL state.
                let status = unsafe { fmu::fmi2FreeFMUstate(inst.c, &mut s) };
                self.check(&inst.key, "fmi2FreeFMUstate(&NULL)".into(), status, Expect::Ok);
            }
            _ if !inst.states.is_empty() => {
                let i = self.rng.random_range(0..inst.states.len());
                let (mut s, _) = inst.states.swap_remove(i);
                // SAFETY: a state of this instance, freed once.
                let status = unsafe { fmu::fmi2FreeFMUstate(inst.c, &mut s) };
                self.check(&inst.key, format!("fmi2FreeFMUstate({i})"), status, Expect::Ok);
                assert!(s.is_null(), "fmi2FreeFMUstate sets the state to NULL");
            }
            _ => {}
        }
    }

    /// The serialised size of state `i` (checked to succeed).
    fn size_of(&mut self, inst: &Instance, i: usize) -> usize {
        let mut size = 0usize;
        // SAFETY: a state of this instance and a valid size pointer.
        let status = unsafe { fmu::fmi2SerializedFMUstateSize(inst.c, inst.states[i].0, &mut size) };
        self.check(&inst.key, format!("fmi2SerializedFMUstateSize({i})"), status, Expect::Ok);
        assert!(size > 0);
        size
    }

    fn serialized_size(&mut self, inst: &mut Instance) {
        let mut size = 0usize;
        if inst.states.is_empty() || self.chance(0.2) {
            let s = inst.states.first().map_or(ptr::null_mut(), |s| s.0);
            let (state, size_ptr): (Fmi2FmuState, *mut usize) =
                if s.is_null() || self.chance(0.5) { (ptr::null_mut(), &mut size) } else { (s, ptr::null_mut()) };
            // SAFETY: NULL or valid pointers.
            let status = unsafe { fmu::fmi2SerializedFMUstateSize(inst.c, state, size_ptr) };
            return self.check(&inst.key, "fmi2SerializedFMUstateSize(NULL)".into(), status, Expect::Error);
        }
        let i = self.rng.random_range(0..inst.states.len());
        self.size_of(inst, i);
    }

    fn serialize(&mut self, inst: &mut Instance) {
        if inst.states.is_empty() && self.chance(0.7) {
            self.get_fmu_state(inst);
        }
        if inst.states.is_empty() {
            let mut buffer = [0u8; 16];
            // SAFETY: a NULL state and a valid buffer.
            let status = unsafe { fmu::fmi2SerializeFMUstate(inst.c, ptr::null_mut(), buffer.as_mut_ptr().cast(), 16) };
            return self.check(&inst.key, "fmi2SerializeFMUstate(NULL state)".into(), status, Expect::Error);
        }
        let i = self.rng.random_range(0..inst.states.len());
        let size = self.size_of(inst, i);
        let (claimed, null) = match self.rng.random_range(0..10) {
            0 => (size, true),
            1 => (size - 1, false),
            2 => (size + 1, false),
            _ => (size, false),
        };
        let mut buffer = vec![0u8; claimed];
        let expect = if null || claimed != size { Expect::Error } else { Expect::Ok };
        // SAFETY: a state of this instance; NULL or a buffer of `claimed` bytes.
        let status = unsafe {
            fmu::fmi2SerializeFMUstate(inst.c, inst.states[i].0, mut_ptr_or_null(&mut buffer, null).cast(), claimed)
        };
        self.check(&inst.key, format!("fmi2SerializeFMUstate({i}, {claimed} of {size}, null {null})"), status, expect);
        if status == Fmi2Status::Ok {
            self.blobs.push((buffer, inst.states[i].1.clone()));
        }
    }

    fn deserialize(&mut self, inst: &mut Instance) {
        let blob = (!self.blobs.is_empty()).then(|| self.blobs[self.rng.random_range(0..self.blobs.len())].clone());
        let case = self.rng.random_range(0..20);
        let (bytes, model): (Vec<u8>, Option<Model>) = match (case, blob) {
            (0..=11, Some((b, m))) => (b, Some(m)),
            (12..=13, Some((mut b, _))) => {
                let cut = self.rng.random_range(0..b.len());
                b.truncate(cut);
                (b, None)
            }
            (14, Some((mut b, _))) => {
                b.push(0);
                (b, None)
            }
            (15..=16, Some((mut b, _))) => {
                // Magic, version, GUID length or GUID.
                let at = self.rng.random_range(0..54);
                b[at] ^= 1 << self.rng.random_range(0..8);
                (b, None)
            }
            (17..=18, Some((b, _))) => ((0..b.len()).map(|_| self.rng.random()).collect(), None),
            _ => ((0..self.rng.random_range(0..300)).map(|_| self.rng.random()).collect(), None),
        };
        let expect = if model.is_some() { Expect::Ok } else { Expect::Error };
        match self.rng.random_range(0..10) {
            0 => {
                // SAFETY: valid bytes; NULL FMUstate pointer.
                let status = unsafe {
                    fmu::fmi2DeSerializeFMUstate(inst.c, bytes.as_ptr().cast(), bytes.len(), ptr::null_mut())
                };
                self.check(&inst.key, "fmi2DeSerializeFMUstate(NULL FMUstate)".into(), status, Expect::Error);
            }
            1 => {
                let mut s: Fmi2FmuState = ptr::null_mut();
                let size = self.pick(&[0, bytes.len().max(1)]);
                // SAFETY: NULL bytes.
                let status = unsafe { fmu::fmi2DeSerializeFMUstate(inst.c, ptr::null(), size, &mut s) };
                self.check(&inst.key, format!("fmi2DeSerializeFMUstate(NULL, {size})"), status, Expect::Error);
                assert!(s.is_null());
            }
            2..=3 if !inst.states.is_empty() => {
                let i = self.rng.random_range(0..inst.states.len());
                let before = inst.states[i].0;
                // SAFETY: `bytes.len()` valid bytes; a state of this instance.
                let status = unsafe {
                    fmu::fmi2DeSerializeFMUstate(inst.c, bytes.as_ptr().cast(), bytes.len(), &mut inst.states[i].0)
                };
                self.check(
                    &inst.key,
                    format!("fmi2DeSerializeFMUstate({} bytes into {i})", bytes.len()),
                    status,
                    expect,
                );
                assert_eq!(inst.states[i].0, before, "deserialised in place");
                if let Some(m) = model {
                    inst.states[i].1 = m;
                }
            }
            _ => {
                let mut s: Fmi2FmuState = ptr::null_mut();
                // SAFETY: `bytes.len()` valid bytes; a pointer to a NULL state.
                let status =
                    unsafe { fmu::fmi2DeSerializeFMUstate(inst.c, bytes.as_ptr().cast(), bytes.len(), &mut s) };
                self.check(&inst.key, format!("fmi2DeSerializeFMUstate({} bytes)", bytes.len()), status, expect);
                match model {
                    Some(m) => inst.states.push((s, m)),
                    None => assert!(s.is_null(), "a refused state leaves FMUstate NULL"),
                }
            }
        }
    }

    // ----- status, cancel, derivatives -----

    fn status(&mut self, inst: &mut Instance, which: usize) {
        let kind = self.pick(&[0, 1, 2, 3, -1, 99]);
        let null = self.chance(0.2);
        let legal = inst.m.status_legal();
        let fail_or_illegal = if legal { Expect::Error } else { Expect::Illegal };
        let (mut status_out, mut real, mut int, mut boolean, mut string) =
            (Fmi2Status::Fatal, -1.0, -1, -1, ptr::null::<c_char>());
        // SAFETY: NULL or valid pointers; the FMU writes at most one value.
        let (name, status, expect) = unsafe {
            match which {
                0 => (
                    "fmi2GetStatus",
                    fmu::fmi2GetStatus(inst.c, kind, if null { ptr::null_mut() } else { &mut status_out }),
                    fail_or_illegal,
                ),
                1 => {
                    let ok = kind == FMI2_LAST_SUCCESSFUL_TIME && !null;
                    let p = if null { ptr::null_mut() } else { &mut real };
                    (
                        "fmi2GetRealStatus",
                        fmu::fmi2GetRealStatus(inst.c, kind, p),
                        if legal && ok { Expect::Ok } else { fail_or_illegal },
                    )
                }
                2 => (
                    "fmi2GetIntegerStatus",
                    fmu::fmi2GetIntegerStatus(inst.c, kind, if null { ptr::null_mut() } else { &mut int }),
                    fail_or_illegal,
                ),
                3 => {
                    let ok = kind == FMI2_TERMINATED && !null;
                    let p = if null { ptr::null_mut() } else { &mut boolean };
                    (
                        "fmi2GetBooleanStatus",
                        fmu::fmi2GetBooleanStatus(inst.c, kind, p),
                        if legal && ok { Expect::Ok } else { fail_or_illegal },
                    )
                }
                _ => (
                    "fmi2GetStringStatus",
                    fmu::fmi2GetStringStatus(inst.c, kind, if null { ptr::null_mut() } else { &mut string }),
                    fail_or_illegal,
                ),
            }
        };
        self.check(&inst.key, format!("{name}({kind}, null {null})"), status, expect);
        if status == Fmi2Status::Ok && which == 1 && inst.m.st == St::StepComplete && !same(real, inst.m.time) {
            self.fail(&format!("last successful time {real}, the FMU is at {}", inst.m.time));
        }
        if status == Fmi2Status::Ok && which == 3 && boolean != Fmi2Boolean::from(inst.m.st == St::StepFailed) {
            self.fail(&format!("fmi2Terminated is {boolean} in {:?}", inst.m.st));
        }
        if int != -1 || !string.is_null() || status_out != Fmi2Status::Fatal {
            self.fail("a status function that is not provided wrote a value");
        }
    }

    fn derivatives(&mut self, inst: &mut Instance) {
        let vrs = [self.t.estimate(), self.t.inputs()[0]];
        let order = [1, 1];
        let mut values = [0.0; 2];
        // SAFETY: NULL or arrays of two elements.
        let (name, status) = unsafe {
            match self.rng.random_range(0..3) {
                0 => (
                    "fmi2GetDirectionalDerivative",
                    fmu::fmi2GetDirectionalDerivative(
                        inst.c,
                        vrs.as_ptr(),
                        1,
                        vrs[1..].as_ptr(),
                        1,
                        values.as_ptr(),
                        ptr::null_mut(),
                    ),
                ),
                1 => (
                    "fmi2SetRealInputDerivatives",
                    fmu::fmi2SetRealInputDerivatives(inst.c, vrs[1..].as_ptr(), 1, order.as_ptr(), values.as_ptr()),
                ),
                _ => (
                    "fmi2GetRealOutputDerivatives",
                    fmu::fmi2GetRealOutputDerivatives(inst.c, vrs.as_ptr(), 1, order.as_ptr(), values.as_mut_ptr()),
                ),
            }
        };
        self.check(&inst.key, name.into(), status, Expect::Error);
        assert_eq!(values, [0.0; 2], "{name} wrote a value");
    }

    /// A function called with a NULL component: fmi2Error, no crash.
    fn null_component(&mut self) {
        let c: Fmi2Component = ptr::null_mut();
        let (r, mut x, mut s) = ([0u32], [0.0], ptr::null_mut());
        // SAFETY: valid argument pointers; the component is NULL.
        let status = unsafe {
            match self.rng.random_range(0..8) {
                0 => fmu::fmi2DoStep(c, 0.0, 0.005, 1),
                1 => fmu::fmi2SetReal(c, r.as_ptr(), 1, x.as_ptr()),
                2 => fmu::fmi2GetReal(c, r.as_ptr(), 1, x.as_mut_ptr()),
                3 => fmu::fmi2GetFMUstate(c, &mut s),
                4 => fmu::fmi2Terminate(c),
                5 => fmu::fmi2Reset(c),
                6 => fmu::fmi2SetDebugLogging(c, 1, 0, ptr::null()),
                _ => {
                    fmu::fmi2FreeInstance(c);
                    Fmi2Status::Error
                }
            }
        };
        self.trace.push(format!("call with a NULL component -> {status:?}"));
        if status != Fmi2Status::Error || !s.is_null() {
            self.fail("a NULL component is not refused");
        }
    }
}

/// Aborts the test process when no sequence finishes for a minute (a hang).
fn watchdog(progress: &'static AtomicU64, done: &'static AtomicBool) {
    std::thread::spawn(move || {
        let mut last = (progress.load(Ordering::Relaxed), Instant::now());
        while !done.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(200));
            let now = progress.load(Ordering::Relaxed);
            if now != last.0 {
                last = (now, Instant::now());
            } else if last.1.elapsed() > Duration::from_secs(60) {
                eprintln!("random_calls: sequence {now} has made no progress for 60 s: a hang");
                std::process::abort();
            }
        }
    });
}

/// The sequences, split evenly between the FMUs: sequence `k` drives FMU `k mod n`.
#[test]
fn random_call_sequences() {
    static PROGRESS: AtomicU64 = AtomicU64::new(0);
    static DONE: AtomicBool = AtomicBool::new(false);
    watchdog(&PROGRESS, &DONE);
    let base: u64 = std::env::var("KALFMU_RANDOM_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(0x6b61_6c66);
    let tables = Table::all();
    let started = Instant::now();
    let mut slowest = (Duration::ZERO, 0);
    // Per FMU: `(function, outcome)` → count.
    let mut stats: Vec<HashMap<(String, String), u64>> = vec![HashMap::new(); tables.len()];
    for k in 0..SEQUENCES {
        let seed = base.wrapping_add(k);
        let which = (k % tables.len() as u64) as usize;
        PROGRESS.store(seed, Ordering::Relaxed);
        let t = Instant::now();
        let mut sequence = Sequence::new(seed, tables[which]);
        sequence.run();
        for (key, n) in sequence.stats {
            *stats[which].entry(key).or_default() += n;
        }
        slowest = slowest.max((t.elapsed(), seed));
    }
    DONE.store(true, Ordering::Relaxed);
    let calls: u64 = stats.iter().flat_map(HashMap::values).sum();
    println!(
        "{SEQUENCES} sequences, {calls} checked calls in {:.2?}; slowest sequence {:.2?} (seed {})",
        started.elapsed(),
        slowest.0,
        slowest.1
    );
    for (table, stats) in tables.iter().zip(&stats) {
        println!("{}:", table.id());
        let mut summary: Vec<_> = stats.iter().collect();
        summary.sort();
        for ((function, outcome), n) in summary {
            println!("  {function:32} {outcome:8} {n}");
        }
        // The sequences reach every corner they are meant to, on every FMU (guards
        // against weights drifting): at least this many per 1000 sequences.
        let count = |f: &str, o: &str| stats.get(&(f.to_owned(), o.to_owned())).copied().unwrap_or(0);
        let per_thousand = (SEQUENCES / tables.len() as u64) as f64 / 1000.0;
        for (f, o, at_least) in [
            ("fmi2DoStep", "Ok", 2500),
            ("fmi2DoStep", "Error", 500),
            ("fmi2DoStep", "Illegal", 500),
            ("fmi2ExitInitializationMode", "Ok", 500),
            ("fmi2ExitInitializationMode", "Error", 5),
            ("fmi2SetReal", "Ok", 2500),
            ("fmi2SetReal", "Error", 1000),
            ("fmi2SetFMUstate", "Ok", 250),
            ("fmi2DeSerializeFMUstate", "Ok", 100),
            ("fmi2DeSerializeFMUstate", "Error", 250),
            ("fmi2SerializeFMUstate", "Ok", 100),
            ("fmi2SetDebugLogging", "Error", 50),
        ] {
            let n = count(f, o);
            assert!(
                n as f64 >= at_least as f64 * per_thousand,
                "{}: only {n} calls of {f} with outcome {o}",
                table.id()
            );
        }
    }
    // A failed step (a filter that cannot go on) is reached on some FMU: the
    // shell's path is the same for all, and a supervised filter that follows
    // jumps and adapts its Q may never fail under these sequences.
    let discards: u64 =
        stats.iter().map(|s| s.get(&("fmi2DoStep".to_owned(), "Discard".to_owned())).copied().unwrap_or(0)).sum();
    assert!(discards >= 2, "only {discards} calls of fmi2DoStep with outcome Discard over every FMU");
}

// ----- directed tests -----

/// A valid instance of FMU `t` through the C logger, initialised with defaults.
fn running_instance(t: Table, name: &CString, callbacks: &Fmi2CallbackFunctions) -> Fmi2Component {
    // SAFETY: valid strings and callbacks.
    unsafe {
        let c = fmu::fmi2Instantiate(name.as_ptr(), FMI2_COSIMULATION, t.guid().as_ptr(), ptr::null(), callbacks, 0, 0);
        assert!(!c.is_null());
        assert_eq!(fmu::fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), Fmi2Status::Ok);
        assert_eq!(fmu::fmi2EnterInitializationMode(c), Fmi2Status::Ok);
        assert_eq!(fmu::fmi2ExitInitializationMode(c), Fmi2Status::Ok);
        c
    }
}

/// One call of a legal run, for [`capturing_the_fmu_state_changes_no_output`].
#[derive(Debug, Clone)]
enum Call {
    /// Every input, in row order.
    SetInputs(Vec<f64>),
    /// Every control, in the order of the model's input.
    SetControls(Vec<f64>),
    SetTunable(u32, f64),
    Read,
    DoStep(f64),
    /// fmi2GetFMUstate, then maybe size and serialise, then maybe free: left
    /// out of the twin run.
    Capture {
        serialize: bool,
        free: bool,
    },
}

/// A random legal run of one instance of FMU `t`: inputs (the first one
/// sometimes NaN), controls of a few degrees (if it has any), reads, steps of 0.2, 1, 1.5 and 2 default sample times (at
/// S1's 5 ms: 1, 5, 7.5 and 10 ms), changes of a tunable (the last: a sensor's
/// noise), and state captures between any two of them.
fn legal_run(t: Table, seed: u64) -> Vec<Call> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (m, ts, sensor) = (t.inputs().len(), t.sample_time(), *t.tunables().last().expect("a tunable"));
    let mut calls = Vec::new();
    for _ in 0..rng.random_range(40..160) {
        let call = match rng.random_range(0..20) {
            0..=5 => {
                let mut z: Vec<f64> = (0..m).map(|_| rng.random_range(-3.0..3.0)).collect();
                if rng.random_bool(0.05) {
                    z[0] = f64::NAN;
                }
                Call::SetInputs(z)
            }
            6 if !t.controls().is_empty() => {
                Call::SetControls(t.controls().iter().map(|_| rng.random_range(-0.05..0.05)).collect())
            }
            6..=9 => Call::Read,
            10..=15 => Call::DoStep([0.2, 1.0, 1.0, 1.5, 2.0][rng.random_range(0..5)] * ts),
            16 => Call::SetTunable(sensor, rng.random_range(0.005..0.05)),
            _ => Call::Capture { serialize: rng.random_bool(0.5), free: rng.random_bool(0.7) },
        };
        calls.push(call);
    }
    calls
}

/// Runs `calls` on a new instance of FMU `t` with filter `kind`, skipping the
/// captures unless `capture`, with `input_timing` = `timing`; returns every output read, as bits.
fn outputs_of(
    t: Table,
    calls: &[Call],
    (kind, timing): (i32, i32),
    capture: bool,
    callbacks: &Fmi2CallbackFunctions,
) -> Vec<u64> {
    let name = CString::new(format!("capture-{kind}-{capture}")).expect("no NUL");
    let (reals, counts, flags) = (t.outputs(Kind::Real), t.outputs(Kind::Integer), t.outputs(Kind::Boolean));
    let (inputs, controls) = (t.inputs(), t.controls());
    let (mut seen, mut held) = (Vec::new(), Vec::new());
    let mut time = 0.0;
    // SAFETY: valid strings, callbacks, pointers and lengths throughout; the
    // states are this instance's and freed once.
    unsafe {
        let c = fmu::fmi2Instantiate(name.as_ptr(), FMI2_COSIMULATION, t.guid().as_ptr(), ptr::null(), callbacks, 0, 0);
        assert!(!c.is_null());
        assert_eq!(fmu::fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), Fmi2Status::Ok);
        assert_eq!(fmu::fmi2EnterInitializationMode(c), Fmi2Status::Ok);
        assert_eq!(fmu::fmi2SetInteger(c, &t.vr("filter"), 1, &kind), Fmi2Status::Ok);
        assert_eq!(fmu::fmi2SetInteger(c, &t.vr("input_timing"), 1, &timing), Fmi2Status::Ok);
        assert_eq!(fmu::fmi2ExitInitializationMode(c), Fmi2Status::Ok);
        for call in calls {
            match *call {
                Call::SetInputs(ref z) => {
                    assert_eq!(fmu::fmi2SetReal(c, inputs.as_ptr(), inputs.len(), z.as_ptr()), Fmi2Status::Ok);
                }
                Call::SetControls(ref u) => {
                    assert_eq!(fmu::fmi2SetReal(c, controls.as_ptr(), controls.len(), u.as_ptr()), Fmi2Status::Ok);
                }
                Call::SetTunable(r, x) => assert_eq!(fmu::fmi2SetReal(c, &r, 1, &x), Fmi2Status::Ok),
                Call::Read => {
                    let mut out = vec![0.0; reals.len()];
                    assert_eq!(fmu::fmi2GetReal(c, reals.as_ptr(), reals.len(), out.as_mut_ptr()), Fmi2Status::Ok);
                    let mut count = vec![0; counts.len()];
                    let status = fmu::fmi2GetInteger(c, counts.as_ptr(), counts.len(), count.as_mut_ptr());
                    assert_eq!(status, Fmi2Status::Ok);
                    let mut flag = vec![0; flags.len()];
                    assert_eq!(fmu::fmi2GetBoolean(c, flags.as_ptr(), flags.len(), flag.as_mut_ptr()), Fmi2Status::Ok);
                    let words = count.iter().chain(&flag).map(|&v| v as u64);
                    seen.extend(out.iter().map(|x| x.to_bits()).chain(words));
                }
                Call::DoStep(h) => {
                    assert_eq!(fmu::fmi2DoStep(c, time, h, 1), Fmi2Status::Ok);
                    time += h;
                }
                Call::Capture { serialize, free } => {
                    if !capture {
                        continue;
                    }
                    let mut state: Fmi2FmuState = ptr::null_mut();
                    assert_eq!(fmu::fmi2GetFMUstate(c, &mut state), Fmi2Status::Ok);
                    if serialize {
                        let mut size = 0;
                        assert_eq!(fmu::fmi2SerializedFMUstateSize(c, state, &mut size), Fmi2Status::Ok);
                        let mut bytes = vec![0u8; size];
                        assert_eq!(
                            fmu::fmi2SerializeFMUstate(c, state, bytes.as_mut_ptr().cast(), size),
                            Fmi2Status::Ok
                        );
                    }
                    if free {
                        assert_eq!(fmu::fmi2FreeFMUstate(c, &mut state), Fmi2Status::Ok);
                    } else {
                        held.push(state);
                    }
                }
            }
        }
        for mut state in held {
            assert_eq!(fmu::fmi2FreeFMUstate(c, &mut state), Fmi2Status::Ok);
        }
        fmu::fmi2FreeInstance(c);
    }
    seen
}

/// Capturing or serialising the FMU state changes nothing: for every filter
/// kind, a random legal run gives bit for bit the outputs of the same run
/// with the fmi2GetFMUstate / fmi2SerializedFMUstateSize /
/// fmi2SerializeFMUstate / fmi2FreeFMUstate calls left out, under either input timing. The 24 runs are
/// split evenly between the FMUs (run `k` on FMU `k mod n`).
#[test]
fn capturing_the_fmu_state_changes_no_output() {
    let callbacks = callbacks();
    let tables = Table::all();
    for seed in 0..24 {
        let t = tables[seed as usize % tables.len()];
        let calls = legal_run(t, seed);
        for kind in 1..=5 {
            // Both input timings: with step_end the controls in force are saved apart from the inputs.
            let timing = 1 + (kind + seed as i32) % 2;
            let with = outputs_of(t, &calls, (kind, timing), true, &callbacks);
            let without = outputs_of(t, &calls, (kind, timing), false, &callbacks);
            assert!(!with.is_empty() || !calls.iter().any(|c| matches!(c, Call::Read)));
            if let Some(i) = with.iter().zip(&without).position(|(a, b)| a != b) {
                panic!(
                    "{}, seed {seed}, filter {kind}: output {i} is {:e} with the captures, {:e} without",
                    t.id(),
                    f64::from_bits(with[i]),
                    f64::from_bits(without[i])
                );
            }
            assert_eq!(with.len(), without.len());
        }
    }
}

/// Refused calls in StepComplete change nothing: on every FMU, the instance
/// steps on exactly like an undisturbed twin.
#[test]
fn rejected_calls_leave_the_instance_usable() {
    let callbacks = callbacks();
    for table in Table::all() {
        let (name_a, name_b) = (c"rejected-a".to_owned(), c"rejected-b".to_owned());
        let (a, b) = (running_instance(table, &name_a, &callbacks), running_instance(table, &name_b, &callbacks));
        let (inputs, controls) = (table.inputs(), table.controls());
        let outputs = table.outputs(Kind::Real);
        let tunables = table.tunables();
        let dt = table.sample_time();
        // SAFETY: live instances and valid arrays of the lengths given.
        unsafe {
            for k in 0..60 {
                let t = k as f64 * dt;
                let z = table.plausible(t);
                let u: Vec<f64> = (0..controls.len()).map(|j| 0.01 * ((2.0 + j as f64) * t).sin()).collect();
                for c in [a, b] {
                    assert_eq!(fmu::fmi2SetReal(c, inputs.as_ptr(), inputs.len(), z.as_ptr()), Fmi2Status::Ok);
                    assert_eq!(fmu::fmi2SetReal(c, controls.as_ptr(), controls.len(), u.as_ptr()), Fmi2Status::Ok);
                }
                if k % 3 == 0 {
                    // Refused: an output, a fixed parameter, NaN / inf into a tunable,
                    // an Integer through SetReal, an unknown reference, wrong step
                    // arguments; a NaN or infinite control (a control is never missing).
                    let mut refused = vec![
                        (table.estimate(), 1.0),
                        (table.fixed_real(), 5.0),
                        (tunables[0], f64::NAN),
                        (tunables[tunables.len() - 1], f64::INFINITY),
                        (table.own_integer(), 2.0),
                        (999, 0.0),
                    ];
                    for &r in &controls {
                        refused.extend([(r, f64::NAN), (r, f64::NEG_INFINITY)]);
                    }
                    for (r, x) in refused {
                        // A good input first: all or nothing, so it is not applied either.
                        let (vrs, xs) = ([inputs[0], r], [1e3, x]);
                        assert_eq!(fmu::fmi2SetReal(a, vrs.as_ptr(), 2, xs.as_ptr()), Fmi2Status::Error, "vr {r}");
                    }
                    let filter = [table.vr("filter")];
                    assert_eq!(fmu::fmi2SetInteger(a, filter.as_ptr(), 1, [4].as_ptr()), Fmi2Status::Error);
                    assert_eq!(fmu::fmi2DoStep(a, t + 1.0, dt, 1), Fmi2Status::Error);
                    assert_eq!(fmu::fmi2DoStep(a, t, 0.0, 1), Fmi2Status::Error);
                    assert_eq!(fmu::fmi2DoStep(a, t, -dt, 1), Fmi2Status::Error);
                    assert_eq!(fmu::fmi2DoStep(a, f64::NAN, dt, 1), Fmi2Status::Error);
                    assert_eq!(fmu::fmi2EnterInitializationMode(a), Fmi2Status::Error);
                    assert_eq!(
                        fmu::fmi2DeSerializeFMUstate(a, [1u8; 64].as_ptr().cast(), 64, &mut ptr::null_mut()),
                        Fmi2Status::Error
                    );
                    let messages = take_messages("rejected-a");
                    assert!(messages.iter().filter(|(l, _)| *l == log::Level::Error).count() >= 12, "{messages:?}");
                    assert!(messages.iter().any(|(_, m)| m.contains("illegal call sequence")), "{messages:?}");
                }
                let (mut ya, mut yb) = (vec![0.0; outputs.len()], vec![0.0; outputs.len()]);
                let mut statuses = Vec::with_capacity(2);
                for (c, y) in [(a, &mut ya), (b, &mut yb)] {
                    // A warning is a step made: these synthetic inputs can drive an
                    // estimate out of its plausible range (fmu/src/plausibility.rs).
                    let status = fmu::fmi2DoStep(c, t, dt, 1);
                    assert!(
                        matches!(status, Fmi2Status::Ok | Fmi2Status::Warning),
                        "{} sample {k}: {status:?}",
                        table.id()
                    );
                    statuses.push(status);
                    assert_eq!(fmu::fmi2GetReal(c, outputs.as_ptr(), outputs.len(), y.as_mut_ptr()), Fmi2Status::Ok);
                }
                assert_eq!(statuses[0], statuses[1], "{} sample {k}: the refused calls changed the step", table.id());
                let bits = |y: &[f64]| y.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&ya), bits(&yb), "{} sample {k}: the refused calls changed the estimate", table.id());
            }
            fmu::fmi2FreeInstance(a);
            fmu::fmi2FreeInstance(b);
        }
        take_messages("rejected-b");
    }
}

/// The FMUs share one library but not their states: a state serialised by an
/// instance of one FMU is refused, saying so, by an instance of every other.
#[test]
fn a_state_of_another_fmu_is_refused() {
    let callbacks = callbacks();
    let name = c"foreign".to_owned();
    let tables = Table::all();
    for (from, to) in tables.iter().flat_map(|a| tables.iter().map(move |b| (*a, *b))) {
        if from.id() == to.id() {
            continue;
        }
        // SAFETY: live instances, valid pointers and lengths; states freed once.
        unsafe {
            let (a, b) = (running_instance(from, &name, &callbacks), running_instance(to, &name, &callbacks));
            let mut s: Fmi2FmuState = ptr::null_mut();
            assert_eq!(fmu::fmi2GetFMUstate(a, &mut s), Fmi2Status::Ok);
            let mut size = 0;
            assert_eq!(fmu::fmi2SerializedFMUstateSize(a, s, &mut size), Fmi2Status::Ok);
            let mut bytes = vec![0u8; size];
            assert_eq!(fmu::fmi2SerializeFMUstate(a, s, bytes.as_mut_ptr().cast(), size), Fmi2Status::Ok);
            take_messages("foreign");
            let mut t: Fmi2FmuState = ptr::null_mut();
            let status = fmu::fmi2DeSerializeFMUstate(b, bytes.as_ptr().cast(), size, &mut t);
            let messages = take_messages("foreign");
            assert_eq!(status, Fmi2Status::Error, "{} state into {}", from.id(), to.id());
            assert!(t.is_null(), "a refused state leaves FMUstate NULL");
            assert!(messages.iter().any(|(_, m)| m.contains("FMU state of another FMU")), "{messages:?}");
            assert_eq!(fmu::fmi2FreeFMUstate(a, &mut s), Fmi2Status::Ok);
            fmu::fmi2FreeInstance(a);
            fmu::fmi2FreeInstance(b);
        }
    }
}

/// A saved state with its model-state tag replaced by every tag: the FMU
/// refuses the states it never saves (they left the instance stuck or made
/// fmi2DoStep panic), goes on without an internal error after the others,
/// and fmi2Reset always brings the instance back.
#[test]
fn crafted_state_tags_are_refused_or_harmless() {
    let callbacks = callbacks();
    let name = c"crafted".to_owned();
    for (table, initialised) in Table::all().into_iter().flat_map(|t| [(t, false), (t, true)]) {
        for tag in [0u8, 1, 2, 4, 8, 16, 32, 64, 128] {
            // SAFETY: a live instance, valid pointers and lengths.
            unsafe {
                let c = if initialised {
                    running_instance(table, &name, &callbacks)
                } else {
                    fmu::fmi2Instantiate(
                        name.as_ptr(),
                        FMI2_COSIMULATION,
                        table.guid().as_ptr(),
                        ptr::null(),
                        &callbacks,
                        0,
                        0,
                    )
                };
                let mut s: Fmi2FmuState = ptr::null_mut();
                assert_eq!(fmu::fmi2GetFMUstate(c, &mut s), Fmi2Status::Ok);
                let mut size = 0;
                assert_eq!(fmu::fmi2SerializedFMUstateSize(c, s, &mut size), Fmi2Status::Ok);
                let mut bytes = vec![0u8; size];
                assert_eq!(fmu::fmi2SerializeFMUstate(c, s, bytes.as_mut_ptr().cast(), size), Fmi2Status::Ok);
                let guid_len = u32::from_le_bytes(bytes[12..16].try_into().expect("4 bytes")) as usize;
                bytes[16 + guid_len] = tag;
                let mut t: Fmi2FmuState = ptr::null_mut();
                let restored = fmu::fmi2DeSerializeFMUstate(c, bytes.as_ptr().cast(), size, &mut t) == Fmi2Status::Ok
                    && fmu::fmi2SetFMUstate(c, t) == Fmi2Status::Ok;
                // Whatever state it claims now, every call answers without an internal error.
                let (r, mut x, mut flag) = ([table.estimate()], [0.0], 0);
                fmu::fmi2DoStep(c, 0.0, table.sample_time(), 1);
                fmu::fmi2GetReal(c, r.as_ptr(), 1, x.as_mut_ptr());
                fmu::fmi2GetBooleanStatus(c, FMI2_TERMINATED, &mut flag);
                fmu::fmi2Terminate(c);
                let reset = fmu::fmi2Reset(c);
                let freed = (fmu::fmi2FreeFMUstate(c, &mut s), fmu::fmi2FreeFMUstate(c, &mut t));
                let messages = take_messages("crafted");
                let what = format!("{} tag {tag} (initialised {initialised}): {messages:?}", table.id());
                // Never saved: no tag, StartAndEnd, StepInProgress, StepCanceled; and
                // StepComplete / StepFailed need the filter an initialised instance has.
                let never = matches!(tag, 0 | 1 | 16 | 64) || (!initialised && matches!(tag, 8 | 32));
                assert_eq!(restored, !never, "{what}");
                assert!(!messages.iter().any(|(_, m)| m.contains("internal error")), "{what}");
                assert_eq!((reset, freed), (Fmi2Status::Ok, (Fmi2Status::Ok, Fmi2Status::Ok)), "{what}");
                fmu::fmi2FreeInstance(c);
            }
        }
    }
}

/// The logger gets the importer's `componentEnvironment` unchanged, the
/// instance name, and `"%s"` as the format with the message as its argument.
///
/// This logger is a plain (non-variadic) Rust function read through the
/// variadic pointer type: on the x86-64 System V and AArch64 Linux ABIs the
/// variadic arguments of a call travel exactly like named ones, so the
/// message is the sixth argument. (Stable Rust cannot define a variadic function.)
#[cfg(all(target_os = "linux", any(target_arch = "x86_64", target_arch = "aarch64")))]
#[test]
fn logger_gets_the_component_environment() {
    struct Seen {
        env: *mut c_void,
        calls: Vec<(String, i32, String, String, String)>,
    }
    unsafe extern "C" fn six_argument_logger(
        env: *mut c_void,
        name: Fmi2String,
        status: i32,
        category: Fmi2String,
        format: Fmi2String,
        message: Fmi2String,
    ) {
        // SAFETY: `env` is the `Seen` below; the FMU passes NUL-terminated strings.
        unsafe {
            let seen = &mut *env.cast::<Seen>();
            let text = |p: Fmi2String| CStr::from_ptr(p).to_string_lossy().into_owned();
            seen.calls.push((text(name), status, text(category), text(format), text(message)));
            seen.env = env;
        }
    }
    type SixArguments = unsafe extern "C" fn(*mut c_void, Fmi2String, i32, Fmi2String, Fmi2String, Fmi2String);
    let direct: SixArguments = six_argument_logger;
    // SAFETY: see the function's documentation: the FMU calls it with exactly six arguments.
    type Variadic = unsafe extern "C" fn(*mut c_void, Fmi2String, i32, Fmi2String, Fmi2String, ...);
    let logger: Fmi2CallbackLogger = Some(unsafe { std::mem::transmute::<SixArguments, Variadic>(direct) });
    let name = c"env%s%n".to_owned();
    for table in Table::all() {
        let mut seen = Seen { env: ptr::null_mut(), calls: Vec::new() };
        let env: *mut c_void = (&mut seen as *mut Seen).cast();
        let callbacks = Fmi2CallbackFunctions { component_environment: env, logger, ..self::callbacks() };
        // SAFETY: valid strings and callbacks; `seen` outlives the instance.
        unsafe {
            let guid = table.guid();
            let c =
                fmu::fmi2Instantiate(name.as_ptr(), FMI2_COSIMULATION, guid.as_ptr(), ptr::null(), &callbacks, 0, 1);
            assert!(!c.is_null());
            assert_eq!(fmu::fmi2DoStep(c, 0.0, table.sample_time(), 1), Fmi2Status::Error);
            let bad = c"%s%s%n".as_ptr();
            assert_eq!(fmu::fmi2SetDebugLogging(c, 1, 1, &bad), Fmi2Status::Error);
            fmu::fmi2FreeInstance(c);
        }
        assert_eq!(seen.env, env, "{}: componentEnvironment unchanged", table.id());
        assert_eq!(seen.calls.len(), 2, "{:?}", seen.calls);
        for (name, status, category, format, _) in &seen.calls {
            assert_eq!(
                (name.as_str(), *status, category.as_str(), format.as_str()),
                ("env%s%n", 3, "logStatusError", "%s")
            );
        }
        assert!(seen.calls[0].4.contains("illegal call sequence"), "{:?}", seen.calls[0]);
        assert!(seen.calls[1].4.contains("'%s%s%n'"), "{:?}", seen.calls[1]);
    }
}
