//! The FMI 3.0 Co-Simulation functions: doStep with early return at events, Step and
//! Event Mode, output derivatives (see [`fmi3`](super) for what each does first).
//!
//! Events inside a step. The core locates the event indicator's sign change inside doStep
//! and applies the event there ([`System::on_event`](crate::model::System::on_event)),
//! as in FMI 2.0. When the importer gave an intermediateUpdate callback or allowed early
//! return, fmi3DoStep runs the core up to each event ([`Instance::do_step_until_event`]):
//! the callback is called at the event time (intermediateStepFinished, canReturnEarly =
//! earlyReturnAllowed), and the step returns early there (earlyReturn, lastSuccessfulTime
//! = the event time) when early return is allowed and either the importer uses Event Mode
//! (then eventHandlingNeeded = true) or the callback asked for it; otherwise the step goes
//! on to its end. The event is applied before the return: in Event Mode,
//! fmi3UpdateDiscreteStates finds nothing left to update.
//!
//! [`Instance::do_step_until_event`]: crate::fmi::Instance::do_step_until_event

use super as table;
use super::{call3, put, Bool3, Inst3};
use crate::fmi::boundary::{ok, slice, slice_mut, Component};
use crate::fmi::{Export, Status, StepOutcome};

/// Most early stops at events in one fmi3DoStep that goes on past them (a chattering model).
const MAX_EVENTS_PER_STEP: usize = 100;

/// What fmi3DoStep writes back.
#[derive(Default)]
struct StepResult {
    event_handling_needed: bool,
    terminate: bool,
    early_return: bool,
    last_successful_time: f64,
}

fn step<E: Export>(f: &mut Inst3<E>, current: f64, h: f64) -> Result<(Status, StepResult), String> {
    let t_end = current + h;
    let stop_at_events = f.early_return_allowed || f.intermediate_update.is_some();
    let mut now = current;
    for _ in 0..=MAX_EVENTS_PER_STEP {
        let outcome = if stop_at_events {
            f.core
                .do_step_until_event(now, if now == current { h } else { t_end - now })?
        } else {
            f.core.do_step(current, h)?
        };
        let t = f.core.time();
        if let StepOutcome::Discarded(message) = outcome {
            f.core.logger.failure(Status::Discard, &message);
            let r = StepResult {
                last_successful_time: t,
                early_return: false,
                ..StepResult::default()
            };
            return Ok((Status::Discard, r));
        }
        if !stop_at_events || t >= t_end || now == t && now != current {
            break;
        }
        // An event at t, inside the step.
        let mut requested = false;
        if let Some(callback) = f.intermediate_update {
            let (mut asked, mut asked_time) = (false, t);
            // SAFETY: the importer's callback, given at instantiation; the pointers are
            // to this frame's locals.
            unsafe {
                callback(
                    f.env,
                    t,
                    false,
                    false,
                    true,
                    f.early_return_allowed,
                    &mut asked,
                    &mut asked_time,
                )
            };
            requested = asked;
        }
        if f.early_return_allowed && (f.event_mode_used || requested) {
            let r = StepResult {
                event_handling_needed: f.event_mode_used,
                terminate: false,
                early_return: true,
                last_successful_time: t,
            };
            return Ok((Status::Ok, r));
        }
        now = t;
    }
    let t = f.core.time();
    if t < t_end {
        return Err(format!(
            "more than {MAX_EVENTS_PER_STEP} events in one communication step (stopped at t = {t})"
        ));
    }
    let r = StepResult {
        last_successful_time: t,
        ..StepResult::default()
    };
    Ok((Status::Ok, r))
}

/// # Safety
/// The four out-pointers point to writable values.
#[allow(clippy::too_many_arguments)]
pub unsafe fn do_step<E: Export>(
    c: Component,
    current: f64,
    h: f64,
    _no_set_prior: Bool3,
    event_handling_needed: *mut Bool3,
    terminate_simulation: *mut Bool3,
    early_return: *mut Bool3,
    last_successful_time: *mut f64,
) -> Status {
    const F: &str = "fmi3DoStep";
    call3::<E>(c, F, table::DO_STEP, |f| {
        if event_handling_needed.is_null()
            || terminate_simulation.is_null()
            || early_return.is_null()
            || last_successful_time.is_null()
        {
            return Err("eventHandlingNeeded, terminateSimulation, earlyReturn or lastSuccessfulTime is NULL".to_string());
        }
        let (status, r) = step::<E>(f, current, h)?;
        put(event_handling_needed, r.event_handling_needed);
        put(terminate_simulation, r.terminate);
        put(early_return, r.early_return);
        *last_successful_time = r.last_successful_time;
        Ok(status)
    })
}

/// Co-Simulation's Event Mode back to Step Mode.
pub fn enter_step_mode<E: Export>(c: Component) -> Status {
    const F: &str = "fmi3EnterStepMode";
    call3::<E>(c, F, table::ENTER_STEP_MODE, |f| {
        f.cs_event_mode = false;
        Ok(Status::Ok)
    })
}

/// # Safety
/// `vr` and `order` hold `nvr`, `value` `n_values` elements.
pub unsafe fn get_output_derivatives<E: Export>(
    c: Component,
    vr: *const u32,
    nvr: usize,
    order: *const i32,
    value: *mut f64,
    n_values: usize,
) -> Status {
    const F: &str = "fmi3GetOutputDerivatives";
    call3::<E>(c, F, table::OUTPUT_DERIVATIVES, |f| {
        if nvr != n_values {
            return Err(format!(
                "nValues = {n_values} differs from nValueReferences = {nvr}"
            ));
        }
        let vr = slice(vr, nvr, "valueReferences[]")?;
        let order = slice(order, nvr, "orders[]")?;
        let value = slice_mut(value, nvr, "values[]")?;
        ok(f.core.output_derivatives(vr, order, value))
    })
}
