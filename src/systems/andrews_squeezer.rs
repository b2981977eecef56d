//! Andrews' squeezing mechanism ([`AndrewsSqueezer`]), the seven-body multibody benchmark
//! of Hairer and Wanner (*Solving Ordinary Differential Equations II*, VII.7; the IVP test
//! set's `andrews` problem), declared as bodies, joints, three loop closures and a spring.
//!
//! Planar (joints about z), no gravity, the test set's parameters and coordinates
//! `beta Theta gamma Phi delta Omega epsilon`, read as bodies:
//!
//! - K1 turns about O = (0, 0) by β (centre of mass at ra on its x axis, inertia i1),
//!   driven by the constant torque mom = 0.033 N·m (the start value of `tau_beta`);
//! - K2 is hinged to K1 at rr on K1's x axis, relative angle Θ (centre of mass at −da on
//!   its x axis); its end P is at −d on that axis;
//! - K3 turns about B = (xb, yb) by γ; P is held on its point ss (sin γ, −cos γ) from B
//!   (closure `P3`); the spring (c0, l0) joins its point D = B + sd (cos γ, sin γ) +
//!   sc (sin γ, −cos γ) to C = (xc, yc) on the frame;
//! - K5 turns about A = (xa, ya) by δ; K4 is hinged to K5 at zt on K5's x axis, relative
//!   angle Φ; P is held on K4's point at e along its (sin, −cos) direction (closure `P4`,
//!   centre of mass at e − ea along it);
//! - K7 turns about A by ε; K6 is hinged to K7 at u along (sin ε, −cos ε), relative angle
//!   Ω; P is held on K6's point zf along its x axis (closure `P6`, centre of mass at
//!   zf − fa along it).
//!
//! Six closure residuals (three points, x and y), one degree of freedom: β is independent,
//! the six others dependent. The closures are written P(K2) − P(K·), the test set's
//! g₁…g₆, so the multipliers are its λ₁…λ₆ (`force_P3_x` … `force_P6_y`). The test set
//! gives only the distances of the centres of mass of K3, K5 and K7 from their pivots
//! (√(sa² + sb²), √(ta² + tb²), √(ua² + ub²)), all that enters without gravity; they are
//! placed at (sa, −sb), (ta, tb), (ua, ub) in the bodies' frames. The out-of-plane
//! moments of inertia do not enter a planar motion: each body's inertia is i·1.

use crate::model::Scene;
use crate::multibody::fmu::Robot;
use crate::multibody::{Body, Mechanism, Origin};

/// The test set's parameters (SI units), named as there.
pub mod p {
    pub const M1: f64 = 0.04325;
    pub const M2: f64 = 0.00365;
    pub const M3: f64 = 0.02373;
    pub const M4: f64 = 0.00706;
    pub const M5: f64 = 0.07050;
    pub const M6: f64 = 0.00706;
    pub const M7: f64 = 0.05498;
    pub const XA: f64 = -0.06934;
    pub const YA: f64 = -0.00227;
    pub const XB: f64 = -0.03635;
    pub const YB: f64 = 0.03273;
    pub const XC: f64 = 0.014;
    pub const YC: f64 = 0.072;
    pub const C0: f64 = 4530.0;
    pub const I1: f64 = 2.194e-6;
    pub const I2: f64 = 4.410e-7;
    pub const I3: f64 = 5.255e-6;
    pub const I4: f64 = 5.667e-7;
    pub const I5: f64 = 1.169e-5;
    pub const I6: f64 = 5.667e-7;
    pub const I7: f64 = 1.912e-5;
    pub const D: f64 = 28e-3;
    pub const DA: f64 = 115e-4;
    pub const E: f64 = 2e-2;
    pub const EA: f64 = 1421e-5;
    pub const RR: f64 = 7e-3;
    pub const RA: f64 = 92e-5;
    pub const L0: f64 = 7785e-5;
    pub const SS: f64 = 35e-3;
    pub const SA: f64 = 1874e-5;
    pub const SB: f64 = 1043e-5;
    pub const SC: f64 = 18e-3;
    pub const SD: f64 = 2e-2;
    pub const TA: f64 = 2308e-5;
    pub const TB: f64 = 916e-5;
    pub const U: f64 = 4e-2;
    pub const UA: f64 = 1228e-5;
    pub const UB: f64 = 449e-5;
    pub const ZF: f64 = 2e-2;
    pub const ZT: f64 = 4e-2;
    pub const FA: f64 = 1421e-5;
    pub const MOM: f64 = 33e-3;
}

