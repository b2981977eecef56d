//! Springy pendulum (notes 5.1.6, 9.4.6; systems.md section 4): a mass m on a massless
//! coiled spring (stiffness c, free length r0) pivoted at O, moving in the vertical plane.
//!
//! SAE axes (z points down) and the angle θ from the downward vertical:
//! `x = r sin θ`, `z = r cos θ`, `e_r = (sin θ, cos θ)`, `e_θ = (cos θ, −sin θ)`.
//! The model integrates the polar form (5.46, 5.47); [`cartesian_rhs`] is the Cartesian
//! form (5.39, 5.40) of the same system, the second derivation the tests compare with.

use crate::model::{Scalar, Scene, System, Var};

pub struct SpringyPendulum;

/// Parameter indices.
const M: usize = 0;
const C: usize = 1;
const R0: usize = 2;
const G: usize = 3;

/// Default parameters.
const M_DEFAULT: f64 = 1.0;
const C_DEFAULT: f64 = 100.0;
const R0_DEFAULT: f64 = 1.0;
const G_DEFAULT: f64 = 9.81;

/// The static equilibrium length `r0 + m g / c` with the default m, r0, g and stiffness `c`.
fn r_eq(c: f64) -> f64 {
    R0_DEFAULT + M_DEFAULT * G_DEFAULT / c
}

/// Stiffness of the `stiff` scene.
const C_STIFF: f64 = 1e6;

/// The Cartesian form (5.39, 5.40), with ρ = √(x² + z²):
///
/// ```text
/// m ẍ + c (1 − r0/ρ) x       = (x F_r + z F_θ)/ρ
/// m z̈ + c (1 − r0/ρ) z − m g = (z F_r − x F_θ)/ρ
/// ```
///
/// States `q = (x, z, ẋ, ż)`, inputs `u = (F_r, F_θ)`, parameters `p = (m, c, r0, g)` as in
/// [`SpringyPendulum`]; writes `dq = (ẋ, ż, ẍ, z̈)`.
pub fn cartesian_rhs<S: Scalar>(q: &[S], u: &[S], p: &[S], dq: &mut [S]) {
    let (m, c, r0, g) = (p[M], p[C], p[R0], p[G]);
    let (x, z) = (q[0], q[1]);
    let (f_r, f_theta) = (u[0], u[1]);
    let rho = (x * x + z * z).sqrt();
    let spring = c * (-(r0 / rho) + 1.0);
    dq[0] = q[2];
    dq[1] = q[3];
    dq[2] = ((x * f_r + z * f_theta) / rho - spring * x) / m;
    dq[3] = ((z * f_r - x * f_theta) / rho - spring * z + m * g) / m;
}

