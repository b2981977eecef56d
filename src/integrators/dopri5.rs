//! Dormand–Prince 5(4): explicit Runge–Kutta of order 5 with an embedded order-4 error
//! estimate, adaptive step, FSAL (the last stage of a step is the first of the next).
//!
//! Source of the coefficients, the error norm, the PI step-size controller and the initial
//! step: E. Hairer, S. P. Nørsett, G. Wanner, *Solving Ordinary Differential Equations I*,
//! 2nd ed., Springer 1993: Table II.5.2 (tableau), II.4 eq. (4.11) (norm) and p. 169
//! (initial step), IV.2 (PI / "Lund" stabilization); and Hairer's reference code `dopri5.f`
//! (subroutines DOPCOR and HINIT), whose default constants are reproduced below.

use super::blob::{put_f64s, Reader};
use super::buffers::sized;
use super::explicit_rk::{
    self, eval, hermite_blocks, rms_norm, step_past, Pair, PiGains, Point, Stages,
};
use super::problem::DenseCall;
use super::{Failure, Memory, Settings, Stats};

// Butcher tableau (Table II.5.2 / dopri5.f). c_i are the nodes, a_ij the stage weights.
// The 5th-order solution uses row 7 (A7j), which is also the FSAL stage.
const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;

const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
/// Row 7 = the 5th-order weights b_i (b2 = b7 = 0).
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;

// Error weights e_i = b_i - b̂_i (5th minus embedded 4th order), as in dopri5.f (e2 = 0).
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;

/// DOPRI5 in the loop it shares with DOP853 (landing mode: [`super::advance`]).
///
/// Counts: each call evaluates f once for its first stage (fresh, because inputs may have
/// changed since the last call), once more for [`hinit`] if `memory.h == 0`, and 6 times per
/// attempted step. On success therefore
/// `rhs_evals = 1 + [memory.h == 0] + 6·(steps + rejected)` for the call.
pub(super) struct Dopri5;

/// Component `i` of Σ eᵢ kᵢ, the difference of the 5th- and 4th-order solutions over h
/// (dopri5.f's error estimate), for [`Pair::error`] and [`Pair::estimates`].
fn error_term(k: &[&[f64]], i: usize) -> f64 {
    let &[k1, _, k3, k4, k5, k6, k7] = k else {
        unreachable!("DOPRI5 has 7 stages")
    };
    E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]
}
impl Pair for Dopri5 {
    const NAME: &'static str = "DOPRI5";
    const ORDER: i32 = 5;
    /// Hairer's PI controller with dopri5.f's defaults.
    const GAINS: PiGains = PiGains {
        // Lund stabilization: weighs in the previous error so the step sequence does not
        // oscillate between accept and reject (dopri5.f BETA = 0.04).
        beta: 0.04,
        // 1/5 for the order-4 estimate, minus 0.75·β so the PI controller stays stable
        // (dopri5.f: `EXPO1 = 0.2 - BETA*0.75`).
        expo1: 0.2 - 0.04 * 0.75,
        // Shrink a step at most 5× at once (dopri5.f FAC1): the error model is unreliable
        // far from the current step.
        fac_min: 0.2,
        // Grow a step at most 10× at once (dopri5.f FAC2), for the same reason.
        fac_max: 10.0,
    };
    const STAGES: &'static [(f64, &'static [(f64, usize)])] = &[
        (C2, &[(A21, 0)]),
        (C3, &[(A31, 0), (A32, 1)]),
        (C4, &[(A41, 0), (A42, 1), (A43, 2)]),
        (C5, &[(A51, 0), (A52, 1), (A53, 2), (A54, 3)]),
        (1.0, &[(A61, 0), (A62, 1), (A63, 2), (A64, 3), (A65, 4)]),
        (1.0, &[(A71, 0), (A73, 2), (A74, 3), (A75, 4), (A76, 5)]),
    ];
    const SOLUTION: Option<&'static [(f64, usize)]> = None;
    /// The sixth stage's argument y₆, for the stiffness test.
    const KEEP: Option<usize> = Some(4);

    /// Hairer's RMS norm of the local error estimate `h·Σ eᵢ kᵢ` with weights
    /// `atol + rtol·max(|x|, |y|)` (scipy's RK45 uses the same norm).
    fn error(x: &[f64], y: &[f64], k: &[&[f64]], hs: f64, settings: &Settings) -> f64 {
        let mut sum = 0.0;
        for i in 0..x.len() {
            let e = hs * error_term(k, i);
            let sk = settings.atol[i] + settings.rtol * x[i].abs().max(y[i].abs());
            sum += (e / sk).powi(2);
        }
        (sum / x.len().max(1) as f64).sqrt()
    }

    const ESTIMATES: usize = 1;

    /// `h·Σ eᵢ kᵢ`, the terms of [`Pair::error`].
    fn estimates(k: &[&[f64]], hs: f64, out: &mut [Vec<f64>]) {
        for (i, e) in out[0].iter_mut().enumerate() {
            *e = hs * error_term(k, i);
        }
    }

    fn error_of(x: &[f64], y: &[f64], e: &[Vec<f64>], settings: &Settings) -> f64 {
        rms_norm(x, y, &e[0], settings)
    }

    fn accepted(memory: &mut Memory, hs: f64, t_new: f64, w: &Stages) {
        let stiffness = &mut memory.stiffness;
        stiffness.observe(hs, (&w.k[5], &w.k[4]), (&w.y, &w.kept), t_new);
    }

    /// The continuous extension (dopri5.f RCONT), 5 blocks of n.
    fn record(x: &[f64], w: &Stages, k1: &[f64], k7: &[f64], hs: f64, record: &mut Vec<f64>) {
        let [_, k3, k4, k5, k6, _] = &w.k[..] else {
            unreachable!("DOPRI5 has 7 stages")
        };
        let r = sized(record, 5 * x.len());
        continuous_extension(x, &w.y, hs, [k1, k3, k4, k5, k6, k7], r);
    }
}

