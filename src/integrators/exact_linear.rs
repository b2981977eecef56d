//! The exact propagator of a linear time-invariant system `ẋ = A x + b`: over a step h,
//! `x(t + h) = e^{Ah} x(t) + (∫₀ʰ e^{As} ds) b`, with no truncation error at any step size.
//!
//! Both parts come from one matrix exponential of the augmented matrix
//! `[[A, b], [0, 0]]·h`, whose exponential is `[[e^{Ah}, ∫₀ʰ e^{As} ds·b], [0, 1]]`
//! (C. Van Loan, *Computing integrals involving the matrix exponential*, IEEE TAC 23 (1978)
//! 395–404). The exponential is nalgebra's `Matrix::exp` (it exists for `DMatrix`): scaling and
//! squaring with Padé approximants of degree 3…13 chosen by the bounds of A. H. Al-Mohy,
//! N. J. Higham, *A new scaling and squaring algorithm for the matrix exponential*, SIAM J.
//! Matrix Anal. Appl. 31 (2009) 970–989.

use super::buffers::zeroed;
use super::expm::Expm;
use super::problem::{fixed_steps, FixedCall, Problem};
use super::{Failure, Stats};
use nalgebra::{DMatrix, DMatrixView, DMatrixViewMut, DVector};

/// `(e^{Ah}, ∫₀ʰ e^{As} ds · b)` for a square `a` and `b` of matching length.
pub fn propagator(a: &DMatrix<f64>, b: &DVector<f64>, h: f64) -> (DMatrix<f64>, DVector<f64>) {
    let n = a.nrows();
    assert_eq!(a.ncols(), n, "A must be square");
    assert_eq!(b.len(), n, "b must have one entry per state");
    let mut m = DMatrix::zeros(n + 1, n + 1);
    m.view_mut((0, 0), (n, n)).copy_from(&(a * h));
    m.view_mut((0, n), (n, 1)).copy_from(&(b * h));
    let e = m.exp();
    (
        e.view((0, 0), (n, n)).into_owned(),
        e.view((0, n), (n, 1)).column(0).into_owned(),
    )
}

/// ExactLinear's part of a [`Workspace`](super::Workspace): the new state, the Jacobian
/// (row-major, then A column-major), f and A·x at the start, b, and the exponential of the
/// augmented matrix for the step `h` it was last computed for in this call.
#[derive(Default)]
pub struct Scratch {
    y: Vec<f64>,
    jac: Vec<f64>,
    a: Vec<f64>,
    f0: Vec<f64>,
    ax: Vec<f64>,
    b: Vec<f64>,
    /// The input polynomial's c₁ and c₂ (and scratch), see [`input_polynomial`].
    c: Vec<f64>,
    expm: Expm,
}

