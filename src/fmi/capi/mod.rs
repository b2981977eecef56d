//! The C side of the boundary: raw pointers in, checked Rust values out.
//!
//! Every function here is generic over the exported model and is called by a one-row
//! `extern "C"` symbol from [`export_fmu!`](crate::export_fmu). This module is FMI 2.0's
//! front-end for what both interfaces have (instantiation, get/set, FMU state, directional
//! derivatives, logging), [`cs`] and [`me`] each interface's own; [`fmi3`], [`fmi3_cs`]
//! and [`fmi3_me`] are FMI 3.0's. Each function goes through the one [`guard`], which
//! - checks its version's state table once (a [`Gate`] of `machine.rs` / `machine3.rs`),
//! - runs the body under `catch_unwind`, so no panic crosses into the host,
//! - turns every `Err` into Error and one line "function: message" through the logger,
//! - returns Warning from a call that logged a warning and would return OK;
//!
//! and the body rejects NULL pointers and impossible lengths before touching memory.

mod cs;
pub mod fmi3;
pub mod fmi3_cs;
pub mod fmi3_me;
mod me;

pub use cs::*;
pub use me::*;

use super::logger::CallbackFunctions;
use super::machine::{self, Gate, Interface};
use super::{Export, Instance, Logger, Snapshot, Status};
use crate::model::System;
use std::collections::BTreeMap;
use std::ffi::{c_char, c_int, c_uint, c_void, CStr};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Mutex, MutexGuard};

pub type Component = *mut c_void;
pub type FmuState = *mut c_void;

/// What an `fmi2FMUstate` points at. The tag and GUID let us reject a state pointer
/// from another model instead of reading it as ours.
struct StateBox {
    tag: [u8; 8],
    guid: &'static str,
    snapshot: Snapshot,
}

const STATE_TAG: [u8; 8] = *b"mbfmuFMS";

/// Every live FMU state of this binary (the address of its [`StateBox`]) with the instance
/// that made it (the address of its component). fmi2FreeInstance frees the states its
/// instance made and the importer did not free (FMI 2.0: freeing an instance frees all
/// memory its functions allocated); a pointer not in here (never ours, or freed already) is
/// refused before it is read, so it is never freed twice. Any live state of this model may
/// be set or serialized by any instance; only its maker frees it or writes into it.
static STATES: Mutex<BTreeMap<usize, usize>> = Mutex::new(BTreeMap::new());

fn states() -> MutexGuard<'static, BTreeMap<usize, usize>> {
    // The map is consistent after every operation: a panic elsewhere cannot spoil it.
    STATES
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A new FMU state of instance `c` holding `snapshot`, registered as its.
fn new_state<E: Export>(c: Component, snapshot: Snapshot) -> FmuState {
    let b = Box::new(StateBox {
        tag: STATE_TAG,
        guid: E::info().guid.as_str(),
        snapshot,
    });
    let state = Box::into_raw(b) as FmuState;
    states().insert(state as usize, c as usize);
    state
}

pub(crate) type Inst<E> = Instance<<E as Export>::Model>;

fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

/// What the guard needs of an instance of either FMI version.
pub(crate) trait Guarded {
    fn logger(&self) -> &Logger;
    /// Moves to the error state (after a panic was caught: nothing can be trusted).
    fn poison(&mut self);
    /// Fails unless this version's state table lets a function behind `gate` run now.
    fn allows(&self, gate: Gate) -> Result<(), String>;
}

/// FMI 2.0 reads the core's mode as its own state.
impl<M: System> Guarded for Instance<M> {
    fn logger(&self) -> &Logger {
        &self.logger
    }
    fn poison(&mut self) {
        Instance::poison(self)
    }
    fn allows(&self, gate: Gate) -> Result<(), String> {
        machine::check(gate, self.machine(), self.interface())
    }
}

