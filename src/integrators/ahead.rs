//! The adaptive methods' point ahead of the communication time (dense output): the one
//! [`Ahead`] a [`Memory`] keeps, started, stepped and read by [`advance_dense`], checked and
//! serialized by the method that owns it, so the FMU never reads a method's internals.

use super::blob::Reader;
use super::dop853::Ahead as Dop853;
use super::dopri5::Ahead as Dopri5;
use super::explicit_rk::Point;
use super::problem::{DenseCall, Problem};
use super::{dop853, dopri5, radau5, sized, Failure, Memory, Method, Settings, Stats, Workspace};

/// The running method's own state ahead of the communication time.
#[derive(Clone, Debug, PartialEq)]
pub enum Ahead {
    Dopri5(dopri5::Ahead),
    Dop853(dop853::Ahead),
    Radau5(radau5::Ahead),
}

impl Ahead {
    /// The method that made it.
    pub fn method(&self) -> Method {
        match self {
            Ahead::Dopri5(_) => Method::Dopri5,
            Ahead::Dop853(_) => Method::Dop853,
            Ahead::Radau5(_) => Method::Radau5,
        }
    }

    /// Writes x(`t`) into `out`; whether the last accepted step covers `t`. DOP853 builds
    /// its extension in a copy (up to 3 evaluations of f, counted nowhere).
    pub fn point_at(&self, problem: &mut Problem, t: f64, out: &mut [f64]) -> bool {
        match self {
            Ahead::Dopri5(a) => {
                a.interpolate(t, out);
                a.point.covers(t)
            }
            Ahead::Radau5(a) => {
                a.interpolate(t, out);
                t <= a.t
            }
            Ahead::Dop853(a) => {
                let (stats, work) = (&mut Stats::default(), &mut dop853::Scratch::default());
                let built = a.clone().point_in(problem, t, out, stats, work);
                a.point.covers(t) && built.is_ok()
            }
        }
    }

    /// The end of the last accepted step: its time, its state, and f there when it must be
    /// f(t, x) (RADAU5 keeps none after landing on the stop time: not needed).
    pub fn end(&self) -> (f64, &[f64], Option<&[f64]>) {
        match self {
            Ahead::Dopri5(Dopri5 { point: p, .. }) | Ahead::Dop853(Dop853 { point: p, .. }) => {
                (p.t, &p.x, Some(&p.f))
            }
            Ahead::Radau5(a) => (a.t, &a.x, (!a.landed).then_some(&a.f[..])),
        }
    }

    /// Its block of the FMU state: the method's code (one byte), then the method's own.
    pub(crate) fn write(ahead: Option<&Ahead>, b: &mut Vec<u8>) {
        b.push(ahead.map_or(0, |a| a.method().code() as u8));
        match ahead {
            None => {}
            Some(Ahead::Dopri5(a)) => a.write(b),
            Some(Ahead::Dop853(a)) => a.write(b),
            Some(Ahead::Radau5(a)) => a.write(b),
        }
    }

    /// Reads what [`Ahead::write`] wrote for `n` states; each method checks its own block.
    pub(crate) fn read(r: &mut Reader, n: usize) -> Result<Option<Ahead>, String> {
        let code = r.take(1)?[0];
        Ok(match Method::from_code(code as i32) {
            _ if code == 0 => None,
            Some(Method::Dopri5) => Some(Ahead::Dopri5(dopri5::Ahead::read(r, n)?)),
            Some(Method::Dop853) => Some(Ahead::Dop853(dop853::Ahead::read(r, n)?)),
            Some(Method::Radau5) => Some(Ahead::Radau5(radau5::Ahead::read(r, n)?)),
            _ => return Err(format!("FMU state holds a point ahead of method {code}")),
        })
    }
}

