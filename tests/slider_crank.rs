//! Slider-crank (systems.md §11, notes Figure 6.1): the reduced model (q = θ) against the
//! surplus model (q = (θ, β, x), two constraints, multipliers), the joint forces against
//! statics, and the constraint drift of the index-1 formulation with and without
//! projection.

use mbfmu::integrators::{advance, Memory, Method, Settings, MAX_STEPS};
use mbfmu::model::lagrangian;
use mbfmu::model::System;
use mbfmu::systems::slider_crank::{closure_rates, static_torque};
use mbfmu::systems::{SliderCrank, SliderCrankSurplus};

mod support;
use support::{surplus_state, Rng};

/// Random parameters `(m1, l1, m2, l2, m3, g)` with l2 ≥ 1.5 l1 (β stays below 42°).
fn random_parameters(rng: &mut Rng) -> [f64; 6] {
    let l1 = rng.uniform(0.05, 0.5);
    [
        rng.uniform(0.2, 5.0),
        l1,
        rng.uniform(0.2, 5.0),
        l1 * rng.uniform(1.5, 5.0),
        rng.uniform(0.1, 3.0),
        rng.uniform(0.0, 20.0),
    ]
}

fn outputs<M: System>(x: &[f64], u: &[f64], p: &[f64]) -> Vec<f64> {
    let mut y = vec![0.0; M::outputs().len()];
    M::extra_outputs(0.0, x, u, p, &mut y);
    y
}

#[test]
fn reduced_and_surplus_derivations_agree_at_random_states() {
    // Two derivations of the same mechanism: θ̈ from the reduced Lagrangian (closure
    // substituted, one coordinate) and from the λ-method on (θ, β, x). β̈ and ẍ of the
    // surplus model must equal the second derivatives of the closure along the motion.
    let mut rng = Rng(0x5eed_c4a7);
    let mut worst = 0.0f64;
    for _ in 0..200 {
        let p = random_parameters(&mut rng);
        let theta = rng.uniform(-std::f64::consts::PI, std::f64::consts::PI);
        let omega = rng.uniform(-20.0, 20.0);
        let u = [rng.uniform(-5.0, 5.0), rng.uniform(-50.0, 50.0)];
        let mut dr = [0.0; 2];
        SliderCrank::derivatives(0.0, &[theta, omega], &u, &p, &mut dr);
        let xs = surplus_state(theta, omega, &p);
        let mut ds = [0.0; 6];
        SliderCrankSurplus::derivatives(0.0, &xs, &u, &p, &mut ds);
        let scale = dr[1].abs().max(omega * omega).max(1.0);
        worst = worst.max((ds[3] - dr[1]).abs() / scale);
        // β̈, ẍ: the closure differentiated twice, by finite differences of its rates
        // along the reduced motion (θ(t+δ) = θ + θ̇ δ + ½ θ̈ δ², θ̇(t+δ) = θ̇ + θ̈ δ).
        let d = 1e-5;
        let rates = |s: f64| {
            let th = theta + omega * s + 0.5 * dr[1] * s * s;
            closure_rates(th, omega + dr[1] * s, &p)
        };
        let (up, down) = (rates(d), rates(-d));
        let (bdd, xdd) = ((up.0 - down.0) / (2.0 * d), (up.1 - down.1) / (2.0 * d));
        let tol = 1e-6 * scale;
        assert!((ds[4] - bdd).abs() < tol, "β̈ {} vs {bdd}", ds[4]);
        assert!(
            (ds[5] - xdd).abs() < tol * p[1] * 10.0,
            "ẍ {} vs {xdd}",
            ds[5]
        );
    }
    println!("METRIC slider-crank reduced vs surplus theta_ddot: worst {worst:.2e} (relative)");
    assert!(worst < 1e-12, "θ̈ differs by {worst:e}");
}

