//! The Model Exchange functions of the C API (see [`super`] for what every function here
//! does first).

use super as table;
use super::{call, ok, slice, slice_mut, Component};
use crate::fmi::{EventInfo, Export, Status};
use std::ffi::c_int;

/// fmi2EventInfo, laid out as in fmi2FunctionTypes.h (fmi2Boolean is an int).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct EventInfoC {
    pub new_discrete_states_needed: c_int,
    pub terminate_simulation: c_int,
    pub nominals_of_continuous_states_changed: c_int,
    pub values_of_continuous_states_changed: c_int,
    pub next_event_time_defined: c_int,
    pub next_event_time: f64,
}

impl From<EventInfo> for EventInfoC {
    fn from(e: EventInfo) -> Self {
        EventInfoC {
            new_discrete_states_needed: e.new_discrete_states_needed as c_int,
            terminate_simulation: e.terminate_simulation as c_int,
            nominals_of_continuous_states_changed: e.nominals_of_continuous_states_changed as c_int,
            values_of_continuous_states_changed: e.values_of_continuous_states_changed as c_int,
            next_event_time_defined: e.next_event_time.is_some() as c_int,
            next_event_time: e.next_event_time.unwrap_or(0.0),
        }
    }
}

pub fn enter_event_mode<E: Export>(c: Component) -> Status {
    call::<E>(c, "fmi2EnterEventMode", table::ENTER_EVENT_MODE, |inst| {
        ok(inst.enter_event_mode())
    })
}

/// # Safety
/// `info` points to a writable fmi2EventInfo.
pub unsafe fn new_discrete_states<E: Export>(c: Component, info: *mut EventInfoC) -> Status {
    const F: &str = "fmi2NewDiscreteStates";
    call::<E>(c, F, table::NEW_DISCRETE_STATES, |inst| {
        if info.is_null() {
            return Err("fmi2EventInfo is NULL".to_string());
        }
        let answer = inst.new_discrete_states()?;
        *info = answer.into();
        Ok(Status::Ok)
    })
}

pub fn enter_continuous_time_mode<E: Export>(c: Component) -> Status {
    call::<E>(
        c,
        "fmi2EnterContinuousTimeMode",
        table::ENTER_CONTINUOUS_TIME_MODE,
        |inst| ok(inst.enter_continuous_time_mode()),
    )
}

/// # Safety
/// `enter_event_mode` and `terminate_simulation` point to writable fmi2Booleans.
pub unsafe fn completed_integrator_step<E: Export>(
    c: Component,
    _no_set_fmu_state_prior: c_int,
    enter_event_mode: *mut c_int,
    terminate_simulation: *mut c_int,
) -> Status {
    const F: &str = "fmi2CompletedIntegratorStep";
    call::<E>(c, F, table::COMPLETED_INTEGRATOR_STEP, |inst| {
        if enter_event_mode.is_null() || terminate_simulation.is_null() {
            return Err("enterEventMode or terminateSimulation is NULL".to_string());
        }
        let (enter, terminate) = inst.completed_integrator_step()?;
        *enter_event_mode = enter as c_int;
        *terminate_simulation = terminate as c_int;
        Ok(Status::Ok)
    })
}

pub fn set_time<E: Export>(c: Component, time: f64) -> Status {
    call::<E>(c, "fmi2SetTime", table::SET_TIME, |inst| {
        ok(inst.set_time(time))
    })
}

/// # Safety
/// `x` points to `nx` values when `nx > 0`.
pub unsafe fn set_continuous_states<E: Export>(c: Component, x: *const f64, nx: usize) -> Status {
    const F: &str = "fmi2SetContinuousStates";
    call::<E>(c, F, table::SET_CONTINUOUS_STATES, |inst| {
        let x = slice(x, nx, "x[]")?;
        ok(inst.set_continuous_states(x))
    })
}

/// # Safety
/// `x` points to `nx` writable values when `nx > 0`.
pub unsafe fn get_continuous_states<E: Export>(c: Component, x: *mut f64, nx: usize) -> Status {
    const F: &str = "fmi2GetContinuousStates";
    call::<E>(c, F, table::GET_CONTINUOUS_STATES, |inst| {
        let x = slice_mut(x, nx, "x[]")?;
        ok(inst.get_continuous_states(x))
    })
}

/// # Safety
/// As [`get_continuous_states`].
pub unsafe fn get_derivatives<E: Export>(c: Component, dx: *mut f64, nx: usize) -> Status {
    const F: &str = "fmi2GetDerivatives";
    call::<E>(c, F, table::GET_DERIVATIVES, |inst| {
        let dx = slice_mut(dx, nx, "derivatives[]")?;
        inst.get_derivatives(dx)
    })
}

/// # Safety
/// `z` points to `ni` writable values when `ni > 0`.
pub unsafe fn get_event_indicators<E: Export>(c: Component, z: *mut f64, ni: usize) -> Status {
    const F: &str = "fmi2GetEventIndicators";
    call::<E>(c, F, table::GET_EVENT_INDICATORS, |inst| {
        let z = slice_mut(z, ni, "eventIndicators[]")?;
        inst.get_event_indicators(z)
    })
}

/// # Safety
/// As [`get_continuous_states`].
pub unsafe fn get_nominals_of_continuous_states<E: Export>(
    c: Component,
    nominals: *mut f64,
    nx: usize,
) -> Status {
    const F: &str = "fmi2GetNominalsOfContinuousStates";
    call::<E>(c, F, table::GET_NOMINALS, |inst| {
        let nominals = slice_mut(nominals, nx, "x_nominal[]")?;
        ok(inst.get_nominals(nominals))
    })
}
