//! The FMI 3.0 front-end of the C API: the same instance core as FMI 2.0, behind the
//! fmi3 functions (this file those both interfaces have; [`fmi3_cs`](super::fmi3_cs) and
//! [`fmi3_me`](super::fmi3_me) each interface's own).
//!
//! An FMI 3.0 instance is an [`Instance3`]: the core [`Instance`] and what FMI 3.0 adds —
//! Co-Simulation's Event Mode, the importer's `eventModeUsed` / `earlyReturnAllowed` and
//! its intermediateUpdate callback. Every function passes the guard with FMI 3.0's table
//! ([`machine3`], the only one checked), then calls the core. Lines go through the
//! importer's `logMessage`, naming the fmi3 function and using FMI 3.0's words.
//!
//! Variables: the value references of FMI 2.0, plus `time` (the independent variable) at
//! the first free value reference and, for a model with an event indicator, the indicator
//! at the next one ([`Layout::fmi3_extra_vrs`](crate::model::Layout::fmi3_extra_vrs)).
//! Types: Float64 (FMI 2.0's Real), Int32 (Integer) and Int64 (the Enumeration `solver`:
//! FMI 3.0 reads enumerations as Int64); every other type answers fmi3Error for any value
//! reference.

use super::{free_states_of, guard, ok, slice, slice_mut, Component, FmuState, Guarded};
use crate::fmi::machine::{Gate, Interface, Machine};
use crate::fmi::machine3::{self, State3};
use crate::fmi::{Export, Instance, Logger, Status};
use crate::model::{System, VarKind};
use std::ffi::{c_char, c_void, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};

pub use crate::fmi::logger::LogMessage3;

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

/// An FMI 3.0 instance: the core and what FMI 3.0 adds.
pub struct Instance3<M: System> {
    pub core: Instance<M>,
    /// Co-Simulation in Event Mode (the core stays in stepComplete underneath).
    pub(super) cs_event_mode: bool,
    /// fmi3InstantiateCoSimulation's arguments.
    pub(super) event_mode_used: bool,
    pub(super) early_return_allowed: bool,
    pub(super) intermediate_update: Option<IntermediateUpdate>,
    pub(super) env: *mut c_void,
}

impl<M: System> Instance3<M> {
    #[inline]
    pub fn state(&self) -> State3 {
        State3::of(self.core.machine(), self.cs_event_mode)
    }
}

/// FMI 3.0 reads the core's mode and its own Event Mode flag as its state.
impl<M: System> Guarded for Instance3<M> {
    fn logger(&self) -> &Logger {
        &self.core.logger
    }
    fn poison(&mut self) {
        self.core.poison()
    }
    fn allows(&self, gate: Gate) -> Result<(), String> {
        machine3::check(gate, self.state(), self.core.interface())
    }
}

