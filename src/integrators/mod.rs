//! The methods that advance a system's state inside `fmi2DoStep`.
//!
//! Two entry points: [`advance_in`] integrates from the current time to exactly the end of the
//! communication step with any method, and [`advance_dense`] runs the adaptive methods ahead
//! of the communication points and reads each from their dense output. What must survive
//! between communication steps (the step-size proposal, the work counters, the point ahead)
//! lives in [`Memory`], which is part of the serialized FMU state, so a restored state
//! continues bit for bit as the original would have. What only saves allocations (buffers
//! of the right sizes) lives in a [`Workspace`], which is not: the caller keeps one so that
//! a call in steady state allocates nothing. [`advance`] and [`advance_with`] are the same
//! in a fresh workspace. Below them every fixed-step method takes one
//! [`FixedCall`](problem::FixedCall) and every dense mode one [`DenseCall`](problem::DenseCall).

// The `rhs` parameter spells out `&mut dyn FnMut(f64, &[f64], &mut [f64])` on purpose: it is
// the interface other modules call, and an alias would hide what it takes.
#![allow(clippy::type_complexity)]

mod ahead;
pub(crate) mod blob;
mod buffers;
pub mod dop853;
pub mod dopri5;
pub mod euler;
pub mod exact_linear;
pub mod explicit_fixed;
mod explicit_rk;
mod expm;
mod finite;
pub mod gauss;
mod lu;
pub mod problem;
pub mod radau5;
pub mod rattle;
pub mod rk4;
pub mod verlet;
mod workspace;

pub use ahead::{advance_dense, Ahead};
pub(crate) use buffers::{copied, sized, zeroed};
use dop853::Dop853;
use dopri5::Dopri5;
use explicit_rk::land;
pub use finite::{all_finite, finite};
use problem::FixedCall;
pub use problem::ImplicitFailure;
use std::fmt;
pub use workspace::Workspace;

/// Integration method, chosen by the FMU's `solver` parameter (these integer codes are public API).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Classic fourth-order Runge–Kutta, fixed step: cheap and predictable.
    Rk4 = 1,
    /// Dormand–Prince 5(4), adaptive step: accuracy by tolerance.
    Dopri5 = 2,
    /// Explicit Euler, fixed step: the textbook baseline (energy grows by 1 + h²ω²).
    ExplicitEuler = 3,
    /// Symplectic Euler (kick-drift), fixed step; needs a second-order system.
    SymplecticEuler = 4,
    /// Störmer–Verlet (velocity Verlet), fixed step; needs a second-order system.
    Verlet = 5,
    /// Implicit midpoint, fixed step, Newton with the exact Jacobian: keeps quadratic invariants.
    ImplicitMidpoint = 6,
    /// Gauss–Legendre order 4, fixed step, Newton with the exact Jacobian: symplectic.
    Gauss4 = 7,
    /// Gauss–Legendre order 6, fixed step, Newton with the exact Jacobian: symplectic.
    Gauss6 = 8,
    /// Dormand–Prince 8(5,3), adaptive step: for tight tolerances.
    Dop853 = 9,
    /// Radau IIA order 5, adaptive step, exact Jacobian: for stiff systems.
    Radau5 = 10,
    /// The exact propagator e^{Ah} of a linear time-invariant system (the floor and the
    /// reference): refused by systems that are not.
    ExactLinear = 11,
    /// RATTLE, fixed step: constrained generalised Störmer–Verlet for Lagrangian systems
    /// (symplectic, keeps holonomic constraints to rounding without projection).
    Rattle = 12,
}

impl Method {
    /// Every method, in code order (for the modelDescription enumeration).
    pub const ALL: [Method; 12] = [
        Method::Rk4,
        Method::Dopri5,
        Method::ExplicitEuler,
        Method::SymplecticEuler,
        Method::Verlet,
        Method::ImplicitMidpoint,
        Method::Gauss4,
        Method::Gauss6,
        Method::Dop853,
        Method::Radau5,
        Method::ExactLinear,
        Method::Rattle,
    ];

