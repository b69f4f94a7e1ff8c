//! The FMUs' shared library: the 34 FMI 2.0 Co-Simulation functions as a thin
//! C-ABI shell around the estimation library (the estimator FMUs) and the truth
//! simulators (the plant FMUs).
//!
//! Every function runs through one guard ([`with_instance`]): NULL check,
//! the state mask of that function (an illegal call logs "illegal call
//! sequence" and returns `fmi2Error`, the instance stays as it was), and
//! `catch_unwind`, so no panic ever crosses the C ABI. Everything lives in the
//! instance; the only statics are read-only enumeration types.
//!
//! One binary serves every FMU: `fmi2Instantiate` binds the instance to the
//! estimator or plant whose GUID it is given (`catalogue.rs`).
//!
//! Safety: the exported functions are `unsafe extern "C"`: their contract is
//! the FMI 2.0 standard (valid pointers for the given lengths, a component
//! returned by `fmi2Instantiate` and not yet freed, one thread per instance at
//! a time). Within that contract nothing here is undefined: pointers are
//! checked for NULL, value references and lengths against the tables.
// The FFI needs unsafe; each block says why it is sound.
#![allow(unsafe_code)]
#![allow(clippy::missing_safety_doc)]
// The exported functions and C types are specified by the FMI 2.0 standard, not here.
#![allow(missing_docs)]

pub mod catalogue;
pub mod estimating;
pub mod estimators;
pub mod ffi;
pub mod input_timing_check;
pub mod instance;
pub mod model_description;
pub mod plants;
pub mod plausibility;
mod serialize;
pub mod simulating;
pub mod state;
pub mod timing;
pub mod variables;
mod wiring_cause;

use std::ffi::{c_char, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr;

use ffi::*;
use instance::Instance;
use state::{Mask, ModelState};
use variables::{Kind, Role};

/// Runs `f` on the instance behind `c` if `mask` allows its state; catches panics.
fn with_instance(
    c: Fmi2Component,
    function: &str,
    mask: Mask,
    f: impl FnOnce(&mut Instance) -> Fmi2Status,
) -> Fmi2Status {
    if c.is_null() {
        return Fmi2Status::Error;
    }
    let instance = c.cast::<Instance>();
    // SAFETY: `c` came from fmi2Instantiate and is not freed (FMI contract); the
    // importer calls an instance from one thread at a time, so this is the only reference.
    let allowed = unsafe { mask.allows((*instance).shell.state) };
    if !allowed {
        // SAFETY: as above.
        let inst = unsafe { &*instance };
        return inst
            .error(&format!("{function}: illegal call sequence (not allowed in state {})", inst.shell.state.name()));
    }
    // SAFETY: as above; the reference lives only inside the closure.
    let outcome = catch_unwind(AssertUnwindSafe(|| f(unsafe { &mut *instance })));
    match outcome {
        Ok(status) => status,
        Err(panic) => {
            let why = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            // SAFETY: the closure's reference ended with the unwinding.
            let inst = unsafe { &mut *instance };
            inst.shell.state = ModelState::Terminated;
            inst.error(&format!("{function}: internal error ({why}); the instance is terminated, reset or free it"))
        }
    }
}

/// A slice from a C array; `None` for NULL with a non-zero length.
///
/// SAFETY (for callers): `p` must point to `n` valid elements when non-NULL.
unsafe fn slice<'a, T>(p: *const T, n: usize) -> Option<&'a [T]> {
    if n == 0 {
        Some(&[])
    } else if p.is_null() {
        None
    } else {
        // SAFETY: the caller guarantees `n` valid elements.
        Some(unsafe { std::slice::from_raw_parts(p, n) })
    }
}

/// A mutable slice from a C array; `None` for NULL with a non-zero length.
unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> Option<&'a mut [T]> {
    if n == 0 {
        Some(&mut [])
    } else if p.is_null() {
        None
    } else {
        // SAFETY: the caller guarantees `n` valid, exclusively borrowed elements.
        Some(unsafe { std::slice::from_raw_parts_mut(p, n) })
    }
}

