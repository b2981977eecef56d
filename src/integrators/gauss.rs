//! Gauss–Legendre collocation, fixed step: implicit midpoint (1 stage, order 2), Gauss4
//! (2 stages, order 4) and Gauss6 (3 stages, order 6). A-stable, symplectic, symmetric, and
//! they conserve every quadratic invariant of the problem (angular momentum of a free rigid
//! body, energy of a linear oscillator) up to the Newton tolerance and rounding.
//!
//! Sources: coefficients from E. Hairer, S. P. Nørsett, G. Wanner, *Solving Ordinary
//! Differential Equations I*, 2nd ed., Springer 1993, Sect. II.7 (Gauss methods, Tables 7.3
//! and 7.4; Kuntzmann 1961, Butcher 1964); conservation of quadratic invariants: E. Hairer,
//! C. Lubich, G. Wanner, *Geometric Numerical Integration*, 2nd ed., Springer 2006, Theorem
//! IV.2.1; simplified Newton iteration on the stage increments: ODE II (Hairer–Wanner), Sect.
//! IV.8, eqs. (8.2)–(8.4), and GNI Sect. VIII.6.2.
//!
//! Each step solves for the stage increments `Zᵢ = Yᵢ − x₀`:
//! `Zᵢ = h Σⱼ aᵢⱼ f(t₀ + cⱼh, x₀ + Zⱼ)`, by simplified Newton with the matrix `I − h A⊗J`,
//! `J = ∂f/∂x(t₀, x₀)` exact (from `problem.jacobian`, evaluated once per step). The LU
//! factorization is reused while `J` and `h` stay bit for bit the same (every step of a linear
//! system). The new state is `x₁ = x₀ + Σᵢ dᵢ Zᵢ` with `dᵀ = bᵀA⁻¹` (GNI eq. VIII.6.5), which
//! equals `x₀ + h Σ bᵢ f(Yᵢ)` at convergence without the s extra evaluations.

use super::buffers::{copied, sized};
use super::problem::{fixed_steps, FixedCall, ImplicitFailure, Problem};
use super::problem::{NewtonWatch, Verdict, NEWTON_MAX_ITER, NEWTON_TOL};
use super::{Failure, Method};

/// √3 and √15 to the last bit (`f64::sqrt` is not `const`).
const SQRT3: f64 = 1.732_050_807_568_877_2;
const SQRT15: f64 = 3.872_983_346_207_417;

/// A collocation tableau: `a` row-major s×s.
struct Tableau {
    name: &'static str,
    a: &'static [f64],
    b: &'static [f64],
    c: &'static [f64],
}

/// Implicit midpoint rule = Gauss with one stage (ODE I, Sect. II.7, eq. (7.4)).
const MIDPOINT: Tableau = Tableau {
    name: "implicit midpoint",
    a: &[0.5],
    b: &[1.0],
    c: &[0.5],
};

/// Gauss, 2 stages, order 4 (ODE I, Table II.7.3).
const GAUSS4: Tableau = Tableau {
    name: "Gauss4",
    a: &[0.25, 0.25 - SQRT3 / 6.0, 0.25 + SQRT3 / 6.0, 0.25],
    b: &[0.5, 0.5],
    c: &[0.5 - SQRT3 / 6.0, 0.5 + SQRT3 / 6.0],
};

/// Gauss, 3 stages, order 6 (ODE I, Table II.7.4).
const GAUSS6: Tableau = Tableau {
    name: "Gauss6",
    a: &[
        5.0 / 36.0,
        2.0 / 9.0 - SQRT15 / 15.0,
        5.0 / 36.0 - SQRT15 / 30.0,
        5.0 / 36.0 + SQRT15 / 24.0,
        2.0 / 9.0,
        5.0 / 36.0 - SQRT15 / 24.0,
        5.0 / 36.0 + SQRT15 / 30.0,
        2.0 / 9.0 + SQRT15 / 15.0,
        5.0 / 36.0,
    ],
    b: &[5.0 / 18.0, 4.0 / 9.0, 5.0 / 18.0],
    c: &[0.5 - SQRT15 / 10.0, 0.5, 0.5 + SQRT15 / 10.0],
};

