//! FMI 2.0's front-end: its state table (Co-Simulation, standard section 4.2.4; Model
//! Exchange, section 3.2.3) as data, its words, and its C marshalling of what both
//! interfaces have (instantiation, get/set, FMU state, directional derivatives, logging);
//! [`cs`] and [`me`] each interface's own.
//!
//! Every function is generic over the exported model and is called by a one-row
//! `extern "C"` symbol from [`export_fmu!`](crate::export_fmu), through the one
//! [`guard`](super::boundary::guard).
//!
//! FMI 2.0's states are the core's modes under FMI 2.0's names ([`State2::of`]). One enum
//! holds the states of both interfaces; an instance lives in those of its own, so a gate
//! may name states of both: a function shared by the two interfaces (fmi2GetReal,
//! fmi2GetFMUstate, …) has one gate, and its refusal lists only the states of the
//! caller's interface.

mod cs;
mod me;

pub use cs::*;
pub use me::*;

use super::boundary::*;
pub use super::boundary::{Component, FmuState};
use super::core::mode::states;
use super::gate::{self, gates, Gate, Table};
use super::CallbackFunctions;
use super::{Export, Instance, Interface, Logger, Mode, ResourceLocation, Status};
use crate::model::System;
use std::ffi::{c_char, c_int, c_uint, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};

states! {
    /// FMI 2.0's states. `StepInProgress` and `StepCanceled` never occur: doStep is
    /// synchronous (canRunAsynchronuously = false). `EventMode` and `ContinuousTimeMode` are
    /// Model Exchange's, `StepComplete` and `StepFailed` Co-Simulation's.
    pub enum State2 {
        Instantiated,
        InitializationMode,
        StepComplete [cs],
        StepFailed [cs],
        Terminated,
        Error,
        EventMode [me],
        ContinuousTimeMode [me],
    }
}

impl State2 {
    /// The FMI 2.0 state of an instance whose core is in `mode`.
    #[inline]
    pub fn of(mode: Mode) -> State2 {
        match mode {
            Mode::Instantiated => State2::Instantiated,
            Mode::Initializing => State2::InitializationMode,
            Mode::Stepping => State2::StepComplete,
            Mode::StepDiscarded => State2::StepFailed,
            Mode::Terminated => State2::Terminated,
            Mode::Error => State2::Error,
            Mode::Event => State2::EventMode,
            Mode::ContinuousTime => State2::ContinuousTimeMode,
        }
    }
}

impl Table for State2 {
    fn made_by(own: Interface) -> String {
        format!("fmuType {} in fmi2Instantiate", own.code())
    }
}

// FMI 2.0's table (sections 3.2.3 and 4.2.4).
#[rustfmt::skip]
gates! { State2;
    ANY = both[
        Instantiated, InitializationMode, StepComplete, StepFailed, Terminated, Error,
        EventMode, ContinuousTimeMode,
    ];
    SETUP_EXPERIMENT = both[Instantiated];
    ENTER_INIT = both[Instantiated];
    EXIT_INIT = both[InitializationMode];
    TERMINATE = both[StepComplete, StepFailed, EventMode, ContinuousTimeMode];
    GET = both[
        InitializationMode, StepComplete, StepFailed, EventMode, ContinuousTimeMode,
        Terminated, Error,
    ];
    /// fmi2SetReal: in Model Exchange's event and continuous-time modes only inputs may be
    /// set (checked per variable, as after initialisation in Co-Simulation).
    SET_REAL = both[
        Instantiated, InitializationMode, StepComplete, EventMode, ContinuousTimeMode,
    ];
    /// fmi2SetInteger: the Integer variables are fixed parameters; Model Exchange admits
    /// the call in event mode (for tunable ones, which these models do not have).
    SET_INTEGER = both[Instantiated, InitializationMode, StepComplete, EventMode];
    // Co-Simulation only.
    INPUT_DERIVATIVES = cs[Instantiated, InitializationMode, StepComplete];
    OUTPUT_DERIVATIVES = cs[StepComplete, StepFailed, Terminated, Error];
    DO_STEP = cs[StepComplete];
    CANCEL_STEP = cs[];
    STATUS = cs[StepComplete, StepFailed, Terminated];
    // Model Exchange only.
    ENTER_EVENT_MODE = me[EventMode, ContinuousTimeMode];
    NEW_DISCRETE_STATES = me[EventMode];
    ENTER_CONTINUOUS_TIME_MODE = me[EventMode];
    COMPLETED_INTEGRATOR_STEP = me[ContinuousTimeMode];
    SET_TIME = me[EventMode, ContinuousTimeMode];
    SET_CONTINUOUS_STATES = me[ContinuousTimeMode];
    GET_EVENT_INDICATORS = me[
        InitializationMode, EventMode, ContinuousTimeMode, Terminated, Error,
    ];
    GET_DERIVATIVES = me[EventMode, ContinuousTimeMode, Terminated, Error];
    GET_NOMINALS = me[Instantiated, EventMode, ContinuousTimeMode, Terminated, Error];
}
pub const RESET: Gate = ANY;
pub const FMU_STATE: Gate = ANY;
pub const DIRECTIONAL_DERIVATIVE: Gate = GET;
pub const GET_CONTINUOUS_STATES: Gate = GET_EVENT_INDICATORS;

