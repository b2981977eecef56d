//! What DOPRI5 and DOP853 share: the stage sum, Hairer's error weights, the initial
//! step (E. Hairer, S. P. Nørsett, G. Wanner, *Solving Ordinary Differential Equations
//! I*, II.4 p. 169; HINIT of dopri5.f / dop853.f), and the landing and step-floor rules.

use super::{Failure, Settings, Stats};

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

/// The largest step `settings.step` allows: itself if positive and finite, else none (∞).
pub(super) fn max_step(settings: &Settings) -> f64 {
    if settings.step > 0.0 && settings.step.is_finite() {
        settings.step
    } else {
        f64::INFINITY
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

/// The constants of Hairer's PI controller for one method (dopri5.f / dop853.f defaults).
pub(super) struct PiGains {
    /// Lund-stabilisation exponent on the previous error.
    pub beta: f64,
    /// Exponent on the current error.
    pub expo1: f64,
    /// Fraction of the step the error model allows that is aimed at.
    pub safety: f64,
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
        let mut h_new = hs / (fac / g.safety).clamp(1.0 / g.fac_max, 1.0 / g.fac_min);
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
        hs / (err.powf(g.expo1) / g.safety).min(1.0 / g.fac_min)
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
