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

mod dense_common;

use dense_common::{
    bits, check_sweep, fresh_from, grids_agree, rollback, steps, sweep, worst_error, Case,
    EXACT_LINEAR, RADAU5,
};
use mbfmu::integrators::Ahead;
use mbfmu::systems::{MassSpringDamper, RigidBody, TwoMassChain};

const TOL: f64 = 1e-6;

fn chain() -> Case<TwoMassChain> {
    Case::new("stiff", &["x1", "x2", "v1", "v2"], TOL)
}

fn msd() -> Case<MassSpringDamper> {
    Case::new("damped", &["x", "v"], TOL)
}

/// The bound on the error at the communication points: radau5.f's local tolerance
/// 0.1·rtol^(2/3) = 1e-5 at rtol 1e-6. Between its steps the collocation polynomial has
/// order 3 (as the error estimate that controls the step), not the method's 5, so the
/// interpolated points are held to the local tolerance rather than to the (smaller)
/// global error at the step ends. Measured: 4.9e-6 (stiff chain), 5.3e-6 (damped).
const DENSE_BOUND: f64 = 1e-5;

#[test]
fn stiff_chain_rhs_count_does_not_depend_on_the_communication_step() {
    let runs = sweep(&chain(), RADAU5);
    check_sweep(&runs, DENSE_BOUND, 0);
}

#[test]
fn damped_oscillator_rhs_count_does_not_depend_on_the_communication_step() {
    let runs = sweep(&msd(), RADAU5);
    check_sweep(&runs, DENSE_BOUND, 0);
}

#[test]
fn communication_points_of_different_grids_agree_bit_for_bit() {
    grids_agree(&chain(), RADAU5, 0);
    grids_agree(&msd(), RADAU5, 0);
}

#[test]
fn rollback_and_serialization_continue_bit_for_bit() {
    rollback(&chain(), RADAU5);
    rollback(&msd(), RADAU5);
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
    assert!(matches!(
        inst.snapshot().memory.ahead,
        Some(Ahead::Radau5(_))
    ));
    inst.set_real(&[case.vr("F")], &[1.0]).unwrap();
    assert!(inst.snapshot().memory.ahead.is_none());
    let mut got = Vec::new();
    for i in 100..200 {
        // An unchanged value set every step keeps the state ahead: no extra work.
        inst.set_real(&[case.vr("F")], &[1.0]).unwrap();
        got.extend(steps(&case, &mut inst, comm, i, i + 1));
    }

    // Against the exact propagator and a RADAU5 run started afresh at t = 1 s from the
    // same state with F = 1 N.
    let fresh = |solver| fresh_from(&case, solver, (1.0, &at_switch), ("F", 1.0), comm, 100);
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
        TOL,
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
    let Some(Ahead::Radau5(ahead)) = inst.snapshot().memory.ahead else {
        panic!("RADAU5 keeps its state ahead");
    };
    let norm = ahead.x[3..7].iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!((norm - 1.0).abs() < 1e-15, "|q| = {norm}");
    println!("METRIC RADAU5 symmetric top: {stats:?} on every grid");
}
