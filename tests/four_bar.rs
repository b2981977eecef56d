//! FourBar, declared as bodies, joints and one loop closure, against the four-bar's closed
//! forms: Freudenstein's equation for the position analysis along a run through the FMU's
//! own Instance (with the closure residuals after every doStep), the crank's equation of
//! motion in its one reduced coordinate (an independent derivation: closed-form positions
//! and velocity ratios, no multibody code), and energy conservation without input.

use mbfmu::fmi::{Instance, Logger, ModelInfo, StepOutcome};
use mbfmu::model::lagrangian::{self, Lagrangian};
use mbfmu::model::System;
use mbfmu::systems::four_bar::{
    freudenstein_rocker, A, B, C, CRANK_START, D, MASSES, RUN_SPEED, RUN_START,
};
use mbfmu::systems::FourBar as R;
use std::f64::consts::PI;

mod support;
use support::Rng;

const G: f64 = 9.81;
const SECTION: f64 = 0.01;

/// `x` into (−π, π].
fn wrap(x: f64) -> f64 {
    let y = x.rem_euclid(2.0 * PI);
    if y > PI {
        y - 2.0 * PI
    } else {
        y
    }
}

/// The closed-form configuration at crank angle θ2: (θ3 absolute, θ4), Freudenstein for
/// θ4 and the coupler's direction from A to B.
fn closed_form(t2: f64) -> (f64, f64) {
    let t4 = freudenstein_rocker(t2);
    let (bx, by) = (D + C * t4.cos(), C * t4.sin());
    let t3 = (by - A * t2.sin()).atan2(bx - A * t2.cos());
    (t3, t4)
}

/// The velocity ratios ω3/ω2, ω4/ω2 of the loop equation's derivative:
/// ω3 = a ω2 sin(θ4 − θ2) / (b sin(θ3 − θ4)), ω4 = a ω2 sin(θ2 − θ3) / (c sin(θ4 − θ3)).
fn ratios(t2: f64) -> (f64, f64, f64, f64) {
    let (t3, t4) = closed_form(t2);
    (
        t3,
        t4,
        A * (t4 - t2).sin() / (B * (t3 - t4).sin()),
        A * (t2 - t3).sin() / (C * (t4 - t3).sin()),
    )
}

/// The reduced model in θ2: `J(θ2) = Σ mᵢ |∂cᵢ/∂θ2|² + Iᵢ (∂θᵢ/∂θ2)²` and `V(θ2)`.
fn inertia_and_potential(t2: f64) -> (f64, f64) {
    let (t3, t4, r3, r4) = ratios(t2);
    let i = |m: f64, l: f64| m * (l * l + SECTION * SECTION) / 12.0;
    let [m1, m2, m3] = MASSES;
    // Centres of mass and their derivatives along θ2.
    let c1 = (
        0.5 * A * t2.sin(),
        [-0.5 * A * t2.sin(), 0.5 * A * t2.cos()],
    );
    let c2y = A * t2.sin() + 0.5 * B * t3.sin();
    let c2d = [
        -A * t2.sin() - 0.5 * B * t3.sin() * r3,
        A * t2.cos() + 0.5 * B * t3.cos() * r3,
    ];
    let c3y = 0.5 * C * t4.sin();
    let c3d = [-0.5 * C * t4.sin() * r4, 0.5 * C * t4.cos() * r4];
    let sq = |v: [f64; 2]| v[0] * v[0] + v[1] * v[1];
    let j = m1 * sq(c1.1)
        + i(m1, A)
        + m2 * sq(c2d)
        + i(m2, B) * r3 * r3
        + m3 * sq(c3d)
        + i(m3, C) * r4 * r4;
    let v = G * (m1 * c1.0 + m2 * c2y + m3 * c3y);
    (j, v)
}

/// θ̈2 of the reduced Lagrangian `½ J(θ2) θ̇2² − V(θ2)` with the crank torque τ:
/// `J θ̈2 + ½ J' θ̇2² + V' = τ` (J', V' by central differences, step 1e-5: truncation
/// ~1e-10, rounding ~1e-11 of J).
fn reduced_acceleration(t2: f64, w2: f64, tau: f64) -> f64 {
    let h = 1e-5;
    let (j, _) = inertia_and_potential(t2);
    let (jp, vp) = inertia_and_potential(t2 + h);
    let (jm, vm) = inertia_and_potential(t2 - h);
    let (dj, dv) = ((jp - jm) / (2.0 * h), (vp - vm) / (2.0 * h));
    (tau - dv - 0.5 * dj * w2 * w2) / j
}

