//! Vertical disk rolling without slip on a plane (notes 6.3, systems.md section 10): a
//! nonholonomic system, in the coordinates `q = (x, y, θ, φ)` (contact point, heading,
//! spin) with two multipliers (the notes' λ-method).
//!
//! ```text
//! M q̈ = Q + G(θ)ᵀ λ,   M = diag(m, m, I_t, I_s),   Q = (0, 0, τ_θ, τ_φ),
//! G(θ) q̇ = 0,         G(θ) = [[1, 0, 0, −a cos θ], [0, 1, 0, −a sin θ]]
//! ```
//!
//! i.e. `m ẍ = λ1`, `m ÿ = λ2`, `I_t θ̈ = τ_θ`, `I_s φ̈ = −a (λ1 cos θ + λ2 sin θ) + τ_φ`.
//! The velocity constraints differentiated once give `G q̈ = γ` with
//! `γ = −Ġ q̇ = (−a θ̇ φ̇ sin θ, a θ̇ φ̇ cos θ)`; at every right-hand-side evaluation the
//! multipliers come from the Schur complement `(G M⁻¹ Gᵀ) λ = γ − G M⁻¹ Q` (a 2×2 system,
//! solved in closed form), then `q̈ = M⁻¹ (Q + Gᵀ λ)`. The constraints are not integrable,
//! so no position constraint exists: [`RollingDisk::project`] projects the velocities only.

use crate::model::{Scalar, Scene, System, Var};

pub struct RollingDisk;

/// Parameter indices.
const M: usize = 0;
const A: usize = 1;

/// State indices.
const TH: usize = 2;
const XD: usize = 4;
const YD: usize = 5;
const THD: usize = 6;
const PHD: usize = 7;

/// `(I_s, I_t)` = (½ m a², ¼ m a²).
fn inertias<S: Scalar>(m: S, a: S) -> (S, S) {
    (m * a * a * 0.5, m * a * a * 0.25)
}

/// The λ-method at the state `x` with torques `(τ_φ, τ_θ) = u`: returns `(λ1, λ2)` and
/// `q̈ = (ẍ, ÿ, θ̈, φ̈)`.
fn solve<S: Scalar>(x: &[S], u: &[S], p: &[S]) -> ([S; 2], [S; 4]) {
    let (m, a) = (p[M], p[A]);
    let (tau_phi, tau_theta) = (u[0], u[1]);
    let (i_s, i_t) = inertias(m, a);
    let (s, c) = (x[TH].sin(), x[TH].cos());
    let (minv, minv_t, minv_s) = (m.recip(), i_t.recip(), i_s.recip());
    // G rows: g1 = (1, 0, 0, −a c), g2 = (0, 1, 0, −a s).
    // Schur complement K = G M⁻¹ Gᵀ (symmetric 2×2).
    let k11 = minv + a * a * c * c * minv_s;
    let k22 = minv + a * a * s * s * minv_s;
    let k12 = a * a * c * s * minv_s;
    // Right-hand side γ − G M⁻¹ Q.
    let w = x[THD] * x[PHD] * a;
    let b1 = -(w * s) + a * c * tau_phi * minv_s;
    let b2 = w * c + a * s * tau_phi * minv_s;
    let det = k11 * k22 - k12 * k12;
    let l1 = (k22 * b1 - k12 * b2) / det;
    let l2 = (k11 * b2 - k12 * b1) / det;
    let qdd = [
        l1 * minv,
        l2 * minv,
        tau_theta * minv_t,
        (tau_phi - a * (l1 * c + l2 * s)) * minv_s,
    ];
    ([l1, l2], qdd)
}

