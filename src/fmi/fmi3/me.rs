//! The FMI 3.0 Model Exchange functions, and fmi3UpdateDiscreteStates of both interfaces
//! (see [`fmi3`](super) for what each does first).

use super as table;
use super::{call3, put, Bool3, Inst3};
use crate::fmi::boundary::{ok, Component};
use crate::fmi::Interface;
use crate::fmi::{Export, Status};

/// fmi3UpdateDiscreteStates. Model Exchange: the event at the time and states set (the
/// core's fmi2NewDiscreteStates). Co-Simulation: the event was applied inside doStep;
/// nothing is left to update.
///
/// # Safety
/// The six out-pointers point to writable values.
pub unsafe fn update_discrete_states<E: Export>(
    c: Component,
    discrete_states_need_update: *mut Bool3,
    terminate_simulation: *mut Bool3,
    nominals_changed: *mut Bool3,
    values_changed: *mut Bool3,
    next_event_time_defined: *mut Bool3,
    next_event_time: *mut f64,
) -> Status {
    const F: &str = "fmi3UpdateDiscreteStates";
    call3::<E>(c, F, table::UPDATE_DISCRETE_STATES, |f| {
        if [
            discrete_states_need_update,
            terminate_simulation,
            nominals_changed,
            values_changed,
            next_event_time_defined,
        ]
        .iter()
        .any(|p| p.is_null())
            || next_event_time.is_null()
        {
            return Err("an out argument is NULL".to_string());
        }
        let info = match f.core.interface() {
            Interface::ModelExchange => f.core.new_discrete_states()?,
            Interface::CoSimulation => crate::fmi::EventInfo::default(),
        };
        put(discrete_states_need_update, info.new_discrete_states_needed);
        put(terminate_simulation, info.terminate_simulation);
        put(nominals_changed, info.nominals_of_continuous_states_changed);
        put(values_changed, info.values_of_continuous_states_changed);
        put(next_event_time_defined, info.next_event_time.is_some());
        *next_event_time = info.next_event_time.unwrap_or(0.0);
        Ok(Status::Ok)
    })
}

pub fn enter_continuous_time_mode<E: Export>(c: Component) -> Status {
    const F: &str = "fmi3EnterContinuousTimeMode";
    call3::<E>(c, F, table::ENTER_CONTINUOUS_TIME_MODE, |f| {
        ok(f.core.enter_continuous_time_mode())
    })
}

/// fmi3GetNumberOfEventIndicators (either interface: the count is the model's).
///
/// # Safety
/// `n` points to a writable `size_t`.
pub unsafe fn get_number_of_event_indicators<E: Export>(c: Component, n: *mut usize) -> Status {
    count::<E>(
        c,
        "fmi3GetNumberOfEventIndicators",
        (n, "nEventIndicators"),
        |f| f.core.number_of_event_indicators(),
    )
}

/// # Safety
/// `n` points to a writable `size_t`.
pub unsafe fn get_number_of_continuous_states<E: Export>(c: Component, n: *mut usize) -> Status {
    count::<E>(
        c,
        "fmi3GetNumberOfContinuousStates",
        (n, "nContinuousStates"),
        |f| f.core.info.layout.n_states,
    )
}

/// A count of the model's written to `n` (named `what` in the standard).
///
/// # Safety
/// `n` points to a writable `size_t`.
unsafe fn count<E: Export>(
    c: Component,
    function: &'static str,
    (n, what): (*mut usize, &str),
    of: impl FnOnce(&Inst3<E>) -> usize,
) -> Status {
    call3::<E>(c, function, table::COUNTS, |f| {
        if n.is_null() {
            return Err(format!("{what} is NULL"));
        }
        *n = of(f);
        Ok(Status::Ok)
    })
}
