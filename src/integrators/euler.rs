//! The two Euler methods, fixed step: explicit Euler (order 1, the baseline every other method
//! is measured against) and symplectic Euler (order 1, but no energy drift on Hamiltonian
//! systems).
//!
//! Source: E. Hairer, C. Lubich, G. Wanner, *Geometric Numerical Integration*, 2nd ed.,
//! Springer 2006, Sect. I.1.2 (explicit and symplectic Euler) and Theorem VI.3.3
//! (symplecticity of the symplectic Euler method).

use super::buffers::sized;
use super::problem::{fixed_steps, Problem};
use super::{Failure, Stats};

/// Explicit Euler `x₁ = x₀ + h f(t₀, x₀)` from `*t` to `t_end` with step `h` (the last step
/// shortened; `h` not positive and finite: one step), one evaluation of f per step.
/// Same conventions as [`super::rk4::advance`]; needs only `problem.rhs`.
pub fn explicit_euler(
    problem: &mut Problem,
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    h: f64,
    stats: &mut Stats,
) -> Result<(), Failure> {
    explicit_euler_in(problem, t, x, t_end, h, stats, &mut Default::default())
}

/// [`explicit_euler`] in the scratch of `work`: no allocation once it has held this size.
pub fn explicit_euler_in(
    problem: &mut Problem,
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    h: f64,
    stats: &mut Stats,
    work: &mut [Vec<f64>; 2],
) -> Result<(), Failure> {
    let [y, k] = work;
    let k = sized(k, x.len());
    fixed_steps(
        "explicit Euler",
        t,
        x,
        t_end,
        h,
        stats,
        y,
        |stats, ta, tb, x, y| {
            let hs = tb - ta;
            if !problem.eval(ta, x, k, stats) {
                return Err(Failure::NonFinite { t: ta });
            }
            for i in 0..x.len() {
                y[i] = x[i] + hs * k[i];
            }
            Ok(())
        },
    )
}

/// Symplectic Euler, kick then drift: `v₁ = v₀ + h a(t₀, q₀, v₀)`, `q₁ = q₀ + h v₁`, with the
/// acceleration `a` read from the last `nq` components of f (the first `nq`, `dq/dt = v`, are
/// not used). One evaluation of f per step. Needs `problem.second_order = Some(nq)` with
/// `x.len() == 2·nq`. Symplectic when `a` depends on `q` only; with velocity-dependent forces
/// it is an explicit first-order method like any other.
pub fn symplectic_euler(
    problem: &mut Problem,
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    h: f64,
    stats: &mut Stats,
) -> Result<(), Failure> {
    symplectic_euler_in(problem, t, x, t_end, h, stats, &mut Default::default())
}

/// [`symplectic_euler`] in the scratch of `work`.
pub fn symplectic_euler_in(
    problem: &mut Problem,
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    h: f64,
    stats: &mut Stats,
    work: &mut [Vec<f64>; 2],
) -> Result<(), Failure> {
    let nq = problem.positions("symplectic Euler", x.len());
    let [y, k] = work;
    let k = sized(k, x.len());
    fixed_steps(
        "symplectic Euler",
        t,
        x,
        t_end,
        h,
        stats,
        y,
        |stats, ta, tb, x, y| {
            let hs = tb - ta;
            if !problem.eval(ta, x, k, stats) {
                return Err(Failure::NonFinite { t: ta });
            }
            for i in 0..nq {
                y[nq + i] = x[nq + i] + hs * k[nq + i];
                y[i] = x[i] + hs * y[nq + i];
            }
            Ok(())
        },
    )
}

#[cfg(test)]
mod tests {
    use super::super::problem::test_support::energy;
    use super::super::test_support::{oscillator, oscillator_error, OMEGA};
    use super::*;

    #[test]
    fn explicit_euler_grows_oscillator_energy_by_exactly_one_plus_h2_omega2() {
        // x₁ = x + h v, v₁ = v − hω² x: ω²x₁² + v₁² = (1 + h²ω²)(ω²x² + v²) exactly.
        let h = 0.01;
        let factor = 1.0 + h * h * OMEGA * OMEGA;
        let mut rhs = oscillator;
        let mut p = Problem::new(&mut rhs);
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        let mut stats = Stats::default();
        let mut worst: f64 = 0.0;
        for i in 0..1000 {
            let e0 = energy(&x);
            explicit_euler(&mut p, &mut t, &mut x, (i + 1) as f64 * h, h, &mut stats).unwrap();
            worst = worst.max((energy(&x) / e0 / factor - 1.0).abs());
        }
        // Measured: worst relative deviation of a step's ratio from 1.01: 2.2e-16 (rounding).
        assert!(worst < 1e-12, "worst {worst:e}");
        // After 1000 steps the energy is 1.01^1000 = 20959 times the start.
        let total = energy(&x) / factor.powi(1000);
        assert!((total - 1.0).abs() < 1e-12, "total {total}");
        assert_eq!((stats.steps, stats.rhs_evals), (1000, 1000));
    }

    fn oscillator_run(
        method: fn(&mut Problem, &mut f64, &mut [f64], f64, f64, &mut Stats) -> Result<(), Failure>,
        h: f64,
    ) -> f64 {
        let mut rhs = oscillator;
        let mut p = Problem::new(&mut rhs);
        p.second_order = Some(1);
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        let mut stats = Stats::default();
        method(&mut p, &mut t, &mut x, 1.0, h, &mut stats).unwrap();
        assert_eq!(t, 1.0);
        oscillator_error(1.0, &x)
    }

    #[test]
    fn explicit_euler_is_first_order() {
        let (e1, e2) = (
            oscillator_run(explicit_euler, 1e-4),
            oscillator_run(explicit_euler, 5e-5),
        );
        // Measured: 4.19e-3 / 2.09e-3 = 2.00 (order 1 ⇒ 2¹).
        let ratio = e1 / e2;
        assert!((ratio - 2.0).abs() < 0.02, "ratio {ratio} ({e1:e}, {e2:e})");
    }

    #[test]
    fn symplectic_euler_is_first_order() {
        let (e1, e2) = (
            oscillator_run(symplectic_euler, 1e-4),
            oscillator_run(symplectic_euler, 5e-5),
        );
        let ratio = e1 / e2;
        assert!((ratio - 2.0).abs() < 0.02, "ratio {ratio} ({e1:e}, {e2:e})");
    }

    #[test]
    fn non_finite_rhs_keeps_last_good_state() {
        let mut rhs = |t: f64, y: &[f64], d: &mut [f64]| {
            d[0] = if t >= 0.5 { f64::NAN } else { -y[0] };
        };
        let mut p = Problem::new(&mut rhs);
        let (mut t, mut x) = (0.0, [1.0]);
        let mut stats = Stats::default();
        let r = explicit_euler(&mut p, &mut t, &mut x, 1.0, 0.1, &mut stats);
        assert_eq!(r, Err(Failure::NonFinite { t }));
        assert!(
            (t - 0.5).abs() < 1e-12 && (x[0] - 0.9f64.powi(5)).abs() < 1e-15,
            "t = {t}, x = {}",
            x[0]
        );
    }
}
