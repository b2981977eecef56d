//! The FMI boundary: FMI 2.0 and FMI 3.0, Co-Simulation and Model Exchange, from one binary.
//!
//! Call flow, from the C symbol down to the physics:
//! 1. [`export_fmu!`](crate::export_fmu) (in `export.rs`) defines every `fmi2*` and `fmi3*`
//!    symbol of one FMU's cdylib from one table, each row a forward to a front-end.
//! 2. The front-ends, one folder per FMI version: [`fmi2`] (`mod.rs`: FMI 2.0's state
//!    table as data, its words, what both interfaces share; `cs.rs`, `me.rs` each
//!    interface's own) and [`fmi3`] (the same for FMI 3.0). Each entry point goes through
//!    the one guard ([`boundary::guard`]): NULL instance, its version's table checked once
//!    ([`gate`]: one check and one wording of a refusal for both), panics caught, every
//!    error one line "function: message". [`boundary`] also holds the NULL-checked slices
//!    and the bodies both versions share (the FMU states, free instance, debug logging);
//!    [`continuous_time`] Model Exchange's continuous-time calls, one body each for both. The only `unsafe`, `extern "C"` and `catch_unwind` of the FMU side
//!    (the packager's side of `mbfmu_describe`, dlopen, is in `package::library`).
//! 3. [`Instance`] is the core (`core/`), which belongs to no FMI version: its [`Mode`]s,
//!    `core/mod.rs` (variables get/set and their checks, initialisation, directional
//!    derivatives, the FMU state and its checked blob in `snapshot.rs`), `cs.rs` (doStep
//!    around an integrator, stepping until an event) and `me.rs` (time, continuous states,
//!    derivatives, event indicators, the event iteration). Its messages name no FMI
//!    function: the guard says which function failed, and the few words a message needs of
//!    the importer's version (which function sets an Integer, what true is called) come
//!    from [`Words`].
//! 4. The [`System`](crate::model::System) computes `ẋ` and the outputs.

pub mod boundary;
pub mod continuous_time;
mod core;
mod export;
pub mod fmi2;
pub mod fmi3;
pub mod gate;

pub use self::core::cs::{StepOutcome, DOSTEP_WORK};
pub use self::core::info::{ModelInfo, Status};
pub use self::core::inputs::MAX_INPUT_DERIVATIVE_ORDER;
pub use self::core::logger::{CallbackFunctions, CallbackLogger, LogMessage3, Logger, Words};
pub use self::core::me::{EventInfo, NO_EVENT_INDICATOR};
pub use self::core::mode::{Interface, Mode};
pub use self::core::snapshot::{Snapshot, SNAPSHOT_MAGIC, SNAPSHOT_VERSION};
pub use self::core::Instance;
pub use gate::Gate;

use crate::model::System;

/// One exported model: the glue the export macro generates for a cdylib.
pub trait Export: 'static {
    type Model: System;
    /// Cached per process (the layout and the GUID are derived once).
    fn info() -> &'static ModelInfo;
}