/// The adaptive methods (DOPRI5, DOP853, RADAU5) with dense output, as the FMU runs them:
/// continues the method's own point ahead of `*t` kept in `memory` (else starts one at
/// `(*t, x)`), steps until its last step covers `t_end` (never past `t_limit`; `project`
/// after every accepted step), and reads x(`t_end`) from the continuous extension into `x`,
/// `*t = t_end`; the point ahead stays in `memory`. On failure `(*t, x)` is the last accepted
/// step if the integrator got past `*t`, and no point ahead is kept. In the scratch of
/// `work`: no allocation in steady state (once a point ahead is kept and `work` has held
/// these sizes). See [`dopri5::Ahead`], [`dop853::Ahead`], [`radau5::Ahead`].
#[allow(clippy::too_many_arguments)]
pub fn advance_dense(
    problem: &mut Problem,
    project: &mut dyn FnMut(f64, &mut [f64]),
    state: (&mut f64, &mut [f64]),
    (t_out, t_limit): (f64, f64),
    settings: &Settings,
    memory: &mut Memory,
    work: &mut Workspace,
) -> Result<(), Failure> {
    let method = settings.method;
    assert!(
        method.is_adaptive(),
        "{} has no dense output",
        method.name()
    );
    let mut point = std::mem::take(&mut work.point);
    let out = sized(&mut point, state.1.len());
    let run = (settings, &mut *memory);
    let call = &mut DenseCall::new(problem, project, (t_out, t_limit), run, (out, &mut *work));
    let result = dense(call, state);
    work.point = point;
    result
}

/// One call of [`advance_dense`], in the whole [`Workspace`]: each method takes its part.
type Call<'c, 'p> = DenseCall<'c, 'p, Workspace>;

/// The running method's point ahead if it resumes at `*t`, else a new one; stepped until
/// its last step covers `call.t_out`, x(`t_out`) read into `call.out`.
fn dense(call: &mut Call, (t, x): (&mut f64, &mut [f64])) -> Result<(), Failure> {
    let method = call.settings.method;
    let kept = call.memory.ahead.take();
    let mut ahead = match kept.filter(|a| a.method() == method && a.resumes(*t)) {
        Some(a) => a,
        None => Ahead::start(call, *t, x)?,
    };
    match ahead.advance(call) {
        Ok(()) => {
            x.copy_from_slice(call.out);
            *t = call.t_out;
            call.memory.ahead = Some(ahead);
            Ok(())
        }
        Err(e) => {
            // The last good point, unless it lies past `t_out` (a step that covered `t_out`
            // was accepted, then f failed at its projected end): the doStep's own end bounds
            // what it may report (fmi2LastSuccessfulTime ≤ t + h), so it stays at its start.
            let (_, t_ahead, x_ahead) = ahead.span();
            if t_ahead > *t && t_ahead <= call.t_out {
                *t = t_ahead;
                x.copy_from_slice(x_ahead);
            }
            Err(e)
        }
    }
}

impl Ahead {
    /// A new one of the running method at `(t, x)` (evaluates f). RADAU5 starts with the
    /// carried step proposal, and a failure resets it.
    fn start(c: &mut Call, t: f64, x: &[f64]) -> Result<Ahead, Failure> {
        let stats = &mut c.memory.stats;
        Ok(match c.settings.method {
            Method::Dopri5 => Ahead::Dopri5(Dopri5::new(Point::start(c.problem.rhs, t, x, stats)?)),
            Method::Dop853 => Ahead::Dop853(Dop853::new(Point::start(c.problem.rhs, t, x, stats)?)),
            _ => {
                let (h, t_limit) = (c.memory.h, c.t_limit);
                let a = radau5::Ahead::start(c.problem, t, x, h, t_limit, c.settings, stats);
                Ahead::Radau5(a.inspect_err(|_| c.memory.h = 0.0)?)
            }
        })
    }

    /// The time it started from, and the time and state its last accepted step reached
    /// (RADAU5 keeps no start: its state covers everything up to its own time, its
    /// collocation polynomial the last step, and before any step the point itself).
    fn span(&self) -> (f64, f64, &[f64]) {
        match self {
            Ahead::Dopri5(Dopri5 { point: p, .. }) | Ahead::Dop853(Dop853 { point: p, .. }) => {
                (p.t0, p.t, &p.x)
            }
            Ahead::Radau5(a) => (f64::NEG_INFINITY, a.t, &a.x),
        }
    }

    /// Whether integration from `t` can go on from it: a time its steps covered.
    fn resumes(&self, t: f64) -> bool {
        let (t0, t1, _) = self.span();
        t0 <= t && t <= t1
    }

    /// Steps until its last step covers `c.t_out`, and x(`t_out`) into `c.out`.
    fn advance(&mut self, c: &mut Call) -> Result<(), Failure> {
        match self {
            Ahead::Dopri5(a) => dopri5::advance_dense_in(a, c.with(|w| &mut w.dopri5)),
            Ahead::Dop853(a) => dop853::advance_dense_in(a, c.with(|w| &mut w.dop853)),
            Ahead::Radau5(a) => radau5::advance_dense_in(a, c.with(|w| &mut w.radau5)),
        }
    }
}
