//! FMI 3.0's front-end: its state table (Co-Simulation, standard section 4.3; Model
//! Exchange, section 3.3) as data ([`State3`]), its words, and its C marshalling of what
//! both interfaces have; [`cs`] and [`me`] each interface's own. The same core as FMI 2.0.
//!
//! An FMI 3.0 instance is an [`Instance3`]: the core [`Instance`] and what FMI 3.0 adds —
//! Co-Simulation's Event Mode, the importer's `eventModeUsed` / `earlyReturnAllowed` and
//! its intermediateUpdate callback. Every function passes the guard with FMI 3.0's table
//! (the only one checked), then calls the core. Lines go through the
//! importer's `logMessage`, naming the fmi3 function and using FMI 3.0's words.
//!
//! Variables: the value references of FMI 2.0, plus `time` (the independent variable) at
//! the first free value reference and, for a model with an event indicator, the indicator
//! at the next one ([`Layout::fmi3_extra_vrs`](crate::model::Layout::fmi3_extra_vrs)).
//! Types: Float64 (FMI 2.0's Real), Int32 (Integer) and Int64 (the Enumerations, `solver`
//! and a system's enumeration parameters: FMI 3.0 reads enumerations as Int64); every other
//! type answers fmi3Error for any value reference.

mod cs;
mod me;

pub use cs::*;
pub use me::*;

use super::boundary::{guard, ok, slice, slice_mut, Component, FmuState, Guarded};
use super::core::mode::states;
use super::gate::{self, gates, Gate, Table};
use crate::fmi::{Export, Instance, Interface, Logger, Mode, ResourceLocation, Status};
use crate::model::{System, VarKind, VarType};
use std::ffi::{c_char, c_void, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};

pub use crate::fmi::LogMessage3;

/// `fmi3IntermediateUpdateCallback`.
pub type IntermediateUpdate = unsafe extern "C" fn(
    env: *mut c_void,
    intermediate_update_time: f64,
    intermediate_variable_set_requested: bool,
    intermediate_variable_get_allowed: bool,
    intermediate_step_finished: bool,
    can_return_early: bool,
    early_return_requested: *mut bool,
    early_return_time: *mut f64,
);

/// fmi3Boolean as received: a byte (any non-zero is true, read without assuming 0 or 1).
pub type Bool3 = u8;

states! {
    /// States of an FMI 3.0 instance (Configuration and Reconfiguration Mode and the Clock
    /// states never occur: the models have no structural parameters and no clocks).
    ///
    /// FMI 3.0 differs from FMI 2.0: Co-Simulation has Step Mode instead of
    /// stepComplete/stepFailed, and an Event Mode of its own when the importer instantiated
    /// with `eventModeUsed`; fmi3EnterInitializationMode takes the experiment (there is no
    /// fmi3SetupExperiment). The state is derived from the core's mode ([`State3::of`]): Step
    /// Mode is the core's stepping mode, also after a discarded step (FMI 3.0 has no
    /// stepFailed: the instance is where lastSuccessfulTime says, and may step on from
    /// there), and the one state the core has no mode for, Co-Simulation's Event Mode, is a
    /// flag of the FMI 3.0 instance.
    pub enum State3 {
        Instantiated,
        InitializationMode,
        EventMode,
        ContinuousTimeMode [me],
        StepMode [cs],
        Terminated,
        /// After a panic was caught (the core's error state): only reading, reset and free.
        Error,
    }
}

impl State3 {
    /// The FMI 3.0 state of an instance whose core is in `mode`; `cs_event_mode`: a
    /// Co-Simulation instance in Event Mode.
    #[inline]
    pub fn of(mode: Mode, cs_event_mode: bool) -> State3 {
        match mode {
            Mode::Instantiated => State3::Instantiated,
            Mode::Initializing => State3::InitializationMode,
            Mode::Stepping | Mode::StepDiscarded if cs_event_mode => State3::EventMode,
            Mode::Stepping | Mode::StepDiscarded => State3::StepMode,
            Mode::Event => State3::EventMode,
            Mode::ContinuousTime => State3::ContinuousTimeMode,
            Mode::Terminated => State3::Terminated,
            Mode::Error => State3::Error,
        }
    }
}