/// The one guard of every C entry point that takes an instance: the NULL check, the debug
/// line, the state table (`gate`, checked once, before the body), the panic guard, every
/// `Err` as one line "function: message" and Error, and OK raised to Warning when the call
/// logged a warning.
#[inline(always)] // (each FMI function has its own body: one call site per instance)
pub(crate) fn guard<I: Guarded>(
    c: Component,
    function: &'static str,
    gate: Gate,
    body: impl FnOnce(&mut I) -> Result<Status, String>,
) -> Status {
    if c.is_null() {
        return Status::Error;
    }
    let ptr = c as *mut I;
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: `c` came from our fmi2Instantiate / fmi3Instantiate* (a Box of this
        // version's instance) and the standard forbids using it after freeing it or from
        // two threads at once.
        let inst = unsafe { &mut *ptr };
        let logger = inst.logger();
        logger.set_function(function);
        logger.take_warned(); // this call's warnings only
        if logger.debug_enabled() {
            logger.debug("called");
        }
        inst.allows(gate)?;
        body(inst)
    }));
    // SAFETY: as above; the body's borrow has ended.
    let inst = unsafe { &mut *ptr };
    match outcome {
        Ok(Ok(Status::Ok)) if inst.logger().take_warned() => Status::Warning,
        Ok(Ok(status)) => status,
        Ok(Err(message)) => {
            inst.logger().failure(Status::Error, &message);
            Status::Error
        }
        Err(payload) => {
            inst.poison();
            let text = panic_text(payload.as_ref());
            let _ = catch_unwind(AssertUnwindSafe(|| {
                inst.logger().failure(
                    Status::Error,
                    &format!("internal error, the instance is unusable: {text}"),
                )
            }));
            Status::Error
        }
    }
}

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

/// A slice from a C array, or an error naming the NULL argument.
///
/// # Safety
/// When `n > 0` and `ptr` is not NULL, `ptr` must point to `n` valid values.
pub(crate) unsafe fn slice<'a, T>(ptr: *const T, n: usize, what: &str) -> Result<&'a [T], String> {
    if n == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(format!("{what} is NULL but nvr = {n}"));
    }
    if n > isize::MAX as usize / std::mem::size_of::<T>().max(1) {
        return Err(format!("nvr = {n} is impossibly large"));
    }
    Ok(std::slice::from_raw_parts(ptr, n))
}

/// # Safety
/// As [`slice`], for writing.
pub(crate) unsafe fn slice_mut<'a, T>(
    ptr: *mut T,
    n: usize,
    what: &str,
) -> Result<&'a mut [T], String> {
    if n == 0 {
        return Ok(&mut []);
    }
    if ptr.is_null() {
        return Err(format!("{what} is NULL but nvr = {n}"));
    }
    if n > isize::MAX as usize / std::mem::size_of::<T>().max(1) {
        return Err(format!("nvr = {n} is impossibly large"));
    }
    Ok(std::slice::from_raw_parts_mut(ptr, n))
}

