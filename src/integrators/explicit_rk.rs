//! What DOPRI5 and DOP853 share: the stepping loop itself ([`run`], over a [`Pair`]'s
//! tableau), the stage sum, Hairer's error weights, the initial step (E. Hairer, S. P.
//! Nørsett, G. Wanner, *Solving Ordinary Differential Equations I*, II.4 p. 169; HINIT of
//! dopri5.f / dop853.f), the PI controller, and the landing and step-floor rules.

use super::blob::{put_f64s, Reader};
use super::buffers::sized;
use super::problem::Problem;
use super::{Failure, Memory, Settings, Stats};

/// A step that would end less than 1 % before the target is stretched to land on it,
/// instead of leaving a sliver step (dopri5.f and dop853.f do the same).
pub(super) const LANDING_STRETCH: f64 = 1.01;

/// Smallest usable step is `MIN_STEP_ULPS · ε · max(|t|, 1)`: 16 ulps of `t`, so `t + h`
/// still differs from `t` in more than the last bits and the stage times are distinct; the
/// `max(·, 1)` keeps an absolute floor (16ε s ≈ 3.6e-15 s) near t = 0, where ulps vanish.
/// (dopri5.f stops when `0.1·|h| <= |t|·uround`, i.e. about 10 ulps, with no floor.)
pub(super) const MIN_STEP_ULPS: f64 = 16.0;

/// Floor of the previous error in the PI term, and its value on a cold start: keeps
/// `facold^β` away from 0 after an exact (error 0) step (both Fortran codes: 1e-4).
pub(super) const FACOLD_MIN: f64 = 1e-4;

/// Where a call of a stepping loop stops (DOPRI5 and DOP853 alike).
#[derive(Clone, Copy)]
pub(super) enum Goal {
    /// Exactly at this time: the last step is shortened (or stretched ≤ 1 %) to land on it.
    Land(f64),
    /// After the first accepted step that reaches `t_out`; steps are cut only at `t_limit`.
    Pass { t_out: f64, t_limit: f64 },
}

impl Goal {
    /// The step taken from `t` for the controller's proposal `h`: `(hs, t_new, landing)`,
    /// shortened (or stretched ≤ 1 %, [`LANDING_STRETCH`]) to land on the end (`Land`) or
    /// the limit (`Pass`); `h` itself stays the proposal.
    pub(super) fn step_from(self, t: f64, h: f64) -> (f64, f64, bool) {
        let land_on = match self {
            Goal::Land(t_end) => t_end,
            Goal::Pass { t_limit, .. } => t_limit,
        };
        if t + LANDING_STRETCH * h >= land_on {
            (land_on - t, land_on, true)
        } else {
            (h, t + h, false)
        }
    }

    /// Whether the accepted step ending at `t_new` (`landing` as [`Goal::step_from`] said)
    /// ends the call.
    pub(super) fn reached(self, t_new: f64, landing: bool) -> bool {
        match self {
            Goal::Land(_) => landing,
            Goal::Pass { t_out, .. } => t_new >= t_out,
        }
    }
}

/// Whether `h` is below the smallest usable step at `t` (or NaN).
pub(super) fn step_too_small(t: f64, h: f64) -> bool {
    h.is_nan() || h < MIN_STEP_ULPS * f64::EPSILON * t.abs().max(1.0)
}

/// `out = x + h·Σ a_j·k_j`, the argument of a stage.
pub(super) fn stage(out: &mut [f64], x: &[f64], h: f64, terms: &[(f64, &[f64])]) {
    for (i, o) in out.iter_mut().enumerate() {
        let s: f64 = terms.iter().map(|(a, k)| a * k[i]).sum();
        *o = x[i] + h * s;
    }
}

/// Hairer's weight of component i: what "one unit of error" means there.
pub(super) fn weight(settings: &Settings, i: usize, x: f64) -> f64 {
    settings.atol[i] + settings.rtol * x.abs()
}

/// One evaluation of f, counted; `false` if the derivative is not finite.
pub(super) fn eval(
    rhs: &mut dyn FnMut(f64, &[f64], &mut [f64]),
    t: f64,
    y: &[f64],
    k: &mut [f64],
    stats: &mut Stats,
) -> bool {
    stats.rhs_evals += 1;
    rhs(t, y, k);
    k.iter().all(|v| v.is_finite())
}

