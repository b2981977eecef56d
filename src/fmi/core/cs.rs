//! The Co-Simulation front-end: fmi2DoStep around an integrator (the fixed-step fast path,
//! the general path with dense output and event location), input and output derivatives,
//! and the status queries, on the shared [`Instance`] core.

use super::info::Status;
use super::inputs::{self, Inputs, MAX_INPUT_DERIVATIVE_ORDER};
use super::mode::Mode;
use super::snapshot::Snapshot;
use super::{crossed, Instance, Res};
use crate::integrators::problem::Problem;
use crate::integrators::{
    self, all_finite, copied, finite, problem::Mechanics, sized, Memory, Method, Settings,
    Workspace,
};
use crate::model::jacobian::{self, Duals, Moving};
use crate::model::{Layout, System, VarKind};
use std::marker::PhantomData;

/// Why an integration inside doStep stopped early: the reason (one line), and whether it
/// was the step limit (`solver_max_steps`), which the importer can raise.
pub(super) struct Stop {
    reason: String,
    step_limit: bool,
    /// The work bound of one doStep ([`DOSTEP_WORK`]) was spent.
    work_limit: bool,
}

impl Stop {
    /// A bound stopped it (steps or work), not the numerics.
    fn bounded(&self) -> bool {
        self.step_limit || self.work_limit
    }
}

impl From<integrators::Failure> for Stop {
    fn from(f: integrators::Failure) -> Self {
        Stop {
            step_limit: f.is_step_limit(),
            work_limit: f.is_work_limit(),
            reason: f.to_string(),
        }
    }
}

impl From<integrators::ImplicitFailure> for Stop {
    fn from(f: integrators::ImplicitFailure) -> Self {
        Stop {
            step_limit: f.is_step_limit(),
            work_limit: f.is_work_limit(),
            reason: f.to_string(),
        }
    }
}

/// The work bound of one doStep, in state-component evaluations ([`integrators::Stats::work`]:
/// an evaluation of f counts n, a Jacobian 6n²): deterministic, and at most about half a
/// second on the costliest system here (measured in docs/methods.md, "How long a doStep may
/// take").
/// `solver_max_steps` bounds the steps; this bounds what they cost (a 16-state RADAU5 step
/// with its Jacobian costs a hundred evaluations of f).
pub const DOSTEP_WORK: u64 = 5_000_000;

/// How a doStep ended when it did not fail on its arguments.
#[derive(Debug, PartialEq)]
pub enum StepOutcome {
    Completed,
    /// The integration failed inside the step; the state is the last good one.
    Discarded(String),
}

/// `settings` (of a [`Work`](super::Work)) for the values in `d`: method, tolerances (`atol` = tolerance
/// × the state's nominal), the step (`adaptive_max_step` for the adaptive methods) and the
/// step limit.
fn prepared<'a>(
    settings: &'a mut Option<Settings>,
    d: &Snapshot,
    layout: &Layout,
    adaptive_max_step: f64,
) -> &'a Settings {
    let stale = !matches!(settings, Some(s) if s.rtol.to_bits() == d.tolerance.to_bits());
    if stale {
        let atol = (0..layout.n_states)
            .map(|i| {
                let vr = layout.vr_of_slot(VarKind::State, i) as usize;
                d.tolerance * layout.vars[vr].1.nominal.unwrap_or(1.0)
            })
            .collect();
        *settings = Some(Settings {
            method: d.method,
            rtol: d.tolerance,
            atol,
            step: 0.0,
            max_steps: 0,
        });
    }
    let s = settings.as_mut().expect("just prepared");
    s.method = d.method;
    // The step parameter is the fixed step of fixed-step methods; adaptive ones are
    // bounded only by the communication interval in landing mode (and by
    // `cap_adaptive_step`, unbounded for importers).
    s.step = if d.method.is_adaptive() {
        adaptive_max_step
    } else {
        d.solver_step
    };
    s.max_steps = d.max_steps;
    s
}

