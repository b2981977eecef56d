//! The C side of the boundary that every front-end shares: raw pointers in, checked Rust
//! values out.
//!
//! Every C entry point that takes an instance goes through the one [`guard`], which
//! - checks the caller's version's state table once (a [`Gate`], see `gate.rs`),
//! - runs the body under `catch_unwind`, so no panic crosses into the host,
//! - turns every `Err` into Error and one line "function: message" through the logger,
//! - returns Warning from a call that logged a warning and would return OK;
//!
//! and the body rejects NULL pointers and impossible lengths ([`slice`], [`slice_mut`])
//! before touching memory. The FMU states live here too (one registry for both versions:
//! a state pointer is checked in it before it is read), and `mbfmu_describe`'s glue.

use super::gate::{Gate, Row};
use super::{Instance, Snapshot, Status};
use crate::model::System;
use std::collections::BTreeMap;
use std::ffi::{c_char, c_void, CStr};
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
fn new_state(c: Component, guid: &'static str, snapshot: Snapshot) -> FmuState {
    let b = Box::new(StateBox {
        tag: STATE_TAG,
        guid,
        snapshot,
    });
    let state = Box::into_raw(b) as FmuState;
    states().insert(state as usize, c as usize);
    state
}

fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

/// An instance of either FMI version, as the guard and the shared bodies see it: the core
/// it wraps and its version's state table.
pub trait Guarded {
    type Model: System;
    fn core(&self) -> &Instance<Self::Model>;
    fn core_mut(&mut self) -> &mut Instance<Self::Model>;
    /// Fails unless this version's state table lets a function behind `gate` run now.
    fn allows(&self, gate: Gate) -> Result<(), String>;
}

