//! Classic fourth-order Runge–Kutta with a fixed step.
//!
//! Fixed steps make the cost of a communication step known in advance and the result
//! independent of tolerances; the price is that accuracy is the user's business.

use super::buffers::sized;
use super::finite::all_finite;
use super::problem::step_count;
use super::{Failure, Stats};

/// A right-hand side `f(t, x, dx)` for the stages of [`advance_sized`]. Closures are one
/// (inlined at the compiler's discretion); the FMU's fixed-step doStep passes a type whose
/// `eval` is `#[inline(always)]`, so that a small system's equations sit in the stages with
/// their lengths known, not behind a call.
pub trait Rhs {
    fn eval(&mut self, t: f64, x: &[f64], dx: &mut [f64]);
}

impl<F: FnMut(f64, &[f64], &mut [f64]) + ?Sized> Rhs for F {
    #[inline(always)]
    fn eval(&mut self, t: f64, x: &[f64], dx: &mut [f64]) {
        self(t, x, dx)
    }
}

/// Advance with RK4 from `*t` to `t_end` (> `*t`, `x` finite; see [`super::advance`]).
///
/// Step `i` runs from `t0 + i·step` to `t0 + (i+1)·step` (the last one to `t_end`): times
/// are computed from the start, not accumulated, so rounding does not drift.
pub fn advance(
    rhs: &mut dyn FnMut(f64, &[f64], &mut [f64]),
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    step: f64,
    stats: &mut Stats,
) -> Result<(), Failure> {
    advance_in(rhs, t, x, t_end, step, stats, &mut Default::default())
}

/// [`advance`] in the buffers `stages`: no allocation once they have held this size.
/// Generic over the right-hand side so that a caller holding a concrete closure (the
/// FMU's doStep) gets it inlined into the stages; `dyn FnMut` callers pass `F = dyn ..`.
pub fn advance_in<F: Rhs + ?Sized>(
    rhs: &mut F,
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    step: f64,
    stats: &mut Stats,
    stages: &mut [Vec<f64>; 5],
) -> Result<(), Failure> {
    let dim = x.len();
    let n = step_count(t_end - *t, step) as u64;
    // (Each written in full, by f or below, before it is read.)
    let [k1, k2, k3, k4, y] = stages;
    let stages = [
        sized(k1, dim),
        sized(k2, dim),
        sized(k3, dim),
        sized(k4, dim),
        sized(y, dim),
    ];
    steps(rhs, (t, x), (t_end, step, n), stats, stages)
}

/// [`advance_in`] in `n` steps (the [`step_count`] of the span: the caller has it from
/// checking its plan) for a state of `N` components, its stages on the stack: with the sizes
/// known, the stage loops unroll, no index is checked and no buffer is sized. The same
/// arithmetic, bit for bit.
#[inline]
pub fn advance_sized<const N: usize, F: Rhs + ?Sized>(
    rhs: &mut F,
    (t, x): (&mut f64, &mut [f64; N]),
    (t_end, step, n): (f64, f64, u64),
    stats: &mut Stats,
) -> Result<(), Failure> {
    let [mut k1, mut k2, mut k3, mut k4, mut y] = [[0.0; N]; 5];
    let stages = [&mut k1, &mut k2, &mut k3, &mut k4, &mut y];
    steps(rhs, (t, x), (t_end, step, n), stats, stages)
}

