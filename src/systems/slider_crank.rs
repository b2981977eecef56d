//! The slider-crank (piston) mechanism of the notes' Figure 6.1, twice: in one reduced
//! coordinate ([`SliderCrank`]) and in surplus coordinates with two multipliers
//! ([`SliderCrankSurplus`]), both written as [`Lagrangian`]s.
//!
//! A crank OA (length l1, mass m1, uniform rod, I_O = m1 l1²/3) turns about O; a
//! connecting rod AB (length l2 > l1, mass m2, uniform, I_G = m2 l2²/12 about its
//! centre) joins it to a piston B (mass m3) sliding on the x axis through O. Gravity g
//! acts along −y. Inputs: the torque τ on the crank and the force F on the piston along x.
//! θ is the crank angle from the x axis, β the rod's angle below it:
//!
//! ```text
//! A = l1 (cos θ, sin θ),  B = A + l2 (cos β, −sin β) = (x, 0)
//! loop closure:  l1 sin θ − l2 sin β = 0,   l1 cos θ + l2 cos β − x = 0
//! ```
//!
//! One degree of freedom. Reduced: q = θ, with β = asin(l1 sin θ / l2) and
//! x = l1 cos θ + l2 cos β substituted. Surplus: q = (θ, β, x) with the two closure
//! equations as constraints Φ(q) = 0 and multipliers λ: what a scene needs when it asks
//! for the forces in the joints (the side thrust of the piston on its guide, the force
//! along the stroke at the wrist pin), which the reduced model never forms.
//!
//! Velocities in T come from differentiating the positions along q̇ with a dual number
//! (`ṗ = dp/dq · q̇`), so each model states its geometry once.

use crate::model::lagrangian::{self, Lagrangian};
use crate::model::{Scalar, Scene, Var};
use num_dual::Dual;

/// Parameter indices (both models).
const M1: usize = 0;
const L1: usize = 1;
const M2: usize = 2;
const L2: usize = 3;
const M3: usize = 4;
const G: usize = 5;

/// Default parameters: a 0.1 m crank, a rod 3 crank lengths long.
const M1_DEFAULT: f64 = 2.0;
const L1_DEFAULT: f64 = 0.1;
const M2_DEFAULT: f64 = 1.0;
const L2_DEFAULT: f64 = 0.3;
const M3_DEFAULT: f64 = 0.5;
const G_DEFAULT: f64 = 9.81;

/// Crank speed of the `run` scene and the default start, rad/s: enough to carry the
/// crank over the top against gravity (about 5 turns a second).
const OMEGA0: f64 = 30.0;

fn parameters() -> Vec<Var> {
    vec![
        Var::new(
            "m1",
            Some("kg"),
            M1_DEFAULT,
            "Mass of the crank (uniform rod)",
        )
        .min(0.0),
        Var::new("l1", Some("m"), L1_DEFAULT, "Crank length OA").min(1e-12),
        Var::new(
            "m2",
            Some("kg"),
            M2_DEFAULT,
            "Mass of the connecting rod (uniform)",
        )
        .min(0.0),
        Var::new(
            "l2",
            Some("m"),
            L2_DEFAULT,
            "Connecting rod length AB (> l1)",
        )
        .min(1e-12),
        Var::new("m3", Some("kg"), M3_DEFAULT, "Mass of the piston").min(0.0),
        Var::new(
            "g",
            Some("m/s2"),
            G_DEFAULT,
            "Gravitational acceleration (along −y)",
        ),
    ]
}

fn inputs() -> Vec<Var> {
    vec![
        Var::new("tau", Some("N.m"), 0.0, "Torque on the crank"),
        Var::new("F", Some("N"), 0.0, "Force on the piston along x"),
    ]
}

/// The rod angle β and the piston position x for the crank angle θ (the loop closure
/// solved): `sin β = l1 sin θ / l2`, `x = l1 cos θ + l2 cos β`.
pub fn closure<S: Scalar>(theta: S, p: &[S]) -> (S, S) {
    let s = p[L1] * theta.sin() / p[L2];
    let cos_beta = (S::from(1.0) - s * s).sqrt();
    (s.asin(), p[L1] * theta.cos() + p[L2] * cos_beta)
}

/// `(β̇, ẋ)` for the crank rate θ̇, from differentiating [`closure`] along θ̇.
pub fn closure_rates<S: Scalar>(theta: S, theta_dot: S, p: &[S]) -> (S, S) {
    // On the stack: the FMU's doStep evaluates this (the outputs) and allocates nothing.
    let pd: [Dual<S>; 6] = std::array::from_fn(|i| Dual::from_re(p[i]));
    let (beta, x) = closure(Dual::new(theta, theta_dot), &pd);
    (beta.eps, x.eps)
}

