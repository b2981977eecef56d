//! Projectile and springy pendulum (systems.md sections 3 and 4) against their
//! independent checks: the closed form, invariants, a second derivation, the static
//! equilibrium and its small-oscillation frequencies, and the rigid pendulum the `stiff`
//! scene should have been modelled with.

use mbfmu::integrators::{advance, Memory, Method, Settings, Stats, MAX_STEPS};
use mbfmu::linearize::{linearize, OperatingPoint};
use mbfmu::model::System;
use mbfmu::systems::springy_pendulum::cartesian_rhs;
use mbfmu::systems::{Projectile, SpringyPendulum};

mod support;
use support::Rng;

/// The operating point (states, inputs, parameters) of a scene of `M`.
fn scene<M: System>(name: &str) -> OperatingPoint {
    let scene = M::scenes()
        .into_iter()
        .find(|s| s.name == name)
        .unwrap_or_else(|| panic!("{} has no scene {name}", M::NAME));
    let o: Vec<(String, f64)> = scene
        .start_values
        .iter()
        .map(|(n, v)| (n.to_string(), *v))
        .collect();
    OperatingPoint::from_start_values::<M>(&o).unwrap()
}

/// DOPRI5 at relative tolerance `tol` (absolute `tol`: every state here has nominal 1),
/// landing on every time of `times` in turn; returns the state at each, and the counters.
fn dopri5(
    mut rhs: impl FnMut(f64, &[f64], &mut [f64]),
    x0: &[f64],
    times: &[f64],
    tol: f64,
) -> (Vec<Vec<f64>>, Stats) {
    let settings = Settings {
        method: Method::Dopri5,
        rtol: tol,
        atol: vec![tol; x0.len()],
        step: f64::INFINITY,
        max_steps: MAX_STEPS,
    };
    let mut memory = Memory::default();
    let (mut t, mut x) = (0.0, x0.to_vec());
    let mut out = Vec::new();
    for &t_end in times {
        advance(&mut rhs, &mut t, &mut x, t_end, &settings, &mut memory).unwrap();
        out.push(x.clone());
    }
    (out, memory.stats)
}

/// `0, dt, 2 dt, …, n dt`, each computed as `k·dt` (no accumulated rounding).
fn grid(dt: f64, n: usize) -> Vec<f64> {
    (0..=n).map(|k| k as f64 * dt).collect()
}

fn polar_rhs(op: &OperatingPoint) -> impl FnMut(f64, &[f64], &mut [f64]) + '_ {
    move |t, x, dx| SpringyPendulum::derivatives(t, x, &op.u, &op.p, dx)
}

fn energy(op: &OperatingPoint, x: &[f64]) -> f64 {
    let mut y = [0.0; 3];
    SpringyPendulum::extra_outputs(0.0, x, &op.u, &op.p, &mut y);
    y[2]
}

// ---------------------------------------------------------------------------------------
// Projectile
// ---------------------------------------------------------------------------------------

