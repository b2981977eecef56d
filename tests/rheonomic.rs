//! Rheonomic systems (issue 14, systems.md §13): time in the constraints and the energies.
//! The bead on a turning hoop and the pulled pendulum against equations derived by hand
//! here (not in the models), their invariants and power balances, the bead's equilibria
//! and linearisation, consistent initialisation at t0 ≠ 0, and a Lagrangian with t in T
//! and in a velocity constraint's b(t).

use mbfmu::integrators::{advance, Memory, Method, Settings, MAX_STEPS};
use mbfmu::linearize::States;
use mbfmu::model::lagrangian::{self, Lagrangian};
use mbfmu::model::symbolic::equations;
use mbfmu::model::{consistent, Scalar, Scene, System, Var};
use mbfmu::systems::{PulledPendulum, RotatingHoopBead};

mod support;
use support::Rng;

fn start<M: System>(vars: Vec<Var>) -> Vec<f64> {
    let _ = M::NAME;
    vars.iter().map(|v| v.start).collect()
}

fn outputs<M: System>(t: f64, x: &[f64], p: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; M::outputs().len()];
    M::extra_outputs(t, x, &[], p, &mut y);
    y
}

/// Integrates `M` with DOPRI5 at rtol 1e-12 from `(t0, x)` to `t_end` in communication
/// steps of 0.01 s, projecting after each at the state's time as the FMU does, with one
/// more state: ∫ `power(t, x, y)` dt. Calls `each(t, x, work)` after every step.
fn run<M: System>(
    p: &[f64],
    x: &mut [f64],
    (t0, t_end): (f64, f64),
    power: impl Fn(f64, &[f64], &[f64]) -> f64,
    mut each: impl FnMut(f64, &[f64], f64),
) {
    let n = x.len();
    let mut xa = x.to_vec();
    xa.push(0.0);
    let settings = Settings {
        method: Method::Dopri5,
        rtol: 1e-12,
        atol: vec![1e-14; n + 1],
        step: f64::INFINITY,
        max_steps: MAX_STEPS,
    };
    let mut memory = Memory::default();
    let mut rhs = |t: f64, x: &[f64], dx: &mut [f64]| {
        M::derivatives(t, &x[..n], &[], p, &mut dx[..n]);
        dx[n] = power(t, &x[..n], &outputs::<M>(t, &x[..n], p));
    };
    let h = 0.01;
    let steps = ((t_end - t0) / h).round() as usize;
    let mut t = t0;
    for i in 1..=steps {
        advance(
            &mut rhs,
            &mut t,
            &mut xa,
            t0 + i as f64 * h,
            &settings,
            &mut memory,
        )
        .unwrap();
        M::project(t, p, &mut xa[..n]);
        each(t, &xa[..n], xa[n]);
    }
    x.copy_from_slice(&xa[..n]);
}

/// The bead's state on its constraints at t: φ = Ω t, φ̇ = Ω.
fn bead_state(t: f64, theta: f64, theta_dot: f64, p: &[f64]) -> [f64; 4] {
    [theta, p[2] * t, theta_dot, p[2]]
}