impl<M: System> Instance<M> {
    /// What doStep works with, prepared once at fmi2ExitInitializationMode.
    pub(super) fn prepare_steps(&mut self) {
        let settings = &mut self.work.get_mut().settings;
        prepared(
            settings,
            &self.data,
            &self.info.layout,
            self.adaptive_max_step,
        );
    }

    /// fmi2DoStep: from the held state at `current` to `current + h`.
    #[inline]
    pub fn do_step(&mut self, current: f64, h: f64) -> Res<StepOutcome> {
        let t_end = self.check_step(current, h)?;
        let d = &self.data;
        if d.method == Method::Rk4
            && !inputs::moving(&d.u_der)
            && M::event_indicator(current, &d.x, &d.u, &d.params).is_none()
        {
            // The sizes of the systems here on the stack (other sizes: `integrate`).
            macro_rules! sized_for {
                ($($n:literal)*) => {
                    match d.x.len() {
                        $($n => return Ok(self.fixed_step::<$n>(current, t_end)),)*
                        _ => {}
                    }
                };
            }
            sized_for!(2 4 6 7 8);
        }
        let work = self.stats().work(self.data.x.len());
        let (t, result) = self.integrate(current, t_end);
        self.report_stiffness();
        if self.logger.debug_enabled() {
            self.log_work(work);
        }
        // Stopped after an event (`stop_at_event`): the step ends there.
        let early = self.work.get_mut().stop_at_event && result.is_ok() && t < t_end;
        let t_end = if early { t } else { t_end };
        Ok(self.settle(current, t_end, t, result))
    }

    /// doStep as [`Instance::do_step`], but ending right after the first event inside the
    /// step (the event applied, the state and time there): FMI 3.0's early return. The time
    /// reached is [`Instance::time`]; `current + h` when no event came.
    pub fn do_step_until_event(&mut self, current: f64, h: f64) -> Res<StepOutcome> {
        self.work.get_mut().stop_at_event = true;
        let outcome = self.do_step(current, h);
        self.work.get_mut().stop_at_event = false;
        outcome
    }

    /// The work of the doStep that began with `before` done (logAll), for importers and
    /// tests that check the bound by counting.
    #[cold]
    fn log_work(&self, before: u64) {
        let done = self.stats().work(self.data.x.len()) - before;
        self.logger.debug(&format!(
            "work {done} state-component evaluations (bound {})",
            DOSTEP_WORK
        ));
    }

    /// The fixed-step doStep, on one screen: RK4 with held inputs and no event, the state's
    /// `N` components on the stack, the right-hand side inlined into the stages ([`Held`]),
    /// nothing assembled. The general path's numbers, bit for bit (tested).
    #[inline(always)]
    fn fixed_step<const N: usize>(&mut self, current: f64, t_end: f64) -> StepOutcome {
        // (No point ahead to drop: only the adaptive methods make one, and the method is
        // fixed from fmi2ExitInitializationMode on; a restored FMU state brings its own.)
        let (d, work) = (&mut self.data, self.work.get_mut());
        let (u, p) = (&d.u[..], &d.params[..]);
        let mut x: [f64; N] = d.x[..].try_into().expect("N states");
        let mut t = current;
        let result = integrators::fixed_plan(d.solver_step, d.max_steps, t, t_end)
            .and_then(|plan| {
                let mut rhs = Held::<M> {
                    u,
                    p,
                    model: PhantomData,
                };
                integrators::rk4::advance_sized(
                    &mut rhs,
                    (&mut t, &mut x),
                    plan,
                    &mut d.memory.stats,
                )
            })
            .map_err(Stop::from);
        if result.is_ok() {
            M::project(t, p, &mut x);
        }
        let outputs = (&mut work.y, &mut work.u_at[0]);
        let layout = &self.info.layout;
        settle_state::<M>(d, layout, (current, t_end), (t, &x, result), outputs, true)
    }

    /// The checks of a doStep before any work (its arguments; the front-end checked the state); the step's end.
    #[inline]
    fn check_step(&self, current: f64, h: f64) -> Res<f64> {
        let (now, t_end) = (self.data.time, current + h);
        let slack = 1e-9 * now.abs().max(1.0);
        let beyond_stop = |stop: f64| t_end > stop + 1e-9 * stop.abs().max(1.0);
        if !(finite(h) && h > 0.0 && finite(current))
            || (current - now).abs() > slack
            || self.data.stop_time.is_some_and(beyond_stop)
        {
            return Err(step_refused(current, h, now, self.data.stop_time));
        }
        Ok(t_end)
    }

