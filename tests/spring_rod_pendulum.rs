//! Spring and rod pendulum (systems.md §6): the equations of motion formed by automatic
//! differentiation of the particle Lagrangian against the hand-derived (5.110), (5.111),
//! (5.122), the energy expression and its conservation, and the static equilibrium.

use mbfmu::integrators::{advance, Memory, Method, Settings, MAX_STEPS};
use mbfmu::linearize::OperatingPoint;
use mbfmu::model::lagrangian;
use mbfmu::model::System;
use mbfmu::systems::SpringRodPendulum;

mod support;
use support::Rng;

fn rhs(x: &[f64], p: &[f64]) -> Vec<f64> {
    let mut dx = vec![0.0; x.len()];
    SpringRodPendulum::derivatives(0.0, x, &[], p, &mut dx);
    dx
}

fn energy_output(x: &[f64], p: &[f64]) -> f64 {
    let mut y = vec![0.0; <SpringRodPendulum as System>::outputs().len()];
    SpringRodPendulum::extra_outputs(0.0, x, &[], p, &mut y);
    y[0]
}

/// Random parameters `(m1, m2, c, r10, l2, g)`.
fn random_parameters(rng: &mut Rng) -> [f64; 6] {
    [
        rng.uniform(0.2, 3.0),
        rng.uniform(0.2, 3.0),
        rng.uniform(5.0, 500.0),
        rng.uniform(0.3, 1.5),
        rng.uniform(0.1, 1.0),
        rng.uniform(1.0, 20.0),
    ]
}

/// Random state `(R, θ, φ, Ṙ, θ̇, φ̇)` with R > l2 ≥ r1′, so the spring length
/// r1 ≥ R − r1′ stays away from 0.
fn random_state(rng: &mut Rng, p: &[f64; 6]) -> [f64; 6] {
    let pi = std::f64::consts::PI;
    [
        p[4] + rng.uniform(0.2, 2.5),
        rng.uniform(-pi, pi),
        rng.uniform(-pi, pi),
        rng.uniform(-3.0, 3.0),
        rng.uniform(-3.0, 3.0),
        rng.uniform(-5.0, 5.0),
    ]
}

/// `(M, r1′, r2′, I = m1 r1′² + m2 r2′², r1)` of systems.md §6.
fn geometry(x: &[f64], p: &[f64]) -> (f64, f64, f64, f64, f64) {
    let (m1, m2, l2) = (p[0], p[1], p[4]);
    let m = m1 + m2;
    let (a1, a2) = (m2 * l2 / m, m1 * l2 / m);
    let (r, th, ph) = (x[0], x[1], x[2]);
    let r1 = (a1 * a1 + r * r - 2.0 * a1 * r * (ph - th).cos()).sqrt();
    (m, a1, a2, m1 * a1 * a1 + m2 * a2 * a2, r1)
}

/// R̈, θ̈, φ̈ solved from (5.110), (5.111), (5.122).
fn by_hand(x: &[f64], p: &[f64]) -> [f64; 3] {
    let (c, r10, g) = (p[2], p[3], p[5]);
    let (r, th, ph, rd, thd) = (x[0], x[1], x[2], x[3], x[4]);
    let (m, a1, _, inertia, r1) = geometry(x, p);
    let k = c * (r1 - r10) / r1;
    let (s, co) = ((ph - th).sin(), (ph - th).cos());
    [
        r * thd * thd + g * th.cos() - k * (r - a1 * co) / m,
        (-2.0 * rd * thd - g * th.sin() + k * a1 * s / m) / r,
        -k * r * a1 * s / inertia,
    ]
}

/// systems.md §6: `½M(Ṙ² + R²θ̇²) + ½(m1r1′² + m2r2′²)φ̇² − M g R cos θ + ½c(r1 − r10)²`.
fn energy_by_hand(x: &[f64], p: &[f64]) -> f64 {
    let (c, r10, g) = (p[2], p[3], p[5]);
    let (r, th, rd, thd, phd) = (x[0], x[1], x[3], x[4], x[5]);
    let (m, _, _, inertia, r1) = geometry(x, p);
    0.5 * m * (rd * rd + r * r * thd * thd) + 0.5 * inertia * phd * phd - m * g * r * th.cos()
        + 0.5 * c * (r1 - r10).powi(2)
}

/// Largest |AD − hand| over 100 draws, relative to max(‖hand‖∞, 1).
#[test]
fn ad_equations_equal_the_hand_derived_ones() {
    let mut rng = Rng(0x5EED_0006_2B7E_1516);
    let mut worst: f64 = 0.0;
    for _ in 0..100 {
        let p = random_parameters(&mut rng);
        let x = random_state(&mut rng, &p);
        let dx = rhs(&x, &p);
        assert_eq!(&dx[..3], &x[3..]);
        let hand = by_hand(&x, &p);
        let scale = hand.iter().fold(1.0f64, |s, h| s.max(h.abs()));
        for k in 0..3 {
            worst = worst.max((dx[3 + k] - hand[k]).abs() / scale);
        }
    }
    println!(
        "spring and rod pendulum: max relative difference AD vs (5.110, 5.111, 5.122) {worst:e}"
    );
    assert!(worst < 1e-12, "{worst:e}");
}