impl Table for State3 {
    fn made_by(own: Interface) -> String {
        match own {
            Interface::CoSimulation => "by fmi3InstantiateCoSimulation".into(),
            Interface::ModelExchange => "by fmi3InstantiateModelExchange".into(),
        }
    }
}

// FMI 3.0's table (sections 3.3 and 4.3).
#[rustfmt::skip]
gates! { State3;
    ANY = both[
        Instantiated, InitializationMode, EventMode, ContinuousTimeMode, StepMode, Terminated,
        Error,
    ];
    ENTER_INIT = both[Instantiated];
    EXIT_INIT = both[InitializationMode];
    /// Model Exchange from Continuous-Time Mode; Co-Simulation (eventModeUsed) from Step
    /// Mode.
    ENTER_EVENT_MODE = both[ContinuousTimeMode, StepMode];
    TERMINATE = both[EventMode, ContinuousTimeMode, StepMode];
    GET = both[
        InitializationMode, EventMode, ContinuousTimeMode, StepMode, Terminated, Error,
    ];
    SET = both[Instantiated, InitializationMode, EventMode, ContinuousTimeMode, StepMode];
    DERIVATIVES = both[InitializationMode, EventMode, ContinuousTimeMode, StepMode, Terminated];
    UPDATE_DISCRETE_STATES = both[EventMode];
    EVALUATE_DISCRETE_STATES = both[InitializationMode, EventMode, ContinuousTimeMode, StepMode];
    // Model Exchange.
    ENTER_CONTINUOUS_TIME_MODE = me[EventMode];
    COMPLETED_INTEGRATOR_STEP = me[ContinuousTimeMode];
    SET_TIME = me[EventMode, ContinuousTimeMode];
    SET_CONTINUOUS_STATES = me[ContinuousTimeMode];
    /// fmi3GetContinuousStates, fmi3GetContinuousStateDerivatives, fmi3GetEventIndicators
    /// and fmi3GetNominalsOfContinuousStates: FMI 3.0.2 section 2.3 allows them in
    /// Initialization Mode, Event Mode, Continuous-Time Mode and Terminated (not in
    /// Instantiated; FMI 2.0's table differs: no derivatives in Initialization Mode,
    /// nominals in Instantiated). Error is FMI 3.0's Terminated after an fmi3Error (values
    /// for debugging).
    EVALUATE = me[InitializationMode, EventMode, ContinuousTimeMode, Terminated, Error];
    // Co-Simulation.
    ENTER_STEP_MODE = cs[EventMode];
    DO_STEP = cs[StepMode];
    OUTPUT_DERIVATIVES = cs[StepMode, Terminated, Error];
}
pub const FMU_STATE: Gate = ANY;
pub const COUNTS: Gate = ANY;

/// An FMI 3.0 instance: the core and what FMI 3.0 adds.
pub struct Instance3<M: System> {
    pub core: Instance<M>,
    /// Co-Simulation in Event Mode (the core stays in stepComplete underneath).
    cs_event_mode: bool,
    /// fmi3InstantiateCoSimulation's arguments.
    event_mode_used: bool,
    early_return_allowed: bool,
    intermediate_update: Option<IntermediateUpdate>,
    env: *mut c_void,
}

impl<M: System> Instance3<M> {
    #[inline]
    pub fn state(&self) -> State3 {
        State3::of(self.core.mode(), self.cs_event_mode)
    }
}

/// FMI 3.0 reads the core's mode and its own Event Mode flag as its state.
impl<M: System> Guarded for Instance3<M> {
    type Model = M;
    fn core(&self) -> &Instance<M> {
        &self.core
    }
    fn core_mut(&mut self) -> &mut Instance<M> {
        &mut self.core
    }
    fn allows(&self, gate: Gate) -> Result<(), String> {
        gate::check(gate, self.state(), self.core.interface())
    }
}

pub type Inst3<E> = Instance3<<E as Export>::Model>;

/// What a value reference is to FMI 3.0.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Var3 {
    /// A variable of the core (FMI 2.0's value reference) of this FMI 3.0 type.
    Core(Type3),
    Time,
    EventIndicator,
}

#[derive(Clone, Copy, PartialEq, Debug)]
enum Type3 {
    Float64,
    Int32,
    Int64,
}

impl Type3 {
    fn name(self) -> &'static str {
        match self {
            Type3::Float64 => "Float64",
            Type3::Int32 => "Int32",
            Type3::Int64 => "Int64 (an Enumeration)",
        }
    }
}