/// A C string, if not NULL and valid UTF-8.
unsafe fn string<'a>(p: *const c_char) -> Option<&'a str> {
    if p.is_null() {
        None
    } else {
        // SAFETY: FMI strings are NUL-terminated.
        unsafe { CStr::from_ptr(p) }.to_str().ok()
    }
}

fn kind_name(kind: Kind) -> &'static str {
    match kind {
        Kind::Real => "Real",
        Kind::Integer => "Integer",
        Kind::Boolean => "Boolean",
        Kind::Enumeration(_) => "Enumeration",
    }
}

// ----- inquiry -----

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

// ----- creation and destruction -----

/// Logs through the importer's callbacks before an instance exists.
unsafe fn log_early(functions: &Fmi2CallbackFunctions, name: *const c_char, message: &str) {
    if let Some(logger) = functions.logger {
        let message = CString::new(message.replace('\0', " ")).unwrap_or_default();
        let name = if name.is_null() { c"".as_ptr() } else { name };
        // SAFETY: the importer's logger with NUL-terminated strings; "%s" takes one argument.
        unsafe {
            logger(
                functions.component_environment,
                name,
                Fmi2Status::Error as i32,
                c"logStatusError".as_ptr(),
                c"%s".as_ptr(),
                message.as_ptr(),
            )
        };
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: Fmi2String,
    fmu_type: Fmi2Type,
    guid: Fmi2String,
    resource_location: Fmi2String,
    functions: *const Fmi2CallbackFunctions,
    _visible: Fmi2Boolean,
    logging_on: Fmi2Boolean,
) -> Fmi2Component {
    let created = catch_unwind(|| {
        if functions.is_null() {
            return ptr::null_mut();
        }
        // SAFETY: non-NULL, and the importer's struct outlives the call.
        let functions = unsafe { *functions };
        if functions.logger.is_none() {
            return ptr::null_mut();
        }
        // SAFETY: FMI strings are NUL-terminated or NULL.
        let name = match unsafe { string(instance_name) } {
            Some(n) if !n.is_empty() => n,
            _ => {
                unsafe {
                    log_early(&functions, instance_name, "fmi2Instantiate: the instance name is missing or empty")
                };
                return ptr::null_mut();
            }
        };
        if fmu_type != FMI2_COSIMULATION {
            let what =
                if fmu_type == FMI2_MODEL_EXCHANGE { "Model Exchange".to_string() } else { format!("type {fmu_type}") };
            let message = format!("fmi2Instantiate: this FMU supports Co-Simulation only, not {what}");
            unsafe { log_early(&functions, instance_name, &message) };
            return ptr::null_mut();
        }
        let Some(fmu) = unsafe { string(guid) }.and_then(catalogue::by_guid) else {
            let known: Vec<String> = catalogue::all()
                .iter()
                .map(|f| format!("{} {}", f.description().model_identifier(), f.description().guid()))
                .collect();
            let message = format!(
                "fmi2Instantiate: GUID {} is not one of this binary's FMUs ({})",
                unsafe { string(guid) }.unwrap_or("(none)"),
                known.join(", ")
            );
            unsafe { log_early(&functions, instance_name, &message) };
            return ptr::null_mut();
        };
        let instance = Instance::new(
            fmu,
            CString::new(name).unwrap_or_default(),
            functions.component_environment,
            functions.logger,
            logging_on != FMI2_FALSE,
        );
        // The FMU needs no resources; a location that is not a URI is still worth a note.
        match unsafe { string(resource_location) } {
            Some(uri) if !uri.is_empty() && !uri.contains(':') => instance.log(
                Fmi2Status::Warning,
                "logStatusWarning",
                &format!("fmi2Instantiate: resource location '{uri}' is not a URI (unused by this FMU)"),
            ),
            _ => {}
        }
        Box::into_raw(Box::new(instance)).cast()
    });
    created.unwrap_or(ptr::null_mut())
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
    if c.is_null() {
        return;
    }
    // SAFETY: `c` came from Box::into_raw in fmi2Instantiate and is freed once (FMI contract).
    let instance = unsafe { Box::from_raw(c.cast::<Instance>()) };
    let _ = catch_unwind(AssertUnwindSafe(move || drop(instance)));
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: Fmi2Component,
    logging_on: Fmi2Boolean,
    n_categories: usize,
    categories: *const Fmi2String,
) -> Fmi2Status {
    with_instance(c, "fmi2SetDebugLogging", state::SET_DEBUG_LOGGING, |inst| {
        // SAFETY: `categories` holds `n_categories` strings (FMI contract).
        let Some(list) = (unsafe { slice(categories, n_categories) }) else {
            return inst.error("fmi2SetDebugLogging: categories is NULL but nCategories > 0");
        };
        let mut names = Vec::with_capacity(list.len());
        for &p in list {
            // SAFETY: each entry is a NUL-terminated string or NULL.
            match unsafe { string(p) } {
                Some(s) => names.push(s),
                None => return inst.error("fmi2SetDebugLogging: a category is NULL or not UTF-8"),
            }
        }
        inst.set_debug_logging(logging_on != FMI2_FALSE, &names)
    })
}

// ----- initialisation, termination, reset -----

#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: Fmi2Component,
    _tolerance_defined: Fmi2Boolean,
    _tolerance: Fmi2Real,
    start_time: Fmi2Real,
    stop_time_defined: Fmi2Boolean,
    stop_time: Fmi2Real,
) -> Fmi2Status {
    with_instance(c, "fmi2SetupExperiment", state::SETUP_EXPERIMENT, |inst| {
        inst.setup_experiment(start_time, (stop_time_defined != FMI2_FALSE).then_some(stop_time))
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2EnterInitializationMode", state::ENTER_INITIALIZATION_MODE, |inst| {
        inst.enter_initialization();
        Fmi2Status::Ok
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2ExitInitializationMode", state::EXIT_INITIALIZATION_MODE, |inst| inst.exit_initialization())
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2Terminate", state::TERMINATE, |inst| {
        inst.terminate();
        Fmi2Status::Ok
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2Reset", state::RESET, |inst| {
        inst.reset();
        inst.log(Fmi2Status::Ok, "logEvents", "reset to the instantiated state");
        Fmi2Status::Ok
    })
}

