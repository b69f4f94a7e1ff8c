//! The FMI 2.0 C types this library exports and receives, written by hand
//! from `fmi2TypesPlatform.h` and `fmi2FunctionTypes.h` (the `fmi-sys`
//! bindings would pull bindgen and a stray C logger into the shipped binary).

use std::ffi::{c_char, c_int, c_uint, c_void};

pub type Fmi2Component = *mut c_void;
pub type Fmi2ComponentEnvironment = *mut c_void;
pub type Fmi2FmuState = *mut c_void;
pub type Fmi2ValueReference = c_uint;
pub type Fmi2Real = f64;
pub type Fmi2Integer = c_int;
pub type Fmi2Boolean = c_int;
pub type Fmi2String = *const c_char;
pub type Fmi2Byte = c_char;

pub const FMI2_TRUE: Fmi2Boolean = 1;
pub const FMI2_FALSE: Fmi2Boolean = 0;

/// `fmi2Status`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Fmi2Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
    Pending = 5,
}

/// `fmi2Type` (as the C int the importer passes; any value can arrive).
pub type Fmi2Type = c_int;
pub const FMI2_MODEL_EXCHANGE: Fmi2Type = 0;
pub const FMI2_COSIMULATION: Fmi2Type = 1;

/// `fmi2StatusKind` (as a C int).
pub type Fmi2StatusKind = c_int;
pub const FMI2_DO_STEP_STATUS: Fmi2StatusKind = 0;
pub const FMI2_PENDING_STATUS: Fmi2StatusKind = 1;
pub const FMI2_LAST_SUCCESSFUL_TIME: Fmi2StatusKind = 2;
pub const FMI2_TERMINATED: Fmi2StatusKind = 3;

/// `fmi2CallbackLogger`: variadic; we always call it with the format `"%s"`.
pub type Fmi2CallbackLogger = Option<
    unsafe extern "C" fn(
        env: Fmi2ComponentEnvironment,
        instance_name: Fmi2String,
        status: c_int,
        category: Fmi2String,
        message: Fmi2String,
        ...
    ),
>;
pub type Fmi2CallbackAllocateMemory = Option<unsafe extern "C" fn(n: usize, size: usize) -> *mut c_void>;
pub type Fmi2CallbackFreeMemory = Option<unsafe extern "C" fn(obj: *mut c_void)>;
pub type Fmi2StepFinished = Option<unsafe extern "C" fn(env: Fmi2ComponentEnvironment, status: c_int)>;

/// `fmi2CallbackFunctions`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct Fmi2CallbackFunctions {
    pub logger: Fmi2CallbackLogger,
    pub allocate_memory: Fmi2CallbackAllocateMemory,
    pub free_memory: Fmi2CallbackFreeMemory,
    pub step_finished: Fmi2StepFinished,
    pub component_environment: Fmi2ComponentEnvironment,
}