#[test]
fn joint_forces_match_statics() {
    // No gravity, at rest, the piston force F held by the crank torque of virtual work:
    // nothing moves, and the rod is a two-force member, so the force on it at the wrist
    // pin lies along it: P = F (along x) and N = −F tan β (along y).
    let mut rng = Rng(42);
    let mut worst = 0.0f64;
    for _ in 0..100 {
        let mut p = random_parameters(&mut rng);
        p[5] = 0.0;
        let theta = rng.uniform(-3.0, 3.0);
        let force = rng.uniform(-100.0, 100.0);
        let u = [static_torque(theta, force, &p), force];
        let mut dr = [0.0; 2];
        SliderCrank::derivatives(0.0, &[theta, 0.0], &u, &p, &mut dr);
        let xs = surplus_state(theta, 0.0, &p);
        let mut ds = [0.0; 6];
        SliderCrankSurplus::derivatives(0.0, &xs, &u, &p, &mut ds);
        let y = outputs::<SliderCrankSurplus>(&xs, &u, &p);
        let (n, pf) = (y[0], y[1]);
        let beta = xs[1];
        let f = force.abs().max(1.0);
        worst = worst
            .max((pf - force).abs() / f)
            .max((n + force * beta.tan()).abs() / f);
        assert!(dr[1].abs() < 1e-10 * f, "reduced θ̈ = {}", dr[1]);
        assert!(ds[3..].iter().all(|a| a.abs() < 1e-10 * f / p[1]), "{ds:?}");
    }
    println!("METRIC slider-crank static joint forces vs statics: worst {worst:.2e} (relative)");
    assert!(worst < 1e-12);
}

/// Integrates the surplus model over `t_end` with DOPRI5 at `tol` in communication steps
/// of 0.01 s, projecting after each (or not); returns the residual |Φ| at times 1, 2, 4, …
fn drift(tol: f64, project: bool, t_end: f64) -> Vec<(f64, f64)> {
    let p: Vec<f64> = <SliderCrankSurplus as System>::parameters()
        .iter()
        .map(|v| v.start)
        .collect();
    let mut x = surplus_state(0.0, 10.0, &p).to_vec();
    let nominal: Vec<f64> = <SliderCrankSurplus as System>::states()
        .iter()
        .map(|v| v.nominal.unwrap_or(1.0))
        .collect();
    let settings = Settings {
        method: Method::Dopri5,
        rtol: tol,
        atol: nominal.iter().map(|n| tol * n).collect(),
        step: f64::INFINITY,
        max_steps: MAX_STEPS,
    };
    let mut memory = Memory::default();
    let mut rhs = |t: f64, x: &[f64], dx: &mut [f64]| {
        SliderCrankSurplus::derivatives(t, x, &[0.0, 0.0], &p, dx)
    };
    let (mut t, h) = (0.0, 0.01);
    let mut out = Vec::new();
    let mut next_report = 1.0;
    let steps = (t_end / h).round() as usize;
    for i in 1..=steps {
        advance(
            &mut rhs,
            &mut t,
            &mut x,
            i as f64 * h,
            &settings,
            &mut memory,
        )
        .unwrap();
        if project {
            SliderCrankSurplus::project(t, &p, &mut x);
        }
        if t >= next_report - 1e-9 {
            let phi = lagrangian::constraint_values::<SliderCrankSurplus, f64>(0.0, &x[..3], &p);
            out.push((t, phi.iter().map(|v| v * v).sum::<f64>().sqrt()));
            next_report *= 2.0;
        }
    }
    out
}

#[test]
fn index_one_constraints_drift_like_t_squared_and_projection_stops_it() {
    // The λ-method enforces only Φ̈ = 0: errors in Φ and Φ̇ are not corrected, so the
    // velocity residual grows like t and the position residual like t² (Hairer, Wanner,
    // ODE II, VII.2). Measured slope of log|Φ| against log t over 8 … 256 s.
    let free = drift(1e-8, false, 256.0);
    for (t, r) in &free {
        println!("METRIC slider-crank index-1 drift, no projection: t = {t:5} s |Φ| = {r:.3e} m");
    }
    let pick = |t: f64| free.iter().find(|(tt, _)| (tt - t).abs() < 1e-6).unwrap().1;
    let slope = (pick(256.0) / pick(8.0)).ln() / (256.0f64 / 8.0).ln();
    println!("METRIC slider-crank index-1 drift exponent: {slope:.2}");
    assert!((1.6..2.4).contains(&slope), "drift exponent {slope}");
    let projected = drift(1e-8, true, 256.0);
    let worst = projected.iter().fold(0.0f64, |w, (_, r)| w.max(*r));
    println!("METRIC slider-crank with projection: worst |Φ| = {worst:.2e} m");
    assert!(worst < 1e-15, "projected residual {worst:e}");
    assert!(pick(256.0) > 1e6 * worst.max(1e-17));
}