/// Initial step for a method of order `order`, with the RMS norm of the book. Costs one
/// evaluation of f through `eval` (`f0 = f(t, x)` is already known; `y1`, `f1` are
/// scratch).
#[allow(clippy::too_many_arguments)]
pub(super) fn initial_step(
    eval: &mut dyn FnMut(f64, &[f64], &mut [f64]) -> bool,
    t: f64,
    x: &[f64],
    f0: &[f64],
    settings: &Settings,
    h_max: f64,
    order: i32,
    (y1, f1): (&mut [f64], &mut [f64]),
) -> f64 {
    let n = x.len().max(1) as f64;
    let (mut dnf, mut dny) = (0.0, 0.0);
    for i in 0..x.len() {
        let sk = weight(settings, i, x[i]);
        dnf += (f0[i] / sk).powi(2);
        dny += (x[i] / sk).powi(2);
    }
    let (dnf, dny) = ((dnf / n).sqrt(), (dny / n).sqrt());
    // a) h0 = 0.01·‖x‖/‖f‖: a step over which x changes by 1 % (or 1e-6 if either is ~0).
    let h0 = if dnf <= 1e-5 || dny <= 1e-5 {
        1e-6
    } else {
        0.01 * dny / dnf
    }
    .min(h_max);
    // b) One explicit Euler step to estimate the second derivative.
    for i in 0..x.len() {
        y1[i] = x[i] + h0 * f0[i];
    }
    if !eval(t + h0, y1, f1) {
        // The probe ran into trouble; the main loop will find out whether h0 itself does.
        return h0;
    }
    let mut der2 = 0.0;
    for i in 0..x.len() {
        der2 += ((f1[i] - f0[i]) / weight(settings, i, x[i])).powi(2);
    }
    let der2 = (der2 / n).sqrt() / h0;
    // c) h1 with h1^(order+1)·max(‖f'‖, ‖f‖) = 0.01 (Hairer's codes use the order here).
    let der12 = der2.max(dnf);
    let h1 = if der12 <= 1e-15 {
        (h0 * 1e-3).max(1e-6)
    } else {
        (0.01 / der12).powf(1.0 / order as f64)
    };
    (100.0 * h0).min(h1).min(h_max)
}

/// The loop guards of both codes before an attempt: give up after `max_steps` attempts in
/// one call ([`Settings::max_steps`]), when the call's work bound is spent
/// ([`Stats::check_work`], `n` states), or when the proposal falls below the smallest usable
/// step.
pub(super) fn check_attempt(
    (t, h): (f64, f64),
    (attempts, max_steps): (u64, u64),
    stats: &Stats,
    n: usize,
) -> Result<(), Failure> {
    if attempts >= max_steps {
        return Err(Failure::TooManySteps { t, steps: attempts });
    }
    stats.check_work(t, n)?;
    if step_too_small(t, h) {
        return Err(Failure::StepTooSmall { t, h });
    }
    Ok(())
}

/// Both codes aim at 90 % of the step the error model allows, so that the next step is
/// usually accepted (dopri5.f and dop853.f SAFE).
const SAFETY: f64 = 0.9;

/// The constants of Hairer's PI controller for one method (dopri5.f / dop853.f defaults).
pub(super) struct PiGains {
    /// Lund-stabilisation exponent on the previous error.
    pub beta: f64,
    /// Exponent on the current error.
    pub expo1: f64,
    /// Smallest factor a step may shrink by at once.
    pub fac_min: f64,
    /// Largest factor a step may grow by at once.
    pub fac_max: f64,
}

/// Hairer's PI step-size controller with Lund stabilisation (ODE I, IV.2; dopri5.f DOPCOR,
/// dop853.f DP86CO): its state is the previous error and whether the last attempt failed.
pub(super) struct PiController {
    gains: PiGains,
    /// The previous accepted error (dopri5.f FACOLD), floored at [`FACOLD_MIN`].
    pub err_prev: f64,
    after_reject: bool,
}

impl PiController {
    /// The controller at the start of a call. The previous error for the PI term: a cold
    /// start uses Hairer's [`FACOLD_MIN`], which damps the first growth (~30 %). A call
    /// continuing with a carried step uses `err_prev` when it is known (dense mode keeps
    /// it); otherwise (landing mode: it is not part of the FMU state) it assumes the
    /// previous error was at tolerance (1), which makes the first update a plain
    /// I-controller instead of shrinking the proposal at every call.
    pub(super) fn resuming(gains: PiGains, carried: bool, err_prev: Option<f64>) -> PiController {
        let err_prev = match err_prev {
            Some(e) if carried => e,
            _ if carried => 1.0,
            _ => FACOLD_MIN,
        };
        PiController {
            gains,
            err_prev,
            after_reject: false,
        }
    }

    /// The proposal after an accepted step of size `hs` with error `err` (≤ 1):
    /// `h_new/hs = SAFETY / (err^EXPO1 / errold^BETA)` within the factor bounds and
    /// `h_max`, and not above `hs` right after a rejection (growing again would likely
    /// fail again).
    pub(super) fn accepted(&mut self, err: f64, hs: f64, h_max: f64) -> f64 {
        let g = &self.gains;
        let fac = err.powf(g.expo1) / self.err_prev.powf(g.beta);
        let mut h_new = hs / (fac / SAFETY).clamp(1.0 / g.fac_max, 1.0 / g.fac_min);
        h_new = h_new.min(h_max);
        if self.after_reject {
            h_new = h_new.min(hs);
        }
        self.err_prev = err.max(FACOLD_MIN);
        self.after_reject = false;
        h_new
    }

    /// The retry after a rejected step of size `hs` with error `err` (> 1): shrink by the
    /// error model alone (no PI term), at most by `fac_min`.
    pub(super) fn rejected(&mut self, err: f64, hs: f64) -> f64 {
        self.after_reject = true;
        let g = &self.gains;
        hs / (err.powf(g.expo1) / SAFETY).min(1.0 / g.fac_min)
    }
}

