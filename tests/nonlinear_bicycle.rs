//! The nonlinear Whipple bicycle against the benchmark's linearisation and other
//! independent references.

use mbfmu::linearize::{self, OperatingPoint};
use mbfmu::model::System;
use mbfmu::systems::{NonlinearBicycle, WhippleBicycle};
use nalgebra::DMatrix;

fn at_speed(v: f64) -> OperatingPoint {
    let set = vec![
        ("roll".to_string(), 0.0),
        ("rear_wheel_dot".to_string(), -v / 0.3),
    ];
    OperatingPoint::consistent::<NonlinearBicycle>(&set)
        .unwrap()
        .0
}

fn whipple_parameters() -> Vec<f64> {
    WhippleBicycle::parameters()
        .iter()
        .map(|v| v.start)
        .collect()
}

fn minimal(v: f64) -> linearize::Linearization {
    let lin = linearize::linearize::<NonlinearBicycle>(&at_speed(v));
    let keep: Vec<String> = ["roll", "steer", "roll_dot", "steer_dot"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    linearize::reduced::<NonlinearBicycle>(&lin, Some(&keep)).unwrap()
}

#[test]
fn minimal_state_matrices_equal_the_benchmark() {
    for v in [0.0, 1.0, 3.0, 4.3, 5.0, 6.0, 8.0, 10.0] {
        let lin = minimal(v);
        let (a, b) = WhippleBicycle::state_matrix(&whipple_parameters(), v);
        let a = DMatrix::from_iterator(4, 4, a.iter().copied());
        let b = DMatrix::from_iterator(4, 2, b.iter().copied());
        let da = (&lin.a - &a).amax();
        let db = (&lin.b - &b).amax();
        println!("v = {v}: |ΔA| = {da:e}, |ΔB| = {db:e}");
        assert!(
            da < 1e-10 * a.amax() && db < 1e-10 * b.amax(),
            "{}\n{}",
            lin.a,
            a
        );
    }
}

/// Peterson's steady turn of the benchmark bicycle (D. L. Peterson, "Precise steady turning
/// conditions", UC Davis Sports Biomechanics Lab, 2011; from his own nonlinear equations,
/// program whipplesteady_review.cpp of OBD): lean 5°, steer δ, steer torque T_δ, front wheel
/// rate θ̇F (v = −rF θ̇F), pitch printed as θ_B + λ.
const PETERSON_TURN: [f64; 5] = [
    0.08726646259971647,  // lean
    0.3139899180509261,   // pitch + λ
    0.0249931148885184,   // steer
    0.002386180613544564, // steer torque
    -17.27895470227879,   // front wheel rate
];

#[test]
fn a_published_steady_turn_is_steady() {
    let [lean, pitch_plus_lambda, steer, torque, front_rate] = PETERSON_TURN;
    let point = |rear_rate: f64| {
        let set: Vec<(String, f64)> = [
            ("roll", lean),
            ("steer", steer),
            ("roll_dot", 0.0),
            ("steer_dot", 0.0),
            ("rear_wheel_dot", rear_rate),
            ("T_delta", torque),
        ]
        .iter()
        .map(|(n, v)| (n.to_string(), *v))
        .collect();
        OperatingPoint::consistent::<NonlinearBicycle>(&set)
            .unwrap()
            .0
    };
    // front_wheel_dot is linear in rear_wheel_dot at a fixed configuration.
    let unit = point(-1.0);
    let rear_rate = -front_rate / unit.x[8 + 7];
    let op = point(rear_rate);
    // The holonomic constraint: Peterson's pitch, printed to 16 digits.
    let pitch = op.x[4];
    let published = pitch_plus_lambda - std::f64::consts::PI / 10.0;
    assert!(
        (pitch - published).abs() < 1e-15,
        "pitch {pitch:e} vs {published:e}"
    );
    // Steady: no roll or steer acceleration under the published torque (scale: g/h ~ 10 rad/s²).
    let mut dx = vec![0.0; 16];
    NonlinearBicycle::derivatives(0.0, &op.x, &op.u, &op.p, &mut dx);
    for (what, a) in [
        ("roll", dx[8 + 3]),
        ("steer", dx[8 + 5]),
        ("rear wheel", dx[8 + 6]),
    ] {
        assert!(
            a.abs() < 1e-12,
            "{what} acceleration {a:e} in a steady turn"
        );
    }
}

/// Kane's equations (d'Alembert's principle on the partial velocities of the independent
/// speeds; Newton–Euler for each body with the workless constraint forces eliminated):
/// a second derivation of the accelerations, from the bodies' poses alone, at a general
/// state far from upright with every rate nonzero.
#[test]
fn accelerations_satisfy_kanes_equations_at_a_general_state() {
    use mbfmu::model::kinematics::{apply, cross, dot, mul, transpose, Mat3, Vec3};
    use num_dual::{Dual64, HyperDual64};
    let set: Vec<(String, f64)> = [
        ("roll", 0.6),
        ("steer", -0.9),
        ("yaw", 0.4),
        ("roll_dot", 0.7),
        ("steer_dot", -1.3),
        ("rear_wheel_dot", -12.0),
        ("T_phi", 1.5),
        ("T_delta", -0.8),
    ]
    .iter()
    .map(|(n, v)| (n.to_string(), *v))
    .collect();
    let op = OperatingPoint::consistent::<NonlinearBicycle>(&set)
        .unwrap()
        .0;
    let (q, qd) = op.x.split_at(8);
    let p = &op.p;
    let mut dx = vec![0.0; 16];
    NonlinearBicycle::derivatives(0.0, &op.x, &op.u, p, &mut dx);
    let qdd = &dx[8..];
    println!("q = {q:?}\nqd = {qd:?}\nqdd = {qdd:?}");

    // Partial velocities: q̇ = B u for the independent speeds u = (roll, steer, rear wheel
    // rates); B's columns span the null space of the constraint rows (from the state
    // constraints' Jacobian with respect to q̇).
    let independent = [3, 5, 6];
    let dependent = [0, 1, 2, 4, 7];
    let rows = |v: &[f64]| -> Vec<f64> {
        // The velocity residuals (G q̇, A q̇) at velocities v: linear in v.
        let mut x = op.x.clone();
        x[8..].copy_from_slice(v);
        let mut r = vec![0.0; 6];
        NonlinearBicycle::state_constraints(0.0, &x, p, &mut r);
        r[1..].to_vec()
    };
    let column = |j: usize| {
        let mut e = vec![0.0; 8];
        e[j] = 1.0;
        rows(&e)
    };
    let cd = DMatrix::from_fn(5, 5, |i, k| column(dependent[k])[i]);
    let basis: Vec<Vec<f64>> = independent
        .iter()
        .map(|&r| {
            let rhs = nalgebra::DVector::from_vec(column(r).iter().map(|v| -v).collect());
            let dep = cd.clone().lu().solve(&rhs).unwrap();
            let mut b = vec![0.0; 8];
            b[r] = 1.0;
            for (k, &d) in dependent.iter().enumerate() {
                b[d] = dep[k];
            }
            b
        })
        .collect();
    // The state's velocities are a combination of the basis: a check of the basis itself.
    for (j, v) in qd.iter().enumerate() {
        let combined: f64 = (0..3).map(|r| basis[r][j] * qd[independent[r]]).sum();
        assert!(
            (combined - v).abs() < 1e-12 * (1.0 + v.abs()),
            "basis, coordinate {j}"
        );
    }

    // Accelerations of every body along the motion: q + (ε1 + ε2) q̇ + ε1ε2 q̈.
    let moving: Vec<HyperDual64> = (0..8)
        .map(|j| HyperDual64::new(q[j], qd[j], qd[j], qdd[j]))
        .collect();
    let ph: Vec<HyperDual64> = p.iter().map(|&v| HyperDual64::from(v)).collect();
    let (poses, _) = NonlinearBicycle::poses(&moving, &ph);
    let inertias = NonlinearBicycle::inertias(p);
    let vee = |w: &Mat3<f64>| [w[2][1], w[0][2], w[1][0]];
    let part = |m: &Mat3<HyperDual64>, f: fn(&HyperDual64) -> f64| m.map(|r| r.map(|x| f(&x)));
    let g = p[3];
    let mut kane = [0.0; 3];
    for (r, b) in basis.iter().enumerate() {
        let along: Vec<Dual64> = (0..8).map(|j| Dual64::new(q[j], b[j])).collect();
        let pd: Vec<Dual64> = p.iter().map(|&v| Dual64::from(v)).collect();
        let (partial, _) = NonlinearBicycle::poses(&along, &pd);
        // Generalised active forces: gravity and the two torques.
        let mut f = op.u[0] * b[3] + op.u[1] * b[5];
        for ((pose, inertia), part_pose) in poses.iter().zip(&inertias).zip(&partial) {
            let a: Vec3<f64> = pose.com.map(|c| c.eps1eps2);
            let rot = part(&pose.rot, |x| x.re);
            let rdot = part(&pose.rot, |x| x.eps1);
            let rddot = part(&pose.rot, |x| x.eps1eps2);
            let omega = vee(&mul(&rdot, &transpose(&rot)));
            let rdot2 = part(&pose.rot, |x| x.eps2);
            let d_omega = mul(&rddot, &transpose(&rot));
            let coriolis = mul(&rdot, &transpose(&rdot2));
            let alpha: Vec3<f64> = std::array::from_fn(|k| {
                let s = [[2, 1], [0, 2], [1, 0]][k];
                d_omega[s[0]][s[1]] + coriolis[s[0]][s[1]]
            });
            let world = mul(&mul(&rot, &inertia.tensor), &transpose(&rot));
            let dv: Vec3<f64> = part_pose.com.map(|c| c.eps);
            let prot = part_pose.rot.map(|row| row.map(|x| x.re));
            let pdot = part_pose.rot.map(|row| row.map(|x| x.eps));
            let dw = vee(&mul(&pdot, &transpose(&prot)));
            let inertial = dot(dv, a.map(|v| v * inertia.mass))
                + dot(
                    dw,
                    add3(apply(&world, alpha), cross(omega, apply(&world, omega))),
                );
            f += inertia.mass * g * dv[2] - inertial;
        }
        kane[r] = f;
    }
    println!("Kane residuals {kane:?}");
    for (r, k) in kane.iter().enumerate() {
        assert!(
            k.abs() < 1e-10,
            "Kane's equation for speed {r}: residual {k:e}"
        );
    }
}

fn add3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// Bisection for the speed in `[lo, hi]` where `f` changes sign, to the resolution of v.
fn crossing(mut lo: f64, mut hi: f64, f: impl Fn(f64) -> f64) -> f64 {
    let below = f(lo) < 0.0;
    assert_ne!(below, f(hi) < 0.0, "no sign change in [{lo}, {hi}]");
    while hi - lo > 4.0 * f64::EPSILON * hi {
        let mid = 0.5 * (lo + hi);
        if (f(mid) < 0.0) == below {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The largest real part of the oscillatory (weave) and of the real (capsize) eigenvalues.
fn weave_and_capsize(a: &DMatrix<f64>) -> (f64, f64) {
    let eig = a.complex_eigenvalues();
    let max_re = |oscillating: bool| {
        eig.iter()
            .filter(|z| (z.im.abs() > 1e-8) == oscillating)
            .map(|z| z.re)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    (max_re(true), max_re(false))
}

#[test]
fn weave_and_capsize_speeds_equal_the_benchmarks() {
    let p = whipple_parameters();
    let linear = |v: f64| {
        let (a, _) = WhippleBicycle::state_matrix(&p, v);
        weave_and_capsize(&DMatrix::from_iterator(4, 4, a.iter().copied()))
    };
    let nonlinear = |v: f64| weave_and_capsize(&minimal(v).a);
    let weave = [
        crossing(4.0, 5.0, |v| linear(v).0),
        crossing(4.0, 5.0, |v| nonlinear(v).0),
    ];
    let capsize = [
        crossing(5.5, 6.5, |v| linear(v).1),
        crossing(5.5, 6.5, |v| nonlinear(v).1),
    ];
    println!("weave {weave:?}, capsize {capsize:?}");
    // The paper's Table 2 (as tests/whipple_bicycle.rs), then the two derivations.
    assert!((weave[0] - 4.29238253634111).abs() < 1e-10);
    assert!((capsize[0] - 6.02426201538837).abs() < 1e-10);
    assert!((weave[0] - weave[1]).abs() < 1e-10, "{weave:?}");
    assert!((capsize[0] - capsize[1]).abs() < 1e-10, "{capsize:?}");
}
