//! `export_fmu!`: the `fmi2*` and `fmi3*` symbols of one FMU's cdylib, Co-Simulation's and Model
//! Exchange's (one binary serves both interfaces; fmi2Instantiate's fmuType picks one).
//!
//! Thin on purpose: each symbol is one row of a table ([`__fmi_c_symbols!`]) forwarding to
//! the generic function of the same name in the front-end of its version,
//! [`fmi2`](crate::fmi::fmi2) or [`fmi3`](crate::fmi::fmi3), where the checks live. One
//! macro line per FMU crate:
//! `mbfmu::export_fmu!(mbfmu::systems::MassSpringDamper);`
//!
//! Beside FMI it exports `mbfmu_describe` and `mbfmu_free`, through which the packager asks
//! the compiled model for its XML, documentation and linearisation
//! ([`package::protocol`](crate::package::protocol)): the FMU's interface comes from the
//! binary it ships.

/// The C symbols from one table: each row `[unsafe] fn name(args) -> Ret = forward;` becomes
/// `#[no_mangle] pub unsafe extern "C" fn name(args) -> Ret { forward }` (`[]` for a safe
/// one). Used by [`export_fmu!`] alone: the rows are its two tables.
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi_c_symbols {
    ($(
        $(#[$attr:meta])*
        [$($unsafety:tt)?] fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)?
            = $forward:expr;
    )*) => {$(
        $(#[$attr])*
        #[no_mangle]
        pub $($unsafety)? extern "C" fn $name($($arg: $ty),*) $(-> $ret)? {
            $forward
        }
    )*};
}

/// FMI 3.0's get and set of a value type the models have no variables of: each row
/// `fmi3GetX / fmi3SetX: T;` is a pair of [`__fmi_c_symbols!`] rows refusing every value
/// reference (`fmi3::no_such_type`).
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi3_absent_types {
    ($($get:ident / $set:ident: $t:ty;)*) => {
        $crate::__fmi_c_symbols! {$(
            [unsafe] fn $get(c: Instance, vr: *const u32, nvr: usize, _v: *mut $t, _nv: usize)
                -> Status
                = fmi3::no_such_type::<E>(c, stringify!($get), fmi3::GET, vr, nvr);
            [unsafe] fn $set(c: Instance, vr: *const u32, nvr: usize, _v: *const $t, _nv: usize)
                -> Status
                = fmi3::no_such_type::<E>(c, stringify!($set), fmi3::SET, vr, nvr);
        )*}
    };
}

/// FMI 3.0 functions these FMUs do not offer (clocks, configuration mode, scheduled
/// execution, dependencies at run time): each group `"why": name(args); …` is rows of
/// [`__fmi_c_symbols!`] answering fmi3Error with one line "not offered by this FMU (why)"
/// (`fmi3::not_offered`).
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi3_not_offered {
    ($($why:literal: $($name:ident($($arg:ident: $ty:ty),* $(,)?);)*)*) => {
        $crate::__fmi_c_symbols! {$($(
            [] fn $name(c: Instance, $($arg: $ty),*) -> Status
                = fmi3::not_offered::<E>(c, stringify!($name), $why);
        )*)*}
    };
}

/// The six FMU-state symbols of one version (get, set, free, serialized size, serialize,
/// deserialize, named in that order), over the shared bodies in
/// [`boundary`](crate::fmi::boundary) with the version's instance, its `FMU_STATE` gate and
/// byte type; `set` the version's fmiXSetFMUState (FMI 3.0 keeps its Event Mode there).
#[doc(hidden)]
#[macro_export]
macro_rules! __fmu_state_symbols {
    (
        $c:ty, $gate:expr, $byte:ty, set = $set_fn:expr,
        $get:ident $set:ident $free:ident $size:ident $serialize:ident $deserialize:ident
    ) => {
        $crate::__fmi_c_symbols! {
            [unsafe] fn $get(c: $c, s: *mut FmuState) -> Status
                = $crate::fmi::boundary::get_fmu_state::<Inst>(c, (stringify!($get), $gate), s);
            [unsafe] fn $set(c: $c, s: FmuState) -> Status
                = ($set_fn)(c, (stringify!($set), $gate), s);
            [unsafe] fn $free(c: $c, s: *mut FmuState) -> Status
                = $crate::fmi::boundary::free_fmu_state::<Inst>(c, (stringify!($free), $gate), s);
            [unsafe] fn $size(c: $c, s: FmuState, size: *mut usize) -> Status
                = $crate::fmi::boundary::serialized_fmu_state_size::<Inst>(
                    c, (stringify!($size), $gate), s, size,
                );
            [unsafe] fn $serialize(c: $c, s: FmuState, bytes: *mut $byte, size: usize) -> Status
                = $crate::fmi::boundary::serialize_fmu_state::<Inst>(
                    c, (stringify!($serialize), $gate), s, (bytes as *mut u8, size),
                );
            [unsafe] fn $deserialize(c: $c, bytes: *const $byte, size: usize, s: *mut FmuState)
                -> Status
                = $crate::fmi::boundary::deserialize_fmu_state::<Inst>(
                    c, (stringify!($deserialize), $gate), (bytes as *const u8, size), s,
                );
        }
    };
}

/// Model Exchange's continuous-time symbols of one version, over the shared bodies in
/// [`continuous_time`](crate::fmi::continuous_time) for the version's instance `Inst`:
/// its component and Boolean types, then one row per call, `name = gate;` (with the word
/// for its array where the versions differ: `name("x[]") = gate;`), in a fixed order.
#[doc(hidden)]
#[macro_export]
macro_rules! __continuous_time_symbols {
    (
        $c:ty, $bool:ty;
        $set_time:ident = $set_time_gate:expr;
        $set_states:ident($set_word:literal) = $set_states_gate:expr;
        $get_states:ident($get_word:literal) = $get_states_gate:expr;
        $derivatives:ident = $derivatives_gate:expr;
        $indicators:ident = $indicators_gate:expr;
        $nominals:ident($nominals_word:literal) = $nominals_gate:expr;
        $completed:ident = $completed_gate:expr;
    ) => {
        $crate::__fmi_c_symbols! {
            [] fn $set_time(c: $c, time: f64) -> Status
                = $crate::fmi::continuous_time::set_time::<Inst>(
                    c, (stringify!($set_time), $set_time_gate), time,
                );
            [unsafe] fn $set_states(c: $c, x: *const f64, nx: usize) -> Status
                = $crate::fmi::continuous_time::set_continuous_states::<Inst>(
                    c, (stringify!($set_states), $set_states_gate), (x, nx, $set_word),
                );
            [unsafe] fn $get_states(c: $c, x: *mut f64, nx: usize) -> Status
                = $crate::fmi::continuous_time::fill::<Inst>(
                    c, (stringify!($get_states), $get_states_gate), (x, nx, $get_word),
                    |core, x| $crate::fmi::boundary::ok(core.get_continuous_states(x)),
                );
            [unsafe] fn $derivatives(c: $c, dx: *mut f64, nx: usize) -> Status
                = $crate::fmi::continuous_time::fill::<Inst>(
                    c, (stringify!($derivatives), $derivatives_gate), (dx, nx, "derivatives[]"),
                    |core, dx| core.get_derivatives(dx),
                );
            [unsafe] fn $indicators(c: $c, z: *mut f64, ni: usize) -> Status
                = $crate::fmi::continuous_time::fill::<Inst>(
                    c, (stringify!($indicators), $indicators_gate), (z, ni, "eventIndicators[]"),
                    |core, z| core.get_event_indicators(z),
                );
            [unsafe] fn $nominals(c: $c, nominals: *mut f64, nx: usize) -> Status
                = $crate::fmi::continuous_time::fill::<Inst>(
                    c, (stringify!($nominals), $nominals_gate), (nominals, nx, $nominals_word),
                    |core, nominals| $crate::fmi::boundary::ok(core.get_nominals(nominals)),
                );
            [unsafe] fn $completed(
                c: $c, _no_set_fmu_state_prior: $bool, enter_event_mode: *mut $bool,
                terminate_simulation: *mut $bool,
            ) -> Status
                = $crate::fmi::continuous_time::completed_integrator_step::<Inst, $bool>(
                    c, (stringify!($completed), $completed_gate), enter_event_mode,
                    terminate_simulation,
                );
        }
    };
}

/// `mbfmu_describe` and `mbfmu_free` (not FMI): the packager's questions
/// ([`package::protocol`](crate::package::protocol)), answered by `describe::$respond` for
/// the exported model `E`. Only with the feature `describe` (the host's build); a binary
/// cross-built for another platform carries FMI alone (this macro is then empty).
#[cfg(feature = "describe")]
#[doc(hidden)]
#[macro_export]
macro_rules! __describe_symbols {
    ($respond:ident) => {
        $crate::__fmi_c_symbols! {
            [unsafe] fn mbfmu_describe(request: *const ::std::ffi::c_char)
                -> *mut ::std::ffi::c_char
                = $crate::fmi::boundary::describe(
                    request, $crate::describe::$respond::<<E as $crate::fmi::Export>::Model>,
                );
            /// Frees what `mbfmu_describe` returned.
            [unsafe] fn mbfmu_free(text: *mut ::std::ffi::c_char)
                = $crate::fmi::boundary::free_string(text);
        }
    };
}

/// Without the feature `describe`: no packager's symbols (see above).
#[cfg(not(feature = "describe"))]
#[doc(hidden)]
#[macro_export]
macro_rules! __describe_symbols {
    ($respond:ident) => {};
}

/// Defines the complete FMI 2.0 and FMI 3.0 C APIs, Co-Simulation and Model Exchange, for one
/// [`System`](crate::model::System).
///
/// `export_fmu!(lagrangian MyModel)` for a [`Lagrangian`](crate::model::lagrangian::Lagrangian)
/// of a crate of one's own: its describe answer also gives the Rust source of the equations
/// of motion generated from its T, V and constraints, which `mbfmu build --manifest-path`
/// writes into the crate (`src/eom.rs`) for its `generated_eom!` line to run.
///
/// `export_fmu!(mechanism_runtime)` for the mechanism runtime
/// ([`multibody::runtime`](crate::multibody::runtime)): its robot is read from the FMU's
/// resources at instantiation, or from the packager's request.
///
/// `export_fmu!(mechanism Ur5)` for a mechanism declared with
/// [`mechanism_fmu!`](crate::mechanism_fmu): the model is
/// [`Robot<Ur5>`](crate::multibody::fmu::Robot), and its describe answer also gives the
/// mechanism it was built from (`mbfmu build --urdf` checks it against the URDF).
#[macro_export]
macro_rules! export_fmu {
    (mechanism $declared:ty) => {
        $crate::export_fmu!(@with respond_mechanism, $crate::multibody::fmu::Robot<$declared>);
    };
    (mechanism_runtime) => {
        $crate::export_fmu!(
            @with respond_runtime,
            $crate::multibody::fmu::Robot<$crate::multibody::runtime::Runtime>,
            /// The robot, from the FMU's resources (`multibody::runtime`).
            fn prepare(
                resources: &$crate::fmi::ResourceLocation,
            ) -> ::std::result::Result<(), ::std::string::String> {
                $crate::multibody::runtime::load_from(&resources.folder()?)
            }
        );
    };
    (lagrangian $model:ty) => {
        $crate::export_fmu!(@with respond_lagrangian, $model);
    };
    ($model:ty) => {
        $crate::export_fmu!(@with respond, $model);
    };
    (@with $respond:ident, $model:ty $(, $(#[$attr:meta])* fn prepare $($prepare:tt)*)?) => {
        /// The exported model, with its layout and GUID computed once per process.
        pub struct ExportedModel;

        impl $crate::fmi::Export for ExportedModel {
            type Model = $model;
            fn info() -> &'static $crate::fmi::ModelInfo {
                static INFO: ::std::sync::OnceLock<$crate::fmi::ModelInfo> =
                    ::std::sync::OnceLock::new();
                INFO.get_or_init($crate::fmi::ModelInfo::of::<$model>)
            }
            $($(#[$attr])* fn prepare $($prepare)*)?
        }

        mod fmi2_symbols {
            #![allow(non_snake_case, clippy::missing_safety_doc)]
            use super::ExportedModel as E;
            use ::std::ffi::{c_char, c_int, c_uint};
            use $crate::fmi::fmi2::{self, Component, EventInfoC, FmuState};
            use $crate::fmi::{CallbackFunctions, Status};
            /// This model's FMI 2.0 instance.
            type Inst = fmi2::Inst<E>;

            $crate::__describe_symbols!($respond);
            $crate::__fmi_c_symbols! {
                [] fn fmi2GetTypesPlatform() -> *const c_char
                    = fmi2::get_types_platform();
                [] fn fmi2GetVersion() -> *const c_char
                    = fmi2::get_version();
                [unsafe] fn fmi2SetDebugLogging(
                    c: Component, on: c_int, n: usize, cats: *const *const c_char,
                ) -> Status
                    = $crate::fmi::boundary::set_debug_logging::<Inst>(
                        c, ("fmi2SetDebugLogging", fmi2::ANY), on != 0, (n, cats),
                    );
                [unsafe] fn fmi2Instantiate(
                    name: *const c_char, fmu_type: c_int, guid: *const c_char,
                    resources: *const c_char, functions: *const CallbackFunctions, visible: c_int,
                    logging_on: c_int,
                ) -> Component
                    = fmi2::instantiate::<E>(
                        name, fmu_type, guid, resources, functions, visible, logging_on,
                    );
                [unsafe] fn fmi2FreeInstance(c: Component)
                    = $crate::fmi::boundary::free_instance::<Inst>(c);
                [] fn fmi2SetupExperiment(
                    c: Component, tol_defined: c_int, tol: f64, start: f64, stop_defined: c_int,
                    stop: f64,
                ) -> Status
                    = fmi2::setup_experiment::<E>(c, tol_defined, tol, start, stop_defined, stop);
                [] fn fmi2EnterInitializationMode(c: Component) -> Status
                    = fmi2::enter_initialization_mode::<E>(c);
                [] fn fmi2ExitInitializationMode(c: Component) -> Status
                    = fmi2::exit_initialization_mode::<E>(c);
                [] fn fmi2Terminate(c: Component) -> Status
                    = fmi2::terminate::<E>(c);
                [] fn fmi2Reset(c: Component) -> Status
                    = fmi2::reset::<E>(c);
                [unsafe] fn fmi2GetReal(
                    c: Component, vr: *const c_uint, n: usize, v: *mut f64,
                ) -> Status
                    = fmi2::get_real::<E>(c, vr, n, v);
                [unsafe] fn fmi2GetInteger(
                    c: Component, vr: *const c_uint, n: usize, v: *mut c_int,
                ) -> Status
                    = fmi2::get_integer::<E>(c, vr, n, v);
                [unsafe] fn fmi2GetBoolean(
                    c: Component, vr: *const c_uint, n: usize, v: *mut c_int,
                ) -> Status
                    = fmi2::no_such_type::<E, c_int>(c, "fmi2GetBoolean", fmi2::GETTER, vr, n, v);
                [unsafe] fn fmi2GetString(
                    c: Component, vr: *const c_uint, n: usize, v: *mut *const c_char,
                ) -> Status
                    = fmi2::no_such_type::<E, *const c_char>(
                        c, "fmi2GetString", fmi2::GETTER, vr, n, v,
                    );
                [unsafe] fn fmi2SetReal(
                    c: Component, vr: *const c_uint, n: usize, v: *const f64,
                ) -> Status
                    = fmi2::set_real::<E>(c, vr, n, v);
                [unsafe] fn fmi2SetInteger(
                    c: Component, vr: *const c_uint, n: usize, v: *const c_int,
                ) -> Status
                    = fmi2::set_integer::<E>(c, vr, n, v);
                [unsafe] fn fmi2SetBoolean(
                    c: Component, vr: *const c_uint, n: usize, v: *const c_int,
                ) -> Status
                    = fmi2::no_such_type::<E, c_int>(c, "fmi2SetBoolean", fmi2::SETTER, vr, n, v);
                [unsafe] fn fmi2SetString(
                    c: Component, vr: *const c_uint, n: usize, v: *const *const c_char,
                ) -> Status
                    = fmi2::no_such_type::<E, *const c_char>(
                        c, "fmi2SetString", fmi2::SETTER, vr, n, v,
                    );
                [unsafe] fn fmi2GetDirectionalDerivative(
                    c: Component, unknown: *const c_uint, n_unknown: usize, known: *const c_uint,
                    n_known: usize, dv_known: *const f64, dv_unknown: *mut f64,
                ) -> Status
                    = fmi2::get_directional_derivative::<E>(
                        c, unknown, n_unknown, known, n_known, dv_known, dv_unknown,
                    );
                [unsafe] fn fmi2SetRealInputDerivatives(
                    c: Component, vr: *const c_uint, n: usize, order: *const c_int, v: *const f64,
                ) -> Status
                    = fmi2::set_real_input_derivatives::<E>(c, vr, n, order, v);
                [unsafe] fn fmi2GetRealOutputDerivatives(
                    c: Component, vr: *const c_uint, n: usize, order: *const c_int, v: *mut f64,
                ) -> Status
                    = fmi2::get_real_output_derivatives::<E>(c, vr, n, order, v);
                [] fn fmi2DoStep(c: Component, t: f64, h: f64, no_prior: c_int) -> Status
                    = fmi2::do_step::<E>(c, t, h, no_prior);
                [] fn fmi2CancelStep(c: Component) -> Status
                    = fmi2::cancel_step::<E>(c);
                [unsafe] fn fmi2GetStatus(c: Component, kind: c_int, v: *mut c_int) -> Status
                    = fmi2::get_status::<E>(c, kind, v);
                [unsafe] fn fmi2GetRealStatus(c: Component, kind: c_int, v: *mut f64) -> Status
                    = fmi2::get_real_status::<E>(c, kind, v);
                [unsafe] fn fmi2GetIntegerStatus(c: Component, kind: c_int, v: *mut c_int) -> Status
                    = fmi2::get_integer_status::<E>(c, kind, v);
                [unsafe] fn fmi2GetBooleanStatus(c: Component, kind: c_int, v: *mut c_int) -> Status
                    = fmi2::get_boolean_status::<E>(c, kind, v);
                // Model Exchange.
                [] fn fmi2EnterEventMode(c: Component) -> Status
                    = fmi2::enter_event_mode::<E>(c);
                [unsafe] fn fmi2NewDiscreteStates(c: Component, info: *mut EventInfoC) -> Status
                    = fmi2::new_discrete_states::<E>(c, info);
                [] fn fmi2EnterContinuousTimeMode(c: Component) -> Status
                    = fmi2::enter_continuous_time_mode::<E>(c);
                // Co-Simulation.
                [unsafe] fn fmi2GetStringStatus(
                    c: Component, kind: c_int, v: *mut *const c_char,
                ) -> Status
                    = fmi2::get_string_status::<E>(c, kind, v);
            }

            $crate::__continuous_time_symbols! {
                Component, c_int;
                fmi2SetTime = fmi2::SET_TIME;
                fmi2SetContinuousStates("x[]") = fmi2::SET_CONTINUOUS_STATES;
                fmi2GetContinuousStates("x[]") = fmi2::GET_CONTINUOUS_STATES;
                fmi2GetDerivatives = fmi2::GET_DERIVATIVES;
                fmi2GetEventIndicators = fmi2::GET_EVENT_INDICATORS;
                fmi2GetNominalsOfContinuousStates("x_nominal[]") = fmi2::GET_NOMINALS;
                fmi2CompletedIntegratorStep = fmi2::COMPLETED_INTEGRATOR_STEP;
            }

            $crate::__fmu_state_symbols! {
                Component, fmi2::FMU_STATE, c_char,
                set = $crate::fmi::boundary::set_fmu_state::<Inst>,
                fmi2GetFMUstate fmi2SetFMUstate fmi2FreeFMUstate fmi2SerializedFMUstateSize
                fmi2SerializeFMUstate fmi2DeSerializeFMUstate
            }
        }

        /// The FMI 3.0 symbols (`fmi3Functions.h`, every one): forwards to
        /// `fmi3::*`; clocks, configuration mode and scheduled execution answer fmi3Error.
        pub mod fmi3_symbols {
            #![allow(non_snake_case, clippy::missing_safety_doc, clippy::too_many_arguments)]
            use super::ExportedModel as E;
            use ::std::ffi::{c_char, c_int, c_void};
            use $crate::fmi::fmi2::{self, FmuState};
            use $crate::fmi::fmi3::{Bool3, IntermediateUpdate};
            use $crate::fmi::fmi3;
            use $crate::fmi::{Interface, LogMessage3, Status};
            type Instance = fmi2::Component;
            /// This model's FMI 3.0 instance.
            type Inst = fmi3::Inst3<E>;

            $crate::__fmi_c_symbols! {
                [] fn fmi3GetVersion() -> *const c_char
                    = fmi3::get_version();
                [unsafe] fn fmi3SetDebugLogging(
                    c: Instance, on: Bool3, n: usize, cats: *const *const c_char,
                ) -> Status
                    = $crate::fmi::boundary::set_debug_logging::<Inst>(
                        c, ("fmi3SetDebugLogging", fmi3::ANY), on != 0, (n, cats),
                    );
                [unsafe] fn fmi3InstantiateModelExchange(
                    name: *const c_char, token: *const c_char, resources: *const c_char,
                    _visible: Bool3, logging_on: Bool3, env: *mut c_void, log: Option<LogMessage3>,
                ) -> Instance
                    = fmi3::instantiate::<E>(
                        "fmi3InstantiateModelExchange", Interface::ModelExchange, name, token,
                        resources, logging_on, (false, false, 0), env, log, None,
                    );
                [unsafe] fn fmi3InstantiateCoSimulation(
                    name: *const c_char, token: *const c_char, resources: *const c_char,
                    _visible: Bool3, logging_on: Bool3, event_mode_used: Bool3,
                    early_return_allowed: Bool3, _required: *const u32, n_required: usize,
                    env: *mut c_void, log: Option<LogMessage3>,
                    intermediate_update: Option<IntermediateUpdate>,
                ) -> Instance
                    = fmi3::instantiate::<E>(
                        "fmi3InstantiateCoSimulation", Interface::CoSimulation, name, token,
                        resources, logging_on, (event_mode_used != 0, early_return_allowed != 0, n_required), env,
                        log, intermediate_update,
                    );
                [unsafe] fn fmi3InstantiateScheduledExecution(
                    name: *const c_char, _token: *const c_char, _resources: *const c_char,
                    _visible: Bool3, _logging_on: Bool3, env: *mut c_void, log: Option<LogMessage3>,
                    _clock_update: *const c_void, _lock: *const c_void, _unlock: *const c_void,
                ) -> Instance
                    = fmi3::instantiate_scheduled_execution(name, env, log);
                [unsafe] fn fmi3FreeInstance(c: Instance)
                    = $crate::fmi::boundary::free_instance::<Inst>(c);
                [] fn fmi3EnterInitializationMode(
                    c: Instance, tol_defined: Bool3, tol: f64, start: f64, stop_defined: Bool3,
                    stop: f64,
                ) -> Status
                    = fmi3::enter_initialization_mode::<E>(
                        c, tol_defined, tol, start, stop_defined, stop,
                    );
                [] fn fmi3ExitInitializationMode(c: Instance) -> Status
                    = fmi3::exit_initialization_mode::<E>(c);
                [] fn fmi3EnterEventMode(c: Instance) -> Status
                    = fmi3::enter_event_mode::<E>(c);
                [] fn fmi3Terminate(c: Instance) -> Status
                    = fmi3::terminate::<E>(c);
                [] fn fmi3Reset(c: Instance) -> Status
                    = fmi3::reset::<E>(c);
                [] fn fmi3EvaluateDiscreteStates(c: Instance) -> Status
                    = fmi3::evaluate_discrete_states::<E>(c);
                [unsafe] fn fmi3GetFloat64(
                    c: Instance, vr: *const u32, nvr: usize, v: *mut f64, nv: usize,
                ) -> Status
                    = fmi3::get_float64::<E>(c, vr, nvr, v, nv);
                [unsafe] fn fmi3SetFloat64(
                    c: Instance, vr: *const u32, nvr: usize, v: *const f64, nv: usize,
                ) -> Status
                    = fmi3::set_float64::<E>(c, vr, nvr, v, nv);
                [unsafe] fn fmi3GetInt32(
                    c: Instance, vr: *const u32, nvr: usize, v: *mut i32, nv: usize,
                ) -> Status
                    = fmi3::get_int32::<E>(c, vr, nvr, v, nv);
                [unsafe] fn fmi3SetInt32(
                    c: Instance, vr: *const u32, nvr: usize, v: *const i32, nv: usize,
                ) -> Status
                    = fmi3::set_int32::<E>(c, vr, nvr, v, nv);
                [unsafe] fn fmi3GetInt64(
                    c: Instance, vr: *const u32, nvr: usize, v: *mut i64, nv: usize,
                ) -> Status
                    = fmi3::get_int64::<E>(c, vr, nvr, v, nv);
                [unsafe] fn fmi3SetInt64(
                    c: Instance, vr: *const u32, nvr: usize, v: *const i64, nv: usize,
                ) -> Status
                    = fmi3::set_int64::<E>(c, vr, nvr, v, nv);
                [unsafe] fn fmi3GetBinary(
                    c: Instance, vr: *const u32, nvr: usize, _sizes: *mut usize, _v: *mut *const u8,
                    _nv: usize,
                ) -> Status
                    = fmi3::no_such_type::<E>(c, "fmi3GetBinary", fmi3::GET, vr, nvr);
                [unsafe] fn fmi3SetBinary(
                    c: Instance, vr: *const u32, nvr: usize, _sizes: *const usize,
                    _v: *const *const u8, _nv: usize,
                ) -> Status
                    = fmi3::no_such_type::<E>(c, "fmi3SetBinary", fmi3::SET, vr, nvr);
                [unsafe] fn fmi3GetDirectionalDerivative(
                    c: Instance, unknowns: *const u32, n_unknowns: usize, knowns: *const u32,
                    n_knowns: usize, seed: *const f64, n_seed: usize, sensitivity: *mut f64,
                    n_sensitivity: usize,
                ) -> Status
                    = fmi3::get_directional_derivative::<E>(
                        c,
                        fmi3::Seeds { unknowns, n_unknowns, knowns, n_knowns, seed, n_seed, sensitivity, n_sensitivity, },
                    );
                [unsafe] fn fmi3GetAdjointDerivative(
                    c: Instance, unknowns: *const u32, n_unknowns: usize, knowns: *const u32,
                    n_knowns: usize, seed: *const f64, n_seed: usize, sensitivity: *mut f64,
                    n_sensitivity: usize,
                ) -> Status
                    = fmi3::get_adjoint_derivative::<E>(
                        c,
                        fmi3::Seeds { unknowns, n_unknowns, knowns, n_knowns, seed, n_seed, sensitivity, n_sensitivity, },
                    );
                [unsafe] fn fmi3UpdateDiscreteStates(
                    c: Instance, need_update: *mut Bool3, terminate: *mut Bool3,
                    nominals_changed: *mut Bool3, values_changed: *mut Bool3, next_defined: *mut Bool3,
                    next: *mut f64,
                ) -> Status
                    = fmi3::update_discrete_states::<E>(
                        c, need_update, terminate, nominals_changed, values_changed, next_defined,
                        next,
                    );
                [] fn fmi3EnterContinuousTimeMode(c: Instance) -> Status
                    = fmi3::enter_continuous_time_mode::<E>(c);
                [unsafe] fn fmi3GetNumberOfEventIndicators(c: Instance, n: *mut usize) -> Status
                    = fmi3::get_number_of_event_indicators::<E>(c, n);
                [unsafe] fn fmi3GetNumberOfContinuousStates(c: Instance, n: *mut usize) -> Status
                    = fmi3::get_number_of_continuous_states::<E>(c, n);
                [] fn fmi3EnterStepMode(c: Instance) -> Status
                    = fmi3::enter_step_mode::<E>(c);
                [unsafe] fn fmi3GetOutputDerivatives(
                    c: Instance, vr: *const u32, nvr: usize, orders: *const i32, v: *mut f64,
                    nv: usize,
                ) -> Status
                    = fmi3::get_output_derivatives::<E>(c, vr, nvr, orders, v, nv);
                [unsafe] fn fmi3DoStep(
                    c: Instance, current: f64, h: f64, no_prior: Bool3,
                    event_handling_needed: *mut Bool3, terminate: *mut Bool3, early_return: *mut Bool3,
                    last_successful_time: *mut f64,
                ) -> Status
                    = fmi3::do_step::<E>(
                        c, current, h, no_prior, event_handling_needed, terminate, early_return,
                        last_successful_time,
                    );
            }

            $crate::__continuous_time_symbols! {
                Instance, Bool3;
                fmi3SetTime = fmi3::SET_TIME;
                fmi3SetContinuousStates("continuousStates[]") = fmi3::SET_CONTINUOUS_STATES;
                fmi3GetContinuousStates("continuousStates[]") = fmi3::EVALUATE;
                fmi3GetContinuousStateDerivatives = fmi3::EVALUATE;
                fmi3GetEventIndicators = fmi3::EVALUATE;
                fmi3GetNominalsOfContinuousStates("nominals[]") = fmi3::EVALUATE;
                fmi3CompletedIntegratorStep = fmi3::COMPLETED_INTEGRATOR_STEP;
            }

            $crate::__fmu_state_symbols! {
                Instance, fmi3::FMU_STATE, u8,
                set = fmi3::set_fmu_state::<E>,
                fmi3GetFMUState fmi3SetFMUState fmi3FreeFMUState fmi3SerializedFMUStateSize
                fmi3SerializeFMUState fmi3DeserializeFMUState
            }

            // What these FMUs do not offer: every call refused with one line saying why.
            $crate::__fmi3_not_offered! {
                "the models have no clocks":
                    fmi3GetClock(_vr: *const u32, _nvr: usize, _v: *mut Bool3);
                    fmi3SetClock(_vr: *const u32, _nvr: usize, _v: *const Bool3);
                    fmi3GetIntervalDecimal(
                        _vr: *const u32, _nvr: usize, _intervals: *mut f64,
                        _qualifiers: *mut c_int,
                    );
                    fmi3GetIntervalFraction(
                        _vr: *const u32, _nvr: usize, _counters: *mut u64, _resolutions: *mut u64,
                        _qualifiers: *mut c_int,
                    );
                    fmi3GetShiftDecimal(_vr: *const u32, _nvr: usize, _shifts: *mut f64);
                    fmi3GetShiftFraction(
                        _vr: *const u32, _nvr: usize, _counters: *mut u64, _resolutions: *mut u64,
                    );
                    fmi3SetIntervalDecimal(_vr: *const u32, _nvr: usize, _intervals: *const f64);
                    fmi3SetIntervalFraction(
                        _vr: *const u32, _nvr: usize, _counters: *const u64,
                        _resolutions: *const u64,
                    );
                    fmi3SetShiftDecimal(_vr: *const u32, _nvr: usize, _shifts: *const f64);
                    fmi3SetShiftFraction(
                        _vr: *const u32, _nvr: usize, _counters: *const u64,
                        _resolutions: *const u64,
                    );
                "the dependencies are in modelDescription.xml":
                    fmi3GetNumberOfVariableDependencies(_vr: u32, _n: *mut usize);
                    fmi3GetVariableDependencies(
                        _dependent: u32, _element_of_dependent: *mut usize,
                        _independents: *mut u32, _element_of_independents: *mut usize,
                        _kinds: *mut c_int, _n: usize,
                    );
                "the models have no structural parameters":
                    fmi3EnterConfigurationMode();
                    fmi3ExitConfigurationMode();
                "no Scheduled Execution: the models have no clocks":
                    fmi3ActivateModelPartition(_clock: u32, _time: f64);
            }

            // The value types the models have no variables of: every value reference refused.
            $crate::__fmi3_absent_types! {
                fmi3GetFloat32 / fmi3SetFloat32: f32;
                fmi3GetInt8 / fmi3SetInt8: i8;
                fmi3GetUInt8 / fmi3SetUInt8: u8;
                fmi3GetInt16 / fmi3SetInt16: i16;
                fmi3GetUInt16 / fmi3SetUInt16: u16;
                fmi3GetUInt32 / fmi3SetUInt32: u32;
                fmi3GetUInt64 / fmi3SetUInt64: u64;
                fmi3GetBoolean / fmi3SetBoolean: Bool3;
                fmi3GetString / fmi3SetString: *const c_char;
            }
        }
    };
}