/// The FourBar state at crank angle θ2 and rate ω2 from the closed forms.
fn state(t2: f64, w2: f64) -> [f64; 6] {
    let (t3, t4, r3, r4) = ratios(t2);
    [t2, t3 - t2, t4, w2, (r3 - 1.0) * w2, r4 * w2]
}

fn params() -> Vec<f64> {
    <R as System>::parameters()
        .iter()
        .map(|v| v.start)
        .collect()
}

/// The held linkage of `four_bar::mechanism` (the FMU starts it moving: `running`).
type Held = mbfmu::multibody::fmu::Robot<mbfmu::systems::four_bar::HeldFourBar>;

/// The FMU's start values are the closed form at θ2 = 1 rad turning at 10 rad/s (the
/// dependent rates solved from the crank's), with no torques: its default experiment moves.
#[test]
fn the_start_is_the_closed_form_turning() {
    let start =
        |vars: Vec<mbfmu::model::Var>| -> Vec<f64> { vars.iter().map(|v| v.start).collect() };
    let q = start(<R as Lagrangian>::coordinates());
    let qd = start(<R as Lagrangian>::velocities());
    let x = state(RUN_START, RUN_SPEED);
    assert_eq!((q[0], qd[0]), (RUN_START, RUN_SPEED));
    let e = (0..3).fold(0.0f64, |s, i| {
        s.max((q[i] - x[i]).abs()).max((qd[i] - x[3 + i]).abs())
    });
    println!("METRIC FourBar start vs Freudenstein: {e:.2e} (rad, rad/s)");
    assert!(e < 1e-13, "{q:?} {qd:?} vs {x:?}");
    let u = start(<R as System>::inputs());
    assert_eq!(u, [0.0; 3], "no torques");
}

/// Declared held at θ2 = −1.5 rad, the start torques hold the linkage: at rest, no
/// acceleration, only the crank driven.
#[test]
fn the_held_start_holds_itself() {
    let q: Vec<f64> = <Held as Lagrangian>::coordinates()
        .iter()
        .map(|v| v.start)
        .collect();
    let x = state(CRANK_START, 0.0);
    assert_eq!(q[0], CRANK_START);
    let e = (q[1] - x[1]).abs().max((q[2] - x[2]).abs());
    assert!(e < 1e-14, "{q:?} vs {x:?}");
    let u: Vec<f64> = <Held as System>::inputs().iter().map(|v| v.start).collect();
    assert_eq!(&u[1..], &[0.0, 0.0], "only the crank is driven");
    assert!(u[0].abs() > 0.1, "gravity needs a torque: {}", u[0]);
    let xs: Vec<f64> = q.iter().copied().chain([0.0; 3]).collect();
    let mut dx = [0.0; 6];
    <Held as System>::derivatives(0.0, &xs, &u, &params(), &mut dx);
    println!("hold tau_crank = {} N.m, q'' = {:?}", u[0], &dx[3..]);
    assert!(dx[3..].iter().all(|a| a.abs() < 1e-12), "{dx:?}");
    // FourBar's `step` scene starts there, at rest, the holding torque stepped by 1 N.m.
    let step = <R as System>::scenes()
        .into_iter()
        .find(|s| s.name == "step")
        .unwrap();
    let value = |name: &str| {
        step.start_values
            .iter()
            .find(|(n, _)| *n == name)
            .unwrap()
            .1
    };
    assert_eq!(value("crank"), CRANK_START);
    // (The closed form's positions; the held start's are Newton's: the last bit may differ.)
    assert!((value("coupler") - q[1]).abs() < 1e-14 && (value("rocker") - q[2]).abs() < 1e-14);
    assert_eq!((value("crank_dot"), value("tau_crank")), (0.0, u[0] + 1.0));
}

/// The λ-method on the declared mechanism gives the crank the acceleration of the reduced
/// one-coordinate model built from the closed forms, at random states and torques.
#[test]
fn the_crank_accelerates_as_the_reduced_model() {
    let p = params();
    let mut rng = Rng(0xf0b4_7001);
    let mut worst = 0.0f64;
    for _ in 0..200 {
        let t2 = rng.uniform(-PI, PI);
        let w2 = rng.uniform(-20.0, 20.0);
        let tau = rng.uniform(-5.0, 5.0);
        let x = state(t2, w2);
        let mut dx = [0.0; 6];
        <R as System>::derivatives(0.0, &x, &[tau, 0.0, 0.0], &p, &mut dx);
        let reduced = reduced_acceleration(t2, w2, tau);
        let scale = reduced.abs().max(w2 * w2).max(1.0);
        worst = worst.max((dx[3] - reduced).abs() / scale);
    }
    println!(
        "METRIC FourBar crank acceleration vs reduced closed-form model: {worst:.2e} (relative)"
    );
    assert!(worst < 1e-8, "{worst:e}");
}