#[test]
fn projectile_follows_the_closed_form_and_keeps_its_energy() {
    let op = scene::<Projectile>("throw");
    let g = op.p[0];
    let x0 = op.x.clone();
    assert_eq!(x0, [0.0, 0.0, 0.0, 10.0, 0.0, -10.0]);
    let times = grid(0.05, 40); // to the scene's stop time, 2 s
    let (states, stats) = dopri5(
        |t, x, dx| Projectile::derivatives(t, x, &[], &op.p, dx),
        &x0,
        &times[1..],
        1e-10,
    );
    let e = |x: &[f64]| {
        let mut y = [0.0];
        Projectile::extra_outputs(0.0, x, &[], &op.p, &mut y);
        y[0]
    };
    let e0 = e(&x0);
    assert_eq!(e0, 100.0);
    let (mut worst, mut worst_e) = (0.0_f64, 0.0_f64);
    for (&t, x) in times[1..].iter().zip(&states) {
        // Closed form, each component with the scale of its terms (z = ½gt² + vz0 t passes
        // through 0 at t = 2.04 s, so |z| alone would be no scale).
        let exact = [
            x0[0] + x0[3] * t,
            x0[1] + x0[4] * t,
            0.5 * g * t * t + x0[5] * t + x0[2],
            x0[3],
            x0[4],
            x0[5] + g * t,
        ];
        let scale = [
            x0[0].abs() + (x0[3] * t).abs(),
            x0[1].abs() + (x0[4] * t).abs(),
            0.5 * g * t * t + (x0[5] * t).abs() + x0[2].abs(),
            x0[3].abs(),
            x0[4].abs(),
            x0[5].abs() + g * t,
        ];
        for i in 0..6 {
            worst = worst.max((x[i] - exact[i]).abs() / scale[i].max(1.0));
        }
        worst_e = worst_e.max((e(x) - e0).abs() / e0.abs());
    }
    // Measured: worst relative error 4.1e-16, energy drift 4.3e-16 relative, in
    // 42 accepted steps (293 RHS evaluations): DOPRI5 integrates a quadratic exactly.
    eprintln!(
        "projectile: worst relative error {worst:.2e}, energy drift {worst_e:.2e}, {stats:?}"
    );
    assert!(worst < 1e-12, "{worst:e}");
    assert!(worst_e < 1e-12, "{worst_e:e}");
}

// ---------------------------------------------------------------------------------------
// Springy pendulum
// ---------------------------------------------------------------------------------------

/// The polar accelerations (r̈, θ̈) mapped to the Cartesian (ẍ, z̈) of `x = r sin θ`,
/// `z = r cos θ`, and the Cartesian state (x, z, ẋ, ż) of the polar state.
fn polar_to_cartesian(q: &[f64], dq: &[f64]) -> ([f64; 4], [f64; 2]) {
    let (r, th, rd, thd) = (q[0], q[1], q[2], q[3]);
    let (rdd, thdd) = (dq[2], dq[3]);
    let (s, c) = th.sin_cos();
    let state = [r * s, r * c, rd * s + r * thd * c, rd * c - r * thd * s];
    let acc = [
        rdd * s + 2.0 * rd * thd * c + r * thdd * c - r * thd * thd * s,
        rdd * c - 2.0 * rd * thd * s - r * thdd * s - r * thd * thd * c,
    ];
    (state, acc)
}

#[test]
fn polar_and_cartesian_forms_agree_pointwise() {
    let op = scene::<SpringyPendulum>("swing");
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut worst = 0.0_f64;
    for _ in 0..100 {
        let q = [
            rng.uniform(0.3, 2.0),
            rng.uniform(-std::f64::consts::PI, std::f64::consts::PI),
            rng.uniform(-3.0, 3.0),
            rng.uniform(-5.0, 5.0),
        ];
        let u = [rng.uniform(-20.0, 20.0), rng.uniform(-20.0, 20.0)];
        let mut dq = [0.0; 4];
        SpringyPendulum::derivatives(0.0, &q, &u, &op.p, &mut dq);
        let (xc, acc) = polar_to_cartesian(&q, &dq);
        let mut dc = [0.0; 4];
        cartesian_rhs(&xc, &u, &op.p, &mut dc);
        let norm = acc[0].hypot(acc[1]);
        let err = (dc[2] - acc[0]).hypot(dc[3] - acc[1]) / norm;
        worst = worst.max(err);
    }
    // Measured: 1.4e-15 (relative to |a|), worst of the 100 states.
    eprintln!("springy pendulum: polar vs Cartesian RHS, worst relative {worst:.2e}");
    assert!(worst < 1e-12, "{worst:e}");
}