impl System for SpringyPendulum {
    const NAME: &'static str = "SpringyPendulum";
    const DESCRIPTION: &'static str =
        "A mass on a coiled spring pivoted at a fixed point, swinging in the vertical plane";
    /// States are (positions, velocities).
    fn second_order() -> bool {
        true
    }
    const EQUATIONS: &'static [&'static str] = &[
        "SAE axes: z points down; θ from the downward vertical: x = r sin θ, z = r cos θ",
        "r̈ − r θ̇² − g cos θ + (c/m)(r − r0) = F_r / m",
        "r θ̈ + 2 ṙ θ̇ + g sin θ = F_theta / m",
        "F_r acts along the spring (outward), F_theta along e_θ = (cos θ, −sin θ)",
        "E = ½ m (ṙ² + r² θ̇²) − m g r cos θ + ½ c (r − r0)² (constant with no input)",
        "Static equilibrium θ = 0, r = r0 + m g / c; small oscillations √(c/m) (radial) and √(g/r) (swing)",
    ];

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m", Some("kg"), M_DEFAULT, "Mass").min(1e-12),
            Var::new("c", Some("N/m"), C_DEFAULT, "Spring stiffness").min(0.0),
            Var::new("r0", Some("m"), R0_DEFAULT, "Free length of the spring").min(0.0),
            Var::new(
                "g",
                Some("m/s2"),
                G_DEFAULT,
                "Gravitational acceleration (along +z, downward)",
            ),
        ]
    }

    fn inputs() -> Vec<Var> {
        vec![
            Var::new(
                "F_r",
                Some("N"),
                0.0,
                "Force on the mass along the spring, outward",
            ),
            Var::new(
                "F_theta",
                Some("N"),
                0.0,
                "Force on the mass perpendicular to the spring, along e_θ",
            ),
        ]
    }

    fn states() -> Vec<Var> {
        vec![
            Var::new(
                "r",
                Some("m"),
                r_eq(C_DEFAULT),
                "Length of the spring (distance of the mass from O)",
            )
            .nominal(1.0),
            Var::new(
                "theta",
                Some("rad"),
                0.5,
                "Angle of the spring from the downward vertical",
            )
            .nominal(1.0),
            Var::new("r_dot", Some("m/s"), 0.0, "Rate of change of r").nominal(1.0),
            Var::new("theta_dot", Some("rad/s"), 0.0, "Angular velocity").nominal(1.0),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![
            Var::new(
                "x",
                Some("m"),
                0.0,
                "Horizontal position of the mass, r sin θ",
            ),
            Var::new(
                "z",
                Some("m"),
                0.0,
                "Vertical position of the mass (down), r cos θ",
            ),
            Var::new(
                "E",
                Some("J"),
                0.0,
                "Mechanical energy (kinetic + gravity + spring)",
            ),
        ]
    }

    /// Neither f nor g reads t.
    fn explicit_time(_p: &[f64]) -> (bool, bool) {
        (false, false)
    }

    #[inline(always)]
    fn derivatives<S: Scalar>(_t: f64, x: &[S], u: &[S], p: &[S], dx: &mut [S]) {
        let (m, c, r0, g) = (p[M], p[C], p[R0], p[G]);
        let (r, theta, r_dot, theta_dot) = (x[0], x[1], x[2], x[3]);
        let (f_r, f_theta) = (u[0], u[1]);
        dx[0] = r_dot;
        dx[1] = theta_dot;
        dx[2] = r * theta_dot * theta_dot + g * theta.cos() - c * (r - r0) / m + f_r / m;
        dx[3] = (f_theta / m - r_dot * theta_dot * 2.0 - g * theta.sin()) / r;
    }

    fn extra_outputs<S: Scalar>(_t: f64, x: &[S], _u: &[S], p: &[S], y: &mut [S]) {
        let (m, c, r0, g) = (p[M], p[C], p[R0], p[G]);
        let (r, theta, r_dot, theta_dot) = (x[0], x[1], x[2], x[3]);
        let (s, co) = (theta.sin(), theta.cos());
        y[0] = r * s;
        y[1] = r * co;
        let stretch = r - r0;
        y[2] = m * (r_dot * r_dot + r * r * theta_dot * theta_dot) * 0.5 - m * g * r * co
            + c * stretch * stretch * 0.5;
    }

    fn scenes() -> Vec<Scene> {
        vec![
            Scene::new(
                "swing",
                "Released at rest from θ0 = 0.5 rad, the spring at its static equilibrium length r0 + m g / c",
                10.0,
            )
            .set("r", r_eq(C_DEFAULT))
            .set("theta", 0.5)
            .set("r_dot", 0.0)
            .set("theta_dot", 0.0),
            Scene::new(
                "bounce",
                "Vertical bounce: θ0 = 0, released at rest 0.1 m below the static equilibrium",
                10.0,
            )
            .set("r", r_eq(C_DEFAULT) + 0.1)
            .set("theta", 0.0)
            .set("r_dot", 0.0)
            .set("theta_dot", 0.0),
            Scene::new(
                "stiff",
                "Stiff spring c = 1e6 N/m, θ0 = 0.5 rad at the static equilibrium length: the rigid pendulum is the model this scene needs",
                2.0,
            )
            .set("c", C_STIFF)
            .set("r", r_eq(C_STIFF))
            .set("theta", 0.5)
            .set("r_dot", 0.0)
            .set("theta_dot", 0.0),
        ]
    }
}