    /// Integrates the held state from `current` to `t_end` into the scratch (`work.x`):
    /// the time reached (`t_end` on success, else the last good internal step) and how it
    /// ended. The state is projected onto the constraints when the integration succeeded.
    /// The adaptive methods run ahead of the communication points with dense output,
    /// unless an event may come (events are located on landing steps).
    /// Inputs with derivatives set move along their polynomial from `current`
    /// ([`Inputs`]).
    fn integrate(&mut self, current: f64, t_end: f64) -> (f64, Result<(), Stop>) {
        let d = &mut self.data;
        let work = self.work.get_mut();
        let stats = &mut d.memory.stats;
        stats.work_limit = stats.work(d.x.len()).saturating_add(DOSTEP_WORK);
        let (u, p) = (&d.u, &d.params);
        let (mut t, x) = (current, copied(&mut work.x, &d.x));
        let result = if d.method == Method::Rk4 && M::event_indicator(t, x, u, p).is_none() {
            // RK4 where `fixed_step` does not go (inputs that move, or a state larger than
            // it keeps on the stack): no settings, no `dyn` (the right-hand side inlines
            // into the stages), no problem to assemble (and no point ahead: see `fixed_step`).
            let plan = (d.solver_step, d.max_steps);
            let (stats, scratch) = (&mut d.memory.stats, &mut work.integrators);
            let inputs = Inputs::new(u, &d.u_der, current);
            if inputs.moving() {
                let buf = &mut work.u_at[0];
                let mut rhs = |t: f64, x: &[f64], dx: &mut [f64]| {
                    M::derivatives(t, x, inputs.at(t, buf), p, dx)
                };
                integrators::rk4_fixed(&mut rhs, (&mut t, x), t_end, plan, stats, scratch)
            } else {
                let mut rhs = Held::<M> {
                    u,
                    p,
                    model: PhantomData,
                };
                integrators::rk4_fixed(&mut rhs, (&mut t, x), t_end, plan, stats, scratch)
            }
            .map_err(Stop::from)
        } else {
            let settings = prepared(
                &mut work.settings,
                d,
                &self.info.layout,
                self.adaptive_max_step,
            );
            let scratch = (&mut work.x0, &mut work.duals, &mut work.integrators);
            let stop_at_event = work.stop_at_event;
            integrate_general::<M>(
                d,
                (&mut t, x),
                (t_end, stop_at_event),
                settings,
                scratch,
                &mut work.u_at,
            )
        };
        d.memory.stats.work_limit = 0;
        if result.is_ok() {
            M::project(t, &d.params, x);
        }
        (t, result)
    }

    /// DOPRI5's stiffness detection, reported once (a warning).
    fn report_stiffness(&mut self) {
        if let Some(at) = self.data.memory.take_stiffness_report() {
            self.logger.failure(
                Status::Warning,
                &format!(
                    "DOPRI5: the problem seems stiff from t = {at} s (15 steps in a row at the stability limit h|λ| > 3.25): steps are set by stability, not the tolerance; RADAU5 (solver = 10) may need far fewer"
                ),
            );
        }
    }

    /// The end of a doStep from `current` to `t_end` that reached `t` with `result` (the
    /// state in `work.x`): [`settle_state`], then moving inputs move to the time reached.
    fn settle(
        &mut self,
        current: f64,
        t_end: f64,
        t: f64,
        result: Result<(), Stop>,
    ) -> StepOutcome {
        let (d, work) = (&mut self.data, self.work.get_mut());
        let (reached, outputs) = ((t, &work.x[..], result), (&mut work.y, &mut work.u_at[0]));
        let layout = &self.info.layout;
        let outcome = settle_state::<M>(d, layout, (current, t_end), reached, outputs, false);
        if d.time != current && inputs::moving(&d.u_der) {
            inputs::advance(&mut d.u, &mut d.u_der, d.time - current);
        }
        outcome
    }