    /// Every method as `code = name`, in code order: "1 = RK4, 2 = DOPRI5, …".
    pub fn codes() -> String {
        Method::ALL
            .iter()
            .map(|m| format!("{} = {}", m.code(), m.name()))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The names of the methods that do (`adaptive`) or do not choose their own step.
    pub fn names_where_adaptive(adaptive: bool) -> String {
        Method::ALL
            .iter()
            .filter(|m| m.is_adaptive() == adaptive)
            .map(|m| m.name())
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The method with this `solver` code, if any.
    pub fn from_code(code: i32) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.code() == code)
    }

    /// The `solver` code of this method.
    pub fn code(self) -> i32 {
        self as i32
    }

    /// Short display name, also the enumeration item name.
    pub fn name(self) -> &'static str {
        match self {
            Method::Rk4 => "RK4",
            Method::Dopri5 => "DOPRI5",
            Method::ExplicitEuler => "ExplicitEuler",
            Method::SymplecticEuler => "SymplecticEuler",
            Method::Verlet => "Verlet",
            Method::ImplicitMidpoint => "ImplicitMidpoint",
            Method::Gauss4 => "Gauss4",
            Method::Gauss6 => "Gauss6",
            Method::Dop853 => "DOP853",
            Method::Radau5 => "RADAU5",
            Method::ExactLinear => "ExactLinear",
            Method::Rattle => "RATTLE",
        }
    }

    /// One line for the modelDescription's enumeration item.
    pub fn description(self) -> &'static str {
        match self {
            Method::Rk4 => "Classic Runge-Kutta of order 4, fixed step solver_step",
            Method::Dopri5 => "Dormand-Prince 5(4), adaptive step with a PI controller",
            Method::ExplicitEuler => "Explicit Euler, fixed step solver_step (order 1)",
            Method::SymplecticEuler => {
                "Symplectic Euler, fixed step solver_step (second-order systems)"
            }
            Method::Verlet => "Stormer-Verlet, fixed step solver_step (second-order systems)",
            Method::ImplicitMidpoint => "Implicit midpoint, fixed step solver_step, exact Jacobian",
            Method::Gauss4 => "Gauss-Legendre order 4, fixed step solver_step, exact Jacobian",
            Method::Gauss6 => "Gauss-Legendre order 6, fixed step solver_step, exact Jacobian",
            Method::Dop853 => "Dormand-Prince 8(5,3), adaptive step",
            Method::Radau5 => "Radau IIA order 5, adaptive step, exact Jacobian (stiff systems)",
            Method::ExactLinear => {
                "Exact propagator e^(Ah) in steps of solver_step (linear time-invariant systems only)"
            }
            Method::Rattle => {
                "RATTLE, fixed step solver_step: symplectic, holonomic constraints kept to rounding (Lagrangian systems only)"
            }
        }
    }

    /// Whether the step size comes from a tolerance (else it is `solver_step`).
    pub fn is_adaptive(self) -> bool {
        matches!(self, Method::Dopri5 | Method::Dop853 | Method::Radau5)
    }

    /// Whether the method needs states of the form (q, q̇) with dq/dt = q̇.
    pub fn needs_second_order(self) -> bool {
        matches!(self, Method::SymplecticEuler | Method::Verlet)
    }

    /// Whether the method needs the Jacobian ∂f/∂x.
    pub fn needs_jacobian(self) -> bool {
        matches!(
            self,
            Method::ImplicitMidpoint
                | Method::Gauss4
                | Method::Gauss6
                | Method::Radau5
                | Method::ExactLinear
        )
    }

    /// Whether the method is only valid for linear time-invariant systems.
    pub fn needs_linear_time_invariant(self) -> bool {
        self == Method::ExactLinear
    }

    /// Whether the method needs the mechanical structure of a Lagrangian
    /// ([`crate::model::System::mechanics`]).
    pub fn needs_mechanics(self) -> bool {
        self == Method::Rattle
    }
}

