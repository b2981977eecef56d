//! The C side of the boundary: raw pointers in, checked Rust values out.
//!
//! Every function here is generic over the exported model and is called by a one-line
//! `extern "C"` symbol from [`export_fmu!`](crate::export_fmu): this module the functions
//! both interfaces have (instantiation, get/set, FMU state, directional derivatives,
//! logging), [`cs`] Co-Simulation's own, [`me`] Model Exchange's own. Each one:
//! - rejects NULL pointers and impossible lengths before touching memory,
//! - runs its body under `catch_unwind`, so no panic crosses into the host,
//! - turns every `Err` into fmi2Error and one line through the logger,
//! - returns fmi2Warning from a call that logged a warning and would return fmi2OK.

mod cs;
pub mod fmi3;
pub mod fmi3_cs;
pub mod fmi3_me;
mod me;

pub use cs::*;
pub use me::*;

use super::logger::CallbackFunctions;
use super::machine::{self, Interface};
use super::{Export, Instance, Logger, Snapshot, Status};
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

/// Runs `body` on the instance behind `c`: NULL check, debug log, panic guard, error log,
/// and fmi2OK raised to fmi2Warning when the body logged a warning.
#[inline(always)] // (each FMI function has its own body: one call site per instance)
pub(crate) fn call<E: Export>(
    c: Component,
    function: &str,
    body: impl FnOnce(&mut Inst<E>) -> Result<Status, String>,
) -> Status {
    if c.is_null() {
        return Status::Error;
    }
    let ptr = c as *mut Inst<E>;
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: `c` came from our fmi2Instantiate (a Box<Instance>) and the standard
        // forbids using it after fmi2FreeInstance or from two threads at once.
        let inst = unsafe { &mut *ptr };
        inst.logger.take_warned(); // this call's warnings only
        if inst.logger.debug_enabled() {
            inst.logger.debug(&format!("{function} called"));
        }
        body(inst)
    }));
    // SAFETY: as above; the body's borrow has ended.
    let inst = unsafe { &mut *ptr };
    match outcome {
        Ok(Ok(Status::Ok)) if inst.logger.take_warned() => Status::Warning,
        Ok(Ok(status)) => status,
        Ok(Err(message)) => {
            inst.logger.failure(Status::Error, &message);
            Status::Error
        }
        Err(payload) => {
            inst.poison();
            let text = panic_text(payload.as_ref());
            let _ = catch_unwind(AssertUnwindSafe(|| {
                inst.logger.failure(
                    Status::Error,
                    &format!("{function}: internal error, the instance is unusable: {text}"),
                )
            }));
            Status::Error
        }
    }
}

/// A slice from a C array, or an error naming the NULL argument.
///
/// # Safety
/// When `n > 0` and `ptr` is not NULL, `ptr` must point to `n` valid values.
pub(crate) unsafe fn slice<'a, T>(
    ptr: *const T,
    n: usize,
    what: &str,
    function: &str,
) -> Result<&'a [T], String> {
    if n == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(format!("{function}: {what} is NULL but nvr = {n}"));
    }
    if n > isize::MAX as usize / std::mem::size_of::<T>().max(1) {
        return Err(format!("{function}: nvr = {n} is impossibly large"));
    }
    Ok(std::slice::from_raw_parts(ptr, n))
}

