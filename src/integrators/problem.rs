//! What the methods beyond [`super::advance`] need to know about a problem, and the loop the
//! fixed-step ones share.
//!
//! [`super::advance`] only needs `f`. Implicit methods also need the Jacobian `∂f/∂x` (exact,
//! e.g. from dual numbers as in [`crate::model::jacobian`]), and the symplectic methods need to
//! know which components are positions. [`Problem`] carries all three; each method states what
//! it requires and panics (a caller bug, as for `t_end < t` in `advance`) when it is missing.
//!
//! Conventions shared with `advance`: every method advances from `*t` to exactly `t_end`; on
//! failure `*t` and `x` hold the last accepted (finite) step; `Stats` counts every evaluation of
//! `f` (not of the Jacobian: wrap the closure to count those).

use super::buffers::sized;
use super::finite::{all_finite, finite};
use super::{Failure, Memory, Settings, Stats};
use std::fmt;

/// Newton has converged when an increment is within a few ulps of the state (max norm, relative
/// to max(‖x₀‖, ‖Z‖)): converged to rounding, which is what makes quadratic invariants hold to
/// rounding rather than to a tolerance.
pub const NEWTON_TOL: f64 = 4.0 * f64::EPSILON;
/// Most Newton iterations per step. The simplified iteration converges linearly with a rate
/// θ ~ h·‖∂J/∂x‖·‖Z‖ (θ = 0 for linear problems: done after one iteration plus one to confirm);
/// 50 iterations reach rounding from O(1) for θ up to about 0.5. Beyond that the step is too
/// large for this fixed-step method, and it fails rather than return an unconverged state.
pub const NEWTON_MAX_ITER: u32 = 50;

/// What one increment says about a simplified Newton iteration (see [`NewtonWatch`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Verdict {
    Converged,
    Diverged,
    Iterate,
}

/// The convergence test the fixed-step implicit methods share (Gauss, RATTLE): an increment
/// within `tol` has converged; one that did not shrink is rounding noise below `stall`
/// (accepted as converged) and divergence above; any other, iterate again.
pub(crate) struct NewtonWatch {
    previous: f64,
}

impl NewtonWatch {
    pub(crate) fn new() -> Self {
        NewtonWatch {
            previous: f64::INFINITY,
        }
    }

    /// The verdict on an increment of size `step`, measured as `tol` and `stall` are.
    pub(crate) fn judge(&mut self, step: f64, (tol, stall): (f64, f64)) -> Verdict {
        if step <= tol {
            return Verdict::Converged;
        }
        if step >= self.previous {
            return if step <= stall {
                Verdict::Converged
            } else {
                Verdict::Diverged
            };
        }
        self.previous = step;
        Verdict::Iterate
    }
}

/// What RATTLE needs to know about a mechanical system: `L = T − V + (work of Q)` with T
/// quadratic in q̇ (`∂T/∂q̇ = M(q) q̇ + b(q)`), and `m` holonomic constraints `g(q) = 0`.
/// Inputs and parameters are fixed for the lifetime of the value.
pub trait Mechanics {
    /// `(n, m)`: coordinates and holonomic constraints.
    fn dims(&self) -> (usize, usize);
    /// `M(q)`, n×n row-major.
    fn mass_matrix(&mut self, q: &[f64], m: &mut [f64]);
    /// `b(q) = ∂T/∂q̇ at q̇ = 0` (zero for natural systems).
    fn momentum_offset(&mut self, q: &[f64], b: &mut [f64]);
    /// `F = ∂L/∂q + Q` at `(t, q, q̇)`.
    fn force(&mut self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]);
    /// `g(q)` (m) and `G(q) = ∂g/∂q` (m×n row-major).
    fn constraints(&mut self, q: &[f64], g: &mut [f64], jac: &mut [f64]);
}