/// The proposal carried to the next call after the last accepted step `hs`, planned as
/// `h`, for which the controller proposed `h_new`. After a landing step the cut-short
/// step's easy error must not shrink it, so keep the planned step unless the controller
/// asks to reduce.
pub(super) fn carried_proposal(landing: bool, h_new: f64, hs: f64, h: f64) -> f64 {
    if !landing || h_new < hs {
        h_new
    } else {
        h_new.max(h)
    }
}

/// An explicit embedded Runge–Kutta pair as data: the tableau [`run`] steps with, and the
/// hooks where Hairer's two codes (dopri5.f, dop853.f) differ.
pub(super) trait Pair {
    /// Name in the panic for a tolerance vector of the wrong size.
    const NAME: &'static str;
    /// Order for the initial step (the codes' IORD).
    const ORDER: i32;
    const GAINS: PiGains;
    /// The stages after k1, each `(c, row)`: its node (1: the step's end, taken as `t_new`
    /// exactly) and its weights `(a, j)` on the stages (k1 is 0), zeros omitted, in the
    /// order the codes add them.
    const STAGES: &'static [(f64, &'static [(f64, usize)])];
    /// The solution's weights; `None` when the last stage's argument is the solution, so
    /// that stage is f at the step's end (first same as last).
    const SOLUTION: Option<&'static [(f64, usize)]>;
    /// A stage whose argument is kept (in [`Stages::kept`]) after the step.
    const KEEP: Option<usize>;
    /// The error norm of the step `x → y` of size `hs` from its stages (`k[0]` is k1).
    fn error(x: &[f64], y: &[f64], k: &[&[f64]], hs: f64, settings: &Settings) -> f64;
    /// How many embedded solutions [`Pair::error`] compares `y` with.
    const ESTIMATES: usize;
    /// Each embedded solution's difference `y − ŷ` into `out` (one vector each).
    fn estimates(k: &[&[f64]], hs: f64, out: &mut [Vec<f64>]);
    /// [`Pair::error`] from the differences [`Pair::estimates`] gives (once projected).
    fn error_of(x: &[f64], y: &[f64], e: &[Vec<f64>], settings: &Settings) -> f64;
    /// After each accepted step (DOPRI5 watches for stiffness).
    fn accepted(_memory: &mut Memory, _hs: f64, _t_new: f64, _w: &Stages) {}
    /// Writes into `record` what the dense output of the last step of a dense call is built
    /// from, `f_end` being f at its end (before `x` moves on).
    fn record(x: &[f64], w: &Stages, k1: &[f64], f_end: &[f64], hs: f64, record: &mut Vec<f64>);
}

/// Hairer's weighted root-mean-square norm of `e` (a difference of states) for the step
/// `x → y`: each entry against `atol + rtol·max(|x|, |y|)`.
pub(super) fn rms_norm(x: &[f64], y: &[f64], e: &[f64], settings: &Settings) -> f64 {
    let sum: f64 = (e.iter().enumerate())
        .map(|(i, e)| {
            let sk = settings.atol[i] + settings.rtol * x[i].abs().max(y[i].abs());
            (e / sk).powi(2)
        })
        .sum();
    (sum / x.len().max(1) as f64).sqrt()
}

/// The most stages a [`Pair`] has (DOP853: 12).
const MAX_STAGES: usize = 12;

/// The work vectors of one step: the stages after k1, the new solution `y`, the kept
/// stage argument and f at the end of a dense step when no stage is.
#[derive(Default)]
pub(super) struct Stages {
    pub k: Vec<Vec<f64>>,
    pub y: Vec<f64>,
    pub kept: Vec<f64>,
    f_end: Vec<f64>,
    manifold: OnManifold,
}

/// Scratch of the error measured on the manifold ([`OnManifold::error`]).
#[derive(Default)]
struct OnManifold {
    /// The projected solution P(y).
    projected: Vec<f64>,
    /// An embedded solution ŷ, then P(ŷ).
    embedded: Vec<f64>,
    /// `y − ŷ` per embedded solution, then `P(y) − P(ŷ)`.
    estimates: Vec<Vec<f64>>,
    /// The defect of the step's start, whether it is known for the current start, and
    /// whether the system measured one there.
    start_defect: Vec<f64>,
    start_known: bool,
    start_measured: bool,
}