/// The coordinates, in the test set's order.
pub const COORDINATES: [&str; 7] = ["beta", "Theta", "gamma", "Phi", "delta", "Omega", "epsilon"];

/// The test set's consistent initial positions (its velocities are zero), as it prints
/// them.
#[allow(clippy::excessive_precision)]
pub const START: [f64; 7] = [
    -0.0617138900142764496358948458001,
    0.0,
    0.455279819163070380255912382449,
    0.222668390165885884674473185609,
    0.487364979543842550225598953530,
    -0.222668390165885884674473185609,
    1.23054744454982119249735015568,
];

/// The test set's reference positions at t = 0.03 s.
pub const REFERENCE: [f64; 7] = [
    0.1581077119629904e2,
    -0.1575637105984298e2,
    0.4082224013073101e-1,
    -0.5347301163226948,
    0.5244099658805304,
    0.5347301163226948,
    0.1048080741042263e1,
];

/// The end time of the test set's problem (s).
pub const END: f64 = 0.03;

/// A body of `mass` with its centre of mass at `com` and planar inertia `i` (as i·1).
fn body(name: &str, mass: f64, com: [f64; 2], i: f64) -> Body {
    Body::new(name, mass)
        .com([com[0], com[1], 0.0])
        .inertia_diag([i; 3])
}

/// The squeezer's bodies, joints, closures and spring.
pub fn mechanism() -> Mechanism {
    use p::*;
    let z = [0.0, 0.0, 1.0];
    let at = |x: f64, y: f64| Origin::xyz([x, y, 0.0]);
    let p_on_k2 = [-D, 0.0, 0.0];
    let mut m = Mechanism::new("AndrewsSqueezer")
        .gravity([0.0; 3])
        .body(Body::massless("frame"))
        .body(body("K1", M1, [RA, 0.0], I1))
        .body(body("K2", M2, [-DA, 0.0], I2))
        .body(body("K3", M3, [SA, -SB], I3))
        .body(body("K4", M4, [0.0, -(E - EA)], I4))
        .body(body("K5", M5, [TA, TB], I5))
        .body(body("K6", M6, [ZF - FA, 0.0], I6))
        .body(body("K7", M7, [UA, UB], I7))
        .continuous("beta", "frame", "K1", Origin::IDENTITY, z)
        .continuous("Theta", "K1", "K2", at(RR, 0.0), z)
        .continuous("gamma", "frame", "K3", at(XB, YB), z)
        .continuous("delta", "frame", "K5", at(XA, YA), z)
        .continuous("Phi", "K5", "K4", at(ZT, 0.0), z)
        .continuous("epsilon", "frame", "K7", at(XA, YA), z)
        .continuous("Omega", "K7", "K6", at(0.0, -U), z)
        .closure("P3", "K2", p_on_k2, "K3", [0.0, -SS, 0.0], "xy")
        .closure("P4", "K2", p_on_k2, "K4", [0.0, -E, 0.0], "xy")
        .closure("P6", "K2", p_on_k2, "K6", [ZF, 0.0, 0.0], "xy")
        .spring(
            "spring",
            "K3",
            [SD, -SC, 0.0],
            "frame",
            [XC, YC, 0.0],
            C0,
            L0,
        )
        .dependent(&["Theta", "gamma", "Phi", "delta", "Omega", "epsilon"])
        .torque("beta", MOM)
        .order(&COORDINATES);
    for (name, value) in COORDINATES.iter().zip(START) {
        m = m.start(name, value);
    }
    m
}

