//! Two masses, two springs, one damper (notes 3.4.5): a wall, spring k1, mass m1,
//! spring k2 in parallel with damper c2, mass m2; the force F acts on m1.

use crate::model::{Scalar, Scene, System, Var};

pub struct TwoMassChain;

/// Where the `stiff` scene releases m2 (m).
const STIFF_X2: f64 = 0.1;

/// The stretch `d = x2 − x1` at rest for which m1 and m2 start with equal accelerations, so
/// the coupling mode is not excited: `(−k1 x1 + k2 d)/m1 = −k2 d/m2` with `x1 = x2 − d`
/// gives `d = k1 m2 x2 / (k2 (m1 + m2) + k1 m2)`.
fn quasi_static_stretch(m1: f64, m2: f64, k1: f64, k2: f64, x2: f64) -> f64 {
    k1 * m2 * x2 / (k2 * (m1 + m2) + k1 * m2)
}

impl System for TwoMassChain {
    const NAME: &'static str = "TwoMassChain";
    const DESCRIPTION: &'static str =
        "Two masses in a chain: wall–k1–m1–(k2 ∥ c2)–m2, force F on m1";
    /// States are (positions, velocities).
    fn second_order() -> bool {
        true
    }
    const EQUATIONS: &'static [&'static str] = &[
        "m1 ẍ1 = −k1 x1 + k2 (x2 − x1) + c2 (ẋ2 − ẋ1) + F",
        "m2 ẍ2 = −k2 (x2 − x1) − c2 (ẋ2 − ẋ1)",
        "E = ½ m1 ẋ1² + ½ m2 ẋ2² + ½ k1 x1² + ½ k2 (x2 − x1)²",
    ];

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m1", Some("kg"), 1.0, "First mass (wall side)").min(1e-12),
            Var::new("m2", Some("kg"), 1.0, "Second mass").min(1e-12),
            Var::new(
                "k1",
                Some("N/m"),
                100.0,
                "Stiffness of the spring from the wall to m1",
            )
            .min(0.0),
            Var::new(
                "k2",
                Some("N/m"),
                100.0,
                "Stiffness of the spring between m1 and m2",
            )
            .min(0.0),
            Var::new("c2", Some("N.s/m"), 2.0, "Damping between m1 and m2").min(0.0),
        ]
    }

    fn inputs() -> Vec<Var> {
        vec![Var::new("F", Some("N"), 0.0, "External force on m1")]
    }

    fn states() -> Vec<Var> {
        vec![
            Var::new("x1", Some("m"), 0.1, "Position of m1").nominal(0.1),
            Var::new("x2", Some("m"), 0.0, "Position of m2").nominal(0.1),
            Var::new("v1", Some("m/s"), 0.0, "Velocity of m1").nominal(1.0),
            Var::new("v2", Some("m/s"), 0.0, "Velocity of m2").nominal(1.0),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![Var::new(
            "E",
            Some("J"),
            0.0,
            "Mechanical energy (kinetic + both springs)",
        )]
    }

    /// Neither f nor g reads t.
    fn explicit_time(_p: &[f64]) -> (bool, bool) {
        (false, false)
    }

    #[inline(always)]
    fn derivatives<S: Scalar>(_t: f64, x: &[S], u: &[S], p: &[S], dx: &mut [S]) {
        let [m1, m2, k1, k2, c2] = [p[0], p[1], p[2], p[3], p[4]];
        let coupling = k2 * (x[1] - x[0]) + c2 * (x[3] - x[2]);
        dx[0] = x[2];
        dx[1] = x[3];
        dx[2] = (u[0] - k1 * x[0] + coupling) / m1;
        dx[3] = -coupling / m2;
    }

    #[inline(always)]
    fn extra_outputs<S: Scalar>(_t: f64, x: &[S], _u: &[S], p: &[S], y: &mut [S]) {
        let [m1, m2, k1, k2] = [p[0], p[1], p[2], p[3]];
        let stretch = x[1] - x[0];
        y[0] =
            (m1 * x[2] * x[2] + m2 * x[3] * x[3] + k1 * x[0] * x[0] + k2 * stretch * stretch) * 0.5;
    }

    /// `ẋ = A x + B u` for any parameters.
    fn linear_time_invariant(_p: &[f64]) -> bool {
        true
    }

    fn scenes() -> Vec<Scene> {
        vec![
            Scene::new("release", "Released from x1 = 0.1 m, all at rest", 10.0).set("x1", 0.1),
            Scene::new("step", "Step force F = 1 N on m1 from rest", 10.0)
                .set("x1", 0.0)
                .set("F", 1.0),
            // The stiff coupling's fast mode (√(k2 (1/m1 + 1/m2)) = 1414 rad/s) starts
            // unexcited: both masses at 0.1 m, k2 pre-stretched so that they start with the
            // same acceleration. The motion is the smooth slow mode (7.07 rad/s) that an
            // L-stable method can follow with large steps while an explicit one stays
            // bound by the fast eigenvalue. (Released with k2 stretched 0.1 m instead,
            // the fast mode carries the motion and every method must resolve it.)
            Scene::new(
                "stiff",
                "Stiff coupling k2 = 1e6 N/m, c2 = 10 N·s/m: both masses released from 0.1 m \
                 with k2 at its quasi-static stretch (fast mode unexcited)",
                2.0,
            )
            .set("k2", 1e6)
            .set("c2", 10.0)
            .set("x2", STIFF_X2)
            .set(
                "x1",
                STIFF_X2 - quasi_static_stretch(1.0, 1.0, 100.0, 1e6, STIFF_X2),
            ),
        ]
    }
}