#[test]
fn polar_and_cartesian_forms_give_the_same_trajectory() {
    let op = scene::<SpringyPendulum>("swing");
    let tol = 1e-11;
    let times = grid(0.05, 100); // 5 s
    let (polar, ps) = dopri5(polar_rhs(&op), &op.x, &times[1..], tol);
    let (xc0, _) = polar_to_cartesian(&op.x, &[0.0; 4]);
    let (cart, cs) = dopri5(
        |_, q, dq| cartesian_rhs(q, &op.u, &op.p, dq),
        &xc0,
        &times[1..],
        tol,
    );
    let (mut worst_r, mut worst_th) = (0.0_f64, 0.0_f64);
    for (p, c) in polar.iter().zip(&cart) {
        let r = c[0].hypot(c[1]);
        let th = c[0].atan2(c[1]);
        worst_r = worst_r.max((p[0] - r).abs());
        worst_th = worst_th.max((p[1] - th).abs());
    }
    // Measured: |Δr| ≤ 8.0e-12 m, |Δθ| ≤ 8.8e-12 rad over 5 s (polar 7 925 RHS
    // evaluations, Cartesian 7 943).
    eprintln!(
        "springy pendulum: polar vs Cartesian trajectory, max |Δr| {worst_r:.2e} m, \
         max |Δθ| {worst_th:.2e} rad; polar {ps:?}, Cartesian {cs:?}"
    );
    assert!(
        worst_r < 1e-8 && worst_th < 1e-8,
        "{worst_r:e} {worst_th:e}"
    );
}

#[test]
fn springy_pendulum_keeps_its_energy() {
    let op = scene::<SpringyPendulum>("swing");
    let times = grid(0.05, 200); // 10 s
    let (states, stats) = dopri5(polar_rhs(&op), &op.x, &times[1..], 1e-10);
    let e0 = energy(&op, &op.x);
    let drift = states
        .iter()
        .map(|x| (energy(&op, x) - e0).abs() / e0.abs())
        .fold(0.0, f64::max);
    // Measured: E0 = −8.9725 J, drift 1.8e-10 relative over 10 s (10 197 RHS evaluations).
    eprintln!("springy pendulum: E0 = {e0} J, energy drift {drift:.2e} relative, {stats:?}");
    assert!(drift < 1e-8, "{drift:e}");
}

/// The static equilibrium θ = 0, r = r0 + m g / c.
fn equilibrium() -> OperatingPoint {
    let p: Vec<f64> = SpringyPendulum::parameters()
        .iter()
        .map(|v| v.start)
        .collect();
    let (m, c, r0, g) = (p[0], p[1], p[2], p[3]);
    let o: Vec<(String, f64)> = [
        ("r", r0 + m * g / c),
        ("theta", 0.0),
        ("r_dot", 0.0),
        ("theta_dot", 0.0),
    ]
    .iter()
    .map(|(n, v)| (n.to_string(), *v))
    .collect();
    OperatingPoint::from_start_values::<SpringyPendulum>(&o).unwrap()
}

#[test]
fn static_equilibrium_has_zero_derivative() {
    // With the default parameters r_eq = 1 + 9.81/100 is not a double: the stored r is off
    // by up to ½ ulp(r_eq) = 1.1e-16 m, and the spring turns that into r̈ = −(c/m) δr. So
    // the derivative is zero to (c/m)·ulp(r_eq) = 2.2e-14, not to 1e-15.
    let op = equilibrium();
    let (m, c) = (op.p[0], op.p[1]);
    let r_eq = op.x[0];
    let mut dx = [f64::NAN; 4];
    SpringyPendulum::derivatives(0.0, &op.x, &op.u, &op.p, &mut dx);
    let bound = c / m * r_eq * f64::EPSILON;
    // Measured: dx = [0, 0, −7.1e-15, 0] (4 ulp of g), bound 2.4e-14.
    eprintln!("springy pendulum: derivative at the static equilibrium {dx:?}, bound {bound:.2e}");
    assert!(dx.iter().all(|d| d.abs() <= bound), "{dx:?}");

    // Where the equilibrium is a double, it is exact: c = 16 g gives m g / c = 1/16,
    // r_eq = 1.0625, and c (r − r0) / m = g to the bit.
    let mut op = op;
    op.p[1] = 16.0 * op.p[3];
    op.x[0] = op.p[2] + op.p[0] * op.p[3] / op.p[1];
    assert_eq!(op.x[0], 1.0625);
    SpringyPendulum::derivatives(0.0, &op.x, &op.u, &op.p, &mut dx);
    // Measured: [0, 0, 0, 0].
    assert_eq!(dx, [0.0; 4]);
}

