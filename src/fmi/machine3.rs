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

use super::machine::{gates, Gate, Interface, Machine};

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

const CS_STATES: u32 = mask(&[
    Instantiated,
    InitializationMode,
    EventMode,
    StepMode,
    Terminated,
    Error,
]);
const ME_STATES: u32 = mask(&[
    Instantiated,
    InitializationMode,
    EventMode,
    ContinuousTimeMode,
    Terminated,
    Error,
]);

const fn both(states: u32) -> Gate {
    Gate::both(states)
}
const fn cs(states: u32) -> Gate {
    Gate::only(Interface::CoSimulation, states, ME_STATES)
}
const fn me(states: u32) -> Gate {
    Gate::only(Interface::ModelExchange, states, CS_STATES)
}

#[rustfmt::skip]
gates! {
    ANY = both[
        Instantiated, InitializationMode, EventMode, ContinuousTimeMode, StepMode, Terminated,
        Error,
    ];
    ENTER_INIT = both[Instantiated];
    EXIT_INIT = both[InitializationMode];
    /// Model Exchange from Continuous-Time Mode; Co-Simulation (eventModeUsed) from Step
    /// Mode.
    ENTER_EVENT_MODE = both[ContinuousTimeMode, StepMode];
    TERMINATE = both[EventMode, ContinuousTimeMode, StepMode];
    GET = both[
        InitializationMode, EventMode, ContinuousTimeMode, StepMode, Terminated, Error,
    ];
    SET = both[Instantiated, InitializationMode, EventMode, ContinuousTimeMode, StepMode];
    DERIVATIVES = both[InitializationMode, EventMode, ContinuousTimeMode, StepMode, Terminated];
    UPDATE_DISCRETE_STATES = both[EventMode];
    EVALUATE_DISCRETE_STATES = both[InitializationMode, EventMode, ContinuousTimeMode, StepMode];
    // Model Exchange.
    ENTER_CONTINUOUS_TIME_MODE = me[EventMode];
    COMPLETED_INTEGRATOR_STEP = me[ContinuousTimeMode];
    SET_TIME = me[EventMode, ContinuousTimeMode];
    SET_CONTINUOUS_STATES = me[ContinuousTimeMode];
    /// fmi3GetContinuousStates, fmi3GetContinuousStateDerivatives, fmi3GetEventIndicators
    /// and fmi3GetNominalsOfContinuousStates: FMI 3.0.2 section 2.3 allows them in
    /// Initialization Mode, Event Mode, Continuous-Time Mode and Terminated (not in
    /// Instantiated; FMI 2.0's table differs: no derivatives in Initialization Mode,
    /// nominals in Instantiated). Error is FMI 3.0's Terminated after an fmi3Error (values
    /// for debugging).
    EVALUATE = me[InitializationMode, EventMode, ContinuousTimeMode, Terminated, Error];
    // Co-Simulation.
    ENTER_STEP_MODE = cs[EventMode];
    DO_STEP = cs[StepMode];
    OUTPUT_DERIVATIVES = cs[StepMode, Terminated, Error];
}
pub const FMU_STATE: Gate = ANY;
pub const COUNTS: Gate = ANY;

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