impl OnManifold {
    /// The error norm of the step `x → y` (stages `k`) between the projected solution and
    /// each projected embedded one: the error the projection after the step leaves; with
    /// a `defect`, at least the norm of what the step added to it (how far the step
    /// itself left the constraints). P(y) stays in `projected` for the step's end.
    #[allow(clippy::too_many_arguments)]
    fn error<P: Pair>(
        &mut self,
        (project, defect): (
            &mut dyn FnMut(f64, &mut [f64]),
            Option<&mut dyn FnMut(f64, &[f64], &mut [f64]) -> bool>,
        ),
        t_new: f64,
        (x, y): (&[f64], &[f64]),
        k: &[&[f64]],
        hs: f64,
        settings: &Settings,
    ) -> f64 {
        let n = y.len();
        self.estimates.resize_with(P::ESTIMATES, Vec::new);
        self.estimates.iter_mut().for_each(|e| {
            sized(e, n);
        });
        P::estimates(k, hs, &mut self.estimates);
        sized(&mut self.projected, n).copy_from_slice(y);
        project(t_new, &mut self.projected);
        let embedded = sized(&mut self.embedded, n);
        for e in &mut self.estimates {
            embedded
                .iter_mut()
                .zip(y.iter().zip(&*e))
                .for_each(|(v, (a, b))| *v = a - b);
            project(t_new, embedded);
            e.iter_mut()
                .zip(self.projected.iter().zip(&*embedded))
                .for_each(|(v, (a, b))| *v = a - b);
        }
        let err = P::error_of(x, y, &self.estimates, settings);
        let Some(defect) = defect else {
            return err;
        };
        // What the step added to the defect its start had (the projection leaves some at
        // a singular position), the start's kept while the step is retried. (`embedded` is
        // free again: the end's defect goes there.)
        if !self.start_known {
            let t0 = t_new - hs;
            self.start_measured = defect(t0, x, sized(&mut self.start_defect, n));
            self.start_known = true;
        }
        if !self.start_measured || !defect(t_new, y, embedded) {
            return err;
        }
        (embedded.iter_mut().zip(&self.start_defect)).for_each(|(e, s)| *e -= s);
        err.max(rms_norm(x, y, embedded, settings))
    }
}

impl Stages {
    /// `stages` vectors of `n` entries each (each is written in full before it is read).
    pub(super) fn size(&mut self, stages: usize, n: usize) {
        self.k.resize_with(stages, Vec::new);
        for v in self.k.iter_mut().chain([&mut self.y, &mut self.kept]) {
            sized(v, n);
        }
    }

    /// One attempted step `x → y` of size `hs` from `t0` (ending at `t_new`, given so a
    /// landing step ends exactly there) with `k1 = f(t0, x)`; its error norm.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn attempt<P: Pair>(
        &mut self,
        rhs: &mut dyn FnMut(f64, &[f64], &mut [f64]),
        k1: &[f64],
        (t0, t_new): (f64, f64),
        x: &[f64],
        hs: f64,
        settings: &Settings,
        stats: &mut Stats,
    ) -> Result<f64, Failure> {
        self.take_stages::<P>(rhs, k1, (t0, t_new), x, hs, stats)?;
        self.raw_error::<P>(k1, x, hs, settings, t0)
    }

    /// The stages and the solution `y` of [`attempt`](Stages::attempt), without its error.
    fn take_stages<P: Pair>(
        &mut self,
        rhs: &mut dyn FnMut(f64, &[f64], &mut [f64]),
        k1: &[f64],
        (t0, t_new): (f64, f64),
        x: &[f64],
        hs: f64,
        stats: &mut Stats,
    ) -> Result<(), Failure> {
        let bad = || Failure::NonFinite { t: t0 };
        let last = P::STAGES.len() - 1;
        for (s, &(c, row)) in P::STAGES.iter().enumerate() {
            let (done, rest) = self.k.split_at_mut(s);
            let arg = if P::KEEP == Some(s) {
                &mut self.kept
            } else {
                &mut self.y
            };
            stage_row(arg, x, hs, row, &stages(k1, done));
            // (The solution as the last stage's argument must be finite before f sees it.)
            let solution = s == last && P::SOLUTION.is_none();
            let t = if c == 1.0 { t_new } else { t0 + c * hs };
            if (solution && !arg.iter().all(|v| v.is_finite()))
                || !eval(rhs, t, arg, &mut rest[0], stats)
            {
                return Err(bad());
            }
        }
        if let Some(weights) = P::SOLUTION {
            stage_row(&mut self.y, x, hs, weights, &stages(k1, &self.k));
            if !self.y.iter().all(|v| v.is_finite()) {
                return Err(bad());
            }
        }
        Ok(())
    }

    /// The error norm of the step [`take_stages`](Stages::take_stages) took, off the
    /// manifold (the pair's own estimate).
    fn raw_error<P: Pair>(
        &self,
        k1: &[f64],
        x: &[f64],
        hs: f64,
        settings: &Settings,
        t0: f64,
    ) -> Result<f64, Failure> {
        let k = stages(k1, &self.k);
        let err = P::error(x, &self.y, &k[..=P::STAGES.len()], hs, settings);
        if err.is_nan() {
            // Only possible with a zero weight (atol = rtol·|x| = 0): no error can be judged.
            return Err(Failure::NonFinite { t: t0 });
        }
        Ok(err)
    }
}

/// The stages by index, k1 first (no allocation: at most [`MAX_STAGES`]).
fn stages<'k>(k1: &'k [f64], rest: &'k [Vec<f64>]) -> [&'k [f64]; MAX_STAGES] {
    let mut k: [&[f64]; MAX_STAGES] = [&[]; MAX_STAGES];
    k[0] = k1;
    for (slot, v) in k[1..].iter_mut().zip(rest) {
        *slot = v;
    }
    k
}