/// An increment that stops shrinking while below this size (relative to the states, or
/// absolute for states smaller than 1) is rounding noise: the residual cannot be computed
/// more accurately, so the iterate is accepted. Above it, an increment that does not
/// shrink means divergence.
pub const NEWTON_STALL: f64 = 1e-12;

/// LU factorization with partial pivoting of a row-major m×m matrix (Doolittle, rows swapped
/// as in LAPACK's getrf). Hand-written rather than nalgebra's because these systems are tiny
/// (s·n) and solved millions of times: no allocation per solve, and none per factorization
/// once its buffers have held this size.
#[derive(Default)]
struct Lu {
    m: usize,
    a: Vec<f64>,
    pivots: Vec<usize>,
}

impl Lu {
    /// `None` if a pivot is exactly zero (singular matrix).
    #[cfg(test)]
    fn factor(m: usize, a: Vec<f64>) -> Option<Lu> {
        let mut lu = Lu {
            m,
            a,
            pivots: Vec::new(),
        };
        lu.factor_in_place(m).then_some(lu)
    }

    /// Factorizes the row-major m×m matrix in `self.a` in place; `false` if a pivot is
    /// exactly zero (singular matrix).
    fn factor_in_place(&mut self, m: usize) -> bool {
        self.m = m;
        self.pivots.clear();
        self.pivots.resize(m, 0);
        let (a, pivots) = (&mut self.a, &mut self.pivots);
        for k in 0..m {
            let p = (k..m)
                .max_by(|&i, &j| a[i * m + k].abs().total_cmp(&a[j * m + k].abs()))
                .expect("k < m");
            if a[p * m + k] == 0.0 {
                return false;
            }
            if p != k {
                for j in 0..m {
                    a.swap(k * m + j, p * m + j);
                }
            }
            pivots[k] = p;
            for i in k + 1..m {
                let l = a[i * m + k] / a[k * m + k];
                a[i * m + k] = l;
                for j in k + 1..m {
                    a[i * m + j] -= l * a[k * m + j];
                }
            }
        }
        true
    }

    /// Solve in place: `b ← A⁻¹ b`.
    fn solve(&self, b: &mut [f64]) {
        let (m, a) = (self.m, &self.a);
        for (k, &p) in self.pivots.iter().enumerate() {
            b.swap(k, p);
        }
        for i in 0..m {
            for j in 0..i {
                b[i] -= a[i * m + j] * b[j];
            }
        }
        for i in (0..m).rev() {
            for j in i + 1..m {
                b[i] -= a[i * m + j] * b[j];
            }
            b[i] /= a[i * m + i];
        }
    }
}

/// The factorized Newton matrix `I − h A⊗J` and the `(tableau, J, h)` it was built from
/// (`None`: nothing built yet). Factorizing the same matrix again would give the same bits,
/// so it is kept across calls: a cache, not information.
#[derive(Default)]
struct NewtonMatrix {
    key: Option<&'static str>,
    jac: Vec<f64>,
    h: f64,
    lu: Lu,
    /// The factorization succeeded (the matrix is not singular).
    regular: bool,
}

/// Gauss's part of a [`Workspace`](super::Workspace).
#[derive(Default)]
pub struct Scratch {
    /// The new state.
    y: Vec<f64>,
    /// The weights `d` and the LU that solves for them.
    d: Vec<f64>,
    d_lu: Lu,
    jac: Vec<f64>,
    newton: NewtonMatrix,
    z: Vec<f64>,
    fz: Vec<f64>,
    ys: Vec<f64>,
    r: Vec<f64>,
}

