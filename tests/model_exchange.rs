//! FMI 2.0 Model Exchange beside Co-Simulation in one binary: the ME state machine of the
//! standard (section 3.2.3) function by function and state by state through the C API
//! (allowed, or fmi2Error with one line and nothing changed), the refusal of the other
//! interface's functions and FMU states, derivatives and directional derivatives equal to
//! Co-Simulation's, events (on_event after a crossing, terminateSimulation from an `Err`),
//! and step events that keep a constrained system on its constraints (and measurably not
//! with `me_projection` = 0).

mod common;

use common::*;
use mbfmu::fmi::fmi2::EventInfoC;
use mbfmu::fmi::{Instance, Interface, Logger, Mode, ModelInfo, Status, NO_EVENT_INDICATOR};
use mbfmu::model::System;
use mbfmu::systems::{
    MassSpringDamper, NonlinearBicycle, PulledPendulum, RollingHoop, SliderCrankSurplus,
    SphereSlide,
};
use std::ffi::{c_int, c_void, CString};

// ---------------------------------------------------------------------------------------
// The state machine through the C API (MassSpringDamper, exported by tests/common)
// ---------------------------------------------------------------------------------------

#[derive(Clone, Copy, Debug, PartialEq)]
enum S {
    Instantiated,
    Init,
    Event,
    Continuous,
    Terminated,
}

const ALL: [S; 5] = [
    S::Instantiated,
    S::Init,
    S::Event,
    S::Continuous,
    S::Terminated,
];

/// A Model Exchange instance of MassSpringDamper brought to `state`.
fn me_in(state: S, name: &str) -> *mut c_void {
    let cname = CString::new(name).unwrap();
    let c = unsafe {
        fmi2Instantiate(
            cname.as_ptr(),
            0,
            guid().as_ptr(),
            std::ptr::null(),
            callbacks(),
            0,
            0,
        )
    };
    assert!(!c.is_null());
    if state == S::Instantiated {
        return c;
    }
    assert_eq!(fmi2SetupExperiment(c, 1, 1e-8, 0.0, 0, 0.0), Status::Ok);
    assert_eq!(fmi2EnterInitializationMode(c), Status::Ok);
    if state == S::Init {
        return c;
    }
    assert_eq!(fmi2ExitInitializationMode(c), Status::Ok);
    match state {
        S::Event => {}
        S::Continuous => assert_eq!(fmi2EnterContinuousTimeMode(c), Status::Ok),
        S::Terminated => assert_eq!(fmi2Terminate(c), Status::Ok),
        _ => unreachable!(),
    }
    c
}

type Call = fn(*mut c_void) -> Status;

