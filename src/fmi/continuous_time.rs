//! Model Exchange's continuous-time calls (time, states, derivatives, event indicators,
//! nominals, completed integrator step): the same in FMI 2.0 and FMI 3.0 but for their
//! names, their rows of each version's table and the words for their arrays, so one body
//! each, over either version's instance `I`. `export.rs` emits them for both versions
//! (`__continuous_time_symbols!`).

use super::boundary::{guard, ok, slice, slice_mut, Component, Guarded};
use super::gate::Row;
use super::{Instance, Status};

/// fmi2SetTime, fmi3SetTime.
pub fn set_time<I: Guarded>(c: Component, (function, gate): Row, time: f64) -> Status {
    guard::<I>(c, function, gate, |inst| ok(inst.core_mut().set_time(time)))
}

/// fmi2SetContinuousStates, fmi3SetContinuousStates: `x` (named `what`) holds `nx` values.
///
/// # Safety
/// `x` points to `nx` values when `nx > 0`.
pub unsafe fn set_continuous_states<I: Guarded>(
    c: Component,
    (function, gate): Row,
    (x, nx, what): (*const f64, usize, &str),
) -> Status {
    guard::<I>(c, function, gate, |inst| {
        let x = slice(x, nx, what)?;
        ok(inst.core_mut().set_continuous_states(x))
    })
}

/// The getters of an array (states, derivatives, event indicators, nominals): `read`
/// fills the `n` values at `out` (named `what`).
///
/// # Safety
/// `out` points to `n` writable values when `n > 0`.
pub unsafe fn fill<I: Guarded>(
    c: Component,
    (function, gate): Row,
    (out, n, what): (*mut f64, usize, &str),
    read: impl FnOnce(&mut Instance<I::Model>, &mut [f64]) -> Result<Status, String>,
) -> Status {
    guard::<I>(c, function, gate, |inst| {
        let out = slice_mut(out, n, what)?;
        read(inst.core_mut(), out)
    })
}

/// fmi2CompletedIntegratorStep, fmi3CompletedIntegratorStep: `B` the version's Boolean.
///
/// # Safety
/// `enter_event_mode` and `terminate_simulation` point to writable Booleans.
pub unsafe fn completed_integrator_step<I: Guarded, B: From<bool>>(
    c: Component,
    (function, gate): Row,
    enter_event_mode: *mut B,
    terminate_simulation: *mut B,
) -> Status {
    guard::<I>(c, function, gate, |inst| {
        if enter_event_mode.is_null() || terminate_simulation.is_null() {
            return Err("enterEventMode or terminateSimulation is NULL".to_string());
        }
        let (enter, terminate) = inst.core_mut().completed_integrator_step()?;
        *enter_event_mode = B::from(enter);
        *terminate_simulation = B::from(terminate);
        Ok(Status::Ok)
    })
}