fn var3<E: Export>(f: &Inst3<E>, vr: u32) -> Result<Var3, String> {
    let info = f.core.info;
    let (time, indicator) = info.layout.fmi3_extra_vrs(info.probe.event_indicators);
    if vr == time {
        return Ok(Var3::Time);
    }
    if Some(vr) == indicator {
        return Ok(Var3::EventIndicator);
    }
    let slot = info.layout.slot(vr).ok_or_else(|| {
        let last = indicator.unwrap_or(time);
        format!("unknown value reference {vr} (this model has 0 … {last})")
    })?;
    let var = &info.layout.vars[vr as usize].1;
    Ok(Var3::Core(match (slot.kind, var.ty) {
        (VarKind::SolverMethod, _) | (VarKind::Parameter, VarType::Enumeration(_)) => Type3::Int64,
        (VarKind::SolverMaxSteps | VarKind::MeProjection, _)
        | (VarKind::Parameter, VarType::Integer) => Type3::Int32,
        _ => Type3::Float64,
    }))
}

fn var_name<E: Export>(f: &Inst3<E>, vr: u32) -> String {
    let layout = &f.core.info.layout;
    match layout.vars.get(vr as usize) {
        Some((_, v)) => v.name.to_string(),
        None if vr as usize == layout.vars.len() => "time".into(),
        None => "the event indicator".into(),
    }
}

/// Checks that every value reference is a variable of type `want`.
fn require_type<E: Export>(f: &Inst3<E>, vrs: &[u32], want: Type3) -> Result<(), String> {
    for &vr in vrs {
        let ty = match var3::<E>(f, vr)? {
            Var3::Core(ty) => ty,
            Var3::Time | Var3::EventIndicator => Type3::Float64,
        };
        if ty != want {
            return Err(format!(
                "value reference {vr} ({}) is a {} variable, not a {}",
                var_name::<E>(f, vr),
                ty.name(),
                want.name()
            ));
        }
    }
    Ok(())
}

/// [`guard`] for an FMI 3.0 instance.
#[inline(always)]
pub(crate) fn call3<E: Export>(
    c: Component,
    function: &'static str,
    gate: Gate,
    body: impl FnOnce(&mut Inst3<E>) -> Result<Status, String>,
) -> Status {
    guard::<Inst3<E>>(c, function, gate, body)
}

/// nValues against nValueReferences (every variable here is a scalar).
fn require_values(n_vr: usize, n_values: usize) -> Result<(), String> {
    if n_vr != n_values {
        return Err(format!(
            "nValues = {n_values}, but {n_vr} value references of scalar variables need {n_vr}"
        ));
    }
    Ok(())
}

pub fn get_version() -> *const c_char {
    c"3.0".as_ptr()
}

/// fmi3InstantiateModelExchange / fmi3InstantiateCoSimulation: NULL (with a line when a
/// logger was given) on a bad argument.
///
/// # Safety
/// Pointers as the FMI 3.0 standard describes for fmi3Instantiate*.
#[allow(clippy::too_many_arguments)]
pub unsafe fn instantiate<E: Export>(
    function: &'static str,
    interface: Interface,
    instance_name: *const c_char,
    token: *const c_char,
    resource_path: *const c_char,
    logging_on: Bool3,
    (event_mode_used, early_return_allowed, n_required): (bool, bool, usize),
    env: *mut c_void,
    log_message: Option<LogMessage3>,
    intermediate_update: Option<IntermediateUpdate>,
) -> Component {
    let result = catch_unwind(AssertUnwindSafe(|| {
        let name = if instance_name.is_null() {
            None
        } else {
            Some(CStr::from_ptr(instance_name).to_string_lossy().into_owned())
        };
        let logger = Logger::fmi3(
            log_message,
            env,
            name.as_deref().unwrap_or("?"),
            logging_on != 0,
        );
        logger.set_function(function);
        let fail = |message: String| {
            logger.failure(Status::Error, &message);
            std::ptr::null_mut()
        };
        let resources = ResourceLocation::from_c(resource_path, false);
        if let Err(e) = resources.and_then(|r| E::prepare(&r)) {
            return fail(e);
        }
        let info = E::info();
        if matches!(name.as_deref(), None | Some("")) {
            return fail("instanceName is NULL or empty".into());
        }
        if token.is_null() {
            return fail("instantiationToken is NULL".into());
        }
        let given = CStr::from_ptr(token).to_string_lossy();
        if given != info.guid.as_str() {
            return fail(format!(
                "instantiationToken {given} does not match this binary's {} (modelDescription.xml and binary from different builds?)",
                info.guid
            ));
        }
        if n_required > 0 {
            return fail(format!(
                "{n_required} required intermediate variables asked; this FMU offers none (providesIntermediateUpdate gives the event times only)"
            ));
        }
        let instance: Box<Inst3<E>> = Box::new(Instance3 {
            core: Instance::for_interface(info, logger, interface),
            cs_event_mode: false,
            event_mode_used,
            early_return_allowed,
            intermediate_update,
            env,
        });
        Box::into_raw(instance) as Component
    }));
    result.unwrap_or(std::ptr::null_mut())
}

