//! RADAU5 inside `fmi2DoStep` runs ahead of the communication points with dense output
//! (radau5.f CONTR5): its steps are its controller's alone, so a small communication step
//! costs no extra work. Checked through the instance API on TwoMassChain `stiff` and
//! MassSpringDamper `damped`, against the exact propagator (ExactLinear, solver 11):
//! - the RHS count over a scene is the same for communication steps from the stop time down
//!   to 1e-4 s, and the communication points of two grids agree bit for bit where they meet;
//! - every communication point is as accurate as the integration;
//! - Get/SetFMUstate and the serialized state continue bit for bit;
//! - a changed input restarts the integration at the communication point;
//! - on a system with a projection (RigidBody's unit quaternion) the steps, projected after
//!   each one, are still the same on every grid.
//!
//! Measured at rtol 1e-6, communication steps stop time / 1e-2 / 1e-3 / 1e-4 s, RHS
//! evaluations (worst scaled error), landing on every point (before) and dense (after):
//! - TwoMassChain stiff, 2 s: landing 297 / 2 216 / 22 012 / 220 008 (66 … 40 002 steps);
//!   dense 297 (66 steps) on every grid, worst error 4.9e-6;
//! - MassSpringDamper damped, 10 s: landing 844 / 11 016 / 110 012 / 1 086 442; dense 844
//!   (190 steps) on every grid, worst error 5.3e-6.

use mbfmu::fmi::{Instance, Logger, ModelInfo, StepOutcome};
use mbfmu::integrators::Stats;
use mbfmu::model::System;
use mbfmu::systems::{MassSpringDamper, RigidBody, TwoMassChain};

const RADAU5: i32 = 10;
const EXACT_LINEAR: i32 = 11;
const TOL: f64 = 1e-6;

fn info<S: System>() -> &'static ModelInfo {
    Box::leak(Box::new(ModelInfo::of::<S>()))
}

/// A system under test: its model info, the scene and the names of its states.
struct Case<S: System> {
    info: &'static ModelInfo,
    scene: &'static str,
    states: &'static [&'static str],
    _s: std::marker::PhantomData<S>,
}

impl<S: System> Case<S> {
    fn new(scene: &'static str, states: &'static [&'static str]) -> Self {
        Case {
            info: info::<S>(),
            scene,
            states,
            _s: std::marker::PhantomData,
        }
    }

    fn vr(&self, name: &str) -> u32 {
        self.info.layout.vr_of(name).unwrap()
    }

    fn stop_time(&self) -> f64 {
        self.scene().stop_time
    }

    fn scene(&self) -> mbfmu::model::Scene {
        S::scenes()
            .into_iter()
            .find(|s| s.name == self.scene)
            .unwrap()
    }

    /// An instance in step mode at `start` with the scene's start values, `solver`, and
    /// `extra` values set in initialization mode (ExactLinear steps by the communication
    /// step `comm`).
    fn started(&self, solver: i32, comm: f64, start: f64, extra: &[(&str, f64)]) -> Instance<S> {
        let scene = self.scene();
        let mut inst = Instance::<S>::new(self.info, Logger::silent("dense_radau5"));
        inst.setup_experiment(Some(TOL), start, Some(scene.stop_time))
            .unwrap();
        inst.enter_initialization_mode().unwrap();
        for (name, value) in scene.start_values.iter().chain(extra) {
            inst.set_real(&[self.vr(name)], &[*value]).unwrap();
        }
        if solver == EXACT_LINEAR {
            inst.set_real(&[self.vr("solver_step")], &[comm]).unwrap();
        }
        inst.set_integer(&[self.vr("solver")], &[solver]).unwrap();
        inst.exit_initialization_mode().unwrap();
        inst
    }

    /// max_t |x_i(t)| of the exact trajectory on a 1e-2 s grid (the bench's error scale).
    fn scale(&self) -> Vec<f64> {
        let (grid, _) = self.run(EXACT_LINEAR, 1e-2);
        (0..self.states.len())
            .map(|i| grid.iter().fold(0.0f64, |m, x| m.max(x[i].abs())))
            .collect()
    }

    fn state(&self, inst: &Instance<S>) -> Vec<f64> {
        let vrs: Vec<u32> = self.states.iter().map(|n| self.vr(n)).collect();
        let mut x = vec![0.0; vrs.len()];
        inst.get_real(&vrs, &mut x).unwrap();
        x
    }

    /// doSteps of `comm` over the scene: the states at every communication point, and the
    /// stats.
    fn run(&self, solver: i32, comm: f64) -> (Vec<Vec<f64>>, Stats) {
        let mut inst = self.started(solver, comm, 0.0, &[]);
        let n = (self.stop_time() / comm).round() as usize;
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let t = i as f64 * comm;
            let h = if i + 1 == n {
                self.stop_time() - t
            } else {
                comm
            };
            assert_eq!(inst.do_step(t, h).unwrap(), StepOutcome::Completed);
            out.push(self.state(&inst));
        }
        (out, inst.stats())
    }
}

