//! A restored FMU state (fmi2SetFMUstate, fmi2DeSerializeFMUstate) is checked as the setters
//! check their values, and its integrator state ahead must agree with it: a blob with an
//! intact checksum but values no setter would take is refused (fmi2Error, one log line,
//! nothing changed), while every state fmi2GetFMUstate makes restores, on every system and
//! with every dense-output method.

mod common;

use common::*;
use mbfmu::fmi::{Export, Instance, Logger, Mode, ModelInfo, Snapshot, Status, StepOutcome};
use mbfmu::integrators::{Ahead, Method};
use mbfmu::model::System;
use mbfmu::systems::{self, MassSpringDamper};
use std::ffi::{c_char, c_void};

/// An instance of `S` on its first scene with `solver`, initialised at t = 0.
fn started<S: System>(solver: Method) -> Instance<S> {
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<S>()));
    let scene = S::scenes().remove(0);
    let mut inst = Instance::<S>::new(info, Logger::silent("validation"));
    let vr = |name: &str| info.layout.vr_of(name).unwrap();
    inst.setup_experiment(Some(1e-8), 0.0, Some(scene.stop_time))
        .unwrap();
    for (name, value) in &scene.start_values {
        inst.set_real(&[vr(name)], &[*value]).unwrap();
    }
    inst.set_integer(&[vr("solver")], &[solver.code()]).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    inst
}

/// The state of `inst` restores, directly and through its blob, to itself.
fn restores<S: System>(inst: &mut Instance<S>, what: &str) {
    let s = inst.snapshot();
    let blob = inst.serialize(&s);
    let back = inst
        .deserialize(&blob)
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    assert_eq!(back, s, "{what}");
    inst.restore(&s).unwrap_or_else(|e| panic!("{what}: {e}"));
    assert_eq!(inst.snapshot(), s, "{what}");
}

/// 12 doSteps of 7e-3 s (not a divisor of any step) with the dense-output methods and a
/// fixed-step one, an input changed after 6 when the system has one: every state on the
/// way restores.
fn every_state_restores<S: System>() {
    for solver in [Method::Dopri5, Method::Dop853, Method::Radau5, Method::Rk4] {
        let mut inst = started::<S>(solver);
        let what = |i: usize| format!("{} {} after {i} doSteps", S::NAME, solver.name());
        restores(&mut inst, &what(0));
        let h = 7e-3;
        for i in 0..12 {
            if i == 6 {
                if let Some(input) = inst
                    .info
                    .layout
                    .vars
                    .iter()
                    .position(|(s, _)| s.kind == mbfmu::model::VarKind::Input)
                {
                    inst.set_real(&[input as u32], &[0.01]).unwrap();
                    restores(&mut inst, &format!("{} (input changed)", what(i)));
                }
            }
            let outcome = inst.do_step(i as f64 * h, h).unwrap();
            restores(&mut inst, &what(i + 1));
            if outcome != StepOutcome::Completed {
                break;
            }
        }
    }
}

#[test]
fn every_state_get_makes_restores_on_every_system() {
    every_state_restores::<systems::MassSpringDamper>();
    every_state_restores::<systems::TwoMassChain>();
    every_state_restores::<systems::RigidBody>();
    every_state_restores::<systems::Projectile>();
    every_state_restores::<systems::SpringyPendulum>();
    every_state_restores::<systems::DoublePendulum>();
    every_state_restores::<systems::SpringRodPendulum>();
    every_state_restores::<systems::SphereSlide>();
    every_state_restores::<systems::CompoundPendulum>();
    every_state_restores::<systems::RollingHoop>();
    every_state_restores::<systems::RollingDisk>();
    every_state_restores::<systems::WhippleBicycle>();
    every_state_restores::<systems::SliderCrank>();
    every_state_restores::<systems::SliderCrankSurplus>();
    every_state_restores::<systems::RotatingHoopBead>();
    every_state_restores::<systems::PulledPendulum>();
}

/// MassSpringDamper under `solver` after 10 doSteps of 1e-2 s (DOPRI5: with its point ahead).
fn msd(solver: Method) -> Instance<MassSpringDamper> {
    let mut inst = started::<MassSpringDamper>(solver);
    for i in 0..10 {
        assert_eq!(
            inst.do_step(i as f64 * 1e-2, 1e-2).unwrap(),
            StepOutcome::Completed
        );
    }
    inst
}

type Change = Box<dyn Fn(&mut Snapshot)>;