/// Dense-output mode: integration that runs ahead of the communication points.
///
/// The integrator keeps its own point `(t, x, f(t, x))` at the end of its last accepted
/// step, and takes the steps its controller wants, never shortened for a communication
/// point; a communication point inside the last step is read from the continuous
/// extension of order 4 (Hairer, ODE I, II.6; dopri5.f CONTD5), which costs no evaluation
/// of f. So the work of a run does not depend on the communication grid. Valid only while
/// f is unchanged (same inputs and parameters): the FMU drops it when an input changes.
#[derive(Clone, Debug, PartialEq)]
pub struct Ahead {
    /// The end of the last accepted step, its start and the controller's memory.
    pub point: Point,
    /// Continuous extension of the last step, 5 blocks of n (dopri5.f RCONT).
    pub rcont: Vec<f64>,
}

impl Ahead {
    /// The integrator at `point` ([`Point::start`]) before any step.
    pub fn new(point: Point) -> Ahead {
        let n = point.x.len();
        let mut rcont = vec![0.0; 5 * n];
        rcont[..n].copy_from_slice(&point.x);
        Ahead { point, rcont }
    }

    /// x(`t`) for `t` in [`t0`, `t`] of the last step: the continuous extension (CONTD5).
    pub fn interpolate(&self, t: f64, out: &mut [f64]) {
        let p = &self.point;
        let n = p.x.len();
        if t == p.t {
            out.copy_from_slice(&p.x);
            return;
        }
        let h = p.t - p.t0;
        let theta = if h > 0.0 { (t - p.t0) / h } else { 0.0 };
        let theta1 = 1.0 - theta;
        let r = |j: usize, i: usize| self.rcont[j * n + i];
        for (i, o) in out.iter_mut().enumerate() {
            *o = r(0, i)
                + theta * (r(1, i) + theta1 * (r(2, i) + theta * (r(3, i) + theta1 * r(4, i))));
        }
    }
}

impl Ahead {
    /// Its block of the FMU state (see [`super::Memory::write`]): the point, then the
    /// continuous extension.
    pub(crate) fn write(&self, b: &mut Vec<u8>) {
        self.point.write(b);
        put_f64s(b, &self.rcont);
    }

    /// Reads what [`Ahead::write`] wrote for `n` states, and checks it.
    pub(crate) fn read(r: &mut Reader, n: usize) -> Result<Ahead, String> {
        let (point, rcont) = (Point::read(r, n)?, r.f64s(5 * n)?);
        if !point.is_sound() || !rcont.iter().all(|v| v.is_finite()) {
            return Err("FMU state holds an invalid integrator point".into());
        }
        Ok(Ahead { point, rcont })
    }
}

/// Hairer's stiffness detection (dopri5.f, NSTIFF): both f(t+h, y₁) and the sixth stage
/// f(t+h, y₆) are taken at t + h, so `h·|f(y₁) − f(y₆)| / |y₁ − y₆|` estimates h·|λ| for
/// the dominant eigenvalue. Above 3.25 (DOPRI5's stability boundary on the negative axis
/// is ≈ 3.3) the step is limited by stability, not accuracy; 15 such steps in a row make
/// the problem "seem stiff", 6 calm steps reset the count. The FMU reports the first
/// detection as a warning: the results stay correct (the error control still holds) but
/// RADAU5 would take far fewer steps, and at loose tolerances an explicit method can run
/// away while its relative error estimate still passes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StiffnessMonitor {
    /// Consecutive steps at the stability boundary (dopri5.f IASTI).
    pub suspicious: u32,
    /// Consecutive steps below it since the last suspicious one (dopri5.f NONSTI).
    pub calm: u32,
    /// Where the problem first seemed stiff (and no one has reported it yet).
    pub detected_at: Option<f64>,
    /// Whether a detection has been reported: one warning per run.
    pub reported: bool,
}