/// Every function a Model Exchange importer may call, with valid arguments, and the states
/// in which the standard's table (FMI 2.0.5, section 3.2.3) allows it. Written out here,
/// independently of `src/fmi/fmi2/mod.rs`.
fn table() -> Vec<(&'static str, Call, &'static [S])> {
    use S::*;
    vec![
        (
            "fmi2SetupExperiment",
            |c| fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0),
            &[Instantiated],
        ),
        (
            "fmi2EnterInitializationMode",
            |c| fmi2EnterInitializationMode(c),
            &[Instantiated],
        ),
        (
            "fmi2ExitInitializationMode",
            |c| fmi2ExitInitializationMode(c),
            &[Init],
        ),
        ("fmi2Terminate", |c| fmi2Terminate(c), &[Event, Continuous]),
        (
            "fmi2Reset",
            |c| fmi2Reset(c),
            &[Instantiated, Init, Event, Continuous, Terminated],
        ),
        (
            "fmi2GetReal",
            |c| unsafe { fmi2GetReal(c, &vr("x"), 1, &mut 0.0) },
            &[Init, Event, Continuous, Terminated],
        ),
        (
            "fmi2SetReal (input)",
            |c| unsafe { fmi2SetReal(c, &vr("F"), 1, &0.5) },
            &[Instantiated, Init, Event, Continuous],
        ),
        (
            "fmi2SetReal (parameter)",
            |c| unsafe { fmi2SetReal(c, &vr("m"), 1, &2.0) },
            &[Instantiated, Init],
        ),
        (
            "fmi2GetInteger",
            |c| unsafe { fmi2GetInteger(c, &vr("me_projection"), 1, &mut 0) },
            &[Init, Event, Continuous, Terminated],
        ),
        (
            "fmi2SetInteger (fixed parameter)",
            |c| unsafe { fmi2SetInteger(c, &vr("me_projection"), 1, &0) },
            &[Instantiated, Init],
        ),
        (
            "fmi2SetTime",
            |c| fmi2SetTime(c, 0.25),
            &[Event, Continuous],
        ),
        (
            "fmi2SetContinuousStates",
            |c| unsafe { fmi2SetContinuousStates(c, [0.2, 0.1].as_ptr(), 2) },
            &[Continuous],
        ),
        (
            "fmi2GetContinuousStates",
            |c| unsafe { fmi2GetContinuousStates(c, [0.0; 2].as_mut_ptr(), 2) },
            &[Init, Event, Continuous, Terminated],
        ),
        (
            "fmi2GetDerivatives",
            |c| unsafe { fmi2GetDerivatives(c, [0.0; 2].as_mut_ptr(), 2) },
            &[Event, Continuous, Terminated],
        ),
        (
            "fmi2GetEventIndicators",
            |c| unsafe { fmi2GetEventIndicators(c, std::ptr::null_mut(), 0) },
            &[Init, Event, Continuous, Terminated],
        ),
        (
            "fmi2GetNominalsOfContinuousStates",
            |c| unsafe { fmi2GetNominalsOfContinuousStates(c, [0.0; 2].as_mut_ptr(), 2) },
            &[Instantiated, Event, Continuous, Terminated],
        ),
        (
            "fmi2EnterEventMode",
            |c| fmi2EnterEventMode(c),
            &[Event, Continuous],
        ),
        (
            "fmi2NewDiscreteStates",
            |c| unsafe { fmi2NewDiscreteStates(c, &mut EventInfoC::default()) },
            &[Event],
        ),
        (
            "fmi2EnterContinuousTimeMode",
            |c| fmi2EnterContinuousTimeMode(c),
            &[Event],
        ),
        (
            "fmi2CompletedIntegratorStep",
            |c| unsafe { fmi2CompletedIntegratorStep(c, 1, &mut 0, &mut 0) },
            &[Continuous],
        ),
        (
            "fmi2GetDirectionalDerivative",
            |c| unsafe {
                fmi2GetDirectionalDerivative(c, &vr("der(v)"), 1, &vr("x"), 1, &1.0, &mut 0.0)
            },
            &[Init, Event, Continuous, Terminated],
        ),
        (
            "fmi2GetFMUstate",
            |c| unsafe {
                let mut s: *mut c_void = std::ptr::null_mut();
                let st = fmi2GetFMUstate(c, &mut s);
                fmi2FreeFMUstate(c, &mut s);
                st
            },
            &[Instantiated, Init, Event, Continuous, Terminated],
        ),
        // Co-Simulation's own functions: never in Model Exchange.
        ("fmi2DoStep", |c| fmi2DoStep(c, 0.0, 0.01, 1), &[]),
        (
            "fmi2SetRealInputDerivatives",
            |c| unsafe { fmi2SetRealInputDerivatives(c, &vr("F"), 1, &1, &0.0) },
            &[],
        ),
        (
            "fmi2GetRealOutputDerivatives",
            |c| unsafe { fmi2GetRealOutputDerivatives(c, &vr("x"), 1, &1, &mut 0.0) },
            &[],
        ),
        (
            "fmi2GetRealStatus",
            |c| unsafe { fmi2GetRealStatus(c, 2, &mut 0.0) },
            &[],
        ),
        (
            "fmi2GetBooleanStatus",
            |c| unsafe { fmi2GetBooleanStatus(c, 3, &mut 0) },
            &[],
        ),
        ("fmi2CancelStep", |c| fmi2CancelStep(c), &[]),
    ]
}