// ----- values -----

/// Shared body of the four getters: checks arrays, references and types.
unsafe fn get_values<T>(
    c: Fmi2Component,
    function: &str,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut T,
    accepts: fn(Kind) -> bool,
    convert: fn(f64) -> T,
) -> Fmi2Status {
    with_instance(c, function, state::GET_VALUES, |inst| {
        // SAFETY: `vr` and `value` hold `nvr` elements (FMI contract).
        let (Some(vrs), Some(out)) = (unsafe { slice(vr, nvr) }, unsafe { slice_mut(value, nvr) }) else {
            return inst.error(&format!("{function}: vr or value is NULL but nvr = {nvr}"));
        };
        inst.refresh_outputs();
        for (slot, &r) in out.iter_mut().zip(vrs) {
            let Some(var) = inst.variables().get(r as usize) else {
                return inst.error(&format!("{function}: {}", inst.unknown(r)));
            };
            if !accepts(var.kind) {
                return inst.error(&format!("{function}: variable {} (vr {r}) is {}", var.name, kind_name(var.kind)));
            }
            *slot = convert(inst.shell.values[r as usize]);
        }
        Fmi2Status::Ok
    })
}

/// Shared body of the setters: checks everything first, then applies all or nothing.
unsafe fn set_values<T: Copy>(
    c: Fmi2Component,
    function: &str,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const T,
    accepts: fn(Kind) -> bool,
    convert: fn(T) -> f64,
) -> Fmi2Status {
    with_instance(c, function, state::SET_VALUES, |inst| {
        // SAFETY: `vr` and `value` hold `nvr` elements (FMI contract).
        let (Some(vrs), Some(values)) = (unsafe { slice(vr, nvr) }, unsafe { slice(value, nvr) }) else {
            return inst.error(&format!("{function}: vr or value is NULL but nvr = {nvr}"));
        };
        let mut updates = Vec::with_capacity(nvr);
        for (&r, &v) in vrs.iter().zip(values) {
            let index = match inst.check_settable(r) {
                Ok(i) => i,
                Err(why) => return inst.error(&format!("{function}: {why}")),
            };
            let var = &inst.variables()[index];
            if !accepts(var.kind) {
                return inst.error(&format!("{function}: variable {} (vr {r}) is {}", var.name, kind_name(var.kind)));
            }
            let x = convert(v);
            if let Kind::Enumeration(t) = var.kind {
                if !t.items.iter().any(|(value, _, _)| f64::from(*value) == x) {
                    return inst
                        .error(&format!("{function}: {x} is not a value of {} (variable {})", t.name, var.name));
                }
            }
            // NaN is outside every bound.
            let below = var.min.is_some_and(|m| x < m || x.is_nan());
            let above = var.max.is_some_and(|m| x > m || x.is_nan());
            if below || above {
                return inst.error(&format!(
                    "{function}: {x} is outside [{}, {}] for variable {}",
                    var.min.map_or("-inf".into(), |m| m.to_string()),
                    var.max.map_or("inf".into(), |m| m.to_string()),
                    var.name
                ));
            }
            // A control is never missing (timing.rs, rule 7): the filter cannot predict
            // without it; nor can a plant step without its inputs.
            if matches!(var.role, Role::Control(_) | Role::PlantInput(_)) && !x.is_finite() {
                return inst.error(&format!(
                    "{function}: input {} (vr {r}) must be finite, got {x}; it drives the model and cannot be missing, the values are unchanged",
                    var.name
                ));
            }
            updates.push((index, x));
        }
        let status = inst.set_values(&updates);
        if status == Fmi2Status::Ok && inst.shell.state == ModelState::InitializationMode {
            inst.mark_initial_outputs_stale();
        }
        status
    })
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

#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    unsafe { get_values(c, "fmi2GetReal", vr, nvr, value, real_kind, |x| x) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    unsafe { get_values(c, "fmi2GetInteger", vr, nvr, value, integer_kind, |x| x as Fmi2Integer) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    unsafe { get_values(c, "fmi2GetBoolean", vr, nvr, value, boolean_kind, |x| Fmi2Boolean::from(x != 0.0)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2String,
) -> Fmi2Status {
    unsafe { get_values(c, "fmi2GetString", vr, nvr, value, no_kind, |_| ptr::null()) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Real,
) -> Fmi2Status {
    unsafe { set_values(c, "fmi2SetReal", vr, nvr, value, real_kind, |x| x) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Integer,
) -> Fmi2Status {
    unsafe { set_values(c, "fmi2SetInteger", vr, nvr, value, integer_kind, f64::from) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Boolean,
) -> Fmi2Status {
    unsafe {
        set_values(c, "fmi2SetBoolean", vr, nvr, value, boolean_kind, |b| if b != FMI2_FALSE { 1.0 } else { 0.0 })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2String,
) -> Fmi2Status {
    unsafe { set_values(c, "fmi2SetString", vr, nvr, value, no_kind, |_| f64::NAN) }
}

// ----- FMU state -----

/// The opaque `fmi2FMUstate`: the serialised bytes.
struct SavedState(Vec<u8>);

#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: Fmi2Component, fmu_state: *mut Fmi2FmuState) -> Fmi2Status {
    with_instance(c, "fmi2GetFMUstate", state::FMU_STATE, |inst| {
        if fmu_state.is_null() {
            return inst.error("fmi2GetFMUstate: FMUstate is NULL");
        }
        let bytes = serialize::save(inst);
        // SAFETY: `fmu_state` is a valid pointer (checked non-NULL); a non-NULL
        // `*fmu_state` is a state this library returned before (FMI contract).
        unsafe {
            let existing = (*fmu_state).cast::<SavedState>();
            if existing.is_null() {
                *fmu_state = Box::into_raw(Box::new(SavedState(bytes))).cast();
            } else {
                (*existing).0 = bytes;
            }
        }
        inst.log(Fmi2Status::Ok, "logEvents", &format!("FMU state saved at t = {}", inst.shell.time));
        Fmi2Status::Ok
    })
}

/// Restores a state's bytes into the instance, or says why not.
fn restore(inst: &mut Instance, bytes: &[u8], function: &str) -> Fmi2Status {
    match serialize::parse(bytes, inst).and_then(|saved| serialize::apply(inst, saved)) {
        Ok(()) => {
            inst.log(Fmi2Status::Ok, "logEvents", &format!("FMU state restored at t = {}", inst.shell.time));
            Fmi2Status::Ok
        }
        Err(why) => inst.error(&format!("{function}: {why}; the instance is unchanged")),
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Fmi2Component, fmu_state: Fmi2FmuState) -> Fmi2Status {
    with_instance(c, "fmi2SetFMUstate", state::FMU_STATE, |inst| {
        if fmu_state.is_null() {
            return inst.error("fmi2SetFMUstate: FMUstate is NULL");
        }
        // SAFETY: a state this library returned and that is not freed (FMI contract).
        let bytes = unsafe { (*fmu_state.cast::<SavedState>()).0.clone() };
        restore(inst, &bytes, "fmi2SetFMUstate")
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: Fmi2Component, fmu_state: *mut Fmi2FmuState) -> Fmi2Status {
    with_instance(c, "fmi2FreeFMUstate", state::FMU_STATE, |_| {
        if !fmu_state.is_null() {
            // SAFETY: a non-NULL `*fmu_state` is a Box this library made (FMI contract);
            // it is set to NULL so it cannot be freed twice through this pointer.
            unsafe {
                let saved = (*fmu_state).cast::<SavedState>();
                if !saved.is_null() {
                    drop(Box::from_raw(saved));
                    *fmu_state = ptr::null_mut();
                }
            }
        }
        Fmi2Status::Ok
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: Fmi2Component,
    fmu_state: Fmi2FmuState,
    size: *mut usize,
) -> Fmi2Status {
    with_instance(c, "fmi2SerializedFMUstateSize", state::FMU_STATE, |inst| {
        if fmu_state.is_null() || size.is_null() {
            return inst.error("fmi2SerializedFMUstateSize: FMUstate or size is NULL");
        }
        // SAFETY: both pointers are valid (checked non-NULL, FMI contract).
        unsafe { *size = (*fmu_state.cast::<SavedState>()).0.len() };
        Fmi2Status::Ok
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: Fmi2Component,
    fmu_state: Fmi2FmuState,
    serialized: *mut Fmi2Byte,
    size: usize,
) -> Fmi2Status {
    with_instance(c, "fmi2SerializeFMUstate", state::FMU_STATE, |inst| {
        if fmu_state.is_null() || serialized.is_null() {
            return inst.error("fmi2SerializeFMUstate: FMUstate or serializedState is NULL");
        }
        // SAFETY: a state this library made; `serialized` has `size` bytes (FMI contract).
        unsafe {
            let bytes = &(*fmu_state.cast::<SavedState>()).0;
            if size != bytes.len() {
                return inst.error(&format!(
                    "fmi2SerializeFMUstate: size is {size}, the state needs {} (fmi2SerializedFMUstateSize)",
                    bytes.len()
                ));
            }
            ptr::copy_nonoverlapping(bytes.as_ptr(), serialized.cast::<u8>(), size);
        }
        Fmi2Status::Ok
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: Fmi2Component,
    serialized: *const Fmi2Byte,
    size: usize,
    fmu_state: *mut Fmi2FmuState,
) -> Fmi2Status {
    with_instance(c, "fmi2DeSerializeFMUstate", state::FMU_STATE, |inst| {
        if fmu_state.is_null() {
            return inst.error("fmi2DeSerializeFMUstate: FMUstate is NULL");
        }
        // SAFETY: `serialized` has `size` bytes (FMI contract).
        let Some(bytes) = (unsafe { slice(serialized.cast::<u8>(), size) }) else {
            return inst.error("fmi2DeSerializeFMUstate: serializedState is NULL");
        };
        if let Err(why) = serialize::parse(bytes, inst) {
            return inst.error(&format!("fmi2DeSerializeFMUstate: {why}"));
        }
        // SAFETY: `fmu_state` is valid (checked); a non-NULL `*fmu_state` is ours.
        unsafe {
            let existing = (*fmu_state).cast::<SavedState>();
            if existing.is_null() {
                *fmu_state = Box::into_raw(Box::new(SavedState(bytes.to_vec()))).cast();
            } else {
                (*existing).0 = bytes.to_vec();
            }
        }
        Fmi2Status::Ok
    })
}

// ----- derivatives (not supported) -----

#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: Fmi2Component,
    _unknown: *const Fmi2ValueReference,
    _n_unknown: usize,
    _known: *const Fmi2ValueReference,
    _n_known: usize,
    _dv_known: *const Fmi2Real,
    _dv_unknown: *mut Fmi2Real,
) -> Fmi2Status {
    with_instance(c, "fmi2GetDirectionalDerivative", state::ANY_INSTANCE, |inst| {
        inst.error("fmi2GetDirectionalDerivative is not supported (providesDirectionalDerivative = false)")
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const Fmi2Integer,
    _value: *const Fmi2Real,
) -> Fmi2Status {
    with_instance(c, "fmi2SetRealInputDerivatives", state::ANY_INSTANCE, |inst| {
        inst.error("fmi2SetRealInputDerivatives is not supported (canInterpolateInputs = false)")
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const Fmi2Integer,
    _value: *mut Fmi2Real,
) -> Fmi2Status {
    with_instance(c, "fmi2GetRealOutputDerivatives", state::ANY_INSTANCE, |inst| {
        inst.error("fmi2GetRealOutputDerivatives is not supported (maxOutputDerivativeOrder = 0)")
    })
}

// ----- stepping -----

#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: Fmi2Component,
    current_communication_point: Fmi2Real,
    communication_step_size: Fmi2Real,
    _no_set_fmu_state_prior_to_current_point: Fmi2Boolean,
) -> Fmi2Status {
    with_instance(c, "fmi2DoStep", state::DO_STEP, |inst| {
        inst.do_step(current_communication_point, communication_step_size)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: Fmi2Component) -> Fmi2Status {
    with_instance(c, "fmi2CancelStep", state::ANY_INSTANCE, |inst| {
        inst.error("fmi2CancelStep is not supported: fmi2DoStep is synchronous and never pending")
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(c: Fmi2Component, kind: Fmi2StatusKind, _value: *mut Fmi2Status) -> Fmi2Status {
    with_instance(c, "fmi2GetStatus", state::GET_STATUS, |inst| {
        inst.error(&format!("fmi2GetStatus: status kind {kind} is not provided (fmi2DoStep never returns fmi2Pending)"))
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(c: Fmi2Component, kind: Fmi2StatusKind, value: *mut Fmi2Real) -> Fmi2Status {
    with_instance(c, "fmi2GetRealStatus", state::GET_STATUS, |inst| {
        if kind != FMI2_LAST_SUCCESSFUL_TIME {
            return inst.error(&format!("fmi2GetRealStatus: status kind {kind} is not fmi2LastSuccessfulTime"));
        }
        if value.is_null() {
            return inst.error("fmi2GetRealStatus: value is NULL");
        }
        // SAFETY: valid (checked non-NULL, FMI contract).
        unsafe { *value = inst.shell.last_successful_time };
        Fmi2Status::Ok
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    _value: *mut Fmi2Integer,
) -> Fmi2Status {
    with_instance(c, "fmi2GetIntegerStatus", state::GET_STATUS, |inst| {
        inst.error(&format!("fmi2GetIntegerStatus: status kind {kind} is not provided"))
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    with_instance(c, "fmi2GetBooleanStatus", state::GET_STATUS, |inst| {
        if kind != FMI2_TERMINATED {
            return inst.error(&format!("fmi2GetBooleanStatus: status kind {kind} is not fmi2Terminated"));
        }
        if value.is_null() {
            return inst.error("fmi2GetBooleanStatus: value is NULL");
        }
        // After a filter failure the slave cannot go on: it asks to terminate.
        // SAFETY: valid (checked non-NULL, FMI contract).
        unsafe { *value = Fmi2Boolean::from(inst.asks_to_terminate()) };
        Fmi2Status::Ok
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    _value: *mut Fmi2String,
) -> Fmi2Status {
    with_instance(c, "fmi2GetStringStatus", state::GET_STATUS, |inst| {
        inst.error(&format!("fmi2GetStringStatus: status kind {kind} is not provided (nothing is ever pending)"))
    })
}