/// The implicit midpoint rule `x₁ = x₀ + h f(t₀ + h/2, (x₀ + x₁)/2)` (one f evaluation per
/// Newton iteration), Gauss4 (2 stages, order 4: two) or Gauss6 (3 stages, order 6: three),
/// by `method`, for one [`FixedCall`], in the scratch of `w`: no allocation once it has held
/// this size. Needs `problem.jacobian`.
pub fn collocation_in(
    method: Method,
    problem: &mut Problem,
    call: FixedCall,
    w: &mut Scratch,
) -> Result<(), ImplicitFailure> {
    let tab = match method {
        Method::ImplicitMidpoint => &MIDPOINT,
        Method::Gauss4 => &GAUSS4,
        Method::Gauss6 => &GAUSS6,
        other => panic!("{} is not a Gauss collocation method", other.name()),
    };
    let n = call.x.len();
    let s = tab.b.len();
    // dᵀ = bᵀ A⁻¹: solve Aᵀ d = b (s ≤ 3; A is invertible for Gauss methods).
    w.d_lu.a.clear();
    w.d_lu
        .a
        .extend((0..s * s).map(|k| tab.a[(k % s) * s + k / s]));
    assert!(w.d_lu.factor_in_place(s), "Gauss tableau is invertible");
    let d = copied(&mut w.d, tab.b);
    w.d_lu.solve(d);
    // (The Jacobian and f write every entry; `z` is cleared at every step.)
    let jac = sized(&mut w.jac, n * n);
    let newton = &mut w.newton;
    let z = sized(&mut w.z, s * n);
    let fz = sized(&mut w.fz, s * n);
    let ys = sized(&mut w.ys, n);
    let r = sized(&mut w.r, s * n);
    fixed_steps(tab.name, call, &mut w.y, |stats, ta, tb, x, y| {
        let hs = tb - ta;
        problem.eval_jacobian(tab.name, (ta, x), jac, stats);
        if newton.key != Some(tab.name) || newton.h.to_bits() != hs.to_bits() || newton.jac != *jac
        {
            let sn = s * n;
            let m = sized(&mut newton.lu.a, sn * sn);
            for i in 0..s {
                for j in 0..s {
                    let haij = hs * tab.a[i * s + j];
                    for p in 0..n {
                        for q in 0..n {
                            let identity = if i == j && p == q { 1.0 } else { 0.0 };
                            m[(i * n + p) * sn + j * n + q] = identity - haij * jac[p * n + q];
                        }
                    }
                }
            }
            newton.regular = newton.lu.factor_in_place(sn);
            copied(&mut newton.jac, jac);
            newton.h = hs;
            newton.key = Some(tab.name);
        }
        if !newton.regular {
            return Err(ImplicitFailure::NewtonFailed {
                t: ta,
                h: hs,
                iterations: 0,
            });
        }
        let lu = &newton.lu;
        let x_norm = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        z.fill(0.0);
        let mut watch = NewtonWatch::new();
        let mut converged = false;
        for iteration in 1..=NEWTON_MAX_ITER {
            for j in 0..s {
                for p in 0..n {
                    ys[p] = x[p] + z[j * n + p];
                }
                if !problem.eval(ta + tab.c[j] * hs, ys, &mut fz[j * n..(j + 1) * n], stats) {
                    return Err(Failure::NonFinite { t: ta }.into());
                }
            }
            for i in 0..s {
                for p in 0..n {
                    let mut sum = 0.0;
                    for j in 0..s {
                        sum += tab.a[i * s + j] * fz[j * n + p];
                    }
                    r[i * n + p] = hs * sum - z[i * n + p];
                }
            }
            lu.solve(r);
            let mut step: f64 = 0.0;
            let mut z_norm: f64 = 0.0;
            for (zi, dzi) in z.iter_mut().zip(r.iter()) {
                *zi += dzi;
                step = step.max(dzi.abs());
                z_norm = z_norm.max(zi.abs());
            }
            if !step.is_finite() {
                return Err(Failure::NonFinite { t: ta }.into());
            }
            let scale = x_norm.max(z_norm);
            // Stalling is judged against at least 1 (the states' nominal: SI units): a state
            // held at rest near 0 (a robot at its equilibrium drifts by 1e-21 rad) has
            // increments at the rounding of f, ~1e-22, which its own size never accepts.
            let stall = NEWTON_STALL * scale.max(1.0);
            match watch.judge(step, (NEWTON_TOL * scale, stall)) {
                Verdict::Converged => {
                    converged = true;
                    break;
                }
                Verdict::Diverged => {
                    return Err(ImplicitFailure::NewtonFailed {
                        t: ta,
                        h: hs,
                        iterations: iteration,
                    })
                }
                Verdict::Iterate => {}
            }
        }
        if !converged {
            return Err(ImplicitFailure::NewtonFailed {
                t: ta,
                h: hs,
                iterations: NEWTON_MAX_ITER,
            });
        }
        for p in 0..n {
            let mut sum = 0.0;
            for i in 0..s {
                sum += d[i] * z[i * n + p];
            }
            y[p] = x[p] + sum;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::super::problem::test_support::oscillator_jacobian;
    use super::super::test_support::{fixed, oscillator, oscillator_error};
    use super::super::Stats;
    use super::*;

    #[test]
    fn lu_solves_with_pivoting() {
        // Needs a row swap: the (0, 0) entry is 0.
        let a = vec![0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
        let x = [1.0, -2.0, 0.5];
        let mut b: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| a[i * 3 + j] * x[j]).sum())
            .collect();
        Lu::factor(3, a).unwrap().solve(&mut b);
        for i in 0..3 {
            assert!((b[i] - x[i]).abs() < 1e-15, "{b:?}");
        }
        assert!(Lu::factor(2, vec![1.0, 2.0, 2.0, 4.0]).is_none());
    }

    #[test]
    fn tableaux_are_consistent() {
        for tab in [&MIDPOINT, &GAUSS4, &GAUSS6] {
            let s = tab.b.len();
            for i in 0..s {
                let row: f64 = tab.a[i * s..(i + 1) * s].iter().sum();
                assert!((row - tab.c[i]).abs() < 1e-15, "{} row {i}", tab.name);
            }
            assert!((tab.b.iter().sum::<f64>() - 1.0).abs() < 1e-15);
            // Order 2s needs Σ bᵢ cᵢ^(k−1) = 1/k for k ≤ 2s.
            for k in 1..=2 * s {
                let q: f64 = (0..s).map(|i| tab.b[i] * tab.c[i].powi(k as i32 - 1)).sum();
                assert!((q - 1.0 / k as f64).abs() < 1e-15, "{} k = {k}", tab.name);
            }
        }
    }

    fn oscillator_run(method: Method, h: f64, t_end: f64) -> (f64, Stats) {
        let mut rhs = oscillator;
        let mut jac = oscillator_jacobian;
        let mut p = Problem::new(&mut rhs);
        p.jacobian = Some(&mut jac);
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        let mut stats = Stats::default();
        fixed(method, &mut p, (&mut t, &mut x), (t_end, h), &mut stats).unwrap();
        assert_eq!(t, t_end);
        (oscillator_error(t_end, &x), stats)
    }

    #[test]
    fn convergence_orders_2_4_6() {
        // (method, h, predicted ratio 2^order, tolerance on the ratio)
        let cases = [
            (Method::ImplicitMidpoint, 1e-3, 4.0, 0.01),
            (Method::Gauss4, 1e-2, 16.0, 0.1),
            (Method::Gauss6, 2e-2, 64.0, 1.0),
        ];
        for (method, h, predicted, tol) in cases {
            let (e1, _) = oscillator_run(method, h, 1.0);
            let (e2, s2) = oscillator_run(method, h / 2.0, 1.0);
            let ratio = e1 / e2;
            eprintln!("h = {h}: errors {e1:e}, {e2:e}, ratio {ratio}, {s2:?}");
            assert!(
                (ratio - predicted).abs() < tol,
                "ratio {ratio} ({e1:e}, {e2:e})"
            );
        }
    }

    #[test]
    fn newton_failure_and_singular_matrix_are_reported() {
        // y' = y²: with h·y large the Newton matrix 1 − h·y/... becomes singular at h y = 2
        // for the midpoint rule (1 − h·2y/2 = 0).
        let mut rhs = |_: f64, y: &[f64], d: &mut [f64]| d[0] = y[0] * y[0];
        let mut jac = |_: f64, y: &[f64], j: &mut [f64]| j[0] = 2.0 * y[0];
        let mut p = Problem::new(&mut rhs);
        p.jacobian = Some(&mut jac);
        let (mut t, mut x) = (0.0, [1.0]);
        let mut stats = Stats::default();
        let midpoint = Method::ImplicitMidpoint;
        let r = fixed(midpoint, &mut p, (&mut t, &mut x), (2.0, 1.0), &mut stats);
        assert_eq!(
            r,
            Err(ImplicitFailure::NewtonFailed {
                t: 0.0,
                h: 1.0,
                iterations: 0
            })
        );
        assert_eq!((t, x[0]), (0.0, 1.0));
        // h = 0.9 from y = 1: the midpoint equation z = h (1 + z/2)² has no real root for
        // h > 0.5·... (discriminant 1 − 2h < 0 for h > 1/2): Newton cannot converge.
        let (mut t, mut x) = (0.0, [1.0]);
        let r = fixed(midpoint, &mut p, (&mut t, &mut x), (2.0, 0.9), &mut stats);
        assert!(
            matches!(r, Err(ImplicitFailure::NewtonFailed { t: 0.0, h, iterations }) if h == 0.9 && iterations > 0),
            "{r:?}"
        );
    }

    /// Max relative energy error of the oscillator (h = 0.01, hω = 0.1) over the first and the
    /// last `window` of `steps` steps, one call per step; and the final energy ratio.
    fn energy_windows(
        step: &mut dyn FnMut(&mut f64, &mut [f64; 2], f64),
        steps: usize,
        window: usize,
    ) -> (f64, f64, f64) {
        use super::super::problem::test_support::energy;
        let h = 0.01;
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        let (mut first, mut last): (f64, f64) = (0.0, 0.0);
        for i in 0..steps {
            step(&mut t, &mut x, (i + 1) as f64 * h);
            let e = (energy(&x) - 1.0).abs();
            if i < window {
                first = first.max(e);
            }
            if i >= steps - window {
                last = last.max(e);
            }
        }
        (first, last, energy(&x))
    }

    fn drift_comparison(steps: usize) {
        let window = 100_000;
        let h = 0.01;
        let mut stats = Stats::default();
        let mut rhs = oscillator;
        let mut jac = oscillator_jacobian;
        let mut p = Problem::new(&mut rhs);
        p.jacobian = Some(&mut jac);
        p.second_order = Some(1);
        let mut windows = |method| {
            let started = std::time::Instant::now();
            let (f, l, e_end) = energy_windows(
                &mut |t, x, te| {
                    let state = (t, &mut x[..]);
                    fixed(method, &mut p, state, (te, h), &mut stats).unwrap()
                },
                steps,
                window,
            );
            eprintln!(
                "{}: max |ΔE/E| first {f:e}, last {l:e} ({:?})",
                method.name(),
                started.elapsed()
            );
            (f, l, e_end)
        };

        // Bounded, O(hω) = 0.1: the modified energy ω²x² + v² − hω²xv is conserved exactly.
        let (f, l, _) = windows(Method::SymplecticEuler);
        assert!(l < 0.06 && l < 1.01 * f, "first {f:e}, last {l:e}");
        // Bounded, (hω)²/4 = 2.5e-3 (modified energy ω²x²(1 − (hω)²/4) + v²).
        let (f, l, _) = windows(Method::Verlet);
        assert!(l < 3e-3 && l < 1.01 * f, "first {f:e}, last {l:e}");
        // Energy is a quadratic invariant: conserved up to rounding, which random-walks
        // (≈ ε·√steps), no systematic drift.
        let (f, l, _) = windows(Method::Gauss4);
        assert!(l < 1e-11, "first {f:e}, last {l:e}");

        let (f, l, e_end) = windows(Method::Rk4);
        // Energy decays by |R(ihω)|² = 1 − (hω)⁶/72 + (hω)⁸/576 per step: a linear drift of
        // 1.39e-8 per step.
        let y: f64 = 0.1;
        let predicted = (1.0 + y.powi(6) * (y * y - 8.0) / 576.0).powi(steps as i32);
        eprintln!("RK4: final energy {e_end} (predicted {predicted})");
        assert!((e_end / predicted - 1.0).abs() < 1e-9);
        let growth = l / f;
        let expected = (1.0 - predicted)
            / (1.0 - (1.0 + y.powi(6) * (y * y - 8.0) / 576.0).powi(window as i32));
        assert!(
            (growth / expected - 1.0).abs() < 1e-3,
            "growth {growth}, expected {expected}"
        );
        assert!(
            growth > 0.9 * steps as f64 / window as f64,
            "growth {growth}"
        );
    }

    /// 5·10⁵ steps, so that a debug build takes < 5 s (10⁶ took 7.7 s, 6 s of it Gauss4):
    /// the last window of 10⁵ steps starts 4·10⁵ steps after the first one ends.
    #[test]
    fn symplectic_methods_do_not_drift_rk4_does() {
        drift_comparison(500_000);
    }

    /// The full 10⁷ steps: `cargo test --release --lib integrators -- --ignored`.
    #[test]
    #[ignore]
    fn symplectic_methods_do_not_drift_rk4_does_1e7() {
        drift_comparison(10_000_000);
    }

    /// Free rigid body, Euler's equations with I = (1, 2, 3), in body angular velocity Ω:
    /// Iᵢ Ω̇ᵢ = (Iⱼ − Iₖ) Ωⱼ Ωₖ, (i, j, k) cyclic. Written generic so the Jacobian comes exactly
    /// from dual numbers.
    fn rigid_body<S: crate::model::Scalar>(w: &[S], dw: &mut [S]) {
        const I: [f64; 3] = [1.0, 2.0, 3.0];
        for i in 0..3 {
            let (j, k) = ((i + 1) % 3, (i + 2) % 3);
            dw[i] = w[j] * w[k] * ((I[j] - I[k]) / I[i]);
        }
    }

    /// |H|² = Σ (Iᵢ Ωᵢ)²: a quadratic invariant (also the energy Σ Iᵢ Ωᵢ², not checked).
    fn momentum2(w: &[f64]) -> f64 {
        (w[0]).powi(2) + (2.0 * w[1]).powi(2) + (3.0 * w[2]).powi(2)
    }

    #[test]
    fn implicit_midpoint_keeps_rigid_body_momentum_to_rounding_rk4_does_not() {
        use num_dual::Dual64;
        let mut rhs = |_: f64, w: &[f64], dw: &mut [f64]| rigid_body(w, dw);
        let mut jacobians = 0;
        let mut jac = |_: f64, w: &[f64], j: &mut [f64]| {
            jacobians += 1;
            for col in 0..3 {
                let wd: Vec<Dual64> = (0..3)
                    .map(|i| Dual64::new(w[i], f64::from(u8::from(i == col))))
                    .collect();
                let mut d = [Dual64::from(0.0); 3];
                rigid_body(&wd, &mut d);
                for row in 0..3 {
                    j[row * 3 + col] = d[row].eps;
                }
            }
        };
        let h = 0.1;
        let steps = 10_000;
        let w0 = [1.0, 0.5, -0.3];
        let h0 = momentum2(&w0);
        let mut p = Problem::new(&mut rhs);
        p.jacobian = Some(&mut jac);
        let mut run = |method| {
            let (mut t, mut w) = (0.0, w0);
            let mut stats = Stats::default();
            let mut worst: f64 = 0.0;
            for i in 0..steps {
                let state = (&mut t, &mut w[..]);
                fixed(method, &mut p, state, ((i + 1) as f64 * h, h), &mut stats).unwrap();
                worst = worst.max((momentum2(&w) / h0 - 1.0).abs());
            }
            (worst, stats)
        };
        let (worst, stats) = run(Method::ImplicitMidpoint);
        let (worst_rk4, _) = run(Method::Rk4);
        eprintln!(
            "midpoint: max relative |H|² error {worst:e}; {stats:?}, {jacobians} Jacobians, \
             {:.2} Newton iterations per step",
            stats.rhs_evals as f64 / stats.steps as f64
        );
        assert!(worst < 1e-14 * 10.0, "midpoint |H|² error {worst:e}");
        eprintln!("RK4: max relative |H|² error {worst_rk4:e}");
        assert!(
            worst_rk4 > 1e4 * worst,
            "RK4 {worst_rk4:e} vs midpoint {worst:e}"
        );
    }
}