#[test]
fn bead_matches_the_hand_derived_equation_and_torque() {
    // R θ̈ = (R Ω² cos θ − g) sin θ; torque = 2 m R² Ω sin θ cos θ θ̇;
    // h = ½ m R² θ̇² − ½ m R² Ω² sin²θ − m g R cos θ; at random states, times, parameters.
    let mut rng = Rng(0x6ead_0014);
    let (mut worst_acc, mut worst_torque, mut worst_h) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..200 {
        let p = [
            rng.uniform(0.01, 2.0),
            rng.uniform(0.1, 2.0),
            rng.uniform(-10.0, 10.0),
            rng.uniform(0.0, 20.0),
        ];
        let (m, r, w, g) = (p[0], p[1], p[2], p[3]);
        let t = rng.uniform(-5.0, 5.0);
        let (th, thd) = (rng.uniform(-3.0, 3.0), rng.uniform(-10.0, 10.0));
        let x = bead_state(t, th, thd, &p);
        let mut dx = [0.0; 4];
        RotatingHoopBead::derivatives(t, &x, &[], &p, &mut dx);
        let expected = (r * w * w * th.cos() - g) * th.sin() / r;
        let scale = (w * w + g / r + thd * thd).max(1.0);
        worst_acc = worst_acc.max((dx[2] - expected).abs() / scale);
        assert!(dx[3].abs() < 1e-12 * scale, "φ̈ = {}", dx[3]);
        let y = outputs::<RotatingHoopBead>(t, &x, &p);
        let torque = 2.0 * m * r * r * w * th.sin() * th.cos() * thd;
        let h = 0.5 * m * r * r * thd * thd
            - 0.5 * m * r * r * w * w * th.sin().powi(2)
            - m * g * r * th.cos();
        let e = 0.5 * m * r * r * (thd * thd + w * w * th.sin().powi(2)) - m * g * r * th.cos();
        let es = m * r * r * scale;
        worst_torque = worst_torque.max((y[2] - torque).abs() / es);
        worst_h = worst_h.max((y[1] - h).abs() / es);
        assert!((y[0] - e).abs() < 1e-13 * es, "E {} vs {e}", y[0]);
    }
    println!(
        "METRIC rotating hoop bead vs hand-derived: theta_ddot {worst_acc:.1e}, torque {worst_torque:.1e}, h {worst_h:.1e} (relative)"
    );
    assert!(worst_acc < 1e-13 && worst_torque < 1e-13 && worst_h < 1e-13);
}

#[test]
fn pulled_pendulum_matches_the_hand_derived_equation_and_tension() {
    // l θ̈ + 2 l̇ θ̇ + g sin θ = 0; tension = m (g cos θ + l θ̇²);
    // E = ½ m (l̇² + l² θ̇²) − m g l cos θ.
    let mut rng = Rng(0x9011_0014);
    let (mut worst_acc, mut worst_tension) = (0.0f64, 0.0f64);
    for _ in 0..200 {
        let p = [
            rng.uniform(0.1, 5.0),
            rng.uniform(0.5, 3.0),
            rng.uniform(-0.1, 0.1),
            rng.uniform(0.0, 20.0),
        ];
        let (m, g) = (p[0], p[3]);
        let t = rng.uniform(-4.0, 4.0);
        let (l, ld) = (p[1] + p[2] * t, p[2]);
        let (th, thd) = (rng.uniform(-3.0, 3.0), rng.uniform(-5.0, 5.0));
        let x = [th, l, thd, ld];
        let mut dx = [0.0; 4];
        PulledPendulum::derivatives(t, &x, &[], &p, &mut dx);
        let expected = -(2.0 * ld * thd + g * th.sin()) / l;
        let scale = (g / l + thd * thd).max(1.0);
        worst_acc = worst_acc.max((dx[2] - expected).abs() / scale);
        assert!(dx[3].abs() < 1e-12 * scale, "r̈ = {}", dx[3]);
        let y = outputs::<PulledPendulum>(t, &x, &p);
        let tension = m * (g * th.cos() + l * thd * thd);
        worst_tension = worst_tension.max((y[2] - tension).abs() / (m * scale * l.max(1.0)));
        let e = 0.5 * m * (ld * ld + l * l * thd * thd) - m * g * l * th.cos();
        assert!((y[0] - l).abs() < 1e-15 && (y[1] - e).abs() < 1e-12 * m * scale * l);
    }
    println!(
        "METRIC pulled pendulum vs hand-derived: theta_ddot {worst_acc:.1e}, tension {worst_tension:.1e} (relative)"
    );
    assert!(worst_acc < 1e-13 && worst_tension < 1e-13);
}

