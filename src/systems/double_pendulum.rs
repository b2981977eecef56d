//! Double pendulum (notes 5.2.4, 9.4.3; systems.md section 5), written as a
//! [`Lagrangian`] from the particle positions.
//!
//! Mass m1 on a massless rod of length r1 from the fixed point O, mass m2 on a massless
//! rod of length l2 from m1; q = (θ1, φ), both angles absolute, from the downward
//! vertical (x horizontal, z down):
//!
//! ```text
//! x1 = r1 sin θ1,       z1 = r1 cos θ1
//! x2 = x1 + l2 sin φ,   z2 = z1 + l2 cos φ
//! T = ½ m1 (ẋ1² + ż1²) + ½ m2 (ẋ2² + ż2²),   V = −g (m1 z1 + m2 z2)
//! ```
//!
//! Joint torques: τ1 at O drives the first rod; τ2 at m1 is exerted by the first rod on
//! the second (and −τ2 back on the first). Their virtual work is
//! `τ1 δθ1 + τ2 (δφ − δθ1)`, so with absolute angles `Q = (τ1 − τ2, τ2)`.
//!
//! Rod tensions, from Newton's law for each particle once q̈ is known. Unit vectors
//! along the rods (from O to m1, from m1 to m2): `e1 = (sin θ1, cos θ1)`,
//! `e2 = (sin φ, cos φ)`; accelerations `a1 = r1 (θ̈1 n1 − θ̇1² e1)`,
//! `a2 = a1 + l2 (φ̈ n2 − φ̇² e2)` with `nᵢ = ∂eᵢ/∂angle`. A massless rod passes its end
//! forces through unchanged, so the force of rod 2 on m2 is `m2 (a2 − g ẑ)` and rod 1
//! carries on m1 both particles' inertia and weight. The tensions (positive when
//! pulling the particle back towards the inner end) are the axial components:
//!
//! ```text
//! F2 = m2 (g ẑ − a2)·e2 = m2 (g cos φ − a2·e2)
//! F1 = [m1 (g ẑ − a1) + m2 (g ẑ − a2)]·e1
//! ```
//!
//! Joint torques add shear forces across the rods, which these axial components do not
//! include; the formulas hold with and without torques. Hanging at rest: F2 = m2 g,
//! F1 = (m1 + m2) g.

use crate::model::lagrangian::{self, Lagrangian};
use crate::model::{Scalar, Scene, Var};

pub struct DoublePendulum;

/// Parameter indices.
const M1: usize = 0;
const M2: usize = 1;
const R1: usize = 2;
const L2: usize = 3;
const G: usize = 4;

/// The particles' velocities `(ẋ1, ż1, ẋ2, ż2)`, from differentiating their positions.
fn particle_velocities<S: Scalar>(q: &[S], qd: &[S], p: &[S]) -> [S; 4] {
    let (th, ph) = (q[0], q[1]);
    let (thd, phd) = (qd[0], qd[1]);
    let x1d = p[R1] * th.cos() * thd;
    let z1d = -(p[R1] * th.sin() * thd);
    let x2d = x1d + p[L2] * ph.cos() * phd;
    let z2d = z1d - p[L2] * ph.sin() * phd;
    [x1d, z1d, x2d, z2d]
}

/// The rod tensions `(F1, F2)` at a state and acceleration (see the module notes).
pub fn rod_tensions<S: Scalar>(q: &[S], qd: &[S], qdd: &[S], p: &[S]) -> (S, S) {
    let (m1, m2, r1, l2, g) = (p[M1], p[M2], p[R1], p[L2], p[G]);
    let (s1, c1, s2, c2) = (q[0].sin(), q[0].cos(), q[1].sin(), q[1].cos());
    let (e1, n1) = ([s1, c1], [c1, -s1]);
    let (e2, n2) = ([s2, c2], [c2, -s2]);
    let a1: [S; 2] = std::array::from_fn(|k| r1 * (qdd[0] * n1[k] - qd[0] * qd[0] * e1[k]));
    let a2: [S; 2] = std::array::from_fn(|k| a1[k] + l2 * (qdd[1] * n2[k] - qd[1] * qd[1] * e2[k]));
    // mᵢ (g ẑ − aᵢ): minus the force the rods must supply to particle i besides its weight.
    let gz = [S::from(0.0), g];
    let f1: [S; 2] = std::array::from_fn(|k| m1 * (gz[k] - a1[k]));
    let f2: [S; 2] = std::array::from_fn(|k| m2 * (gz[k] - a2[k]));
    let t2 = f2[0] * e2[0] + f2[1] * e2[1];
    let t1 = (f1[0] + f2[0]) * e1[0] + (f1[1] + f2[1]) * e1[1];
    (t1, t2)
}

