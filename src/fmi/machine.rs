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
    /// Whether an instance of the other interface can be in one of `states` (else the
    /// states alone settle the interface, and [`Gate::admits`] does not test it).
    test_interface: bool,
}

impl Gate {
    /// A function of both interfaces.
    pub const fn both(states: u32) -> Gate {
        Gate {
            states,
            interface: None,
            test_interface: false,
        }
    }

    /// A function of `interface` alone, whose other interface's instances can be in
    /// `other_states`.
    pub const fn only(interface: Interface, states: u32, other_states: u32) -> Gate {
        Gate {
            states,
            interface: Some(interface),
            test_interface: states & other_states != 0,
        }
    }

    /// Whether the gate lets a function run in state `code` of an instance made for `own`:
    /// the per-call check of every entry point, inlined into each (the refusal is cold).
    #[inline]
    pub fn admits(self, code: u32, own: Interface) -> bool {
        self.states & code != 0 && (!self.test_interface || self.interface == Some(own))
    }
}

/// A state table as rows `NAME = interface[states];`, `interface` one of `both`, `cs`,
/// `me` (the table's own constructors, in scope where it is written).
macro_rules! gates {
    ($($(#[$doc:meta])* $name:ident = $interface:ident[$($state:ident),* $(,)?];)*) => {
        $($(#[$doc])* pub const $name: Gate = $interface(mask(&[$($state),*]));)*
    };
}
pub(crate) use gates;

const fn both(states: u32) -> Gate {
    Gate::both(states)
}
const fn cs(states: u32) -> Gate {
    Gate::only(Interface::CoSimulation, states, ME_STATES)
}
const fn me(states: u32) -> Gate {
    Gate::only(Interface::ModelExchange, states, CS_STATES)
}

// FMI 2.0's table (sections 3.2.3 and 4.2.4).
#[rustfmt::skip]
gates! {
    ANY = both[
        Instantiated, InitializationMode, StepComplete, StepFailed, Terminated, Error,
        EventMode, ContinuousTimeMode,
    ];
    SETUP_EXPERIMENT = both[Instantiated];
    ENTER_INIT = both[Instantiated];
    EXIT_INIT = both[InitializationMode];
    TERMINATE = both[StepComplete, StepFailed, EventMode, ContinuousTimeMode];
    GET = both[
        InitializationMode, StepComplete, StepFailed, EventMode, ContinuousTimeMode,
        Terminated, Error,
    ];
    /// fmi2SetReal: in Model Exchange's event and continuous-time modes only inputs may be
    /// set (checked per variable, as after initialisation in Co-Simulation).
    SET_REAL = both[
        Instantiated, InitializationMode, StepComplete, EventMode, ContinuousTimeMode,
    ];
    /// fmi2SetInteger: the Integer variables are fixed parameters; Model Exchange admits
    /// the call in event mode (for tunable ones, which these models do not have).
    SET_INTEGER = both[Instantiated, InitializationMode, StepComplete, EventMode];
    // Co-Simulation only.
    INPUT_DERIVATIVES = cs[Instantiated, InitializationMode, StepComplete];
    OUTPUT_DERIVATIVES = cs[StepComplete, StepFailed, Terminated, Error];
    DO_STEP = cs[StepComplete];
    CANCEL_STEP = cs[];
    STATUS = cs[StepComplete, StepFailed, Terminated];
    // Model Exchange only.
    ENTER_EVENT_MODE = me[EventMode, ContinuousTimeMode];
    NEW_DISCRETE_STATES = me[EventMode];
    ENTER_CONTINUOUS_TIME_MODE = me[EventMode];
    COMPLETED_INTEGRATOR_STEP = me[ContinuousTimeMode];
    SET_TIME = me[EventMode, ContinuousTimeMode];
    SET_CONTINUOUS_STATES = me[ContinuousTimeMode];
    GET_EVENT_INDICATORS = me[
        InitializationMode, EventMode, ContinuousTimeMode, Terminated, Error,
    ];
    GET_DERIVATIVES = me[EventMode, ContinuousTimeMode, Terminated, Error];
    GET_NOMINALS = me[Instantiated, EventMode, ContinuousTimeMode, Terminated, Error];
}
pub const RESET: Gate = ANY;
pub const FMU_STATE: Gate = ANY;
pub const DIRECTIONAL_DERIVATIVE: Gate = GET;
pub const GET_CONTINUOUS_STATES: Gate = GET_EVENT_INDICATORS;

/// States in which fixed parameters and the start values of states may be set (the core's
/// rule per variable, the same in every FMI version).
pub const BEFORE_INIT_DONE: u32 = mask(&[Instantiated, InitializationMode]);
/// Where a variable with initial = "approx" (a guess: the dependent states) may be set:
/// before initialisation mode.
pub const BEFORE_INIT_MODE: u32 = mask(&[Instantiated]);

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
