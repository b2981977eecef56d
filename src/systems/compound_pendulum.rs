//! Compound pendulum (notes 8.9, 9.4.3; systems.md section 7): a rigid body swinging
//! about a fixed horizontal axis through O, written as a [`Lagrangian`].
//!
//! `T = ½ I_O θ̇²`, `V = −m g l cos θ` (z down, θ from the downward vertical), the
//! torque τ at O the generalised force. The derived equation is
//! `I_O θ̈ + m g l sin θ = τ`.

use crate::model::lagrangian::{self, Lagrangian};
use crate::model::{Scalar, Scene, Var};

pub struct CompoundPendulum;

/// Parameter indices.
const M: usize = 0;
const L: usize = 1;
const I_O: usize = 2;
const G: usize = 3;

impl Lagrangian for CompoundPendulum {
    /// Forces and outputs take t only into T, V and the constraints.
    const TIME_IN_FORCES_OR_OUTPUTS: bool = false;
    const NAME: &'static str = "CompoundPendulum";
    crate::generated_eom!(crate::model::symbolic::generated::CompoundPendulumEom);
    const DESCRIPTION: &'static str =
        "A rigid body swinging about a fixed horizontal axis, equations derived from its Lagrangian";
    const EQUATIONS: &'static [&'static str] = &[
        "q = θ, the angle of O→centre of mass from the downward vertical",
        "T = ½ I_O θ̇², V = −m g l cos θ, L = T − V; generalised force τ (torque at O)",
        "Equation of motion, formed by automatic differentiation of L: I_O θ̈ + m g l sin θ = τ",
        "Equivalent simple pendulum of length I_O/(m l); period 4 √(I_O/(m g l)) K(sin(θ0/2))",
        "E = ½ I_O θ̇² − m g l cos θ",
    ];

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m", Some("kg"), 1.0, "Mass of the body").min(1e-12),
            Var::new(
                "l",
                Some("m"),
                0.5,
                "Distance from the axis O to the centre of mass",
            )
            .min(0.0),
            Var::new(
                "I_O",
                Some("kg.m2"),
                1.0 / 3.0,
                "Moment of inertia about the axis through O",
            )
            .min(1e-12),
            Var::new("g", Some("m/s2"), 9.81, "Gravitational acceleration"),
        ]
    }

    fn inputs() -> Vec<Var> {
        vec![Var::new(
            "tau",
            Some("N.m"),
            0.0,
            "Torque about the axis at O",
        )]
    }

    fn coordinates() -> Vec<Var> {
        vec![Var::new(
            "theta",
            Some("rad"),
            0.1,
            "Angle from the downward vertical",
        )
        .nominal(1.0)]
    }

    fn velocities() -> Vec<Var> {
        vec![Var::new("theta_dot", Some("rad/s"), 0.0, "Angular velocity").nominal(1.0)]
    }

    fn outputs() -> Vec<Var> {
        vec![Var::new(
            "E",
            Some("J"),
            0.0,
            "Mechanical energy ½ I_O θ̇² − m g l cos θ",
        )]
    }

    fn kinetic<S: Scalar>(_t: S, _q: &[S], qd: &[S], p: &[S]) -> S {
        p[I_O] * qd[0] * qd[0] * 0.5
    }

    fn potential<S: Scalar>(_t: S, q: &[S], p: &[S]) -> S {
        -(p[M] * p[G] * p[L] * q[0].cos())
    }

    fn forces<S: Scalar>(_t: f64, _q: &[S], _qd: &[S], u: &[S], _p: &[S], out: &mut [S]) {
        out[0] = u[0];
    }

    fn extra_outputs<S: Scalar>(t: f64, q: &[S], qd: &[S], _u: &[S], p: &[S], y: &mut [S]) {
        y[0] = lagrangian::energy::<Self, S>(t, q, qd, p);
    }

    fn scenes() -> Vec<Scene> {
        vec![
            Scene::new("small", "Small swing from θ0 = 0.1 rad, at rest", 10.0)
                .set("theta", 0.1)
                .set("theta_dot", 0.0),
            Scene::new(
                "large",
                "Large swing from θ0 = 3.0 rad, close to the separatrix",
                10.0,
            )
            .set("theta", 3.0)
            .set("theta_dot", 0.0),
            Scene::new(
                "inverted",
                "From θ0 = π − 1e-3 rad: leaves the upright equilibrium",
                10.0,
            )
            .set("theta", std::f64::consts::PI - 1e-3)
            .set("theta_dot", 0.0),
        ]
    }
}
