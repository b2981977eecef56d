//! Spring and rod pendulum (notes 5.2.5; systems.md section 6), written as a
//! [`Lagrangian`] from the particle positions.
//!
//! Mass m1 hangs from the fixed point O on a massless spring (stiffness c, free length
//! r10); mass m2 hangs from m1 on a rigid massless rod of length l2. The coordinates are
//! those of the centre of mass A of the two particles, `q = (R, θ, φ)`: R its distance
//! from O, θ its angle and φ the rod's angle, both from the downward vertical
//! (x horizontal, z down).
//!
//! With `M = m1 + m2`, the rod direction `e = (sin φ, cos φ)` (from m1 to m2) and
//! `m2 = m1 + l2 e`, the centre of mass `A = (m1 x1 + m2 x2)/M = x1 + (m2 l2/M) e`, so A
//! lies `r1′ = m2 l2/M` beyond m1 and `r2′ = m1 l2/M` short of m2 along the rod:
//!
//! ```text
//! A  = R (sin θ, cos θ)
//! x1 = A − r1′ e,   x2 = A + r2′ e
//! r1 = |x1| = √(R² + r1′² − 2 r1′ R cos(φ−θ))          (spring length)
//! T  = ½ m1 |ẋ1|² + ½ m2 |ẋ2|²  = ½ M (Ṙ² + R² θ̇²) + ½ (m1 r1′² + m2 r2′²) φ̇²
//! V  = −g (m1 z1 + m2 z2) + ½ c (r1 − r10)²  = −M g R cos θ + ½ c (r1 − r10)²
//! ```
//!
//! (the cross terms cancel because m1 r1′ = m2 r2′). Static equilibrium: θ = φ = 0,
//! spring stretched by M g / c, so `R = r10 + M g / c + r1′`.

use crate::model::lagrangian::{self, Lagrangian};
use crate::model::{Scalar, Scene, Var};

pub struct SpringRodPendulum;

/// Parameter indices.
const M1: usize = 0;
const M2: usize = 1;
const C: usize = 2;
const R10: usize = 3;
const L2: usize = 4;
const G: usize = 5;

/// Default parameters.
const M1_DEFAULT: f64 = 1.0;
const M2_DEFAULT: f64 = 1.0;
const C_DEFAULT: f64 = 100.0;
const R10_DEFAULT: f64 = 1.0;
const L2_DEFAULT: f64 = 0.5;
const G_DEFAULT: f64 = 9.81;

/// R at the static equilibrium with the default parameters: `r10 + M g / c + r1′`.
fn r_eq() -> f64 {
    let m = M1_DEFAULT + M2_DEFAULT;
    R10_DEFAULT + m * G_DEFAULT / C_DEFAULT + M2_DEFAULT * L2_DEFAULT / m
}

/// The lever arms `(r1′, r2′)`: from m1 to A and from A to m2, along the rod.
fn arms<S: Scalar>(p: &[S]) -> (S, S) {
    let m = p[M1] + p[M2];
    (p[M2] * p[L2] / m, p[M1] * p[L2] / m)
}

/// The particle positions `(x1, z1, x2, z2)` in terms of q = (R, θ, φ).
fn particle_positions<S: Scalar>(q: &[S], p: &[S]) -> [S; 4] {
    let (r, th, ph) = (q[0], q[1], q[2]);
    let (a1, a2) = arms(p);
    let (ax, az) = (r * th.sin(), r * th.cos());
    let (ex, ez) = (ph.sin(), ph.cos());
    [ax - a1 * ex, az - a1 * ez, ax + a2 * ex, az + a2 * ez]
}

/// The particle velocities `(ẋ1, ż1, ẋ2, ż2)`, from differentiating their positions.
fn particle_velocities<S: Scalar>(q: &[S], qd: &[S], p: &[S]) -> [S; 4] {
    let (r, th, ph) = (q[0], q[1], q[2]);
    let (rd, thd, phd) = (qd[0], qd[1], qd[2]);
    let (a1, a2) = arms(p);
    let (s, c) = (th.sin(), th.cos());
    let axd = rd * s + r * c * thd;
    let azd = rd * c - r * s * thd;
    // ė = φ̇ (cos φ, −sin φ)
    let (exd, ezd) = (ph.cos() * phd, -(ph.sin() * phd));
    [
        axd - a1 * exd,
        azd - a1 * ezd,
        axd + a2 * exd,
        azd + a2 * ezd,
    ]
}

/// The spring length `r1 = |x1|`.
fn spring_length<S: Scalar>(q: &[S], p: &[S]) -> S {
    let [x1, z1, _, _] = particle_positions(q, p);
    (x1 * x1 + z1 * z1).sqrt()
}