/// The right-hand side and what some methods need besides it.
pub struct Problem<'a> {
    pub rhs: &'a mut dyn FnMut(f64, &[f64], &mut [f64]),
    /// Exact Jacobian ∂f/∂x at (t, x), written row-major into an n×n slice (implicit methods).
    pub jacobian: Option<&'a mut dyn FnMut(f64, &[f64], &mut [f64])>,
    /// Some(nq) when the state is (q, q̇) with dq/dt = q̇ (the first nq components are
    /// positions): needed by the symplectic Euler and Störmer–Verlet methods.
    pub second_order: Option<usize>,
    /// Mass matrix, generalized force and holonomic constraints (RATTLE).
    pub mechanics: Option<&'a mut dyn Mechanics>,
    /// f reads inputs that move along a polynomial of degree ≤ 2 in t over the call
    /// (fmi2SetRealInputDerivatives): ExactLinear then follows that polynomial exactly.
    pub inputs_move: bool,
    /// The system projects its state onto constraints after every step: the adaptive
    /// methods then measure each step's local error between the projected solution and
    /// the projected embedded one (the error the projection leaves), not off the manifold
    /// where the projection removes it anyway.
    pub error_on_manifold: bool,
    /// With `error_on_manifold`: how far a state is off the constraints, written as a
    /// displacement of the state (zero on them) that does not invert the constraints'
    /// Gram matrix, so it stays what the residuals are at a singular position where the
    /// projection's own correction carries rounding amplified by 1/distance². A step
    /// that adds more than the tolerance to it is rejected: its projected solutions can
    /// agree while the step itself went astray (the N four-bar's passages).
    pub defect: Option<&'a mut dyn FnMut(f64, &[f64], &mut [f64]) -> bool>,
}

impl<'a> Problem<'a> {
    /// A problem with only a right-hand side.
    pub fn new(rhs: &'a mut dyn FnMut(f64, &[f64], &mut [f64])) -> Self {
        Problem {
            rhs,
            jacobian: None,
            second_order: None,
            mechanics: None,
            inputs_move: false,
            error_on_manifold: false,
            defect: None,
        }
    }

    /// One evaluation of f, counted; `false` if the derivative is not finite.
    pub(crate) fn eval(&mut self, t: f64, x: &[f64], dx: &mut [f64], stats: &mut Stats) -> bool {
        stats.rhs_evals += 1;
        (self.rhs)(t, x, dx);
        dx.iter().all(|v| v.is_finite())
    }

    /// The Jacobian at (t, x) into `jac` (row-major n×n), counted; panics if the problem
    /// has none.
    pub(crate) fn eval_jacobian(
        &mut self,
        method: &str,
        (t, x): (f64, &[f64]),
        jac: &mut [f64],
        stats: &mut Stats,
    ) {
        stats.jacobians += 1;
        let jacobian = self
            .jacobian
            .as_mut()
            .unwrap_or_else(|| panic!("{method} needs the exact Jacobian (Problem::jacobian)"));
        jacobian(t, x, jac);
    }

    /// Number of position components; panics unless the problem is second order with
    /// `2·nq == x.len()`.
    pub(crate) fn positions(&self, method: &str, dim: usize) -> usize {
        match self.second_order {
            Some(nq) if 2 * nq == dim => nq,
            Some(nq) => panic!("{method}: second_order = {nq} does not split {dim} states"),
            None => panic!("{method} needs a second-order problem (Problem::second_order)"),
        }
    }
}

/// Why an implicit fixed-step method (implicit midpoint, Gauss) stopped early. The state was
/// left at the last accepted step in every case.
///
/// A fixed-step method cannot answer a Newton failure by shrinking its step, and mapping it to
/// [`Failure::StepTooSmall`] would say the opposite of the truth (the step is too *large* for
/// Newton), so it gets a variant of its own; everything `advance` can report is wrapped as is.
#[derive(Clone, Debug, PartialEq)]
pub enum ImplicitFailure {
    /// One of the failures of [`super::advance`].
    Integration(Failure),
    /// The simplified Newton iteration of the step of size `h` from `t` did not converge:
    /// it diverged (an increment did not shrink), or hit the iteration cap after
    /// `iterations` iterations; `iterations == 0` means the Newton matrix was singular.
    NewtonFailed { t: f64, h: f64, iterations: u32 },
}

impl ImplicitFailure {
    /// See [`Failure::is_step_limit`].
    pub fn is_step_limit(&self) -> bool {
        matches!(self, ImplicitFailure::Integration(f) if f.is_step_limit())
    }

    /// See [`Failure::is_work_limit`].
    pub fn is_work_limit(&self) -> bool {
        matches!(self, ImplicitFailure::Integration(f) if f.is_work_limit())
    }
}

impl From<Failure> for ImplicitFailure {
    fn from(f: Failure) -> Self {
        ImplicitFailure::Integration(f)
    }
}

