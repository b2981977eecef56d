//! The Co-Simulation state machine of FMI 2.0 (standard, section 4.2.4): which
//! function may be called in which state, checked in one place before any work.

/// States of a co-simulation slave. `StepInProgress` and `StepCanceled` never occur:
/// doStep is synchronous (canRunAsynchronuously = false).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Machine {
    Instantiated = 1 << 0,
    InitializationMode = 1 << 1,
    StepComplete = 1 << 2,
    StepFailed = 1 << 3,
    Terminated = 1 << 4,
    Error = 1 << 5,
}

impl Machine {
    pub fn code(self) -> u32 {
        self as u32
    }

    pub fn from_code(code: u32) -> Option<Machine> {
        ALL_STATES.into_iter().find(|m| m.code() == code)
    }
}

use Machine::*;

const ALL_STATES: [Machine; 6] = [
    Instantiated,
    InitializationMode,
    StepComplete,
    StepFailed,
    Terminated,
    Error,
];

const fn mask(states: &[Machine]) -> u32 {
    let mut m = 0;
    let mut i = 0;
    while i < states.len() {
        m |= states[i] as u32;
        i += 1;
    }
    m
}

pub const ANY: u32 = mask(&ALL_STATES);
pub const SETUP_EXPERIMENT: u32 = mask(&[Instantiated]);
pub const ENTER_INIT: u32 = mask(&[Instantiated]);
pub const EXIT_INIT: u32 = mask(&[InitializationMode]);
pub const TERMINATE: u32 = mask(&[StepComplete, StepFailed]);
pub const RESET: u32 = ANY;
pub const GET: u32 = mask(&[
    InitializationMode,
    StepComplete,
    StepFailed,
    Terminated,
    Error,
]);
pub const SET_REAL: u32 = mask(&[Instantiated, InitializationMode, StepComplete]);
pub const SET_INTEGER: u32 = mask(&[Instantiated, InitializationMode, StepComplete]);
pub const FMU_STATE: u32 = ANY;
pub const INPUT_DERIVATIVES: u32 = mask(&[Instantiated, InitializationMode, StepComplete]);
pub const OUTPUT_DERIVATIVES: u32 = mask(&[StepComplete, StepFailed, Terminated, Error]);
pub const DIRECTIONAL_DERIVATIVE: u32 = GET;
pub const DO_STEP: u32 = mask(&[StepComplete]);
pub const CANCEL_STEP: u32 = 0;
pub const STATUS: u32 = mask(&[StepComplete, StepFailed, Terminated]);
/// States in which fixed parameters and the start values of states may be set.
pub const BEFORE_INIT_DONE: u32 = mask(&[Instantiated, InitializationMode]);
/// Where a variable with initial = "approx" (a guess: the dependent states) may be set:
/// FMI 2.0 allows it only before fmi2EnterInitializationMode.
pub const BEFORE_INIT_MODE: u32 = mask(&[Instantiated]);

/// Names of the states a mask admits, for error messages.
pub fn describe(mask: u32) -> String {
    let names: Vec<String> = ALL_STATES
        .into_iter()
        .filter(|m| mask & m.code() != 0)
        .map(|m| format!("{m:?}"))
        .collect();
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}
