//! The two Euler methods, fixed step: explicit Euler (order 1, the baseline every other method
//! is measured against) and symplectic Euler (order 1, but no energy drift on Hamiltonian
//! systems).
//!
//! Source: E. Hairer, C. Lubich, G. Wanner, *Geometric Numerical Integration*, 2nd ed.,
//! Springer 2006, Sect. I.1.2 (explicit and symplectic Euler) and Theorem VI.3.3
//! (symplecticity of the symplectic Euler method).

/// Explicit Euler's step of size `hs`, `x₁ = x₀ + hs f(t₀, x₀)`, into `y`, from `k = f(t₀, x₀)`:
/// one evaluation of f per step.
#[inline]
pub(super) fn explicit(hs: f64, x: &[f64], k: &[f64], y: &mut [f64]) {
    for i in 0..x.len() {
        y[i] = x[i] + hs * k[i];
    }
}

/// Symplectic Euler's step of size `hs`, kick then drift: `v₁ = v₀ + hs a(t₀, q₀, v₀)`,
/// `q₁ = q₀ + hs v₁`, into `y`, with the acceleration `a` read from the last `nq` components
/// of `k = f(t₀, x₀)` (the first `nq`, `dq/dt = v`, are not used). One evaluation of f per
/// step. Symplectic when `a` depends on `q` only; with velocity-dependent forces it is an
/// explicit first-order method like any other.
#[inline]
pub(super) fn symplectic(nq: usize, hs: f64, x: &[f64], k: &[f64], y: &mut [f64]) {
    for i in 0..nq {
        y[nq + i] = x[nq + i] + hs * k[nq + i];
        y[i] = x[i] + hs * y[nq + i];
    }
}

#[cfg(test)]
mod tests {
    use super::super::problem::test_support::energy;
    use super::super::problem::Problem;
    use super::super::test_support::{fixed, oscillator, oscillator_error, OMEGA};
    use super::super::{Failure, Method, Stats};

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
            let t_end = (i + 1) as f64 * h;
            fixed(
                Method::ExplicitEuler,
                &mut p,
                (&mut t, &mut x),
                (t_end, h),
                &mut stats,
            )
            .unwrap();
            worst = worst.max((energy(&x) / e0 / factor - 1.0).abs());
        }
        // Measured: worst relative deviation of a step's ratio from 1.01: 2.2e-16 (rounding).
        assert!(worst < 1e-12, "worst {worst:e}");
        // After 1000 steps the energy is 1.01^1000 = 20959 times the start.
        let total = energy(&x) / factor.powi(1000);
        assert!((total - 1.0).abs() < 1e-12, "total {total}");
        assert_eq!((stats.steps, stats.rhs_evals), (1000, 1000));
    }

    fn oscillator_run(method: Method, h: f64) -> f64 {
        let mut rhs = oscillator;
        let mut p = Problem::new(&mut rhs);
        p.second_order = Some(1);
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        let mut stats = Stats::default();
        fixed(method, &mut p, (&mut t, &mut x), (1.0, h), &mut stats).unwrap();
        assert_eq!(t, 1.0);
        oscillator_error(1.0, &x)
    }

    /// `method`'s error on the oscillator halves with the step.
    fn assert_first_order(method: Method) {
        let (e1, e2) = (oscillator_run(method, 1e-4), oscillator_run(method, 5e-5));
        // Measured (explicit Euler): 4.19e-3 / 2.09e-3 = 2.00 (order 1 ⇒ 2¹).
        let ratio = e1 / e2;
        assert!((ratio - 2.0).abs() < 0.02, "ratio {ratio} ({e1:e}, {e2:e})");
    }

    #[test]
    fn explicit_euler_is_first_order() {
        assert_first_order(Method::ExplicitEuler);
    }

    #[test]
    fn symplectic_euler_is_first_order() {
        assert_first_order(Method::SymplecticEuler);
    }

    #[test]
    fn non_finite_rhs_keeps_last_good_state() {
        let mut rhs = |t: f64, y: &[f64], d: &mut [f64]| {
            d[0] = if t >= 0.5 { f64::NAN } else { -y[0] };
        };
        let mut p = Problem::new(&mut rhs);
        let (mut t, mut x) = (0.0, [1.0]);
        let mut stats = Stats::default();
        let r = fixed(
            Method::ExplicitEuler,
            &mut p,
            (&mut t, &mut x),
            (1.0, 0.1),
            &mut stats,
        );
        assert_eq!(r, Err(Failure::NonFinite { t }.into()));
        assert!(
            (t - 0.5).abs() < 1e-12 && (x[0] - 0.9f64.powi(5)).abs() < 1e-15,
            "t = {t}, x = {}",
            x[0]
        );
    }
}