    /// fmi2SetRealInputDerivatives: the inputs' time derivatives of order 1 or 2 at the
    /// communication point; the next doStep integrates with the polynomial input they
    /// make ([`Inputs`]). A changed derivative changes f over the step: the integrator's
    /// point ahead no longer holds (as for a changed input).
    pub fn set_input_derivatives(&mut self, vrs: &[u32], orders: &[i32], values: &[f64]) -> Res {
        let mut der = self.data.u_der.clone();
        for ((&vr, &order), &value) in vrs.iter().zip(orders).zip(values) {
            let slot = self.slot(vr)?;
            if slot.kind != VarKind::Input {
                return Err(format!(
                    "{} (value reference {vr}) is not an input",
                    self.name(vr)
                ));
            }
            if !(1..=MAX_INPUT_DERIVATIVE_ORDER).contains(&order) {
                return Err(format!(
                    "order {order} for {} is not in 1 … {MAX_INPUT_DERIVATIVE_ORDER}",
                    self.name(vr)
                ));
            }
            if !value.is_finite() {
                return Err(format!(
                    "derivative {value} of order {order} for {} is not finite",
                    self.name(vr)
                ));
            }
            der[order as usize - 1][slot.index] = value;
        }
        let bits = |d: &[Vec<f64>; 2]| d.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
        if bits(&der) != bits(&self.data.u_der) {
            self.data.memory.drop_ahead();
        }
        self.data.u_der = der;
        Ok(())
    }

    /// fmi2GetRealOutputDerivatives: exact time derivatives of outputs (states and extra
    /// outputs) at the current time, along the trajectory with the inputs' derivatives
    /// ([`jacobian::rates`]). An order that would need ∂/∂t of a model that reads t with
    /// these parameters is refused, never approximated.
    pub fn output_derivatives(&self, vrs: &[u32], orders: &[i32], values: &mut [f64]) -> Res {
        let max = jacobian::output_derivative_order::<M>();
        let d = &self.data;
        let (f_reads_t, g_reads_t) = M::explicit_time(&d.params);
        for (&vr, &order) in vrs.iter().zip(orders) {
            let slot = self.slot(vr)?;
            let name = self.name(vr);
            if !matches!(slot.kind, VarKind::State | VarKind::Output) {
                return Err(format!("{name} (value reference {vr}) is not an output"));
            }
            if !(1..=max).contains(&order) {
                return Err(format!(
                    "order {order} for {name} is not in 1 … {max} (maxOutputDerivativeOrder = {max})"
                ));
            }
            let needs_f_t = order == 2;
            let needs_g_t = slot.kind == VarKind::Output;
            if (needs_f_t && f_reads_t) || (needs_g_t && g_reads_t) {
                return Err(format!(
                    "the derivative of order {order} of {name} needs ∂/∂t of a model that reads t explicitly with these parameters; not available exactly"
                ));
            }
        }
        let rates = jacobian::rates::<M>(
            &Moving {
                t: d.time,
                x: &d.x,
                u: [&d.u, &d.u_der[0], &d.u_der[1]],
                p: &d.params,
            },
            self.info.layout.n_outputs,
        );
        for ((out, &vr), &order) in values.iter_mut().zip(vrs).zip(orders) {
            let slot = self.info.layout.vars[vr as usize].0;
            let i = slot.index;
            *out = match (slot.kind, order) {
                (VarKind::State, 1) => rates.x1[i],
                (VarKind::State, _) => rates.x2[i],
                (_, 1) => rates.y1[i],
                _ => rates.y2[i],
            };
        }
        Ok(())
    }

    /// The time of the last successful step (lastSuccessfulTime).
    pub fn last_successful_time(&self) -> f64 {
        self.data.time
    }
}

/// Most events handled inside one doStep before it gives up (a chattering model).
const MAX_EVENTS_PER_STEP: usize = 100;