/// Advances with any [`Method`] (RK4, DOPRI5 and DOP853 as [`advance`] does, the others
/// through [`Problem`](problem::Problem)): the one entry point the FMU uses. Same landing and
/// failure conventions; a fixed-step method that would need more than
/// [`Settings::max_steps`] steps is refused before any work
/// ([`Failure::TooManyPlanned`]), an adaptive one gives up after that many attempts
/// ([`Failure::TooManySteps`]). [`advance_in`] in a fresh [`Workspace`].
pub fn advance_with(
    problem: &mut problem::Problem,
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    settings: &Settings,
    memory: &mut Memory,
) -> Result<(), ImplicitFailure> {
    advance_in(
        problem,
        t,
        x,
        t_end,
        settings,
        memory,
        &mut Workspace::default(),
    )
}

/// [`advance_with`] in the scratch of `work`: in steady state (the same sizes as an earlier
/// call) no method allocates (what f, the Jacobian and RATTLE's `Mechanics` do is theirs).
pub fn advance_in(
    problem: &mut problem::Problem,
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    settings: &Settings,
    memory: &mut Memory,
    work: &mut Workspace,
) -> Result<(), ImplicitFailure> {
    let method = settings.method;
    if !method.is_adaptive() {
        check_plan(settings, *t, t_end)?;
    }
    match method {
        // (RK4's plan was checked above.)
        Method::Rk4 | Method::Dopri5 | Method::Dop853 => Ok(advance_rhs(
            problem.rhs,
            (t, x),
            t_end,
            (settings, memory),
            work,
            false,
        )?),
        Method::Radau5 => {
            let work = &mut work.radau5;
            Ok(radau5::advance_in(
                problem,
                (t, x),
                t_end,
                (settings, memory),
                work,
            )?)
        }
        _ => {
            let (h, stats) = (settings.step, &mut memory.stats);
            advance_fixed(
                method,
                problem,
                FixedCall {
                    t,
                    x,
                    t_end,
                    h,
                    stats,
                },
                work,
            )
        }
    }
}

/// A fixed-step method other than RK4 for one call (its plan checked), in its part of `work`.
fn advance_fixed(
    method: Method,
    problem: &mut problem::Problem,
    call: FixedCall,
    work: &mut Workspace,
) -> Result<(), ImplicitFailure> {
    match method {
        Method::ExplicitEuler | Method::SymplecticEuler | Method::Verlet => Ok(
            explicit_fixed::advance_in(method, problem, call, &mut work.fixed)?,
        ),
        Method::ImplicitMidpoint | Method::Gauss4 | Method::Gauss6 => {
            gauss::collocation_in(method, problem, call, &mut work.gauss)
        }
        Method::ExactLinear => Ok(exact_linear::advance_in(
            problem,
            call,
            &mut work.exact_linear,
        )?),
        Method::Rattle => {
            let mech = problem
                .mechanics
                .as_deref_mut()
                .expect("RATTLE needs Problem::mechanics");
            rattle::advance_in(mech, call, &mut work.rattle)
        }
        adaptive => unreachable!("{} is adaptive", adaptive.name()),
    }
}

/// Refuses, before any work, a fixed-step call from `t` to `t_end` that would need more than
/// `settings.max_steps` steps of `settings.step` (counted as the methods count them: the last
/// one shortened, or stretched by a sliver).
fn check_plan(settings: &Settings, t: f64, t_end: f64) -> Result<(), Failure> {
    fixed_plan(settings.step, settings.max_steps, t, t_end).map(|_| ())
}

/// The fixed-step plan from `t` to `t_end` with steps of `step`, `(t_end, step, number of
/// steps)`, refused before any work when it needs more than `max_steps` steps.
#[inline(always)]
pub fn fixed_plan(
    step: f64,
    max_steps: u64,
    t: f64,
    t_end: f64,
) -> Result<(f64, f64, u64), Failure> {
    let planned = problem::step_count(t_end - t, step);
    if planned == 1.0 && max_steps >= 1 {
        return Ok((t_end, step, 1)); // (a doStep of one solver step: no count converted)
    }
    if planned > max_steps as f64 {
        return Err(Failure::TooManyPlanned {
            t,
            planned,
            step,
            max: max_steps,
        });
    }
    // (planned ≤ max_steps < 2⁶⁴ here; through i64 as in `step_count`.)
    Ok((t_end, step, planned as i64 as u64))
}

