//! Test harness: the MassSpringDamper C API exported into the test binary, a recording
//! logger, and a small owner of one instance.
#![allow(dead_code)]

use mbfmu::fmi::{CallbackFunctions, Export, Status};
use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::sync::Mutex;

mbfmu::export_fmu!(mbfmu::systems::MassSpringDamper);
pub use fmi2_symbols::*;

/// Log lines received, with the instance name, so parallel tests can tell theirs apart.
pub static LOG: Mutex<Vec<(String, c_int, String, String)>> = Mutex::new(Vec::new());

/// Stands in for the variadic `fmi2CallbackLogger`. Stable Rust cannot define a
/// variadic function; the FMU always calls the logger as (…, "%s", message), and on
/// x86-64 System V a variadic call passes those in the same registers as this
/// fixed-argument function reads them.
extern "C" fn record(
    _env: *mut c_void,
    name: *const c_char,
    status: c_int,
    category: *const c_char,
    format: *const c_char,
    message: *const c_char,
) {
    let s = |p: *const c_char| unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned();
    assert_eq!(s(format), "%s");
    LOG.lock()
        .unwrap()
        .push((s(name), status, s(category), s(message)));
}

pub fn callbacks() -> &'static CallbackFunctions {
    static CB: std::sync::OnceLock<SyncCallbacks> = std::sync::OnceLock::new();
    &CB.get_or_init(|| {
        SyncCallbacks(CallbackFunctions {
            // SAFETY: see `record`.
            logger: Some(unsafe {
                std::mem::transmute::<*const (), mbfmu::fmi::CallbackLogger>(record as *const ())
            }),
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: std::ptr::null_mut(),
        })
    })
    .0
}

struct SyncCallbacks(CallbackFunctions);
unsafe impl Sync for SyncCallbacks {}
unsafe impl Send for SyncCallbacks {}

pub fn log_of(name: &str) -> Vec<(c_int, String, String)> {
    LOG.lock()
        .unwrap()
        .iter()
        .filter(|(n, ..)| n == name)
        .map(|(_, s, c, m)| (*s, c.clone(), m.clone()))
        .collect()
}

pub fn guid() -> CString {
    CString::new(ExportedModel::info().guid.clone()).unwrap()
}

pub fn vr(name: &str) -> u32 {
    ExportedModel::info().layout.vr_of(name).unwrap()
}

pub struct Fmu {
    pub c: *mut c_void,
    pub name: String,
}

impl Fmu {
    pub fn new(name: &str) -> Fmu {
        let cname = CString::new(name).unwrap();
        let c = unsafe {
            fmi2Instantiate(
                cname.as_ptr(),
                1,
                guid().as_ptr(),
                std::ptr::null(),
                callbacks(),
                0,
                0,
            )
        };
        assert!(!c.is_null());
        Fmu {
            c,
            name: name.into(),
        }
    }

    pub fn init(&self, params: &[(&str, f64)]) {
        assert_eq!(
            fmi2SetupExperiment(self.c, 1, 1e-10, 0.0, 0, 0.0),
            Status::Ok
        );
        for (n, v) in params {
            assert_eq!(self.set(n, *v), Status::Ok);
        }
        assert_eq!(fmi2EnterInitializationMode(self.c), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(self.c), Status::Ok);
    }

    pub fn set(&self, name: &str, v: f64) -> Status {
        unsafe { fmi2SetReal(self.c, &vr(name), 1, &v) }
    }

    pub fn get(&self, name: &str) -> f64 {
        let mut v = f64::NAN;
        assert_eq!(
            unsafe { fmi2GetReal(self.c, &vr(name), 1, &mut v) },
            Status::Ok
        );
        v
    }

    pub fn errors(&self) -> usize {
        log_of(&self.name).len()
    }
}

impl Drop for Fmu {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) }
    }
}

pub fn run_to(f: &Fmu, t0: f64, t1: f64, h: f64) -> Vec<u64> {
    let n = ((t1 - t0) / h).round() as usize;
    let mut out = Vec::new();
    for i in 0..n {
        let t = t0 + i as f64 * h;
        assert_eq!(fmi2DoStep(f.c, t, h, 0), Status::Ok);
        out.push(f.get("x").to_bits());
        out.push(f.get("v").to_bits());
    }
    out
}