/// How far past the communication point the methods with dense output may run ahead when
/// no stop time bounds them: as far again as the time simulated so far, and at least this
/// many communication steps. A step the error estimate cannot judge (zero for a solution
/// the method integrates exactly: a free mass under a held force) is accepted and the next
/// one proposed ten times longer, without end when nothing bounds it (steps of 1e45 s were
/// seen); the state at the communication point was then read off a step whose end was so
/// large that rounding swamped it (0.54 m wrong, then fmi2Discard). A step no longer than
/// the time behind it keeps a step's end within a few times the state it starts from (for
/// a polynomial motion) and leaves the run-ahead its gain. With a stop time the steps stay
/// bounded by it, as in Hairer's codes, and do not depend on the communication grid
/// (tests/dense_common).
const RUN_AHEAD: f64 = 1000.0;

/// Bisection halvings of the interval that holds an event: stops earlier when the
/// midpoint can no longer be told from an end point in floating point.
const MAX_BISECTIONS: usize = 200;
/// Every method but plain RK4 (see [`Instance::integrate`]): the problem with its exact
/// Jacobian and mechanical structure; the adaptive methods run ahead with dense output
/// unless an event may come (events are located on landing steps).
fn integrate_general<M: System>(
    d: &mut Snapshot,
    (t, x): (&mut f64, &mut [f64]),
    (t_end, stop_at_event): (f64, bool),
    settings: &Settings,
    (x0, duals, work): (&mut Vec<f64>, &mut Duals, &mut Workspace),
    [u_rhs, u_jac, u_event]: &mut [Vec<f64>; 3],
) -> Result<(), Stop> {
    let (u, p) = (&d.u, &d.params);
    // The inputs from the communication point (moving ones: a buffer per closure).
    let inputs = Inputs::new(u, &d.u_der, *t);
    let mut rhs =
        |t: f64, x: &[f64], dx: &mut [f64]| M::derivatives(t, x, inputs.at(t, u_rhs), p, dx);
    // ∂f/∂x column by column with dual numbers (exact), row-major for the methods.
    let mut jacobian =
        |t: f64, x: &[f64], jac: &mut [f64]| duals.jacobian::<M>(t, x, inputs.at(t, u_jac), p, jac);
    let mut mechanics = if !d.method.needs_mechanics() {
        None
    } else if inputs.moving() {
        M::mechanics(u, p).map(|held| {
            let moving = MovingInputs::<M> {
                held,
                inputs,
                p,
                u: Vec::new(),
                model: PhantomData,
            };
            Box::new(moving) as Box<dyn Mechanics>
        })
    } else {
        M::mechanics(u, p)
    };
    let mut defect = |t: f64, x: &[f64], out: &mut [f64]| M::constraint_defect(t, p, x, out);
    let n = d.x.len();
    let mut problem = Problem {
        rhs: &mut rhs,
        jacobian: Some(&mut jacobian),
        second_order: M::second_order().then_some(n / 2),
        // (the cast shortens the trait object's lifetime to the borrow's)
        mechanics: mechanics.as_deref_mut().map(|m| m as &mut dyn Mechanics),
        inputs_move: inputs.moving(),
        error_on_manifold: M::error_on_manifold(),
        defect: M::error_on_manifold().then_some(&mut defect),
    };
    let memory = &mut d.memory;
    // Dense output runs past the communication point with this step's f: with moving
    // inputs the next step's differs (its polynomial starts there), so it lands instead.
    let dense = d.method.is_adaptive() && !inputs.moving();
    if dense && M::event_indicator(*t, x, u, p).is_none() {
        // Never step past the stop time (f may not be defined beyond it); without one, not
        // past the horizon of RUN_AHEAD.
        let horizon = || t_end + (RUN_AHEAD * (t_end - *t)).max(t_end - d.start_time);
        let t_limit = d.stop_time.map_or_else(horizon, |stop| stop.max(t_end));
        let mut project = |t: f64, x: &mut [f64]| M::project(t, p, x);
        integrators::advance_dense(
            &mut problem,
            &mut project,
            (t, x),
            (t_end, t_limit),
            settings,
            memory,
            work,
        )
        .map_err(Stop::from)
    } else {
        memory.drop_ahead();
        advance_locating_events::<M>(
            &mut problem,
            (t, x),
            (t_end, stop_at_event),
            settings,
            memory,
            (inputs, p, u_event),
            (x0, work),
        )
    }
}