#[test]
fn every_function_in_every_state_is_allowed_or_refused_with_one_line() {
    let mut refused = 0;
    for (k, (name, call, allowed)) in table().into_iter().enumerate() {
        for (j, state) in ALL.into_iter().enumerate() {
            let inst = format!("me_table_{k}_{j}");
            let c = me_in(state, &inst);
            let before = log_of(&inst).len();
            let status = call(c);
            let lines = &log_of(&inst)[before..];
            if allowed.contains(&state) {
                assert!(
                    matches!(status, Status::Ok),
                    "{name} in {state:?}: {status:?}, {lines:?}"
                );
                assert!(lines.is_empty(), "{name} in {state:?}: {lines:?}");
            } else {
                refused += 1;
                assert_eq!(status, Status::Error, "{name} in {state:?} was accepted");
                assert_eq!(lines.len(), 1, "{name} in {state:?}: {lines:?}");
                let line = &lines[0].2;
                assert!(!line.contains('\n'), "{line}");
                // The other interface's functions say so.
                if allowed.is_empty() && name != "fmi2CancelStep" {
                    assert!(line.contains("a Co-Simulation function"), "{line}");
                }
                // A refused call changed nothing: the instance is still in its state (the
                // functions allowed there still are).
                if state == S::Continuous {
                    assert_eq!(fmi2CompletedIntegratorStep_ok(c), Status::Ok, "{name}");
                }
            }
            unsafe { fmi2FreeInstance(c) };
        }
    }
    println!("METRIC model exchange state table: {refused} refusals, each one line");
}

#[allow(non_snake_case)]
fn fmi2CompletedIntegratorStep_ok(c: *mut c_void) -> Status {
    unsafe { fmi2CompletedIntegratorStep(c, 1, &mut 0, &mut 0) }
}

/// Bad arguments in the states that allow the call: fmi2Error, one line, nothing changed.
#[test]
fn bad_arguments_are_refused_and_change_nothing() {
    let c = me_in(S::Continuous, "me_bad");
    let mut x = [0.0; 2];
    assert_eq!(
        unsafe { fmi2GetContinuousStates(c, x.as_mut_ptr(), 2) },
        Status::Ok
    );
    let nan = f64::NAN;
    let cases: Vec<(&str, Status)> = vec![
        ("NaN time", fmi2SetTime(c, nan)),
        ("infinite time", fmi2SetTime(c, f64::INFINITY)),
        ("NaN state", unsafe {
            fmi2SetContinuousStates(c, [nan, 0.0].as_ptr(), 2)
        }),
        ("inf state", unsafe {
            fmi2SetContinuousStates(c, [0.0, -f64::INFINITY].as_ptr(), 2)
        }),
        ("nx too small", unsafe {
            fmi2SetContinuousStates(c, [0.3].as_ptr(), 1)
        }),
        ("nx too large", unsafe {
            fmi2GetDerivatives(c, [0.0; 3].as_mut_ptr(), 3)
        }),
        ("NULL states", unsafe {
            fmi2SetContinuousStates(c, std::ptr::null(), 2)
        }),
        ("NULL derivatives", unsafe {
            fmi2GetDerivatives(c, std::ptr::null_mut(), 2)
        }),
        ("ni of a model without indicators", unsafe {
            fmi2GetEventIndicators(c, [0.0].as_mut_ptr(), 1)
        }),
        ("NULL enterEventMode", unsafe {
            fmi2CompletedIntegratorStep(c, 1, std::ptr::null_mut(), &mut 0)
        }),
        ("nominals nx", unsafe {
            fmi2GetNominalsOfContinuousStates(c, [0.0].as_mut_ptr(), 1)
        }),
        ("state through fmi2SetReal", unsafe {
            fmi2SetReal(c, &vr("x"), 1, &0.3)
        }),
        ("NaN input", unsafe { fmi2SetReal(c, &vr("F"), 1, &nan) }),
    ];
    for (what, status) in &cases {
        assert_eq!(*status, Status::Error, "{what}");
    }
    let log = log_of("me_bad");
    assert_eq!(log.len(), cases.len(), "one line each: {log:?}");
    let mut after = [0.0; 2];
    assert_eq!(
        unsafe { fmi2GetContinuousStates(c, after.as_mut_ptr(), 2) },
        Status::Ok
    );
    assert_eq!(x, after);
    let mut info = EventInfoC::default();
    assert_eq!(fmi2EnterEventMode(c), Status::Ok);
    assert_eq!(
        unsafe { fmi2NewDiscreteStates(c, std::ptr::null_mut()) },
        Status::Error
    );
    assert_eq!(unsafe { fmi2NewDiscreteStates(c, &mut info) }, Status::Ok);
    assert_eq!(info.values_of_continuous_states_changed, 0);
    unsafe { fmi2FreeInstance(c) };
}

