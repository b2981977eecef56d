//! Mass-spring-damper (notes 3.4.1–3.4.4): `m ẍ + c ẋ + k x = F_ext`.

use crate::model::{Scalar, Scene, System, Var};

pub struct MassSpringDamper;

impl System for MassSpringDamper {
    const NAME: &'static str = "MassSpringDamper";
    const DESCRIPTION: &'static str =
        "A mass on a linear spring and viscous damper, driven by an external force";
    /// States are (positions, velocities).
    fn second_order() -> bool {
        true
    }
    const EQUATIONS: &'static [&'static str] = &[
        "m ẍ + c ẋ + k x = F + F_amp sin(F_omega t)",
        "ωn = √(k/m), ζ = c / (2 m ωn)",
        "E = ½ m ẋ² + ½ k x²",
        "The sinusoidal term is built in so a resonance scene is exact: a co-simulation input is a polynomial over each communication step (held, or with the derivatives the master gives), never a sine.",
    ];

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m", Some("kg"), 1.0, "Mass").min(1e-12),
            Var::new("k", Some("N/m"), 100.0, "Spring stiffness").min(0.0),
            Var::new("c", Some("N.s/m"), 2.0, "Damping coefficient").min(0.0),
            Var::new(
                "F_amp",
                Some("N"),
                0.0,
                "Amplitude of the built-in sinusoidal force",
            ),
            Var::new(
                "F_omega",
                Some("rad/s"),
                10.0,
                "Angular frequency of the built-in sinusoidal force",
            ),
        ]
    }

    fn inputs() -> Vec<Var> {
        vec![Var::new("F", Some("N"), 0.0, "External force on the mass")]
    }

    fn states() -> Vec<Var> {
        vec![
            Var::new(
                "x",
                Some("m"),
                0.1,
                "Position of the mass (spring relaxed at 0)",
            )
            .nominal(0.1),
            Var::new("v", Some("m/s"), 0.0, "Velocity of the mass").nominal(1.0),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![Var::new(
            "E",
            Some("J"),
            0.0,
            "Mechanical energy ½ m v² + ½ k x²",
        )]
    }

    /// f reads t in the harmonic forcing (when it is on); g never.
    fn explicit_time(p: &[f64]) -> (bool, bool) {
        (p[3] != 0.0, false)
    }

    #[inline(always)]
    fn derivatives<S: Scalar>(t: f64, x: &[S], u: &[S], p: &[S], dx: &mut [S]) {
        let [m, k, c, f_amp, f_omega] = [p[0], p[1], p[2], p[3], p[4]];
        // (No sine to pay for when the forcing is off: F_amp·sin is then zero.)
        let force = if f_amp.is_zero() {
            u[0]
        } else {
            u[0] + f_amp * (f_omega * t).sin()
        };
        dx[0] = x[1];
        dx[1] = (force - c * x[1] - k * x[0]) / m;
    }

    #[inline(always)]
    fn extra_outputs<S: Scalar>(_t: f64, x: &[S], _u: &[S], p: &[S], y: &mut [S]) {
        let (m, k) = (p[0], p[1]);
        y[0] = m * x[1] * x[1] * 0.5 + k * x[0] * x[0] * 0.5;
    }

    /// Affine and time invariant unless the harmonic forcing is on.
    fn linear_time_invariant(p: &[f64]) -> bool {
        p[3] == 0.0
    }

    fn scenes() -> Vec<Scene> {
        vec![
            Scene::new("free", "Undamped free oscillation from x0 = 0.1 m", 10.0)
                .set("c", 0.0)
                .set("x", 0.1),
            Scene::new("damped", "Underdamped, ζ = 0.1, from x0 = 0.1 m", 10.0)
                .set("c", 2.0)
                .set("x", 0.1),
            Scene::new("critical", "Critically damped, ζ = 1, from x0 = 0.1 m", 5.0)
                .set("c", 20.0)
                .set("x", 0.1),
            Scene::new("overdamped", "Overdamped, ζ = 2.5, from x0 = 0.1 m", 5.0)
                .set("c", 50.0)
                .set("x", 0.1),
            Scene::new(
                "step",
                "Step force F = 1 N from rest at t = 0, ζ = 0.1",
                10.0,
            )
            .set("x", 0.0)
            .set("F", 1.0),
            Scene::new(
                "resonance",
                "F = sin(ωn t) from rest, light damping c = 0.1",
                10.0,
            )
            .set("c", 0.1)
            .set("x", 0.0)
            .set("F_amp", 1.0)
            .set("F_omega", 10.0),
        ]
    }
}