/// h·|λ| above which a DOPRI5 step counts as stability-limited (dopri5.f: 3.25).
const STIFF_H_LAMBDA: f64 = 3.25;
/// Consecutive stability-limited steps that make a problem "seem stiff" (dopri5.f: 15).
const STIFF_STEPS: u32 = 15;
/// Consecutive calm steps that reset the count (dopri5.f: 6).
const CALM_STEPS: u32 = 6;

impl StiffnessMonitor {
    /// Its block of the FMU state (see [`super::Memory::write`]).
    pub(crate) fn write(&self, b: &mut Vec<u8>) {
        b.extend_from_slice(&self.suspicious.to_le_bytes());
        b.extend_from_slice(&self.calm.to_le_bytes());
        b.push(self.detected_at.is_some() as u8);
        put_f64s(b, &[self.detected_at.unwrap_or(0.0)]);
        b.push(self.reported as u8);
    }

    /// Reads what [`StiffnessMonitor::write`] wrote, and checks it.
    pub(crate) fn read(r: &mut Reader) -> Result<StiffnessMonitor, String> {
        let (suspicious, calm) = (r.u32()?, r.u32()?);
        let (has_detected, detected) = (r.take(1)?[0], r.f64()?);
        let reported = r.take(1)?[0];
        if has_detected > 1 || reported > 1 || !detected.is_finite() {
            return Err("FMU state holds an invalid stiffness monitor".into());
        }
        Ok(StiffnessMonitor {
            suspicious,
            calm,
            detected_at: (has_detected == 1).then_some(detected),
            reported: reported == 1,
        })
    }

    /// One accepted step of size `h` ending at `t` with `(f(y₁), f(y₆))` and `(y₁, y₆)`.
    fn observe(&mut self, h: f64, (f1, f6): (&[f64], &[f64]), (y1, y6): (&[f64], &[f64]), t: f64) {
        let num: f64 = f1.iter().zip(f6).map(|(a, b)| (a - b) * (a - b)).sum();
        let den: f64 = y1.iter().zip(y6).map(|(a, b)| (a - b) * (a - b)).sum();
        if den <= 0.0 {
            return;
        }
        if h * (num / den).sqrt() > STIFF_H_LAMBDA {
            self.calm = 0;
            self.suspicious += 1;
            if self.suspicious == STIFF_STEPS && !self.reported && self.detected_at.is_none() {
                self.detected_at = Some(t);
            }
        } else {
            self.calm += 1;
            if self.calm == CALM_STEPS {
                self.suspicious = 0;
            }
        }
    }
}

/// Dense-output coefficients d_i of dopri5.f (the order-4 continuous extension).
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

/// Dense mode (see [`Ahead`]) for one [`DenseCall`]: steps `ahead` until its last step
/// covers `t_out`, then writes x(`t_out`) into `out`. Steps are cut only to land on
/// `t_limit` (the experiment's stop time, or +∞), which the integrator never passes. `t_out`
/// must lie in [`ahead.t0`, `t_limit`].
///
/// `project` maps a state back onto the system's constraints (or leaves it alone); it is
/// applied after every accepted step, so the steps do not depend on the communication
/// grid either, and f is evaluated again where it changed the state.
///
/// Counts: 6 evaluations of f per attempted step, one more for [`hinit`] if
/// `memory.h == 0`, one per step the projection changed, none for a `t_out` already
/// covered. On failure `ahead` holds the last accepted step and `memory.h` is reset.
/// No allocation once the call's scratch has held this size.
pub fn advance_dense_in(ahead: &mut Ahead, c: DenseCall<Scratch>) -> Result<(), Failure> {
    let (t_out, t_limit) = (c.t_out, c.t_limit);
    assert!(
        t_out >= ahead.point.t0 && t_out <= t_limit,
        "dopri5::advance_dense: t_out = {t_out} outside [{}, {t_limit}]",
        ahead.point.t0
    );
    let Point {
        t,
        x,
        f,
        t0,
        err_prev,
    } = &mut ahead.point;
    let (point, ends) = ((t, &mut x[..], f), (t_out, t_limit));
    let (settings, memory, work) = (c.settings, c.memory, c.work);
    let past = step_past::<Dopri5>(
        c.problem, c.project, point, *err_prev, ends, settings, memory, work,
    )?;
    if let Some(last) = past {
        *t0 = last.t0;
        *err_prev = last.err_prev;
        std::mem::swap(&mut ahead.rcont, &mut work.record);
    }
    ahead.interpolate(t_out, c.out);
    Ok(())
}

/// DOPRI5's part of a [`Workspace`](super::Workspace): its record is the continuous
/// extension of the last step of a dense call (swapped into [`Ahead::rcont`]).
pub type Scratch = explicit_rk::Scratch;

