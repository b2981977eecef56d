//! Lagrangian systems: the equations of motion formed by automatic differentiation
//! against the hand-derived ones of systems.md, rod forces, energy, linearisation and
//! the large-amplitude period.

use mbfmu::integrators::{advance, Memory, Method, Settings, MAX_STEPS};
use mbfmu::linearize::{linearize, OperatingPoint};
use mbfmu::model::lagrangian::{self, Lagrangian};
use mbfmu::model::System;
use mbfmu::systems::{CompoundPendulum, DoublePendulum};
use nalgebra::DMatrix;

mod support;
use support::Rng;

fn rhs<M: System>(x: &[f64], u: &[f64], p: &[f64]) -> Vec<f64> {
    let mut dx = vec![0.0; x.len()];
    M::derivatives(0.0, x, u, p, &mut dx);
    dx
}

fn outputs<M: System>(x: &[f64], u: &[f64], p: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; M::outputs().len()];
    M::extra_outputs(0.0, x, u, p, &mut y);
    y
}

fn starts(vars: Vec<mbfmu::model::Var>) -> Vec<f64> {
    vars.iter().map(|v| v.start).collect()
}

/// θ̈1, φ̈ of systems.md §5 (with the torques on the right: τ1 − τ2, τ2), by Cramer's rule.
fn double_pendulum_by_hand(x: &[f64], u: &[f64], p: &[f64]) -> [f64; 2] {
    let (th, ph, thd, phd) = (x[0], x[1], x[2], x[3]);
    let (m1, m2, r1, l2, g) = (p[0], p[1], p[2], p[3], p[4]);
    let (s, c) = ((ph - th).sin(), (ph - th).cos());
    let a = [
        [(m1 + m2) * r1 * r1, m2 * r1 * l2 * c],
        [m2 * r1 * l2 * c, m2 * l2 * l2],
    ];
    let b = [
        u[0] - u[1] + m2 * r1 * l2 * phd * phd * s - (m1 + m2) * g * r1 * th.sin(),
        u[1] - m2 * r1 * l2 * thd * thd * s - m2 * g * l2 * ph.sin(),
    ];
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    [
        (b[0] * a[1][1] - a[0][1] * b[1]) / det,
        (a[0][0] * b[1] - b[0] * a[1][0]) / det,
    ]
}

/// Largest |AD − hand| over the 100 draws, relative to max(‖hand‖∞, 1).
#[test]
fn ad_equations_equal_the_hand_derived_ones() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let pi = std::f64::consts::PI;
    let mut worst: f64 = 0.0;
    for _ in 0..100 {
        let p = [
            rng.uniform(0.5, 2.0),
            rng.uniform(0.2, 2.0),
            rng.uniform(0.1, 1.0),
            rng.uniform(1.0, 20.0),
        ];
        let x = [rng.uniform(-pi, pi), rng.uniform(-5.0, 5.0)];
        let u = [rng.uniform(-3.0, 3.0)];
        let dx = rhs::<CompoundPendulum>(&x, &u, &p);
        let (m, l, io, g) = (p[0], p[1], p[2], p[3]);
        let hand = (u[0] - m * g * l * x[0].sin()) / io;
        assert_eq!(dx[0], x[1]);
        worst = worst.max((dx[1] - hand).abs() / hand.abs().max(1.0));
    }
    println!("compound pendulum: max relative difference {worst:e}");
    assert!(worst < 1e-12, "{worst:e}");

    let mut worst: f64 = 0.0;
    for _ in 0..100 {
        let p = [
            rng.uniform(0.5, 2.0),
            rng.uniform(0.5, 2.0),
            rng.uniform(0.5, 2.0),
            rng.uniform(0.5, 2.0),
            rng.uniform(1.0, 20.0),
        ];
        let x = [
            rng.uniform(-pi, pi),
            rng.uniform(-pi, pi),
            rng.uniform(-5.0, 5.0),
            rng.uniform(-5.0, 5.0),
        ];
        let u = [rng.uniform(-3.0, 3.0), rng.uniform(-3.0, 3.0)];
        let dx = rhs::<DoublePendulum>(&x, &u, &p);
        let hand = double_pendulum_by_hand(&x, &u, &p);
        assert_eq!(&dx[..2], &x[2..]);
        let scale = hand[0].abs().max(hand[1].abs()).max(1.0);
        for k in 0..2 {
            worst = worst.max((dx[2 + k] - hand[k]).abs() / scale);
        }
    }
    println!("double pendulum: max relative difference {worst:e}");
    assert!(worst < 1e-12, "{worst:e}");
}