impl fmt::Display for ImplicitFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ImplicitFailure::Integration(e) => e.fmt(f),
            ImplicitFailure::NewtonFailed {
                t,
                h,
                iterations: 0,
            } => write!(
                f,
                "singular Newton matrix in the step of {h:e} s after t = {t} s (step too large?)"
            ),
            ImplicitFailure::NewtonFailed { t, h, iterations } => write!(
                f,
                "Newton did not converge in {iterations} iterations in the step of {h:e} s \
                 after t = {t} s (step too large?)"
            ),
        }
    }
}

impl std::error::Error for ImplicitFailure {}

/// The checks `advance` makes before any work: `Ok(false)` for the no-op `t_end == t`,
/// `Err(NonFinite)` for a non-finite start; panics if `t_end < t` (caller bug).
pub(crate) fn start(method: &str, t: f64, x: &[f64], t_end: f64) -> Result<bool, Failure> {
    assert!(
        t_end >= t,
        "{method}: t_end = {t_end} must not precede t = {t}"
    );
    if t_end == t {
        return Ok(false);
    }
    if !x.iter().all(|v| v.is_finite()) {
        return Err(Failure::NonFinite { t });
    }
    Ok(true)
}

/// A final remainder shorter than this fraction of a step is merged into the previous step:
/// a sliver step (often pure rounding of `t_end - t`) would cost a whole step's RHS
/// evaluations and change nothing but the step count.
pub const SLIVER: f64 = 1e-10;

/// Number of steps covering `span` with steps of `step`, as RK4 counts them: the last one
/// shortened, or lengthened by at most a [`SLIVER`] of a step; one step if `step` is not
/// positive and finite.
#[inline]
pub(crate) fn step_count(span: f64, step: f64) -> f64 {
    if !(step > 0.0 && finite(step)) {
        return 1.0;
    }
    // (span / step ≥ 0 here, so the cast truncates as `floor` would, without libm's call;
    // counts past 2⁶³ saturate and are refused by any step limit. Through i64, not u64:
    // x86-64 converts signed integers in one instruction, unsigned ones in a dozen.)
    let ratio = span / step;
    if ratio < 1.0 + 1e-12 {
        // One step (the doStep of one solver step): what the rule below gives here, as
        // `full` is 0 or 1 and `rest` at most ~1e-12 steps, well inside the sliver.
        return 1.0;
    }
    let full = ratio as i64 as f64;
    let rest = span - full * step;
    if rest <= SLIVER * step {
        full.max(1.0)
    } else {
        full + 1.0
    }
}

/// One call of a fixed-step method: the state `(*t, x)` to advance to exactly `t_end` in
/// steps of `h` (the last one shortened; `h` not positive and finite: one step), counting into
/// `stats`. Every fixed-step method takes one and hands it on to [`fixed_steps`].
pub struct FixedCall<'c> {
    pub t: &'c mut f64,
    pub x: &'c mut [f64],
    pub t_end: f64,
    pub h: f64,
    pub stats: &'c mut Stats,
}

/// One call of an adaptive method's dense mode (see [`super::advance_dense`]): step its point
/// ahead until its last step covers `t_out` (never past `t_limit`, `project` after every
/// accepted step), then write x(`t_out`) into `out`; in `work`, the method's own scratch.
pub struct DenseCall<'c, 'p, W> {
    pub problem: &'c mut Problem<'p>,
    pub project: &'c mut dyn FnMut(f64, &mut [f64]),
    pub t_out: f64,
    pub t_limit: f64,
    pub settings: &'c Settings,
    pub memory: &'c mut Memory,
    pub out: &'c mut [f64],
    pub work: &'c mut W,
}

impl<'c, 'p, W> DenseCall<'c, 'p, W> {
    /// The call to `t_out`, never past `t_limit`, with `settings`, carrying `memory`, into
    /// `out`, in the scratch `work`.
    pub fn new(
        problem: &'c mut Problem<'p>,
        project: &'c mut dyn FnMut(f64, &mut [f64]),
        (t_out, t_limit): (f64, f64),
        (settings, memory): (&'c Settings, &'c mut Memory),
        (out, work): (&'c mut [f64], &'c mut W),
    ) -> Self {
        DenseCall {
            problem,
            project,
            t_out,
            t_limit,
            settings,
            memory,
            out,
            work,
        }
    }

    /// The same call in the part of `work` that `part` picks: each method has its own.
    pub fn with<V>(&mut self, part: impl FnOnce(&mut W) -> &mut V) -> DenseCall<'_, 'p, V> {
        DenseCall {
            problem: &mut *self.problem,
            project: &mut *self.project,
            t_out: self.t_out,
            t_limit: self.t_limit,
            settings: self.settings,
            memory: &mut *self.memory,
            out: &mut *self.out,
            work: part(&mut *self.work),
        }
    }
}