/// A Co-Simulation instance refuses Model Exchange's functions, and an FMU state of one
/// interface is refused by an instance of the other (fmi2SetFMUstate and
/// fmi2DeSerializeFMUstate), with a line naming both.
#[test]
fn the_other_interface_is_refused_functions_and_states() {
    let cs = Fmu::new("cs_refuses_me");
    cs.init(&[]);
    assert_eq!(fmi2SetTime(cs.c, 0.0), Status::Error);
    assert_eq!(
        unsafe { fmi2GetDerivatives(cs.c, [0.0; 2].as_mut_ptr(), 2) },
        Status::Error
    );
    assert_eq!(
        unsafe { fmi2GetNominalsOfContinuousStates(cs.c, [0.0; 2].as_mut_ptr(), 2) },
        Status::Error
    );
    assert_eq!(fmi2EnterEventMode(cs.c), Status::Error);
    let log = log_of("cs_refuses_me");
    assert_eq!(log.len(), 4, "{log:?}");
    assert!(
        log.iter()
            .all(|l| l.2.contains("a Model Exchange function")),
        "{log:?}"
    );

    let me = me_in(S::Continuous, "me_refuses_cs_state");
    let mut s_cs: *mut c_void = std::ptr::null_mut();
    let mut s_me: *mut c_void = std::ptr::null_mut();
    assert_eq!(unsafe { fmi2GetFMUstate(cs.c, &mut s_cs) }, Status::Ok);
    assert_eq!(unsafe { fmi2GetFMUstate(me, &mut s_me) }, Status::Ok);
    assert_eq!(unsafe { fmi2SetFMUstate(me, s_cs) }, Status::Error);
    assert_eq!(unsafe { fmi2SetFMUstate(cs.c, s_me) }, Status::Error);
    assert_eq!(unsafe { fmi2SetFMUstate(me, s_me) }, Status::Ok);
    // Serialized: refused on the way in.
    let mut size = 0usize;
    assert_eq!(
        unsafe { fmi2SerializedFMUstateSize(cs.c, s_cs, &mut size) },
        Status::Ok
    );
    let mut blob = vec![0 as std::ffi::c_char; size];
    assert_eq!(
        unsafe { fmi2SerializeFMUstate(cs.c, s_cs, blob.as_mut_ptr(), size) },
        Status::Ok
    );
    let mut s_in: *mut c_void = std::ptr::null_mut();
    assert_eq!(
        unsafe { fmi2DeSerializeFMUstate(me, blob.as_ptr(), size, &mut s_in) },
        Status::Error
    );
    assert!(s_in.is_null());
    let me_log = log_of("me_refuses_cs_state");
    assert_eq!(me_log.len(), 2, "{me_log:?}");
    for l in &me_log {
        assert!(
            l.2.contains("taken in a Co-Simulation instance, this one is Model Exchange"),
            "{}",
            l.2
        );
    }
    assert!(log_of("cs_refuses_me")[4]
        .2
        .contains("taken in a Model Exchange instance"));
    unsafe {
        fmi2FreeFMUstate(me, &mut s_me);
        fmi2FreeFMUstate(cs.c, &mut s_cs);
        fmi2FreeInstance(me);
    }
}

// ---------------------------------------------------------------------------------------
// The models under Model Exchange (the instance API, with a small importer of its own)
// ---------------------------------------------------------------------------------------

fn info<M: System>() -> &'static ModelInfo {
    Box::leak(Box::new(ModelInfo::of::<M>()))
}

fn instance<M: System>(
    interface: Interface,
    set: &[(&str, f64)],
    ints: &[(&str, i32)],
) -> Instance<M> {
    let info = info::<M>();
    let vr = |n: &str| info.layout.vr_of(n).unwrap();
    let mut inst = Instance::<M>::for_interface(info, Logger::silent("me"), interface);
    inst.setup_experiment(Some(1e-8), 0.0, None).unwrap();
    for (n, v) in set {
        inst.set_real(&[vr(n)], &[*v]).unwrap();
    }
    for (n, v) in ints {
        inst.set_integer(&[vr(n)], &[*v]).unwrap();
    }
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    if interface == Interface::ModelExchange {
        assert_eq!(inst.mode(), Mode::Event);
        let info = inst.new_discrete_states().unwrap();
        assert!(
            !info.values_of_continuous_states_changed,
            "initial state already projected"
        );
        inst.enter_continuous_time_mode().unwrap();
    }
    inst
}

