//! The core's modes, and FMI 2.0's state table, Co-Simulation (standard, section 4.2.4)
//! and Model Exchange (section 3.2.3): which function may be called in which state, as
//! data ([`Gate`]), checked by the guard of every C entry point before any work.
//!
//! One enum holds the states of both interfaces; an instance lives in those of its own
//! ([`Interface::states`]), so a mask may name states of both: a function shared by the two
//! interfaces (fmi2GetReal, fmi2GetFMUstate, …) has one mask, and its refusal lists only the
//! states of the caller's interface ([`describe`]).

/// States of an instance. `StepInProgress` and `StepCanceled` never occur: doStep is
/// synchronous (canRunAsynchronuously = false). `EventMode` and `ContinuousTimeMode` are
/// Model Exchange's, `StepComplete` and `StepFailed` Co-Simulation's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Machine {
    Instantiated = 1 << 0,
    InitializationMode = 1 << 1,
    StepComplete = 1 << 2,
    StepFailed = 1 << 3,
    Terminated = 1 << 4,
    Error = 1 << 5,
    EventMode = 1 << 6,
    ContinuousTimeMode = 1 << 7,
}

impl Machine {
    #[inline]
    pub fn code(self) -> u32 {
        self as u32
    }

    pub fn from_code(code: u32) -> Option<Machine> {
        ALL_STATES.into_iter().find(|m| m.code() == code)
    }
}

/// The interface an instance was made for (fmi2Type: fmi2ModelExchange = 0,
/// fmi2CoSimulation = 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interface {
    ModelExchange = 0,
    CoSimulation = 1,
}

impl Interface {
    pub fn code(self) -> u8 {
        self as u8
    }

    pub fn from_code(code: u8) -> Option<Interface> {
        [Interface::ModelExchange, Interface::CoSimulation]
            .into_iter()
            .find(|i| i.code() == code)
    }

    /// The states an instance of this interface can be in.
    pub const fn states(self) -> u32 {
        match self {
            Interface::CoSimulation => CS_STATES,
            Interface::ModelExchange => ME_STATES,
        }
    }

    /// As the standard names it (fmi2Type).
    pub fn name(self) -> &'static str {
        match self {
            Interface::ModelExchange => "Model Exchange",
            Interface::CoSimulation => "Co-Simulation",
        }
    }
}

use Machine::*;