/// The mass matrix from the particle velocities is diag(M, M R², m1 r1′² + m2 r2′²).
#[test]
fn mass_matrix_is_diagonal_in_centre_of_mass_coordinates() {
    let mut rng = Rng(77);
    let mut worst: f64 = 0.0;
    for _ in 0..20 {
        let p = random_parameters(&mut rng);
        let x = random_state(&mut rng, &p);
        let mm = lagrangian::mass_matrix::<SpringRodPendulum, f64>(0.0, &x[..3], &x[3..], &p);
        let (m, _, _, inertia, _) = geometry(&x, &p);
        let expected = [
            [m, 0.0, 0.0],
            [0.0, m * x[0] * x[0], 0.0],
            [0.0, 0.0, inertia],
        ];
        let scale = m * x[0] * x[0];
        for i in 0..3 {
            for j in 0..3 {
                worst = worst.max((mm[i][j] - expected[i][j]).abs() / scale);
            }
        }
    }
    println!("mass matrix: max relative difference {worst:e}");
    assert!(worst < 1e-14, "{worst:e}");
}

#[test]
fn energy_output_equals_the_expression_of_systems_md() {
    let mut rng = Rng(4242);
    let mut worst: f64 = 0.0;
    for _ in 0..100 {
        let p = random_parameters(&mut rng);
        let x = random_state(&mut rng, &p);
        let (e, hand) = (energy_output(&x, &p), energy_by_hand(&x, &p));
        worst = worst.max((e - hand).abs() / hand.abs().max(1.0));
    }
    println!("energy output vs systems.md: max relative difference {worst:e}");
    assert!(worst < 1e-13, "{worst:e}");
}

/// The start values of a scene: (x, p).
fn scene(name: &str) -> (Vec<f64>, Vec<f64>) {
    let s = <SpringRodPendulum as System>::scenes()
        .into_iter()
        .find(|s| s.name == name)
        .unwrap();
    let o: Vec<(String, f64)> = s
        .start_values
        .iter()
        .map(|(n, v)| (n.to_string(), *v))
        .collect();
    let op = OperatingPoint::from_start_values::<SpringRodPendulum>(&o).unwrap();
    assert!(op.u.is_empty());
    (op.x, op.p)
}

#[test]
fn energy_is_conserved_in_both_scenes() {
    for name in ["swing", "wobble"] {
        let (mut x, p) = scene(name);
        let e0 = energy_output(&x, &p);
        let settings = Settings {
            method: Method::Dopri5,
            rtol: 1e-10,
            atol: vec![1e-10; 6],
            step: f64::INFINITY,
            max_steps: MAX_STEPS,
        };
        let mut f = |_t: f64, x: &[f64], dx: &mut [f64]| {
            SpringRodPendulum::derivatives(0.0, x, &[], &p, dx)
        };
        let (mut t, mut memory, mut drift): (f64, Memory, f64) = (0.0, Memory::default(), 0.0);
        for k in 1..=1000 {
            advance(
                &mut f,
                &mut t,
                &mut x,
                k as f64 * 0.01,
                &settings,
                &mut memory,
            )
            .unwrap();
            let e = energy_output(&x, &p);
            drift = drift.max((e - e0).abs() / e0.abs());
        }
        println!("{name}, 10 s: E0 = {e0} J, max relative drift {drift:e}");
        assert!(drift < 1e-8, "{name}: {drift:e}");
    }
}

#[test]
fn static_equilibrium_has_zero_derivative() {
    let mut rng = Rng(99);
    let mut draws: Vec<[f64; 6]> = vec![[1.0, 1.0, 100.0, 1.0, 0.5, 9.81]];
    draws.extend((0..20).map(|_| random_parameters(&mut rng)));
    let mut worst: f64 = 0.0;
    for p in draws {
        let (m1, m2, c, r10, l2, g) = (p[0], p[1], p[2], p[3], p[4], p[5]);
        let m = m1 + m2;
        // Spring stretched by M g / c below O, A a further r1′ below m1.
        let r = r10 + m * g / c + m2 * l2 / m;
        let dx = rhs(&[r, 0.0, 0.0, 0.0, 0.0, 0.0], &p);
        worst = dx.iter().fold(worst, |w, d| w.max(d.abs() / g));
    }
    println!("static equilibrium: max |ẋ| / g {worst:e}");
    assert!(worst < 1e-13, "{worst:e}");
    // The default start R is that equilibrium.
    let starts: Vec<f64> = <SpringRodPendulum as System>::states()
        .iter()
        .map(|v| v.start)
        .collect();
    assert!((starts[0] - (1.0 + 2.0 * 9.81 / 100.0 + 0.25)).abs() < 1e-15);
}

#[test]
fn declarations() {
    let names = |v: Vec<mbfmu::model::Var>| -> Vec<String> {
        v.into_iter().map(|v| v.name.into_owned()).collect()
    };
    assert_eq!(
        names(<SpringRodPendulum as System>::states()),
        ["R", "theta", "phi", "R_dot", "theta_dot", "phi_dot"]
    );
    assert_eq!(
        names(<SpringRodPendulum as System>::parameters()),
        ["m1", "m2", "c", "r10", "l2", "g"]
    );
    assert_eq!(names(<SpringRodPendulum as System>::outputs()), ["E"]);
    assert_eq!(<SpringRodPendulum as System>::NAME, "SpringRodPendulum");
}