/// Changes to a valid MassSpringDamper state (DOPRI5, after 10 doSteps) that make one no
/// setter would accept, with a word the refusal must contain.
fn bad_states() -> Vec<(&'static str, &'static str, Change)> {
    vec![
        ("tolerance 0", "tolerance", Box::new(|s| s.tolerance = 0.0)),
        ("tolerance 1", "tolerance", Box::new(|s| s.tolerance = 1.0)),
        (
            "tolerance < 0",
            "tolerance",
            Box::new(|s| s.tolerance = -1e-6),
        ),
        (
            "solver_step 0",
            "solver_step",
            Box::new(|s| s.solver_step = 0.0),
        ),
        (
            "solver_step < 0",
            "solver_step",
            Box::new(|s| s.solver_step = -1e-3),
        ),
        (
            "solver_max_steps 0",
            "solver_max_steps",
            Box::new(|s| s.max_steps = 0),
        ),
        (
            "solver_max_steps above an Integer",
            "solver_max_steps",
            Box::new(|s| s.max_steps = 1 << 40),
        ),
        ("mass 0", "for m ", Box::new(|s| s.params[0] = 0.0)),
        (
            "stiffness < 0",
            "for k ",
            Box::new(|s| s.params[1] = -100.0),
        ),
        (
            "NaN damping",
            "not finite",
            Box::new(|s| s.params[2] = f64::NAN),
        ),
        (
            "infinite input",
            "not finite",
            Box::new(|s| s.u[0] = f64::INFINITY),
        ),
        ("NaN state", "not finite", Box::new(|s| s.x[1] = f64::NAN)),
        (
            "RATTLE on a system not written as a Lagrangian",
            "RATTLE",
            Box::new(|s| {
                s.method = Method::Rattle;
                s.memory.ahead = None;
            }),
        ),
        (
            "ExactLinear with harmonic forcing",
            "linear time-invariant",
            Box::new(|s| {
                s.method = Method::ExactLinear;
                s.params[3] = 1.0;
                s.memory.ahead = None;
            }),
        ),
        (
            "stop time before the start time",
            "stopTime",
            Box::new(|s| s.stop_time = Some(-1.0)),
        ),
        (
            "time before the start time",
            "outside the experiment",
            Box::new(|s| {
                s.time = -0.5;
                s.memory.ahead = None;
            }),
        ),
        (
            "time after the stop time",
            "outside the experiment",
            Box::new(|s| {
                s.time = 11.0;
                s.memory.ahead = None;
            }),
        ),
        (
            "instantiated at another time than the start",
            "before initialisation",
            Box::new(|s| {
                s.mode = Mode::Instantiated;
                s.memory = Default::default();
            }),
        ),
        (
            "initialization mode with integrator memory",
            "before initialisation",
            Box::new(|s| {
                s.mode = Mode::Initializing;
                s.time = s.start_time;
            }),
        ),
        (
            "negative step proposal",
            "step-size proposal",
            Box::new(|s| s.memory.h = -1e-3),
        ),
        (
            "state moved under the point ahead",
            "another state",
            Box::new(|s| s.x[0] += 1e-9),
        ),
        (
            "time moved inside the point ahead's step",
            "another state",
            Box::new(|s| s.time -= 1e-9),
        ),
        (
            "time moved past the point ahead",
            "does not cover",
            Box::new(|s| s.time += 1.0),
        ),
        (
            "input changed under the point ahead",
            "other inputs or parameters",
            Box::new(|s| s.u[0] = 3.0),
        ),
        (
            "parameter changed under the point ahead",
            "other inputs or parameters",
            Box::new(|s| s.params[1] = 50.0),
        ),
        (
            "point ahead of a method not running",
            "kept for solver RK4",
            Box::new(|s| s.method = Method::Rk4),
        ),
    ]
}

#[test]
fn restored_values_are_checked_as_the_setters_check_them() {
    let mut inst = msd(Method::Dopri5);
    let good = inst.snapshot();
    assert!(good.memory.ahead.is_some());
    for (what, word, change) in bad_states() {
        let mut bad = good.clone();
        change(&mut bad);
        let e = inst.restore(&bad).unwrap_err();
        assert!(
            e.starts_with("refused, in the FMU state: ") && e.contains(word),
            "{what}: {e}"
        );
        assert_eq!(
            inst.snapshot(),
            good,
            "{what}: the refusal changed the instance"
        );
        // Behind an intact checksum: refused by fmi2DeSerializeFMUstate as well.
        let e = inst.deserialize(&inst.serialize(&bad)).unwrap_err();
        assert!(e.contains(word), "{what}: {e}");
        println!("{what}: {e}");
    }
    // Still usable, and the good state still restores.
    inst.restore(&good).unwrap();
    assert_eq!(inst.do_step(0.1, 1e-2).unwrap(), StepOutcome::Completed);
}

