//! A model's compiled cdylib, loaded into the packager to answer the describe protocol:
//! the FMU's interface comes from the binary it ships, not from a catalogue compiled here.

use super::protocol::{self, Records, DESCRIBE_SYMBOL, FREE_SYMBOL};
use std::ffi::{c_char, c_void, CStr, CString};
use std::path::{Path, PathBuf};

type DescribeFn = unsafe extern "C" fn(*const c_char) -> *mut c_char;
type FreeFn = unsafe extern "C" fn(*mut c_char);

/// An opened model library. It is never unloaded: a Rust cdylib's thread-local destructors
/// make `dlclose` unsafe, and the CLI process is short-lived.
pub struct ModelLibrary {
    path: PathBuf,
    describe: DescribeFn,
    free: FreeFn,
}

/// The platform's dynamic loader: `dlopen`/`dlsym` on Unix, `LoadLibraryA`/`GetProcAddress`
/// on Windows (a handle is never closed, see [`ModelLibrary`]).
mod loader {
    #[cfg(windows)]
    use std::ffi::c_char;
    use std::ffi::{c_void, CStr};

    #[cfg(unix)]
    pub fn open(path: &CStr) -> Result<*mut c_void, String> {
        // SAFETY: a valid C string; loading runs the library's initialisers, which for a
        // Rust cdylib are std's own.
        let handle = unsafe { libc::dlopen(path.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
        if handle.is_null() {
            // SAFETY: dlerror returns NULL or a valid C string owned by libc.
            let e = unsafe { libc::dlerror() };
            return Err(if e.is_null() {
                "unknown error".into()
            } else {
                // SAFETY: non-null, NUL-terminated (above).
                unsafe { CStr::from_ptr(e) }.to_string_lossy().into_owned()
            });
        }
        Ok(handle)
    }

    #[cfg(unix)]
    pub fn symbol(handle: *mut c_void, name: &CStr) -> *mut c_void {
        // SAFETY: a live handle and a valid C string.
        unsafe { libc::dlsym(handle, name.as_ptr()) }
    }

    #[cfg(windows)]
    extern "system" {
        fn LoadLibraryA(name: *const c_char) -> *mut c_void;
        fn GetProcAddress(module: *mut c_void, name: *const c_char) -> *mut c_void;
        fn GetLastError() -> u32;
    }

    #[cfg(windows)]
    pub fn open(path: &CStr) -> Result<*mut c_void, String> {
        // SAFETY: a valid C string (an ANSI path).
        let handle = unsafe { LoadLibraryA(path.as_ptr()) };
        if handle.is_null() {
            // SAFETY: no arguments; the calling thread's last error.
            return Err(format!("LoadLibrary failed (Windows error {})", unsafe {
                GetLastError()
            }));
        }
        Ok(handle)
    }

    #[cfg(windows)]
    pub fn symbol(handle: *mut c_void, name: &CStr) -> *mut c_void {
        // SAFETY: a live module handle and a valid C string.
        unsafe { GetProcAddress(handle, name.as_ptr()) }
    }
}

impl ModelLibrary {
    /// Loads `path` and finds its describe symbols (a cdylib made by `export_fmu!`).
    pub fn open(path: &Path) -> Result<ModelLibrary, String> {
        let c_path = CString::new(path.as_os_str().as_encoded_bytes())
            .map_err(|_| format!("{}: a NUL in the path", path.display()))?;
        let handle =
            loader::open(&c_path).map_err(|e| format!("cannot load {}: {e}", path.display()))?;
        let symbol = |name: &str| -> Result<*mut c_void, String> {
            let c_name = CString::new(name).expect("symbol names have no NUL");
            let s = loader::symbol(handle, &c_name);
            if s.is_null() {
                Err(format!(
                    "{} has no symbol {name}: not an FMU built by `mbfmu::export_fmu!` of this version (or one built for another platform, or without the packager's `describe` feature)",
                    path.display()
                ))
            } else {
                Ok(s)
            }
        };
        let (describe, free) = (symbol(DESCRIBE_SYMBOL)?, symbol(FREE_SYMBOL)?);
        Ok(ModelLibrary {
            path: path.to_path_buf(),
            // SAFETY: export_fmu! defines both symbols with exactly these signatures.
            describe: unsafe { std::mem::transmute::<*mut c_void, DescribeFn>(describe) },
            free: unsafe { std::mem::transmute::<*mut c_void, FreeFn>(free) },
        })
    }

    /// Sends one request (see [`protocol`]) and returns the raw response text.
    pub fn respond(&self, request: &str) -> Result<String, String> {
        let c_request =
            CString::new(request).map_err(|_| "describe request with a NUL".to_string())?;
        // SAFETY: a valid C string; the library returns NULL or a string it allocated,
        // handed back to its own free function below.
        let answer = unsafe { (self.describe)(c_request.as_ptr()) };
        if answer.is_null() {
            return Err(format!(
                "{}: {DESCRIBE_SYMBOL} failed (a panic in the model?)",
                self.path.display()
            ));
        }
        // SAFETY: non-null and NUL-terminated (it came from CString::into_raw).
        let text = unsafe { CStr::from_ptr(answer) }
            .to_string_lossy()
            .into_owned();
        // SAFETY: returned by this library's describe, freed once.
        unsafe { (self.free)(answer) };
        Ok(text)
    }

    /// [`respond`](Self::respond), then checks the ABI and turns an `error` record into `Err`.
    pub fn call(&self, request: &str) -> Result<Records, String> {
        protocol::parse_response(&self.respond(request)?)
    }
}