#[test]
fn mass_matrix_and_energy_helpers() {
    let (q, qd) = ([0.3, -1.1], [0.7, 2.0]);
    let p = [1.5, 0.5, 1.2, 0.8, 9.81];
    let m = lagrangian::mass_matrix::<DoublePendulum, f64>(0.0, &q, &qd, &p);
    let c = (q[1] - q[0]).cos();
    let expected = [
        [(p[0] + p[1]) * p[2] * p[2], p[1] * p[2] * p[3] * c],
        [p[1] * p[2] * p[3] * c, p[1] * p[3] * p[3]],
    ];
    for i in 0..2 {
        for j in 0..2 {
            assert!((m[i][j] - expected[i][j]).abs() < 1e-14, "{m:?}");
        }
    }
    // E = ½ qdᵀ M qd + V.
    let t: f64 = (0..2)
        .flat_map(|i| (0..2).map(move |j| (i, j)))
        .map(|(i, j)| 0.5 * qd[i] * expected[i][j] * qd[j])
        .sum();
    let v = -p[4] * ((p[0] + p[1]) * p[2] * q[0].cos() + p[1] * p[3] * q[1].cos());
    let e = lagrangian::energy::<DoublePendulum, f64>(0.0, &q, &qd, &p);
    assert!((e - (t + v)).abs() < 1e-13, "{e} {}", t + v);
}

#[test]
fn rod_tensions_hanging_at_rest() {
    let (m1, m2, g) = (1.3, 0.7, 9.81);
    let p = [m1, m2, 1.1, 0.6, g];
    let y = outputs::<DoublePendulum>(&[0.0; 4], &[0.0; 2], &p);
    assert!((y[1] - m2 * g).abs() < 1e-14, "F2 = {}", y[1]);
    assert!((y[0] - (m1 + m2) * g).abs() < 1e-14, "F1 = {}", y[0]);
}