const ALL_STATES: [Machine; 8] = [
    Instantiated,
    InitializationMode,
    StepComplete,
    StepFailed,
    Terminated,
    Error,
    EventMode,
    ContinuousTimeMode,
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

const CS_STATES: u32 = mask(&[
    Instantiated,
    InitializationMode,
    StepComplete,
    StepFailed,
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

/// Where a function may run: the states of its version's table that admit it (bits of
/// [`Machine`] here, of [`State3`](super::machine3::State3) in FMI 3.0's table), and the
/// interface it belongs to (`None`: both). Checked once per call, by the guard of every C
/// entry point, before the body runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Gate {
    pub states: u32,
    pub interface: Option<Interface>,
}

impl Gate {
    /// A function of both interfaces.
    pub const fn both(states: u32) -> Gate {
        Gate {
            states,
            interface: None,
        }
    }
    /// A Co-Simulation function.
    pub const fn cs(states: u32) -> Gate {
        Gate {
            states,
            interface: Some(Interface::CoSimulation),
        }
    }
    /// A Model Exchange function.
    pub const fn me(states: u32) -> Gate {
        Gate {
            states,
            interface: Some(Interface::ModelExchange),
        }
    }
}

// FMI 2.0's table (sections 3.2.3 and 4.2.4). Both interfaces:
pub const ANY: Gate = Gate::both(mask(&ALL_STATES));
pub const SETUP_EXPERIMENT: Gate = Gate::both(mask(&[Instantiated]));
pub const ENTER_INIT: Gate = Gate::both(mask(&[Instantiated]));
pub const EXIT_INIT: Gate = Gate::both(mask(&[InitializationMode]));
pub const TERMINATE: Gate = Gate::both(mask(&[
    StepComplete,
    StepFailed,
    EventMode,
    ContinuousTimeMode,
]));
pub const RESET: Gate = ANY;
pub const GET: Gate = Gate::both(mask(&[
    InitializationMode,
    StepComplete,
    StepFailed,
    EventMode,
    ContinuousTimeMode,
    Terminated,
    Error,
]));
/// fmi2SetReal: in Model Exchange's event and continuous-time modes only inputs may be
/// set (checked per variable, as after initialisation in Co-Simulation).
pub const SET_REAL: Gate = Gate::both(mask(&[
    Instantiated,
    InitializationMode,
    StepComplete,
    EventMode,
    ContinuousTimeMode,
]));
/// fmi2SetInteger: the Integer variables are fixed parameters; Model Exchange admits the
/// call in event mode (for tunable ones, which these models do not have).
pub const SET_INTEGER: Gate = Gate::both(mask(&[
    Instantiated,
    InitializationMode,
    StepComplete,
    EventMode,
]));
pub const FMU_STATE: Gate = ANY;
pub const DIRECTIONAL_DERIVATIVE: Gate = GET;

// Co-Simulation only.
pub const INPUT_DERIVATIVES: Gate =
    Gate::cs(mask(&[Instantiated, InitializationMode, StepComplete]));
pub const OUTPUT_DERIVATIVES: Gate = Gate::cs(mask(&[StepComplete, StepFailed, Terminated, Error]));
pub const DO_STEP: Gate = Gate::cs(mask(&[StepComplete]));
pub const CANCEL_STEP: Gate = Gate::cs(0);
pub const STATUS: Gate = Gate::cs(mask(&[StepComplete, StepFailed, Terminated]));

// Model Exchange only.
pub const ENTER_EVENT_MODE: Gate = Gate::me(mask(&[EventMode, ContinuousTimeMode]));
pub const NEW_DISCRETE_STATES: Gate = Gate::me(mask(&[EventMode]));
pub const ENTER_CONTINUOUS_TIME_MODE: Gate = Gate::me(mask(&[EventMode]));
pub const COMPLETED_INTEGRATOR_STEP: Gate = Gate::me(mask(&[ContinuousTimeMode]));
pub const SET_TIME: Gate = Gate::me(mask(&[EventMode, ContinuousTimeMode]));
pub const SET_CONTINUOUS_STATES: Gate = Gate::me(mask(&[ContinuousTimeMode]));
pub const GET_EVENT_INDICATORS: Gate = Gate::me(mask(&[
    InitializationMode,
    EventMode,
    ContinuousTimeMode,
    Terminated,
    Error,
]));
pub const GET_CONTINUOUS_STATES: Gate = GET_EVENT_INDICATORS;
pub const GET_DERIVATIVES: Gate =
    Gate::me(mask(&[EventMode, ContinuousTimeMode, Terminated, Error]));
pub const GET_NOMINALS: Gate = Gate::me(mask(&[
    Instantiated,
    EventMode,
    ContinuousTimeMode,
    Terminated,
    Error,
]));

/// States in which fixed parameters and the start values of states may be set (the core's
/// rule per variable, the same in every FMI version).
pub const BEFORE_INIT_DONE: u32 = mask(&[Instantiated, InitializationMode]);
/// Where a variable with initial = "approx" (a guess: the dependent states) may be set:
/// before initialisation mode.
pub const BEFORE_INIT_MODE: u32 = mask(&[Instantiated]);

impl Gate {
    /// Whether the gate lets a function run in state `code` of an instance made for `own`:
    /// the per-call check of every entry point, inlined into each (the refusal is cold).
    #[inline]
    pub fn admits(self, code: u32, own: Interface) -> bool {
        self.states & code != 0 && self.interface.is_none_or(|of| of == own)
    }
}

/// Fails unless FMI 2.0's table lets a function behind `gate` run in `state` of an
/// instance made for `own`.
#[inline]
pub fn check(gate: Gate, state: Machine, own: Interface) -> Result<(), String> {
    match gate.admits(state.code(), own) {
        true => Ok(()),
        false => Err(refusal(gate, state, own)),
    }
}

/// Why FMI 2.0's table refuses (see [`check`]).
#[cold]
#[inline(never)]
fn refusal(gate: Gate, state: Machine, own: Interface) -> String {
    match gate.interface {
        Some(of) if of != own => format!(
            "a {} function; this instance was made for {} (fmuType {} in fmi2Instantiate)",
            of.name(),
            own.name(),
            own.code()
        ),
        _ => format!(
            "not allowed in state {state:?} (allowed in: {})",
            describe(gate.states & own.states())
        ),
    }
}

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