/// scipy's `solve_ivp(method="RK45")` step-size controller around this file's step, for
/// conformance testing only (not an FMU solver): the same Dormand–Prince pair and error
/// norm, with scipy's rules instead of Hairer's: a pure I-controller
/// `h·min(10, 0.9·err^(−1/5))` on acceptance (`err < 1`, strictly; capped at 1 after a
/// rejection in the same step), `h·max(0.2, 0.9·err^(−1/5))` on rejection, no PI term, no
/// 1 % landing stretch, scipy's initial step (`select_initial_step` with order 4) and its
/// step floor of 10 ulps of t. From `t0` to `t_bound` with one absolute tolerance per
/// component; returns the accepted step end times. `stats.rhs_evals` then equals scipy's
/// `nfev`: 1 (f at t0) + 1 (initial step) + 6 per attempted step.
pub fn scipy_rk45(
    rhs: &mut dyn FnMut(f64, &[f64], &mut [f64]),
    t0: f64,
    x: &mut [f64],
    t_bound: f64,
    (rtol, atol): (f64, &[f64]),
    max_step: f64,
    stats: &mut Stats,
) -> Result<Vec<f64>, Failure> {
    const SAFETY: f64 = 0.9;
    const MIN_FACTOR: f64 = 0.2;
    const MAX_FACTOR: f64 = 10.0;
    const EXPONENT: f64 = -1.0 / 5.0;
    let n = x.len();
    let settings = Settings {
        method: super::Method::Dopri5,
        rtol,
        atol: atol.to_vec(),
        step: max_step,
        max_steps: super::MAX_STEPS,
    };
    let mut f = vec![0.0; n];
    if !eval(rhs, t0, x, &mut f, stats) {
        return Err(Failure::NonFinite { t: t0 });
    }
    // select_initial_step (scipy/integrate/_ivp/common.py), order 4.
    let rms = |v: &mut dyn Iterator<Item = f64>| (v.map(|c| c * c).sum::<f64>() / n as f64).sqrt();
    let scale: Vec<f64> = (0..n).map(|i| atol[i] + x[i].abs() * rtol).collect();
    let d0 = rms(&mut (0..n).map(|i| x[i] / scale[i]));
    let d1 = rms(&mut (0..n).map(|i| f[i] / scale[i]));
    let interval = (t_bound - t0).abs();
    let h0 = if d0 < 1e-5 || d1 < 1e-5 {
        1e-6
    } else {
        0.01 * d0 / d1
    }
    .min(interval);
    let y1: Vec<f64> = (0..n).map(|i| x[i] + h0 * f[i]).collect();
    let mut f1 = vec![0.0; n];
    if !eval(rhs, t0 + h0, &y1, &mut f1, stats) {
        return Err(Failure::NonFinite { t: t0 });
    }
    let d2 = rms(&mut (0..n).map(|i| (f1[i] - f[i]) / scale[i])) / h0;
    let h1 = if d1 <= 1e-15 && d2 <= 1e-15 {
        (h0 * 1e-3).max(1e-6)
    } else {
        (0.01 / d1.max(d2)).powf(1.0 / 5.0)
    };
    let mut h_abs = (100.0 * h0).min(h1).min(interval).min(max_step);

    let mut w = Stages::default();
    w.size(Dopri5::STAGES.len(), n);
    let mut t = t0;
    let mut times = Vec::new();
    while t < t_bound {
        let min_step = 10.0 * (next_up(t) - t);
        h_abs = h_abs.min(max_step).max(min_step);
        let mut rejected = false;
        loop {
            if h_abs < min_step {
                return Err(Failure::StepTooSmall { t, h: h_abs });
            }
            let t_new = (t + h_abs).min(t_bound);
            let h = t_new - t;
            h_abs = h.abs();
            let err = w.attempt::<Dopri5>(rhs, &f, (t, t_new), x, h, &settings, stats)?;
            if err < 1.0 {
                let mut factor = if err == 0.0 {
                    MAX_FACTOR
                } else {
                    MAX_FACTOR.min(SAFETY * err.powf(EXPONENT))
                };
                if rejected {
                    factor = factor.min(1.0);
                }
                h_abs *= factor;
                stats.steps += 1;
                x.copy_from_slice(&w.y);
                std::mem::swap(&mut f, &mut w.k[5]);
                t = t_new;
                times.push(t);
                break;
            }
            stats.rejected += 1;
            h_abs *= MIN_FACTOR.max(SAFETY * err.powf(EXPONENT));
            rejected = true;
        }
    }
    Ok(times)
}

/// The next f64 above `t` (numpy's `nextafter(t, inf)`).
fn next_up(t: f64) -> f64 {
    if t.is_nan() || t == f64::INFINITY {
        return t;
    }
    if t == 0.0 {
        return f64::from_bits(1);
    }
    let bits = t.to_bits();
    f64::from_bits(if t > 0.0 { bits + 1 } else { bits - 1 })
}

/// dopri5.f's RCONT for the step x → y of size h with stages k1, k3 … k7 (k7 = f(y)).
fn continuous_extension(x: &[f64], y: &[f64], h: f64, k: [&[f64]; 6], r: &mut [f64]) {
    let n = x.len();
    let [k1, k3, k4, k5, k6, k7] = k;
    for i in 0..n {
        hermite_blocks(r, (n, i), (x, y), h, (k1, k7));
        r[4 * n + i] =
            h * (D1 * k1[i] + D3 * k3[i] + D4 * k4[i] + D5 * k5[i] + D6 * k6[i] + D7 * k7[i]);
    }
}

