//! The state table of FMI 3.0, Co-Simulation (standard, section 4.3) and Model Exchange
//! (section 3.3), as the FMI 3.0 front-end ([`capi::fmi3`](super::capi::fmi3)) checks it
//! before it calls the shared core (which checks no table of its own).
//!
//! FMI 3.0 differs from FMI 2.0 ([`machine`](super::machine)): Co-Simulation has Step Mode
//! instead of stepComplete/stepFailed, and an Event Mode of its own when the importer
//! instantiated with `eventModeUsed`; fmi3EnterInitializationMode takes the experiment
//! (there is no fmi3SetupExperiment). The FMI 3.0 state is derived from the core's
//! ([`State3::of`]): Step Mode is the core's stepping mode, also after a discarded step
//! (FMI 3.0 has no stepFailed: the instance is where lastSuccessfulTime says, and may step
//! on from there), and the one state the core has no mode for, Co-Simulation's Event Mode,
//! is a flag of the FMI 3.0 instance.

use super::machine::{Gate, Interface, Machine};

/// States of an FMI 3.0 instance (Configuration and Reconfiguration Mode and the Clock
/// states never occur: the models have no structural parameters and no clocks).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum State3 {
    Instantiated = 1 << 0,
    InitializationMode = 1 << 1,
    EventMode = 1 << 2,
    ContinuousTimeMode = 1 << 3,
    StepMode = 1 << 4,
    Terminated = 1 << 5,
    /// After a panic was caught (the core's error state): only reading, reset and free.
    Error = 1 << 6,
}

use State3::*;

const ALL: [State3; 7] = [
    Instantiated,
    InitializationMode,
    EventMode,
    ContinuousTimeMode,
    StepMode,
    Terminated,
    Error,
];

impl State3 {
    /// The FMI 3.0 state of an instance whose core is in `core`; `cs_event_mode`: a
    /// Co-Simulation instance in Event Mode.
    #[inline]
    pub fn of(core: Machine, cs_event_mode: bool) -> State3 {
        match core {
            Machine::Instantiated => Instantiated,
            Machine::InitializationMode => InitializationMode,
            Machine::StepComplete | Machine::StepFailed if cs_event_mode => EventMode,
            Machine::StepComplete | Machine::StepFailed => StepMode,
            Machine::EventMode => EventMode,
            Machine::ContinuousTimeMode => ContinuousTimeMode,
            Machine::Terminated => Terminated,
            Machine::Error => Error,
        }
    }

    #[inline]
    pub fn code(self) -> u32 {
        self as u32
    }
}

const fn mask(states: &[State3]) -> u32 {
    let mut m = 0;
    let mut i = 0;
    while i < states.len() {
        m |= states[i] as u32;
        i += 1;
    }
    m
}

pub const ANY: Gate = Gate::both(mask(&ALL));
pub const ENTER_INIT: Gate = Gate::both(mask(&[Instantiated]));
pub const EXIT_INIT: Gate = Gate::both(mask(&[InitializationMode]));
/// Model Exchange from Continuous-Time Mode; Co-Simulation (eventModeUsed) from Step Mode.
pub const ENTER_EVENT_MODE: Gate = Gate::both(mask(&[ContinuousTimeMode, StepMode]));
pub const TERMINATE: Gate = Gate::both(mask(&[EventMode, ContinuousTimeMode, StepMode]));
pub const GET: Gate = Gate::both(mask(&[
    InitializationMode,
    EventMode,
    ContinuousTimeMode,
    StepMode,
    Terminated,
    Error,
]));
pub const SET: Gate = Gate::both(mask(&[
    Instantiated,
    InitializationMode,
    EventMode,
    ContinuousTimeMode,
    StepMode,
]));
pub const FMU_STATE: Gate = ANY;
pub const DERIVATIVES: Gate = Gate::both(mask(&[
    InitializationMode,
    EventMode,
    ContinuousTimeMode,
    StepMode,
    Terminated,
]));
pub const UPDATE_DISCRETE_STATES: Gate = Gate::both(mask(&[EventMode]));
pub const EVALUATE_DISCRETE_STATES: Gate = Gate::both(mask(&[
    InitializationMode,
    EventMode,
    ContinuousTimeMode,
    StepMode,
]));
// Model Exchange.
pub const ENTER_CONTINUOUS_TIME_MODE: Gate = Gate::me(mask(&[EventMode]));
pub const COMPLETED_INTEGRATOR_STEP: Gate = Gate::me(mask(&[ContinuousTimeMode]));
pub const SET_TIME: Gate = Gate::me(mask(&[EventMode, ContinuousTimeMode]));
pub const SET_CONTINUOUS_STATES: Gate = Gate::me(mask(&[ContinuousTimeMode]));
pub const COUNTS: Gate = ANY;
/// fmi3GetContinuousStates, fmi3GetContinuousStateDerivatives, fmi3GetEventIndicators and
/// fmi3GetNominalsOfContinuousStates: FMI 3.0.2 section 2.3 allows them in Initialization
/// Mode, Event Mode, Continuous-Time Mode and Terminated (not in Instantiated; FMI 2.0's
/// table differs: no derivatives in Initialization Mode, nominals in Instantiated). Error
/// is FMI 3.0's Terminated after an fmi3Error (values for debugging).
pub const EVALUATE: Gate = Gate::me(mask(&[
    InitializationMode,
    EventMode,
    ContinuousTimeMode,
    Terminated,
    Error,
]));
// Co-Simulation.
pub const ENTER_STEP_MODE: Gate = Gate::cs(mask(&[EventMode]));
pub const DO_STEP: Gate = Gate::cs(mask(&[StepMode]));
pub const OUTPUT_DERIVATIVES: Gate = Gate::cs(mask(&[StepMode, Terminated, Error]));

/// Fails unless FMI 3.0's table lets a function behind `gate` run in `state` of an
/// instance made for `own`.
#[inline]
pub fn check(gate: Gate, state: State3, own: Interface) -> Result<(), String> {
    match gate.admits(state.code(), own) {
        true => Ok(()),
        false => Err(refusal(gate, state, own)),
    }
}

/// Why FMI 3.0's table refuses (see [`check`]).
#[cold]
#[inline(never)]
fn refusal(gate: Gate, state: State3, own: Interface) -> String {
    match gate.interface {
        Some(of) if of != own => format!(
            "a {} function; this instance was made by fmi3Instantiate{}",
            of.name(),
            match own {
                Interface::CoSimulation => "CoSimulation",
                Interface::ModelExchange => "ModelExchange",
            }
        ),
        _ => format!(
            "not allowed in state {state:?} (allowed in: {})",
            describe(gate.states)
        ),
    }
}

/// Names of the states a mask admits, for error messages.
pub fn describe(mask: u32) -> String {
    let names: Vec<String> = ALL
        .into_iter()
        .filter(|s| mask & s.code() != 0)
        .map(|s| format!("{s:?}"))
        .collect();
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}