/// The one guard of every C entry point that takes an instance: the NULL check, the debug
/// line, the state table (`gate`, checked once, before the body), the panic guard, every
/// `Err` as one line "function: message" and Error, and OK raised to Warning when the call
/// logged a warning.
#[inline(always)] // (each FMI function has its own body: one call site per instance)
pub fn guard<I: Guarded>(
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
        let logger = &inst.core().logger;
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
        Ok(Ok(Status::Ok)) if inst.core().logger.take_warned() => Status::Warning,
        Ok(Ok(status)) => status,
        Ok(Err(message)) => {
            inst.core().logger.failure(Status::Error, &message);
            Status::Error
        }
        Err(payload) => {
            inst.core_mut().poison();
            let text = panic_text(payload.as_ref());
            let _ = catch_unwind(AssertUnwindSafe(|| {
                inst.core().logger.failure(
                    Status::Error,
                    &format!("internal error, the instance is unusable: {text}"),
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

/// OK from a call that answers nothing else.
pub fn ok(r: Result<(), String>) -> Result<Status, String> {
    r.map(|()| Status::Ok)
}

/// fmi2FreeInstance, fmi3FreeInstance: frees the instance `I` and every FMU state it made
/// that the importer did not free.
///
/// # Safety
/// `c` is NULL or a live instance `I` of this model.
pub unsafe fn free_instance<I: Guarded>(c: Component) {
    if c.is_null() {
        return;
    }
    let _ = catch_unwind(AssertUnwindSafe(|| {
        free_states_of(c);
        drop(Box::from_raw(c as *mut I))
    }));
}

/// fmi2SetDebugLogging, fmi3SetDebugLogging.
///
/// # Safety
/// `categories` points to `n` C strings when `n > 0`.
pub unsafe fn set_debug_logging<I: Guarded>(
    c: Component,
    (function, gate): Row,
    logging_on: bool,
    (n, categories): (usize, *const *const c_char),
) -> Status {
    guard::<I>(c, function, gate, |inst| {
        let ptrs = slice(categories, n, "categories[]")?;
        let mut names = Vec::with_capacity(n);
        for &p in ptrs {
            if p.is_null() {
                return Err("a category is NULL".into());
            }
            names.push(CStr::from_ptr(p).to_string_lossy().into_owned());
        }
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        ok(inst.core_mut().logger.set_debug_logging(logging_on, &names))
    })
}

/// Frees every FMU state instance `c` made that the importer did not free.
///
/// # Safety
/// Called while freeing `c`: no call of it runs.
unsafe fn free_states_of(c: Component) {
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

/// Who may use an FMU state in a call.
#[derive(Clone, Copy, PartialEq)]
enum Use {
    /// Any instance of the model: the state is only read.
    Read,
    /// Only the instance that made it: the state is written or freed.
    Own,
}

/// The FMU state behind `state`, if it is a live one of this model (`guid`; made by `c`
/// for [`Use::Own`]); checked in the registry before the pointer is read.
///
/// # Safety
/// A registered pointer is a live `Box<StateBox>`; no other thread uses the same state
/// during the call (the standard's rule for an instance and what it made).
unsafe fn state_ref<'a>(
    c: Component,
    guid: &str,
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
    if b.tag != STATE_TAG || b.guid != guid {
        return Err("FMUstate was not made by this model".to_string());
    }
    Ok(b)
}

/// The snapshot in FMU state `state`, any live one of this model (only read).
///
/// # Safety
/// As [`state_ref`].
unsafe fn read<'a, M: System>(
    c: Component,
    core: &Instance<M>,
    state: FmuState,
) -> Result<&'a Snapshot, String> {
    Ok(&state_ref(c, &core.info.guid, state, Use::Read)?.snapshot)
}

/// `*state` made or overwritten (if it is one of `c`'s) to hold `snapshot`.
///
/// # Safety
/// `state` is not NULL and points to an FMU state pointer (NULL or one of ours).
unsafe fn store<M: System>(
    c: Component,
    core: &Instance<M>,
    state: *mut FmuState,
    snapshot: Snapshot,
) -> Result<Status, String> {
    let guid = core.info.guid.as_str();
    if (*state).is_null() {
        *state = new_state(c, guid, snapshot);
    } else {
        state_ref(c, guid, *state, Use::Own)?.snapshot = snapshot;
    }
    Ok(Status::Ok)
}

// The FMU-state functions of both versions (fmi2GetFMUstate and fmi3GetFMUState, …): `I`
// is the version's instance, `function` and `gate` its name and row of its table.

/// fmi2GetFMUstate, fmi3GetFMUState.
///
/// # Safety
/// `state` points to an FMU state pointer (NULL or one of ours).
pub unsafe fn get_fmu_state<I: Guarded>(
    c: Component,
    (function, gate): Row,
    state: *mut FmuState,
) -> Status {
    guard::<I>(c, function, gate, |inst| {
        if state.is_null() {
            return Err("FMUstate is NULL".to_string());
        }
        let core = inst.core();
        store(c, core, state, core.snapshot())
    })
}

/// fmi2SetFMUstate's body (fmi3SetFMUState adds its Event Mode): the state restored into
/// `core`, checked as set values are.
///
/// # Safety
/// `state` is NULL or one of ours.
pub unsafe fn restore<M: System>(
    c: Component,
    core: &mut Instance<M>,
    state: FmuState,
) -> Result<Status, String> {
    let snapshot = read(c, core, state)?;
    ok(core.restore(snapshot))
}

/// fmi2SetFMUstate.
///
/// # Safety
/// As [`restore`].
pub unsafe fn set_fmu_state<I: Guarded>(
    c: Component,
    (function, gate): Row,
    state: FmuState,
) -> Status {
    guard::<I>(c, function, gate, |inst| restore(c, inst.core_mut(), state))
}

/// fmi2FreeFMUstate, fmi3FreeFMUState.
///
/// # Safety
/// As [`get_fmu_state`].
pub unsafe fn free_fmu_state<I: Guarded>(
    c: Component,
    (function, gate): Row,
    state: *mut FmuState,
) -> Status {
    guard::<I>(c, function, gate, |inst| {
        if state.is_null() {
            return Err("FMUstate is NULL".to_string());
        }
        if (*state).is_null() {
            return Ok(Status::Ok);
        }
        state_ref(c, &inst.core().info.guid, *state, Use::Own)?;
        states().remove(&(*state as usize));
        // SAFETY: a live Box<StateBox> of this instance, just taken out of the registry.
        drop(Box::from_raw(*state as *mut StateBox));
        *state = std::ptr::null_mut();
        Ok(Status::Ok)
    })
}

/// fmi2SerializedFMUstateSize, fmi3SerializedFMUStateSize.
///
/// # Safety
/// `state` is one of ours; `size` points to a writable `size_t`.
pub unsafe fn serialized_fmu_state_size<I: Guarded>(
    c: Component,
    (function, gate): Row,
    state: FmuState,
    size: *mut usize,
) -> Status {
    guard::<I>(c, function, gate, |inst| {
        let core = inst.core();
        let blob = core.serialize(read(c, core, state)?);
        if size.is_null() {
            return Err("size is NULL".to_string());
        }
        *size = blob.len();
        Ok(Status::Ok)
    })
}

/// fmi2SerializeFMUstate, fmi3SerializeFMUState.
///
/// # Safety
/// `state` is one of ours; `bytes` points to `size` writable bytes.
pub unsafe fn serialize_fmu_state<I: Guarded>(
    c: Component,
    (function, gate): Row,
    state: FmuState,
    (bytes, size): (*mut u8, usize),
) -> Status {
    guard::<I>(c, function, gate, |inst| {
        let core = inst.core();
        let blob = core.serialize(read(c, core, state)?);
        if size != blob.len() {
            return Err(format!(
                "size {size} differs from the serialized size {}",
                blob.len()
            ));
        }
        let out = slice_mut(bytes, size, "serializedState[]")?;
        out.copy_from_slice(&blob);
        Ok(Status::Ok)
    })
}

/// fmi2DeSerializeFMUstate, fmi3DeserializeFMUState.
///
/// # Safety
/// `bytes` points to `size` bytes; `state` points to an FMU state pointer (NULL or ours).
pub unsafe fn deserialize_fmu_state<I: Guarded>(
    c: Component,
    (function, gate): Row,
    (bytes, size): (*const u8, usize),
    state: *mut FmuState,
) -> Status {
    guard::<I>(c, function, gate, |inst| {
        if state.is_null() {
            return Err("FMUstate is NULL".to_string());
        }
        let blob = slice(bytes, size, "serializedState[]")?;
        let core = inst.core();
        let snapshot = core.deserialize(blob)?;
        store(c, core, state, snapshot)
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