impl System for RollingDisk {
    const NAME: &'static str = "RollingDisk";
    const DESCRIPTION: &'static str =
        "A vertical disk rolling without slip on a plane (nonholonomic), the constraints kept by Lagrange multipliers";
    /// States are (positions, velocities).
    fn second_order() -> bool {
        true
    }
    const EQUATIONS: &'static [&'static str] = &[
        "q = (x, y, θ, φ): contact point, heading, spin angle; constraints ẋ = a φ̇ cos θ, ẏ = a φ̇ sin θ (not integrable)",
        "I_s = ½ m a² (spin axis), I_t = ¼ m a² (vertical diameter)",
        "m ẍ = λ1, m ÿ = λ2, I_t θ̈ = τ_θ, I_s φ̈ = −a (λ1 cos θ + λ2 sin θ) + τ_φ",
        "λ-method: the constraints differentiated, ẍ = a φ̈ cos θ − a θ̇ φ̇ sin θ, ÿ = a φ̈ sin θ + a θ̇ φ̇ cos θ, are solved with the equations of motion at every evaluation (2×2 Schur complement G M⁻¹ Gᵀ λ = γ − G M⁻¹ Q)",
        "They reduce to (I_s + m a²) φ̈ = τ_φ",
        "No torques: θ̇ = ω, φ̇ = s constant; the contact point runs on a circle of radius a s / ω",
        "After every doStep (and at initialisation) (ẋ, ẏ, θ̇, φ̇) is projected onto the constraints, orthogonally in the mass metric diag(m, m, I_t, I_s); positions are not projected (no position constraint exists)",
        "residual_x = ẋ − a φ̇ cos θ, residual_y = ẏ − a φ̇ sin θ; E = ½ m (ẋ² + ẏ²) + ½ I_t θ̇² + ½ I_s φ̇²",
    ];

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m", Some("kg"), 2.0, "Mass of the disk").min(1e-12),
            Var::new("a", Some("m"), 0.3, "Radius of the disk").min(1e-12),
        ]
    }

    fn inputs() -> Vec<Var> {
        vec![
            Var::new(
                "tau_phi",
                Some("N.m"),
                0.0,
                "Drive torque about the spin axis",
            ),
            Var::new(
                "tau_theta",
                Some("N.m"),
                0.0,
                "Steering torque about the vertical",
            ),
        ]
    }

    fn states() -> Vec<Var> {
        vec![
            Var::new("x", Some("m"), 0.0, "Contact point, x").nominal(1.0),
            Var::new("y", Some("m"), 0.0, "Contact point, y").nominal(1.0),
            Var::new(
                "theta",
                Some("rad"),
                0.0,
                "Heading: angle of the rolling direction from the x axis",
            )
            .nominal(1.0),
            Var::new("phi", Some("rad"), 0.0, "Spin angle of the disk").nominal(1.0),
            Var::new(
                "x_dot",
                Some("m/s"),
                0.0,
                "Velocity of the contact point, x (computed: a φ̇ cos θ)",
            )
            .nominal(1.0)
            .dependent(),
            Var::new(
                "y_dot",
                Some("m/s"),
                0.0,
                "Velocity of the contact point, y (computed: a φ̇ sin θ)",
            )
            .nominal(1.0)
            .dependent(),
            Var::new("theta_dot", Some("rad/s"), 0.0, "Heading rate").nominal(1.0),
            Var::new("phi_dot", Some("rad/s"), 0.0, "Spin rate").nominal(1.0),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![
            Var::new(
                "lambda1",
                Some("N"),
                0.0,
                "Constraint force on the disk along x (= m ẍ)",
            ),
            Var::new(
                "lambda2",
                Some("N"),
                0.0,
                "Constraint force on the disk along y (= m ÿ)",
            ),
            Var::new(
                "residual_x",
                Some("m/s"),
                0.0,
                "Velocity constraint residual ẋ − a φ̇ cos θ (signed, so it stays differentiable)",
            ),
            Var::new(
                "residual_y",
                Some("m/s"),
                0.0,
                "Velocity constraint residual ẏ − a φ̇ sin θ",
            ),
            Var::new(
                "E",
                Some("J"),
                0.0,
                "Kinetic energy ½ m (ẋ² + ẏ²) + ½ I_t θ̇² + ½ I_s φ̇²",
            ),
        ]
    }

    /// Neither f nor g reads t.
    fn explicit_time(_p: &[f64]) -> (bool, bool) {
        (false, false)
    }

    #[inline(always)]
    fn derivatives<S: Scalar>(_t: f64, x: &[S], u: &[S], p: &[S], dx: &mut [S]) {
        let (_, qdd) = solve(x, u, p);
        dx[..4].copy_from_slice(&x[4..8]);
        dx[4..8].copy_from_slice(&qdd);
    }

    fn extra_outputs<S: Scalar>(_t: f64, x: &[S], u: &[S], p: &[S], y: &mut [S]) {
        let (m, a) = (p[M], p[A]);
        let (i_s, i_t) = inertias(m, a);
        let ([l1, l2], _) = solve(x, u, p);
        y[0] = l1;
        y[1] = l2;
        y[2] = x[XD] - a * x[PHD] * x[TH].cos();
        y[3] = x[YD] - a * x[PHD] * x[TH].sin();
        y[4] = m * (x[XD] * x[XD] + x[YD] * x[YD]) * 0.5
            + i_t * x[THD] * x[THD] * 0.5
            + i_s * x[PHD] * x[PHD] * 0.5;
    }

    fn scenes() -> Vec<Scene> {
        let a = Self::parameters()[A].start;
        vec![
            Scene::new(
                "circle",
                "No torques, θ̇ = 1 rad/s, φ̇ = 5 rad/s: the contact point runs on a circle of radius a φ̇ / θ̇ = 1.5 m",
                10.0,
            )
            .set("theta_dot", 1.0)
            .set("phi_dot", 5.0)
            .set("x_dot", a * 5.0)
            .set("y_dot", 0.0),
            Scene::new(
                "straight",
                "No torques, θ̇ = 0, φ̇ = 5 rad/s: a straight line along x at a φ̇ = 1.5 m/s",
                10.0,
            )
            .set("theta_dot", 0.0)
            .set("phi_dot", 5.0)
            .set("x_dot", a * 5.0)
            .set("y_dot", 0.0),
            Scene::new(
                "driven",
                "From rest, drive torque τ_φ = 0.1 N.m: (I_s + m a²) φ̈ = τ_φ, a straight line along x",
                10.0,
            )
            .set("tau_phi", 0.1),
        ]
    }

    /// Velocity projection only (the constraints are nonholonomic: there is no position
    /// constraint to project onto). `v = (ẋ, ẏ, θ̇, φ̇)` is replaced by its orthogonal
    /// projection onto `G(θ) v = 0` in the mass metric `M = diag(m, m, I_t, I_s)`:
    /// `v ← v − M⁻¹ Gᵀ (G M⁻¹ Gᵀ)⁻¹ G v`, the velocity of least kinetic-energy distance
    /// (Gauss's principle for an impulsive constraint). Exact in one step; θ̇ is untouched
    /// (G has no θ column); a state that satisfies the constraints is left unchanged up to
    /// rounding.
    /// Rolling without slip: `ẋ = a φ̇ cos θ`, `ẏ = a φ̇ sin θ`; a user sets θ̇ and φ̇
    /// (and the positions), the contact point's velocity follows.
    const STATE_CONSTRAINTS: usize = 2;

    fn state_constraints<S: Scalar>(_t: f64, x: &[S], p: &[S], residual: &mut [S]) -> bool {
        let a = p[A];
        residual[0] = x[XD] - a * x[PHD] * x[TH].cos();
        residual[1] = x[YD] - a * x[PHD] * x[TH].sin();
        true
    }

    fn project(_t: f64, p: &[f64], x: &mut [f64]) {
        let (m, a) = (p[M], p[A]);
        if !(m > 0.0 && a > 0.0 && m.is_finite() && a.is_finite()) {
            return;
        }
        let (i_s, _) = inertias(m, a);
        let (s, c) = x[TH].sin_cos();
        let (minv, minv_s) = (1.0 / m, 1.0 / i_s);
        let k11 = minv + a * a * c * c * minv_s;
        let k22 = minv + a * a * s * s * minv_s;
        let k12 = a * a * c * s * minv_s;
        let r1 = x[XD] - a * c * x[PHD];
        let r2 = x[YD] - a * s * x[PHD];
        let det = k11 * k22 - k12 * k12;
        let mu1 = (k22 * r1 - k12 * r2) / det;
        let mu2 = (k11 * r2 - k12 * r1) / det;
        x[XD] -= minv * mu1;
        x[YD] -= minv * mu2;
        x[PHD] += minv_s * a * (c * mu1 + s * mu2);
    }
}