#[cfg(test)]
mod tests {
    use super::super::problem::Problem;
    use super::super::test_support::{
        adaptive, broken_decay, decay, dense_call, one, oscillator, oscillator_error, square,
    };
    use super::super::{self as integ, Method, MAX_STEPS};
    use super::*;

    fn settings(tol: f64, n: usize, step: f64) -> Settings {
        adaptive(Method::Dopri5, tol, n, step)
    }

    /// Dense mode on the oscillator up to `t_out` (no projection) in fresh scratch.
    fn dense_to(
        ahead: &mut Ahead,
        ends: (f64, f64),
        (s, memory): (&Settings, &mut Memory),
        out: &mut [f64],
    ) -> Result<(), Failure> {
        let mut rhs = oscillator;
        let p = &mut Problem::new(&mut rhs);
        advance_dense_in(
            ahead,
            dense_call(p, ends, (s, memory), (out, &mut Scratch::default())),
        )
    }

    /// Evaluations one successful call must have made, per the formula in [`advance_in`].
    fn expected_evals(calls: u64, hinits: u64, s: Stats) -> u64 {
        calls + hinits + 6 * (s.steps + s.rejected)
    }

    #[test]
    fn tableau_is_consistent() {
        let rows: [&[f64]; 6] = [
            &[A21],
            &[A31, A32],
            &[A41, A42, A43],
            &[A51, A52, A53, A54],
            &[A61, A62, A63, A64, A65],
            &[A71, 0.0, A73, A74, A75, A76],
        ];
        let c = [C2, C3, C4, C5, 1.0, 1.0];
        for (row, ci) in rows.iter().zip(c) {
            assert!((row.iter().sum::<f64>() - ci).abs() < 1e-14);
        }
        // e = b - b̂ with Hairer's embedded 4th-order weights b̂.
        let b_hat = [
            5179.0 / 57600.0,
            7571.0 / 16695.0,
            393.0 / 640.0,
            -92097.0 / 339200.0,
            187.0 / 2100.0,
            1.0 / 40.0,
        ];
        let b = [A71, A73, A74, A75, A76, 0.0];
        let e = [E1, E3, E4, E5, E6, E7];
        for i in 0..6 {
            assert!((b[i] - b_hat[i] - e[i]).abs() < 1e-15, "e{i}");
        }
        assert!(e.iter().sum::<f64>().abs() < 1e-15);
    }

    fn oscillator_run(tol: f64) -> ([f64; 2], Stats) {
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        let s = settings(tol, 2, 1.0);
        integ::advance(&mut oscillator, &mut t, &mut x, 10.0, &s, &mut memory).unwrap();
        assert_eq!(t.to_bits(), 10.0f64.to_bits());
        assert_eq!(memory.stats.rhs_evals, expected_evals(1, 1, memory.stats));
        (x, memory.stats)
    }

    #[test]
    fn dopri5_oscillator_error_scales_with_tolerance() {
        let (x8, s8) = oscillator_run(1e-8);
        let (x10, s10) = oscillator_run(1e-10);
        let (e8, e10) = (oscillator_error(10.0, &x8), oscillator_error(10.0, &x10));
        // Measured: e8 = 1.51e-7 (1110 steps, 0 rejected), e10 = 1.58e-9 (2813 steps, 0
        // rejected): ratio 95. Global error over 16 periods: ~15× the tolerance, within 100×.
        assert!(e8 < 100.0 * 1e-8, "e8 = {e8:e}");
        assert!(e10 < 100.0 * 1e-10, "e10 = {e10:e}");
        assert!(e8 > 20.0 * e10, "e8 = {e8:e}, e10 = {e10:e}");
        // Order 5: 100× tighter tolerance costs about 100^(1/5) ≈ 2.5× the steps.
        let ratio = s10.steps as f64 / s8.steps as f64;
        assert!((2.0..3.2).contains(&ratio), "step ratio {ratio}");
    }

    #[test]
    fn dopri5_respects_max_step() {
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        let s = settings(1e-4, 2, 0.01);
        let mut starts = vec![];
        let mut f = |t: f64, y: &[f64], d: &mut [f64]| {
            starts.push(t);
            oscillator(t, y, d)
        };
        integ::advance(&mut f, &mut t, &mut x, 10.0, &s, &mut memory).unwrap();
        // Uncapped, 1e-4 needs 168 steps (h up to 0.065); capped: a short hinit step
        // (h = 3.5e-5), then 1000 steps of 0.01 (measured 1001, the last one landing).
        assert_eq!(memory.stats.steps, 1001);
        assert!(memory.h <= 0.01);
        // Every f call is at most one step after the previous one (stage times are monotone
        // within a step, FSAL starts the next), so no step exceeded the cap.
        for w in starts.windows(2) {
            assert!(w[1] - w[0] <= 0.01 * (1.0 + 1e-9), "{} -> {}", w[0], w[1]);
        }
    }

