//! A bead on a hoop that a drive turns about its vertical diameter at a prescribed rate
//! (notes 6.5; systems.md section 13): a rheonomic system written as a [`Lagrangian`].
//!
//! The hoop's angle φ is kept as a surplus coordinate with the rheonomic constraint
//! `φ − Ω t = 0`, so that its multiplier is the drive's torque (`torque = −λ`) and no
//! equation is derived by hand: `T = ½ m R² (θ̇² + sin²θ φ̇²)`, `V = −m g R cos θ` (z down).
//! The energy E is not conserved (the drive does work, `dE/dt = torque · Ω`); the Jacobi
//! integral `h = E − φ̇ ∂T/∂φ̇` is.
//!
//! No generated equations (`generated_eom!`): M = diag(m R², m R² sin²θ) is singular at
//! the bottom θ = 0 (the bead on the axis gives the hoop no inertia), where only the
//! constraint makes `[M Gᵀ; G 0]` regular. The generated solve goes through M⁻¹ (Schur
//! complement), so it fails there and loses digits near it (9e-13 measured); the
//! automatic-differentiation path solves the augmented system and is exact.

use crate::model::lagrangian::{self, Lagrangian};
use crate::model::{Scalar, Scene, Var};
use num_dual::Dual;

pub struct RotatingHoopBead;

/// Parameter indices.
const M: usize = 0;
const R: usize = 1;
const OMEGA: usize = 2;
const G: usize = 3;

impl Lagrangian for RotatingHoopBead {
    /// Forces and outputs take t only into T, V and the constraints.
    const TIME_IN_FORCES_OR_OUTPUTS: bool = false;
    const NAME: &'static str = "RotatingHoopBead";
    const DESCRIPTION: &'static str =
        "A bead on a hoop turned about its vertical diameter at a prescribed rate (rheonomic)";
    const EQUATIONS: &'static [&'static str] = &[
        "q = (θ, φ): the bead's angle on the hoop from its lowest point, the hoop's angle about the vertical",
        "T = ½ m R² (θ̇² + sin²θ φ̇²), V = −m g R cos θ (z down); rheonomic constraint φ − Ω t = 0",
        "φ, φ̇ are dependent states (φ = Ω t, φ̇ = Ω); the multiplier λ of the constraint gives torque = −λ",
        "Equations formed by automatic differentiation (time a dual number too): R θ̈ = (R Ω² cos θ − g) sin θ",
        "torque = d/dt(m R² sin²θ Ω) = 2 m R² Ω sin θ cos θ θ̇; dE/dt = torque · Ω",
        "Jacobi integral h = E − φ̇ ∂T/∂φ̇ = ½ m R² θ̇² − ½ m R² Ω² sin²θ − m g R cos θ: conserved",
        "Equilibria: θ = 0, stable iff Ω² < g/R (eigenvalues ±i√(g/R − Ω²), else ±√(Ω² − g/R));",
        "θ* = arccos(g/(R Ω²)) for Ω² > g/R, small oscillations at √(Ω² − g²/(R² Ω²))",
    ];
    const CONSTRAINTS: usize = 1;
    const RHEONOMIC: bool = true;

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m", Some("kg"), 0.1, "Mass of the bead").min(1e-12),
            Var::new("R", Some("m"), 0.5, "Radius of the hoop").min(1e-12),
            Var::new(
                "Omega",
                Some("rad/s"),
                6.0,
                "Prescribed rate of the hoop about the vertical",
            ),
            Var::new("g", Some("m/s2"), 9.81, "Gravitational acceleration"),
        ]
    }

    fn inputs() -> Vec<Var> {
        Vec::new()
    }

    fn coordinates() -> Vec<Var> {
        vec![
            Var::new(
                "theta",
                Some("rad"),
                0.5,
                "Bead's angle on the hoop from its lowest point",
            )
            .nominal(1.0),
            Var::new(
                "phi",
                Some("rad"),
                0.0,
                "Hoop's angle about the vertical (dependent: Ω t)",
            )
            .nominal(1.0)
            .dependent(),
        ]
    }

    fn velocities() -> Vec<Var> {
        vec![
            Var::new("theta_dot", Some("rad/s"), 0.0, "Rate of theta").nominal(1.0),
            Var::new("phi_dot", Some("rad/s"), 6.0, "Hoop's rate (dependent: Ω)")
                .nominal(1.0)
                .dependent(),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![
            Var::new(
                "E",
                Some("J"),
                0.0,
                "Kinetic plus potential energy in the inertial frame",
            ),
            Var::new(
                "h",
                Some("J"),
                0.0,
                "Jacobi integral E − φ̇ ∂T/∂φ̇ (conserved)",
            ),
            Var::new(
                "torque",
                Some("N.m"),
                0.0,
                "Torque the drive exerts on the hoop about the vertical (−λ)",
            ),
        ]
    }

    fn kinetic<S: Scalar>(_t: S, q: &[S], qd: &[S], p: &[S]) -> S {
        let s = q[0].sin();
        p[M] * p[R] * p[R] * (qd[0] * qd[0] + s * s * qd[1] * qd[1]) * 0.5
    }

    fn potential<S: Scalar>(_t: S, q: &[S], p: &[S]) -> S {
        -(p[M] * p[G] * p[R] * q[0].cos())
    }

    fn constraints<S: Scalar>(t: S, q: &[S], p: &[S], phi: &mut [S]) {
        phi[0] = q[1] - p[OMEGA] * t;
    }

    fn extra_outputs<S: Scalar>(t: f64, q: &[S], qd: &[S], u: &[S], p: &[S], y: &mut [S]) {
        let (mut qdd, mut lambda) = ([S::from(0.0); 2], [S::from(0.0); 1]);
        lagrangian::accelerations_and_multipliers_into::<Self, S>(
            t,
            q,
            qd,
            u,
            p,
            &mut qdd,
            &mut lambda,
        );
        let e = lagrangian::energy::<Self, S>(t, q, qd, p);
        // ∂T/∂φ̇: one dual evaluation of T.
        let lift = |v: &[S]| -> Vec<Dual<S>> { v.iter().map(|&x| Dual::from_re(x)).collect() };
        let mut qd_dual = lift(qd);
        qd_dual[1].eps = S::from(1.0);
        let p_phi = Self::kinetic(Dual::from_re(S::from(t)), &lift(q), &qd_dual, &lift(p)).eps;
        y[0] = e;
        y[1] = e - qd[1] * p_phi;
        y[2] = -lambda[0];
    }

    fn default_experiment() -> (f64, f64, f64) {
        (20.0, 1e-10, 1e-2)
    }

    fn scenes() -> Vec<Scene> {
        vec![
            Scene::new(
                "slow",
                "Ω = 3 rad/s (Ω² < g/R): the bead oscillates about the bottom, from θ = 0.3 rad",
                20.0,
            )
            .set("Omega", 3.0)
            .set("theta", 0.3)
            .set("theta_dot", 0.0)
            .set("phi_dot", 3.0),
            Scene::new(
                "fast",
                "Ω = 6 rad/s (Ω² > g/R): the bead oscillates about θ* = arccos(g/(R Ω²)) ≈ 0.995 rad, from θ = 0.5 rad",
                20.0,
            )
            .set("Omega", 6.0)
            .set("theta", 0.5)
            .set("theta_dot", 0.0)
            .set("phi_dot", 6.0),
        ]
    }
}
