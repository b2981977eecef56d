//! Störmer–Verlet in its velocity form (kick–drift–kick), fixed step: second order, explicit,
//! symplectic and time-reversible for `q̈ = a(t, q)`.
//!
//! Source: E. Hairer, C. Lubich, G. Wanner, *Geometric Numerical Integration*, 2nd ed.,
//! Springer 2006, Sect. I.1.4, eq. (1.17) (velocity Verlet), Sect. VI.3 (symplecticity); and
//! E. Hairer, C. Lubich, G. Wanner, *Geometric numerical integration illustrated by the
//! Störmer–Verlet method*, Acta Numerica 12 (2003) 399–450, Sect. 4 (stability: hω < 2).

use super::problem::Problem;
use super::{Failure, Stats};

/// One velocity-Verlet step from `(ta, x)` to `tb` into `y`, given `k = f(ta, x)`:
///
/// `v½ = v₀ + (h/2) a(t₀, q₀, v₀)`, `q₁ = q₀ + h v½`, `v₁ = v½ + (h/2) a(t₁, q₁, v½)`,
///
/// the acceleration `a` being the last `nq` components of f (`k` is overwritten by the
/// second). Two evaluations of f per step (no reuse of the last one as the next first: with
/// velocity-dependent forces the two differ). Second order and symplectic when `a` does not
/// depend on `v`; with velocity-dependent forces it stays consistent but is neither
/// symplectic nor, in general, of second order.
pub(super) fn kick_drift_kick(
    problem: &mut Problem,
    stats: &mut Stats,
    nq: usize,
    (ta, tb): (f64, f64),
    x: &[f64],
    k: &mut [f64],
    y: &mut [f64],
) -> Result<(), Failure> {
    let hs = tb - ta;
    for i in 0..nq {
        y[nq + i] = x[nq + i] + 0.5 * hs * k[nq + i];
        y[i] = x[i] + hs * y[nq + i];
    }
    if !problem.eval(tb, y, k, stats) {
        return Err(Failure::NonFinite { t: ta });
    }
    for i in 0..nq {
        y[nq + i] += 0.5 * hs * k[nq + i];
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{fixed, oscillator, oscillator_error, OMEGA};
    use super::super::{ImplicitFailure, Method};
    use super::*;

    fn run(h: f64, steps: usize) -> (Vec<[f64; 2]>, Stats) {
        let mut rhs = oscillator;
        let mut p = Problem::new(&mut rhs);
        p.second_order = Some(1);
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        let mut stats = Stats::default();
        let mut states = vec![x];
        for i in 0..steps {
            let t_end = (i + 1) as f64 * h;
            match fixed(
                Method::Verlet,
                &mut p,
                (&mut t, &mut x),
                (t_end, h),
                &mut stats,
            ) {
                Ok(()) => states.push(x),
                Err(ImplicitFailure::Integration(Failure::NonFinite { .. })) => break,
                Err(e) => panic!("{e}"),
            }
        }
        (states, stats)
    }

    /// The quadratic form velocity Verlet conserves exactly on the oscillator (scaled to 1 at
    /// the start): ω²x²(1 − (hω/2)²) + v², the "modified energy" of GNI Sect. I.5.
    fn modified_energy(h: f64, y: &[f64; 2]) -> f64 {
        let w2 = OMEGA * OMEGA;
        (w2 * y[0] * y[0] * (1.0 - 0.25 * h * h * w2) + y[1] * y[1]) / w2
    }

    #[test]
    fn verlet_is_stable_below_h_omega_2_and_diverges_above() {
        // hω = 1.99: bounded; the modified energy is conserved, so |x| ≤ 1/√(1 − 1.99²/4) = 10.0.
        let h = 1.99 / OMEGA;
        let (states, _) = run(h, 10_000);
        assert_eq!(states.len(), 10_001);
        let e0 = modified_energy(h, &states[0]);
        let (mut max_x, mut max_drift): (f64, f64) = (0.0, 0.0);
        for s in &states {
            max_x = max_x.max(s[0].abs());
            max_drift = max_drift.max((modified_energy(h, s) / e0 - 1.0).abs());
        }
        // Measured: max |x| = 10.0 (the bound 10.01), modified energy conserved to 8.4e-13.
        assert!(
            max_x <= 1.0 / (1.0 - 0.25 * 1.99f64.powi(2)).sqrt() + 1e-9,
            "{max_x}"
        );
        assert!(max_drift < 1e-10, "modified energy drift {max_drift:e}");

        // hω = 2.01: the eigenvalue 1 − y²/2 − √((1 − y²/2)² − 1) = −1.2213 (y = hω): the
        // amplitude grows by 1.2213 per step.
        let h = 2.01 / OMEGA;
        let (states, _) = run(h, 100);
        let growth = (states[100][0] / states[50][0]).abs().powf(1.0 / 50.0);
        let y2: f64 = 2.01f64.powi(2);
        let lambda = (1.0 - y2 / 2.0).abs() + ((1.0 - y2 / 2.0).powi(2) - 1.0).sqrt();
        assert!(
            (growth / lambda - 1.0).abs() < 1e-6,
            "growth {growth}, predicted {lambda}"
        );
        // ...and, left alone, overflows: 10⁴ steps end in NonFinite.
        let (states, _) = run(h, 10_000);
        assert!(states.len() < 10_001, "no blow-up");
    }

    #[test]
    fn verlet_is_second_order() {
        let err = |h: f64| {
            let mut rhs = oscillator;
            let mut p = Problem::new(&mut rhs);
            p.second_order = Some(1);
            let (mut t, mut x) = (0.0, [1.0, 0.0]);
            let mut stats = Stats::default();
            fixed(
                Method::Verlet,
                &mut p,
                (&mut t, &mut x),
                (1.0, h),
                &mut stats,
            )
            .unwrap();
            assert_eq!(stats.rhs_evals, 2 * stats.steps);
            oscillator_error(1.0, &x)
        };
        let (e1, e2) = (err(1e-3), err(5e-4));
        // Measured: see the assertion message.
        let ratio = e1 / e2;
        assert!((ratio - 4.0).abs() < 0.05, "ratio {ratio} ({e1:e}, {e2:e})");
    }
}