#[test]
fn linearisation_at_equilibrium_has_the_two_small_oscillation_frequencies() {
    let op = equilibrium();
    let (m, c, g) = (op.p[0], op.p[1], op.p[3]);
    let r_eq = op.x[0];
    let l = linearize::<SpringyPendulum>(&op);
    let mut eig: Vec<_> = l.a.complex_eigenvalues().iter().copied().collect();
    eig.sort_by(|a, b| a.im.total_cmp(&b.im));
    let (radial, swing) = ((c / m).sqrt(), (g / r_eq).sqrt());
    let expected = [-radial, -swing, swing, radial];
    let mut worst = 0.0_f64;
    for (e, w) in eig.iter().zip(expected) {
        worst = worst.max(e.re.abs().max((e.im - w).abs()) / w.abs());
    }
    // Measured: eigenvalues ±10.000000000000002 i and ±2.988914954224697 i (real parts
    // ~1e-47), worst relative error 4.5e-16.
    eprintln!("springy pendulum: eigenvalues {eig:?}, worst relative error {worst:.2e}");
    assert!(worst < 1e-12, "{worst:e}: {eig:?}");
}

#[test]
fn stiff_scene_needs_only_the_rigid_pendulum() {
    let op = scene::<SpringyPendulum>("stiff");
    let (m, c, r0, g) = (op.p[0], op.p[1], op.p[2], op.p[3]);
    let len = r0 + m * g / c;
    assert_eq!(op.x, [len, 0.5, 0.0, 0.0]);
    let tol = 1e-8;
    let times = grid(0.01, 200); // 2 s in 0.01 s communication steps (the FMU default)
    let (springy, ss) = dopri5(polar_rhs(&op), &op.x, &times[1..], tol);
    let (rigid, rs) = dopri5(
        |_, q, dq| {
            dq[0] = q[1];
            dq[1] = -(g / len) * q[0].sin();
        },
        &[op.x[1], 0.0],
        &times[1..],
        tol,
    );
    let diff = springy
        .iter()
        .zip(&rigid)
        .map(|(s, r)| (s[1] - r[0]).abs())
        .fold(0.0, f64::max);
    let ratio = ss.rhs_evals as f64 / rs.rhs_evals as f64;
    // Without the communication grid (one call to 2 s), the rigid pendulum's cost is its own.
    // Measured: springy 30 338 RHS evaluations (4 564 steps, 492 rejected), rigid 368
    // (61 steps), ratio 82.4.
    let (_, ss1) = dopri5(polar_rhs(&op), &op.x, &[2.0], tol);
    let (_, rs1) = dopri5(
        |_, q, dq| {
            dq[0] = q[1];
            dq[1] = -(g / len) * q[0].sin();
        },
        &[op.x[1], 0.0],
        &[2.0],
        tol,
    );
    let ratio1 = ss1.rhs_evals as f64 / rs1.rhs_evals as f64;
    eprintln!("stiff scene, one call to 2 s: springy {ss1:?}, rigid {rs1:?}, ratio {ratio1:.1}");
    assert!(ratio1 >= 10.0, "{ratio1}");
    // Measured: springy 32 013 RHS evaluations (4 696 steps, 606 rejected), rigid 1 407
    // (201 steps: one per communication step), ratio 22.8; max |Δθ| 4.2e-6 rad.
    eprintln!(
        "stiff scene: springy {ss:?}, rigid {rs:?}, cost ratio {ratio:.1}, \
         max |Δθ| {diff:.2e} rad"
    );
    assert!(ratio >= 10.0, "{ratio}");
    assert!(diff < 1e-3, "{diff:e}");
}