/// Checks that are not on MassSpringDamper: a symplectic method needs (q, q̇) states.
#[test]
fn a_method_the_system_refuses_is_refused_in_a_restored_state() {
    let mut inst = started::<systems::RigidBody>(Method::Rk4);
    let mut bad = inst.snapshot();
    bad.method = Method::Verlet;
    let e = inst.restore(&bad).unwrap_err();
    assert!(e.contains("needs states of the form"), "{e}");
    // Before initialisation ExactLinear is accepted with forcing parameters (they may still
    // change; fmi2ExitInitializationMode decides), as fmi2SetInteger accepts it.
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<MassSpringDamper>()));
    let mut fresh = Instance::<MassSpringDamper>::new(info, Logger::silent("fresh"));
    let mut before = fresh.snapshot();
    before.method = Method::ExactLinear;
    before.params[3] = 1.0;
    fresh.restore(&before).unwrap();
}

/// Through the C API: a blob with a valid checksum but a non-positive tolerance (which made
/// the next doStep panic before), or with a point ahead that no longer matches its state
/// (which made it return non-finite outputs with fmi2OK), is refused with fmi2Error and one
/// log line; the state pointer stays NULL.
#[test]
fn the_c_api_refuses_a_blob_with_values_no_setter_takes() {
    let f = Fmu::new("validated");
    f.init(&[("F", 0.5)]);
    run_to(&f, 0.0, 0.1, 0.01);
    let inst = Instance::<MassSpringDamper>::new(ExportedModel::info(), Logger::silent("x"));
    let mut s: *mut c_void = std::ptr::null_mut();
    assert_eq!(unsafe { fmi2GetFMUstate(f.c, &mut s) }, Status::Ok);
    let mut size = 0usize;
    assert_eq!(
        unsafe { fmi2SerializedFMUstateSize(f.c, s, &mut size) },
        Status::Ok
    );
    let mut blob = vec![0u8; size];
    let status = unsafe { fmi2SerializeFMUstate(f.c, s, blob.as_mut_ptr() as *mut c_char, size) };
    assert_eq!(status, Status::Ok);
    let good = inst.deserialize(&blob).unwrap();
    assert!(good.memory.ahead.is_some());
    let changes: [(&str, Change); 3] = [
        ("tolerance 0", Box::new(|s| s.tolerance = 0.0)),
        ("mass < 0", Box::new(|s| s.params[0] = -1.0)),
        (
            "point ahead far from the state",
            Box::new(|s| {
                let Some(Ahead::Dopri5(a)) = s.memory.ahead.as_mut() else {
                    panic!("DOPRI5 keeps its point ahead");
                };
                a.point.x[0] = 1e300;
                a.rcont.fill(1e300);
            }),
        ),
    ];
    for (what, change) in changes {
        let mut bad = good.clone();
        change(&mut bad);
        let bytes = inst.serialize(&bad);
        let mut out: *mut c_void = std::ptr::null_mut();
        let n = f.errors();
        let status = unsafe {
            fmi2DeSerializeFMUstate(f.c, bytes.as_ptr() as *const c_char, bytes.len(), &mut out)
        };
        assert_eq!(status, Status::Error, "{what}");
        assert!(out.is_null(), "{what}");
        let log = log_of(&f.name);
        assert_eq!(log.len(), n + 1, "{what}: one log line");
        assert!(log[n].2.contains("refused"), "{what}: {}", log[n].2);
    }
    // The instance is untouched and goes on.
    assert_eq!(fmi2DoStep(f.c, 0.1, 0.01, 1), Status::Ok);
    assert_eq!(unsafe { fmi2FreeFMUstate(f.c, &mut s) }, Status::Ok);
}

/// A blob's machine state does not change how its values are checked: ExactLinear on
/// CompoundPendulum (never linear) is refused in StepFailed as in StepComplete, through
/// fmi2SetFMUstate and through a serialized blob, and before initialisation too, where
/// fmi2SetInteger refuses it (issue 24: a StepFailed blob at the start time with its machine
/// state changed to Instantiated was accepted).
#[test]
fn a_refused_solver_is_refused_in_every_machine_state_after_initialisation() {
    let mut inst = started::<systems::CompoundPendulum>(Method::Rk4);
    let before_init = {
        let info: &'static ModelInfo =
            Box::leak(Box::new(ModelInfo::of::<systems::CompoundPendulum>()));
        Instance::<systems::CompoundPendulum>::new(info, Logger::silent("fresh")).snapshot()
    };
    for machine in [
        Mode::Instantiated,
        Mode::Initializing,
        Mode::Stepping,
        Mode::StepDiscarded,
        Mode::Terminated,
        Mode::Error,
    ] {
        let mut bad = if machine == Mode::Instantiated || machine == Mode::Initializing {
            before_init.clone()
        } else {
            inst.snapshot()
        };
        bad.method = Method::ExactLinear;
        bad.mode = machine;
        let e = inst.restore(&bad).unwrap_err();
        assert!(e.contains("linear time-invariant"), "{machine:?}: {e}");
        let blob = inst.serialize(&bad);
        let e = inst.deserialize(&blob).unwrap_err();
        assert!(e.contains("linear time-invariant"), "{machine:?}: {e}");
    }
}
