//! `export_fmu!`: the `fmi2*` and `fmi3*` symbols of one FMU's cdylib, Co-Simulation's and Model
//! Exchange's (one binary serves both interfaces; fmi2Instantiate's fmuType picks one).
//!
//! Thin on purpose: each symbol is one row of a table ([`__fmi_c_symbols!`]) forwarding to
//! the generic function of the same name in [`capi`](crate::fmi::capi), where the checks
//! live. One macro line per FMU crate:
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
/// reference (`capi::fmi3::no_such_type`).
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi3_absent_types {
    ($($get:ident / $set:ident: $t:ty;)*) => {
        $crate::__fmi_c_symbols! {$(
            [unsafe] fn $get(c: Instance, vr: *const u32, nvr: usize, _v: *mut $t, _nv: usize)
                -> Status
                = capi::fmi3::no_such_type::<E>(c, stringify!($get), machine3::GET, vr, nvr);
            [unsafe] fn $set(c: Instance, vr: *const u32, nvr: usize, _v: *const $t, _nv: usize)
                -> Status
                = capi::fmi3::no_such_type::<E>(c, stringify!($set), machine3::SET, vr, nvr);
        )*}
    };
}

/// Defines the complete FMI 2.0 and FMI 3.0 C APIs, Co-Simulation and Model Exchange, for one
/// [`System`](crate::model::System).
///
/// `export_fmu!(lagrangian MyModel)` for a [`Lagrangian`](crate::model::lagrangian::Lagrangian)
/// of a crate of one's own: its describe answer also gives the Rust source of the equations
/// of motion generated from its T, V and constraints, which `mbfmu build --manifest-path`
/// writes into the crate (`src/eom.rs`) for its `generated_eom!` line to run.
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
    (lagrangian $model:ty) => {
        $crate::export_fmu!(@with respond_lagrangian, $model);
    };
    ($model:ty) => {
        $crate::export_fmu!(@with respond, $model);
    };
    (@with $respond:ident, $model:ty) => {
        /// The exported model, with its layout and GUID computed once per process.
        pub struct ExportedModel;

        impl $crate::fmi::Export for ExportedModel {
            type Model = $model;
            fn info() -> &'static $crate::fmi::ModelInfo {
                static INFO: ::std::sync::OnceLock<$crate::fmi::ModelInfo> =
                    ::std::sync::OnceLock::new();
                INFO.get_or_init($crate::fmi::ModelInfo::of::<$model>)
            }
        }

        mod fmi2_symbols {
            #![allow(non_snake_case, clippy::missing_safety_doc)]
            use super::ExportedModel as E;
            use ::std::ffi::{c_char, c_int, c_uint};
            use $crate::fmi::capi::{self, Component, EventInfoC, FmuState};
            use $crate::fmi::{CallbackFunctions, Status};

            $crate::__fmi_c_symbols! {
                /// Not FMI: the packager's questions (`mbfmu::package::protocol`).
                [unsafe] fn mbfmu_describe(request: *const c_char) -> *mut c_char
                    = capi::describe(
                        request, $crate::describe::$respond::<<E as $crate::fmi::Export>::Model>,
                    );
                /// Not FMI: frees what `mbfmu_describe` returned.
                [unsafe] fn mbfmu_free(text: *mut c_char)
                    = capi::free_string(text);
                [] fn fmi2GetTypesPlatform() -> *const c_char
                    = capi::get_types_platform();
                [] fn fmi2GetVersion() -> *const c_char
                    = capi::get_version();
                [unsafe] fn fmi2SetDebugLogging(
                    c: Component, on: c_int, n: usize, cats: *const *const c_char,
                ) -> Status
                    = capi::set_debug_logging::<E>(c, on, n, cats);
                [unsafe] fn fmi2Instantiate(
                    name: *const c_char, fmu_type: c_int, guid: *const c_char,
                    resources: *const c_char, functions: *const CallbackFunctions, visible: c_int,
                    logging_on: c_int,
                ) -> Component
                    = capi::instantiate::<E>(
                        name, fmu_type, guid, resources, functions, visible, logging_on,
                    );
                [unsafe] fn fmi2FreeInstance(c: Component)
                    = capi::free_instance::<E>(c);
                [] fn fmi2SetupExperiment(
                    c: Component, tol_defined: c_int, tol: f64, start: f64, stop_defined: c_int,
                    stop: f64,
                ) -> Status
                    = capi::setup_experiment::<E>(c, tol_defined, tol, start, stop_defined, stop);
                [] fn fmi2EnterInitializationMode(c: Component) -> Status
                    = capi::enter_initialization_mode::<E>(c);
                [] fn fmi2ExitInitializationMode(c: Component) -> Status
                    = capi::exit_initialization_mode::<E>(c);
                [] fn fmi2Terminate(c: Component) -> Status
                    = capi::terminate::<E>(c);
                [] fn fmi2Reset(c: Component) -> Status
                    = capi::reset::<E>(c);
                [unsafe] fn fmi2GetReal(
                    c: Component, vr: *const c_uint, n: usize, v: *mut f64,
                ) -> Status
                    = capi::get_real::<E>(c, vr, n, v);
                [unsafe] fn fmi2GetInteger(
                    c: Component, vr: *const c_uint, n: usize, v: *mut c_int,
                ) -> Status
                    = capi::get_integer::<E>(c, vr, n, v);
                [unsafe] fn fmi2GetBoolean(
                    c: Component, vr: *const c_uint, n: usize, v: *mut c_int,
                ) -> Status
                    = capi::no_such_type::<E, c_int>(c, "fmi2GetBoolean", capi::GETTER, vr, n, v);
                [unsafe] fn fmi2GetString(
                    c: Component, vr: *const c_uint, n: usize, v: *mut *const c_char,
                ) -> Status
                    = capi::no_such_type::<E, *const c_char>(
                        c, "fmi2GetString", capi::GETTER, vr, n, v,
                    );
                [unsafe] fn fmi2SetReal(
                    c: Component, vr: *const c_uint, n: usize, v: *const f64,
                ) -> Status
                    = capi::set_real::<E>(c, vr, n, v);
                [unsafe] fn fmi2SetInteger(
                    c: Component, vr: *const c_uint, n: usize, v: *const c_int,
                ) -> Status
                    = capi::set_integer::<E>(c, vr, n, v);
                [unsafe] fn fmi2SetBoolean(
                    c: Component, vr: *const c_uint, n: usize, v: *const c_int,
                ) -> Status
                    = capi::no_such_type::<E, c_int>(c, "fmi2SetBoolean", capi::SETTER, vr, n, v);
                [unsafe] fn fmi2SetString(
                    c: Component, vr: *const c_uint, n: usize, v: *const *const c_char,
                ) -> Status
                    = capi::no_such_type::<E, *const c_char>(
                        c, "fmi2SetString", capi::SETTER, vr, n, v,
                    );
                [unsafe] fn fmi2GetFMUstate(c: Component, s: *mut FmuState) -> Status
                    = capi::get_fmu_state::<E>(c, s);
                [unsafe] fn fmi2SetFMUstate(c: Component, s: FmuState) -> Status
                    = capi::set_fmu_state::<E>(c, s);
                [unsafe] fn fmi2FreeFMUstate(c: Component, s: *mut FmuState) -> Status
                    = capi::free_fmu_state::<E>(c, s);
                [unsafe] fn fmi2SerializedFMUstateSize(
                    c: Component, s: FmuState, size: *mut usize,
                ) -> Status
                    = capi::serialized_fmu_state_size::<E>(c, s, size);
                [unsafe] fn fmi2SerializeFMUstate(
                    c: Component, s: FmuState, bytes: *mut c_char, size: usize,
                ) -> Status
                    = capi::serialize_fmu_state::<E>(c, s, bytes, size);
                [unsafe] fn fmi2DeSerializeFMUstate(
                    c: Component, bytes: *const c_char, size: usize, s: *mut FmuState,
                ) -> Status
                    = capi::deserialize_fmu_state::<E>(c, bytes, size, s);
                [unsafe] fn fmi2GetDirectionalDerivative(
                    c: Component, unknown: *const c_uint, n_unknown: usize, known: *const c_uint,
                    n_known: usize, dv_known: *const f64, dv_unknown: *mut f64,
                ) -> Status
                    = capi::get_directional_derivative::<E>(
                        c, unknown, n_unknown, known, n_known, dv_known, dv_unknown,
                    );
                [unsafe] fn fmi2SetRealInputDerivatives(
                    c: Component, vr: *const c_uint, n: usize, order: *const c_int, v: *const f64,
                ) -> Status
                    = capi::set_real_input_derivatives::<E>(c, vr, n, order, v);
                [unsafe] fn fmi2GetRealOutputDerivatives(
                    c: Component, vr: *const c_uint, n: usize, order: *const c_int, v: *mut f64,
                ) -> Status
                    = capi::get_real_output_derivatives::<E>(c, vr, n, order, v);
                [] fn fmi2DoStep(c: Component, t: f64, h: f64, no_prior: c_int) -> Status
                    = capi::do_step::<E>(c, t, h, no_prior);
                [] fn fmi2CancelStep(c: Component) -> Status
                    = capi::cancel_step::<E>(c);
                [unsafe] fn fmi2GetStatus(c: Component, kind: c_int, v: *mut c_int) -> Status
                    = capi::get_status::<E>(c, kind, v);
                [unsafe] fn fmi2GetRealStatus(c: Component, kind: c_int, v: *mut f64) -> Status
                    = capi::get_real_status::<E>(c, kind, v);
                [unsafe] fn fmi2GetIntegerStatus(c: Component, kind: c_int, v: *mut c_int) -> Status
                    = capi::get_integer_status::<E>(c, kind, v);
                [unsafe] fn fmi2GetBooleanStatus(c: Component, kind: c_int, v: *mut c_int) -> Status
                    = capi::get_boolean_status::<E>(c, kind, v);
                // Model Exchange.
                [] fn fmi2EnterEventMode(c: Component) -> Status
                    = capi::enter_event_mode::<E>(c);
                [unsafe] fn fmi2NewDiscreteStates(c: Component, info: *mut EventInfoC) -> Status
                    = capi::new_discrete_states::<E>(c, info);
                [] fn fmi2EnterContinuousTimeMode(c: Component) -> Status
                    = capi::enter_continuous_time_mode::<E>(c);
                [unsafe] fn fmi2CompletedIntegratorStep(
                    c: Component, no_prior: c_int, enter_event_mode: *mut c_int,
                    terminate_simulation: *mut c_int,
                ) -> Status
                    = capi::completed_integrator_step::<E>(
                        c, no_prior, enter_event_mode, terminate_simulation,
                    );
                [] fn fmi2SetTime(c: Component, time: f64) -> Status
                    = capi::set_time::<E>(c, time);
                [unsafe] fn fmi2SetContinuousStates(c: Component, x: *const f64, nx: usize) -> Status
                    = capi::set_continuous_states::<E>(c, x, nx);
                [unsafe] fn fmi2GetDerivatives(c: Component, dx: *mut f64, nx: usize) -> Status
                    = capi::get_derivatives::<E>(c, dx, nx);
                [unsafe] fn fmi2GetEventIndicators(c: Component, z: *mut f64, ni: usize) -> Status
                    = capi::get_event_indicators::<E>(c, z, ni);
                [unsafe] fn fmi2GetContinuousStates(c: Component, x: *mut f64, nx: usize) -> Status
                    = capi::get_continuous_states::<E>(c, x, nx);
                [unsafe] fn fmi2GetNominalsOfContinuousStates(
                    c: Component, nominals: *mut f64, nx: usize,
                ) -> Status
                    = capi::get_nominals_of_continuous_states::<E>(c, nominals, nx);
                // Co-Simulation.
                [unsafe] fn fmi2GetStringStatus(
                    c: Component, kind: c_int, v: *mut *const c_char,
                ) -> Status
                    = capi::get_string_status::<E>(c, kind, v);
            }
        }

        /// The FMI 3.0 symbols (`fmi3Functions.h`, every one): forwards to
        /// `capi::fmi3*`; clocks, configuration mode and scheduled execution answer fmi3Error.
        pub mod fmi3_symbols {
            #![allow(non_snake_case, clippy::missing_safety_doc, clippy::too_many_arguments)]
            use super::ExportedModel as E;
            use ::std::ffi::{c_char, c_int, c_void};
            use $crate::fmi::capi::{self, FmuState};
            use $crate::fmi::capi::fmi3::{Bool3, IntermediateUpdate};
            use $crate::fmi::machine3;
            use $crate::fmi::{Interface, LogMessage3, Status};
            type Instance = capi::Component;

            $crate::__fmi_c_symbols! {
                [] fn fmi3GetVersion() -> *const c_char
                    = capi::fmi3::get_version();
                [unsafe] fn fmi3SetDebugLogging(
                    c: Instance, on: Bool3, n: usize, cats: *const *const c_char,
                ) -> Status
                    = capi::fmi3::set_debug_logging::<E>(c, on, n, cats);
                [unsafe] fn fmi3InstantiateModelExchange(
                    name: *const c_char, token: *const c_char, _resources: *const c_char,
                    _visible: Bool3, logging_on: Bool3, env: *mut c_void, log: Option<LogMessage3>,
                ) -> Instance
                    = capi::fmi3::instantiate::<E>(
                        "fmi3InstantiateModelExchange", Interface::ModelExchange, name, token,
                        logging_on, (false, false, 0), env, log, None,
                    );
                [unsafe] fn fmi3InstantiateCoSimulation(
                    name: *const c_char, token: *const c_char, _resources: *const c_char,
                    _visible: Bool3, logging_on: Bool3, event_mode_used: Bool3,
                    early_return_allowed: Bool3, _required: *const u32, n_required: usize,
                    env: *mut c_void, log: Option<LogMessage3>,
                    intermediate_update: Option<IntermediateUpdate>,
                ) -> Instance
                    = capi::fmi3::instantiate::<E>(
                        "fmi3InstantiateCoSimulation", Interface::CoSimulation, name, token,
                        logging_on, (event_mode_used != 0, early_return_allowed != 0, n_required), env,
                        log, intermediate_update,
                    );
                [unsafe] fn fmi3InstantiateScheduledExecution(
                    name: *const c_char, _token: *const c_char, _resources: *const c_char,
                    _visible: Bool3, _logging_on: Bool3, env: *mut c_void, log: Option<LogMessage3>,
                    _clock_update: *const c_void, _lock: *const c_void, _unlock: *const c_void,
                ) -> Instance
                    = capi::fmi3::instantiate_scheduled_execution(name, env, log);
                [unsafe] fn fmi3FreeInstance(c: Instance)
                    = capi::fmi3::free_instance::<E>(c);
                [] fn fmi3EnterInitializationMode(
                    c: Instance, tol_defined: Bool3, tol: f64, start: f64, stop_defined: Bool3,
                    stop: f64,
                ) -> Status
                    = capi::fmi3::enter_initialization_mode::<E>(
                        c, tol_defined, tol, start, stop_defined, stop,
                    );
                [] fn fmi3ExitInitializationMode(c: Instance) -> Status
                    = capi::fmi3::exit_initialization_mode::<E>(c);
                [] fn fmi3EnterEventMode(c: Instance) -> Status
                    = capi::fmi3::enter_event_mode::<E>(c);
                [] fn fmi3Terminate(c: Instance) -> Status
                    = capi::fmi3::terminate::<E>(c);
                [] fn fmi3Reset(c: Instance) -> Status
                    = capi::fmi3::reset::<E>(c);
                [] fn fmi3EvaluateDiscreteStates(c: Instance) -> Status
                    = capi::fmi3::evaluate_discrete_states::<E>(c);
                [unsafe] fn fmi3GetFloat64(
                    c: Instance, vr: *const u32, nvr: usize, v: *mut f64, nv: usize,
                ) -> Status
                    = capi::fmi3::get_float64::<E>(c, vr, nvr, v, nv);
                [unsafe] fn fmi3SetFloat64(
                    c: Instance, vr: *const u32, nvr: usize, v: *const f64, nv: usize,
                ) -> Status
                    = capi::fmi3::set_float64::<E>(c, vr, nvr, v, nv);
                [unsafe] fn fmi3GetInt32(
                    c: Instance, vr: *const u32, nvr: usize, v: *mut i32, nv: usize,
                ) -> Status
                    = capi::fmi3::get_int32::<E>(c, vr, nvr, v, nv);
                [unsafe] fn fmi3SetInt32(
                    c: Instance, vr: *const u32, nvr: usize, v: *const i32, nv: usize,
                ) -> Status
                    = capi::fmi3::set_int32::<E>(c, vr, nvr, v, nv);
                [unsafe] fn fmi3GetInt64(
                    c: Instance, vr: *const u32, nvr: usize, v: *mut i64, nv: usize,
                ) -> Status
                    = capi::fmi3::get_int64::<E>(c, vr, nvr, v, nv);
                [unsafe] fn fmi3SetInt64(
                    c: Instance, vr: *const u32, nvr: usize, v: *const i64, nv: usize,
                ) -> Status
                    = capi::fmi3::set_int64::<E>(c, vr, nvr, v, nv);
                [unsafe] fn fmi3GetBinary(
                    c: Instance, vr: *const u32, nvr: usize, _sizes: *mut usize, _v: *mut *const u8,
                    _nv: usize,
                ) -> Status
                    = capi::fmi3::no_such_type::<E>(c, "fmi3GetBinary", machine3::GET, vr, nvr);
                [unsafe] fn fmi3SetBinary(
                    c: Instance, vr: *const u32, nvr: usize, _sizes: *const usize,
                    _v: *const *const u8, _nv: usize,
                ) -> Status
                    = capi::fmi3::no_such_type::<E>(c, "fmi3SetBinary", machine3::SET, vr, nvr);
                [] fn fmi3GetClock(c: Instance, _vr: *const u32, _nvr: usize, _v: *mut Bool3) -> Status
                    = capi::fmi3::not_offered::<E>(c, "fmi3GetClock", "the models have no clocks");
                [] fn fmi3SetClock(
                    c: Instance, _vr: *const u32, _nvr: usize, _v: *const Bool3,
                ) -> Status
                    = capi::fmi3::not_offered::<E>(c, "fmi3SetClock", "the models have no clocks");
                [] fn fmi3GetNumberOfVariableDependencies(
                    c: Instance, _vr: u32, _n: *mut usize,
                ) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3GetNumberOfVariableDependencies",
                        "the dependencies are in modelDescription.xml",
                    );
                [] fn fmi3GetVariableDependencies(
                    c: Instance, _dependent: u32, _element_of_dependent: *mut usize,
                    _independents: *mut u32, _element_of_independents: *mut usize, _kinds: *mut c_int,
                    _n: usize,
                ) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3GetVariableDependencies",
                        "the dependencies are in modelDescription.xml",
                    );
                [unsafe] fn fmi3GetFMUState(c: Instance, s: *mut FmuState) -> Status
                    = capi::fmi3::get_fmu_state::<E>(c, s);
                [unsafe] fn fmi3SetFMUState(c: Instance, s: FmuState) -> Status
                    = capi::fmi3::set_fmu_state::<E>(c, s);
                [unsafe] fn fmi3FreeFMUState(c: Instance, s: *mut FmuState) -> Status
                    = capi::fmi3::free_fmu_state::<E>(c, s);
                [unsafe] fn fmi3SerializedFMUStateSize(
                    c: Instance, s: FmuState, size: *mut usize,
                ) -> Status
                    = capi::fmi3::serialized_fmu_state_size::<E>(c, s, size);
                [unsafe] fn fmi3SerializeFMUState(
                    c: Instance, s: FmuState, bytes: *mut u8, size: usize,
                ) -> Status
                    = capi::fmi3::serialize_fmu_state::<E>(c, s, bytes, size);
                [unsafe] fn fmi3DeserializeFMUState(
                    c: Instance, bytes: *const u8, size: usize, s: *mut FmuState,
                ) -> Status
                    = capi::fmi3::deserialize_fmu_state::<E>(c, bytes, size, s);
                [unsafe] fn fmi3GetDirectionalDerivative(
                    c: Instance, unknowns: *const u32, n_unknowns: usize, knowns: *const u32,
                    n_knowns: usize, seed: *const f64, n_seed: usize, sensitivity: *mut f64,
                    n_sensitivity: usize,
                ) -> Status
                    = capi::fmi3::get_directional_derivative::<E>(
                        c,
                        capi::fmi3::Seeds { unknowns, n_unknowns, knowns, n_knowns, seed, n_seed, sensitivity, n_sensitivity, },
                    );
                [unsafe] fn fmi3GetAdjointDerivative(
                    c: Instance, unknowns: *const u32, n_unknowns: usize, knowns: *const u32,
                    n_knowns: usize, seed: *const f64, n_seed: usize, sensitivity: *mut f64,
                    n_sensitivity: usize,
                ) -> Status
                    = capi::fmi3::get_adjoint_derivative::<E>(
                        c,
                        capi::fmi3::Seeds { unknowns, n_unknowns, knowns, n_knowns, seed, n_seed, sensitivity, n_sensitivity, },
                    );
                [] fn fmi3EnterConfigurationMode(c: Instance) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3EnterConfigurationMode", "the models have no structural parameters",
                    );
                [] fn fmi3ExitConfigurationMode(c: Instance) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3ExitConfigurationMode", "the models have no structural parameters",
                    );
                [] fn fmi3GetIntervalDecimal(
                    c: Instance, _vr: *const u32, _nvr: usize, _intervals: *mut f64,
                    _qualifiers: *mut c_int,
                ) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3GetIntervalDecimal", "the models have no clocks",
                    );
                [] fn fmi3GetIntervalFraction(
                    c: Instance, _vr: *const u32, _nvr: usize, _counters: *mut u64,
                    _resolutions: *mut u64, _qualifiers: *mut c_int,
                ) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3GetIntervalFraction", "the models have no clocks",
                    );
                [] fn fmi3GetShiftDecimal(
                    c: Instance, _vr: *const u32, _nvr: usize, _shifts: *mut f64,
                ) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3GetShiftDecimal", "the models have no clocks",
                    );
                [] fn fmi3GetShiftFraction(
                    c: Instance, _vr: *const u32, _nvr: usize, _counters: *mut u64,
                    _resolutions: *mut u64,
                ) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3GetShiftFraction", "the models have no clocks",
                    );
                [] fn fmi3SetIntervalDecimal(
                    c: Instance, _vr: *const u32, _nvr: usize, _intervals: *const f64,
                ) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3SetIntervalDecimal", "the models have no clocks",
                    );
                [] fn fmi3SetIntervalFraction(
                    c: Instance, _vr: *const u32, _nvr: usize, _counters: *const u64,
                    _resolutions: *const u64,
                ) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3SetIntervalFraction", "the models have no clocks",
                    );
                [] fn fmi3SetShiftDecimal(
                    c: Instance, _vr: *const u32, _nvr: usize, _shifts: *const f64,
                ) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3SetShiftDecimal", "the models have no clocks",
                    );
                [] fn fmi3SetShiftFraction(
                    c: Instance, _vr: *const u32, _nvr: usize, _counters: *const u64,
                    _resolutions: *const u64,
                ) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3SetShiftFraction", "the models have no clocks",
                    );
                [unsafe] fn fmi3UpdateDiscreteStates(
                    c: Instance, need_update: *mut Bool3, terminate: *mut Bool3,
                    nominals_changed: *mut Bool3, values_changed: *mut Bool3, next_defined: *mut Bool3,
                    next: *mut f64,
                ) -> Status
                    = capi::fmi3_me::update_discrete_states::<E>(
                        c, need_update, terminate, nominals_changed, values_changed, next_defined,
                        next,
                    );
                [] fn fmi3EnterContinuousTimeMode(c: Instance) -> Status
                    = capi::fmi3_me::enter_continuous_time_mode::<E>(c);
                [unsafe] fn fmi3CompletedIntegratorStep(
                    c: Instance, no_prior: Bool3, enter_event_mode: *mut Bool3, terminate: *mut Bool3,
                ) -> Status
                    = capi::fmi3_me::completed_integrator_step::<E>(
                        c, no_prior, enter_event_mode, terminate,
                    );
                [] fn fmi3SetTime(c: Instance, time: f64) -> Status
                    = capi::fmi3_me::set_time::<E>(c, time);
                [unsafe] fn fmi3SetContinuousStates(c: Instance, x: *const f64, nx: usize) -> Status
                    = capi::fmi3_me::set_continuous_states::<E>(c, x, nx);
                [unsafe] fn fmi3GetContinuousStateDerivatives(
                    c: Instance, dx: *mut f64, nx: usize,
                ) -> Status
                    = capi::fmi3_me::get_continuous_state_derivatives::<E>(c, dx, nx);
                [unsafe] fn fmi3GetEventIndicators(c: Instance, z: *mut f64, ni: usize) -> Status
                    = capi::fmi3_me::get_event_indicators::<E>(c, z, ni);
                [unsafe] fn fmi3GetContinuousStates(c: Instance, x: *mut f64, nx: usize) -> Status
                    = capi::fmi3_me::get_continuous_states::<E>(c, x, nx);
                [unsafe] fn fmi3GetNominalsOfContinuousStates(
                    c: Instance, nominals: *mut f64, nx: usize,
                ) -> Status
                    = capi::fmi3_me::get_nominals_of_continuous_states::<E>(c, nominals, nx);
                [unsafe] fn fmi3GetNumberOfEventIndicators(c: Instance, n: *mut usize) -> Status
                    = capi::fmi3_me::get_number_of_event_indicators::<E>(c, n);
                [unsafe] fn fmi3GetNumberOfContinuousStates(c: Instance, n: *mut usize) -> Status
                    = capi::fmi3_me::get_number_of_continuous_states::<E>(c, n);
                [] fn fmi3EnterStepMode(c: Instance) -> Status
                    = capi::fmi3_cs::enter_step_mode::<E>(c);
                [unsafe] fn fmi3GetOutputDerivatives(
                    c: Instance, vr: *const u32, nvr: usize, orders: *const i32, v: *mut f64,
                    nv: usize,
                ) -> Status
                    = capi::fmi3_cs::get_output_derivatives::<E>(c, vr, nvr, orders, v, nv);
                [unsafe] fn fmi3DoStep(
                    c: Instance, current: f64, h: f64, no_prior: Bool3,
                    event_handling_needed: *mut Bool3, terminate: *mut Bool3, early_return: *mut Bool3,
                    last_successful_time: *mut f64,
                ) -> Status
                    = capi::fmi3_cs::do_step::<E>(
                        c, current, h, no_prior, event_handling_needed, terminate, early_return,
                        last_successful_time,
                    );
                [] fn fmi3ActivateModelPartition(c: Instance, _clock: u32, _time: f64) -> Status
                    = capi::fmi3::not_offered::<E>(
                        c, "fmi3ActivateModelPartition",
                        "no Scheduled Execution: the models have no clocks",
                    );
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