fn states<M: System>(inst: &Instance<M>) -> Vec<f64> {
    let mut x = vec![0.0; M::states().len()];
    inst.get_continuous_states(&mut x).unwrap();
    x
}

/// The full Jacobian [∂(ẋ, y)/∂(x, u)] through fmi2GetDirectionalDerivative, column by column.
fn jacobian<M: System>(inst: &Instance<M>) -> Vec<f64> {
    let l = &inst.info.layout;
    let knowns: Vec<u32> = (0..l.vars.len() as u32)
        .filter(|&v| {
            matches!(
                l.slot(v).unwrap().kind,
                mbfmu::model::VarKind::State | mbfmu::model::VarKind::Input
            )
        })
        .collect();
    let unknowns: Vec<u32> = (0..l.vars.len() as u32)
        .filter(|&v| {
            matches!(
                l.slot(v).unwrap().kind,
                mbfmu::model::VarKind::Derivative | mbfmu::model::VarKind::Output
            )
        })
        .collect();
    let mut out = Vec::new();
    for &k in &knowns {
        let mut col = vec![0.0; unknowns.len()];
        inst.directional_derivative(&unknowns, &[k], &[1.0], &mut col)
            .unwrap();
        out.extend(col);
    }
    out
}

/// At a state a Co-Simulation run reached, an ME instance set to the same time and states
/// gives the same derivatives (bit for bit: the same f) and the same directional
/// derivatives (the same dual numbers).
fn derivatives_equal_cs<M: System>(set: &[(&str, f64)]) {
    let mut cs = instance::<M>(Interface::CoSimulation, set, &[]);
    for i in 0..10 {
        cs.do_step(i as f64 * 0.01, 0.01).unwrap();
    }
    let l = &cs.info.layout;
    let n = M::states().len();
    let x: Vec<f64> = (0..n)
        .map(|i| {
            let mut v = 0.0;
            cs.get_real(
                &[l.vr_of_slot(mbfmu::model::VarKind::State, i)],
                std::slice::from_mut(&mut v),
            )
            .unwrap();
            v
        })
        .collect();
    let der_vrs: Vec<u32> = (0..n)
        .map(|i| l.vr_of_slot(mbfmu::model::VarKind::Derivative, i))
        .collect();
    let mut dx_cs = vec![0.0; n];
    cs.get_real(&der_vrs, &mut dx_cs).unwrap();
    let mut me = instance::<M>(Interface::ModelExchange, set, &[]);
    me.set_time(cs.time()).unwrap();
    me.set_continuous_states(&x).unwrap();
    let mut dx_me = vec![0.0; n];
    assert_eq!(me.get_derivatives(&mut dx_me).unwrap(), Status::Ok);
    assert_eq!(dx_cs, dx_me, "{}", M::NAME);
    assert_eq!(jacobian(&cs), jacobian(&me), "{}", M::NAME);
}

#[test]
fn derivatives_and_directional_derivatives_equal_co_simulation() {
    derivatives_equal_cs::<MassSpringDamper>(&[("F", 0.3)]);
    derivatives_equal_cs::<SphereSlide>(&[]);
    derivatives_equal_cs::<RollingHoop>(&[]);
    derivatives_equal_cs::<PulledPendulum>(&[]);
    derivatives_equal_cs::<SliderCrankSurplus>(&[]);
    derivatives_equal_cs::<NonlinearBicycle>(&[]);
}

/// The largest constraint residual of `M` at this state (0 where it holds none).
fn residual<M: System>(t: f64, x: &[f64], p: &[f64]) -> f64 {
    let mut r = vec![0.0; M::STATE_CONSTRAINTS];
    if !M::state_constraints(t, x, p, &mut r) {
        return 0.0;
    }
    r.iter().fold(0.0f64, |a, v| a.max(v.abs()))
}

