//! Hoop rolling down an incline (notes 9.4.6, systems.md section 9), in surplus
//! coordinates `q = (x, θ)` with the rolling constraint kept by a Lagrange multiplier
//! (the notes' λ-method).
//!
//! Equations of motion with the multiplier λ (the friction force along the plane):
//!
//! ```text
//! M q̈ = Q + Gᵀ λ,   M = diag(m, m r²),   Q = (m g sin φ, 0),   G = (1, −r)
//! ```
//!
//! i.e. `m ẍ − m g sin φ − λ = 0`, `m r² θ̈ + λ r = 0`. The velocity constraint
//! `G q̇ = ẋ − r θ̇ = 0` differentiated once more gives `G q̈ = 0` (G is constant), and
//! the two together are solved at every right-hand-side evaluation through the Schur
//! complement: `λ = −(G M⁻¹ Gᵀ)⁻¹ G M⁻¹ Q`, then `q̈ = M⁻¹ (Q + Gᵀ λ)`.
//! The acceleration-level constraint alone keeps only `r θ̈ − ẍ` at zero; the position and
//! velocity residuals are held on the manifold by [`RollingHoop::project`].

use crate::model::{Scalar, Scene, System, Var};

pub struct RollingHoop;

/// Parameter indices.
const M: usize = 0;
const R: usize = 1;
const PHI: usize = 2;
const G: usize = 4;

/// The multiplier λ and the accelerations (ẍ, θ̈) of the λ-method, from `M q̈ = Q + Gᵀ λ`
/// and `G q̈ = 0`, by the Schur complement of the saddle-point system.
fn solve<S: Scalar>(p: &[S]) -> (S, S, S) {
    let (m, r, phi, g) = (p[M], p[R], p[PHI], p[G]);
    // M⁻¹ = diag(1/m, 1/(m r²)); Q = (m g sin φ, 0); G = (1, −r).
    let (minv_x, minv_th) = (m.recip(), (m * r * r).recip());
    let q_x = m * g * phi.sin();
    // G M⁻¹ Gᵀ = 1/m + r²/(m r²);  G M⁻¹ Q = Q_x / m.
    let schur = minv_x + r * r * minv_th;
    let lambda = -(q_x * minv_x) / schur;
    let x_ddot = (q_x + lambda) * minv_x;
    let theta_ddot = -(r * lambda) * minv_th;
    (lambda, x_ddot, theta_ddot)
}

/// With the default parameters, from rest at x = 0: `x = ¼ g sin φ t²` reaches `l` at
/// `t = √(2 l / (½ g sin φ))` = 2.8557 s.
fn roll_time() -> f64 {
    let p: Vec<f64> = RollingHoop::parameters().iter().map(|v| v.start).collect();
    (2.0 * p[3] / (0.5 * p[G] * p[PHI].sin())).sqrt()
}