#[test]
fn bead_keeps_its_jacobi_integral_while_the_drive_does_work() {
    for (scene, omega) in [("slow", 3.0), ("fast", 6.0)] {
        let mut p = start::<RotatingHoopBead>(<RotatingHoopBead as System>::parameters());
        p[2] = omega;
        let mut x = bead_state(0.0, 0.5, 0.0, &p).to_vec();
        let y0 = outputs::<RotatingHoopBead>(0.0, &x, &p);
        let (mut h_drift, mut e_range, mut balance) = (0.0f64, 0.0f64, 0.0f64);
        let mut phi_err = 0.0f64;
        run::<RotatingHoopBead>(
            &p,
            &mut x,
            (0.0, 20.0),
            |_, _, y| y[2] * omega,
            |t, x, work| {
                let y = outputs::<RotatingHoopBead>(t, x, &p);
                h_drift = h_drift.max(((y[1] - y0[1]) / y0[1]).abs());
                e_range = e_range.max((y[0] - y0[0]).abs());
                balance = balance.max((y[0] - y0[0] - work).abs());
                phi_err = phi_err
                    .max((x[1] - omega * t).abs())
                    .max((x[3] - omega).abs());
            },
        );
        println!(
            "METRIC rotating hoop bead {scene} over 20 s: h drift {h_drift:.1e} (relative), E varies by {e_range:.3e} J, |ΔE − ∫torque·Ω dt| {balance:.1e} J, |φ − Ω t| {phi_err:.1e}"
        );
        assert!(h_drift < 1e-9, "{scene}: h drifts {h_drift:e}");
        assert!(e_range > 1e-2, "{scene}: E should change, by {e_range:e}");
        assert!(
            balance < 1e-9 * e_range.max(1.0),
            "{scene}: power balance {balance:e}"
        );
        assert!(phi_err < 1e-12, "{scene}: φ off Ω t by {phi_err:e}");
    }
}

#[test]
fn pulled_pendulum_balances_the_work_of_the_pull_and_follows_the_reduced_equation() {
    let p = start::<PulledPendulum>(<PulledPendulum as System>::parameters());
    let (l0, rate, g) = (p[1], p[2], p[3]);
    let mut x = vec![0.3, l0, 0.0, rate];
    let e0 = outputs::<PulledPendulum>(0.0, &x, &p)[1];
    let (mut balance, mut e_range) = (0.0f64, 0.0f64);
    run::<PulledPendulum>(
        &p,
        &mut x,
        (0.0, 10.0),
        |_, _, y| -y[2] * rate,
        |t, x, work| {
            let e = outputs::<PulledPendulum>(t, x, &p)[1];
            balance = balance.max((e - e0 - work).abs());
            e_range = e_range.max((e - e0).abs());
        },
    );
    // The hand-derived equation in θ alone, integrated the same way.
    let mut z = vec![0.3, 0.0];
    let settings = Settings {
        method: Method::Dopri5,
        rtol: 1e-12,
        atol: vec![1e-14; 2],
        step: f64::INFINITY,
        max_steps: MAX_STEPS,
    };
    let mut rhs = |t: f64, z: &[f64], dz: &mut [f64]| {
        let l = l0 + rate * t;
        dz[0] = z[1];
        dz[1] = -(2.0 * rate * z[1] + g * z[0].sin()) / l;
    };
    let mut t = 0.0;
    advance(
        &mut rhs,
        &mut t,
        &mut z,
        10.0,
        &settings,
        &mut Memory::default(),
    )
    .unwrap();
    let theta_err = (x[0] - z[0]).abs().max((x[2] - z[1]).abs());
    println!(
        "METRIC pulled pendulum over 10 s: |ΔE + ∫tension·l̇ dt| {balance:.1e} J (E varies by {e_range:.3e} J), theta vs the reduced equation {theta_err:.1e}"
    );
    assert!(e_range > 1e-2);
    assert!(balance < 1e-9, "power balance {balance:e}");
    assert!(theta_err < 1e-9, "θ differs by {theta_err:e}");
    assert!((x[1] - (l0 + rate * 10.0)).abs() < 1e-12);
}