/// The crank torque that holds the mechanism at rest at θ against a piston force F
/// without gravity (virtual work, the textbook formula): `τ = F l1 sin(θ + β) / cos β`.
pub fn static_torque(theta: f64, force: f64, p: &[f64]) -> f64 {
    let (beta, _) = closure(theta, p);
    force * p[L1] * (theta + beta).sin() / beta.cos()
}

/// Kinetic and potential energy of the mechanism from (θ, β, x) and their rates.
fn energies<S: Scalar>(q: [S; 3], qd: [S; 3], p: &[S]) -> (S, S) {
    let [th, be, _] = q;
    let [thd, bed, xd] = qd;
    let half = S::from(0.5);
    // Rod centre G = A + (l2/2)(cos β, −sin β); its velocity by the chain rule.
    let gxd = -(p[L1] * th.sin() * thd) - half * p[L2] * be.sin() * bed;
    let gyd = p[L1] * th.cos() * thd - half * p[L2] * be.cos() * bed;
    let i_o = p[M1] * p[L1] * p[L1] / S::from(3.0);
    let i_g = p[M2] * p[L2] * p[L2] / S::from(12.0);
    let t = half * (i_o * thd * thd + p[M2] * (gxd * gxd + gyd * gyd) + i_g * bed * bed)
        + half * p[M3] * xd * xd;
    let gy = p[L1] * th.sin() - half * p[L2] * be.sin();
    let v = p[G] * (p[M1] * half * p[L1] * th.sin() + p[M2] * gy);
    (t, v)
}

/// Start values: crank at θ = 0 (outer dead centre) turning at 30 rad/s.
fn run_scene(name: &'static str, description: &'static str) -> Scene {
    Scene::new(name, description, 10.0).set("theta", 0.0)
}

// ---------------------------------------------------------------------------------------
// Reduced: q = θ
// ---------------------------------------------------------------------------------------

/// The slider-crank in its one reduced coordinate θ (minimal: no multiplier).
pub struct SliderCrank;

impl Lagrangian for SliderCrank {
    /// Forces and outputs take t only into T, V and the constraints.
    const TIME_IN_FORCES_OR_OUTPUTS: bool = false;
    const NAME: &'static str = "SliderCrank";
    crate::generated_eom!(crate::model::symbolic::generated::SliderCrankEom);
    const DESCRIPTION: &'static str =
        "Slider-crank (piston) mechanism in its one reduced coordinate, the crank angle";
    const EQUATIONS: &'static [&'static str] = &[
        "Crank OA (l1, m1, I_O = m1 l1²/3) about O, rod AB (l2, m2, I_G = m2 l2²/12), piston B (m3) on the x axis; gravity along −y",
        "q = θ (crank angle); loop closure solved: sin β = l1 sin θ / l2, x = l1 cos θ + l2 cos β",
        "T = ½ I_O θ̇² + ½ m2 |v_G|² + ½ I_G β̇² + ½ m3 ẋ², β̇ and ẋ by differentiating the closure",
        "V = g (m1 (l1/2) sin θ + m2 (l1 sin θ − (l2/2) sin β)), Q = τ + F ∂x/∂θ",
        "Equations of motion by automatic differentiation of L = T − V (one coordinate: no multiplier)",
        "At rest without gravity a piston force F is held by τ = F l1 sin(θ + β) / cos β",
    ];

    fn parameters() -> Vec<Var> {
        parameters()
    }

    fn inputs() -> Vec<Var> {
        inputs()
    }

    fn coordinates() -> Vec<Var> {
        vec![Var::new("theta", Some("rad"), 0.0, "Crank angle from the x axis").nominal(1.0)]
    }

    fn velocities() -> Vec<Var> {
        vec![Var::new("theta_dot", Some("rad/s"), OMEGA0, "Crank angular velocity").nominal(10.0)]
    }

    fn outputs() -> Vec<Var> {
        vec![
            Var::new("beta", Some("rad"), 0.0, "Rod angle below the x axis"),
            Var::new("x", Some("m"), 0.0, "Piston position"),
            Var::new("x_dot", Some("m/s"), 0.0, "Piston velocity"),
            Var::new("E", Some("J"), 0.0, "Mechanical energy T + V"),
        ]
    }

    fn kinetic<S: Scalar>(_t: S, q: &[S], qd: &[S], p: &[S]) -> S {
        let (beta, x) = closure(q[0], p);
        let (bed, xd) = closure_rates(q[0], qd[0], p);
        energies([q[0], beta, x], [qd[0], bed, xd], p).0
    }

    fn potential<S: Scalar>(_t: S, q: &[S], p: &[S]) -> S {
        let (beta, x) = closure(q[0], p);
        let zero = S::from(0.0);
        energies([q[0], beta, x], [zero; 3], p).1
    }

    fn forces<S: Scalar>(_t: f64, q: &[S], _qd: &[S], u: &[S], p: &[S], out: &mut [S]) {
        let (_, dx_dtheta) = closure_rates(q[0], S::from(1.0), p);
        out[0] = u[0] + u[1] * dx_dtheta;
    }

    fn extra_outputs<S: Scalar>(t: f64, q: &[S], qd: &[S], _u: &[S], p: &[S], y: &mut [S]) {
        let (beta, x) = closure(q[0], p);
        y[0] = beta;
        y[1] = x;
        y[2] = closure_rates(q[0], qd[0], p).1;
        y[3] = lagrangian::energy::<Self, S>(t, q, qd, p);
    }

    fn scenes() -> Vec<Scene> {
        vec![
            run_scene(
                "run",
                "Free run from the outer dead centre at 30 rad/s, no inputs (energy conserved)",
            )
            .set("theta_dot", OMEGA0),
            Scene::new(
                "driven",
                "From rest at θ = 0.3 rad, a constant crank torque of 0.5 N·m",
                3.0,
            )
            .set("theta", 0.3)
            .set("theta_dot", 0.0)
            .set("tau", 0.5),
        ]
    }
}