/// Newton on each particle, independently of the outputs' formula: the accelerations by
/// central differences of the particle positions along a trajectory, then the rod
/// forces F1, F2 and the shear forces (perpendicular to the rods) solved from
/// `m2 a2 = −F2 e2 + S2 n2 + m2 g ẑ` and `m1 a1 = −F1 e1 + S1 n1 + F2 e2 − S2 n2 + m1 g ẑ`.
/// The moment balance of each massless rod fixes the shear: `S2 = τ2 / l2`,
/// `S1 = (τ1 − τ2) / r1`, which also checks the generalised forces Q = (τ1 − τ2, τ2).
#[test]
fn rod_tensions_satisfy_newton_on_each_particle() {
    let p = [1.3, 0.7, 1.1, 0.6, 9.81];
    let mut rng = Rng(12345);
    let mut worst: f64 = 0.0;
    for _ in 0..20 {
        let x0 = [
            rng.uniform(-3.0, 3.0),
            rng.uniform(-3.0, 3.0),
            rng.uniform(-3.0, 3.0),
            rng.uniform(-3.0, 3.0),
        ];
        let u = [rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0)];
        // States at t = −h, 0, h by integrating tightly both ways from x0.
        let h = 1e-3;
        let at = |dt: f64| -> Vec<f64> {
            let mut x = x0.to_vec();
            if dt > 0.0 {
                integrate::<DoublePendulum>(&mut x, &u, &p, dt, 1e-13);
            } else if dt < 0.0 {
                // Time reversal (q̈ is even in q̇, the torques are held): negate the
                // velocities, go forward, negate back.
                x[2] = -x[2];
                x[3] = -x[3];
                integrate::<DoublePendulum>(&mut x, &u, &p, -dt, 1e-13);
                x[2] = -x[2];
                x[3] = -x[3];
            }
            x
        };
        let pos = |x: &[f64]| -> [f64; 4] {
            let (x1, z1) = (p[2] * x[0].sin(), p[2] * x[0].cos());
            [x1, z1, x1 + p[3] * x[1].sin(), z1 + p[3] * x[1].cos()]
        };
        // Second central differences at h and 2h, Richardson-extrapolated (error O(h⁴)).
        let r0 = pos(&at(0.0));
        let second = |h: f64| -> Vec<f64> {
            let (rm, rp) = (pos(&at(-h)), pos(&at(h)));
            (0..4)
                .map(|k| (rp[k] - 2.0 * r0[k] + rm[k]) / (h * h))
                .collect()
        };
        let (a_h, a_2h) = (second(h), second(2.0 * h));
        let acc: Vec<f64> = (0..4).map(|k| a_h[k] + (a_h[k] - a_2h[k]) / 3.0).collect();
        let (e1, n1) = ([x0[0].sin(), x0[0].cos()], [x0[0].cos(), -x0[0].sin()]);
        let (e2, n2) = ([x0[1].sin(), x0[1].cos()], [x0[1].cos(), -x0[1].sin()]);
        // Force the rods exert on m2 and on m1: m a − m g ẑ.
        let f_on_2 = [p[1] * acc[2], p[1] * (acc[3] - p[4])];
        let f_on_1 = [p[0] * acc[0], p[0] * (acc[1] - p[4])];
        let f2 = -(f_on_2[0] * e2[0] + f_on_2[1] * e2[1]);
        let s2 = f_on_2[0] * n2[0] + f_on_2[1] * n2[1];
        // Rod 1's force on m1 = f_on_1 minus rod 2's force on m1 (= −f_on_2).
        let rod1 = [f_on_1[0] + f_on_2[0], f_on_1[1] + f_on_2[1]];
        let f1 = -(rod1[0] * e1[0] + rod1[1] * e1[1]);
        let s1 = rod1[0] * n1[0] + rod1[1] * n1[1];
        let y = outputs::<DoublePendulum>(&x0, &u, &p);
        let scale = y[0].abs().max(y[1].abs()).max(1.0);
        worst = worst
            .max((y[0] - f1).abs() / scale)
            .max((y[1] - f2).abs() / scale)
            .max((s1 - (u[0] - u[1]) / p[2]).abs() / scale)
            .max((s2 - u[1] / p[3]).abs() / scale);
    }
    // Extrapolated differences with h = 1e-3: truncation ~ h⁴ a⁽⁶⁾/90, integration
    // error and rounding ~ 1e-13/h².
    println!("rod forces against Newton by finite differences: max relative {worst:e}");
    assert!(worst < 1e-8, "{worst:e}");
}

/// Integrates `x` over `duration` with DOPRI5 at tolerance `tol` (rtol = atol), inputs held.
fn integrate<M: System>(x: &mut [f64], u: &[f64], p: &[f64], duration: f64, tol: f64) {
    let settings = Settings {
        method: Method::Dopri5,
        rtol: tol,
        atol: vec![tol; x.len()],
        step: f64::INFINITY,
        max_steps: MAX_STEPS,
    };
    let mut rhs = |_t: f64, x: &[f64], dx: &mut [f64]| M::derivatives(0.0, x, u, p, dx);
    let mut t = 0.0;
    advance(
        &mut rhs,
        &mut t,
        x,
        duration,
        &settings,
        &mut Memory::default(),
    )
    .unwrap();
}

/// The start values of a scene: (x, u, p).
fn scene<M: System>(name: &str) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let s = M::scenes().into_iter().find(|s| s.name == name).unwrap();
    let o: Vec<(String, f64)> = s
        .start_values
        .iter()
        .map(|(n, v)| (n.to_string(), *v))
        .collect();
    let op = OperatingPoint::from_start_values::<M>(&o).unwrap();
    (op.x, op.u, op.p)
}