fn linearize_bead(at: &[(&str, f64)]) -> (Vec<String>, Vec<f64>, f64, [f64; 4]) {
    let overrides: Vec<(String, f64)> = at.iter().map(|(n, v)| (n.to_string(), *v)).collect();
    let lin =
        mbfmu::describe::linearize_at::<RotatingHoopBead>(&overrides, None, &States::Independent)
            .unwrap();
    let a = [lin.a[(0, 0)], lin.a[(0, 1)], lin.a[(1, 0)], lin.a[(1, 1)]];
    (lin.state_names.clone(), lin.point.x.clone(), lin.point.t, a)
}

/// The eigenvalues of a 2 × 2 matrix `[a b; c d]` as (re, im) of the one with im ≥ 0,
/// or the two real ones.
fn eigenvalues(a: [f64; 4]) -> (f64, f64) {
    let (tr, det) = (a[0] + a[3], a[0] * a[3] - a[1] * a[2]);
    let disc = tr * tr / 4.0 - det;
    if disc >= 0.0 {
        (tr / 2.0 + disc.sqrt(), tr / 2.0 - disc.sqrt())
    } else {
        (tr / 2.0, (-disc).sqrt())
    }
}

#[test]
fn bead_equilibria_and_their_linearisation() {
    let (r, g) = (0.5, 9.81);
    // Below the critical rate the bottom is a centre: ±i√(g/R − Ω²).
    let (names, x, t, a) = linearize_bead(&[
        ("Omega", 3.0),
        ("theta", 0.0),
        ("theta_dot", 0.0),
        ("time", 0.7),
    ]);
    assert_eq!(names, ["theta", "theta_dot"]);
    assert_eq!(t, 0.7);
    assert!((x[1] - 3.0 * 0.7).abs() < 1e-14, "φ at t = 0.7: {}", x[1]);
    let (re, im) = eigenvalues(a);
    let slow = (g / r - 9.0f64).sqrt();
    // Above it, a saddle: ±√(Ω² − g/R).
    let (_, _, _, a) = linearize_bead(&[("Omega", 6.0), ("theta", 0.0), ("theta_dot", 0.0)]);
    let (up, down) = eigenvalues(a);
    let fast = (36.0 - g / r).sqrt();
    // About θ* = arccos(g/(R Ω²)): a centre at √(Ω² − g²/(R² Ω²)).
    let theta_star = (g / (r * 36.0f64)).acos();
    let (_, _, _, a) = linearize_bead(&[("theta", theta_star), ("theta_dot", 0.0)]);
    let (re_star, im_star) = eigenvalues(a);
    let star = (36.0 - g * g / (r * r * 36.0f64)).sqrt();
    println!(
        "METRIC rotating hoop bead eigenvalues: bottom Ω=3 ±{im:.15}i (closed form {slow:.15}), bottom Ω=6 ±{up:.15} (closed form {fast:.15}), θ*={theta_star:.6} ±{im_star:.15}i (closed form {star:.15})"
    );
    assert!(re.abs() < 1e-14 && (im - slow).abs() < 1e-13);
    assert!((up - fast).abs() < 1e-13 && (down + fast).abs() < 1e-13);
    assert!(re_star.abs() < 1e-13 && (im_star - star).abs() < 1e-13);

    // Started at rest at θ* it stays there.
    let p = [0.1, r, 6.0, g];
    let mut x = bead_state(0.0, theta_star, 0.0, &p).to_vec();
    let mut worst = 0.0f64;
    run::<RotatingHoopBead>(
        &p,
        &mut x,
        (0.0, 20.0),
        |_, _, _| 0.0,
        |_, x, _| {
            worst = worst.max((x[0] - theta_star).abs());
        },
    );
    println!("METRIC rotating hoop bead at rest at θ*: |θ − θ*| ≤ {worst:.1e} over 20 s");
    assert!(worst < 1e-10, "left θ* by {worst:e}");
}

