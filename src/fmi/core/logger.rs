//! The logger callback of the environment, and which categories are switched on.

use super::info::Status;
use crate::xml::LOG_CATEGORIES;
use std::cell::Cell;
use std::ffi::{c_char, c_int, c_void, CString};

/// `fmi2CallbackLogger`: variadic, printf-style. We always pass `"%s"` and the
/// message as the one argument, so a `%` in a message can never be misread.
pub type CallbackLogger = unsafe extern "C" fn(
    env: *mut c_void,
    instance_name: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
    ...
);

/// `fmi3LogMessageCallback`: not variadic, no instance name (the environment knows it).
pub type LogMessage3 = unsafe extern "C" fn(
    env: *mut c_void,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
);

/// `fmi2CallbackFunctions`, laid out as in fmi2FunctionTypes.h.
#[repr(C)]
pub struct CallbackFunctions {
    pub logger: Option<CallbackLogger>,
    pub allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    pub component_environment: *mut c_void,
}

/// Sends lines to the environment's logger.
pub struct Logger {
    callback: Option<CallbackLogger>,
    /// FMI 3.0's callback (an instance made by fmi3Instantiate*): used instead of `callback`.
    callback3: Option<LogMessage3>,
    /// The FMI function being called (set by the guard of every C entry point): every
    /// failure line starts with it, so the core's messages name no function.
    function: Cell<&'static str>,
    /// How this importer's FMI version names what the core's messages refer to.
    pub words: &'static Words,
    env: *mut c_void,
    instance_name: CString,
    logging_on: bool,
    /// Bit i set: category `LOG_CATEGORIES[i]` is on.
    enabled: u32,
    /// A warning went out since the last [`Logger::take_warned`].
    warned: Cell<bool>,
}

const ALL_CATEGORIES: u32 = (1 << LOG_CATEGORIES.len()) - 1;

impl Logger {
    pub fn new(
        callback: Option<CallbackLogger>,
        env: *mut c_void,
        instance_name: &str,
        logging_on: bool,
    ) -> Self {
        Logger {
            callback,
            callback3: None,
            function: Cell::new(""),
            words: &FMI2_WORDS,
            env,
            instance_name: to_cstring(instance_name),
            logging_on,
            enabled: ALL_CATEGORIES,
            warned: Cell::new(false),
        }
    }

    /// A logger for an FMI 3.0 instance: lines go to its `logMessage` callback.
    pub fn fmi3(
        callback: Option<LogMessage3>,
        env: *mut c_void,
        instance_name: &str,
        logging_on: bool,
    ) -> Self {
        let mut logger = Logger::new(None, env, instance_name, logging_on);
        logger.callback3 = callback;
        logger.words = &FMI3_WORDS;
        logger
    }

    /// The function now running (see `function`).
    #[inline]
    pub fn set_function(&self, function: &'static str) {
        self.function.set(function);
    }

    /// A logger that prints nothing, for Rust-side use of an [`Instance`](super::Instance).
    pub fn silent(instance_name: &str) -> Self {
        Logger::new(None, std::ptr::null_mut(), instance_name, false)
    }

    /// fmi2SetDebugLogging: an empty list switches every category.
    pub fn set_debug_logging(&mut self, on: bool, categories: &[&str]) -> Result<(), String> {
        let mut bits = 0;
        for c in categories {
            let i = LOG_CATEGORIES
                .iter()
                .position(|(name, _)| name == c)
                .ok_or_else(|| format!("unknown log category \"{c}\""))?;
            bits |= 1 << i;
        }
        self.logging_on = on;
        self.enabled = if categories.is_empty() {
            ALL_CATEGORIES
        } else {
            bits
        };
        Ok(())
    }

    fn category_on(&self, category: &str) -> bool {
        LOG_CATEGORIES
            .iter()
            .position(|(name, _)| *name == category)
            .is_some_and(|i| self.enabled & (1 << i) != 0)
    }

    /// Whether a warning was logged since the last call, and forgets it. A function that
    /// reported a warning returns fmi2Warning (FMI 2.0, section 2.1.3: things are not quite
    /// right but the computation can continue, and the logger was called to say what): the
    /// C API asks at the start and at the end of every call.
    #[inline]
    pub fn take_warned(&self) -> bool {
        self.warned.replace(false)
    }

    /// A failure: always reported (it is not debug output), under the category of its status.
    pub fn failure(&self, status: Status, message: &str) {
        if status == Status::Warning {
            self.warned.set(true);
        }
        let category = match status {
            Status::Warning => "logStatusWarning",
            Status::Discard => "logStatusDiscard",
            Status::Fatal => "logStatusFatal",
            _ => "logStatusError",
        };
        self.emit(status, category, message);
    }

    /// Debug output (category logAll): only when logging is on and logAll enabled.
    pub fn debug(&self, message: &str) {
        if self.logging_on && self.category_on("logAll") {
            self.emit(Status::Ok, "logAll", message);
        }
    }

    #[inline]
    pub fn debug_enabled(&self) -> bool {
        self.logging_on && self.category_on("logAll")
    }

    /// Sends "function: message" (the function the guard set; the message alone outside a
    /// call).
    fn emit(&self, status: Status, category: &str, message: &str) {
        let message = match self.function.get() {
            "" => message.to_string(),
            f => format!("{f}: {message}"),
        };
        let message = message.as_str();
        if let Some(callback) = self.callback3 {
            let category = to_cstring(category);
            let message = to_cstring(message);
            // SAFETY: the environment gave us this callback in fmi3Instantiate* and
            // promised it stays valid for the instance's life; the strings live in this frame.
            unsafe {
                callback(
                    self.env,
                    status as c_int,
                    category.as_ptr(),
                    message.as_ptr(),
                )
            };
            return;
        }
        let Some(callback) = self.callback else {
            return;
        };
        let category = to_cstring(category);
        let message = to_cstring(message);
        // SAFETY: the environment gave us this callback in fmi2Instantiate and promised
        // it stays valid for the instance's life; every pointer passed is a live,
        // NUL-terminated string owned by this frame.
        unsafe {
            callback(
                self.env,
                self.instance_name.as_ptr(),
                status as c_int,
                category.as_ptr(),
                c"%s".as_ptr(),
                message.as_ptr(),
            );
        }
    }
}

/// How a front-end's FMI version names the functions and values the core's messages refer
/// to (the core names none itself).
#[derive(Debug)]
pub struct Words {
    pub enter_initialization_mode: &'static str,
    pub exit_initialization_mode: &'static str,
    pub get_integer: &'static str,
    pub set_integer: &'static str,
    pub terminate: &'static str,
    pub true_: &'static str,
}

pub const FMI2_WORDS: Words = Words {
    enter_initialization_mode: "fmi2EnterInitializationMode",
    exit_initialization_mode: "fmi2ExitInitializationMode",
    get_integer: "fmi2GetInteger",
    set_integer: "fmi2SetInteger",
    terminate: "fmi2Terminate",
    true_: "fmi2True",
};

pub const FMI3_WORDS: Words = Words {
    enter_initialization_mode: "fmi3EnterInitializationMode",
    exit_initialization_mode: "fmi3ExitInitializationMode",
    get_integer: "fmi3GetInt32",
    set_integer: "fmi3SetInt32",
    terminate: "fmi3Terminate",
    true_: "fmi3True",
};

/// A C string from text that might hold a NUL (replaced, never truncated silently).
fn to_cstring(s: &str) -> CString {
    CString::new(s.replace('\0', "\\0")).expect("NULs replaced")
}