/// RK4 from `*t` to `t_end` with `step`, at most `max_steps` steps (refused before any
/// work), monomorphised on the right-hand side: the FMU's fixed-step doStep, where a `dyn`
/// call per stage and the method dispatch of [`advance_in`] cost more than the equations of
/// a small system. The same arithmetic as [`advance_in`] with [`Method::Rk4`], bit for bit.
pub fn rk4_fixed<F: rk4::Rhs>(
    rhs: &mut F,
    (t, x): (&mut f64, &mut [f64]),
    t_end: f64,
    (step, max_steps): (f64, u64),
    stats: &mut Stats,
    work: &mut Workspace,
) -> Result<(), Failure> {
    let plan = fixed_plan(step, max_steps, *t, t_end)?;
    // The sizes of the systems here on the stack (more states take the buffers of `work`).
    macro_rules! sized_for {
        ($($n:literal)*) => {
            match x.len() {
                $($n => rk4::advance_sized::<$n, F>(rhs, (t, x.try_into().expect("n")), plan, stats),)*
                _ => rk4::advance_in(rhs, t, x, t_end, step, stats, &mut work.rk4),
            }
        };
    }
    sized_for!(2 4 6 7 8)
}

/// What the caller chooses for one call of [`advance`].
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    pub method: Method,
    /// Relative tolerance (adaptive methods).
    pub rtol: f64,
    /// Absolute tolerance per state component (adaptive methods). Must have one entry per
    /// state for DOPRI5, and `atol[i] + rtol·|x[i]|` must stay positive.
    pub atol: Vec<f64>,
    /// Fixed step of RK4; upper bound on the step of DOPRI5 (infinite: no bound).
    /// A value that is not positive and finite means "no step": RK4 then takes one step over
    /// the whole interval, DOPRI5 has no upper bound.
    pub step: f64,
    /// Most steps one call may take: attempts (accepted + rejected) of the adaptive methods,
    /// planned steps of the fixed-step ones (refused before any work). Bounds the time one
    /// `fmi2DoStep` can take (the FMU's `solver_max_steps`); [`MAX_STEPS`] for Rust callers
    /// that have no such bound to honour.
    pub max_steps: u64,
}

impl Settings {
    /// The largest step of an adaptive method: `step` if positive and finite, else none (∞).
    pub fn max_step(&self) -> f64 {
        if self.step > 0.0 && self.step.is_finite() {
            self.step
        } else {
            f64::INFINITY
        }
    }
}

/// Counters: noise-free measures of work. Part of the FMU state.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stats {
    /// Every evaluation of the right-hand side, including those of failed steps.
    pub rhs_evals: u64,
    /// Accepted steps.
    pub steps: u64,
    /// Rejected steps (error estimate above tolerance); always 0 for RK4.
    pub rejected: u64,
    /// Evaluations of the exact Jacobian ∂f/∂x (the implicit methods and ExactLinear).
    pub jacobians: u64,
    /// Not a counter: the [`Stats::work`] at which the running call stops with
    /// [`Failure::TooMuchWork`] (0: no bound). Set by the caller for one call (the FMU: one
    /// doStep's work bound); not part of the FMU state, ignored by `==`.
    pub work_limit: u64,
}

impl PartialEq for Stats {
    fn eq(&self, other: &Self) -> bool {
        let counters = |s: &Stats| (s.rhs_evals, s.steps, s.rejected, s.jacobians);
        counters(self) == counters(other)
    }
}

impl Eq for Stats {}

/// What one evaluation of the exact Jacobian counts in [`Stats::work`], in evaluations of f:
/// `JACOBIAN_EVALS · n`. Dual numbers evaluate f once per column at a few times its cost:
/// 1.4–5.4 n evaluations of f measured on every system here (`mbfmu speed`,
/// docs/bench/speed.csv, column jacobian_over_n_rhs).
pub const JACOBIAN_EVALS: u64 = 6;