/// The run scene (crank at 10 rad/s, no torque) for 2 s in doSteps of 10 ms through the
/// FMU's Instance at the default tolerance. After every doStep the state is projected on
/// the closure, so the closure residual is at rounding (the projection's own rule:
/// 4 ε max(1, |q|)), and θ4 equals Freudenstein's θ4(θ2) up to that residual over
/// c sin μ (μ the transmission angle, 54° … 100° for this linkage, so sin μ ≥ 0.81): a
/// bound at rounding, not at the integration tolerance, which only enters θ2(t) itself.
/// Energy is conserved to the integration tolerance (no input, no damping).
#[test]
fn a_run_follows_freudenstein_with_closed_loops_and_conserves_energy() {
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<R>()));
    let mut inst = Instance::<R>::new(info, Logger::silent("four_bar"));
    let vr = |n: &str| info.layout.vr_of(n).expect(n);
    let scene = <R as Lagrangian>::scenes()
        .into_iter()
        .find(|s| s.name == "run")
        .expect("a run scene");
    for (name, v) in &scene.start_values {
        inst.set_real(&[vr(name)], &[*v]).unwrap();
    }
    let (_, tol, _) = <R as Lagrangian>::default_experiment();
    inst.setup_experiment(Some(tol), 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    let names = ["crank", "coupler", "rocker", "crank_dot", "E"];
    let vrs: Vec<u32> = names.iter().map(|n| vr(n)).collect();
    let mut y = [0.0; 5];
    inst.get_real(&vrs, &mut y).unwrap();
    assert_eq!(y[0], RUN_START);
    assert_eq!(y[3], RUN_SPEED);
    let e0 = y[4];
    let p = params();
    let (mut wr, mut wf, mut we) = (0.0f64, 0.0f64, 0.0f64);
    let mut bound = 0.0f64;
    let h = 0.01;
    for k in 0..200 {
        assert_eq!(
            inst.do_step(k as f64 * h, h).unwrap(),
            StepOutcome::Completed
        );
        inst.get_real(&vrs, &mut y).unwrap();
        let q = &y[..3];
        let phi = lagrangian::constraint_values::<R, f64>(0.0, q, &p);
        let r = phi.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        let rounding = 4.0 * f64::EPSILON * q.iter().fold(1.0f64, |s, v| s.max(v.abs()));
        assert!(r <= rounding, "residual {r:e} at step {k}");
        wr = wr.max(r);
        // Residual over c sin μ, plus the closed form's own rounding at this |θ2|.
        bound = bound.max(rounding / (C * 0.81) + 8.0 * f64::EPSILON * q[0].abs().max(1.0));
        wf = wf.max(wrap(q[2] - freudenstein_rocker(q[0])).abs());
        we = we.max((y[4] - e0).abs() / e0.abs());
    }
    println!("turns of the crank: {:.2}", (y[0] - RUN_START) / (2.0 * PI));
    println!(
        "METRIC FourBar run (DOPRI5 rtol {tol:e}): max closure residual {wr:.2e} m, max |θ4 − Freudenstein(θ2)| {wf:.2e} rad (bound {bound:.2e}), max |E − E0|/E0 {we:.2e}"
    );
    assert!(wf <= bound, "{wf:e} > {bound:e}");
    assert!(
        y[0] - RUN_START > 4.0 * PI,
        "the crank turns over: {}",
        y[0]
    );
    assert!(we < 1e-7, "{we:e}");
}