#[test]
fn energy_is_conserved_in_the_chaotic_scene() {
    let (mut x, u, p) = scene::<DoublePendulum>("chaotic");
    assert_eq!(x, [2.0, 2.0, 0.0, 0.0]);
    let e0 = outputs::<DoublePendulum>(&x, &u, &p)[2];
    let settings = Settings {
        method: Method::Dopri5,
        rtol: 1e-10,
        atol: vec![1e-10; 4],
        step: f64::INFINITY,
        max_steps: MAX_STEPS,
    };
    let mut rhs = |_t: f64, x: &[f64], dx: &mut [f64]| {
        <DoublePendulum as System>::derivatives(0.0, x, &u, &p, dx)
    };
    let (mut t, mut memory, mut drift): (f64, Memory, f64) = (0.0, Memory::default(), 0.0);
    for k in 1..=1000 {
        advance(
            &mut rhs,
            &mut t,
            &mut x,
            k as f64 * 0.01,
            &settings,
            &mut memory,
        )
        .unwrap();
        let e = outputs::<DoublePendulum>(&x, &u, &p)[2];
        drift = drift.max((e - e0).abs() / e0.abs());
    }
    println!("chaotic double pendulum, 10 s: E0 = {e0}, max relative drift {drift:e}");
    assert!(drift < 1e-7, "{drift:e}");
}

/// Eigenvalues of A, sorted by (imaginary, real) part.
fn eigenvalues(a: &DMatrix<f64>) -> Vec<nalgebra::Complex<f64>> {
    let mut ev: Vec<_> = a.complex_eigenvalues().iter().copied().collect();
    ev.sort_by(|a, b| a.im.total_cmp(&b.im).then(a.re.total_cmp(&b.re)));
    ev
}

fn at<M: System>(overrides: &[(&str, f64)]) -> OperatingPoint {
    let o: Vec<(String, f64)> = overrides.iter().map(|(n, v)| (n.to_string(), *v)).collect();
    OperatingPoint::from_start_values::<M>(&o).unwrap()
}

#[test]
fn linearisation_gives_the_small_oscillation_frequencies() {
    let (m, l, io, g): (f64, f64, f64, f64) = (2.0, 0.3, 0.25, 9.81);
    let w = (m * g * l / io).sqrt();
    let params = [("m", m), ("l", l), ("I_O", io), ("g", g)];
    let mut worst: f64 = 0.0;

    let mut down = params.to_vec();
    down.extend([("theta", 0.0), ("theta_dot", 0.0)]);
    let lin = linearize::<CompoundPendulum>(&at::<CompoundPendulum>(&down));
    assert!(lin.residual == 0.0);
    let ev = eigenvalues(&lin.a);
    for (e, im) in ev.iter().zip([-w, w]) {
        worst = worst.max(e.re.abs() / w).max((e.im - im).abs() / w);
    }

    let mut up = params.to_vec();
    up.extend([("theta", std::f64::consts::PI), ("theta_dot", 0.0)]);
    let lin = linearize::<CompoundPendulum>(&at::<CompoundPendulum>(&up));
    let mut ev = eigenvalues(&lin.a);
    ev.sort_by(|a, b| a.re.total_cmp(&b.re));
    for (e, re) in ev.iter().zip([-w, w]) {
        worst = worst.max(e.im.abs() / w).max((e.re - re).abs() / w);
    }
    println!("compound pendulum eigenvalues: max relative error {worst:e}");
    assert!(worst < 1e-12, "{worst:e}");

    // Double pendulum, m1 = m2, r1 = l2 = l: ω² = (2 ∓ √2) g / l.
    let (l, g): (f64, f64) = (0.7, 9.81);
    let lin = linearize::<DoublePendulum>(&at::<DoublePendulum>(&[
        ("m1", 1.5),
        ("m2", 1.5),
        ("r1", l),
        ("l2", l),
        ("g", g),
        ("theta1", 0.0),
        ("phi", 0.0),
    ]));
    assert!(lin.residual == 0.0);
    let ev = eigenvalues(&lin.a);
    let (w1, w2) = (
        ((2.0 - 2f64.sqrt()) * g / l).sqrt(),
        ((2.0 + 2f64.sqrt()) * g / l).sqrt(),
    );
    let mut worst: f64 = 0.0;
    for (e, im) in ev.iter().zip([-w2, -w1, w1, w2]) {
        worst = worst
            .max(e.re.abs() / im.abs())
            .max((e.im - im).abs() / im.abs());
    }
    println!("double pendulum eigenvalues: max relative error {worst:e}");
    assert!(worst < 1e-12, "{worst:e}");
}