impl Stats {
    /// The work done so far by a problem of `n` states, in state-component evaluations: an
    /// evaluation of f counts `n` (the cost of f grows at least with the states it
    /// computes), a Jacobian `JACOBIAN_EVALS · n²`. Deterministic: counts, not time.
    pub fn work(&self, n: usize) -> u64 {
        let n = n as u64;
        let jacobian = JACOBIAN_EVALS.saturating_mul(n).saturating_mul(n);
        n.saturating_mul(self.rhs_evals)
            .saturating_add(jacobian.saturating_mul(self.jacobians))
    }

    /// Fails with [`Failure::TooMuchWork`] at `t` once the work bound of this call is
    /// reached (checked before each step or attempt).
    #[inline]
    pub fn check_work(&self, t: f64, n: usize) -> Result<(), Failure> {
        if self.work_limit != 0 && self.work(n) >= self.work_limit {
            return Err(Failure::TooMuchWork { t });
        }
        Ok(())
    }
}

/// What an integrator carries from one call of `advance` to the next.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Memory {
    /// The controller's step-size proposal carried across calls; 0 = none yet (choose an initial step).
    /// The adaptive methods use it; the fixed-step ones leave it alone. Reset to 0 when a call fails, so a retry
    /// starts from a fresh estimate instead of a step that has just proved hopeless.
    pub h: f64,
    pub stats: Stats,
    /// The running method's point ahead of the communication time, in dense-output mode
    /// (see [`Ahead`]); `None` in every other mode and whenever f has changed.
    pub ahead: Option<Ahead>,
    /// DOPRI5's stiffness detection (see [`dopri5::StiffnessMonitor`]).
    pub stiffness: dopri5::StiffnessMonitor,
}

impl Memory {
    /// Forgets the point ahead of the communication time: f changed (an input), or the
    /// mode or method that kept it is not the one running.
    #[inline]
    pub fn drop_ahead(&mut self) {
        // (Tested first: the fixed-step doStep calls this each step, and has none to drop.)
        if self.ahead.is_some() {
            self.ahead = None;
        }
    }

    /// Where DOPRI5 first found the problem stiff, once: a second call says `None`.
    pub fn take_stiffness_report(&mut self) -> Option<f64> {
        let at = self.stiffness.detected_at.take();
        self.stiffness.reported |= at.is_some();
        at
    }

    /// Appends this memory to an FMU state: the step proposal, the counters, then each
    /// method's own block (the stiffness monitor, the point ahead).
    pub(crate) fn write(&self, b: &mut Vec<u8>) {
        blob::put_f64(b, self.h);
        let s = self.stats;
        for v in [s.rhs_evals, s.steps, s.rejected, s.jacobians] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        self.stiffness.write(b);
        Ahead::write(self.ahead.as_ref(), b);
    }

    /// Reads what [`Memory::write`] wrote for `n` states, each block checked by its owner.
    pub(crate) fn read(r: &mut blob::Reader, n: usize) -> Result<Memory, String> {
        let h = r.f64()?;
        let stats = Stats {
            rhs_evals: r.u64()?,
            steps: r.u64()?,
            rejected: r.u64()?,
            jacobians: r.u64()?,
            work_limit: 0,
        };
        let stiffness = dopri5::StiffnessMonitor::read(r)?;
        let ahead = Ahead::read(r, n)?;
        Ok(Memory {
            h,
            stats,
            ahead,
            stiffness,
        })
    }
}

