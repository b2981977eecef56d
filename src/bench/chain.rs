//! How the cost of a Lagrangian system grows with its size: a planar chain of N point
//! masses on rigid massless links, written as T and V like any system (`mbfmu speed
//! --chain`). Not an FMU: the bench's yardstick, beside the same chain in Pinocchio
//! (`benches/pinocchio_chain.py`).
//!
//! Absolute angles θᵢ from the downward vertical (x horizontal, z down), link length l,
//! mass m at the end of each link:
//!
//! ```text
//! x_k = Σ_{i≤k} l sin θᵢ,   z_k = Σ_{i≤k} l cos θᵢ
//! T = ½ m Σ_k (ẋ_k² + ż_k²),   V = −m g Σ_k z_k
//! ```

use super::speed::rhs_and_jacobian_ns;
use crate::model::lagrangian::Lagrangian;
use crate::model::{Scalar, Scene, Var};

/// The chain of `N` links; parameters `m l g` (1 kg, 1 m, 9.81 m/s²).
pub struct Chain<const N: usize>;

impl<const N: usize> Lagrangian for Chain<N> {
    const NAME: &'static str = "Chain";
    const DESCRIPTION: &'static str = "A planar chain of point masses on rigid massless links";
    const EQUATIONS: &'static [&'static str] = &[];

    fn parameters() -> Vec<Var> {
        vec![
            Var::new("m", Some("kg"), 1.0, "Mass at the end of each link"),
            Var::new("l", Some("m"), 1.0, "Length of each link"),
            Var::new("g", Some("m/s2"), 9.81, "Gravitational acceleration"),
        ]
    }

    fn inputs() -> Vec<Var> {
        Vec::new()
    }

    fn coordinates() -> Vec<Var> {
        (0..N)
            .map(|_| Var::new("theta", Some("rad"), 0.0, "Link angle"))
            .collect()
    }

    fn velocities() -> Vec<Var> {
        (0..N)
            .map(|_| Var::new("theta_dot", Some("rad/s"), 0.0, "Link rate"))
            .collect()
    }

    fn outputs() -> Vec<Var> {
        Vec::new()
    }

    fn kinetic<S: Scalar>(_t: S, q: &[S], qd: &[S], p: &[S]) -> S {
        let (m, l) = (p[0], p[1]);
        let (mut vx, mut vz, mut t) = (S::from(0.0), S::from(0.0), S::from(0.0));
        for (th, thd) in q.iter().zip(qd) {
            let (s, c) = th.sin_cos();
            vx += l * c * *thd;
            vz -= l * s * *thd;
            t += vx * vx + vz * vz;
        }
        m * t * 0.5
    }

    fn potential<S: Scalar>(_t: S, q: &[S], p: &[S]) -> S {
        let (m, l, g) = (p[0], p[1], p[2]);
        let (mut z, mut v) = (S::from(0.0), S::from(0.0));
        for th in q {
            z += l * th.cos();
            v -= m * g * z;
        }
        v
    }

    fn extra_outputs<S: Scalar>(_t: f64, _q: &[S], _qd: &[S], _u: &[S], _p: &[S], _y: &mut [S]) {}

    fn scenes() -> Vec<Scene> {
        Vec::new()
    }
}

/// Cost of one RHS and one Jacobian (ns) of the N-link chain at a generic state, measured
/// as `mbfmu speed` measures every system.
pub fn costs<const N: usize>(reps: usize) -> (f64, f64) {
    let x: Vec<f64> = (0..2 * N).map(|i| 0.3 + 0.1 * i as f64).collect();
    rhs_and_jacobian_ns::<Chain<N>>(&x, &[], &[1.0, 1.0, 9.81], reps)
}

/// `(N, ns per RHS, ns per Jacobian)` for N = 1, 2, 4, 8, 16.
pub fn sweep(reps: usize) -> Vec<(usize, f64, f64)> {
    let row = |n: usize, (rhs, jac): (f64, f64)| (n, rhs, jac);
    vec![
        row(1, costs::<1>(reps)),
        row(2, costs::<2>(reps)),
        row(4, costs::<4>(reps)),
        row(8, costs::<8>(reps)),
        row(16, costs::<16>(reps)),
    ]
}

/// The exponent k of cost ∝ N^k, least squares on log-log.
pub fn growth_exponent(points: &[(usize, f64)]) -> f64 {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .map(|&(n, c)| ((n as f64).ln(), c.ln()))
        .collect();
    let k = logs.len() as f64;
    let (mx, my) = logs
        .iter()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / k, b + y / k));
    let (sxy, sxx) = logs.iter().fold((0.0, 0.0), |(a, b), (x, y)| {
        (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
    });
    sxy / sxx
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::lagrangian;
    use crate::model::System;

    /// The N = 1 chain is the simple pendulum: θ̈ = −(g/l) sin θ; the N = 2 chain is the
    /// double pendulum of systems.md §5 with m1 = m2, r1 = l2.
    #[test]
    fn small_chains_are_the_pendulums() {
        let p = [1.0, 1.0, 9.81];
        let qdd = lagrangian::accelerations::<Chain<1>, f64>(0.0, &[0.7], &[0.3], &[], &p);
        assert!((qdd[0] + 9.81 * 0.7f64.sin()).abs() < 1e-14);
        let x = [0.4, -0.3, 0.5, 0.2];
        let mut chain = [0.0; 4];
        <Chain<2> as System>::derivatives(0.0, &x, &[], &p, &mut chain);
        let mut double = [0.0; 4];
        let dp = [1.0, 1.0, 1.0, 1.0, 9.81]; // m1 m2 r1 l2 g
        <crate::systems::DoublePendulum as System>::derivatives(
            0.0,
            &x,
            &[0.0, 0.0],
            &dp,
            &mut double,
        );
        for i in 0..4 {
            assert!(
                (chain[i] - double[i]).abs() < 1e-13,
                "{chain:?} vs {double:?}"
            );
        }
    }

    #[test]
    fn the_growth_exponent_of_a_power_law_is_its_power() {
        let pts: Vec<(usize, f64)> = [1, 2, 4, 8]
            .iter()
            .map(|&n| (n, 3.0 * (n as f64).powi(3)))
            .collect();
        assert!((growth_exponent(&pts) - 3.0).abs() < 1e-12);
    }
}