impl Lagrangian for SpringRodPendulum {
    /// Forces and outputs take t only into T, V and the constraints.
    const TIME_IN_FORCES_OR_OUTPUTS: bool = false;
    const NAME: &'static str = "SpringRodPendulum";
    crate::generated_eom!(crate::model::symbolic::generated::SpringRodPendulumEom);
    const DESCRIPTION: &'static str =
        "A mass on a spring from a fixed point with a second mass on a rigid rod below it, equations derived from the Lagrangian";
    const EQUATIONS: &'static [&'static str] = &[
        "q = (R, θ, φ): distance and angle of the centre of mass A from O, and the rod's angle, angles from the downward vertical (x horizontal, z down)",
        "M = m1 + m2, r1′ = m2 l2 / M (m1 to A), r2′ = m1 l2 / M (A to m2), e = (sin φ, cos φ)",
        "A = R (sin θ, cos θ), x1 = A − r1′ e, x2 = A + r2′ e, spring length r1 = |x1| = √(R² + r1′² − 2 r1′ R cos(φ−θ))",
        "T = ½ m1 |ẋ1|² + ½ m2 |ẋ2|² = ½ M (Ṙ² + R² θ̇²) + ½ (m1 r1′² + m2 r2′²) φ̇²",
        "V = −g (m1 z1 + m2 z2) + ½ c (r1 − r10)² = −M g R cos θ + ½ c (r1 − r10)², L = T − V",
        "Equations of motion formed by automatic differentiation of L: M(q) q̈ = ∂L/∂q − (∂²L/∂q̇∂q) q̇, M = ∂²T/∂q̇²",
        "R̈ − R θ̇² − g cos θ + c (r1 − r10)(R − r1′ cos(φ−θ)) / (M r1) = 0",
        "R θ̈ + 2 Ṙ θ̇ + g sin θ − c (r1 − r10) r1′ sin(φ−θ) / (M r1) = 0",
        "(m1 r1′² + m2 r2′²) φ̈ + c (r1 − r10) R r1′ sin(φ−θ) / r1 = 0",
        "E = T + V; static equilibrium θ = φ = 0, R = r10 + M g / c + r1′",
    ];

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m1", Some("kg"), M1_DEFAULT, "Mass on the spring").min(1e-12),
            Var::new("m2", Some("kg"), M2_DEFAULT, "Mass on the rod").min(1e-12),
            Var::new("c", Some("N/m"), C_DEFAULT, "Spring stiffness").min(0.0),
            Var::new("r10", Some("m"), R10_DEFAULT, "Free length of the spring").min(0.0),
            Var::new("l2", Some("m"), L2_DEFAULT, "Length of the rod m1–m2").min(1e-12),
            Var::new("g", Some("m/s2"), G_DEFAULT, "Gravitational acceleration"),
        ]
    }

    fn inputs() -> Vec<Var> {
        Vec::new()
    }

    fn coordinates() -> Vec<Var> {
        vec![
            Var::new(
                "R",
                Some("m"),
                r_eq(),
                "Distance of the centre of mass A from O",
            )
            .nominal(1.0),
            Var::new(
                "theta",
                Some("rad"),
                0.3,
                "Angle of OA from the downward vertical",
            )
            .nominal(1.0),
            Var::new(
                "phi",
                Some("rad"),
                0.3,
                "Angle of the rod m1–m2 from the downward vertical",
            )
            .nominal(1.0),
        ]
    }

    fn velocities() -> Vec<Var> {
        vec![
            Var::new("R_dot", Some("m/s"), 0.0, "Rate of change of R").nominal(1.0),
            Var::new("theta_dot", Some("rad/s"), 0.0, "Angular velocity of OA").nominal(1.0),
            Var::new("phi_dot", Some("rad/s"), 0.0, "Angular velocity of the rod").nominal(1.0),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![Var::new(
            "E",
            Some("J"),
            0.0,
            "Mechanical energy (kinetic + gravity + spring)",
        )]
    }

    fn kinetic<S: Scalar>(_t: S, q: &[S], qd: &[S], p: &[S]) -> S {
        let [x1d, z1d, x2d, z2d] = particle_velocities(q, qd, p);
        (p[M1] * (x1d * x1d + z1d * z1d) + p[M2] * (x2d * x2d + z2d * z2d)) * 0.5
    }

    fn potential<S: Scalar>(_t: S, q: &[S], p: &[S]) -> S {
        let [_, z1, _, z2] = particle_positions(q, p);
        let stretch = spring_length(q, p) - p[R10];
        p[C] * stretch * stretch * 0.5 - p[G] * (p[M1] * z1 + p[M2] * z2)
    }

    fn extra_outputs<S: Scalar>(t: f64, q: &[S], qd: &[S], _u: &[S], p: &[S], y: &mut [S]) {
        y[0] = lagrangian::energy::<Self, S>(t, q, qd, p);
    }

    fn scenes() -> Vec<Scene> {
        vec![
            Scene::new(
                "swing",
                "Swing from θ = φ = 0.3 rad, the spring at its static stretch, at rest",
                10.0,
            )
            .set("R", r_eq())
            .set("theta", 0.3)
            .set("phi", 0.3)
            .set("R_dot", 0.0)
            .set("theta_dot", 0.0)
            .set("phi_dot", 0.0),
            Scene::new(
                "wobble",
                "Rod released at φ = 0.6 rad with the centre of mass below O (θ = 0), at rest",
                10.0,
            )
            .set("R", r_eq())
            .set("theta", 0.0)
            .set("phi", 0.6)
            .set("R_dot", 0.0)
            .set("theta_dot", 0.0)
            .set("phi_dot", 0.0),
        ]
    }
}