impl Lagrangian for DoublePendulum {
    /// Forces and outputs take t only into T, V and the constraints.
    const TIME_IN_FORCES_OR_OUTPUTS: bool = false;
    const NAME: &'static str = "DoublePendulum";
    crate::generated_eom!(crate::model::symbolic::generated::DoublePendulumEom);
    const DESCRIPTION: &'static str =
        "Two point masses on massless rods in a vertical plane, equations derived from the Lagrangian";
    const EQUATIONS: &'static [&'static str] = &[
        "q = (θ1, φ): absolute angles of the rods O–m1 and m1–m2 from the downward vertical (x horizontal, z down)",
        "x1 = r1 sin θ1, z1 = r1 cos θ1, x2 = x1 + l2 sin φ, z2 = z1 + l2 cos φ",
        "T = ½ m1 (ẋ1² + ż1²) + ½ m2 (ẋ2² + ż2²), V = −g (m1 z1 + m2 z2), L = T − V",
        "Generalised forces of the joint torques τ1 (at O) and τ2 (at m1, first rod on second): Q = (τ1 − τ2, τ2)",
        "Equations of motion formed by automatic differentiation of L: M(q) q̈ = Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇, M = ∂²T/∂q̇²",
        "(m1+m2) r1² θ̈1 + m2 r1 l2 cos(φ−θ1) φ̈ − m2 r1 l2 φ̇² sin(φ−θ1) + (m1+m2) g r1 sin θ1 = τ1 − τ2",
        "m2 l2² φ̈ + m2 r1 l2 cos(φ−θ1) θ̈1 + m2 r1 l2 θ̇1² sin(φ−θ1) + m2 g l2 sin φ = τ2",
        "Rod tensions (axial components, from Newton's law on each particle): F2 = m2 (g ẑ − a2)·e2, F1 = [m1 (g ẑ − a1) + m2 (g ẑ − a2)]·e1, e1 = (sin θ1, cos θ1), e2 = (sin φ, cos φ)",
        "E = T + V",
    ];

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m1", Some("kg"), 1.0, "Inner mass").min(1e-12),
            Var::new("m2", Some("kg"), 1.0, "Outer mass").min(1e-12),
            Var::new("r1", Some("m"), 1.0, "Length of the rod O–m1").min(1e-12),
            Var::new("l2", Some("m"), 1.0, "Length of the rod m1–m2").min(1e-12),
            Var::new("g", Some("m/s2"), 9.81, "Gravitational acceleration"),
        ]
    }

    fn inputs() -> Vec<Var> {
        vec![
            Var::new("tau1", Some("N.m"), 0.0, "Torque on the first rod at O"),
            Var::new(
                "tau2",
                Some("N.m"),
                0.0,
                "Torque of the first rod on the second, at m1",
            ),
        ]
    }

    fn coordinates() -> Vec<Var> {
        vec![
            Var::new(
                "theta1",
                Some("rad"),
                0.05,
                "Angle of the rod O–m1 from the downward vertical",
            )
            .nominal(1.0),
            Var::new(
                "phi",
                Some("rad"),
                0.05,
                "Angle of the rod m1–m2 from the downward vertical",
            )
            .nominal(1.0),
        ]
    }

    fn velocities() -> Vec<Var> {
        vec![
            Var::new(
                "theta1_dot",
                Some("rad/s"),
                0.0,
                "Angular velocity of the rod O–m1",
            )
            .nominal(1.0),
            Var::new(
                "phi_dot",
                Some("rad/s"),
                0.0,
                "Angular velocity of the rod m1–m2",
            )
            .nominal(1.0),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![
            Var::new("F1", Some("N"), 0.0, "Tension in the rod O–m1"),
            Var::new("F2", Some("N"), 0.0, "Tension in the rod m1–m2"),
            Var::new("E", Some("J"), 0.0, "Mechanical energy T + V"),
        ]
    }

    fn kinetic<S: Scalar>(_t: S, q: &[S], qd: &[S], p: &[S]) -> S {
        let [x1d, z1d, x2d, z2d] = particle_velocities(q, qd, p);
        (p[M1] * (x1d * x1d + z1d * z1d) + p[M2] * (x2d * x2d + z2d * z2d)) * 0.5
    }

    fn potential<S: Scalar>(_t: S, q: &[S], p: &[S]) -> S {
        let z1 = p[R1] * q[0].cos();
        let z2 = z1 + p[L2] * q[1].cos();
        -(p[G] * (p[M1] * z1 + p[M2] * z2))
    }

    fn forces<S: Scalar>(_t: f64, _q: &[S], _qd: &[S], u: &[S], _p: &[S], out: &mut [S]) {
        out[0] = u[0] - u[1];
        out[1] = u[1];
    }

    fn extra_outputs<S: Scalar>(t: f64, q: &[S], qd: &[S], u: &[S], p: &[S], y: &mut [S]) {
        let mut qdd = [S::from(0.0); 2];
        lagrangian::accelerations_into::<Self, S>(t, q, qd, u, p, &mut qdd);
        let (f1, f2) = rod_tensions(q, qd, &qdd, p);
        y[0] = f1;
        y[1] = f2;
        y[2] = lagrangian::energy::<Self, S>(t, q, qd, p);
    }

    fn scenes() -> Vec<Scene> {
        vec![
            Scene::new(
                "small",
                "Small oscillation from θ1 = φ = 0.05 rad, at rest",
                10.0,
            )
            .set("theta1", 0.05)
            .set("phi", 0.05)
            .set("theta1_dot", 0.0)
            .set("phi_dot", 0.0),
            Scene::new(
                "chaotic",
                "Chaotic motion from θ1 = φ = 2 rad, at rest",
                20.0,
            )
            .set("theta1", 2.0)
            .set("phi", 2.0)
            .set("theta1_dot", 0.0)
            .set("phi_dot", 0.0),
        ]
    }
}
