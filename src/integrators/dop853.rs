//! DOP853: explicit Runge–Kutta of order 8 (Dormand–Prince 8(5,3)), 12 stages, adaptive step,
//! first-same-as-last. For smooth non-stiff problems at tight tolerances it takes far fewer
//! steps than DOPRI5.
//!
//! Source of the coefficients, the combined 5th/3rd-order error estimate, the step-size
//! controller and its defaults: E. Hairer, S. P. Nørsett, G. Wanner, *Solving Ordinary
//! Differential Equations I*, 2nd ed., Springer 1993, Sect. II.10 (the method DOP853 and its
//! combined error estimator), and Hairer's reference code `dop853.f` (subroutines DP86CO and
//! HINIT, version of 2004), whose coefficient values (30 digits) and default constants are
//! reproduced below. The controller is the one of [`super::dopri5`] with dop853.f's defaults.

// The coefficients are copied digit for digit from Hairer's Fortran source, so that they can
// be checked against it; the compiler rounds them to the nearest f64.
#![allow(clippy::excessive_precision)]

use super::explicit_rk::{
    carried_proposal, check_attempt, initial_step, stage, PiController, PiGains, FACOLD_MIN,
    LANDING_STRETCH,
};
use super::problem::{start, Problem};
use super::{Failure, Memory, Settings};

// Nodes c_i (dop853.f; c12 = 1; c13..c16 belong to dense output, not implemented).
const C2: f64 = 0.526001519587677318785587544488e-01;
const C3: f64 = 0.789002279381515978178381316732e-01;
const C4: f64 = 0.118350341907227396726757197510e+00;
const C5: f64 = 0.281649658092772603273242802490e+00;
const C6: f64 = 0.333333333333333333333333333333e+00;
const C7: f64 = 0.25e+00;
const C8: f64 = 0.307692307692307692307692307692e+00;
const C9: f64 = 0.651282051282051282051282051282e+00;
const C10: f64 = 0.6e+00;
const C11: f64 = 0.857142857142857142857142857142e+00;

// 8th-order weights b_i (b2..b5 = 0).
const B1: f64 = 5.42937341165687622380535766363e-2;
const B6: f64 = 4.45031289275240888144113950566e0;
const B7: f64 = 1.89151789931450038304281599044e0;
const B8: f64 = -5.8012039600105847814672114227e0;
const B9: f64 = 3.1116436695781989440891606237e-1;
const B10: f64 = -1.52160949662516078556178806805e-1;
const B11: f64 = 2.01365400804030348374776537501e-1;
const B12: f64 = 4.47106157277725905176885569043e-2;

// Third-order embedded weights (on stages 1, 9, 12): err3 = Σ b_i k_i − (BHH1 k1 + BHH2 k9 + BHH3 k12).
const BHH1: f64 = 0.244094488188976377952755905512e+00;
const BHH2: f64 = 0.733846688281611857341361741547e+00;
const BHH3: f64 = 0.220588235294117647058823529412e-01;

// Fifth-order error weights e_i (e2..e5 = 0): err5 = Σ e_i k_i.
const ER1: f64 = 0.1312004499419488073250102996e-01;
const ER6: f64 = -0.1225156446376204440720569753e+01;
const ER7: f64 = -0.4957589496572501915214079952e+00;
const ER8: f64 = 0.1664377182454986536961530415e+01;
const ER9: f64 = -0.3503288487499736816886487290e+00;
const ER10: f64 = 0.3341791187130174790297318841e+00;
const ER11: f64 = 0.8192320648511571246570742613e-01;
const ER12: f64 = -0.2235530786388629525884427845e-01;