/// fmi3InstantiateScheduledExecution: not offered (no clocks, no model partitions).
///
/// # Safety
/// `instance_name` is NULL or a C string.
pub unsafe fn instantiate_scheduled_execution(
    instance_name: *const c_char,
    env: *mut c_void,
    log_message: Option<LogMessage3>,
) -> Component {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        let name = if instance_name.is_null() {
            "?".to_string()
        } else {
            CStr::from_ptr(instance_name).to_string_lossy().into_owned()
        };
        let logger = Logger::fmi3(log_message, env, &name, false);
        logger.set_function("fmi3InstantiateScheduledExecution");
        logger.failure(
            Status::Error,
            "this FMU offers Model Exchange and Co-Simulation only (no Scheduled Execution: the models have no clocks)",
        );
    }));
    std::ptr::null_mut()
}

pub fn enter_initialization_mode<E: Export>(
    c: Component,
    tolerance_defined: Bool3,
    tolerance: f64,
    start_time: f64,
    stop_time_defined: Bool3,
    stop_time: f64,
) -> Status {
    const F: &str = "fmi3EnterInitializationMode";
    call3::<E>(c, F, ENTER_INIT, |f| {
        f.core.setup_experiment(
            (tolerance_defined != 0).then_some(tolerance),
            start_time,
            (stop_time_defined != 0).then_some(stop_time),
        )?;
        ok(f.core.enter_initialization_mode())
    })
}

pub fn exit_initialization_mode<E: Export>(c: Component) -> Status {
    const F: &str = "fmi3ExitInitializationMode";
    call3::<E>(c, F, EXIT_INIT, |f| {
        let status = f.core.exit_initialization_mode()?;
        // Co-Simulation with eventModeUsed goes to Event Mode, else to Step Mode.
        f.cs_event_mode = f.core.interface() == Interface::CoSimulation && f.event_mode_used;
        Ok(status)
    })
}

/// Model Exchange from Continuous-Time Mode; Co-Simulation (instantiated with
/// eventModeUsed) from Step Mode.
pub fn enter_event_mode<E: Export>(c: Component) -> Status {
    const F: &str = "fmi3EnterEventMode";
    call3::<E>(c, F, ENTER_EVENT_MODE, |f| match f.core.interface() {
        Interface::ModelExchange => ok(f.core.enter_event_mode()),
        Interface::CoSimulation => {
            if !f.event_mode_used {
                return Err(
                    "this Co-Simulation instance was made with eventModeUsed = false".to_string(),
                );
            }
            f.cs_event_mode = true;
            Ok(Status::Ok)
        }
    })
}

pub fn terminate<E: Export>(c: Component) -> Status {
    const F: &str = "fmi3Terminate";
    call3::<E>(c, F, TERMINATE, |f| {
        f.core.terminate()?;
        f.cs_event_mode = false;
        Ok(Status::Ok)
    })
}

pub fn reset<E: Export>(c: Component) -> Status {
    const F: &str = "fmi3Reset";
    call3::<E>(c, F, ANY, |f| {
        f.core.reset()?;
        f.cs_event_mode = false;
        Ok(Status::Ok)
    })
}