/// The fixed-step loop: step `i` runs from `t0 + i·h` to `t0 + (i+1)·h` (the last one to
/// `t_end`), times computed from the start so rounding does not drift. `one_step(stats, ta,
/// tb, x, y)` writes the state at `tb` into `y` (the scratch `y`, of which it takes
/// `x.len()`: `one_step` writes every component); a non-finite `y` stops the loop with
/// `NonFinite` at the last good state, as does an error of `one_step`.
pub(crate) fn fixed_steps<E: From<Failure>>(
    method: &str,
    call: FixedCall,
    y: &mut Vec<f64>,
    mut one_step: impl FnMut(&mut Stats, f64, f64, &[f64], &mut [f64]) -> Result<(), E>,
) -> Result<(), E> {
    let FixedCall {
        t,
        x,
        t_end,
        h: step,
        stats,
    } = call;
    if !start(method, *t, x, t_end)? {
        return Ok(());
    }
    let t0 = *t;
    // No limit here: `advance_with` checks the plan against `Settings::max_steps` first.
    let n = step_count(t_end - t0, step) as u64;
    let y = sized(y, x.len());
    for i in 0..n {
        let ta = *t;
        let tb = if i + 1 == n {
            t_end
        } else {
            t0 + (i + 1) as f64 * step
        };
        stats.check_work(ta, x.len())?;
        one_step(stats, ta, tb, x, y)?;
        if !all_finite(y) {
            return Err(Failure::NonFinite { t: ta }.into());
        }
        x.copy_from_slice(y);
        *t = tb;
        stats.steps += 1;
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod test_support {
    use super::super::test_support::OMEGA;

    /// Energy of the oscillator in the scale where it is 1 at x = 1, v = 0.
    pub fn energy(y: &[f64]) -> f64 {
        y[0] * y[0] + y[1] * y[1] / (OMEGA * OMEGA)
    }

    /// Jacobian of [`super::super::test_support::oscillator`].
    pub fn oscillator_jacobian(_t: f64, _y: &[f64], j: &mut [f64]) {
        j.copy_from_slice(&[0.0, 1.0, -OMEGA * OMEGA, 0.0]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one-step shortcut of `step_count` gives what its rule gives, at spans a
    /// rounding away from one step and a sliver on either side.
    #[test]
    fn step_count_shortcut_is_the_rule() {
        let rule = |span: f64, step: f64| {
            let full = (span / step) as i64 as f64;
            if span - full * step <= SLIVER * step {
                full.max(1.0)
            } else {
                full + 1.0
            }
        };
        for step in [1e-3, 0.1, 0.7, 3.0, 1e-9] {
            for ulps in -40i64..=40 {
                for scale in [0.0, 1e-13, 1e-12, 1e-11, 1e-10, 2e-10, 1e-6] {
                    let span = step * (1.0 + scale * ulps as f64 / 40.0);
                    let span = f64::from_bits((span.to_bits() as i64 + ulps) as u64);
                    assert_eq!(step_count(span, step), rule(span, step), "{span} {step}");
                }
            }
            // Spans made as a doStep makes them: (t + h) − t.
            for t in [0.0, 0.001, 0.3, 1.7, 123.4, 1e5] {
                let span = (t + step) - t;
                assert_eq!(step_count(span, step), rule(span, step), "{t} {step}");
            }
        }
    }

    #[test]
    fn step_count_matches_rk4_rules() {
        assert_eq!(step_count(1.0 + 1e-13, 0.1), 10.0);
        assert_eq!(step_count(0.3, 0.1), 3.0);
        assert_eq!(step_count(1.05, 0.1), 11.0);
        assert_eq!(step_count(0.01, 0.1), 1.0);
        assert_eq!(step_count(0.5, 0.0), 1.0);
        assert_eq!(step_count(0.5, f64::INFINITY), 1.0);
    }

    #[test]
    fn implicit_failure_display_is_one_line() {
        for f in [
            ImplicitFailure::Integration(Failure::NonFinite { t: 1.0 }),
            ImplicitFailure::NewtonFailed {
                t: 1.0,
                h: 0.1,
                iterations: 0,
            },
            ImplicitFailure::NewtonFailed {
                t: 1.0,
                h: 0.1,
                iterations: 50,
            },
        ] {
            let s = f.to_string();
            assert!(!s.contains('\n') && s.contains("t = "), "{s}");
        }
    }
}