/// An FMI 2.0 instance is the core itself: its state is the core's mode, under FMI 2.0's
/// names.
impl<M: System> Guarded for Instance<M> {
    type Model = M;
    fn core(&self) -> &Instance<M> {
        self
    }
    fn core_mut(&mut self) -> &mut Instance<M> {
        self
    }
    #[inline]
    fn allows(&self, gate: Gate) -> Result<(), String> {
        gate::check(gate, State2::of(self.mode()), self.interface())
    }
}

/// An FMI 2.0 instance of the exported model `E`.
pub type Inst<E> = Instance<<E as Export>::Model>;

/// [`guard`] for an FMI 2.0 instance.
#[inline(always)]
pub(crate) fn call<E: Export>(
    c: Component,
    function: &'static str,
    gate: Gate,
    body: impl FnOnce(&mut Inst<E>) -> Result<Status, String>,
) -> Status {
    guard::<Inst<E>>(c, function, gate, body)
}

pub fn get_types_platform() -> *const c_char {
    c"default".as_ptr()
}

pub fn get_version() -> *const c_char {
    c"2.0".as_ptr()
}

/// # Safety
/// Pointers as the FMI 2.0 standard describes for fmi2Instantiate.
pub unsafe fn instantiate<E: Export>(
    instance_name: *const c_char,
    fmu_type: c_int,
    guid: *const c_char,
    resource_location: *const c_char,
    functions: *const CallbackFunctions,
    _visible: c_int,
    logging_on: c_int,
) -> Component {
    let result = catch_unwind(AssertUnwindSafe(|| {
        let (callback, env) = match functions.as_ref() {
            Some(f) => (f.logger, f.component_environment),
            None => return std::ptr::null_mut(),
        };
        let name = if instance_name.is_null() {
            None
        } else {
            Some(CStr::from_ptr(instance_name).to_string_lossy().into_owned())
        };
        let logger = Logger::new(
            callback,
            env,
            name.as_deref().unwrap_or("?"),
            logging_on != 0,
        );
        logger.set_function("fmi2Instantiate");
        let fail = |message: String| {
            logger.failure(Status::Error, &message);
            std::ptr::null_mut()
        };
        let resources = ResourceLocation::from_c(resource_location, true);
        if let Err(e) = resources.and_then(|r| E::prepare(&r)) {
            return fail(e);
        }
        let info = E::info();
        match name.as_deref() {
            None | Some("") => return fail("instanceName is NULL or empty".into()),
            Some(_) => {}
        }
        let interface = match u8::try_from(fmu_type).ok().and_then(Interface::from_code) {
            Some(interface) => interface,
            None => {
                return fail(format!(
                    "fmuType {fmu_type} requested; {} offers fmi2ModelExchange = 0 and fmi2CoSimulation = 1",
                    info.name
                ))
            }
        };
        if guid.is_null() {
            return fail("fmuGUID is NULL".into());
        }
        let given = CStr::from_ptr(guid).to_string_lossy();
        if given != info.guid.as_str() {
            return fail(format!(
                "fmuGUID {given} does not match this binary's {} (modelDescription.xml and binary from different builds?)",
                info.guid
            ));
        }
        let instance: Box<Inst<E>> = Box::new(Instance::for_interface(info, logger, interface));
        Box::into_raw(instance) as Component
    }));
    result.unwrap_or(std::ptr::null_mut())
}