/// What every fmi3Get{Float64, Int32, Int64} checks before `read`: the state, nValues, the
/// two arrays and that every value reference is a variable of type `want`.
///
/// # Safety
/// `vr` holds `nvr` and `value` `n_values` elements.
unsafe fn getter<E: Export, T>(
    c: Component,
    function: &'static str,
    want: Type3,
    (vr, nvr): (*const u32, usize),
    (value, n_values): (*mut T, usize),
    read: impl FnOnce(&mut Inst3<E>, &[u32], &mut [T]) -> Result<(), String>,
) -> Status {
    call3::<E>(c, function, GET, |f| {
        require_values(nvr, n_values)?;
        let vr = slice(vr, nvr, "valueReferences[]")?;
        let value = slice_mut(value, nvr, "values[]")?;
        require_type::<E>(f, vr, want)?;
        ok(read(f, vr, value))
    })
}

/// [`getter`]'s twin for fmi3Set{Float64, Int32, Int64}.
///
/// # Safety
/// As [`getter`].
unsafe fn setter<E: Export, T>(
    c: Component,
    function: &'static str,
    want: Type3,
    (vr, nvr): (*const u32, usize),
    (value, n_values): (*const T, usize),
    write: impl FnOnce(&mut Inst3<E>, &[u32], &[T]) -> Result<(), String>,
) -> Status {
    call3::<E>(c, function, SET, |f| {
        require_values(nvr, n_values)?;
        let vr = slice(vr, nvr, "valueReferences[]")?;
        let value = slice(value, nvr, "values[]")?;
        require_type::<E>(f, vr, want)?;
        ok(write(f, vr, value))
    })
}

/// Reads the Float64 variables: the core's Reals, `time` and the event indicator.
fn read_float64<E: Export>(f: &Inst3<E>, vrs: &[u32], values: &mut [f64]) -> Result<(), String> {
    let n = f.core.info.layout.vars.len();
    if vrs.iter().all(|&vr| (vr as usize) < n) {
        return f.core.get_real(vrs, values);
    }
    for (value, &vr) in values.iter_mut().zip(vrs) {
        *value = match var3::<E>(f, vr)? {
            Var3::Time => f.core.time(),
            Var3::EventIndicator => f.core.event_indicator_value(),
            Var3::Core(_) => {
                let mut one = [0.0];
                f.core.get_real(&[vr], &mut one)?;
                one[0]
            }
        };
        if !value.is_finite() {
            return Err(format!(
                "{} = {value} is not finite here",
                var_name::<E>(f, vr)
            ));
        }
    }
    Ok(())
}

/// # Safety
/// `vr` holds `nvr` and `value` `n_values` elements.
pub unsafe fn get_float64<E: Export>(
    c: Component,
    vr: *const u32,
    nvr: usize,
    value: *mut f64,
    n_values: usize,
) -> Status {
    const F: &str = "fmi3GetFloat64";
    getter::<E, f64>(
        c,
        F,
        Type3::Float64,
        (vr, nvr),
        (value, n_values),
        |f, vr, value| read_float64::<E>(f, vr, value),
    )
}

/// # Safety
/// As [`get_float64`].
pub unsafe fn set_float64<E: Export>(
    c: Component,
    vr: *const u32,
    nvr: usize,
    value: *const f64,
    n_values: usize,
) -> Status {
    const F: &str = "fmi3SetFloat64";
    setter::<E, f64>(
        c,
        F,
        Type3::Float64,
        (vr, nvr),
        (value, n_values),
        |f, vr, value| {
            for &v in vr {
                match var3::<E>(f, v)? {
                Var3::Time => {
                    return Err(format!(
                        "time (value reference {v}) is the independent variable: fmi3EnterInitializationMode's startTime, fmi3SetTime (Model Exchange) or fmi3DoStep (Co-Simulation) set it"
                    ))
                }
                Var3::EventIndicator => {
                    return Err(format!(
                        "the event indicator (value reference {v}) is computed, it cannot be set"
                    ))
                }
                Var3::Core(_) => {}
            }
            }
            f.core.set_real(vr, value)
        },
    )
}

/// # Safety
/// As [`get_float64`].
pub unsafe fn get_int32<E: Export>(
    c: Component,
    vr: *const u32,
    nvr: usize,
    value: *mut i32,
    n_values: usize,
) -> Status {
    getter::<E, i32>(
        c,
        "fmi3GetInt32",
        Type3::Int32,
        (vr, nvr),
        (value, n_values),
        |f, vr, value| f.core.get_integer(vr, value),
    )
}