/// # Safety
/// As [`slice`], for writing.
pub(crate) unsafe fn slice_mut<'a, T>(
    ptr: *mut T,
    n: usize,
    what: &str,
    function: &str,
) -> Result<&'a mut [T], String> {
    if n == 0 {
        return Ok(&mut []);
    }
    if ptr.is_null() {
        return Err(format!("{function}: {what} is NULL but nvr = {n}"));
    }
    if n > isize::MAX as usize / std::mem::size_of::<T>().max(1) {
        return Err(format!("{function}: nvr = {n} is impossibly large"));
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
        let fail = |message: String| {
            logger.failure(Status::Error, &format!("fmi2Instantiate: {message}"));
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
    call::<E>(c, "fmi2SetDebugLogging", |inst| {
        inst.require(machine::ANY, "fmi2SetDebugLogging")?;
        let ptrs = slice(categories, n, "categories[]", "fmi2SetDebugLogging")?;
        let mut names = Vec::with_capacity(n);
        for &p in ptrs {
            if p.is_null() {
                return Err("fmi2SetDebugLogging: a category is NULL".into());
            }
            names.push(CStr::from_ptr(p).to_string_lossy().into_owned());
        }
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        ok(inst
            .logger
            .set_debug_logging(logging_on != 0, &names)
            .map_err(|e| format!("fmi2SetDebugLogging: {e}")))
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
    call::<E>(c, "fmi2SetupExperiment", |inst| {
        ok(inst.setup_experiment(
            (tolerance_defined != 0).then_some(tolerance),
            start_time,
            (stop_time_defined != 0).then_some(stop_time),
        ))
    })
}

pub fn enter_initialization_mode<E: Export>(c: Component) -> Status {
    call::<E>(c, "fmi2EnterInitializationMode", |inst| {
        ok(inst.enter_initialization_mode())
    })
}

pub fn exit_initialization_mode<E: Export>(c: Component) -> Status {
    call::<E>(c, "fmi2ExitInitializationMode", |inst| {
        inst.exit_initialization_mode()
    })
}

pub fn terminate<E: Export>(c: Component) -> Status {
    call::<E>(c, "fmi2Terminate", |inst| ok(inst.terminate()))
}

pub fn reset<E: Export>(c: Component) -> Status {
    call::<E>(c, "fmi2Reset", |inst| ok(inst.reset()))
}

/// # Safety
/// `vr` and `value` point to `nvr` elements when `nvr > 0`.
pub unsafe fn get_real<E: Export>(
    c: Component,
    vr: *const c_uint,
    nvr: usize,
    value: *mut f64,
) -> Status {
    call::<E>(c, "fmi2GetReal", |inst| {
        let vr = slice(vr, nvr, "vr[]", "fmi2GetReal")?;
        let value = slice_mut(value, nvr, "value[]", "fmi2GetReal")?;
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
    call::<E>(c, "fmi2SetReal", |inst| {
        let vr = slice(vr, nvr, "vr[]", "fmi2SetReal")?;
        let value = slice(value, nvr, "value[]", "fmi2SetReal")?;
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
    call::<E>(c, "fmi2GetInteger", |inst| {
        let vr = slice(vr, nvr, "vr[]", "fmi2GetInteger")?;
        let value = slice_mut(value, nvr, "value[]", "fmi2GetInteger")?;
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
    call::<E>(c, "fmi2SetInteger", |inst| {
        let vr = slice(vr, nvr, "vr[]", "fmi2SetInteger")?;
        let value = slice(value, nvr, "value[]", "fmi2SetInteger")?;
        ok(inst.set_integer(vr, value))
    })
}

/// fmi2Get/SetBoolean and fmi2Get/SetString: the models have no such variables.
///
/// # Safety
/// `vr` and `value` point to `nvr` elements when `nvr > 0`.
pub unsafe fn no_such_type<E: Export, T>(
    c: Component,
    function: &str,
    mask: u32,
    vr: *const c_uint,
    nvr: usize,
    value: *const T,
) -> Status {
    call::<E>(c, function, |inst| {
        let vr = slice(vr, nvr, "vr[]", function)?;
        slice(value, nvr, "value[]", function)?;
        ok(inst.no_variables_of_type(function, mask, vr))
    })
}

pub const GET_MASK: u32 = machine::GET;
pub const SET_MASK: u32 = machine::SET_INTEGER;

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
    function: &str,
) -> Result<&'a mut StateBox, String> {
    if state.is_null() {
        return Err(format!("{function}: FMUstate is NULL"));
    }
    match states().get(&(state as usize)) {
        None => {
            return Err(format!(
                "{function}: FMUstate {state:p} is not a live FMU state of this FMU (never made by it, or freed already)"
            ))
        }
        Some(&owner) if access == Use::Own && owner != c as usize => {
            return Err(format!(
                "{function}: FMUstate {state:p} was made by another instance; only that one may free or overwrite it"
            ))
        }
        Some(_) => {}
    }
    let b = &mut *(state as *mut StateBox);
    if b.tag != STATE_TAG || b.guid != E::info().guid {
        return Err(format!("{function}: FMUstate was not made by this model"));
    }
    Ok(b)
}

/// # Safety
/// `state` points to an `fmi2FMUstate` (NULL or one of ours).
pub unsafe fn get_fmu_state<E: Export>(c: Component, state: *mut FmuState) -> Status {
    const F: &str = "fmi2GetFMUstate";
    call::<E>(c, F, |inst| {
        inst.require(machine::FMU_STATE, F)?;
        get_fmu_state_of::<E>(c, inst, state, F)
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
    function: &str,
) -> Result<Status, String> {
    if state.is_null() {
        return Err(format!("{function}: FMUstate is NULL"));
    }
    let snapshot = inst.snapshot();
    if (*state).is_null() {
        *state = new_state::<E>(c, snapshot);
    } else {
        state_ref::<E>(c, *state, Use::Own, function)?.snapshot = snapshot;
    }
    Ok(Status::Ok)
}

/// # Safety
/// `state` is NULL or one of ours.
pub unsafe fn set_fmu_state<E: Export>(c: Component, state: FmuState) -> Status {
    const F: &str = "fmi2SetFMUstate";
    call::<E>(c, F, |inst| set_fmu_state_of::<E>(c, inst, state, F))
}

/// The body of fmi2SetFMUstate and fmi3SetFMUState.
///
/// # Safety
/// As [`set_fmu_state`].
pub(crate) unsafe fn set_fmu_state_of<E: Export>(
    c: Component,
    inst: &mut Inst<E>,
    state: FmuState,
    function: &str,
) -> Result<Status, String> {
    let b = state_ref::<E>(c, state, Use::Read, function)?;
    ok(inst.restore(&b.snapshot))
}

/// # Safety
/// `state` points to an `fmi2FMUstate` (NULL or one of ours).
pub unsafe fn free_fmu_state<E: Export>(c: Component, state: *mut FmuState) -> Status {
    const F: &str = "fmi2FreeFMUstate";
    call::<E>(c, F, |inst| {
        inst.require(machine::FMU_STATE, F)?;
        free_fmu_state_of::<E>(c, state, F)
    })
}

/// The body of fmi2FreeFMUstate and fmi3FreeFMUState.
///
/// # Safety
/// As [`free_fmu_state`].
pub(crate) unsafe fn free_fmu_state_of<E: Export>(
    c: Component,
    state: *mut FmuState,
    function: &str,
) -> Result<Status, String> {
    if state.is_null() {
        return Err(format!("{function}: FMUstate is NULL"));
    }
    if (*state).is_null() {
        return Ok(Status::Ok);
    }
    state_ref::<E>(c, *state, Use::Own, function)?;
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
    call::<E>(c, F, |inst| {
        inst.require(machine::FMU_STATE, F)?;
        serialized_fmu_state_size_of::<E>(c, inst, state, size, F)
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
    function: &str,
) -> Result<Status, String> {
    let b = state_ref::<E>(c, state, Use::Read, function)?;
    if size.is_null() {
        return Err(format!("{function}: size is NULL"));
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
    call::<E>(c, F, |inst| {
        inst.require(machine::FMU_STATE, F)?;
        serialize_fmu_state_of::<E>(c, inst, state, bytes as *mut u8, size, F)
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
    function: &str,
) -> Result<Status, String> {
    let b = state_ref::<E>(c, state, Use::Read, function)?;
    let blob = inst.serialize(&b.snapshot);
    if size != blob.len() {
        return Err(format!(
            "{function}: size {size} differs from the serialized size {}",
            blob.len()
        ));
    }
    let out = slice_mut(bytes, size, "serializedState[]", function)?;
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
    call::<E>(c, F, |inst| {
        inst.require(machine::FMU_STATE, F)?;
        deserialize_fmu_state_of::<E>(c, inst, bytes as *const u8, size, state, F)
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
    function: &str,
) -> Result<Status, String> {
    if state.is_null() {
        return Err(format!("{function}: FMUstate is NULL"));
    }
    let blob = slice(bytes, size, "serializedState[]", function)?;
    let snapshot = inst.deserialize(blob)?;
    if (*state).is_null() {
        *state = new_state::<E>(c, snapshot);
    } else {
        state_ref::<E>(c, *state, Use::Own, function)?.snapshot = snapshot;
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
    call::<E>(c, F, |inst| {
        let unknown = slice(unknown, n_unknown, "vUnknown_ref[]", F)?;
        let known = slice(known, n_known, "vKnown_ref[]", F)?;
        let dv_known = slice(dv_known, n_known, "dvKnown[]", F)?;
        let dv_unknown = slice_mut(dv_unknown, n_unknown, "dvUnknown[]", F)?;
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