/// The largest error over a grid, component i scaled by `scale[i]`.
fn worst_error(got: &[Vec<f64>], reference: &[Vec<f64>], scale: &[f64]) -> f64 {
    let dim = scale.len();
    got.iter().zip(reference).fold(0.0f64, |m, (x, r)| {
        (0..dim).fold(m, |m, i| m.max((x[i] - r[i]).abs() / scale[i]))
    })
}

fn chain() -> Case<TwoMassChain> {
    Case::new("stiff", &["x1", "x2", "v1", "v2"])
}

fn msd() -> Case<MassSpringDamper> {
    Case::new("damped", &["x", "v"])
}

/// RHS counts and worst errors for communication steps stop time, 1e-2, 1e-3, 1e-4.
fn sweep<S: System>(case: &Case<S>) -> Vec<(f64, u64, f64)> {
    let scale = case.scale();
    [case.stop_time(), 1e-2, 1e-3, 1e-4]
        .into_iter()
        .map(|comm| {
            let (x, stats) = case.run(RADAU5, comm);
            let (reference, _) = case.run(EXACT_LINEAR, comm);
            let err = worst_error(&x, &reference, &scale);
            println!(
                "METRIC RADAU5 {} comm {comm:e}: {} RHS, {} steps, worst error {err:.2e}",
                case.scene, stats.rhs_evals, stats.steps
            );
            (comm, stats.rhs_evals, err)
        })
        .collect()
}

fn check_sweep(runs: &[(f64, u64, f64)], bound: f64) {
    for (comm, evals, err) in runs {
        assert_eq!(*evals, runs[0].1, "comm {comm}: {evals} vs {}", runs[0].1);
        assert!(*err < bound, "comm {comm}: worst error {err:e}");
    }
}

/// The bound on the error at the communication points: radau5.f's local tolerance
/// 0.1·rtol^(2/3) = 1e-5 at rtol 1e-6. Between its steps the collocation polynomial has
/// order 3 (as the error estimate that controls the step), not the method's 5, so the
/// interpolated points are held to the local tolerance rather than to the (smaller)
/// global error at the step ends. Measured: 4.9e-6 (stiff chain), 5.3e-6 (damped).
const DENSE_BOUND: f64 = 1e-5;

#[test]
fn stiff_chain_rhs_count_does_not_depend_on_the_communication_step() {
    let runs = sweep(&chain());
    check_sweep(&runs, DENSE_BOUND);
}

#[test]
fn damped_oscillator_rhs_count_does_not_depend_on_the_communication_step() {
    let runs = sweep(&msd());
    check_sweep(&runs, DENSE_BOUND);
}

fn bits(v: &[Vec<f64>]) -> Vec<u64> {
    v.iter().flatten().map(|x| x.to_bits()).collect()
}

/// Grids of 1/8, 1/64 and 1/512 s (exact in binary, so the points meet exactly): the
/// states where they meet are the same bits, as from one run read at those points.
fn grids_agree<S: System>(case: &Case<S>) {
    let coarse = 0.125;
    let (x8, s8) = case.run(RADAU5, coarse);
    for fine in [coarse / 8.0, coarse / 64.0] {
        let (x, s) = case.run(RADAU5, fine);
        let every = (coarse / fine) as usize;
        let met: Vec<Vec<f64>> = x.into_iter().skip(every - 1).step_by(every).collect();
        assert_eq!(bits(&met), bits(&x8), "{} at {fine}", case.scene);
        assert_eq!(s, s8, "{} at {fine}", case.scene);
    }
}

#[test]
fn communication_points_of_different_grids_agree_bit_for_bit() {
    grids_agree(&chain());
    grids_agree(&msd());
}

/// doSteps of `comm` from `from` to `to` (indices), the states after each.
fn steps<S: System>(
    case: &Case<S>,
    inst: &mut Instance<S>,
    comm: f64,
    from: usize,
    to: usize,
) -> Vec<Vec<f64>> {
    (from..to)
        .map(|i| {
            assert_eq!(
                inst.do_step(i as f64 * comm, comm).unwrap(),
                StepOutcome::Completed
            );
            case.state(inst)
        })
        .collect()
}

fn rollback<S: System>(case: &Case<S>) {
    let comm = 1e-3;
    let mut inst = case.started(RADAU5, comm, 0.0, &[]);
    steps(case, &mut inst, comm, 0, 300);
    let saved = inst.snapshot();
    assert!(
        saved.memory.radau5_ahead.is_some(),
        "RADAU5 keeps its loop state ahead of the communication time"
    );
    let blob = inst.serialize(&saved);
    let forward = steps(case, &mut inst, comm, 300, 700);
    let stats = inst.stats();
    for restore in [saved.clone(), inst.deserialize(&blob).unwrap()] {
        assert_eq!(restore, saved);
        inst.restore(&restore).unwrap();
        let again = steps(case, &mut inst, comm, 300, 700);
        assert_eq!(bits(&again), bits(&forward), "{}", case.scene);
        assert_eq!(inst.stats(), stats);
    }
}

