//! Projectile (notes 5.1.5, systems.md section 3): a point mass in uniform gravity,
//! no drag. SAE axes: z points down, so gravity is `+g k`.

use crate::model::{Scalar, Scene, System, Var};

pub struct Projectile;

impl System for Projectile {
    const NAME: &'static str = "Projectile";
    const DESCRIPTION: &'static str =
        "A point mass thrown in uniform gravity, no drag (z points down)";
    /// States are (positions, velocities).
    fn second_order() -> bool {
        true
    }
    const EQUATIONS: &'static [&'static str] = &[
        "SAE axes: z points down, gravity is +g k, the height is −z",
        "ẍ = 0, ÿ = 0, z̈ = g",
        "Closed form: x = x0 + vx0 t, y = y0 + vy0 t, z = z0 + vz0 t + ½ g t²",
        "E = ½ (vx² + vy² + vz²) − g z (specific energy, per unit mass: no mass is declared)",
    ];

    fn parameters() -> Vec<Var> {
        vec![Var::new(
            "g",
            Some("m/s2"),
            9.81,
            "Gravitational acceleration (along +z, downward)",
        )]
    }

    fn inputs() -> Vec<Var> {
        Vec::new()
    }

    fn states() -> Vec<Var> {
        vec![
            Var::new("x", Some("m"), 0.0, "Position, x (horizontal)").nominal(1.0),
            Var::new("y", Some("m"), 0.0, "Position, y (horizontal)").nominal(1.0),
            Var::new("z", Some("m"), 0.0, "Position, z (downward)").nominal(1.0),
            Var::new("vx", Some("m/s"), 10.0, "Velocity, x").nominal(1.0),
            Var::new("vy", Some("m/s"), 0.0, "Velocity, y").nominal(1.0),
            Var::new("vz", Some("m/s"), -10.0, "Velocity, z (downward)").nominal(1.0),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![Var::new(
            "E",
            Some("J/kg"),
            0.0,
            "Specific mechanical energy ½ |v|² − g z (constant)",
        )]
    }

    /// Neither f nor g reads t.
    fn explicit_time(_p: &[f64]) -> (bool, bool) {
        (false, false)
    }

    #[inline(always)]
    fn derivatives<S: Scalar>(_t: f64, x: &[S], _u: &[S], p: &[S], dx: &mut [S]) {
        dx[0] = x[3];
        dx[1] = x[4];
        dx[2] = x[5];
        dx[3] = S::zero();
        dx[4] = S::zero();
        dx[5] = p[0];
    }

    fn extra_outputs<S: Scalar>(_t: f64, x: &[S], _u: &[S], p: &[S], y: &mut [S]) {
        let speed2 = x[3] * x[3] + x[4] * x[4] + x[5] * x[5];
        y[0] = speed2 * 0.5 - p[0] * x[2];
    }

    fn scenes() -> Vec<Scene> {
        vec![Scene::new(
            "throw",
            "Thrown from the origin with v0 = (10, 0, −10) m/s (45° upward)",
            2.0,
        )
        .set("x", 0.0)
        .set("y", 0.0)
        .set("z", 0.0)
        .set("vx", 10.0)
        .set("vy", 0.0)
        .set("vz", -10.0)]
    }

    fn default_experiment() -> (f64, f64, f64) {
        (2.0, 1e-8, 1e-2)
    }
}
