//! Velocity constraints in a `Lagrangian`: the vertical rolling disk (systems.md §10)
//! written as T and the non-integrable constraints `ẋ = a φ̇ cos θ`, `ẏ = a φ̇ sin θ`,
//! its equations of motion and multipliers formed by automatic differentiation, against
//! the hand-derived λ-method of `RollingDisk` (the FMU's model): two derivations that
//! must agree at random states to near machine precision, and so must their velocity
//! projections.

use mbfmu::model::lagrangian::{self, Lagrangian};
use mbfmu::model::{Scalar, Scene, System, Var};
use mbfmu::systems::RollingDisk;

mod support;
use support::Rng;

/// The rolling disk from its energies: q = (x, y, θ, φ), inputs (τ_φ, τ_θ) as RollingDisk.
struct DiskLagrangian;

impl Lagrangian for DiskLagrangian {
    const NAME: &'static str = "DiskLagrangian";
    const DESCRIPTION: &'static str = "Rolling disk from T and its velocity constraints";
    const EQUATIONS: &'static [&'static str] = &[];
    const VELOCITY_CONSTRAINTS: usize = 2;

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m", Some("kg"), 2.0, "mass"),
            Var::new("a", Some("m"), 0.3, "radius"),
        ]
    }
    fn inputs() -> Vec<Var> {
        vec![
            Var::new("tau_phi", Some("N.m"), 0.0, "drive torque"),
            Var::new("tau_theta", Some("N.m"), 0.0, "steering torque"),
        ]
    }
    fn coordinates() -> Vec<Var> {
        ["x", "y", "theta", "phi"]
            .map(|n| Var::new(n, None, 0.0, "coordinate"))
            .to_vec()
    }
    fn velocities() -> Vec<Var> {
        ["x_dot", "y_dot", "theta_dot", "phi_dot"]
            .map(|n| Var::new(n, None, 0.0, "velocity"))
            .to_vec()
    }
    fn outputs() -> Vec<Var> {
        Vec::new()
    }
    /// T = ½ m (ẋ² + ẏ²) + ½ I_t θ̇² + ½ I_s φ̇², I_s = ½ m a², I_t = ¼ m a².
    fn kinetic<S: Scalar>(_t: S, _q: &[S], qd: &[S], p: &[S]) -> S {
        let (m, a) = (p[0], p[1]);
        let (i_s, i_t) = (m * a * a * 0.5, m * a * a * 0.25);
        (m * (qd[0] * qd[0] + qd[1] * qd[1]) + i_t * qd[2] * qd[2] + i_s * qd[3] * qd[3]) * 0.5
    }
    fn potential<S: Scalar>(_t: S, _q: &[S], _p: &[S]) -> S {
        S::from(0.0)
    }
    fn forces<S: Scalar>(_t: f64, _q: &[S], _qd: &[S], u: &[S], _p: &[S], out: &mut [S]) {
        out[0] = S::from(0.0);
        out[1] = S::from(0.0);
        out[2] = u[1];
        out[3] = u[0];
    }
    fn velocity_constraints<S: Scalar>(_t: S, q: &[S], qd: &[S], p: &[S], out: &mut [S]) {
        let a = p[1];
        out[0] = qd[0] - a * qd[3] * q[2].cos();
        out[1] = qd[1] - a * qd[3] * q[2].sin();
    }
    fn extra_outputs<S: Scalar>(_t: f64, _q: &[S], _qd: &[S], _u: &[S], _p: &[S], _y: &mut [S]) {}
    fn scenes() -> Vec<Scene> {
        Vec::new()
    }
}

#[test]
fn lagrangian_with_velocity_constraints_matches_the_hand_derived_disk() {
    let mut rng = Rng(0xd15c);
    let (mut worst_acc, mut worst_lambda, mut worst_projection) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..200 {
        let p = [rng.uniform(0.2, 5.0), rng.uniform(0.05, 1.0)];
        let u = [rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0)];
        let (th, thd, phd) = (
            rng.uniform(-4.0, 4.0),
            rng.uniform(-5.0, 5.0),
            rng.uniform(-20.0, 20.0),
        );
        // A state on the constraints, and the same with the velocities pushed off them.
        let x = [
            rng.uniform(-3.0, 3.0),
            rng.uniform(-3.0, 3.0),
            th,
            rng.uniform(-9.0, 9.0),
            p[1] * phd * th.cos(),
            p[1] * phd * th.sin(),
            thd,
            phd,
        ];
        let (mut hand, mut auto) = ([0.0; 8], [0.0; 8]);
        RollingDisk::derivatives(0.0, &x, &u, &p, &mut hand);
        DiskLagrangian::derivatives(0.0, &x, &u, &p, &mut auto);
        let scale = hand.iter().fold(1.0f64, |s, v| s.max(v.abs()));
        for (h, a) in hand.iter().zip(&auto) {
            worst_acc = worst_acc.max((h - a).abs() / scale);
        }
        // RollingDisk's λ: m ẍ = λ1 (the force); the Lagrangian's: M q̈ + Aᵀλ = Q.
        let mut y = vec![0.0; <RollingDisk as System>::outputs().len()];
        RollingDisk::extra_outputs(0.0, &x, &u, &p, &mut y);
        let (_, lambda) = lagrangian::accelerations_and_multipliers::<DiskLagrangian, f64>(
            0.0,
            &x[..4],
            &x[4..],
            &u,
            &p,
        );
        let force_scale = y[0].abs().max(y[1].abs()).max(1.0);
        worst_lambda = worst_lambda
            .max((y[0] + lambda[0]).abs() / force_scale)
            .max((y[1] + lambda[1]).abs() / force_scale);
        // Velocity projection: both are the M-orthogonal projection onto A q̇ = 0.
        let mut off = x;
        off[4] += rng.uniform(-0.1, 0.1);
        off[5] += rng.uniform(-0.1, 0.1);
        off[7] += rng.uniform(-0.1, 0.1);
        let (mut ph, mut pa) = (off, off);
        RollingDisk::project(0.0, &p, &mut ph);
        DiskLagrangian::project(0.0, &p, &mut pa);
        for (h, a) in ph.iter().zip(&pa) {
            worst_projection = worst_projection.max((h - a).abs() / h.abs().max(1.0));
        }
    }
    println!("METRIC disk: Lagrangian + velocity constraints vs hand λ-method, accelerations {worst_acc:.2e}, λ {worst_lambda:.2e}, projection {worst_projection:.2e}");
    assert!(worst_acc < 1e-13, "accelerations differ by {worst_acc:e}");
    assert!(
        worst_lambda < 1e-13,
        "multipliers differ by {worst_lambda:e}"
    );
    assert!(
        worst_projection < 1e-14,
        "projections differ by {worst_projection:e}"
    );
}