/// Advance `ẋ = A x + b` exactly from `*t` to `t_end` in steps of `h` (the last one shortened;
/// `h` not positive and finite: one step), `x ← Φ x + γ` with `(Φ, γ) = propagator(A, b, h)`.
///
/// `A` is `problem.jacobian` at the start `(t, x)` and `b = f(t, x) − A x` (one evaluation
/// of f, counted): the caller promises that f is affine and time invariant. For any other f
/// this is the exponential integrator of the linearization at the start, not exact.
/// One exponential for the full steps and one more for a shortened last step; the step size
/// only affects rounding (more steps, more rounding), never truncation.
///
/// In the scratch of `w`: no allocation once it has held this size (the exponential is
/// nalgebra's, step for step, in kept buffers).
pub fn advance_in(problem: &mut Problem, call: FixedCall, w: &mut Scratch) -> Result<(), Failure> {
    if call.t_end == *call.t || !call.x.iter().all(|v| v.is_finite()) {
        // Let the common loop report the no-op or the non-finite start, before any work.
        let nothing = |_: &mut Stats, _, _, _: &[f64], _: &mut [f64]| Ok::<(), Failure>(());
        return fixed_steps("exact linear", call, &mut w.y, nothing);
    }
    let FixedCall {
        t,
        x,
        t_end,
        h,
        stats,
    } = call;
    let n = x.len();
    let jac = zeroed(&mut w.jac, n * n);
    problem.eval_jacobian("exact linear propagator", (*t, x), jac, stats);
    // A, column-major as nalgebra's `DMatrix::from_row_slice(n, n, jac)`.
    let a = zeroed(&mut w.a, n * n);
    for i in 0..n {
        for j in 0..n {
            a[j * n + i] = jac[i * n + j];
        }
    }
    let f0 = zeroed(&mut w.f0, n);
    if !problem.eval(*t, x, f0, stats) {
        return Err(Failure::NonFinite { t: *t });
    }
    // b = f(t, x) − A x, with nalgebra's product.
    let ax = zeroed(&mut w.ax, n);
    DMatrixView::from_slice(a, n, n).mul_to(
        &DMatrixView::from_slice(x, n, 1),
        &mut DMatrixViewMut::from_slice(ax, n, 1),
    );
    let b = zeroed(&mut w.b, n);
    for i in 0..n {
        b[i] = f0[i] - ax[i];
    }
    // Inputs that move over the call (fmi2SetRealInputDerivatives) add a polynomial in
    // s = t − t₀ to f, c₁ s + c₂ s²/2 ([`input_polynomial`]); held inputs add nothing.
    let t0 = *t;
    let moving = input_polynomial(problem, (t0, x, t_end - t0), stats, (&w.f0, &mut w.c))?;
    let (a, b, c, expm) = (&*a, &*b, &w.c, &mut w.expm);
    let mut cached: Option<f64> = None;
    fixed_steps(
        "exact linear",
        FixedCall {
            t,
            x,
            t_end,
            h,
            stats,
        },
        &mut w.y,
        |_, ta, tb, x, y| {
            let hs = tb - ta;
            if cached.is_none_or(|hc| hc.to_bits() != hs.to_bits()) {
                if moving {
                    // e^{M hs} of z = (x, s²/2, s, 1): ẋ = A x + c₂ s²/2 + c₁ s + b, and the
                    // polynomial's own chain d(s²/2)/dt = s, ds/dt = 1.
                    expm.set(n + 3, |i, j| match (i < n, j < n) {
                        (true, true) => a[j * n + i] * hs,
                        (true, false) => [c[n + i], c[i], b[i]][j - n] * hs,
                        (false, false) if j == i + 1 => hs,
                        _ => 0.0,
                    });
                } else {
                    // The propagator of `propagator(A, b, hs)`: e^{[[A, b], [0, 0]]·hs}.
                    expm.set(n + 1, |i, j| match (i < n, j < n) {
                        (true, true) => a[j * n + i] * hs,
                        (true, false) => b[i] * hs,
                        _ => 0.0,
                    });
                }
                expm.exp();
                cached = Some(hs);
            }
            // x ← Φ x + γ, Φ = e[..n, ..n], γ = e[..n, n] (held inputs), or the columns of
            // the polynomial at the step's start s = ta − t₀.
            let s = ta - t0;
            for (i, yi) in y.iter_mut().enumerate() {
                let mut v = if moving {
                    expm.get(i, n) * (0.5 * s * s) + expm.get(i, n + 1) * s + expm.get(i, n + 2)
                } else {
                    expm.get(i, n)
                };
                for (j, xj) in x.iter().enumerate() {
                    v += expm.get(i, j) * xj;
                }
                *yi = v;
            }
            Ok(())
        },
    )
}