/// Why [`advance`] stopped early. In every case the state was left at the last accepted step.
#[derive(Clone, Debug, PartialEq)]
pub enum Failure {
    /// The step attempted from `t` (the last accepted time) produced a NaN or infinity,
    /// in a stage derivative or in the new state (or the state was already non-finite).
    NonFinite { t: f64 },
    /// The step-size controller asked for a step `h` below the smallest step that still
    /// moves `t` meaningfully: typically a singularity or discontinuity near `t`.
    StepTooSmall { t: f64, h: f64 },
    /// The call took [`Settings::max_steps`] attempts (accepted + rejected) and was not done.
    TooManySteps { t: f64, steps: u64 },
    /// A fixed-step method would need `planned` steps of `step` from `t`, more than
    /// [`Settings::max_steps`] = `max`: refused before taking any.
    TooManyPlanned {
        t: f64,
        planned: f64,
        step: f64,
        max: u64,
    },
    /// The call reached the work bound its caller set ([`Stats::work_limit`]) at `t`, the
    /// last accepted time.
    TooMuchWork { t: f64 },
}

impl Failure {
    /// Whether the call stopped at its step limit ([`Settings::max_steps`]) rather than on a
    /// numerical failure: a larger limit or a shorter call would get through.
    pub fn is_step_limit(&self) -> bool {
        matches!(
            self,
            Failure::TooManySteps { .. } | Failure::TooManyPlanned { .. }
        )
    }

    /// Whether the call stopped at the work bound of [`Stats::work_limit`].
    pub fn is_work_limit(&self) -> bool {
        matches!(self, Failure::TooMuchWork { .. })
    }
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Failure::NonFinite { t } => {
                write!(f, "state became non-finite in the step after t = {t} s")
            }
            Failure::StepTooSmall { t, h } => write!(
                f,
                "step size {h:e} s became too small at t = {t} s (singularity or discontinuity?)"
            ),
            Failure::TooManySteps { t, steps } => write!(
                f,
                "gave up at t = {t} s after {steps} steps in one communication step"
            ),
            Failure::TooManyPlanned {
                t,
                planned,
                step,
                max,
            } => write!(
                f,
                "refused to plan {planned} fixed steps of {step:e} s from t = {t} s, more than the limit of {max}: took none"
            ),
            Failure::TooMuchWork { t } => {
                write!(f, "gave up at t = {t} s: the work bound was spent")
            }
        }
    }
}

impl std::error::Error for Failure {}

/// [`Settings::max_steps`] for Rust callers without a bound of their own (the FMU takes its
/// `solver_max_steps` instead, default [`crate::model::DEFAULT_SOLVER_MAX_STEPS`]).
pub const MAX_STEPS: u64 = 1_000_000;

/// Advance `x` from `*t` to exactly `t_end` (> *t). On success `*t == t_end` bit for bit
/// (the last internal step is shortened to land on t_end, never overshoots).
/// On failure, `*t` and `x` hold the last accepted (finite) step, and the error says why.
///
/// `t_end == *t` is a no-op. Panics if `t_end < *t` or either is NaN: that is a caller bug,
/// not a numerical failure.
pub fn advance(
    rhs: &mut dyn FnMut(f64, &[f64], &mut [f64]),
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    settings: &Settings,
    memory: &mut Memory,
) -> Result<(), Failure> {
    let work = &mut Workspace::default();
    advance_rhs(rhs, (t, x), t_end, (settings, memory), work, true)
}

/// [`advance`] in the scratch of `work`; RK4's plan is checked if `plan` (else the caller
/// did).
fn advance_rhs(
    rhs: &mut dyn FnMut(f64, &[f64], &mut [f64]),
    (t, x): (&mut f64, &mut [f64]),
    t_end: f64,
    (settings, memory): (&Settings, &mut Memory),
    work: &mut Workspace,
    plan: bool,
) -> Result<(), Failure> {
    assert!(
        t_end >= *t,
        "integrators::advance: t_end = {t_end} must not precede t = {}",
        *t
    );
    if t_end == *t {
        return Ok(());
    }
    // A non-finite start would poison every step; report it before spending work.
    if !x.iter().all(|v| v.is_finite()) {
        return Err(Failure::NonFinite { t: *t });
    }
    match settings.method {
        Method::Rk4 => {
            if plan {
                check_plan(settings, *t, t_end)?;
            }
            let stages = &mut work.rk4;
            rk4::advance_in(rhs, t, x, t_end, settings.step, &mut memory.stats, stages)
        }
        Method::Dopri5 => land::<Dopri5>(rhs, (t, x), t_end, settings, memory, &mut work.dopri5),
        Method::Dop853 => {
            let work = &mut work.dop853.rk;
            land::<Dop853>(rhs, (t, x), t_end, settings, memory, work)
        }
        other => panic!(
            "integrators::advance runs RK4, DOPRI5 and DOP853; {} needs advance_with and a \
             Problem",
            other.name()
        ),
    }
}

