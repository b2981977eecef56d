//! The FMI boundary: FMI 2.0 and FMI 3.0, Co-Simulation and Model Exchange, from one binary.
//!
//! Call flow, from the C symbol down to the physics:
//! 1. [`export_fmu!`](crate::export_fmu) (in `export.rs`) defines every `fmi2*` symbol of one
//!    FMU's cdylib (both interfaces), each a one-line forward to [`capi`].
//! 2. [`capi`] turns C pointers into checked Rust values, catches panics and logs
//!    failures: the only `unsafe`, `extern "C"` and `catch_unwind` of the FMU side (the
//!    packager's side of `mbfmu_describe`, dlopen, is in `package::library`). Split as the
//!    instance is: `capi/mod.rs` the functions both interfaces have, `capi/cs.rs` and
//!    `capi/me.rs` each interface's own.
//! 3. [`Instance`] is the safe state machine of the standard, one core and two thin
//!    front-ends: `core.rs` (argument checks, get/set, initialisation, directional
//!    derivatives, FMU state and its checked blob in `snapshot.rs`, the state machines of
//!    both interfaces in `machine.rs`), `cs.rs` (doStep around an integrator) and `me.rs`
//!    (time, continuous states, derivatives, event indicators, event mode).
//! 4. FMI 3.0 is a second front-end over the same core: `export_fmu!` also defines every
//!    `fmi3*` symbol, forwarding to `capi/fmi3*.rs`, which check FMI 3.0's state machine
//!    (`machine3.rs`) and call the same [`Instance`].
//! 5. The [`System`](crate::model::System) computes `ẋ` and the outputs.

pub mod capi;
mod core;
mod cs;
mod export;
mod inputs;
mod logger;
mod machine;
pub mod machine3;
mod me;
mod snapshot;

pub use cs::{StepOutcome, DOSTEP_WORK};
pub use inputs::MAX_INPUT_DERIVATIVE_ORDER;
pub use logger::{CallbackFunctions, CallbackLogger, LogMessage3, Logger};
pub use machine::{Interface, Machine};
pub use me::{EventInfo, NO_EVENT_INDICATOR};

pub use self::core::Instance;
pub use snapshot::{Snapshot, SNAPSHOT_MAGIC, SNAPSHOT_VERSION};

use crate::model::{Layout, System};

/// fmi2Status.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
    Pending = 5,
}

/// What the FMU knows of its model, computed once per process.
#[derive(Debug)]
pub struct ModelInfo {
    pub name: &'static str,
    pub layout: Layout,
    pub guid: String,
    /// DefaultExperiment tolerance: used when fmi2SetupExperiment defines none.
    pub default_tolerance: f64,
    /// What Model Exchange declares: event indicators, projection, `reinit` states.
    pub probe: crate::model::Probe,
}

impl ModelInfo {
    pub fn of<M: System>() -> ModelInfo {
        let layout = Layout::of::<M>();
        ModelInfo {
            name: M::NAME,
            probe: crate::model::Probe::of::<M>(&layout),
            layout,
            guid: crate::xml::guid::<M>(),
            default_tolerance: M::default_experiment().1,
        }
    }
}

/// One exported model: the glue the export macro generates for a cdylib.
pub trait Export: 'static {
    type Model: System;
    /// Cached per process (the layout and the GUID are derived once).
    fn info() -> &'static ModelInfo;
}