// Stage weights a_ij (zeros omitted).
const A21: f64 = 5.26001519587677318785587544488e-2;
const A31: f64 = 1.97250569845378994544595329183e-2;
const A32: f64 = 5.91751709536136983633785987549e-2;
const A41: f64 = 2.95875854768068491816892993775e-2;
const A43: f64 = 8.87627564304205475450678981324e-2;
const A51: f64 = 2.41365134159266685502369798665e-1;
const A53: f64 = -8.84549479328286085344864962717e-1;
const A54: f64 = 9.24834003261792003115737966543e-1;
const A61: f64 = 3.7037037037037037037037037037e-2;
const A64: f64 = 1.70828608729473871279604482173e-1;
const A65: f64 = 1.25467687566822425016691814123e-1;
const A71: f64 = 3.7109375e-2;
const A74: f64 = 1.70252211019544039314978060272e-1;
const A75: f64 = 6.02165389804559606850219397283e-2;
const A76: f64 = -1.7578125e-2;
const A81: f64 = 3.70920001185047927108779319836e-2;
const A84: f64 = 1.70383925712239993810214054705e-1;
const A85: f64 = 1.07262030446373284651809199168e-1;
const A86: f64 = -1.53194377486244017527936158236e-2;
const A87: f64 = 8.27378916381402288758473766002e-3;
const A91: f64 = 6.24110958716075717114429577812e-1;
const A94: f64 = -3.36089262944694129406857109825e0;
const A95: f64 = -8.68219346841726006818189891453e-1;
const A96: f64 = 2.75920996994467083049415600797e1;
const A97: f64 = 2.01540675504778934086186788979e1;
const A98: f64 = -4.34898841810699588477366255144e1;
const A101: f64 = 4.77662536438264365890433908527e-1;
const A104: f64 = -2.48811461997166764192642586468e0;
const A105: f64 = -5.90290826836842996371446475743e-1;
const A106: f64 = 2.12300514481811942347288949897e1;
const A107: f64 = 1.52792336328824235832596922938e1;
const A108: f64 = -3.32882109689848629194453265587e1;
const A109: f64 = -2.03312017085086261358222928593e-2;
const A111: f64 = -9.3714243008598732571704021658e-1;
const A114: f64 = 5.18637242884406370830023853209e0;
const A115: f64 = 1.09143734899672957818500254654e0;
const A116: f64 = -8.14978701074692612513997267357e0;
const A117: f64 = -1.85200656599969598641566180701e1;
const A118: f64 = 2.27394870993505042818970056734e1;
const A119: f64 = 2.49360555267965238987089396762e0;
const A1110: f64 = -3.0467644718982195003823669022e0;
const A121: f64 = 2.27331014751653820792359768449e0;
const A124: f64 = -1.05344954667372501984066689879e1;
const A125: f64 = -2.00087205822486249909675718444e0;
const A126: f64 = -1.79589318631187989172765950534e1;
const A127: f64 = 2.79488845294199600508499808837e1;
const A128: f64 = -2.85899827713502369474065508674e0;
const A129: f64 = -8.87285693353062954433549289258e0;
const A1210: f64 = 1.23605671757943030647266201528e1;
const A1211: f64 = 6.43392746015763530355970484046e-1;

/// Lund-stabilization exponent of the PI controller: dop853.f's default is 0 (a pure
/// I-controller); kept as a named constant so the controller reads like DOPRI5's.
const BETA: f64 = 0.0;
/// Exponent on the current error: 1/8 for the order-8 step (dop853.f: `EXPO1 = 1/8 - BETA*0.2`).
const EXPO1: f64 = 1.0 / 8.0 - BETA * 0.2;
/// Aim at 90 % of the step the error model allows (dop853.f SAFE).
const SAFETY: f64 = 0.9;
/// Shrink a step at most 3× at once (dop853.f FAC1 = 0.333: a high-order error model
/// extrapolates worse than DOPRI5's, hence tighter bounds than its 0.2).
const FAC_MIN: f64 = 0.333;
/// Grow a step at most 6× at once (dop853.f FAC2).
const FAC_MAX: f64 = 6.0;
/// The controller constants above, for [`PiController`].
const GAINS: PiGains = PiGains {
    beta: BETA,
    expo1: EXPO1,
    safety: SAFETY,
    fac_min: FAC_MIN,
    fac_max: FAC_MAX,
};
/// Weight of the third-order estimate in the denominator of the combined estimate
/// (dop853.f: `DENO = ERR + 0.01*ERR2`): keeps the 5th-order estimate from vanishing
/// accidentally when the 3rd-order one does not.
const ERR3_WEIGHT: f64 = 0.01;
/// Order of the method, for the initial step `h₁⁸·max(‖f'‖, ‖f‖) = 0.01` (dop853.f IORD = 8).
const ORDER: i32 = 8;