/// K(k) = π / (2 AGM(1, √(1 − k²))).
fn elliptic_k(k: f64) -> f64 {
    let (mut a, mut b) = (1.0f64, (1.0 - k * k).sqrt());
    while (a - b).abs() > 1e-16 * a {
        (a, b) = (0.5 * (a + b), (a * b).sqrt());
    }
    std::f64::consts::PI / (a + b)
}

#[test]
fn large_amplitude_period_equals_the_elliptic_integral() {
    let (mut x, u, p) = scene::<CompoundPendulum>("large");
    assert_eq!(x, [3.0, 0.0]);
    let theta0 = x[0];
    let (m, l, io, g) = (p[0], p[1], p[2], p[3]);
    let exact = 4.0 * (io / (m * g * l)).sqrt() * elliptic_k((theta0 / 2.0).sin());
    let settings = Settings {
        method: Method::Dopri5,
        rtol: 1e-12,
        atol: vec![1e-12; 2],
        step: f64::INFINITY,
        max_steps: MAX_STEPS,
    };
    let f = |x: &[f64]| rhs::<CompoundPendulum>(x, &u, &p);
    let mut rhs_fn = |_t: f64, x: &[f64], dx: &mut [f64]| {
        <CompoundPendulum as System>::derivatives(0.0, x, &u, &p, dx)
    };
    // Communication points every h; a zero of θ̇ between two of them is located on the
    // cubic Hermite interpolant of θ̇ (values θ̇, slopes θ̈ = f at both ends), by bisection.
    let h = 1e-3;
    let (mut t, mut memory) = (0.0, Memory::default());
    let mut crossings = Vec::new();
    let mut k = 0;
    while crossings.len() < 2 {
        let (t0, x0) = (t, x.clone());
        k += 1;
        advance(
            &mut rhs_fn,
            &mut t,
            &mut x,
            k as f64 * h,
            &settings,
            &mut memory,
        )
        .unwrap();
        let (v0, v1) = (x0[1], x[1]);
        if k > 1 && v0 * v1 <= 0.0 && v0 != v1 {
            let (s0, s1) = (f(&x0)[1], f(&x)[1]);
            let dt = t - t0;
            let hermite = |s: f64| {
                let (h00, h10) = (
                    2.0 * s.powi(3) - 3.0 * s * s + 1.0,
                    s.powi(3) - 2.0 * s * s + s,
                );
                let (h01, h11) = (-2.0 * s.powi(3) + 3.0 * s * s, s.powi(3) - s * s);
                h00 * v0 + h10 * dt * s0 + h01 * v1 + h11 * dt * s1
            };
            let (mut lo, mut hi) = (0.0, 1.0);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if (hermite(mid) > 0.0) == (v0 > 0.0) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            crossings.push(t0 + 0.5 * (lo + hi) * dt);
        }
    }
    let period = crossings[1];
    let err = (period - exact).abs() / exact;
    let err_half = (2.0 * crossings[0] - exact).abs() / exact;
    println!(
        "θ0 = 3: period {period} s, exact {exact} s, relative error {err:e} (from the half period: {err_half:e})"
    );
    assert!(err < 1e-8 && err_half < 1e-8, "{err:e} {err_half:e}");
}

#[test]
fn lagrangian_and_system_declarations_agree() {
    assert_eq!(
        <DoublePendulum as System>::NAME,
        <DoublePendulum as Lagrangian>::NAME
    );
    let states: Vec<String> = <DoublePendulum as System>::states()
        .into_iter()
        .map(|v| v.name.into_owned())
        .collect();
    assert_eq!(states, ["theta1", "phi", "theta1_dot", "phi_dot"]);
    assert_eq!(starts(<CompoundPendulum as System>::states()), [0.1, 0.0]);
    assert!(<CompoundPendulum as System>::second_order());
}
