//! A pendulum whose string is pulled in (or let out) at a prescribed rate (notes 6.5;
//! systems.md section 13): a rheonomic system written as a [`Lagrangian`].
//!
//! The radius r is kept as a surplus coordinate with the rheonomic constraint
//! `r − l(t) = 0`, `l(t) = l0 + l_rate t`, so that its multiplier is the string's tension
//! and no equation is derived by hand: `T = ½ m (ṙ² + r² θ̇²)`, `V = −m g r cos θ`.
//! The pull does work: `dE/dt = −tension · l̇`.

use crate::model::lagrangian::{self, Lagrangian};
use crate::model::{Scalar, Scene, Var};

pub struct PulledPendulum;

/// Parameter indices.
const M: usize = 0;
const L0: usize = 1;
const L_RATE: usize = 2;
const G: usize = 3;

/// The shortest string, as a fraction of l0: the run stops there (fmi2Discard) rather than
/// run into l = 0, where the equations are singular.
pub const L_MIN_FRACTION: f64 = 0.01;

fn length<S: Scalar>(t: S, p: &[S]) -> S {
    p[L0] + p[L_RATE] * t
}

impl Lagrangian for PulledPendulum {
    /// Forces and outputs take t only into T, V and the constraints.
    const TIME_IN_FORCES_OR_OUTPUTS: bool = false;
    const NAME: &'static str = "PulledPendulum";
    crate::generated_eom!(crate::model::symbolic::generated::PulledPendulumEom);
    const DESCRIPTION: &'static str =
        "A pendulum whose string length is prescribed, l(t) = l0 + l_rate t (rheonomic)";
    const EQUATIONS: &'static [&'static str] = &[
        "q = (θ, r): the angle from the downward vertical, the radius",
        "T = ½ m (ṙ² + r² θ̇²), V = −m g r cos θ (z down); rheonomic constraint r − l(t) = 0, l = l0 + l_rate t",
        "r, r_dot are dependent states (l(t), l_rate); the constraint's multiplier is the tension",
        "Equations formed by automatic differentiation (time a dual number too): l θ̈ + 2 l̇ θ̇ + g sin θ = 0",
        "tension = m (g cos θ + l θ̇²); E = ½ m (l̇² + l² θ̇²) − m g l cos θ, dE/dt = −tension · l̇",
        "The run stops (fmi2Discard) when l reaches 0.01 l0",
    ];
    const CONSTRAINTS: usize = 1;
    const RHEONOMIC: bool = true;

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m", Some("kg"), 1.0, "Mass of the bob").min(1e-12),
            Var::new("l0", Some("m"), 1.0, "Length of the string at t = 0").min(1e-9),
            Var::new(
                "l_rate",
                Some("m/s"),
                -0.05,
                "Rate of the length (negative: pulled in)",
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
                0.3,
                "Angle of the string from the downward vertical",
            )
            .nominal(1.0),
            Var::new("r", Some("m"), 1.0, "Radius (dependent: l(t))")
                .nominal(1.0)
                .dependent(),
        ]
    }

    fn velocities() -> Vec<Var> {
        vec![
            Var::new("theta_dot", Some("rad/s"), 0.0, "Rate of theta").nominal(1.0),
            Var::new("r_dot", Some("m/s"), -0.05, "Rate of r (dependent: l_rate)")
                .nominal(1.0)
                .dependent(),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![
            Var::new(
                "l",
                Some("m"),
                1.0,
                "Length of the string now, l0 + l_rate t",
            ),
            Var::new("E", Some("J"), 0.0, "Kinetic plus potential energy"),
            Var::new(
                "tension",
                Some("N"),
                0.0,
                "Tension of the string (the constraint's multiplier)",
            ),
        ]
    }

    fn kinetic<S: Scalar>(_t: S, q: &[S], qd: &[S], p: &[S]) -> S {
        p[M] * (qd[1] * qd[1] + q[1] * q[1] * qd[0] * qd[0]) * 0.5
    }

    fn potential<S: Scalar>(_t: S, q: &[S], p: &[S]) -> S {
        -(p[M] * p[G] * q[1] * q[0].cos())
    }

    fn constraints<S: Scalar>(t: S, q: &[S], p: &[S], phi: &mut [S]) {
        phi[0] = q[1] - length(t, p);
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
        y[0] = length(S::from(t), p);
        y[1] = lagrangian::energy::<Self, S>(t, q, qd, p);
        y[2] = lambda[0];
    }

    fn default_experiment() -> (f64, f64, f64) {
        (10.0, 1e-10, 1e-2)
    }

    /// The string reaching its shortest length `L_MIN_FRACTION · l0`.
    fn event_indicator(t: f64, _q: &[f64], _qd: &[f64], _u: &[f64], p: &[f64]) -> Option<f64> {
        Some(length(t, p) - L_MIN_FRACTION * p[L0])
    }

    fn on_event(
        t: f64,
        _q: &mut [f64],
        _qd: &mut [f64],
        _u: &[f64],
        p: &[f64],
    ) -> Result<(), String> {
        Err(format!(
            "PulledPendulum: the string length l = l0 + l_rate t reaches {} m ({} l0) at t = {t} s; stopped there",
            L_MIN_FRACTION * p[L0],
            L_MIN_FRACTION
        ))
    }

    fn scenes() -> Vec<Scene> {
        vec![
            Scene::new(
                "pull",
                "Pulled in at 0.05 m/s from l = 1 m, θ0 = 0.3 rad: the swing speeds up",
                10.0,
            )
            .set("l_rate", -0.05)
            .set("theta", 0.3)
            .set("theta_dot", 0.0),
            Scene::new(
                "let_out",
                "Let out at 0.05 m/s from l = 1 m, θ0 = 0.3 rad: the swing slows down",
                10.0,
            )
            .set("l_rate", 0.05)
            .set("theta", 0.3)
            .set("theta_dot", 0.0),
        ]
    }
}