/// `out = x + h·Σ a·k[j]` over a tableau row of `(a, j)`: [`stage`] on stages by index.
fn stage_row(out: &mut [f64], x: &[f64], h: f64, row: &[(f64, usize)], k: &[&[f64]]) {
    for (i, o) in out.iter_mut().enumerate() {
        let s: f64 = row.iter().map(|&(a, j)| a * k[j][i]).sum();
        *o = x[i] + h * s;
    }
}

/// Component `i` of the four blocks (of `n` each) that both codes' continuous extensions
/// begin with (dopri5.f RCONT, dop853.f CONT), for the step x → y of size `h` with k1 = f(x)
/// and f1 = f(y): x, y − x, h·k1 − (y − x), and (y − x) − h·f1 − (h·k1 − (y − x)).
#[inline]
pub(super) fn hermite_blocks(
    cont: &mut [f64],
    (n, i): (usize, usize),
    (x, y): (&[f64], &[f64]),
    h: f64,
    (k1, f1): (&[f64], &[f64]),
) {
    let ydiff = y[i] - x[i];
    let bspl = h * k1[i] - ydiff;
    cont[i] = x[i];
    cont[n + i] = ydiff;
    cont[2 * n + i] = bspl;
    cont[3 * n + i] = ydiff - h * f1[i] - bspl;
}

/// The point ahead of a pair in dense mode, DOPRI5's and DOP853's alike: the end of its
/// last accepted step, where that step started, and the controller's error memory (each
/// method's [`Ahead`](super::dopri5::Ahead) adds what its continuous extension is built from).
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// End of the last accepted step: the integrator's own time.
    pub t: f64,
    /// State at `t`.
    pub x: Vec<f64>,
    /// f(t, x): the first stage of the next step (FSAL).
    pub f: Vec<f64>,
    /// Start of the last accepted step (= `t` before the first step).
    pub t0: f64,
    /// The PI controller's previous error (0 before the first step), carried so the step
    /// sequence is the same however many calls it is cut into.
    pub err_prev: f64,
}

impl Point {
    /// The point at `(t, x)` before any step; evaluates f once.
    pub fn start(
        rhs: &mut dyn FnMut(f64, &[f64], &mut [f64]),
        t: f64,
        x: &[f64],
        stats: &mut Stats,
    ) -> Result<Point, Failure> {
        let mut f = vec![0.0; x.len()];
        if !x.iter().all(|v| v.is_finite()) || !eval(rhs, t, x, &mut f, stats) {
            return Err(Failure::NonFinite { t });
        }
        let (x, t0, err_prev) = (x.to_vec(), t, 0.0);
        Ok(Point {
            t,
            x,
            f,
            t0,
            err_prev,
        })
    }

    /// Whether `t` lies in its last step.
    pub fn covers(&self, t: f64) -> bool {
        self.t0 <= t && t <= self.t
    }

    /// Its part of the FMU state: the times and the error memory, then x and f.
    pub(super) fn write(&self, b: &mut Vec<u8>) {
        let fields = [self.t, self.t0, self.err_prev];
        put_f64s(b, fields.iter().chain(&self.x).chain(&self.f));
    }

    /// Reads what [`Point::write`] wrote for `n` states; the method checks it
    /// ([`Point::is_sound`]) with what it read after it.
    pub(super) fn read(r: &mut Reader, n: usize) -> Result<Point, String> {
        let (t, t0, err_prev) = (r.f64()?, r.f64()?, r.f64()?);
        let (x, f) = (r.f64s(n)?, r.f64s(n)?);
        Ok(Point {
            t,
            x,
            f,
            t0,
            err_prev,
        })
    }

    /// Everything finite, and the last step not ending before it started.
    pub(super) fn is_sound(&self) -> bool {
        let fields = [self.t, self.t0, self.err_prev];
        let finite = fields.iter().chain(&self.x).chain(&self.f);
        finite.into_iter().all(|v| v.is_finite()) && self.t0 <= self.t
    }
}

/// The scratch of a pair: f at the start of a landing call, the stages, and the record of
/// the last step of a dense call (swapped into the method's point ahead).
#[derive(Default)]
pub struct Scratch {
    k1: Vec<f64>,
    stages: Stages,
    pub(super) record: Vec<f64>,
}

/// The last accepted step of a dense call, besides its record.
pub(super) struct LastStep {
    pub t0: f64,
    /// The PI controller's error memory after the step.
    pub err_prev: f64,
}