// ---------------------------------------------------------------------------------------
// Surplus: q = (θ, β, x), two constraints
// ---------------------------------------------------------------------------------------

/// The slider-crank in surplus coordinates (θ, β, x) with the loop closure as two
/// holonomic constraints and their multipliers: the λ-method, for the joint forces.
pub struct SliderCrankSurplus;

impl Lagrangian for SliderCrankSurplus {
    /// Forces and outputs take t only into T, V and the constraints.
    const TIME_IN_FORCES_OR_OUTPUTS: bool = false;
    const NAME: &'static str = "SliderCrankSurplus";
    crate::generated_eom!(crate::model::symbolic::generated::SliderCrankSurplusEom);
    const DESCRIPTION: &'static str =
        "Slider-crank (piston) mechanism in surplus coordinates with the loop closure kept by multipliers, which give the joint forces";
    const EQUATIONS: &'static [&'static str] = &[
        "Crank OA (l1, m1, I_O = m1 l1²/3) about O, rod AB (l2, m2, I_G = m2 l2²/12), piston B (m3) on the x axis; gravity along −y",
        "q = (θ, β, x): crank angle, rod angle below the x axis, piston position",
        "Φ1 = l1 sin θ − l2 sin β = 0 (B on the axis), Φ2 = l1 cos θ + l2 cos β − x = 0 (rod end at the piston)",
        "T = ½ I_O θ̇² + ½ m2 |v_G|² + ½ I_G β̇² + ½ m3 ẋ², V = g (m1 (l1/2) sin θ + m2 (l1 sin θ − (l2/2) sin β)), Q = (τ, 0, F)",
        "λ-method: [M Gᵀ; G 0] [q̈; λ] = [Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇; −q̇ᵀ∇²Φ q̇], G = ∂Φ/∂q, all by automatic differentiation",
        "Joint forces on the rod at the wrist pin B: N = −λ1 (along y), P = −λ2 (along x); guide force on the piston N_guide = N + m3 g",
        "After every step: coordinate projection onto Φ = 0 (Newton, M-metric) and of q̇ onto G q̇ = 0; residual_y, residual_x = Φ(q), residual_y_dot, residual_x_dot = G q̇",
        "At rest without gravity, with τ = F l1 sin(θ + β) / cos β: P = F and N = −F tan β (the rod is a two-force member)",
    ];
    const CONSTRAINTS: usize = 2;

    fn parameters() -> Vec<Var> {
        parameters()
    }

    fn inputs() -> Vec<Var> {
        inputs()
    }

    fn coordinates() -> Vec<Var> {
        vec![
            Var::new("theta", Some("rad"), 0.0, "Crank angle from the x axis").nominal(1.0),
            Var::new("beta", Some("rad"), 0.0, "Rod angle below the x axis")
                .nominal(1.0)
                .dependent(),
            Var::new("x", Some("m"), L1_DEFAULT + L2_DEFAULT, "Piston position")
                .nominal(0.1)
                .dependent(),
        ]
    }

    fn velocities() -> Vec<Var> {
        vec![
            Var::new("theta_dot", Some("rad/s"), OMEGA0, "Crank angular velocity").nominal(10.0),
            Var::new(
                "beta_dot",
                Some("rad/s"),
                OMEGA0 * L1_DEFAULT / L2_DEFAULT,
                "Rod angular velocity",
            )
            .nominal(10.0)
            .dependent(),
            Var::new("x_dot", Some("m/s"), 0.0, "Piston velocity")
                .nominal(1.0)
                .dependent(),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![
            Var::new(
                "N",
                Some("N"),
                0.0,
                "Force on the rod at the wrist pin, along y (−λ1)",
            ),
            Var::new(
                "P",
                Some("N"),
                0.0,
                "Force on the rod at the wrist pin, along x (−λ2)",
            ),
            Var::new(
                "N_guide",
                Some("N"),
                0.0,
                "Normal force of the guide on the piston (N + m3 g)",
            ),
            Var::new(
                "residual_y",
                Some("m"),
                0.0,
                "Constraint residual Φ1 (rod end above the axis)",
            ),
            Var::new(
                "residual_x",
                Some("m"),
                0.0,
                "Constraint residual Φ2 (rod end beyond the piston)",
            ),
            Var::new(
                "residual_y_dot",
                Some("m/s"),
                0.0,
                "Velocity constraint residual (G q̇)1",
            ),
            Var::new(
                "residual_x_dot",
                Some("m/s"),
                0.0,
                "Velocity constraint residual (G q̇)2",
            ),
            Var::new("E", Some("J"), 0.0, "Mechanical energy T + V"),
        ]
    }

    fn kinetic<S: Scalar>(_t: S, q: &[S], qd: &[S], p: &[S]) -> S {
        energies([q[0], q[1], q[2]], [qd[0], qd[1], qd[2]], p).0
    }

    fn potential<S: Scalar>(_t: S, q: &[S], p: &[S]) -> S {
        let zero = S::from(0.0);
        energies([q[0], q[1], q[2]], [zero; 3], p).1
    }

    fn forces<S: Scalar>(_t: f64, _q: &[S], _qd: &[S], u: &[S], _p: &[S], out: &mut [S]) {
        out[0] = u[0];
        out[1] = S::from(0.0);
        out[2] = u[1];
    }

    fn constraints<S: Scalar>(_t: S, q: &[S], p: &[S], phi: &mut [S]) {
        let (th, be, x) = (q[0], q[1], q[2]);
        phi[0] = p[L1] * th.sin() - p[L2] * be.sin();
        phi[1] = p[L1] * th.cos() + p[L2] * be.cos() - x;
    }

    fn extra_outputs<S: Scalar>(t: f64, q: &[S], qd: &[S], u: &[S], p: &[S], y: &mut [S]) {
        let (mut qdd, mut lambda) = ([S::from(0.0); 3], [S::from(0.0); 2]);
        lagrangian::accelerations_and_multipliers_into::<Self, S>(
            t,
            q,
            qd,
            u,
            p,
            &mut qdd,
            &mut lambda,
        );
        let (n, pf) = (-lambda[0], -lambda[1]);
        y[0] = n;
        y[1] = pf;
        y[2] = n + p[M3] * p[G];
        Self::constraints(S::from(t), q, p, &mut y[3..5]);
        // G q̇ = d/dε Φ(q + ε q̇), one dual evaluation on the stack.
        let q_along: [Dual<S>; 3] = std::array::from_fn(|i| Dual::new(q[i], qd[i]));
        let pd: [Dual<S>; 6] = std::array::from_fn(|i| Dual::from_re(p[i]));
        let mut rate = [Dual::from_re(S::from(0.0)); 2];
        Self::constraints(Dual::from_re(S::from(t)), &q_along, &pd, &mut rate);
        y[5] = rate[0].eps;
        y[6] = rate[1].eps;
        y[7] = lagrangian::energy::<Self, S>(t, q, qd, p);
    }

    fn scenes() -> Vec<Scene> {
        let p = [
            M1_DEFAULT, L1_DEFAULT, M2_DEFAULT, L2_DEFAULT, M3_DEFAULT, G_DEFAULT,
        ];
        let consistent = |scene: Scene, theta: f64, omega: f64| {
            let (beta, x) = closure(theta, &p);
            let (bed, xd) = closure_rates(theta, omega, &p);
            scene
                .set("theta", theta)
                .set("beta", beta)
                .set("x", x)
                .set("theta_dot", omega)
                .set("beta_dot", bed)
                .set("x_dot", xd)
        };
        vec![
            consistent(
                run_scene(
                    "run",
                    "Free run from the outer dead centre at 30 rad/s, no inputs (energy conserved)",
                ),
                0.0,
                OMEGA0,
            ),
            consistent(
                Scene::new(
                    "driven",
                    "From rest at θ = 0.3 rad, a constant crank torque of 2 N·m",
                    5.0,
                ),
                0.3,
                0.0,
            )
            .set("tau", 0.5),
        ]
    }
}