#[cfg(test)]
pub(crate) mod test_support {
    use super::problem::{DenseCall, Problem};
    use super::{ImplicitFailure, Memory, Method, Settings, Stats, Workspace, MAX_STEPS};

    /// The settings of a fixed-step `method` with step `step` (no tolerances).
    pub fn settings(method: Method, step: f64) -> Settings {
        Settings {
            method,
            rtol: 0.0,
            atol: vec![],
            step,
            max_steps: MAX_STEPS,
        }
    }

    /// The settings of an adaptive `method` with `rtol = tol` and `atol = tol` for each of
    /// `n` states, its steps at most `step`.
    pub fn adaptive(method: Method, tol: f64, n: usize, step: f64) -> Settings {
        Settings {
            method,
            rtol: tol,
            atol: vec![tol; n],
            step,
            max_steps: MAX_STEPS,
        }
    }

    /// `x' = 1`.
    pub fn one(_: f64, _: &[f64], d: &mut [f64]) {
        d[0] = 1.0;
    }

    /// `x' = −x`.
    pub fn decay(_: f64, y: &[f64], d: &mut [f64]) {
        d[0] = -y[0];
    }

    /// `x' = x²`, which blows up at t = 1 from x(0) = 1.
    pub fn square(_: f64, y: &[f64], d: &mut [f64]) {
        d[0] = y[0] * y[0];
    }

    /// `x' = −x` that breaks down after t = 0.5 (NaN): where a method must stop.
    pub fn broken_decay(t: f64, y: &[f64], d: &mut [f64]) {
        d[0] = if t > 0.5 { f64::NAN } else { -y[0] };
    }

    /// A dense-mode call with no projection, for the tests of each method's dense output.
    pub fn dense_call<'c, 'p, W>(
        problem: &'c mut Problem<'p>,
        ends: (f64, f64),
        run: (&'c Settings, &'c mut Memory),
        buffers: (&'c mut [f64], &'c mut W),
    ) -> DenseCall<'c, 'p, W> {
        // (A closure that captures nothing: boxing and leaking it allocates nothing.)
        let project = Box::leak(Box::new(|_: f64, _: &mut [f64]| {}));
        DenseCall::new(problem, project, ends, run, buffers)
    }

    /// A fixed-step `method` from `*t` to `t_end` in steps of `h`, as the FMU runs it
    /// ([`super::advance_in`]) but in a fresh workspace, with no step limit, counting into
    /// `stats`: how the tests call one method.
    pub fn fixed(
        method: Method,
        problem: &mut Problem,
        (t, x): (&mut f64, &mut [f64]),
        (t_end, h): (f64, f64),
        stats: &mut Stats,
    ) -> Result<(), ImplicitFailure> {
        let settings = Settings {
            max_steps: u64::MAX,
            ..settings(method, h)
        };
        let mut memory = Memory {
            stats: *stats,
            ..Memory::default()
        };
        let work = &mut Workspace::default();
        let result = super::advance_in(problem, t, x, t_end, &settings, &mut memory, work);
        *stats = memory.stats;
        result
    }

    /// Harmonic oscillator x'' = -ω² x as the first-order system (x, v).
    pub const OMEGA: f64 = 10.0;

    pub fn oscillator(_t: f64, y: &[f64], dy: &mut [f64]) {
        dy[0] = y[1];
        dy[1] = -OMEGA * OMEGA * y[0];
    }

