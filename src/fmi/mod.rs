//! The FMI boundary: FMI 2.0 and FMI 3.0, Co-Simulation and Model Exchange, from one binary.
//!
//! Call flow, from the C symbol down to the physics:
//! 1. [`export_fmu!`](crate::export_fmu) (in `export.rs`) defines every `fmi2*` and `fmi3*`
//!    symbol of one FMU's cdylib from one table, each row a forward to a front-end.
//! 2. The front-ends, one folder per FMI version: [`fmi2`] (`mod.rs`: FMI 2.0's state
//!    table as data, its words, what both interfaces share; `cs.rs`, `me.rs` each
//!    interface's own) and [`fmi3`] (the same for FMI 3.0). Each entry point goes through
//!    the one guard ([`boundary::guard`]): NULL instance, its version's table checked once
//!    ([`gate`]: one check and one wording of a refusal for both), panics caught, every
//!    error one line "function: message". [`boundary`] also holds the NULL-checked slices
//!    and the bodies both versions share (the FMU states, free instance, debug logging);
//!    [`continuous_time`] Model Exchange's continuous-time calls, one body each for both. The only `unsafe`, `extern "C"` and `catch_unwind` of the FMU side
//!    (the packager's side of `mbfmu_describe`, dlopen, is in `package::library`).
//! 3. [`Instance`] is the core (`core/`), which belongs to no FMI version: its [`Mode`]s,
//!    `core/mod.rs` (variables get/set and their checks, initialisation, directional
//!    derivatives, the FMU state and its checked blob in `snapshot.rs`), `cs.rs` (doStep
//!    around an integrator, stepping until an event) and `me.rs` (time, continuous states,
//!    derivatives, event indicators, the event iteration). Its messages name no FMI
//!    function: the guard says which function failed, and the few words a message needs of
//!    the importer's version (which function sets an Integer, what true is called) come
//!    from [`Words`].
//! 4. The [`System`](crate::model::System) computes `ẋ` and the outputs.

pub mod boundary;
pub mod continuous_time;
mod core;
mod export;
pub mod fmi2;
pub mod fmi3;
pub mod gate;

pub use self::core::cs::{StepOutcome, DOSTEP_WORK};
pub use self::core::info::{ModelInfo, Status};
pub use self::core::inputs::MAX_INPUT_DERIVATIVE_ORDER;
pub use self::core::logger::{CallbackFunctions, CallbackLogger, LogMessage3, Logger, Words};
pub use self::core::me::{EventInfo, NO_EVENT_INDICATOR};
pub use self::core::mode::{Interface, Mode};
pub use self::core::snapshot::{Snapshot, SNAPSHOT_MAGIC, SNAPSHOT_VERSION};
pub use self::core::Instance;
pub use gate::Gate;

use crate::model::System;

/// One exported model: the glue the export macro generates for a cdylib.
pub trait Export: 'static {
    type Model: System;
    /// Cached per process (the layout and the GUID are derived once).
    fn info() -> &'static ModelInfo;

    /// Called by every instantiate before [`Export::info`], with where the importer says
    /// the FMU's resources are: nothing to do but for the mechanism runtime, which reads
    /// its robot from there. An error refuses the instantiation with that one line.
    fn prepare(_resources: &ResourceLocation) -> Result<(), String> {
        Ok(())
    }
}

/// Where an instance's `resources/` folder is, as the importer gave it.
#[derive(Clone, Copy, Debug)]
pub enum ResourceLocation<'a> {
    /// FMI 2.0's `fmuResourceLocation`: a URI (`file:///…`).
    Uri(&'a str),
    /// FMI 3.0's `resourcePath`: a path in the platform's syntax.
    Path(&'a str),
    /// NULL.
    Absent,
}

impl<'a> ResourceLocation<'a> {
    /// The importer's C string: FMI 2.0's URI (`uri`) or FMI 3.0's path; NULL is absent.
    ///
    /// # Safety
    /// `location` is NULL or a NUL-terminated string that outlives `'a`.
    pub unsafe fn from_c(
        location: *const std::ffi::c_char,
        uri: bool,
    ) -> Result<ResourceLocation<'a>, String> {
        if location.is_null() {
            return Ok(ResourceLocation::Absent);
        }
        match (std::ffi::CStr::from_ptr(location).to_str(), uri) {
            (Ok(text), true) => Ok(ResourceLocation::Uri(text)),
            (Ok(text), false) => Ok(ResourceLocation::Path(text)),
            (Err(_), _) => Err("the resource location is not UTF-8".into()),
        }
    }

    /// The folder, as a path of this platform: a `file:` URI decoded (`%20`, `localhost`,
    /// a Windows drive letter, a UNC host), a path taken as it is.
    pub fn folder(&self) -> Result<std::path::PathBuf, String> {
        match *self {
            ResourceLocation::Absent => {
                Err("no resource location given (NULL): the FMU's resources are needed".into())
            }
            ResourceLocation::Path("") => {
                Err("an empty resourcePath: the FMU's resources are needed".into())
            }
            ResourceLocation::Path(p) => Ok(std::path::PathBuf::from(p)),
            ResourceLocation::Uri(uri) => file_uri_path(uri)
                .map(std::path::PathBuf::from)
                .ok_or_else(|| format!("fmuResourceLocation {uri:?} is no file: URI")),
        }
    }
}

/// The path of a `file:` URI (RFC 8089): `file:///p`, `file:/p`, `file://localhost/p`,
/// `file:///C:/p` (Windows: `C:/p`), `file://host/share` (UNC: `//host/share`), percent
/// escapes decoded; `None` for another scheme or a bad escape.
fn file_uri_path(uri: &str) -> Option<String> {
    let rest = uri
        .strip_prefix("file:")
        .or_else(|| uri.strip_prefix("FILE:"))?;
    let path = match rest.strip_prefix("//") {
        Some(authority_and_path) => {
            let (host, path) = match authority_and_path.find('/') {
                Some(i) => authority_and_path.split_at(i),
                None => (authority_and_path, ""),
            };
            if host.is_empty() || host.eq_ignore_ascii_case("localhost") {
                path.to_string()
            } else {
                format!("//{host}{path}")
            }
        }
        None => rest.to_string(),
    };
    let bytes = path.as_bytes();
    let mut decoded = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            decoded.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            decoded.push(bytes[i]);
            i += 1;
        }
    }
    let mut path = String::from_utf8(decoded).ok()?;
    // `/C:/…` is a Windows drive path.
    let b = path.as_bytes();
    if b.len() >= 3 && b[0] == b'/' && b[1].is_ascii_alphabetic() && b[2] == b':' {
        path.remove(0);
    }
    Some(path)
}

#[cfg(test)]
mod tests {
    use super::file_uri_path;

    #[test]
    fn file_uris_become_paths() {
        let cases = [
            ("file:///tmp/a%20b/resources/", "/tmp/a b/resources/"),
            ("file:/tmp/x", "/tmp/x"),
            ("file://localhost/tmp/x", "/tmp/x"),
            ("file:///C:/Users/me/res", "C:/Users/me/res"),
            ("file://server/share/res", "//server/share/res"),
        ];
        for (uri, path) in cases {
            assert_eq!(file_uri_path(uri).as_deref(), Some(path), "{uri}");
        }
        assert_eq!(file_uri_path("http://x/y"), None);
        assert_eq!(file_uri_path("file:///bad%2"), None);
        assert_eq!(file_uri_path("file:///bad%zz"), None);
    }
}