impl System for RollingHoop {
    const NAME: &'static str = "RollingHoop";
    const DESCRIPTION: &'static str =
        "A hoop rolling without slip down an inclined plane, the rolling constraint kept by a Lagrange multiplier";
    /// States are (positions, velocities).
    fn second_order() -> bool {
        true
    }
    const EQUATIONS: &'static [&'static str] = &[
        "q = (x, θ): x down the slope, θ the hoop's rotation; constraint r θ̇ = ẋ (r θ = x from the start)",
        "m ẍ − m g sin φ − λ = 0",
        "m r² θ̈ + λ r = 0",
        "λ-method: the constraint differentiated to r θ̈ = ẍ and solved with the equations of motion at every evaluation: λ = −(G M⁻¹ Gᵀ)⁻¹ G M⁻¹ Q with M = diag(m, m r²), G = (1, −r), Q = (m g sin φ, 0)",
        "Closed form: ẍ = ½ g sin φ, λ = −½ m g sin φ (the friction force that keeps the hoop rolling)",
        "After every doStep (and at initialisation) (x, θ) is projected onto r θ = x and (ẋ, θ̇) onto r θ̇ = ẋ, orthogonally in the mass metric diag(m, m r²)",
        "residual = r θ − x; E = ½ m ẋ² + ½ m r² θ̇² − m g x sin φ (conserved: the friction force does no work)",
        "l is the length of the plane: the scene roll stops where the hoop reaches it; the model itself does not stop there",
    ];

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m", Some("kg"), 1.0, "Mass of the hoop").min(1e-12),
            Var::new("r", Some("m"), 0.5, "Radius of the hoop").min(1e-12),
            Var::new(
                "phi",
                Some("rad"),
                std::f64::consts::FRAC_PI_6,
                "Inclination of the plane",
            ),
            Var::new("l", Some("m"), 10.0, "Length of the plane").min(0.0),
            Var::new("g", Some("m/s2"), 9.81, "Gravitational acceleration"),
        ]
    }

    fn inputs() -> Vec<Var> {
        Vec::new()
    }

    fn states() -> Vec<Var> {
        vec![
            Var::new(
                "x",
                Some("m"),
                0.0,
                "Distance of the hoop's centre down the slope",
            )
            .nominal(1.0),
            Var::new(
                "theta",
                Some("rad"),
                0.0,
                "Rotation angle of the hoop (computed: x / r)",
            )
            .nominal(1.0)
            .dependent(),
            Var::new("x_dot", Some("m/s"), 0.0, "Speed down the slope").nominal(1.0),
            Var::new(
                "theta_dot",
                Some("rad/s"),
                0.0,
                "Angular velocity of the hoop (computed: ẋ / r)",
            )
            .nominal(1.0)
            .dependent(),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![
            Var::new(
                "lambda",
                Some("N"),
                0.0,
                "Constraint (friction) force on the hoop along the slope",
            ),
            Var::new(
                "residual",
                Some("m"),
                0.0,
                "Position constraint residual r θ − x",
            ),
            Var::new(
                "E",
                Some("J"),
                0.0,
                "Mechanical energy ½ m ẋ² + ½ m r² θ̇² − m g x sin φ",
            ),
        ]
    }

    /// Neither f nor g reads t.
    fn explicit_time(_p: &[f64]) -> (bool, bool) {
        (false, false)
    }

    #[inline(always)]
    fn derivatives<S: Scalar>(_t: f64, x: &[S], _u: &[S], p: &[S], dx: &mut [S]) {
        let (_, x_ddot, theta_ddot) = solve(p);
        dx[0] = x[2];
        dx[1] = x[3];
        dx[2] = x_ddot;
        dx[3] = theta_ddot;
    }

    fn extra_outputs<S: Scalar>(_t: f64, x: &[S], _u: &[S], p: &[S], y: &mut [S]) {
        let (m, r, phi, g) = (p[M], p[R], p[PHI], p[G]);
        let (lambda, _, _) = solve(p);
        y[0] = lambda;
        y[1] = r * x[1] - x[0];
        y[2] = m * x[2] * x[2] * 0.5 + m * r * r * x[3] * x[3] * 0.5 - m * g * x[0] * phi.sin();
    }

    fn scenes() -> Vec<Scene> {
        vec![Scene::new(
            "roll",
            "From rest at the top (x = 0) until the hoop reaches the end of the plane, x = l = 10 m",
            roll_time(),
        )
        .set("x", 0.0)
        .set("theta", 0.0)
        .set("x_dot", 0.0)
        .set("theta_dot", 0.0)]
    }

    /// Stop at the end of the plane (the `roll` scene), 2.856 s with the defaults.
    fn default_experiment() -> (f64, f64, f64) {
        (roll_time(), 1e-8, 1e-2)
    }

    /// Orthogonal projection in the mass (kinetic-energy) metric `M = diag(m, m r²)`:
    /// `(x, θ)` onto the line `r θ = x`, then `(ẋ, θ̇)` onto `r θ̇ = ẋ`. For a linear
    /// constraint `C q = c` the nearest point in that metric is
    /// `q ← q − M⁻¹ Cᵀ (C M⁻¹ Cᵀ)⁻¹ (C q − c)`; with `C = (−1, r)` this moves x by half the
    /// residual and r θ by minus half of it (the mass cancels). Exact in one step (the
    /// constraints are linear); a state on the manifold is left unchanged up to rounding.
    /// Rolling from the start: `r θ = x` and `r θ̇ = ẋ`; a user sets x and ẋ.
    const STATE_CONSTRAINTS: usize = 2;

    fn state_constraints<S: Scalar>(_t: f64, x: &[S], p: &[S], residual: &mut [S]) -> bool {
        let r = p[R];
        residual[0] = r * x[1] - x[0];
        residual[1] = r * x[3] - x[2];
        true
    }

    fn project(_t: f64, p: &[f64], x: &mut [f64]) {
        let (m, r) = (p[M], p[R]);
        if !(m > 0.0 && r > 0.0 && m.is_finite() && r.is_finite()) {
            return;
        }
        let (minv_x, minv_th) = (1.0 / m, 1.0 / (m * r * r));
        let schur = minv_x + r * r * minv_th; // C M⁻¹ Cᵀ with C = (−1, r)
        for (i_x, i_th) in [(0, 1), (2, 3)] {
            let residual = r * x[i_th] - x[i_x];
            let mu = residual / schur;
            x[i_x] += minv_x * mu;
            x[i_th] -= minv_th * r * mu;
        }
    }
}