pub(crate) type Inst3<E> = Instance3<<E as Export>::Model>;

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
    Ok(Var3::Core(match slot.kind {
        VarKind::SolverMethod => Type3::Int64,
        VarKind::SolverMaxSteps | VarKind::MeProjection => Type3::Int32,
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
        let info = E::info();
        let fail = |message: String| {
            logger.failure(Status::Error, &message);
            std::ptr::null_mut()
        };
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

/// # Safety
/// `c` is NULL or a live FMI 3.0 instance of this model.
pub unsafe fn free_instance<E: Export>(c: Component) {
    if c.is_null() {
        return;
    }
    let _ = catch_unwind(AssertUnwindSafe(|| {
        free_states_of(c);
        drop(Box::from_raw(c as *mut Inst3<E>))
    }));
}

/// # Safety
/// `categories` points to `n` C strings when `n > 0`.
pub unsafe fn set_debug_logging<E: Export>(
    c: Component,
    logging_on: Bool3,
    n: usize,
    categories: *const *const c_char,
) -> Status {
    const F: &str = "fmi3SetDebugLogging";
    call3::<E>(c, F, machine3::ANY, |f| {
        let ptrs = slice(categories, n, "categories[]")?;
        let mut names = Vec::with_capacity(n);
        for &p in ptrs {
            if p.is_null() {
                return Err("a category is NULL".to_string());
            }
            names.push(CStr::from_ptr(p).to_string_lossy().into_owned());
        }
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        ok(f.core.logger.set_debug_logging(logging_on != 0, &names))
    })
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
    call3::<E>(c, F, machine3::ENTER_INIT, |f| {
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
    call3::<E>(c, F, machine3::EXIT_INIT, |f| {
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
    call3::<E>(c, F, machine3::ENTER_EVENT_MODE, |f| {
        match f.core.interface() {
            Interface::ModelExchange => ok(f.core.enter_event_mode()),
            Interface::CoSimulation => {
                if !f.event_mode_used {
                    return Err(
                        "this Co-Simulation instance was made with eventModeUsed = false"
                            .to_string(),
                    );
                }
                f.cs_event_mode = true;
                Ok(Status::Ok)
            }
        }
    })
}

pub fn terminate<E: Export>(c: Component) -> Status {
    const F: &str = "fmi3Terminate";
    call3::<E>(c, F, machine3::TERMINATE, |f| {
        f.core.terminate()?;
        f.cs_event_mode = false;
        Ok(Status::Ok)
    })
}

pub fn reset<E: Export>(c: Component) -> Status {
    const F: &str = "fmi3Reset";
    call3::<E>(c, F, machine3::ANY, |f| {
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
    call3::<E>(c, function, machine3::GET, |f| {
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
    call3::<E>(c, function, machine3::SET, |f| {
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

/// The Enumeration `solver`, which FMI 3.0 reads as Int64.
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
            let v32 = value
                .iter()
                .map(|&v| i32::try_from(v).map_err(|_| format!("{v} is not a solver (1 … 12)")))
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
    call3::<E>(c, function, machine3::ANY, |_| {
        Err(format!("not offered by this FMU ({why})"))
    })
}

/// # Safety
/// `state` points to an `fmi3FMUState` (NULL or one of ours).
pub unsafe fn get_fmu_state<E: Export>(c: Component, state: *mut FmuState) -> Status {
    const F: &str = "fmi3GetFMUState";
    call3::<E>(c, F, machine3::FMU_STATE, |f| {
        super::get_fmu_state_of::<E>(c, &mut f.core, state)
    })
}

/// Restores the core. The FMI 3.0 mode does not change (a Co-Simulation instance in Event
/// Mode stays there: only fmi3EnterStepMode leaves it), unless the restored core cannot be
/// in it.
///
/// # Safety
/// `state` is NULL or one of ours.
pub unsafe fn set_fmu_state<E: Export>(c: Component, state: FmuState) -> Status {
    const F: &str = "fmi3SetFMUState";
    call3::<E>(c, F, machine3::FMU_STATE, |f| {
        let status = super::set_fmu_state_of::<E>(c, &mut f.core, state)?;
        f.cs_event_mode &= matches!(
            f.core.machine(),
            Machine::StepComplete | Machine::StepFailed
        );
        Ok(status)
    })
}

/// # Safety
/// `state` points to an `fmi3FMUState` (NULL or one of ours).
pub unsafe fn free_fmu_state<E: Export>(c: Component, state: *mut FmuState) -> Status {
    const F: &str = "fmi3FreeFMUState";
    call3::<E>(c, F, machine3::FMU_STATE, |_| {
        super::free_fmu_state_of::<E>(c, state)
    })
}

/// # Safety
/// `state` is one of ours; `size` points to a writable `size_t`.
pub unsafe fn serialized_fmu_state_size<E: Export>(
    c: Component,
    state: FmuState,
    size: *mut usize,
) -> Status {
    const F: &str = "fmi3SerializedFMUStateSize";
    call3::<E>(c, F, machine3::FMU_STATE, |f| {
        super::serialized_fmu_state_size_of::<E>(c, &f.core, state, size)
    })
}

/// # Safety
/// `state` is one of ours; `bytes` points to `size` writable bytes.
pub unsafe fn serialize_fmu_state<E: Export>(
    c: Component,
    state: FmuState,
    bytes: *mut u8,
    size: usize,
) -> Status {
    const F: &str = "fmi3SerializeFMUState";
    call3::<E>(c, F, machine3::FMU_STATE, |f| {
        super::serialize_fmu_state_of::<E>(c, &f.core, state, bytes, size)
    })
}

/// # Safety
/// `bytes` points to `size` bytes; `state` points to an `fmi3FMUState` (NULL or ours).
pub unsafe fn deserialize_fmu_state<E: Export>(
    c: Component,
    bytes: *const u8,
    size: usize,
    state: *mut FmuState,
) -> Status {
    const F: &str = "fmi3DeserializeFMUState";
    call3::<E>(c, F, machine3::FMU_STATE, |f| {
        super::deserialize_fmu_state_of::<E>(c, &f.core, bytes, size, state)
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

/// fmi3GetDirectionalDerivative: sensitivity = J · seed (J = ∂unknowns/∂knowns, exact).
///
/// # Safety
/// The arrays hold as many elements as their counts say.
pub unsafe fn get_directional_derivative<E: Export>(c: Component, a: Seeds) -> Status {
    const F: &str = "fmi3GetDirectionalDerivative";
    call3::<E>(c, F, machine3::DERIVATIVES, |f| {
        if a.n_seed != a.n_knowns || a.n_sensitivity != a.n_unknowns {
            return Err(format!(
                "nSeed = {} and nSensitivity = {} must equal nKnowns = {} and nUnknowns = {}",
                a.n_seed, a.n_sensitivity, a.n_knowns, a.n_unknowns
            ));
        }
        let unknowns = slice(a.unknowns, a.n_unknowns, "unknowns[]")?;
        let knowns = slice(a.knowns, a.n_knowns, "knowns[]")?;
        let seed = slice(a.seed, a.n_seed, "seed[]")?;
        let out = slice_mut(a.sensitivity, a.n_sensitivity, "sensitivity[]")?;
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
    call3::<E>(c, F, machine3::DERIVATIVES, |f| {
        if a.n_seed != a.n_unknowns || a.n_sensitivity != a.n_knowns {
            return Err(format!(
                "nSeed = {} and nSensitivity = {} must equal nUnknowns = {} and nKnowns = {}",
                a.n_seed, a.n_sensitivity, a.n_unknowns, a.n_knowns
            ));
        }
        let unknowns = slice(a.unknowns, a.n_unknowns, "unknowns[]")?;
        let knowns = slice(a.knowns, a.n_knowns, "knowns[]")?;
        let seed = slice(a.seed, a.n_seed, "seed[]")?;
        let out = slice_mut(a.sensitivity, a.n_sensitivity, "sensitivity[]")?;
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
    call3::<E>(c, F, machine3::EVALUATE_DISCRETE_STATES, |_| Ok(Status::Ok))
}

/// Writes `value` through an fmi3Boolean out-pointer.
///
/// # Safety
/// `p` points to a writable fmi3Boolean.
pub(crate) unsafe fn put(p: *mut Bool3, value: bool) {
    *p = value as u8;
}