/// The input polynomial of a call over `span` from `(t0, x)`: f(t, x) − f(t₀, x) =
/// c₁ (t − t₀) + c₂ (t − t₀)²/2 for an f affine in x and in inputs that move along a
/// polynomial of degree ≤ 2 (zero for held inputs). Read off f at s = span and 2·span (two
/// evaluations, counted) into `w.c` = (c₁, c₂): the differences are exact for such an f up
/// to rounding, and their rounding, divided by span or span², enters the state multiplied
/// by at least as high a power of the step. `Ok(false)`: the inputs are held
/// ([`Problem::inputs_move`] false), nothing evaluated.
fn input_polynomial(
    problem: &mut Problem,
    (t0, x, span): (f64, &[f64], f64),
    stats: &mut Stats,
    (f0, c): (&[f64], &mut Vec<f64>),
) -> Result<bool, Failure> {
    if !problem.inputs_move {
        return Ok(false);
    }
    let n = x.len();
    let c = zeroed(c, 4 * n);
    let (c, g) = c.split_at_mut(2 * n);
    let (g1, g2) = g.split_at_mut(n);
    if !problem.eval(t0 + span, x, g1, stats) || !problem.eval(t0 + 2.0 * span, x, g2, stats) {
        return Err(Failure::NonFinite { t: t0 });
    }
    for i in 0..n {
        let (d1, d2) = (g1[i] - f0[i], g2[i] - f0[i]);
        // d1 = c₁ S + c₂ S²/2, d2 = 2 c₁ S + 2 c₂ S².
        c[i] = (4.0 * d1 - d2) / (2.0 * span);
        c[n + i] = (d2 - 2.0 * d1) / (span * span);
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::super::problem::test_support::oscillator_jacobian;
    use super::super::test_support::{fixed, oscillator, oscillator_exact, OMEGA};
    use super::super::Method;
    use super::*;

    #[test]
    fn exponential_matches_oscillator_closed_form() {
        // e^{Ah} = [[cos ωh, sin ωh / ω], [−ω sin ωh, cos ωh]] for A = [[0, 1], [−ω², 0]].
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -OMEGA * OMEGA, 0.0]);
        let mut worst: f64 = 0.0;
        for h in [1e-3, 0.01, 0.1, 0.37, 1.0, 2.5, 10.0] {
            let (phi, gamma) = propagator(&a, &DVector::zeros(2), h);
            let (c, s) = ((OMEGA * h).cos(), (OMEGA * h).sin());
            // Compare in the energy scale (x, v/ω): every entry of size ≤ 1.
            let errs = [
                (phi[(0, 0)] - c).abs(),
                (phi[(0, 1)] - s / OMEGA).abs() * OMEGA,
                (phi[(1, 0)] + OMEGA * s).abs() / OMEGA,
                (phi[(1, 1)] - c).abs(),
            ];
            let e = errs.iter().fold(0.0f64, |m, v| m.max(*v));
            eprintln!("h = {h}: max entry error {e:e}");
            worst = worst.max(e);
            assert_eq!(gamma.amax(), 0.0);
        }
        assert!(worst < 1e-14, "worst {worst:e}");
    }

    #[test]
    fn affine_part_is_integrated_exactly() {
        // ẋ = −2x + 3: x(h) = 3/2 + (x₀ − 3/2) e^{−2h}.
        let a = DMatrix::from_row_slice(1, 1, &[-2.0]);
        let (phi, gamma) = propagator(&a, &DVector::from_column_slice(&[3.0]), 0.7);
        assert!((phi[(0, 0)] - (-1.4f64).exp()).abs() < 1e-15);
        assert!((gamma[0] - 1.5 * (1.0 - (-1.4f64).exp())).abs() < 1e-15);
    }

    #[test]
    fn advance_is_exact_at_any_step() {
        let mut rhs = oscillator;
        let mut jac = oscillator_jacobian;
        for h in [0.01, 0.3, f64::INFINITY] {
            let mut p = Problem::new(&mut rhs);
            p.jacobian = Some(&mut jac);
            let (mut t, mut x) = (0.0, [1.0, 0.0]);
            let mut stats = Stats::default();
            let exact = Method::ExactLinear;
            fixed(exact, &mut p, (&mut t, &mut x), (10.0, h), &mut stats).unwrap();
            assert_eq!(t, 10.0);
            let e = oscillator_exact(10.0);
            let err = (x[0] - e[0]).abs().max((x[1] - e[1]).abs() / OMEGA);
            eprintln!("h = {h}: error {err:e} after {} steps", stats.steps);
            // Rounding only: grows with the number of steps (1000 steps of 0.01).
            assert!(err < 1e-11, "h = {h}: error {err:e}");
            assert_eq!(stats.rhs_evals, 1);
        }
    }
}