/// `n` steps from `*t` to `t_end` in the buffers `[k1, k2, k3, k4, y]`, each as long as `x`:
/// slices, or arrays whose length the compiler then knows.
/// (No limit here: `integrators::advance` checks the plan against `Settings::max_steps`.)
#[inline(always)]
fn steps<F, B>(
    rhs: &mut F,
    (t, x): (&mut f64, &mut B),
    (t_end, step, n): (f64, f64, u64),
    stats: &mut Stats,
    [k1, k2, k3, k4, y]: [&mut B; 5],
) -> Result<(), Failure>
where
    F: Rhs + ?Sized,
    B: AsMut<[f64]> + ?Sized,
{
    let x = x.as_mut();
    let [k1, k2, k3, k4, y] = [
        k1.as_mut(),
        k2.as_mut(),
        k3.as_mut(),
        k4.as_mut(),
        y.as_mut(),
    ];
    if n == 0 {
        return Ok(());
    }
    // Steps 1 … n−1 end at t0 + i·step, the last at t_end: the body twice, so that the
    // doStep of one solver step runs no loop and computes no time it does not use.
    let t0 = *t;
    for i in 1..n {
        let tb = t0 + i as i64 as f64 * step; // (i < n ≤ a step limit: exact through i64)
        let stages = [&mut *k1, &mut *k2, &mut *k3, &mut *k4, &mut *y];
        one_step(rhs, (t, x), tb, stats, stages)?;
    }
    one_step(rhs, (t, x), t_end, stats, [k1, k2, k3, k4, y])
}