pub(crate) fn ok(r: Result<(), String>) -> Result<Status, String> {
    r.map(|()| Status::Ok)
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
    _resource_location: *const c_char,
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
        let info = E::info();
        logger.set_function("fmi2Instantiate");
        let fail = |message: String| {
            logger.failure(Status::Error, &message);
            std::ptr::null_mut()
        };
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

/// Frees the instance and every FMU state it made that the importer did not free.
///
/// # Safety
/// `c` is NULL or a live instance of this model.
pub unsafe fn free_instance<E: Export>(c: Component) {
    if c.is_null() {
        return;
    }
    let _ = catch_unwind(AssertUnwindSafe(|| {
        free_states_of(c);
        drop(Box::from_raw(c as *mut Inst<E>))
    }));
}

/// Frees every FMU state instance `c` made that the importer did not free.
///
/// # Safety
/// Called while freeing `c`: no call of it runs.
pub(crate) unsafe fn free_states_of(c: Component) {
    {
        let owned: Vec<usize> = {
            let mut map = states();
            let owned: Vec<usize> = map
                .iter()
                .filter(|(_, &owner)| owner == c as usize)
                .map(|(&state, _)| state)
                .collect();
            for state in &owned {
                map.remove(state);
            }
            owned
        };
        for state in owned {
            // SAFETY: registered by new_state from a Box<StateBox>, removed from the
            // registry just now, so freed exactly once.
            drop(Box::from_raw(state as *mut StateBox));
        }
    }
}

/// # Safety
/// `categories` points to `n` C strings when `n > 0`.
pub unsafe fn set_debug_logging<E: Export>(
    c: Component,
    logging_on: c_int,
    n: usize,
    categories: *const *const c_char,
) -> Status {
    call::<E>(c, "fmi2SetDebugLogging", machine::ANY, |inst| {
        let ptrs = slice(categories, n, "categories[]")?;
        let mut names = Vec::with_capacity(n);
        for &p in ptrs {
            if p.is_null() {
                return Err("a category is NULL".into());
            }
            names.push(CStr::from_ptr(p).to_string_lossy().into_owned());
        }
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        ok(inst.logger.set_debug_logging(logging_on != 0, &names))
    })
}

pub fn setup_experiment<E: Export>(
    c: Component,
    tolerance_defined: c_int,
    tolerance: f64,
    start_time: f64,
    stop_time_defined: c_int,
    stop_time: f64,
) -> Status {
    call::<E>(
        c,
        "fmi2SetupExperiment",
        machine::SETUP_EXPERIMENT,
        |inst| {
            ok(inst.setup_experiment(
                (tolerance_defined != 0).then_some(tolerance),
                start_time,
                (stop_time_defined != 0).then_some(stop_time),
            ))
        },
    )
}

pub fn enter_initialization_mode<E: Export>(c: Component) -> Status {
    call::<E>(
        c,
        "fmi2EnterInitializationMode",
        machine::ENTER_INIT,
        |inst| ok(inst.enter_initialization_mode()),
    )
}

pub fn exit_initialization_mode<E: Export>(c: Component) -> Status {
    call::<E>(
        c,
        "fmi2ExitInitializationMode",
        machine::EXIT_INIT,
        |inst| inst.exit_initialization_mode(),
    )
}

pub fn terminate<E: Export>(c: Component) -> Status {
    call::<E>(c, "fmi2Terminate", machine::TERMINATE, |inst| {
        ok(inst.terminate())
    })
}

pub fn reset<E: Export>(c: Component) -> Status {
    call::<E>(c, "fmi2Reset", machine::RESET, |inst| ok(inst.reset()))
}

/// # Safety
/// `vr` and `value` point to `nvr` elements when `nvr > 0`.
pub unsafe fn get_real<E: Export>(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *mut f64,
) -> Status {
    call::<E>(c, "fmi2GetReal", machine::GET, |inst| {
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
    call::<E>(c, "fmi2SetReal", machine::SET_REAL, |inst| {
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
    call::<E>(c, "fmi2GetInteger", machine::GET, |inst| {
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
    call::<E>(c, "fmi2SetInteger", machine::SET_INTEGER, |inst| {
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
pub const GETTER: Gate = machine::GET;
pub const SETTER: Gate = machine::SET_INTEGER;

/// Who may use an FMU state in a call.
#[derive(Clone, Copy, PartialEq)]
enum Use {
    /// Any instance of the model: the state is only read.
    Read,
    /// Only the instance that made it: the state is written or freed.
    Own,
}

/// The FMU state behind `state`, if it is a live one of this model (and made by `c` for
/// [`Use::Own`]); checked in the registry before the pointer is read.
///
/// # Safety
/// A registered pointer is a live `Box<StateBox>`; no other thread uses the same state
/// during the call (the standard's rule for an instance and what it made).
unsafe fn state_ref<'a, E: Export>(
    c: Component,
    state: FmuState,
    access: Use,
) -> Result<&'a mut StateBox, String> {
    if state.is_null() {
        return Err("FMUstate is NULL".to_string());
    }
    match states().get(&(state as usize)) {
        None => {
            return Err(format!(
                "FMUstate {state:p} is not a live FMU state of this FMU (never made by it, or freed already)"
            ))
        }
        Some(&owner) if access == Use::Own && owner != c as usize => {
            return Err(format!(
                "FMUstate {state:p} was made by another instance; only that one may free or overwrite it"
            ))
        }
        Some(_) => {}
    }
    let b = &mut *(state as *mut StateBox);
    if b.tag != STATE_TAG || b.guid != E::info().guid {
        return Err("FMUstate was not made by this model".to_string());
    }
    Ok(b)
}

/// # Safety
/// `state` points to an `fmi2FMUstate` (NULL or one of ours).
pub unsafe fn get_fmu_state<E: Export>(c: Component, state: *mut FmuState) -> Status {
    const F: &str = "fmi2GetFMUstate";
    call::<E>(c, F, machine::FMU_STATE, |inst| {
        get_fmu_state_of::<E>(c, inst, state)
    })
}

/// The body of fmi2GetFMUstate and fmi3GetFMUState: `c` is the instance's handle (the
/// owner recorded for the state).
///
/// # Safety
/// As [`get_fmu_state`].
pub(crate) unsafe fn get_fmu_state_of<E: Export>(
    c: Component,
    inst: &mut Inst<E>,
    state: *mut FmuState,
) -> Result<Status, String> {
    if state.is_null() {
        return Err("FMUstate is NULL".to_string());
    }
    let snapshot = inst.snapshot();
    if (*state).is_null() {
        *state = new_state::<E>(c, snapshot);
    } else {
        state_ref::<E>(c, *state, Use::Own)?.snapshot = snapshot;
    }
    Ok(Status::Ok)
}

/// # Safety
/// `state` is NULL or one of ours.
pub unsafe fn set_fmu_state<E: Export>(c: Component, state: FmuState) -> Status {
    const F: &str = "fmi2SetFMUstate";
    call::<E>(c, F, machine::FMU_STATE, |inst| {
        set_fmu_state_of::<E>(c, inst, state)
    })
}

/// The body of fmi2SetFMUstate and fmi3SetFMUState.
///
/// # Safety
/// As [`set_fmu_state`].
pub(crate) unsafe fn set_fmu_state_of<E: Export>(
    c: Component,
    inst: &mut Inst<E>,
    state: FmuState,
) -> Result<Status, String> {
    let b = state_ref::<E>(c, state, Use::Read)?;
    ok(inst.restore(&b.snapshot))
}

/// # Safety
/// `state` points to an `fmi2FMUstate` (NULL or one of ours).
pub unsafe fn free_fmu_state<E: Export>(c: Component, state: *mut FmuState) -> Status {
    const F: &str = "fmi2FreeFMUstate";
    call::<E>(c, F, machine::FMU_STATE, |_| {
        free_fmu_state_of::<E>(c, state)
    })
}

/// The body of fmi2FreeFMUstate and fmi3FreeFMUState.
///
/// # Safety
/// As [`free_fmu_state`].
pub(crate) unsafe fn free_fmu_state_of<E: Export>(
    c: Component,
    state: *mut FmuState,
) -> Result<Status, String> {
    if state.is_null() {
        return Err("FMUstate is NULL".to_string());
    }
    if (*state).is_null() {
        return Ok(Status::Ok);
    }
    state_ref::<E>(c, *state, Use::Own)?;
    states().remove(&(*state as usize));
    // SAFETY: a live Box<StateBox> of this instance, just taken out of the registry.
    drop(Box::from_raw(*state as *mut StateBox));
    *state = std::ptr::null_mut();
    Ok(Status::Ok)
}

/// # Safety
/// `state` is one of ours; `size` points to a writable `size_t`.
pub unsafe fn serialized_fmu_state_size<E: Export>(
    c: Component,
    state: FmuState,
    size: *mut usize,
) -> Status {
    const F: &str = "fmi2SerializedFMUstateSize";
    call::<E>(c, F, machine::FMU_STATE, |inst| {
        serialized_fmu_state_size_of::<E>(c, inst, state, size)
    })
}

/// The body of fmi2SerializedFMUstateSize and fmi3SerializedFMUStateSize.
///
/// # Safety
/// As [`serialized_fmu_state_size`].
pub(crate) unsafe fn serialized_fmu_state_size_of<E: Export>(
    c: Component,
    inst: &Inst<E>,
    state: FmuState,
    size: *mut usize,
) -> Result<Status, String> {
    let b = state_ref::<E>(c, state, Use::Read)?;
    if size.is_null() {
        return Err("size is NULL".to_string());
    }
    *size = inst.serialize(&b.snapshot).len();
    Ok(Status::Ok)
}

/// # Safety
/// `state` is one of ours; `bytes` points to `size` writable bytes.
pub unsafe fn serialize_fmu_state<E: Export>(
    c: Component,
    state: FmuState,
    bytes: *mut c_char,
    size: usize,
) -> Status {
    const F: &str = "fmi2SerializeFMUstate";
    call::<E>(c, F, machine::FMU_STATE, |inst| {
        serialize_fmu_state_of::<E>(c, inst, state, bytes as *mut u8, size)
    })
}

/// The body of fmi2SerializeFMUstate and fmi3SerializeFMUState.
///
/// # Safety
/// As [`serialize_fmu_state`].
pub(crate) unsafe fn serialize_fmu_state_of<E: Export>(
    c: Component,
    inst: &Inst<E>,
    state: FmuState,
    bytes: *mut u8,
    size: usize,
) -> Result<Status, String> {
    let b = state_ref::<E>(c, state, Use::Read)?;
    let blob = inst.serialize(&b.snapshot);
    if size != blob.len() {
        return Err(format!(
            "size {size} differs from the serialized size {}",
            blob.len()
        ));
    }
    let out = slice_mut(bytes, size, "serializedState[]")?;
    out.copy_from_slice(&blob);
    Ok(Status::Ok)
}

/// # Safety
/// `bytes` points to `size` bytes; `state` points to an `fmi2FMUstate` (NULL or ours).
pub unsafe fn deserialize_fmu_state<E: Export>(
    c: Component,
    bytes: *const c_char,
    size: usize,
    state: *mut FmuState,
) -> Status {
    const F: &str = "fmi2DeSerializeFMUstate";
    call::<E>(c, F, machine::FMU_STATE, |inst| {
        deserialize_fmu_state_of::<E>(c, inst, bytes as *const u8, size, state)
    })
}

/// The body of fmi2DeSerializeFMUstate and fmi3DeserializeFMUState.
///
/// # Safety
/// As [`deserialize_fmu_state`].
pub(crate) unsafe fn deserialize_fmu_state_of<E: Export>(
    c: Component,
    inst: &Inst<E>,
    bytes: *const u8,
    size: usize,
    state: *mut FmuState,
) -> Result<Status, String> {
    if state.is_null() {
        return Err("FMUstate is NULL".to_string());
    }
    let blob = slice(bytes, size, "serializedState[]")?;
    let snapshot = inst.deserialize(blob)?;
    if (*state).is_null() {
        *state = new_state::<E>(c, snapshot);
    } else {
        state_ref::<E>(c, *state, Use::Own)?.snapshot = snapshot;
    }
    Ok(Status::Ok)
}

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
    call::<E>(c, F, machine::DIRECTIONAL_DERIVATIVE, |inst| {
        let unknown = slice(unknown, n_unknown, "vUnknown_ref[]")?;
        let known = slice(known, n_known, "vKnown_ref[]")?;
        let dv_known = slice(dv_known, n_known, "dvKnown[]")?;
        let dv_unknown = slice_mut(dv_unknown, n_unknown, "dvUnknown[]")?;
        ok(inst.directional_derivative(unknown, known, dv_known, dv_unknown))
    })
}

/// `mbfmu_describe` (not FMI): the packager's questions to the compiled model, answered by
/// `respond` (`describe::respond::<Model>`, wired by `export_fmu!` so this layer does not
/// import the ones above). Returns a string for [`free_string`], or NULL on a NULL request
/// or a panic.
///
/// # Safety
/// `request` is NULL or a NUL-terminated string.
pub unsafe fn describe(request: *const c_char, respond: fn(&str) -> String) -> *mut c_char {
    if request.is_null() {
        return std::ptr::null_mut();
    }
    catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: non-null and NUL-terminated (the caller's contract).
        let request = unsafe { CStr::from_ptr(request) }.to_string_lossy();
        // The protocol's text never holds a NUL; replace one rather than fail.
        let answer = respond(&request).replace('\0', "\u{fffd}");
        std::ffi::CString::new(answer)
            .expect("NULs replaced")
            .into_raw()
    }))
    .unwrap_or(std::ptr::null_mut())
}

/// `mbfmu_free`: frees what [`describe`] returned, with this library's allocator.
///
/// # Safety
/// `text` is NULL or a pointer returned by [`describe`] of this library, not yet freed.
pub unsafe fn free_string(text: *mut c_char) {
    if !text.is_null() {
        // SAFETY: it came from CString::into_raw (the caller's contract).
        drop(unsafe { std::ffi::CString::from_raw(text) });
    }
}
