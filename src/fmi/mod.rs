//! The FMI 2.0 Co-Simulation boundary.
//!
//! Call flow, from the C symbol down to the physics:
//! 1. [`export_fmu!`](crate::export_fmu) (in `export.rs`) defines every `fmi2*` symbol of one
//!    FMU's cdylib, each a one-line forward to [`capi`].
//! 2. [`capi`] turns C pointers into checked Rust values, catches panics and logs
//!    failures: the only `unsafe`, `extern "C"` and `catch_unwind` of the FMU side (the
//!    packager's side of `mbfmu_describe`, dlopen, is in `package::library`).
//! 3. [`Instance`] is the safe state machine of the standard: argument checks, get/set,
//!    doStep around an integrator, FMU state.
//! 4. The [`System`](crate::model::System) computes `ẋ` and the outputs.

pub mod capi;
mod export;
mod inputs;
mod instance;
mod logger;
mod machine;
mod snapshot;

pub use inputs::MAX_INPUT_DERIVATIVE_ORDER;
pub use instance::{Instance, StepOutcome, DOSTEP_WORK};
pub use logger::{CallbackFunctions, CallbackLogger, Logger};
pub use machine::Machine;
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
}

impl ModelInfo {
    pub fn of<M: System>() -> ModelInfo {
        ModelInfo {
            name: M::NAME,
            layout: Layout::of::<M>(),
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