/// One step from `*t` to `tb` in the buffers `[k1, k2, k3, k4, y]`.
#[inline(always)]
fn one_step<F: Rhs + ?Sized>(
    rhs: &mut F,
    (t, x): (&mut f64, &mut [f64]),
    tb: f64,
    stats: &mut Stats,
    [k1, k2, k3, k4, y]: [&mut [f64]; 5],
) -> Result<(), Failure> {
    let ta = *t;
    let h = tb - ta;
    let tm = ta + 0.5 * h;
    let dim = x.len();
    rhs.eval(ta, x, k1);
    for j in 0..dim {
        y[j] = x[j] + 0.5 * h * k1[j];
    }
    rhs.eval(tm, y, k2);
    for j in 0..dim {
        y[j] = x[j] + 0.5 * h * k2[j];
    }
    rhs.eval(tm, y, k3);
    for j in 0..dim {
        y[j] = x[j] + h * k3[j];
    }
    rhs.eval(tb, y, k4);
    stats.rhs_evals += 4;
    for j in 0..dim {
        y[j] = x[j] + h / 6.0 * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j]);
    }
    // Every stage enters the new state with a nonzero weight, so a non-finite stage always
    // makes it non-finite (inf - inf is NaN): checking the new state suffices.
    if !all_finite(y) {
        return Err(Failure::NonFinite { t: ta });
    }
    x.copy_from_slice(y);
    *t = tb;
    stats.steps += 1;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{one, oscillator, oscillator_error, settings, square, OMEGA};
    use super::super::{self as integ, Memory, Method, MAX_STEPS};
    use super::*;

    /// A coupled nonlinear system of any size, time dependent.
    fn chain(t: f64, x: &[f64], dx: &mut [f64]) {
        let n = x.len();
        for i in 0..n {
            dx[i] = (t + x[(i + 1) % n]).sin() - 0.3 * x[i] * x[(i + n - 1) % n];
        }
    }

    /// The FMU's path (`integrators::rk4_fixed`: stages on the stack for the sizes it knows,
    /// the workspace otherwise) gives the general path's numbers bit for bit, and refuses
    /// the plans the general path refuses.
    #[test]
    fn fixed_path_is_the_general_path_bit_for_bit() {
        for dim in [1, 2, 3, 4, 6, 7, 8, 9] {
            for (t_end, step) in [(0.47, 0.01), (0.4, 0.1), (0.101, 1e-3), (0.35, 0.07)] {
                let x0: Vec<f64> = (0..dim).map(|i| 0.2 + 0.1 * i as f64).collect();
                let settings = settings(Method::Rk4, step);
                let (mut t, mut x, mut memory) = (0.1, x0.clone(), Memory::default());
                integ::advance(&mut chain, &mut t, &mut x, t_end, &settings, &mut memory).unwrap();
                let (mut tf, mut xf, mut stats) = (0.1, x0, Stats::default());
                let mut f = chain;
                let mut work = crate::integrators::Workspace::default();
                let plan = (step, MAX_STEPS);
                integ::rk4_fixed(
                    &mut f,
                    (&mut tf, &mut xf),
                    t_end,
                    plan,
                    &mut stats,
                    &mut work,
                )
                .unwrap();
                assert_eq!(tf.to_bits(), t.to_bits());
                assert!(
                    x.iter().zip(&xf).all(|(a, b)| a.to_bits() == b.to_bits()),
                    "{dim}"
                );
                assert_eq!(stats, memory.stats);
            }
        }
        let (mut t, mut x, mut stats) = (0.0, [1.0, 0.0], Stats::default());
        let refused = integ::rk4_fixed(
            &mut chain,
            (&mut t, &mut x),
            1.0,
            (1e-3, 999),
            &mut stats,
            &mut crate::integrators::Workspace::default(),
        );
        assert!(matches!(refused, Err(Failure::TooManyPlanned { .. })));
        assert_eq!((t, x, stats.rhs_evals), (0.0, [1.0, 0.0], 0));
    }

    fn run_rk4(step: f64, t_end: f64) -> (f64, [f64; 2], Stats) {
        let settings = settings(Method::Rk4, step);
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        integ::advance(
            &mut oscillator,
            &mut t,
            &mut x,
            t_end,
            &settings,
            &mut memory,
        )
        .unwrap();
        (t, x, memory.stats)
    }

    #[test]
    fn rk4_oscillator_matches_closed_form() {
        let (t, x, stats) = run_rk4(1e-3, 10.0);
        assert_eq!(t.to_bits(), 10.0f64.to_bits());
        let err = oscillator_error(10.0, &x);
        // Measured: 7.15e-9 (phase error ≈ ωT·(ωh)⁴/120 = 8.3e-9 rad, minus the amplitude part).
        assert!(err < 1e-8, "error {err:e}");
        assert!(err > 1e-9, "suspiciously exact: {err:e}");
        assert_eq!(stats.steps, 10_000);
        assert_eq!(stats.rhs_evals, 40_000);
        assert_eq!(stats.rejected, 0);
    }

    #[test]
    fn rk4_is_fourth_order() {
        let (_, x1, _) = run_rk4(2e-3, 10.0);
        let (_, x2, _) = run_rk4(1e-3, 10.0);
        let ratio = oscillator_error(10.0, &x1) / oscillator_error(10.0, &x2);
        // Measured: 1.138e-7 / 7.15e-9 = 15.92 (order 4 ⇒ 2⁴).
        assert!((ratio - 16.0).abs() < 0.5, "ratio {ratio}");
    }

    #[test]
    fn rk4_lands_exactly_and_merges_slivers() {
        // 10 steps and a rounding sliver: merged, 10 steps.
        let (t, _, s) = run_rk4(0.1, 1.0 + 1e-13);
        assert_eq!(t, 1.0 + 1e-13);
        assert_eq!(s.steps, 10);
        // 0.1 does not divide 0.3 exactly in binary: still 3 steps, no sliver.
        let (t, _, s) = run_rk4(0.1, 0.3);
        assert_eq!(t, 0.3);
        assert_eq!(s.steps, 3);
        // A genuine remainder gets its own, shortened step.
        let (t, _, s) = run_rk4(0.1, 1.05);
        assert_eq!(t, 1.05);
        assert_eq!(s.steps, 11);
        // Interval shorter than the step: one step.
        let (t, _, s) = run_rk4(0.1, 0.01);
        assert_eq!((t, s.steps), (0.01, 1));
        // No step given: one step over the interval.
        let (_, _, s) = run_rk4(0.0, 0.5);
        assert_eq!(s.steps, 1);
    }

    #[test]
    fn rk4_times_do_not_drift() {
        // Record the times RK4 evaluates at; the step starts must be exactly t0 + i·h.
        let settings = settings(Method::Rk4, 0.1);
        let mut memory = Memory::default();
        let mut times = Vec::new();
        let (mut t, mut x) = (3.0, [0.0]);
        let mut f = |t: f64, _: &[f64], d: &mut [f64]| {
            times.push(t);
            d[0] = 1.0;
        };
        integ::advance(&mut f, &mut t, &mut x, 103.0, &settings, &mut memory).unwrap();
        assert_eq!(memory.stats.steps, 1000);
        for i in 0..1000 {
            assert_eq!(times[4 * i], 3.0 + i as f64 * 0.1, "step {i}");
        }
        assert_eq!(t, 103.0);
        assert!((x[0] - 100.0).abs() < 1e-12);
    }

    /// RK4 with `step` on the scalar `rhs` from x(0) = 1 to `t_end` in a fresh memory: the
    /// result, where it stopped, and the memory.
    fn run_scalar(
        mut rhs: fn(f64, &[f64], &mut [f64]),
        step: f64,
        t_end: f64,
    ) -> (Result<(), Failure>, f64, f64, Memory) {
        let settings = settings(Method::Rk4, step);
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [1.0]);
        let r = integ::advance(&mut rhs, &mut t, &mut x, t_end, &settings, &mut memory);
        (r, t, x[0], memory)
    }

    #[test]
    fn rk4_blow_up_fails_with_finite_state() {
        let (r, t, x, _) = run_scalar(square, 1e-3, 2.0);
        // RK4 cannot see the singularity at t = 1; it overflows a few steps past it.
        assert_eq!(r, Err(Failure::NonFinite { t }));
        assert!(x.is_finite() && t < 2.0);
    }

    #[test]
    fn rk4_refuses_absurd_step_counts_up_front() {
        let (r, _, _, memory) = run_scalar(one, 1e-9, 1.0);
        assert_eq!(
            r,
            Err(Failure::TooManyPlanned {
                t: 0.0,
                planned: 1e9,
                step: 1e-9,
                max: MAX_STEPS
            })
        );
        assert_eq!(memory.stats.rhs_evals, 0);
        // Up to the limit it plans and steps.
        let (r, _, _, memory) = run_scalar(one, 1.0 / MAX_STEPS as f64, 1.0);
        r.unwrap();
        assert_eq!(memory.stats.steps, MAX_STEPS);
    }

    /// RK4 on the oscillator: in the scaled coordinates (x, v/ω) the system is normal, so
    /// every step multiplies the energy by exactly |R(ihω)|², with
    /// R(z) = 1 + z + z²/2 + z³/6 + z⁴/24: |R(iy)|² = 1 + y⁶(y² − 8)/576. Stable up to
    /// y = 2√2 = 2.8284.
    fn rk4_energy_ratio(y: f64, steps: usize) -> (f64, f64) {
        let h = y / OMEGA;
        let (_, x, stats) = run_rk4(h, steps as f64 * h);
        assert_eq!(stats.steps, steps as u64);
        let measured = x[0] * x[0] + x[1] * x[1] / (OMEGA * OMEGA);
        let predicted = (1.0 + y.powi(6) * (y * y - 8.0) / 576.0).powi(steps as i32);
        (measured, predicted)
    }

    #[test]
    fn rk4_is_stable_just_below_two_root_two_and_grows_just_above() {
        // hω = 2.82: |R|² = 0.95844 per step (strongly damped), 10⁴ steps: 4.4e-185 of the start.
        let (e, p) = rk4_energy_ratio(2.82, 10_000);
        eprintln!("RK4 hω = 2.82, 10⁴ steps: energy ratio {e:e}, predicted {p:e}");
        assert!(e < 1.0 && (e / p - 1.0).abs() < 1e-9, "{e:e} vs {p:e}");
        // hω = 2.84: |R|² = 1.05976 per step; 10⁴ steps: 1.2e252 times the start.
        let (e, p) = rk4_energy_ratio(2.84, 10_000);
        eprintln!("RK4 hω = 2.84, 10⁴ steps: energy ratio {e:e}, predicted {p:e}");
        assert!(e > 1e10 && (e / p - 1.0).abs() < 1e-9, "{e:e} vs {p:e}");
    }
}
