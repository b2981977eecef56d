//! A front-end's state table as data: which function may be called in which of its
//! version's states ([`Gate`], rows of [`gates!`]), checked once per call by the guard of
//! every C entry point before any work ([`check`]), with one wording of a refusal for
//! both versions.

use super::core::mode::{Interface, States};

/// The states of one FMI version's table (`fmi2::State2`, `fmi3::State3`, declared with
/// `states!`): bits, so a [`Gate`] holds a set of them in a `u32`.
pub trait Table: States {
    /// How the importer chose the interface, for a refusal ("fmuType 1 in
    /// fmi2Instantiate").
    fn made_by(own: Interface) -> String;

    fn states_of(own: Interface) -> u32 {
        match own {
            Interface::CoSimulation => Self::CS,
            Interface::ModelExchange => Self::ME,
        }
    }
}

/// A call's name and its row of its version's table: what every body shared by both
/// versions is given, so that the guard can check and name it.
pub type Row = (&'static str, Gate);

/// Where a function may run: the states of its version's table that admit it, and the
/// interface it belongs to (`None`: both).
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

/// A state table as rows `NAME = interface[states];` over the states of `$table` (a
/// [`Table`]), `interface` one of `both`, `cs`, `me`.
macro_rules! gates {
    ($table:ident; $($(#[$doc:meta])* $name:ident = $interface:ident[$($state:ident),* $(,)?];)*) => {
        $($(#[$doc])* pub const $name: $crate::fmi::gate::Gate =
            $crate::fmi::gate::gates!(@ $table, $interface, $crate::fmi::core::mode::bits!($table[$($state),*]));)*
    };
    (@ $table:ident, both, $states:expr) => {
        $crate::fmi::gate::Gate::both($states)
    };
    (@ $table:ident, cs, $states:expr) => {
        $crate::fmi::gate::Gate::only(
            $crate::fmi::Interface::CoSimulation,
            $states,
            <$table as $crate::fmi::core::mode::States>::ME,
        )
    };
    (@ $table:ident, me, $states:expr) => {
        $crate::fmi::gate::Gate::only(
            $crate::fmi::Interface::ModelExchange,
            $states,
            <$table as $crate::fmi::core::mode::States>::CS,
        )
    };
}
pub(crate) use gates;

/// Fails unless the table of `S` lets a function behind `gate` run in `state` of an
/// instance made for `own`.
#[inline]
pub fn check<S: Table>(gate: Gate, state: S, own: Interface) -> Result<(), String> {
    match gate.admits(state.code(), own) {
        true => Ok(()),
        false => Err(refusal(gate, state, own)),
    }
}

/// Why the table refuses (see [`check`]): the function is the other interface's, or the
/// states of the caller's interface in which it is allowed.
#[cold]
#[inline(never)]
fn refusal<S: Table>(gate: Gate, state: S, own: Interface) -> String {
    match gate.interface {
        Some(of) if of != own => format!(
            "a {} function; this instance was made for {} ({})",
            of.name(),
            own.name(),
            S::made_by(own)
        ),
        _ => format!(
            "not allowed in state {state:?} (allowed in: {})",
            describe::<S>(gate.states & S::states_of(own))
        ),
    }
}

/// Names of the states in `mask`, for error messages.
fn describe<S: Table>(mask: u32) -> String {
    let names: Vec<String> = S::ALL
        .iter()
        .filter(|s| mask & s.code() != 0)
        .map(|s| format!("{s:?}"))
        .collect();
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}
