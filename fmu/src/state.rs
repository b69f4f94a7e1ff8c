//! The FMI 2.0 Co-Simulation state machine as bit flags, and for every
//! function the set of states it may be called in (as the Reference-FMUs do).

/// One state of the FMI 2.0 CS state machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum ModelState {
    /// Not instantiated (or freed).
    StartAndEnd = 1 << 0,
    /// After `fmi2Instantiate`.
    Instantiated = 1 << 1,
    /// Between `fmi2EnterInitializationMode` and `fmi2ExitInitializationMode`.
    InitializationMode = 1 << 2,
    /// Ready for `fmi2DoStep`.
    StepComplete = 1 << 3,
    /// An asynchronous step in progress (never: `fmi2DoStep` is synchronous).
    StepInProgress = 1 << 4,
    /// A step returned `fmi2Discard` (the filter failed at a known time).
    StepFailed = 1 << 5,
    /// A step was cancelled (never: cancelling is not supported).
    StepCanceled = 1 << 6,
    /// After `fmi2Terminate`, or after an `fmi2Error`.
    Terminated = 1 << 7,
}

impl ModelState {
    /// The state's name for messages.
    pub fn name(self) -> &'static str {
        match self {
            ModelState::StartAndEnd => "StartAndEnd",
            ModelState::Instantiated => "Instantiated",
            ModelState::InitializationMode => "InitializationMode",
            ModelState::StepComplete => "StepComplete",
            ModelState::StepInProgress => "StepInProgress",
            ModelState::StepFailed => "StepFailed",
            ModelState::StepCanceled => "StepCanceled",
            ModelState::Terminated => "Terminated",
        }
    }

    /// The state for a serialised tag, if it is one.
    pub fn from_tag(tag: u8) -> Option<Self> {
        use ModelState::*;
        [
            StartAndEnd,
            Instantiated,
            InitializationMode,
            StepComplete,
            StepInProgress,
            StepFailed,
            StepCanceled,
            Terminated,
        ]
        .into_iter()
        .find(|s| *s as u8 == tag)
    }
}

/// A set of states.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mask(u8);

impl Mask {
    /// Whether `state` is in the set.
    pub fn allows(self, state: ModelState) -> bool {
        self.0 & state as u8 != 0
    }
}

const fn mask(states: &[ModelState]) -> Mask {
    let mut bits = 0;
    let mut i = 0;
    while i < states.len() {
        bits |= states[i] as u8;
        i += 1;
    }
    Mask(bits)
}

use ModelState::*;

pub const ANY_INSTANCE: Mask =
    mask(&[Instantiated, InitializationMode, StepComplete, StepInProgress, StepFailed, StepCanceled, Terminated]);
pub const SET_DEBUG_LOGGING: Mask = ANY_INSTANCE;
pub const SETUP_EXPERIMENT: Mask = mask(&[Instantiated]);
pub const ENTER_INITIALIZATION_MODE: Mask = mask(&[Instantiated]);
pub const EXIT_INITIALIZATION_MODE: Mask = mask(&[InitializationMode]);
pub const TERMINATE: Mask = mask(&[StepComplete, StepFailed, StepCanceled]);
pub const RESET: Mask = mask(&[Instantiated, InitializationMode, StepComplete, StepFailed, StepCanceled, Terminated]);
pub const GET_VALUES: Mask = mask(&[InitializationMode, StepComplete, StepFailed, StepCanceled, Terminated]);
pub const SET_VALUES: Mask = mask(&[Instantiated, InitializationMode, StepComplete]);
pub const FMU_STATE: Mask = RESET;
pub const DO_STEP: Mask = mask(&[StepComplete]);
pub const CANCEL_STEP: Mask = mask(&[StepInProgress]);
pub const GET_STATUS: Mask = mask(&[StepComplete, StepInProgress, StepFailed, StepCanceled, Terminated]);
pub const DERIVATIVES: Mask = mask(&[Instantiated, InitializationMode, StepComplete]);
