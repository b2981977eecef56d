//! The Co-Simulation functions of the C API: doStep, input and output derivatives, status
//! queries (see [`super`] for what every function here does first).

use super as table;
use super::{call, ok, slice, slice_mut, Component, Inst};
use crate::fmi::{Export, Status, StepOutcome};
use std::ffi::{c_char, c_int, c_uint};

/// fmi2StatusKind values this FMU answers (fmi2DoStepStatus and fmi2PendingStatus
/// only concern asynchronous steps, which it never runs).
const LAST_SUCCESSFUL_TIME: c_int = 2;
const TERMINATED: c_int = 3;

/// # Safety
/// The arrays hold `n` elements when `n` is positive.
pub unsafe fn set_real_input_derivatives<E: Export>(
    c: Component,
    vr: *const c_uint,
    n: usize,
    order: *const c_int,
    value: *const f64,
) -> Status {
    const F: &str = "fmi2SetRealInputDerivatives";
    call::<E>(c, F, table::INPUT_DERIVATIVES, |inst| {
        let vr = slice(vr, n, "vr[]")?;
        let order = slice(order, n, "order[]")?;
        let value = slice(value, n, "value[]")?;
        ok(inst.set_input_derivatives(vr, order, value))
    })
}

/// # Safety
/// The arrays hold `n` elements when `n` is positive.
pub unsafe fn get_real_output_derivatives<E: Export>(
    c: Component,
    vr: *const c_uint,
    n: usize,
    order: *const c_int,
    value: *mut f64,
) -> Status {
    const F: &str = "fmi2GetRealOutputDerivatives";
    call::<E>(c, F, table::OUTPUT_DERIVATIVES, |inst| {
        let vr = slice(vr, n, "vr[]")?;
        let order = slice(order, n, "order[]")?;
        let value = slice_mut(value, n, "value[]")?;
        ok(inst.output_derivatives(vr, order, value))
    })
}

pub fn do_step<E: Export>(c: Component, current: f64, h: f64, _no_set_prior: c_int) -> Status {
    call::<E>(c, "fmi2DoStep", table::DO_STEP, |inst| {
        match inst.do_step(current, h)? {
            StepOutcome::Completed => Ok(Status::Ok),
            StepOutcome::Discarded(message) => {
                inst.logger.failure(Status::Discard, &message);
                Ok(Status::Discard)
            }
        }
    })
}

pub fn cancel_step<E: Export>(c: Component) -> Status {
    call::<E>(c, "fmi2CancelStep", table::CANCEL_STEP, |_| Ok(Status::Ok))
}

/// Status kinds this FMU cannot report answer fmi2Discard (standard, 4.2.3).
fn unavailable<E: Export>(inst: &Inst<E>, kind: c_int) -> Result<Status, String> {
    inst.logger.failure(
        Status::Discard,
        &format!("status kind {kind} is not available from this FMU (doStep is synchronous)"),
    );
    Ok(Status::Discard)
}

/// The body of every fmi2Get*Status: `value` checked, then the one kind this FMU knows of
/// the type (`known`: the kind and its value), else fmi2Discard.
///
/// # Safety
/// `value` points to a writable value of the kind's type.
unsafe fn status<E: Export, T>(
    c: Component,
    function: &'static str,
    kind: c_int,
    value: *mut T,
    known: impl FnOnce(&Inst<E>) -> Option<(c_int, T)>,
) -> Status {
    call::<E>(c, function, table::STATUS, |inst| {
        if value.is_null() {
            return Err("value is NULL".into());
        }
        match known(inst) {
            Some((k, v)) if k == kind => {
                *value = v;
                Ok(Status::Ok)
            }
            _ => unavailable::<E>(inst, kind),
        }
    })
}

/// # Safety
/// As [`status`].
pub unsafe fn get_status<E: Export>(c: Component, kind: c_int, value: *mut c_int) -> Status {
    status::<E, c_int>(c, "fmi2GetStatus", kind, value, |_| None)
}

/// # Safety
/// As [`status`].
pub unsafe fn get_real_status<E: Export>(c: Component, kind: c_int, value: *mut f64) -> Status {
    status::<E, f64>(c, "fmi2GetRealStatus", kind, value, |inst| {
        Some((LAST_SUCCESSFUL_TIME, inst.last_successful_time()))
    })
}

/// # Safety
/// As [`status`].
pub unsafe fn get_integer_status<E: Export>(c: Component, kind: c_int, v: *mut c_int) -> Status {
    status::<E, c_int>(c, "fmi2GetIntegerStatus", kind, v, |_| None)
}

/// # Safety
/// As [`status`]. The slave never asks to end the simulation early (fmi2Terminated false).
pub unsafe fn get_boolean_status<E: Export>(c: Component, kind: c_int, v: *mut c_int) -> Status {
    status::<E, c_int>(c, "fmi2GetBooleanStatus", kind, v, |_| {
        Some((TERMINATED, 0))
    })
}

/// # Safety
/// As [`status`].
pub unsafe fn get_string_status<E: Export>(
    c: Component,
    kind: c_int,
    v: *mut *const c_char,
) -> Status {
    status::<E, *const c_char>(c, "fmi2GetStringStatus", kind, v, |_| None)
}