    /// Deterministic, uneven chunk boundaries: 0 = b_0 < b_1 < … < b_n = t_end exactly.
    fn chunk_ends(n: usize, t_end: f64) -> Vec<f64> {
        let mut state: u64 = 0x2545_f491_4f6c_dd1d;
        let weights: Vec<f64> = (0..n)
            .map(|_| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                0.2 + 1.6 * ((state >> 11) as f64 / (1u64 << 53) as f64)
            })
            .collect();
        let total: f64 = weights.iter().sum();
        let mut acc = 0.0;
        let mut ends: Vec<f64> = weights
            .iter()
            .map(|w| {
                acc += w;
                t_end * acc / total
            })
            .collect();
        *ends.last_mut().unwrap() = t_end;
        ends
    }

    fn chunked_run(tol: f64, t_end: f64, n: usize) -> ([f64; 2], Stats) {
        let s = settings(tol, 2, 10.0);
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        let mut hinits = 0;
        for end in chunk_ends(n, t_end) {
            hinits += u64::from(memory.h == 0.0);
            integ::advance(&mut oscillator, &mut t, &mut x, end, &s, &mut memory).unwrap();
            assert_eq!(t.to_bits(), end.to_bits());
        }
        assert_eq!(t.to_bits(), t_end.to_bits());
        assert_eq!(hinits, 1);
        assert_eq!(
            memory.stats.rhs_evals,
            expected_evals(n as u64, hinits, memory.stats)
        );
        (x, memory.stats)
    }

    fn single_run(tol: f64, t_end: f64) -> ([f64; 2], Stats) {
        let s = settings(tol, 2, 10.0);
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        integ::advance(&mut oscillator, &mut t, &mut x, t_end, &s, &mut memory).unwrap();
        (x, memory.stats)
    }

    #[test]
    fn dopri5_chunked_lands_exactly_and_agrees() {
        // 1000 chunks over 10 s: mean 0.01 s, about the natural step at 1e-8 (0.0095 s).
        // (chunked_run asserts every chunk and the end land bit for bit.)
        let (xc, sc) = chunked_run(1e-8, 10.0, 1000);
        let (xs, ss) = single_run(1e-8, 10.0);
        let diff = (xc[0] - xs[0]).abs().max((xc[1] - xs[1]).abs() / 10.0);
        // Measured: diff 3.7e-8; errors vs closed form 1.1e-7 (chunked), 1.5e-7 (single).
        assert!(diff < 10.0 * 1e-8, "diff {diff:e}");
        assert!(oscillator_error(10.0, &xc) < 100.0 * 1e-8);
        // Chunks as short as the step cost about one step each (measured 1563 + 22 rejected
        // vs 1110 single; 2393 if the proposal were re-estimated every call).
        let ratio = (sc.steps + sc.rejected) as f64 / ss.steps as f64;
        assert!(ratio < 1.6, "chunked {sc:?} vs single {ss:?}");
    }

    #[test]
    fn dopri5_carried_step_keeps_chunked_cost_near_single_call() {
        // 1000 uneven chunks over 30 s: mean 0.03 s ≈ 3 natural steps per chunk.
        let (xc, sc) = chunked_run(1e-8, 30.0, 1000);
        let (xs, ss) = single_run(1e-8, 30.0);
        let ratio = (sc.steps + sc.rejected) as f64 / ss.steps as f64;
        // Measured: chunked 3776 + 2 rejected vs single 3330 → 1.13 (about the half step per
        // chunk that landing costs). Re-estimating h every call gives 4980 (1.50); carrying
        // h but restarting the PI term cold (facold = 1e-4) gave 4252 (1.28).
        assert!(ratio < 1.25, "chunked {sc:?} vs single {ss:?}");
        let diff = (xc[0] - xs[0]).abs().max((xc[1] - xs[1]).abs() / 10.0);
        // Measured: 2.0e-8, against a global error of 5.8e-7 of either run.
        assert!(diff < 10.0 * 1e-8, "diff {diff:e}");
    }

    #[test]
    fn dopri5_landing_step_does_not_shrink_carried_proposal() {
        let s = settings(1e-8, 2, 10.0);
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [1.0, 0.0]);
        integ::advance(&mut oscillator, &mut t, &mut x, 1.0, &s, &mut memory).unwrap();
        let h = memory.h;
        // A tiny chunk is a single, very short step with a tiny error.
        integ::advance(
            &mut oscillator,
            &mut t,
            &mut x,
            1.0 + h * 1e-3,
            &s,
            &mut memory,
        )
        .unwrap();
        assert!(memory.h >= h, "carried {} shrank below {h}", memory.h);
        assert!(
            memory.h <= 1.5 * h,
            "carried {} grew from a sliver",
            memory.h
        );
    }

    #[test]
    fn dopri5_does_not_carry_last_stage_across_calls() {
        // y' = u, with the input u changed between calls: exact for any step, so the result
        // shows whether the second call used the old derivative as its first stage.
        let s = settings(1e-8, 1, 10.0);
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [0.0]);
        let mut u = 1.0;
        integ::advance(
            &mut |_, _, d| d[0] = u,
            &mut t,
            &mut x,
            1.0,
            &s,
            &mut memory,
        )
        .unwrap();
        u = 2.0;
        integ::advance(
            &mut |_, _, d| d[0] = u,
            &mut t,
            &mut x,
            2.0,
            &s,
            &mut memory,
        )
        .unwrap();
        assert!((x[0] - 3.0).abs() < 1e-14, "x = {}", x[0]);
    }

    #[test]
    fn dopri5_blow_up_fails_before_singularity() {
        // y' = y², y(0) = 1: y = 1/(1 - t) blows up at t = 1. The numerical solution has its
        // own pole, displaced by the global error (y off by a relative δ moves it by ~δ), so it
        // can lie a hair past 1: measured stops at 1 - 5.8e-5 (tol 1e-3), 1 + 7.6e-6 (1e-4),
        // 1 + 3.2e-7 (1e-6), 1 + 1.1e-9 (1e-8), 1 - 1.7e-11 (1e-10), all StepTooSmall
        // with y ≈ 1e13..2e14.
        for (tol, before_one) in [
            (1e-3, true),
            (1e-4, false),
            (1e-6, false),
            (1e-8, false),
            (1e-10, true),
        ] {
            let s = settings(tol, 1, 10.0);
            let mut memory = Memory::default();
            let (mut t, mut x) = (0.0, [1.0]);
            let r = integ::advance(&mut square, &mut t, &mut x, 2.0, &s, &mut memory);
            match r {
                Err(Failure::StepTooSmall { t: tf, .. }) | Err(Failure::NonFinite { t: tf }) => {
                    assert_eq!(tf, t)
                }
                other => panic!("expected a failure, got {other:?}"),
            }
            if before_one {
                assert!(t < 1.0, "tol {tol:e}: t = {t}");
            }
            assert!((t - 1.0).abs() < 10.0 * tol, "tol {tol:e}: t = {t}");
            assert!(x[0].is_finite() && x[0] > 1e12, "tol {tol:e}: x = {}", x[0]);
            assert_eq!(
                memory.h, 0.0,
                "a failed call must not leave a hopeless proposal"
            );
        }
    }

    #[test]
    fn dopri5_gives_up_after_max_steps() {
        // A max step of 1e-7 over 1 s would need 1e7 steps.
        let s = settings(1e-6, 1, 1e-7);
        assert_eq!(s.max_steps, MAX_STEPS);
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [0.0]);
        let r = integ::advance(&mut one, &mut t, &mut x, 1.0, &s, &mut memory);
        assert_eq!(
            r,
            Err(Failure::TooManySteps {
                t,
                steps: MAX_STEPS
            })
        );
        assert_eq!(memory.stats.steps + memory.stats.rejected, MAX_STEPS);
        assert!((t - 0.1).abs() < 1e-6 && (x[0] - t).abs() < 1e-9, "t = {t}");
        assert_eq!(memory.h, 0.0);
        // The limit is the caller's (the FMU's solver_max_steps): 1000 attempts, t = 1e-4.
        let s = Settings {
            max_steps: 1000,
            ..s
        };
        let (mut t, mut x) = (0.0, [0.0]);
        let r = integ::advance(&mut one, &mut t, &mut x, 1.0, &s, &mut memory);
        assert_eq!(r, Err(Failure::TooManySteps { t, steps: 1000 }));
        assert!((t - 1e-4).abs() < 1e-9, "t = {t}");
    }

    #[test]
    fn dopri5_nan_rhs_stops_at_last_good_state() {
        let s = settings(1e-8, 1, 10.0);
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [1.0]);
        let r = integ::advance(&mut broken_decay, &mut t, &mut x, 1.0, &s, &mut memory);
        assert_eq!(r, Err(Failure::NonFinite { t }));
        assert!(t <= 0.5 && t > 0.3, "t = {t}");
        assert!((x[0] - (-t).exp()).abs() < 1e-7);
    }

    #[test]
    fn dopri5_decay_error_tracks_tolerance() {
        // y' = -y, y(0) = 1, to t = 1: the global error should be of the order of the tolerance,
        // and error against work (steps) should fall like steps⁻⁵.
        let mut runs = vec![];
        for k in 4..=11 {
            let tol = 10f64.powi(-k);
            let s = settings(tol, 1, 10.0);
            let mut memory = Memory::default();
            let (mut t, mut x) = (0.0, [1.0]);
            integ::advance(&mut decay, &mut t, &mut x, 1.0, &s, &mut memory).unwrap();
            let err = (x[0] - (-1f64).exp()).abs();
            // Measured err/tol: 0.012, 0.031, 0.063, 0.094, 0.107, 0.131, 0.135, 0.143
            // with 4, 5, 6, 9, 12, 18, 26, 40 steps for tol = 1e-4 … 1e-11.
            assert!(
                err < 0.5 * tol && err > 0.005 * tol,
                "tol {tol:e}: err {err:e}"
            );
            assert_eq!(memory.stats.rhs_evals, expected_evals(1, 1, memory.stats));
            runs.push((memory.stats.steps as f64, err));
        }
        // Tolerance 1e-6 → 1e-11: 6 → 40 steps, error 6.3e-8 → 1.4e-12: slope 5.6.
        let ((n0, e0), (n1, e1)) = (runs[2], runs[7]);
        let order = (e0 / e1).ln() / (n1 / n0).ln();
        assert!((4.5..7.0).contains(&order), "observed order {order}");
    }

    #[test]
    fn dopri5_is_fifth_order_with_capped_steps() {
        // Loose tolerances so the max step always binds: DOPRI5 becomes a fixed-step method
        // and the error ratio for h and h/2 shows its order.
        let run = |h: f64| {
            let s = settings(1e3, 1, h);
            let mut memory = Memory::default();
            let (mut t, mut x) = (0.0, [1.0]);
            integ::advance(&mut decay, &mut t, &mut x, 2.0, &s, &mut memory).unwrap();
            assert_eq!(memory.stats.steps as f64, (2.0 / h).round());
            (x[0] - (-2f64).exp()).abs()
        };
        let (e1, e2, e3) = (run(0.1), run(0.05), run(0.025));
        // Measured errors 8.9e-10, 2.6e-11, 7.7e-13: ratios 34.8, 33.4 (order 5 ⇒ 2⁵ = 32).
        for ratio in [e1 / e2, e2 / e3] {
            assert!((28.0..38.0).contains(&ratio), "ratio {ratio}");
        }
    }

    /// Dense mode on the oscillator: reads x at every point of a grid `dt` up to 10 s.
    /// Returns the worst error on the grid, the work, and the integrator's own end point.
    fn dense_run(tol: f64, dt: f64) -> (f64, Stats, Ahead) {
        let mut memory = Memory::default();
        let s = settings(tol, 2, f64::INFINITY);
        let mut ahead =
            Ahead::new(Point::start(&mut oscillator, 0.0, &[1.0, 0.0], &mut memory.stats).unwrap());
        let (mut worst, mut out) = (0.0f64, [0.0; 2]);
        let steps = (10.0 / dt).round() as usize;
        for i in 1..=steps {
            let t_out = i as f64 * dt;
            dense_to(&mut ahead, (t_out, 10.0), (&s, &mut memory), &mut out).unwrap();
            worst = worst.max(oscillator_error(t_out, &out));
        }
        (worst, memory.stats, ahead)
    }

    #[test]
    fn dense_output_work_does_not_depend_on_the_output_grid() {
        // The steps are the controller's alone: a grid 1000× finer costs no evaluation
        // more, and the integrator ends at the same point bit for bit.
        let (e_coarse, s_coarse, a_coarse) = dense_run(1e-8, 0.1);
        let (e_fine, s_fine, a_fine) = dense_run(1e-8, 1e-4);
        assert_eq!(s_coarse, s_fine);
        assert_eq!(a_coarse, a_fine);
        assert_eq!(a_fine.point.t, 10.0, "lands on the limit");
        // 1 start + 1 hinit + 6 per attempt.
        assert_eq!(s_fine.rhs_evals, 2 + 6 * (s_fine.steps + s_fine.rejected));
        // Interpolated values are as accurate as the steps: order-4 extension of an
        // order-5 method, error at the level of the global error (measured 1.9e-7 worst
        // on the 1e-4 grid, 1.5e-7 at the end of a run landing on 10 s: tol 1e-8 over
        // 16 periods).
        let (e_steps, _) = oscillator_run(1e-8);
        let e_steps = oscillator_error(10.0, &e_steps);
        println!("METRIC dense grid error {e_fine:.2e} (coarse {e_coarse:.2e}), end {e_steps:.2e}");
        assert!(
            e_fine < 5.0 * e_steps.max(1e-8),
            "{e_fine:e} vs {e_steps:e}"
        );
    }

    #[test]
    fn continuous_extension_hits_both_ends_of_a_step() {
        let mut memory = Memory::default();
        let s = settings(1e-6, 2, f64::INFINITY);
        let x0 = [1.0, 0.0];
        let mut ahead =
            Ahead::new(Point::start(&mut oscillator, 0.0, &x0, &mut memory.stats).unwrap());
        let mut out = [0.0; 2];
        dense_to(&mut ahead, (1e-9, 1.0), (&s, &mut memory), &mut out).unwrap();
        assert_eq!(memory.stats.steps, 1);
        let mut at = [0.0; 2];
        ahead.interpolate(ahead.point.t0, &mut at);
        assert_eq!(at, x0);
        // θ = 1 reproduces the step's end value up to rounding of the polynomial.
        let h = ahead.point.t - ahead.point.t0;
        ahead.interpolate(ahead.point.t0 + h * (1.0 - 1e-16), &mut at);
        for (a, x) in at.iter().zip(&ahead.point.x) {
            assert!((a - x).abs() <= 1e-14 * (1.0 + x.abs()));
        }
    }
}