/// Consistent initialisation on the closure: the crank set to 1.5 rad is kept bit for bit and
/// the coupler and rocker are solved (modulo a turn) (to Freudenstein's θ4, and from the crank rate their
/// rates); a rocker set against the closure is reported with fmi2Warning, never silently
/// replaced.
#[test]
fn initialisation_keeps_the_crank_and_solves_the_loop() {
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<R>()));
    let vr = |n: &str| info.layout.vr_of(n).expect(n);
    let init = |values: &[(&str, f64)]| {
        let mut inst = Instance::<R>::new(info, Logger::silent("four_bar"));
        for (name, v) in values {
            inst.set_real(&[vr(name)], &[*v]).unwrap();
        }
        inst.setup_experiment(Some(1e-8), 0.0, None).unwrap();
        inst.enter_initialization_mode().unwrap();
        let status = inst.exit_initialization_mode().unwrap();
        let names = [
            "crank",
            "coupler",
            "rocker",
            "crank_dot",
            "coupler_dot",
            "rocker_dot",
        ];
        let vrs: Vec<u32> = names.iter().map(|n| vr(n)).collect();
        let mut x = [0.0; 6];
        inst.get_real(&vrs, &mut x).unwrap();
        (status, x)
    };
    // (From the start configuration at 1 rad, Newton reaches 1.5 rad; set 2 rad and it
    // stalls, 3 rad and it lands on the crossed configuration turns away: the dependent
    // joints' first guesses must be near, as the case below sets them.)
    let (status, x) = init(&[("crank", 1.5), ("crank_dot", 3.0)]);
    assert_eq!(status, mbfmu::fmi::Status::Ok);
    let want = state(1.5, 3.0);
    assert_eq!((x[0], x[3]), (1.5, 3.0));
    // Positions as angles (Newton from the start values may land a turn away: the same
    // configuration), velocities as they are.
    let e = (0..6).fold(0.0f64, |s, i| {
        let d = x[i] - want[i];
        s.max(if i < 3 { wrap(d) } else { d }.abs())
    });
    println!("METRIC FourBar initialisation vs closed form: {e:.2e}");
    assert!(e < 1e-13, "{x:?} vs {want:?}");
    // Near the open configuration (the set value is also Newton's first guess).
    // (The coupler set too: from the start value's coupler, Newton would land on the
    // crossed configuration, also a solution.)
    let (status, x) = init(&[
        ("crank", 1.5),
        ("coupler", want[1]),
        ("rocker", want[2] + 0.05),
    ]);
    assert_eq!(status, mbfmu::fmi::Status::Warning);
    assert!(wrap(x[2] - want[2]).abs() < 1e-13, "{x:?}");
}

/// The FMU's linearisation (its `linearization.json`, its page, `mbfmu linearize FourBar`)
/// is taken at the held linkage, a stable equilibrium, not at the running start: in the
/// independent states (crank, crank_dot) A = [[0, 1], [−ω², 0]] with ω² = V''/J of the
/// reduced model's closed forms, and the holding torque is V'.
#[test]
fn the_linearisation_is_at_the_held_stable_equilibrium() {
    use mbfmu::describe::linearize_at;
    use mbfmu::linearize::States;
    let point = <R as System>::linearization_point();
    let lin = linearize_at::<R>(&point, None, &States::Independent).unwrap();
    assert_eq!(lin.state_names, ["crank", "crank_dot"]);
    assert_eq!(lin.point.x[0], CRANK_START);
    assert!(lin.point.x[3..].iter().all(|&v| v == 0.0), "at rest");
    // Central differences of the closed forms, step 1e-4: truncation ~1e-9, rounding
    // ε V / h² ~ 1e-8 of V''.
    let h = 1e-4;
    let (j, v) = inertia_and_potential(CRANK_START);
    let (_, vp) = inertia_and_potential(CRANK_START + h);
    let (_, vm) = inertia_and_potential(CRANK_START - h);
    let (dv, d2v) = ((vp - vm) / (2.0 * h), (vp - 2.0 * v + vm) / (h * h));
    let omega2 = d2v / j;
    println!(
        "METRIC FourBar linearised at θ2 = {CRANK_START}: A21 = {:.10e}, −V''/J = {:.10e}; holding torque {:.10e} vs V' {dv:.10e}; residual {:.1e}",
        lin.a[(1, 0)],
        -omega2,
        lin.point.u[0],
        lin.residual
    );
    assert!(omega2 > 0.0, "a stable equilibrium: V convex");
    assert!(lin.residual < 1e-10, "{}", lin.residual);
    assert!(
        (lin.point.u[0] - dv).abs() < 1e-8 * dv.abs(),
        "{} vs {dv}",
        lin.point.u[0]
    );
    assert!((lin.a[(1, 0)] + omega2).abs() < 1e-6 * omega2);
    assert_eq!(
        (lin.a[(0, 0)], lin.a[(0, 1)], lin.a[(1, 1)]),
        (0.0, 1.0, 0.0)
    );
}