/// Landing mode of a pair: from `*t` (`x` finite) to exactly `t_end`; `memory.h` reset on
/// failure. Counts f once at the start (fresh: inputs may have changed since the last call).
pub(super) fn land<P: Pair>(
    rhs: &mut dyn FnMut(f64, &[f64], &mut [f64]),
    (t, x): (&mut f64, &mut [f64]),
    t_end: f64,
    settings: &Settings,
    memory: &mut Memory,
    work: &mut Scratch,
) -> Result<(), Failure> {
    let k1 = &mut work.k1;
    sized(k1, x.len());
    let result = if eval(rhs, *t, x, k1, &mut memory.stats) {
        let ends = (Goal::Land(t_end), None);
        let steps = (&mut work.stages, &mut work.record);
        run::<P>(rhs, (t, x), k1, ends, None, settings, memory, steps).map(|_| ())
    } else {
        Err(Failure::NonFinite { t: *t })
    };
    if result.is_err() {
        memory.h = 0.0;
    }
    result
}

/// Dense mode's steps of a pair: if `t_out` lies past the point `(t, x, f = f(t, x))`,
/// steps it until its last step covers `t_out` (cut only to land on `t_limit`), `project`
/// after every accepted step (each step's error measured after it when the problem says
/// [`error_on_manifold`](Problem::error_on_manifold)), and returns that step (its record in `work.record`).
/// `err_prev`: the controller's memory the point kept (0: none). `memory.h` reset on failure.
#[allow(clippy::too_many_arguments)]
pub(super) fn step_past<P: Pair>(
    problem: &mut Problem,
    project: &mut dyn FnMut(f64, &mut [f64]),
    (t, x, f): (&mut f64, &mut [f64], &mut Vec<f64>),
    err_prev: f64,
    (t_out, t_limit): (f64, f64),
    settings: &Settings,
    memory: &mut Memory,
    work: &mut Scratch,
) -> Result<Option<LastStep>, Failure> {
    if t_out <= *t {
        return Ok(None);
    }
    let ends = (
        Goal::Pass { t_out, t_limit },
        (err_prev > 0.0).then_some(err_prev),
    );
    let steps = (&mut work.stages, &mut work.record);
    // (the cast shortens the trait object's lifetime to the borrow's)
    let defect = (problem.defect.as_deref_mut()).map(|d| d as &mut dyn FnMut(_, &_, &mut _) -> _);
    let project = Some((project, problem.error_on_manifold, defect));
    let rhs = &mut *problem.rhs;
    let result = run::<P>(rhs, (t, x), f, ends, project, settings, memory, steps);
    if result.is_err() {
        memory.h = 0.0;
    }
    result.map(Some)
}

/// The map onto the constraints applied after every accepted step, whether the step's
/// error is measured after it ([`Problem::error_on_manifold`]) and the defect the step's
/// end is measured by besides ([`Problem::defect`]).
type Projection<'p, 'd> = (
    &'p mut dyn FnMut(f64, &mut [f64]),
    bool,
    Option<&'d mut dyn FnMut(f64, &[f64], &mut [f64]) -> bool>,
);