/// # Safety
/// As [`get_float64`].
pub unsafe fn set_int32<E: Export>(
    c: Component,
    vr: *const u32,
    nvr: usize,
    value: *const i32,
    n_values: usize,
) -> Status {
    setter::<E, i32>(
        c,
        "fmi3SetInt32",
        Type3::Int32,
        (vr, nvr),
        (value, n_values),
        |f, vr, value| f.core.set_integer(vr, value),
    )
}

/// The Enumerations (`solver`, a system's enumeration parameters), which FMI 3.0 reads as
/// Int64.
///
/// # Safety
/// As [`get_float64`].
pub unsafe fn get_int64<E: Export>(
    c: Component,
    vr: *const u32,
    nvr: usize,
    value: *mut i64,
    n_values: usize,
) -> Status {
    getter::<E, i64>(
        c,
        "fmi3GetInt64",
        Type3::Int64,
        (vr, nvr),
        (value, n_values),
        |f, vr, value| {
            let mut v32 = vec![0; vr.len()];
            f.core.get_integer(vr, &mut v32)?;
            for (out, v) in value.iter_mut().zip(v32) {
                *out = v as i64;
            }
            Ok(())
        },
    )
}

/// # Safety
/// As [`get_float64`].
pub unsafe fn set_int64<E: Export>(
    c: Component,
    vr: *const u32,
    nvr: usize,
    value: *const i64,
    n_values: usize,
) -> Status {
    const F: &str = "fmi3SetInt64";
    setter::<E, i64>(
        c,
        F,
        Type3::Int64,
        (vr, nvr),
        (value, n_values),
        |f, vr, value| {
            let v32 = vr
                .iter()
                .zip(value)
                .map(|(&r, &v)| {
                    i32::try_from(v).map_err(|_| {
                        format!(
                            "{v} is not a value of {} (value reference {r})",
                            var_name::<E>(f, r)
                        )
                    })
                })
                .collect::<Result<Vec<i32>, String>>()?;
            f.core.set_integer(vr, &v32)
        },
    )
}

/// fmi3Get/Set of a type the model has no variables of (Float32, the small and unsigned
/// integers, Boolean, String, Binary): fmi3Error naming the first value reference;
/// nothing asked, nothing to refuse.
///
/// # Safety
/// `vr` points to `nvr` elements when `nvr > 0`.
pub unsafe fn no_such_type<E: Export>(
    c: Component,
    function: &'static str,
    gate: Gate,
    vr: *const u32,
    nvr: usize,
) -> Status {
    call3::<E>(c, function, gate, |f| {
        let vr = slice(vr, nvr, "valueReferences[]")?;
        if let Some(&v) = vr.first() {
            let what = match var3::<E>(f, v) {
                Ok(Var3::Core(ty)) => format!("a {} variable", ty.name()),
                Ok(_) => "a Float64 variable".into(),
                Err(e) => return Err(e),
            };
            return Err(format!(
                "value reference {v} ({}) is {what}; this model has no variables of this function's type",
                var_name::<E>(f, v)
            ));
        }
        Ok(Status::Ok)
    })
}

/// A function this FMU does not offer (clocks, configuration mode, scheduled execution,
/// variable dependencies): fmi3Error with one line.
pub fn not_offered<E: Export>(c: Component, function: &'static str, why: &str) -> Status {
    call3::<E>(c, function, ANY, |_| {
        Err(format!("not offered by this FMU ({why})"))
    })
}

/// Restores the core. The FMI 3.0 mode does not change (a Co-Simulation instance in Event
/// Mode stays there: only fmi3EnterStepMode leaves it), unless the restored core cannot be
/// in it.
///
/// # Safety
/// `state` is NULL or one of ours.
pub unsafe fn set_fmu_state<E: Export>(
    c: Component,
    (function, gate): gate::Row,
    state: FmuState,
) -> Status {
    call3::<E>(c, function, gate, |f| {
        let status = super::boundary::restore(c, &mut f.core, state)?;
        f.cs_event_mode &= matches!(f.core.mode(), Mode::Stepping | Mode::StepDiscarded);
        Ok(status)
    })
}