#[test]
fn consistent_initialisation_holds_at_the_start_time() {
    let p = start::<RotatingHoopBead>(<RotatingHoopBead as System>::parameters());
    let t0 = 2.5;
    let mut x = vec![0.4, 0.0, 1.0, 0.0];
    consistent::solve::<RotatingHoopBead>(t0, &p, &mut x).unwrap();
    assert_eq!((x[0], x[2]), (0.4, 1.0));
    assert!(
        (x[1] - p[2] * t0).abs() < 1e-13 && (x[3] - p[2]).abs() < 1e-13,
        "{x:?}"
    );
    let p = start::<PulledPendulum>(<PulledPendulum as System>::parameters());
    let mut x = vec![0.2, 7.0, 0.0, 3.0];
    consistent::solve::<PulledPendulum>(t0, &p, &mut x).unwrap();
    assert!((x[1] - (p[1] + p[2] * t0)).abs() < 1e-13 && (x[3] - p[2]).abs() < 1e-13);
}

#[test]
fn rattle_refuses_rheonomic_systems() {
    let p = start::<RotatingHoopBead>(<RotatingHoopBead as System>::parameters());
    assert!(<RotatingHoopBead as System>::mechanics(&[], &p).is_none());
    let p = start::<PulledPendulum>(<PulledPendulum as System>::parameters());
    assert!(<PulledPendulum as System>::mechanics(&[], &p).is_none());
}

/// The generated equations (t traced as a leaf) against automatic differentiation at
/// random states and times: derivatives and outputs (the tension: the multiplier).
/// (RotatingHoopBead has none: its M is singular at θ = 0, see its module notes.)
fn generated_matches_ad<L: Lagrangian>(state: impl Fn(&mut Rng, f64, &[f64]) -> Vec<f64>) -> f64 {
    let mut rng = Rng(0x9e4e_0014);
    let p = start::<L>(<L as System>::parameters());
    let n = <L as System>::states().len();
    let ny = <L as System>::outputs().len();
    let mut worst = 0.0f64;
    for _ in 0..200 {
        let t = rng.uniform(-5.0, 15.0);
        let x = state(&mut rng, t, &p);
        let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
        <L as System>::derivatives(t, &x, &[], &p, &mut a);
        <lagrangian::AutoDiff<L> as System>::derivatives(t, &x, &[], &p, &mut b);
        let (mut ya, mut yb) = (vec![0.0; ny], vec![0.0; ny]);
        <L as System>::extra_outputs(t, &x, &[], &p, &mut ya);
        <lagrangian::AutoDiff<L> as System>::extra_outputs(t, &x, &[], &p, &mut yb);
        for (u, v) in a.iter().zip(&b).chain(ya.iter().zip(&yb)) {
            worst = worst.max((u - v).abs() / v.abs().max(1.0));
        }
    }
    worst
}

#[test]
fn generated_equations_match_automatic_differentiation() {
    let pulled = generated_matches_ad::<PulledPendulum>(|rng, t, p| {
        vec![
            rng.uniform(-3.0, 3.0),
            p[1] + p[2] * t,
            rng.uniform(-5.0, 5.0),
            p[2],
        ]
    });
    // t in T and in b(t): the graph (the tracer's equations) at time t against AD.
    let eq = equations::<MovingFrame>().unwrap();
    let p = [2.0, 3.0, 0.4, 1.7];
    let mut rng = Rng(0x7ace_0014);
    let mut frame = 0.0f64;
    for _ in 0..100 {
        let t = rng.uniform(-5.0, 5.0);
        let q = [rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)];
        let qd = [rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0)];
        let (_, rhs, _, gamma) = eq.eval_at(t, &q, &qd, &[], &p);
        let rhs_ad = lagrangian::generalized_rhs::<MovingFrame, f64>(t, &q, &qd, &[], &p);
        // γ of ẏ − sin t = 0 is ḃ = −cos t.
        frame = frame.max((gamma[0] + t.cos()).abs());
        for (u, v) in rhs.iter().zip(&rhs_ad) {
            frame = frame.max((u - v).abs());
        }
    }
    let source = mbfmu::model::symbolic::emit::emit(&eq, "MovingFrameEom", "", "crate").source;
    println!(
        "METRIC generated vs AD: PulledPendulum {pulled:.1e}; MovingFrame graph (t a leaf) {frame:.1e}"
    );
    assert!(pulled < 1e-14 && frame < 1e-14);
    assert!(source.contains("let t = [S::from(t)];"), "{source}");
}