/// The stepping loop of both modes. `k1` holds f(t, x) on entry. Landing mode evaluates f
/// at the start of a step when no stage gave it (so the last step of a call does not pay
/// for it); dense mode evaluates it at once (the dense output needs it), leaves it in `k1`,
/// applies `project` after every accepted step and leaves the last step's record in
/// `record`. `err_prev`: the PI controller's previous error when the caller kept it.
#[allow(clippy::too_many_arguments)]
fn run<P: Pair>(
    rhs: &mut dyn FnMut(f64, &[f64], &mut [f64]),
    (t, x): (&mut f64, &mut [f64]),
    k1: &mut Vec<f64>,
    (goal, err_prev): (Goal, Option<f64>),
    mut project: Option<Projection>,
    settings: &Settings,
    memory: &mut Memory,
    (w, record): (&mut Stages, &mut Vec<f64>),
) -> Result<LastStep, Failure> {
    let n = x.len();
    assert_eq!(
        settings.atol.len(),
        n,
        "{} needs one absolute tolerance per state",
        P::NAME
    );
    let h_max = settings.max_step();
    let stats = &mut memory.stats;
    w.size(P::STAGES.len(), n);
    let carried = memory.h > 0.0 && memory.h.is_finite();
    w.manifold.start_known = false;
    let mut h = if carried {
        memory.h.min(h_max)
    } else {
        let mut probe = |t: f64, y: &[f64], k: &mut [f64]| eval(rhs, t, y, k, stats);
        let scratch = (&mut w.y[..], &mut w.k[0][..]);
        initial_step(&mut probe, *t, x, k1, settings, h_max, P::ORDER, scratch)
    };
    let mut controller = PiController::resuming(P::GAINS, carried, err_prev);
    let dense = matches!(goal, Goal::Pass { .. });
    let last = P::STAGES.len() - 1;
    let mut k1_fresh = true;
    let mut attempts: u64 = 0;
    loop {
        check_attempt((*t, h), (attempts, settings.max_steps), &memory.stats, n)?;
        attempts += 1;
        // `h` stays the controller's proposal; `hs` is the step actually taken.
        let (hs, t_new, landing) = goal.step_from(*t, h);
        let t0 = *t;
        let stats = &mut memory.stats;
        if !k1_fresh {
            if !eval(rhs, t0, x, k1, stats) {
                return Err(Failure::NonFinite { t: t0 });
            }
            k1_fresh = true;
        }
        w.take_stages::<P>(rhs, k1, (t0, t_new), x, hs, stats)?;
        let (err, on_manifold) = match project.as_mut() {
            Some((project, true, defect)) => {
                let k = stages(k1, &w.k);
                let (xy, k) = ((&x[..], &w.y[..]), &k[..=P::STAGES.len()]);
                let defect = defect
                    .as_mut()
                    .map(|d| &mut **d as &mut dyn FnMut(_, &_, &mut _) -> _);
                let maps = (&mut **project as &mut dyn FnMut(_, &mut _), defect);
                let err = w.manifold.error::<P>(maps, t_new, xy, k, hs, settings);
                if err.is_nan() {
                    // A projection that broke down: nothing to judge, nothing accepted.
                    return Err(Failure::NonFinite { t: t0 });
                }
                (err, true)
            }
            _ => (w.raw_error::<P>(k1, x, hs, settings, t0)?, false),
        };
        if err > 1.0 {
            stats.rejected += 1;
            h = controller.rejected(err, hs);
            continue;
        }
        let h_new = controller.accepted(err, hs, h_max);
        let done = goal.reached(t_new, landing);
        // f at the step's end: its last stage, or evaluated now in dense mode.
        let fsal = P::SOLUTION.is_none();
        if !fsal && dense && !eval(rhs, t_new, &w.y, sized(&mut w.f_end, n), stats) {
            return Err(Failure::NonFinite { t: t0 });
        }
        stats.steps += 1;
        P::accepted(memory, hs, t_new, w);
        if done && dense {
            let f_end = if fsal { &w.k[last] } else { &w.f_end };
            P::record(x, w, k1, f_end, hs, record);
        }
        x.copy_from_slice(&w.y);
        w.manifold.start_known = false;
        if fsal {
            std::mem::swap(k1, &mut w.k[last]);
        } else if dense {
            std::mem::swap(k1, &mut w.f_end);
        } else {
            k1_fresh = false;
        }
        *t = t_new;
        if let Some((project, _, _)) = project.as_mut() {
            if on_manifold {
                x.copy_from_slice(&w.manifold.projected);
            } else {
                project(t_new, x);
            }
            if x != &w.y[..] && !eval(rhs, t_new, x, k1, &mut memory.stats) {
                return Err(Failure::NonFinite { t: t_new });
            }
        }
        if done {
            memory.h = carried_proposal(landing, h_new, hs, h);
            return Ok(LastStep {
                t0,
                err_prev: controller.err_prev,
            });
        }
        h = h_new;
    }
}

#[cfg(test)]
mod tests {
    use super::super::dop853::Dop853;
    use super::super::dopri5::Dopri5;
    use super::*;

    /// The start `x`, `k1 = f(x)` and the stages of one step of `P` (size [`HS`]) on a
    /// pendulum with a weak spring (no symmetry that zeroes an error term) from a generic
    /// state.
    fn one_step<P: Pair>() -> ([f64; 2], [f64; 2], Stages) {
        let rhs = |_: f64, x: &[f64], dx: &mut [f64]| {
            dx[0] = x[1];
            dx[1] = -9.81 * x[0].sin() - 0.3 * x[0] + 0.05 * x[1] * x[1];
        };
        let x = [1.1, -0.4];
        let mut k1 = [0.0; 2];
        rhs(0.0, &x, &mut k1);
        let mut w = Stages::default();
        w.size(P::STAGES.len(), 2);
        let mut stats = Stats::default();
        w.take_stages::<P>(&mut { rhs }, &k1, (0.0, HS), &x, HS, &mut stats)
            .unwrap();
        (x, k1, w)
    }

    /// The step size of [`one_step`].
    const HS: f64 = 0.2;

    /// One step of `P` ([`one_step`]): its error measured raw and through the manifold
    /// path with a projection that moves nothing.
    fn error_both_ways<P: Pair>() -> (f64, f64) {
        let settings = Settings {
            method: crate::integrators::Method::Dopri5,
            rtol: 1e-9,
            atol: vec![1e-12; 2],
            step: 0.0,
            max_steps: crate::integrators::MAX_STEPS,
        };
        let (x, k1, mut w) = one_step::<P>();
        let hs = HS;
        let raw = w.raw_error::<P>(&k1, &x, hs, &settings, 0.0).unwrap();
        let k = stages(&k1, &w.k);
        let through = w.manifold.error::<P>(
            (&mut |_, _| {}, None),
            hs,
            (&x, &w.y),
            &k[..=P::STAGES.len()],
            hs,
            &settings,
        );
        (raw, through)
    }