/// The argument arrays of fmi3GetDirectionalDerivative / fmi3GetAdjointDerivative.
pub struct Seeds {
    pub unknowns: *const u32,
    pub n_unknowns: usize,
    pub knowns: *const u32,
    pub n_knowns: usize,
    pub seed: *const f64,
    pub n_seed: usize,
    pub sensitivity: *mut f64,
    pub n_sensitivity: usize,
}

/// The arrays of a directional (`adjoint` false: seed per known, sensitivity per
/// unknown) or adjoint derivative (the other way round).
type SeedArrays<'a> = (&'a [u32], &'a [u32], &'a [f64], &'a mut [f64]);

impl Seeds {
    /// The four arrays, once their counts fit the derivative asked for.
    ///
    /// # Safety
    /// The arrays hold as many elements as their counts say.
    unsafe fn arrays<'a>(&self, adjoint: bool) -> Result<SeedArrays<'a>, String> {
        let (knowns, unknowns) = (("nKnowns", self.n_knowns), ("nUnknowns", self.n_unknowns));
        let (seeded, sensed) = if adjoint {
            (unknowns, knowns)
        } else {
            (knowns, unknowns)
        };
        if self.n_seed != seeded.1 || self.n_sensitivity != sensed.1 {
            return Err(format!(
                "nSeed = {} and nSensitivity = {} must equal {} = {} and {} = {}",
                self.n_seed, self.n_sensitivity, seeded.0, seeded.1, sensed.0, sensed.1
            ));
        }
        Ok((
            slice(self.unknowns, self.n_unknowns, "unknowns[]")?,
            slice(self.knowns, self.n_knowns, "knowns[]")?,
            slice(self.seed, self.n_seed, "seed[]")?,
            slice_mut(self.sensitivity, self.n_sensitivity, "sensitivity[]")?,
        ))
    }
}

/// fmi3GetDirectionalDerivative: sensitivity = J · seed (J = ∂unknowns/∂knowns, exact).
///
/// # Safety
/// The arrays hold as many elements as their counts say.
pub unsafe fn get_directional_derivative<E: Export>(c: Component, a: Seeds) -> Status {
    const F: &str = "fmi3GetDirectionalDerivative";
    call3::<E>(c, F, DERIVATIVES, |f| {
        let (unknowns, knowns, seed, out) = a.arrays(false)?;
        ok(f.core.directional_derivative(unknowns, knowns, seed, out))
    })
}

/// fmi3GetAdjointDerivative: sensitivity = Jᵀ · seed, from the same exact J as the
/// directional derivative, one column per known (J · e_j).
///
/// # Safety
/// The arrays hold as many elements as their counts say.
pub unsafe fn get_adjoint_derivative<E: Export>(c: Component, a: Seeds) -> Status {
    const F: &str = "fmi3GetAdjointDerivative";
    call3::<E>(c, F, DERIVATIVES, |f| {
        let (unknowns, knowns, seed, out) = a.arrays(true)?;
        if let Some(v) = seed.iter().find(|v| !v.is_finite()) {
            return Err(format!("a seed is not finite ({v})"));
        }
        // The loop below checks the unknowns only when there is a known to seed.
        f.core.check_unknowns(unknowns)?;
        let mut unit = vec![0.0; knowns.len()];
        let mut column = vec![0.0; unknowns.len()];
        let mut result = vec![0.0; knowns.len()];
        for j in 0..knowns.len() {
            unit.fill(0.0);
            unit[j] = 1.0;
            f.core
                .directional_derivative(unknowns, knowns, &unit, &mut column)?;
            result[j] = column.iter().zip(seed).map(|(c, s)| c * s).sum();
        }
        if let Some(v) = result.iter().find(|v| !v.is_finite()) {
            return Err(format!("a sensitivity is not finite ({v})"));
        }
        out.copy_from_slice(&result);
        Ok(Status::Ok)
    })
}

/// fmi3EvaluateDiscreteStates: the models have no discrete states, nothing to evaluate.
pub fn evaluate_discrete_states<E: Export>(c: Component) -> Status {
    const F: &str = "fmi3EvaluateDiscreteStates";
    call3::<E>(c, F, EVALUATE_DISCRETE_STATES, |_| Ok(Status::Ok))
}

/// Writes `value` through an fmi3Boolean out-pointer.
///
/// # Safety
/// `p` points to a writable fmi3Boolean.
pub(crate) unsafe fn put(p: *mut Bool3, value: bool) {
    *p = value as u8;
}