/// A mass on a spring whose anchor moves as a sin ωt, in the coordinate q measured from
/// the anchor, so that t is in T: `T = ½ m (q̇ + a ω cos ωt)²`, `V = ½ k q²`; hand-derived
/// `q̈ = −(k/m) q + a ω² sin ωt`. And a second, free coordinate y with the velocity
/// constraint `ẏ − sin t = 0` (A q̇ + b with b(t)): ÿ = cos t, multiplier −m cos t.
struct MovingFrame;

impl Lagrangian for MovingFrame {
    const NAME: &'static str = "MovingFrame";
    const DESCRIPTION: &'static str = "test";
    const EQUATIONS: &'static [&'static str] = &[];
    const VELOCITY_CONSTRAINTS: usize = 1;
    const RHEONOMIC: bool = true;
    fn parameters() -> Vec<Var> {
        ["m", "k", "a", "w"]
            .iter()
            .zip([2.0, 3.0, 0.4, 1.7])
            .map(|(n, v)| Var::new(n, None, v, "test"))
            .collect()
    }
    fn inputs() -> Vec<Var> {
        Vec::new()
    }
    fn coordinates() -> Vec<Var> {
        vec![
            Var::new("q", None, 0.0, "test"),
            Var::new("y", None, 0.0, "test"),
        ]
    }
    fn velocities() -> Vec<Var> {
        vec![
            Var::new("q_dot", None, 0.0, "test"),
            Var::new("y_dot", None, 0.0, "test").dependent(),
        ]
    }
    fn outputs() -> Vec<Var> {
        Vec::new()
    }
    fn kinetic<S: Scalar>(t: S, _q: &[S], qd: &[S], p: &[S]) -> S {
        let v = qd[0] + p[2] * p[3] * (p[3] * t).cos();
        p[0] * (v * v + qd[1] * qd[1]) * 0.5
    }
    fn potential<S: Scalar>(_t: S, q: &[S], p: &[S]) -> S {
        p[1] * q[0] * q[0] * 0.5
    }
    fn velocity_constraints<S: Scalar>(t: S, _q: &[S], qd: &[S], _p: &[S], out: &mut [S]) {
        out[0] = qd[1] - t.sin();
    }
    fn extra_outputs<S: Scalar>(_: f64, _: &[S], _: &[S], _: &[S], _: &[S], _: &mut [S]) {}
    fn scenes() -> Vec<Scene> {
        Vec::new()
    }
}

#[test]
fn time_in_the_kinetic_energy_and_in_a_velocity_constraint() {
    let p = [2.0, 3.0, 0.4, 1.7];
    let mut rng = Rng(0x7e57_0014);
    let mut worst = 0.0f64;
    for _ in 0..100 {
        let t = rng.uniform(-5.0, 5.0);
        let (q, qd) = (
            [rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0)],
            rng.uniform(-2.0, 2.0),
        );
        let x = [q[0], q[1], qd, t.sin()];
        let (qdd, lambda) = lagrangian::accelerations_and_multipliers::<MovingFrame, f64>(
            t,
            &x[..2],
            &x[2..],
            &[],
            &p,
        );
        let expected = -p[1] / p[0] * q[0] + p[2] * p[3] * p[3] * (p[3] * t).sin();
        worst = worst
            .max((qdd[0] - expected).abs())
            .max((qdd[1] - t.cos()).abs())
            .max((lambda[0] + p[0] * t.cos()).abs());
        let mut r = [0.0];
        assert!(<MovingFrame as System>::state_constraints(
            t, &x, &p, &mut r
        ));
        assert!(r[0].abs() < 1e-15);
    }
    println!("METRIC moving frame (t in T and in b(t)) vs hand-derived: {worst:.1e}");
    assert!(worst < 1e-13);
    // The projection at time t puts ẏ on sin t.
    let mut x = [0.1, 0.2, 0.3, 5.0];
    <MovingFrame as System>::project(1.1, &p, &mut x);
    assert!((x[3] - 1.1f64.sin()).abs() < 1e-14 && x[2] == 0.3, "{x:?}");
}
