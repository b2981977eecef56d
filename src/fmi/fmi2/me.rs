//! The Model Exchange functions of the C API (see [`super`] for what every function here
//! does first).

use super as table;
use super::{call, ok, Component};
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