/// A minimal importer: classic RK4 on fmi2SetTime / fmi2SetContinuousStates /
/// fmi2GetDerivatives with step `h`, fmi2CompletedIntegratorStep after every step and the
/// step event it asks for. Returns the largest constraint residual seen and the number of
/// step events.
fn import_rk4<M: System>(inst: &mut Instance<M>, t_end: f64, h: f64) -> (f64, usize) {
    let n = M::states().len();
    let p: Vec<f64> = {
        let l = &inst.info.layout;
        (0..M::parameters().len())
            .map(|i| {
                let mut v = 0.0;
                inst.get_real(
                    &[l.vr_of_slot(mbfmu::model::VarKind::Parameter, i)],
                    std::slice::from_mut(&mut v),
                )
                .unwrap();
                v
            })
            .collect()
    };
    let (mut t, mut worst, mut events) = (inst.time(), 0.0f64, 0);
    let f = |inst: &mut Instance<M>, t: f64, x: &[f64]| {
        inst.set_time(t).unwrap();
        inst.set_continuous_states(x).unwrap();
        let mut dx = vec![0.0; n];
        inst.get_derivatives(&mut dx).unwrap();
        dx
    };
    while t < t_end - 1e-12 {
        let x = states(inst);
        let k1 = f(inst, t, &x);
        let x2: Vec<f64> = (0..n).map(|i| x[i] + 0.5 * h * k1[i]).collect();
        let k2 = f(inst, t + 0.5 * h, &x2);
        let x3: Vec<f64> = (0..n).map(|i| x[i] + 0.5 * h * k2[i]).collect();
        let k3 = f(inst, t + 0.5 * h, &x3);
        let x4: Vec<f64> = (0..n).map(|i| x[i] + h * k3[i]).collect();
        let k4 = f(inst, t + h, &x4);
        let xn: Vec<f64> = (0..n)
            .map(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
            .collect();
        t += h;
        inst.set_time(t).unwrap();
        inst.set_continuous_states(&xn).unwrap();
        let (enter, terminate) = inst.completed_integrator_step().unwrap();
        assert!(!terminate);
        if enter {
            events += 1;
            inst.enter_event_mode().unwrap();
            let info = inst.new_discrete_states().unwrap();
            assert!(info.values_of_continuous_states_changed);
            inst.enter_continuous_time_mode().unwrap();
        }
        worst = worst.max(residual::<M>(t, &states(inst), &p));
    }
    (worst, events)
}

/// A constrained system under Model Exchange stays on its constraints through step events,
/// to within the rule that asks for them (a state off by more than 10 × the tolerance, 1e-8
/// here, of its scale); with `me_projection` = 0 the same importer drifts off them further.
#[test]
fn step_events_keep_constrained_systems_on_their_constraints() {
    fn case<M: System>(t_end: f64, h: f64) {
        let mut on = instance::<M>(Interface::ModelExchange, &[], &[]);
        let (kept, events) = import_rk4(&mut on, t_end, h);
        let mut off = instance::<M>(Interface::ModelExchange, &[], &[("me_projection", 0)]);
        let (drift, none) = import_rk4(&mut off, t_end, h);
        println!(
            "METRIC {} ME RK4 h = {h}: residual {kept:.1e} with projection ({events} step events), {drift:.1e} without",
            M::NAME
        );
        assert_eq!(
            none,
            0,
            "{}: no step events with me_projection = 0",
            M::NAME
        );
        // The residual in its own units (lengths and rates together) from a 1e-7 move per
        // state, plus one step's drift before the check: below 50 × the tolerance (the same
        // bound as tests/python/test_model_exchange.py's under CVODE).
        assert!(kept < 50.0 * 1e-8, "{}: {kept}", M::NAME);
        if drift > 1e-6 {
            assert!(events > 0, "{}", M::NAME);
            assert!(drift > 100.0 * kept, "{}: {drift} vs {kept}", M::NAME);
        } else {
            // Within the rule's 1e-7 per state (RK4 at h = 1e-2 keeps the bicycle's
            // constraints to 1e-10 over 1 s): no event, no restart asked of the importer.
            assert!(drift < 1e-7, "{}: {drift}", M::NAME);
            assert_eq!(events, 0, "{}", M::NAME);
        }
    }
    case::<SliderCrankSurplus>(1.0, 1e-2);
    case::<NonlinearBicycle>(1.0, 1e-2);
    case::<SphereSlide>(2.3, 1e-2);
    case::<SphereSlide>(2.3, 5e-2);
}

/// SphereSlide: the normal force is the indicator while on the sphere; once it changed sign
/// fmi2NewDiscreteStates applies the departure (on_surface = 0, valuesOfContinuousStatesChanged)
/// and the indicator is the constant NO_EVENT_INDICATOR in free flight.
#[test]
fn sphere_slide_departs_in_event_mode() {
    let mut me = instance::<SphereSlide>(Interface::ModelExchange, &[], &[]);
    let mut z = [0.0];
    me.get_event_indicators(&mut z).unwrap();
    assert!(z[0] > 0.0, "pressed onto the sphere at the top: {}", z[0]);
    // Past the departure angle (cos θ < 2/3) at rest speed of the energy: N < 0.
    let theta: f64 = 0.9;
    let v = (2.0 * 9.81 * (1.0 - theta.cos())).sqrt();
    let x = [
        theta.sin(),
        theta.cos(),
        v * theta.cos(),
        -v * theta.sin(),
        1.0,
    ];
    // A mode a little past its declared [0, 1] is accepted: CVODE's finite-difference
    // Jacobian perturbs on_surface = 1 to 1 + 1.5e-8 (refusing it broke fmpy's runs).
    me.set_continuous_states(&[x[0], x[1], x[2], x[3], 1.0 + 1.5e-8])
        .unwrap();
    me.set_continuous_states(&x).unwrap();
    me.get_event_indicators(&mut z).unwrap();
    assert!(z[0] < 0.0, "{}", z[0]);
    let mut ev = [0.0];
    me.completed_integrator_step().unwrap();
    me.enter_event_mode().unwrap();
    let info = me.new_discrete_states().unwrap();
    assert!(info.values_of_continuous_states_changed && !info.terminate_simulation);
    assert_eq!(states(&me)[4], 0.0, "on_surface");
    me.get_event_indicators(&mut ev).unwrap();
    assert_eq!(ev[0], NO_EVENT_INDICATOR);
    // A second event iteration changes nothing.
    let again = me.new_discrete_states().unwrap();
    assert!(!again.values_of_continuous_states_changed);
}

/// PulledPendulum: the string reaching its shortest length is an event whose `on_event`
/// refuses to go on: terminateSimulation, the states unchanged.
#[test]
fn an_event_the_model_cannot_pass_terminates_the_simulation() {
    let mut me = instance::<PulledPendulum>(Interface::ModelExchange, &[("l_rate", -0.5)], &[]);
    let mut z = [0.0];
    me.get_event_indicators(&mut z).unwrap();
    assert!(z[0] > 0.0);
    me.set_time(2.5).unwrap(); // l = 1 − 0.5·2.5 < 0.01
    me.get_event_indicators(&mut z).unwrap();
    assert!(z[0] < 0.0);
    let x = states(&me);
    me.enter_event_mode().unwrap();
    let info = me.new_discrete_states().unwrap();
    assert!(info.terminate_simulation);
    assert_eq!(states(&me)[..2], x[..2]);
    me.terminate().unwrap();
    assert_eq!(me.mode(), Mode::Terminated);
}

/// The Error state (after a caught panic): the getters answer, the rest is refused (FMI
/// 2.0's table, checked by the C entry points).
#[test]
fn the_error_state_allows_only_getters_and_reset() {
    let c = me_in(S::Event, "error-state");
    let inst = c as *mut Instance<MassSpringDamper>;
    // SAFETY: an FMI 2.0 instance of the MassSpringDamper exported into this test.
    unsafe { (*inst).poison() };
    let (mut x, mut enter, mut terminate) = ([0.0; 2], 0, 0);
    unsafe {
        assert_eq!(fmi2GetContinuousStates(c, x.as_mut_ptr(), 2), Status::Ok);
        assert_eq!(fmi2GetDerivatives(c, x.as_mut_ptr(), 2), Status::Ok);
        let nominals = fmi2GetNominalsOfContinuousStates(c, x.as_mut_ptr(), 2);
        assert_eq!(nominals, Status::Ok);
        assert_eq!(fmi2SetContinuousStates(c, x.as_ptr(), 2), Status::Error);
        let completed = fmi2CompletedIntegratorStep(c, 1, &mut enter, &mut terminate);
        assert_eq!(completed, Status::Error);
    }
    assert_eq!(fmi2SetTime(c, 1.0), Status::Error);
    assert_eq!(fmi2EnterEventMode(c), Status::Error);
    assert_eq!(fmi2Terminate(c), Status::Error);
    assert_eq!(fmi2Reset(c), Status::Ok);
    // SAFETY: as above.
    let (machine, interface) = unsafe { ((*inst).mode(), (*inst).interface()) };
    assert_eq!(machine, Mode::Instantiated);
    assert_eq!(interface, Interface::ModelExchange);
    unsafe { fmi2FreeInstance(c) };
}

/// What the modelDescriptions declare for Model Exchange, system by system: one event
/// indicator for the systems with events, step events (completedIntegratorStepNotNeeded =
/// false) for those that project.
#[test]
fn every_system_declares_its_indicators_and_step_events() {
    let events = ["SphereSlide", "NonlinearBicycle", "PulledPendulum"];
    let projects = [
        "RigidBody",
        "RollingHoop",
        "RollingDisk",
        "SphereSlide",
        "SliderCrankSurplus",
        "NonlinearBicycle",
        "RotatingHoopBead",
        "PulledPendulum",
        // The mechanisms with closed loops project onto their closures.
        "FourBar",
        "AndrewsSqueezer",
        "NFourBar",
        "Bricard",
    ];
    for e in mbfmu::catalogue::all() {
        let xml = (e.model_description)();
        let n = if events.contains(&e.name) { 1 } else { 0 };
        assert!(
            xml.contains(&format!("numberOfEventIndicators=\"{n}\"")),
            "{}",
            e.name
        );
        let not_needed = !projects.contains(&e.name);
        assert!(
            xml.contains(&format!(
                "completedIntegratorStepNotNeeded=\"{not_needed}\""
            )),
            "{}",
            e.name
        );
        assert_eq!(
            xml.contains("reinit=\"true\""),
            !not_needed || n > 0,
            "{}",
            e.name
        );
        let me = xml.find("<ModelExchange ").expect("ModelExchange");
        assert!(me < xml.find("<CoSimulation ").unwrap(), "schema order");
        let last = xml.rfind("<ScalarVariable name=").unwrap();
        assert!(
            xml[last..].starts_with("<ScalarVariable name=\"me_projection\""),
            "{}: appended last",
            e.name
        );
    }
}

#[allow(dead_code)]
fn unused(_: c_int) {}

/// A Model Exchange FMU state goes through its blob unchanged (the interface, the event
/// reference and `me_projection` included), every bit flip of it is refused, and a restored
/// state goes on as the original does.
#[test]
fn a_model_exchange_state_round_trips_through_its_blob() {
    let mut me = instance::<SphereSlide>(Interface::ModelExchange, &[], &[("me_projection", 0)]);
    me.set_time(0.5).unwrap();
    let snap = me.snapshot();
    assert_eq!(snap.interface, Interface::ModelExchange);
    assert!(!snap.me_projection);
    assert!(snap.event_reference.is_some());
    let blob = me.serialize(&snap);
    let back = me.deserialize(&blob).unwrap();
    assert_eq!(back, snap);
    let mut bad = blob.clone();
    for byte in 0..blob.len() {
        for bit in 0..8 {
            bad[byte] ^= 1 << bit;
            assert!(me.deserialize(&bad).is_err(), "flip {byte}.{bit} accepted");
            bad[byte] ^= 1 << bit;
        }
    }
    let mut other = instance::<SphereSlide>(Interface::ModelExchange, &[], &[]);
    other.restore(&back).unwrap();
    let (mut a, mut b) = ([0.0; 5], [0.0; 5]);
    me.get_derivatives(&mut a).unwrap();
    other.get_derivatives(&mut b).unwrap();
    assert_eq!(a, b);
    assert_eq!(other.completed_integrator_step().unwrap(), (false, false));
}
