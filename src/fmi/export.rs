//! `export_fmu!`: the `fmi2*` symbols of one FMU's cdylib, Co-Simulation's and Model
//! Exchange's (one binary serves both interfaces; fmi2Instantiate's fmuType picks one).
//!
//! Thin on purpose: each symbol forwards to the generic function of the same name in
//! [`capi`](crate::fmi::capi), where the checks live. One macro line per FMU crate:
//! `mbfmu::export_fmu!(mbfmu::systems::MassSpringDamper);`
//!
//! Beside FMI it exports `mbfmu_describe` and `mbfmu_free`, through which the packager asks
//! the compiled model for its XML, documentation and linearisation
//! ([`package::protocol`](crate::package::protocol)): the FMU's interface comes from the
//! binary it ships.

/// Defines the complete FMI 2.0 C API, Co-Simulation and Model Exchange, for one
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

            /// Not FMI: the packager's questions (`mbfmu::package::protocol`).
            #[no_mangle]
            pub unsafe extern "C" fn mbfmu_describe(request: *const c_char) -> *mut c_char {
                capi::describe(
                    request,
                    $crate::describe::$respond::<<E as $crate::fmi::Export>::Model>,
                )
            }
            /// Not FMI: frees what `mbfmu_describe` returned.
            #[no_mangle]
            pub unsafe extern "C" fn mbfmu_free(text: *mut c_char) {
                capi::free_string(text)
            }
            #[no_mangle]
            pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
                capi::get_types_platform()
            }
            #[no_mangle]
            pub extern "C" fn fmi2GetVersion() -> *const c_char {
                capi::get_version()
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetDebugLogging(
                c: Component,
                on: c_int,
                n: usize,
                cats: *const *const c_char,
            ) -> Status {
                capi::set_debug_logging::<E>(c, on, n, cats)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2Instantiate(
                name: *const c_char,
                fmu_type: c_int,
                guid: *const c_char,
                resources: *const c_char,
                functions: *const CallbackFunctions,
                visible: c_int,
                logging_on: c_int,
            ) -> Component {
                capi::instantiate::<E>(
                    name, fmu_type, guid, resources, functions, visible, logging_on,
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeInstance(c: Component) {
                capi::free_instance::<E>(c)
            }
            #[no_mangle]
            pub extern "C" fn fmi2SetupExperiment(
                c: Component,
                tol_defined: c_int,
                tol: f64,
                start: f64,
                stop_defined: c_int,
                stop: f64,
            ) -> Status {
                capi::setup_experiment::<E>(c, tol_defined, tol, start, stop_defined, stop)
            }
            #[no_mangle]
            pub extern "C" fn fmi2EnterInitializationMode(c: Component) -> Status {
                capi::enter_initialization_mode::<E>(c)
            }
            #[no_mangle]
            pub extern "C" fn fmi2ExitInitializationMode(c: Component) -> Status {
                capi::exit_initialization_mode::<E>(c)
            }
            #[no_mangle]
            pub extern "C" fn fmi2Terminate(c: Component) -> Status {
                capi::terminate::<E>(c)
            }
            #[no_mangle]
            pub extern "C" fn fmi2Reset(c: Component) -> Status {
                capi::reset::<E>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetReal(
                c: Component,
                vr: *const c_uint,
                n: usize,
                v: *mut f64,
            ) -> Status {
                capi::get_real::<E>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetInteger(
                c: Component,
                vr: *const c_uint,
                n: usize,
                v: *mut c_int,
            ) -> Status {
                capi::get_integer::<E>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBoolean(
                c: Component,
                vr: *const c_uint,
                n: usize,
                v: *mut c_int,
            ) -> Status {
                capi::no_such_type::<E, c_int>(c, "fmi2GetBoolean", capi::GET_MASK, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetString(
                c: Component,
                vr: *const c_uint,
                n: usize,
                v: *mut *const c_char,
            ) -> Status {
                capi::no_such_type::<E, *const c_char>(c, "fmi2GetString", capi::GET_MASK, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetReal(
                c: Component,
                vr: *const c_uint,
                n: usize,
                v: *const f64,
            ) -> Status {
                capi::set_real::<E>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetInteger(
                c: Component,
                vr: *const c_uint,
                n: usize,
                v: *const c_int,
            ) -> Status {
                capi::set_integer::<E>(c, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetBoolean(
                c: Component,
                vr: *const c_uint,
                n: usize,
                v: *const c_int,
            ) -> Status {
                capi::no_such_type::<E, c_int>(c, "fmi2SetBoolean", capi::SET_MASK, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetString(
                c: Component,
                vr: *const c_uint,
                n: usize,
                v: *const *const c_char,
            ) -> Status {
                capi::no_such_type::<E, *const c_char>(c, "fmi2SetString", capi::SET_MASK, vr, n, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetFMUstate(c: Component, s: *mut FmuState) -> Status {
                capi::get_fmu_state::<E>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetFMUstate(c: Component, s: FmuState) -> Status {
                capi::set_fmu_state::<E>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2FreeFMUstate(c: Component, s: *mut FmuState) -> Status {
                capi::free_fmu_state::<E>(c, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
                c: Component,
                s: FmuState,
                size: *mut usize,
            ) -> Status {
                capi::serialized_fmu_state_size::<E>(c, s, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SerializeFMUstate(
                c: Component,
                s: FmuState,
                bytes: *mut c_char,
                size: usize,
            ) -> Status {
                capi::serialize_fmu_state::<E>(c, s, bytes, size)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
                c: Component,
                bytes: *const c_char,
                size: usize,
                s: *mut FmuState,
            ) -> Status {
                capi::deserialize_fmu_state::<E>(c, bytes, size, s)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
                c: Component,
                unknown: *const c_uint,
                n_unknown: usize,
                known: *const c_uint,
                n_known: usize,
                dv_known: *const f64,
                dv_unknown: *mut f64,
            ) -> Status {
                capi::get_directional_derivative::<E>(
                    c, unknown, n_unknown, known, n_known, dv_known, dv_unknown,
                )
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
                c: Component,
                vr: *const c_uint,
                n: usize,
                order: *const c_int,
                v: *const f64,
            ) -> Status {
                capi::set_real_input_derivatives::<E>(c, vr, n, order, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
                c: Component,
                vr: *const c_uint,
                n: usize,
                order: *const c_int,
                v: *mut f64,
            ) -> Status {
                capi::get_real_output_derivatives::<E>(c, vr, n, order, v)
            }
            #[no_mangle]
            pub extern "C" fn fmi2DoStep(c: Component, t: f64, h: f64, no_prior: c_int) -> Status {
                capi::do_step::<E>(c, t, h, no_prior)
            }
            #[no_mangle]
            pub extern "C" fn fmi2CancelStep(c: Component) -> Status {
                capi::cancel_step::<E>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStatus(
                c: Component,
                kind: c_int,
                v: *mut c_int,
            ) -> Status {
                capi::get_status::<E>(c, kind, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetRealStatus(
                c: Component,
                kind: c_int,
                v: *mut f64,
            ) -> Status {
                capi::get_real_status::<E>(c, kind, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetIntegerStatus(
                c: Component,
                kind: c_int,
                v: *mut c_int,
            ) -> Status {
                capi::get_integer_status::<E>(c, kind, v)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetBooleanStatus(
                c: Component,
                kind: c_int,
                v: *mut c_int,
            ) -> Status {
                capi::get_boolean_status::<E>(c, kind, v)
            }
            // Model Exchange.
            #[no_mangle]
            pub extern "C" fn fmi2EnterEventMode(c: Component) -> Status {
                capi::enter_event_mode::<E>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2NewDiscreteStates(
                c: Component,
                info: *mut EventInfoC,
            ) -> Status {
                capi::new_discrete_states::<E>(c, info)
            }
            #[no_mangle]
            pub extern "C" fn fmi2EnterContinuousTimeMode(c: Component) -> Status {
                capi::enter_continuous_time_mode::<E>(c)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2CompletedIntegratorStep(
                c: Component,
                no_prior: c_int,
                enter_event_mode: *mut c_int,
                terminate_simulation: *mut c_int,
            ) -> Status {
                capi::completed_integrator_step::<E>(
                    c,
                    no_prior,
                    enter_event_mode,
                    terminate_simulation,
                )
            }
            #[no_mangle]
            pub extern "C" fn fmi2SetTime(c: Component, time: f64) -> Status {
                capi::set_time::<E>(c, time)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2SetContinuousStates(
                c: Component,
                x: *const f64,
                nx: usize,
            ) -> Status {
                capi::set_continuous_states::<E>(c, x, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetDerivatives(
                c: Component,
                dx: *mut f64,
                nx: usize,
            ) -> Status {
                capi::get_derivatives::<E>(c, dx, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetEventIndicators(
                c: Component,
                z: *mut f64,
                ni: usize,
            ) -> Status {
                capi::get_event_indicators::<E>(c, z, ni)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetContinuousStates(
                c: Component,
                x: *mut f64,
                nx: usize,
            ) -> Status {
                capi::get_continuous_states::<E>(c, x, nx)
            }
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetNominalsOfContinuousStates(
                c: Component,
                nominals: *mut f64,
                nx: usize,
            ) -> Status {
                capi::get_nominals_of_continuous_states::<E>(c, nominals, nx)
            }
            // Co-Simulation.
            #[no_mangle]
            pub unsafe extern "C" fn fmi2GetStringStatus(
                c: Component,
                kind: c_int,
                v: *mut *const c_char,
            ) -> Status {
                capi::get_string_status::<E>(c, kind, v)
            }
        }
    };
}