/// Integrates to `t_end`, stopping at every sign change of the system's event indicator:
/// the crossing is located by bisection on re-integrations from the start of the piece
/// (deterministic, and as exact as the integration itself), [`System::on_event`] is
/// applied there, and the integration continues. Work spent on bisection is counted in
/// the statistics. In the scratch `(x0, work)`: a doStep without an event allocates
/// nothing (the bisection's re-integrations do).
fn advance_locating_events<M: System>(
    problem: &mut Problem,
    (t, x): (&mut f64, &mut [f64]),
    (t_end, stop_at_event): (f64, bool),
    settings: &Settings,
    memory: &mut Memory,
    (inputs, p, u_buf): (Inputs, &[f64], &mut Vec<f64>),
    (x0, work): (&mut Vec<f64>, &mut Workspace),
) -> Result<(), Stop> {
    let mut indicator = |t: f64, x: &[f64]| M::event_indicator(t, x, inputs.at(t, u_buf), p);
    // The pieces below are single steps: the doStep's step limit is checked on the whole
    // (a fixed-step plan before any work, as one call would; adaptive attempts as counted).
    if !settings.method.is_adaptive() {
        integrators::fixed_plan(settings.step, settings.max_steps, *t, t_end)?;
    }
    let attempts = |m: &Memory| m.stats.steps + m.stats.rejected;
    let attempts_before = attempts(memory);
    let mut events = 0;
    while events < MAX_EVENTS_PER_STEP {
        let g0 = indicator(*t, x);
        if g0.is_none() {
            // No indicator here, so no crossing to look for (the common case).
            return Ok(integrators::advance_in(
                problem, t, x, t_end, settings, memory, work,
            )?);
        }
        // The indicator is read about every step (a piece of the step the method proposes,
        // or of its fixed step), not only at t_end: a crossing and back (a pendulum
        // bouncing on a stop) inside one long doStep is not stepped over.
        let piece_end = sampled_end(*t, t_end, settings, memory);
        // (No point ahead is kept here: the memory's clone is its counters and step.)
        let (t0, x0, m0) = (*t, copied(x0, x), memory.clone());
        // A failure (not a step limit) may be the singularity the event guards against (a
        // string pulled to zero length): look for a crossing before it, failing as past it.
        let failed = match integrators::advance_in(problem, t, x, piece_end, settings, memory, work)
        {
            Ok(()) if !crossed(g0, indicator(*t, x)) => {
                if *t >= t_end {
                    return Ok(());
                }
                let used = attempts(memory) - attempts_before;
                if settings.method.is_adaptive() && used >= settings.max_steps {
                    let steps = used;
                    return Err(integrators::Failure::TooManySteps { t: *t, steps }.into());
                }
                continue;
            }
            Ok(()) => None,
            Err(e) => {
                let stop = Stop::from(e);
                if stop.bounded() {
                    return Err(stop);
                }
                Some(stop)
            }
        };
        // Work already spent past the event; the bisection adds to it, and its
        // re-integrations share the doStep's work bound.
        let n = x0.len();
        let mut extra_evals = memory.stats.rhs_evals - m0.stats.rhs_evals;
        let mut extra_work = memory.stats.work(n) - m0.stats.work(n);
        let mut rerun = |to: f64, extra: &mut u64| -> Result<(Vec<f64>, Memory), Stop> {
            let (mut tt, mut xx, mut mm) = (t0, x0.to_vec(), m0.clone());
            if m0.stats.work_limit != 0 {
                let left = m0.stats.work_limit.saturating_sub(extra_work);
                mm.stats.work_limit = left.max(m0.stats.work(n) + 1);
            }
            let result =
                integrators::advance_in(problem, &mut tt, &mut xx, to, settings, &mut mm, work);
            *extra += mm.stats.rhs_evals - m0.stats.rhs_evals;
            extra_work += mm.stats.work(n) - m0.stats.work(n);
            result.map(|()| (xx, mm)).map_err(Stop::from)
        };
        // The event lies in (lo, hi]: bisect on re-integrations from (t0, x0).
        let (mut lo, mut hi) = (t0, if failed.is_some() { piece_end } else { *t });
        events += 1;
        for _ in 0..MAX_BISECTIONS {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            let past = match rerun(mid, &mut extra_evals) {
                Ok((xm, _)) => crossed(g0, indicator(mid, &xm)),
                Err(stop) if failed.is_some() && !stop.bounded() => true,
                Err(stop) => return Err(stop),
            };
            if past {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        let mut counted = 0;
        let (mut xx, mut mm) = match (rerun(hi, &mut counted), failed) {
            (Ok((xx, mm)), _) if crossed(g0, indicator(hi, &xx)) => (xx, mm),
            // No crossing before the failure: report the failure as it was.
            (_, Some(stop)) => return Err(stop),
            (result, None) => result?,
        };
        mm.stats.rhs_evals += extra_evals;
        *memory = mm;
        // The inputs at the event (an allocation per event only: the indicator holds `u_buf`).
        let applied = M::on_event(hi, &mut xx, inputs.at(hi, &mut Vec::new()), p);
        *t = hi;
        x.copy_from_slice(&xx);
        if let Err(reason) = applied {
            return Err(Stop {
                reason,
                step_limit: false,
                work_limit: false,
            });
        }
        if *t >= t_end || stop_at_event {
            return Ok(());
        }
    }
    Err(Stop {
        reason: format!("more than {MAX_EVENTS_PER_STEP} events in one communication step"),
        step_limit: false,
        work_limit: false,
    })
}

/// Where the next piece of an integration that watches an event indicator ends: one step
/// ahead (the adaptive method's proposal, or the fixed step; `t_end` without one); never
/// past `t_end`.
fn sampled_end(t: f64, t_end: f64, settings: &Settings, memory: &Memory) -> f64 {
    if !settings.method.is_adaptive() {
        // The fixed grid's next point (its last step takes a sliver in, as the plan does;
        // no step: one over the whole interval).
        let h = settings.step;
        let steps = crate::integrators::problem::step_count(t_end - t, h);
        return if steps > 1.0 { t + h } else { t_end };
    }
    // No proposal yet (the first call, or a method that keeps none): to t_end, as before.
    let step = memory.h;
    if step.is_nan() || step <= 0.0 {
        return t_end;
    }
    let end = t + step;
    // A last sliver shorter than a tenth of a step joins this piece.
    if end >= t_end || t_end - end < 0.1 * step {
        t_end
    } else {
        end
    }
}

/// Why fmi2DoStep refuses a step of `h` from `current` ([`Instance::check_step`]) when the
/// FMU is at `now` and stops at `stop`.
#[cold]
fn step_refused(current: f64, h: f64, now: f64, stop: Option<f64>) -> String {
    if !(finite(h) && h > 0.0) {
        format!("communicationStepSize must be positive and finite, got {h}")
    } else if !finite(current) || (current - now).abs() > 1e-9 * now.abs().max(1.0) {
        format!("currentCommunicationPoint {current} is not the FMU's time {now}")
    } else {
        let stop = stop.unwrap_or(f64::NAN);
        format!("the step ends at {}, after stopTime {stop}", current + h)
    }
}

/// The end of a doStep from `current` to `t_end` that reached `t` with `result` and the
/// state `x`: the new state if it and the outputs are finite, else the last good one
/// ([`failed_step`]), and the outcome. The outputs are written into `y`, with the inputs
/// evaluated in `u_at` when they move (`held`: the caller knows they do not). Inlined, so
/// that the fixed-step path copies and checks a state of known length.
#[inline(always)]
fn settle_state<M: System>(
    d: &mut Snapshot,
    layout: &Layout,
    (current, t_end): (f64, f64),
    (t, x, result): (f64, &[f64], Result<(), Stop>),
    (y, u_at): (&mut Vec<f64>, &mut Vec<f64>),
    held: bool,
) -> StepOutcome {
    let y = sized(y, layout.n_outputs);
    let inputs = if held {
        Inputs::held(&d.u, &d.u_der)
    } else {
        Inputs::new(&d.u, &d.u_der, current)
    };
    let u = inputs.at(t, u_at);
    M::extra_outputs(t, x, u, &d.params, y);
    let finite = all_finite(x) && all_finite(y);
    if finite && result.is_ok() {
        d.x.copy_from_slice(x);
        d.time = t_end;
        return StepOutcome::Completed;
    }
    failed_step(d, layout, t_end, (t, x, result), finite)
}

/// [`settle_state`] when the integration failed or the outputs are not finite.
#[cold]
#[inline(never)]
fn failed_step(
    d: &mut Snapshot,
    layout: &Layout,
    t_end: f64,
    (t, x, result): (f64, &[f64], Result<(), Stop>),
    finite: bool,
) -> StepOutcome {
    let now = d.time;
    d.mode = Mode::StepDiscarded;
    let Err(stop) = result else {
        // The state stays at `now`: the point ahead of `t_end` no longer goes with it.
        d.memory.drop_ahead();
        return StepOutcome::Discarded(format!(
            "outputs became non-finite at t = {t_end}; state kept at t = {now}"
        ));
    };
    let mut why = stop.reason;
    if stop.work_limit {
        let n = d.x.len() as u64;
        why += &format!(
            " (the bound on one doStep's work: {DOSTEP_WORK:e} state-component evaluations, where an evaluation of f counts n = {n} and a Jacobian {}; about half a second on the costliest systems here); shorten the communication step or choose a cheaper solver",
            integrators::JACOBIAN_EVALS * n * n
        );
    }
    if stop.step_limit {
        let vr = layout.vr_of_slot(VarKind::SolverMaxSteps, 0);
        why += &format!(
            "; raise solver_max_steps (value reference {vr}, now {}) or shorten the communication step",
            d.max_steps
        );
    }
    if t > now && finite {
        d.x.copy_from_slice(x);
        d.time = t;
        StepOutcome::Discarded(format!(
            "{why}; integration stopped at the last good state, t = {t}"
        ))
    } else {
        StepOutcome::Discarded(format!("{why}; state kept at t = {now}"))
    }
}

/// RATTLE's mechanics under inputs that move over the step (input derivatives set): the
/// generalised force at t is the system's with the inputs at t; the mass matrix and the
/// constraints do not read inputs (a Lagrangian's T, V and g do not), so the held ones serve.
/// (A mechanics per evaluation of the force: one allocation each, on this path only.)
struct MovingInputs<'a, M> {
    held: Box<dyn Mechanics + 'a>,
    inputs: Inputs<'a>,
    p: &'a [f64],
    u: Vec<f64>,
    model: PhantomData<M>,
}

impl<M: System> Mechanics for MovingInputs<'_, M> {
    fn dims(&self) -> (usize, usize) {
        self.held.dims()
    }

    fn mass_matrix(&mut self, q: &[f64], m: &mut [f64]) {
        self.held.mass_matrix(q, m)
    }

    fn momentum_offset(&mut self, q: &[f64], b: &mut [f64]) {
        self.held.momentum_offset(q, b)
    }

    fn force(&mut self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) {
        let u = self.inputs.at(t, &mut self.u);
        let mut at_t = M::mechanics(u, self.p).expect("the held inputs had mechanics");
        at_t.force(t, q, qd, f)
    }

    fn constraints(&mut self, q: &[f64], g: &mut [f64], jac: &mut [f64]) {
        self.held.constraints(q, g, jac)
    }
}

/// The right-hand side with inputs held, inlined into the RK4 stages of the fixed-step path.
struct Held<'a, M> {
    u: &'a [f64],
    p: &'a [f64],
    model: PhantomData<M>,
}

impl<M: System> integrators::rk4::Rhs for Held<'_, M> {
    #[inline(always)]
    fn eval(&mut self, t: f64, x: &[f64], dx: &mut [f64]) {
        M::derivatives(t, x, self.u, self.p, dx)
    }
}