    /// `advance_dense` of ẏ = −y from y(0) = 1 to `ends` by `method`, with a projection
    /// that gives NaN past `breaks`: its result and the point it leaves.
    fn dense_with_projection_breaking_after(
        method: crate::integrators::Method,
        breaks: f64,
        error_on_manifold: bool,
        ends: (f64, f64),
    ) -> (Result<(), Failure>, f64, [f64; 1]) {
        let mut rhs = |_: f64, y: &[f64], d: &mut [f64]| d[0] = -y[0];
        let mut problem = crate::integrators::problem::Problem::new(&mut rhs);
        problem.error_on_manifold = error_on_manifold;
        let mut project = |t: f64, x: &mut [f64]| {
            if t > breaks {
                x[0] = f64::NAN;
            }
        };
        let settings = crate::integrators::test_support::adaptive(method, 1e-8, 1, 10.0);
        let (mut t, mut x) = (0.0, [1.0]);
        let r = crate::integrators::advance_dense(
            &mut problem,
            &mut project,
            (&mut t, &mut x),
            ends,
            &settings,
            &mut Memory::default(),
            &mut crate::integrators::Workspace::default(),
        );
        (r, t, x)
    }

    /// A projection that breaks down (NaN after t = 0.5) stops DOPRI5 and DOP853 as a NaN
    /// derivative does: NonFinite, the state left at the last step accepted, finite.
    #[test]
    fn a_projection_giving_nan_stops_the_method_at_the_last_good_state() {
        for method in [
            crate::integrators::Method::Dopri5,
            crate::integrators::Method::Dop853,
        ] {
            let (r, t, x) = dense_with_projection_breaking_after(method, 0.5, true, (1.0, 1.0));
            assert!(matches!(r, Err(Failure::NonFinite { .. })), "{r:?}");
            assert!(x[0].is_finite() && t <= 0.5, "{t} {x:?}");
        }
    }

    /// A step that covers the requested time is accepted, then f fails at its projected end
    /// (NaN past t = 0.25, the time asked for): the failure reports a last good point no
    /// later than that time, not the step's end past it (fmi2LastSuccessfulTime ≤ t + h;
    /// a random call sequence of Bricard found it reported past).
    #[test]
    fn a_failure_past_the_requested_time_reports_no_point_past_it() {
        for method in [
            crate::integrators::Method::Dopri5,
            crate::integrators::Method::Dop853,
        ] {
            let (r, t, x) = dense_with_projection_breaking_after(method, 0.25, false, (0.25, 10.0));
            assert!(
                matches!(r, Err(Failure::NonFinite { t }) if t > 0.25),
                "{r:?}"
            );
            assert!(x[0].is_finite() && t <= 0.25, "{t} {x:?}");
        }
    }

    /// A step of `P` ([`one_step`]) measured through a projection that sends every state to the origin
    /// (so the projected solutions always agree), with the defect `z ↦ z` when
    /// `with_defect`: the error it measures, and the norm of `y − x` (what the step added
    /// to the defect).
    fn error_collapsed<P: Pair>(with_defect: bool) -> (f64, f64) {
        let settings = crate::integrators::test_support::adaptive(
            crate::integrators::Method::Dop853,
            1e-9,
            2,
            1.0,
        );
        let (x, k1, mut w) = one_step::<P>();
        let hs = HS;
        let k = stages(&k1, &w.k);
        let mut defect = |_: f64, z: &[f64], d: &mut [f64]| {
            d.copy_from_slice(z);
            true
        };
        let defect = with_defect.then_some(&mut defect as &mut dyn FnMut(_, &_, &mut _) -> _);
        w.manifold.start_known = false;
        let err = w.manifold.error::<P>(
            (&mut |_, z: &mut [f64]| z.fill(0.0), defect),
            hs,
            (&x, &w.y),
            &k[..=P::STAGES.len()],
            hs,
            &settings,
        );
        let added = [w.y[0] - x[0], w.y[1] - x[1]];
        (err, rms_norm(&x, &w.y, &added, &settings))
    }

    /// Projected solutions that agree do not pass a step that left the constraints: with
    /// a defect, the error is at least what the step added to it (here all of it, as the
    /// step moved the state by far more than the tolerance).
    #[test]
    fn a_step_off_the_constraints_is_not_passed_by_its_projections_agreeing() {
        for (blind, (err, added)) in [
            (
                error_collapsed::<Dopri5>(false).0,
                error_collapsed::<Dopri5>(true),
            ),
            (
                error_collapsed::<Dop853>(false).0,
                error_collapsed::<Dop853>(true),
            ),
        ] {
            assert_eq!(blind, 0.0);
            assert!(added > 1e6, "{added}");
            assert_eq!(err, added);
        }
    }

    /// Measured on the manifold with nothing to project, each pair's error is the one it
    /// measures raw (the estimates and their norm are the same sums written twice: this
    /// keeps them one); it is large enough here that a lost term would show.
    #[test]
    fn the_error_on_the_manifold_without_constraints_is_the_raw_error() {
        for (raw, through) in [error_both_ways::<Dopri5>(), error_both_ways::<Dop853>()] {
            assert!(raw > 1.0, "{raw}");
            // y − (y − e) carries the rounding of |y| ~ 1 against |e| ≥ 6e-8 (DOP853's):
            // ≤ 4e-9 relative (measured 7e-11; DOPRI5's 2e-12).
            assert!((raw - through).abs() <= 1e-8 * raw, "{raw} vs {through}");
        }
    }
}