    /// Closed form from x(0) = 1, v(0) = 0.
    pub fn oscillator_exact(t: f64) -> [f64; 2] {
        [(OMEGA * t).cos(), -OMEGA * (OMEGA * t).sin()]
    }

    /// Error in the energy-consistent scale: position error and velocity error / ω,
    /// so both components weigh the same for amplitude 1.
    pub fn oscillator_error(t: f64, y: &[f64]) -> f64 {
        let e = oscillator_exact(t);
        (y[0] - e[0]).abs().max((y[1] - e[1]).abs() / OMEGA)
    }
}

#[cfg(test)]
mod tests {
    use super::test_support::one;
    use super::*;

    #[test]
    fn method_codes_round_trip() {
        assert_eq!(Method::from_code(1), Some(Method::Rk4));
        assert_eq!(Method::from_code(2), Some(Method::Dopri5));
        assert_eq!(Method::from_code(0), None);
        assert_eq!(Method::from_code(13), None);
        assert_eq!(Method::from_code(12), Some(Method::Rattle));
        assert_eq!(Method::from_code(11), Some(Method::ExactLinear));
        assert_eq!(Method::from_code(10), Some(Method::Radau5));
        for m in Method::ALL {
            assert_eq!(Method::from_code(m.code()), Some(m));
        }
        assert_eq!(Method::Rk4.name(), "RK4");
        assert_eq!(Method::Dopri5.name(), "DOPRI5");
        let codes = Method::codes();
        assert!(
            codes.starts_with("1 = RK4, 2 = DOPRI5, 3 = ExplicitEuler"),
            "{codes}"
        );
        assert!(codes.ends_with("11 = ExactLinear, 12 = RATTLE"), "{codes}");
        assert_eq!(Method::names_where_adaptive(true), "DOPRI5, DOP853, RADAU5");
    }

    #[test]
    fn failure_display_is_one_line() {
        let all = [
            Failure::NonFinite { t: 1.234 },
            Failure::StepTooSmall { t: 0.999, h: 1e-15 },
            Failure::TooManySteps {
                t: 2.0,
                steps: MAX_STEPS,
            },
            Failure::TooManyPlanned {
                t: 0.0,
                planned: 1e9,
                step: 1e-3,
                max: 100_000,
            },
        ];
        for f in &all {
            let s = f.to_string();
            assert!(!s.contains('\n') && s.contains("t = "), "{s}");
        }
        assert_eq!(
            Failure::NonFinite { t: 1.234 }.to_string(),
            "state became non-finite in the step after t = 1.234 s"
        );
        // A refusal says it took no step (it used to read "gave up at t = 0 s after
        // 1000000000 steps").
        assert_eq!(
            all[3].to_string(),
            "refused to plan 1000000000 fixed steps of 1e-3 s from t = 0 s, more than the limit of 100000: took none"
        );
        assert!(all.iter().filter(|f| f.is_step_limit()).count() == 2);
    }

    #[test]
    fn non_finite_start_fails_without_work() {
        for method in Method::ALL {
            let settings = Settings {
                method,
                rtol: 1e-6,
                atol: vec![1e-6],
                step: 0.1,
                max_steps: MAX_STEPS,
            };
            let mut memory = Memory::default();
            let (mut t, mut x) = (0.0, [f64::NAN]);
            let r = advance(&mut one, &mut t, &mut x, 1.0, &settings, &mut memory);
            assert_eq!(r, Err(Failure::NonFinite { t: 0.0 }));
            assert_eq!(memory.stats, Stats::default());
        }
    }

    #[test]
    fn zero_length_interval_is_a_no_op() {
        for method in Method::ALL {
            let settings = Settings {
                method,
                rtol: 1e-6,
                atol: vec![1e-6],
                step: 0.1,
                max_steps: MAX_STEPS,
            };
            let mut memory = Memory::default();
            let (mut t, mut x) = (1.0, [2.0]);
            advance(&mut one, &mut t, &mut x, 1.0, &settings, &mut memory).unwrap();
            assert_eq!((t, x[0]), (1.0, 2.0));
            assert_eq!(memory, Memory::default());
        }
    }
}