#[test]
fn rollback_and_serialization_continue_bit_for_bit() {
    rollback(&chain());
    rollback(&msd());
}

#[test]
fn a_changed_input_restarts_at_the_communication_point() {
    // Stiff chain; F = 1 N on m1 from t = 1 s on, set between doSteps of 0.01 s. Had the
    // integrator kept its state ahead (computed with F = 0), the force would start late.
    let case = chain();
    let comm = 0.01;
    let mut inst = case.started(RADAU5, comm, 0.0, &[]);
    steps(&case, &mut inst, comm, 0, 100);
    let at_switch = case.state(&inst);
    assert!(inst.snapshot().memory.radau5_ahead.is_some());
    inst.set_real(&[case.vr("F")], &[1.0]).unwrap();
    assert!(inst.snapshot().memory.radau5_ahead.is_none());
    let mut got = Vec::new();
    for i in 100..200 {
        // An unchanged value set every step keeps the state ahead: no extra work.
        inst.set_real(&[case.vr("F")], &[1.0]).unwrap();
        got.extend(steps(&case, &mut inst, comm, i, i + 1));
    }

    // Against the exact propagator and a RADAU5 run started afresh at t = 1 s from the
    // same state with F = 1 N.
    let start: Vec<(&str, f64)> = case
        .states
        .iter()
        .copied()
        .zip(at_switch)
        .chain([("F", 1.0)])
        .collect();
    let fresh = |solver: i32| {
        let mut inst = case.started(solver, comm, 1.0, &start);
        (0..100)
            .map(|i| {
                let t = 1.0 + i as f64 * comm;
                assert_eq!(inst.do_step(t, comm).unwrap(), StepOutcome::Completed);
                case.state(&inst)
            })
            .collect::<Vec<_>>()
    };
    let (exact, restarted) = (fresh(EXACT_LINEAR), fresh(RADAU5));
    // Positions only: the force step on m1 excites the fast mode (relative velocity
    // amplitude ~F/(m·ω_fast) ≈ 4e-4 m/s at ω_fast = 1414 rad/s), which RADAU5's L-stable
    // steps damp instead of resolving (its error estimate filters stiff components through
    // (γ/h·I − J)⁻¹): every RADAU5 run, the fresh one too, is off by ~3e-4 (scaled) in the
    // velocities. In the positions that mode is ω_fast times smaller. A force starting one
    // RADAU5 step (~0.03 s) late would be off by ~0.5·a·dt² ≈ 2e-4 m, 2e-3 scaled.
    let pos = |v: &[Vec<f64>]| v.iter().map(|x| x[..2].to_vec()).collect::<Vec<_>>();
    let scale = &case.scale()[..2];
    let err_exact = worst_error(&pos(&got), &pos(&exact), scale);
    let err_fresh = worst_error(&pos(&got), &pos(&restarted), scale);
    println!(
        "METRIC RADAU5 input step at t = 1 s: position error {err_exact:.2e}, vs fresh run {err_fresh:.2e}"
    );
    assert!(
        err_exact < DENSE_BOUND && err_fresh < DENSE_BOUND,
        "{err_exact:e} {err_fresh:e}"
    );

    // Unchanged inputs set every step: the same bits and work as not setting them.
    let work = |set_every_step: bool| {
        let mut inst = case.started(RADAU5, comm, 0.0, &[]);
        let mut x = Vec::new();
        for i in 0..200 {
            if set_every_step {
                inst.set_real(&[case.vr("F")], &[0.0]).unwrap();
            }
            x.extend(steps(&case, &mut inst, comm, i, i + 1));
        }
        (inst.stats(), bits(&x))
    };
    assert_eq!(work(true), work(false));
}

#[test]
fn projected_steps_do_not_depend_on_the_communication_step() {
    let case = Case::<RigidBody>::new(
        "symmetric_top",
        &["omega1", "omega2", "omega3", "q0", "q1", "q2", "q3"],
    );
    let (x_stop, stats) = case.run(RADAU5, case.stop_time());
    for comm in [1e-2, 1e-3] {
        let (x, s) = case.run(RADAU5, comm);
        assert_eq!(s, stats, "comm {comm}");
        let end = x.last().unwrap();
        let gap = (0..7).fold(0.0f64, |m, i| m.max((end[i] - x_stop[0][i]).abs()));
        assert_eq!(
            gap, 0.0,
            "comm {comm}: the stop time is a step end on every grid"
        );
        for q in x.iter().map(|x| &x[3..]) {
            let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
            assert!((norm - 1.0).abs() < 1e-14, "|q| = {norm}");
        }
    }
    // The integrator's own point is on the constraint (projected after every step).
    let mut inst = case.started(RADAU5, 1e-2, 0.0, &[]);
    steps(&case, &mut inst, 1e-2, 0, 123);
    let ahead = inst.snapshot().memory.radau5_ahead.unwrap();
    let norm = ahead.x[3..7].iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!((norm - 1.0).abs() < 1e-15, "|q| = {norm}");
    println!("METRIC RADAU5 symmetric top: {stats:?} on every grid");
}