pub fn setup_experiment<E: Export>(
    c: Component,
    tolerance_defined: c_int,
    tolerance: f64,
    start_time: f64,
    stop_time_defined: c_int,
    stop_time: f64,
) -> Status {
    call::<E>(c, "fmi2SetupExperiment", SETUP_EXPERIMENT, |inst| {
        ok(inst.setup_experiment(
            (tolerance_defined != 0).then_some(tolerance),
            start_time,
            (stop_time_defined != 0).then_some(stop_time),
        ))
    })
}

pub fn enter_initialization_mode<E: Export>(c: Component) -> Status {
    call::<E>(c, "fmi2EnterInitializationMode", ENTER_INIT, |inst| {
        ok(inst.enter_initialization_mode())
    })
}

pub fn exit_initialization_mode<E: Export>(c: Component) -> Status {
    call::<E>(c, "fmi2ExitInitializationMode", EXIT_INIT, |inst| {
        inst.exit_initialization_mode()
    })
}

pub fn terminate<E: Export>(c: Component) -> Status {
    call::<E>(c, "fmi2Terminate", TERMINATE, |inst| ok(inst.terminate()))
}

pub fn reset<E: Export>(c: Component) -> Status {
    call::<E>(c, "fmi2Reset", RESET, |inst| ok(inst.reset()))
}

/// # Safety
/// `vr` and `value` point to `nvr` elements when `nvr > 0`.
pub unsafe fn get_real<E: Export>(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *mut f64,
) -> Status {
    call::<E>(c, "fmi2GetReal", GET, |inst| {
        let vr = slice(vr, nvr, "vr[]")?;
        let value = slice_mut(value, nvr, "value[]")?;
        ok(inst.get_real(vr, value))
    })
}

/// # Safety
/// As [`get_real`].
pub unsafe fn set_real<E: Export>(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *const f64,
) -> Status {
    call::<E>(c, "fmi2SetReal", SET_REAL, |inst| {
        let vr = slice(vr, nvr, "vr[]")?;
        let value = slice(value, nvr, "value[]")?;
        ok(inst.set_real(vr, value))
    })
}

/// # Safety
/// As [`get_real`].
pub unsafe fn get_integer<E: Export>(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *mut c_int,
) -> Status {
    call::<E>(c, "fmi2GetInteger", GET, |inst| {
        let vr = slice(vr, nvr, "vr[]")?;
        let value = slice_mut(value, nvr, "value[]")?;
        ok(inst.get_integer(vr, value))
    })
}

/// # Safety
/// As [`get_real`].
pub unsafe fn set_integer<E: Export>(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *const c_int,
) -> Status {
    call::<E>(c, "fmi2SetInteger", SET_INTEGER, |inst| {
        let vr = slice(vr, nvr, "vr[]")?;
        let value = slice(value, nvr, "value[]")?;
        ok(inst.set_integer(vr, value))
    })
}

/// fmi2Get/SetBoolean and fmi2Get/SetString: the models have no such variables.
///
/// # Safety
/// `vr` and `value` point to `nvr` elements when `nvr > 0`.
pub unsafe fn no_such_type<E: Export, T>(
    c: Component,
    function: &'static str,
    gate: Gate,
    vr: *const c_uint,
    nvr: usize,
    value: *const T,
) -> Status {
    call::<E>(c, function, gate, |inst| {
        let vr = slice(vr, nvr, "vr[]")?;
        slice(value, nvr, "value[]")?;
        ok(inst.no_variables_of_type(vr))
    })
}

/// The gates of fmi2Get/SetBoolean and fmi2Get/SetString (those of fmi2Get/SetInteger).
pub const GETTER: Gate = GET;

pub const SETTER: Gate = SET_INTEGER;

/// # Safety
/// The arrays hold `n_unknown` / `n_known` elements when those are positive.
pub unsafe fn get_directional_derivative<E: Export>(
    c: Component,
    unknown: *const c_uint,
    n_unknown: usize,
    known: *const c_uint,
    n_known: usize,
    dv_known: *const f64,
    dv_unknown: *mut f64,
) -> Status {
    const F: &str = "fmi2GetDirectionalDerivative";
    call::<E>(c, F, DIRECTIONAL_DERIVATIVE, |inst| {
        let unknown = slice(unknown, n_unknown, "vUnknown_ref[]")?;
        let known = slice(known, n_known, "vKnown_ref[]")?;
        let dv_known = slice(dv_known, n_known, "dvKnown[]")?;
        let dv_unknown = slice_mut(dv_unknown, n_unknown, "dvUnknown[]")?;
        ok(inst.directional_derivative(unknown, known, dv_known, dv_unknown))
    })
}
