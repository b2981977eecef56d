//! The core's modes: where an instance is in its life, in no FMI version's words.
//!
//! Each front-end reads them as its own version's states (`fmi2::State2::of`,
//! `fmi3::State3::of`) and checks its own table; the core checks none.

/// What a set of states declared with [`states!`] has: its states as bits of a `u32`, and
/// which of them an instance of each interface can be in.
pub trait States: Copy + std::fmt::Debug + 'static {
    /// Every state, in declaration order.
    const ALL: &'static [Self];
    /// The states of a Co-Simulation instance, and of a Model Exchange one.
    const CS: u32;
    const ME: u32;
    fn code(self) -> u32;
}

/// Declares a set of states: the enum and its [`States`], each state the bit of its place
/// (the first 1 << 0), and of both interfaces unless marked `[cs]` or `[me]`. The core's
/// modes below, and each FMI version's table states.
macro_rules! states {
    (@in cs) => { true };
    (@in me) => { true };
    (@in cs cs) => { true };
    (@in me me) => { true };
    (@in cs me) => { false };
    (@in me cs) => { false };
    ($(#[$m:meta])* pub enum $name:ident {
        $($(#[$vm:meta])* $v:ident $([$only:ident])?,)*
    }) => {
        $(#[$m])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum $name {
            $($(#[$vm])* $v,)*
        }

        impl $crate::fmi::core::mode::States for $name {
            const ALL: &'static [$name] = &[$($name::$v),*];
            const CS: u32 = 0 $(| ($crate::fmi::core::mode::states!(@in cs $($only)?) as u32)
                << $name::$v as u32)*;
            const ME: u32 = 0 $(| ($crate::fmi::core::mode::states!(@in me $($only)?) as u32)
                << $name::$v as u32)*;
            #[inline]
            fn code(self) -> u32 {
                1 << self as u32
            }
        }
    };
}
pub(crate) use states;

/// The bits of the states named, of a set declared with [`states!`]: `bits!(Mode[Event,
/// ContinuousTime])`.
macro_rules! bits {
    ($set:ident[$($state:ident),* $(,)?]) => {
        0 $(| 1 << $set::$state as u32)*
    };
}
pub(crate) use bits;

states! {
    /// Where an instance is. The bits are stored in the FMU state blob: do not reorder.
    pub enum Mode {
        /// Made, not yet initialising: parameters and start values may be set.
        Instantiated,
        /// Between entering and leaving initialisation.
        Initializing,
        /// Co-Simulation, initialised: steps may be taken.
        Stepping [cs],
        /// Co-Simulation after a step that ended early (Discard): the state is where the
        /// last successful time says.
        StepDiscarded [cs],
        /// After terminate: values may be read.
        Terminated,
        /// After a panic was caught: nothing can be trusted; only reading, reset and free.
        Error,
        /// Model Exchange's event iteration.
        Event [me],
        /// Model Exchange between events: the importer integrates.
        ContinuousTime [me],
    }
}

use Mode::*;

impl Mode {
    pub fn from_code(code: u32) -> Option<Mode> {
        Mode::ALL.iter().copied().find(|m| m.code() == code)
    }

    /// Fixed parameters and the start values of states may still be set.
    pub fn before_init_done(self) -> bool {
        matches!(self, Instantiated | Initializing)
    }
}

/// The interface an instance was made for (the codes of fmi2Type: fmi2ModelExchange = 0,
/// fmi2CoSimulation = 1; stored in the FMU state blob).
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

    /// Whether an instance of this interface can be in `mode`.
    pub fn has(self, mode: Mode) -> bool {
        let states = match self {
            Interface::CoSimulation => Mode::CS,
            Interface::ModelExchange => Mode::ME,
        };
        states & mode.code() != 0
    }

    /// As the standards name it.
    pub fn name(self) -> &'static str {
        match self {
            Interface::ModelExchange => "Model Exchange",
            Interface::CoSimulation => "Co-Simulation",
        }
    }
}