crate::mechanism_fmu!(
    /// The squeezer's declaration (its FMU model is [`AndrewsSqueezer`]).
    pub AndrewsMechanism,
    "AndrewsSqueezer",
    mechanism,
    constraints = 6,
    notes = [
        "Andrews' squeezing mechanism (Hairer & Wanner, Solving ODEs II, VII.7; the IVP test set's andrews problem): seven bodies, planar, no gravity, the test set's parameters",
        "K1 about O by β (driven by tau_beta = mom = 0.033 N·m), K2 on K1 by Θ, K3 about B by γ, K5 about A by δ and K4 on K5 by Φ, K7 about A by ε and K6 on K7 by Ω",
        "Closures P3, P4, P6: K2's end P on K3, K4 and K6 (x, y): the test set's g₁…g₆, whose multipliers are force_P3_x … force_P6_y; β independent, the six others dependent",
        "Spring (c0 = 4530 N/m, l0 = 0.07785 m) from K3's point D to C = (xc, yc) on the frame; start values: the test set's consistent initial positions at rest",
    ],
    {
        const DESCRIPTION: &'static str =
            "Andrews' squeezing mechanism, the seven-body benchmark of Hairer and Wanner, declared as bodies, joints, three loop closures and a spring";
        const DEFAULT_EXPERIMENT: (f64, f64, f64) = (END, 1e-8, 1e-3);
        crate::generated_closed_terms!(crate::systems::generated::andrews_squeezer);

        fn scenes(_generated: Vec<Scene>) -> Vec<Scene> {
            let at_start = |mut s: Scene| {
                s = s.set("beta", START[0]).set("beta_dot", 0.0);
                for input in ["tau_Theta", "tau_gamma", "tau_Phi", "tau_delta", "tau_Omega", "tau_epsilon"] {
                    s = s.set(input, 0.0);
                }
                s
            };
            vec![
                at_start(Scene::new(
                    "test_set",
                    "The test set's problem: from its consistent initial positions at rest, the constant torque mom = 0.033 N·m on K1, to t = 0.03 s",
                    END,
                ))
                .set("tau_beta", p::MOM),
                at_start(Scene::new(
                    "released",
                    "From the same positions with no torque: the spring alone moves the mechanism",
                    END,
                ))
                .set("tau_beta", 0.0),
            ]
        }
    }
);

/// The squeezer as a model: a [`Robot`] of its declaration.
pub type AndrewsSqueezer = Robot<AndrewsMechanism>;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::lagrangian::Lagrangian;
    use crate::multibody::fmu::Declared;

    /// The generated closed terms against the interpreted path
    /// ([`crate::systems::check_generated_closed`]) at random states (off the closures,
    /// at large velocities: the formulas hold anywhere).
    #[test]
    fn generated_closed_terms_equal_the_interpreted_path() {
        crate::systems::check_generated_closed::<AndrewsMechanism>(
            &[(START.to_vec(), 1.0)],
            100.0,
            0.05,
            f64::MIN_POSITIVE,
        );
    }

    /// Where the right-hand side's time goes (`cargo test --release --lib
    /// andrews_squeezer::tests::parts -- --ignored --nocapture`): ns of each step of the
    /// generated path, best of 5.
    #[test]
    #[ignore]
    fn parts() {
        use crate::bench::speed::best_ns;
        use crate::multibody::closed::Code as _;
        use crate::systems::generated::andrews_squeezer::Code;
        use std::hint::black_box;
        let q = START;
        let qd = [1.0, -2.0, 3.0, 0.5, -0.5, 2.0, 1.5];
        let ns = |name: &str, v: f64| println!("{name}: {v:.1} ns");
        let mut t = Code::position(&q);
        ns(
            "position",
            best_ns(5, || {
                t = Code::position(black_box(&q));
            }),
        );
        ns(
            "factor",
            best_ns(5, || {
                black_box(black_box(&mut t).factor());
            }),
        );
        let mut v = qd;
        ns(
            "tangent",
            best_ns(5, || {
                v = qd;
                t.tangent::<Code>(black_box(&mut v));
            }),
        );
        ns(
            "velocity",
            best_ns(5, || {
                (t.bias, t.gamma) = Code::velocity(&q, &t.sc, black_box(&v));
            }),
        );
        let f = [0.01; 7];
        let mut qdd = [0.0; 7];
        ns(
            "accelerations",
            best_ns(5, || {
                black_box(t.accelerations::<Code>(black_box(&f), &mut qdd));
            }),
        );
        let p: Vec<f64> = <AndrewsSqueezer as Lagrangian>::parameters()
            .iter()
            .map(|v| v.start)
            .collect();
        let u = [p::MOM, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut mu = [0.0; 6];
        ns(
            "whole",
            best_ns(5, || {
                AndrewsMechanism::generated_closed::<f64>(
                    0.0,
                    (black_box(&q), &qd, &u, &p),
                    &mut qdd,
                    &mut mu,
                );
            }),
        );
    }
}