/// Advance with DOP853 from `*t` to exactly `t_end`, with `settings.rtol`, `settings.atol`
/// (one per state) and `settings.step` as the maximum step (`settings.method` is not consulted:
/// it names the methods of [`super::advance`]). Conventions of [`super::advance`]: `*t == t_end`
/// bit for bit on success; on failure the last accepted state, and `memory.h` reset to 0.
/// Needs only `problem.rhs`.
///
/// Counts: f once at the start of every accepted step (fresh at the start of a call, FSAL
/// reuse is not carried across calls), 11 times per attempted step, once more for [`hinit`]
/// if `memory.h == 0`: on success `rhs_evals = [memory.h == 0] + 12·steps + 11·rejected`.
pub fn advance(
    problem: &mut Problem,
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    settings: &Settings,
    memory: &mut Memory,
) -> Result<(), Failure> {
    if !start("DOP853", *t, x, t_end)? {
        return Ok(());
    }
    let result = run(problem, t, x, t_end, settings, memory);
    if result.is_err() {
        memory.h = 0.0;
    }
    result
}

fn run(
    problem: &mut Problem,
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    settings: &Settings,
    memory: &mut Memory,
) -> Result<(), Failure> {
    let n = x.len();
    assert_eq!(
        settings.atol.len(),
        n,
        "DOP853 needs one absolute tolerance per state"
    );
    let h_max = if settings.step > 0.0 && settings.step.is_finite() {
        settings.step
    } else {
        f64::INFINITY
    };
    let stats = &mut memory.stats;
    let [mut k1, mut k2, mut k3, mut k4, mut k5, mut k6, mut k7, mut k8, mut k9, mut k10, mut k11, mut k12, mut y] =
        std::array::from_fn(|_| vec![0.0; n]);

    if !problem.eval(*t, x, &mut k1, stats) {
        return Err(Failure::NonFinite { t: *t });
    }
    let carried = memory.h > 0.0 && memory.h.is_finite();
    let mut h = if carried {
        memory.h.min(h_max)
    } else {
        let mut probe = |t: f64, y: &[f64], k: &mut [f64]| problem.eval(t, y, k, stats);
        initial_step(
            &mut probe,
            *t,
            x,
            &k1,
            settings,
            h_max,
            ORDER,
            (&mut y, &mut k2),
        )
    };
    // As in DOPRI5: a continuing call assumes the previous error was at tolerance.
    let mut controller = PiController::new(GAINS, if carried { 1.0 } else { FACOLD_MIN });
    let mut k1_fresh = true;
    let mut attempts: u64 = 0;

    loop {
        check_attempt(*t, h, attempts)?;
        attempts += 1;
        let last = *t + LANDING_STRETCH * h >= t_end;
        let (hs, t_new) = if last {
            (t_end - *t, t_end)
        } else {
            (h, *t + h)
        };
        let t0 = *t;
        let bad = || Failure::NonFinite { t: t0 };
        if !k1_fresh {
            // First stage of the step: f at the new state (FSAL evaluated lazily, so the last
            // step of a call does not pay for it).
            if !problem.eval(t0, x, &mut k1, stats) {
                return Err(bad());
            }
            k1_fresh = true;
        }

        stage(&mut y, x, hs, &[(A21, &k1)]);
        if !problem.eval(t0 + C2 * hs, &y, &mut k2, stats) {
            return Err(bad());
        }
        stage(&mut y, x, hs, &[(A31, &k1), (A32, &k2)]);
        if !problem.eval(t0 + C3 * hs, &y, &mut k3, stats) {
            return Err(bad());
        }
        stage(&mut y, x, hs, &[(A41, &k1), (A43, &k3)]);
        if !problem.eval(t0 + C4 * hs, &y, &mut k4, stats) {
            return Err(bad());
        }
        stage(&mut y, x, hs, &[(A51, &k1), (A53, &k3), (A54, &k4)]);
        if !problem.eval(t0 + C5 * hs, &y, &mut k5, stats) {
            return Err(bad());
        }
        stage(&mut y, x, hs, &[(A61, &k1), (A64, &k4), (A65, &k5)]);
        if !problem.eval(t0 + C6 * hs, &y, &mut k6, stats) {
            return Err(bad());
        }
        stage(
            &mut y,
            x,
            hs,
            &[(A71, &k1), (A74, &k4), (A75, &k5), (A76, &k6)],
        );
        if !problem.eval(t0 + C7 * hs, &y, &mut k7, stats) {
            return Err(bad());
        }
        let row8 = [
            (A81, &k1[..]),
            (A84, &k4),
            (A85, &k5),
            (A86, &k6),
            (A87, &k7),
        ];
        stage(&mut y, x, hs, &row8);
        if !problem.eval(t0 + C8 * hs, &y, &mut k8, stats) {
            return Err(bad());
        }
        let row9 = [
            (A91, &k1[..]),
            (A94, &k4),
            (A95, &k5),
            (A96, &k6),
            (A97, &k7),
            (A98, &k8),
        ];
        stage(&mut y, x, hs, &row9);
        if !problem.eval(t0 + C9 * hs, &y, &mut k9, stats) {
            return Err(bad());
        }
        let row10 = [
            (A101, &k1[..]),
            (A104, &k4),
            (A105, &k5),
            (A106, &k6),
            (A107, &k7),
            (A108, &k8),
            (A109, &k9),
        ];
        stage(&mut y, x, hs, &row10);
        if !problem.eval(t0 + C10 * hs, &y, &mut k10, stats) {
            return Err(bad());
        }
        let row11 = [
            (A111, &k1[..]),
            (A114, &k4),
            (A115, &k5),
            (A116, &k6),
            (A117, &k7),
            (A118, &k8),
            (A119, &k9),
            (A1110, &k10),
        ];
        stage(&mut y, x, hs, &row11);
        if !problem.eval(t0 + C11 * hs, &y, &mut k11, stats) {
            return Err(bad());
        }
        let row12 = [
            (A121, &k1[..]),
            (A124, &k4),
            (A125, &k5),
            (A126, &k6),
            (A127, &k7),
            (A128, &k8),
            (A129, &k9),
            (A1210, &k10),
            (A1211, &k11),
        ];
        stage(&mut y, x, hs, &row12);
        if !problem.eval(t_new, &y, &mut k12, stats) {
            return Err(bad());
        }
        let weights = [
            (B1, &k1[..]),
            (B6, &k6),
            (B7, &k7),
            (B8, &k8),
            (B9, &k9),
            (B10, &k10),
            (B11, &k11),
            (B12, &k12),
        ];
        stage(&mut y, x, hs, &weights);
        if !y.iter().all(|v| v.is_finite()) {
            return Err(bad());
        }

        // dop853.f's combined estimate: err5²/√(err5² + 0.01·err3²), in Hairer's RMS norm.
        let (mut err5, mut err3) = (0.0, 0.0);
        for i in 0..n {
            let sk = settings.atol[i] + settings.rtol * x[i].abs().max(y[i].abs());
            let bsum = B1 * k1[i]
                + B6 * k6[i]
                + B7 * k7[i]
                + B8 * k8[i]
                + B9 * k9[i]
                + B10 * k10[i]
                + B11 * k11[i]
                + B12 * k12[i];
            let e3 = bsum - BHH1 * k1[i] - BHH2 * k9[i] - BHH3 * k12[i];
            let e5 = ER1 * k1[i]
                + ER6 * k6[i]
                + ER7 * k7[i]
                + ER8 * k8[i]
                + ER9 * k9[i]
                + ER10 * k10[i]
                + ER11 * k11[i]
                + ER12 * k12[i];
            err3 += (e3 / sk).powi(2);
            err5 += (e5 / sk).powi(2);
        }
        let mut deno = err5 + ERR3_WEIGHT * err3;
        if deno <= 0.0 {
            deno = 1.0;
        }
        let err = hs.abs() * err5 * (1.0 / (n.max(1) as f64 * deno)).sqrt();
        if err.is_nan() {
            return Err(bad());
        }

        if err <= 1.0 {
            let h_new = controller.accepted(err, hs, h_max);
            stats.steps += 1;
            x.copy_from_slice(&y);
            *t = t_new;
            k1_fresh = false;
            if last {
                memory.h = carried_proposal(h_new, hs, h);
                return Ok(());
            }
            h = h_new;
        } else {
            stats.rejected += 1;
            h = controller.rejected(err, hs);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{oscillator, oscillator_error};
    use super::super::{Method, Stats};
    use super::*;

    fn settings(tol: f64, n: usize, step: f64) -> Settings {
        Settings {
            method: Method::Dopri5,
            rtol: tol,
            atol: vec![tol; n],
            step,
        }
    }

    #[test]
    fn tableau_is_consistent() {
        let rows: [(&[f64], f64); 11] = [
            (&[A21], C2),
            (&[A31, A32], C3),
            (&[A41, A43], C4),
            (&[A51, A53, A54], C5),
            (&[A61, A64, A65], C6),
            (&[A71, A74, A75, A76], C7),
            (&[A81, A84, A85, A86, A87], C8),
            (&[A91, A94, A95, A96, A97, A98], C9),
            (&[A101, A104, A105, A106, A107, A108, A109], C10),
            (&[A111, A114, A115, A116, A117, A118, A119, A1110], C11),
            (
                &[A121, A124, A125, A126, A127, A128, A129, A1210, A1211],
                1.0,
            ),
        ];
        for (row, c) in rows {
            assert!((row.iter().sum::<f64>() - c).abs() < 1e-13, "c = {c}");
        }
        let b = [B1, B6, B7, B8, B9, B10, B11, B12];
        assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-14);
        assert!((BHH1 + BHH2 + BHH3 - 1.0).abs() < 1e-15);
        let e = [ER1, ER6, ER7, ER8, ER9, ER10, ER11, ER12];
        assert!(e.iter().sum::<f64>().abs() < 1e-14);
        // Order conditions Σ b_i c_i^(k−1) = 1/k, k = 1..8 (quadrature part of order 8).
        let c = [0.0, C6, C7, C8, C9, C10, C11, 1.0];
        for k in 1..=8 {
            let q: f64 = (0..8).map(|i| b[i] * c[i].powi(k - 1)).sum();
            assert!((q - 1.0 / k as f64).abs() < 1e-14, "k = {k}: {q}");
        }
    }

    fn decay_run(tol: f64, step: f64, t_end: f64) -> (f64, Stats) {
        let mut rhs = |_: f64, y: &[f64], d: &mut [f64]| d[0] = -y[0];
        let mut p = Problem::new(&mut rhs);
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [1.0]);
        advance(
            &mut p,
            &mut t,
            &mut x,
            t_end,
            &settings(tol, 1, step),
            &mut memory,
        )
        .unwrap();
        assert_eq!(t.to_bits(), t_end.to_bits());
        let s = memory.stats;
        assert_eq!(s.rhs_evals, 1 + 12 * s.steps + 11 * s.rejected);
        ((x[0] - (-t_end).exp()).abs(), s)
    }

    #[test]
    fn dop853_is_eighth_order_with_capped_steps() {
        // Loose tolerance: the max step binds, DOP853 is a fixed-step method of order 8.
        let (e1, s1) = decay_run(1e3, 0.5, 4.0);
        let (e2, s2) = decay_run(1e3, 0.25, 4.0);
        assert_eq!((s1.steps, s2.steps), (8, 16));
        let ratio = e1 / e2;
        eprintln!("DOP853 capped: {e1:e} / {e2:e} = {ratio}");
        // Measured: see message (order 8 ⇒ 2⁸ = 256).
        assert!((200.0..320.0).contains(&ratio), "ratio {ratio}");
    }

    #[test]
    fn dop853_oscillator_error_tracks_tolerance_with_fewer_steps_than_dopri5() {
        for tol in [1e-6, 1e-9, 1e-12] {
            let mut rhs = oscillator;
            let mut p = Problem::new(&mut rhs);
            let mut memory = Memory::default();
            let (mut t, mut x) = (0.0, [1.0, 0.0]);
            let s = settings(tol, 2, f64::INFINITY);
            advance(&mut p, &mut t, &mut x, 10.0, &s, &mut memory).unwrap();
            let e = oscillator_error(10.0, &x);
            let mut m5 = Memory::default();
            let (mut t5, mut x5) = (0.0, [1.0, 0.0]);
            super::super::dopri5::advance(&mut oscillator, &mut t5, &mut x5, 10.0, &s, &mut m5)
                .unwrap();
            let e5 = oscillator_error(10.0, &x5);
            eprintln!(
                "tol {tol:e}: DOP853 err {e:e}, {:?}; DOPRI5 err {e5:e}, {:?}",
                memory.stats, m5.stats
            );
            assert!(e < 100.0 * tol, "tol {tol:e}: err {e:e}");
            assert!(memory.stats.rhs_evals < m5.stats.rhs_evals);
        }
    }

    #[test]
    fn dop853_nan_rhs_stops_at_last_good_state() {
        let mut rhs = |t: f64, y: &[f64], d: &mut [f64]| {
            d[0] = if t > 0.5 { f64::NAN } else { -y[0] };
        };
        let mut p = Problem::new(&mut rhs);
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [1.0]);
        let r = advance(
            &mut p,
            &mut t,
            &mut x,
            1.0,
            &settings(1e-8, 1, 10.0),
            &mut memory,
        );
        assert_eq!(r, Err(Failure::NonFinite { t }));
        assert!(t <= 0.5 && (x[0] - (-t).exp()).abs() < 1e-7, "t = {t}");
        assert_eq!(memory.h, 0.0);
    }
}
