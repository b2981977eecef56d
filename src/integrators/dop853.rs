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
//! Dense output (the FMU's dense mode, [`advance_dense_in`]): dop853.f's order-7 continuous
//! extension CONTD8 with its three extra stages.

// The coefficients are copied digit for digit from Hairer's Fortran source, so that they can
// be checked against it; the compiler rounds them to the nearest f64.
#![allow(clippy::excessive_precision)]

use super::blob::{put_f64s, Reader};
use super::buffers::sized;
use super::explicit_rk::{self, hermite_blocks, stage, step_past, Pair, PiGains, Point, Stages};
use super::problem::{DenseCall, Problem};
use super::{Failure, Settings, Stats};

// Nodes c_i (dop853.f; c12 = 1; c14..c16 of the dense output are below).
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

/// DOP853 in the loop it shares with DOPRI5 (landing mode: [`super::advance`]), with
/// `settings.rtol`, `settings.atol` (one per state) and `settings.step` as the maximum step.
/// Needs only f.
///
/// Counts: f once at the start of every accepted step (fresh at the start of a call, FSAL
/// reuse is not carried across calls), 11 times per attempted step, once more for [`hinit`]
/// if `memory.h == 0`: on success `rhs_evals = [memory.h == 0] + 12·steps + 11·rejected`.
pub(super) struct Dop853;

/// Component `i` of DOP853's two error estimates over h, (e5, e3) (dop853.f's ERR and
/// ERR2), for [`Pair::error`] and [`Pair::estimates`].
fn error_terms(k: &[&[f64]], i: usize) -> (f64, f64) {
    let &[k1, _, _, _, _, k6, k7, k8, k9, k10, k11, k12] = k else {
        unreachable!("DOP853 has 12 stages")
    };
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
    (e5, e3)
}
impl Pair for Dop853 {
    const NAME: &'static str = "DOP853";
    const ORDER: i32 = ORDER;
    /// The controller of DOPRI5 with dop853.f's defaults.
    const GAINS: PiGains = PiGains {
        // dop853.f's default β is 0 (a pure I-controller).
        beta: 0.0,
        // 1/8 for the order-8 step (dop853.f: `EXPO1 = 1/8 - BETA*0.2`).
        expo1: 1.0 / 8.0 - 0.0 * 0.2,
        // Shrink a step at most 3× at once (dop853.f FAC1 = 0.333: a high-order error model
        // extrapolates worse than DOPRI5's, hence tighter bounds than its 0.2).
        fac_min: 0.333,
        // Grow a step at most 6× at once (dop853.f FAC2).
        fac_max: 6.0,
    };
    const STAGES: &'static [(f64, &'static [(f64, usize)])] = &[
        (C2, &[(A21, 0)]),
        (C3, &[(A31, 0), (A32, 1)]),
        (C4, &[(A41, 0), (A43, 2)]),
        (C5, &[(A51, 0), (A53, 2), (A54, 3)]),
        (C6, &[(A61, 0), (A64, 3), (A65, 4)]),
        (C7, &[(A71, 0), (A74, 3), (A75, 4), (A76, 5)]),
        (C8, &[(A81, 0), (A84, 3), (A85, 4), (A86, 5), (A87, 6)]),
        (
            C9,
            &[(A91, 0), (A94, 3), (A95, 4), (A96, 5), (A97, 6), (A98, 7)],
        ),
        (
            C10,
            &[
                (A101, 0),
                (A104, 3),
                (A105, 4),
                (A106, 5),
                (A107, 6),
                (A108, 7),
                (A109, 8),
            ],
        ),
        (
            C11,
            &[
                (A111, 0),
                (A114, 3),
                (A115, 4),
                (A116, 5),
                (A117, 6),
                (A118, 7),
                (A119, 8),
                (A1110, 9),
            ],
        ),
        (
            1.0,
            &[
                (A121, 0),
                (A124, 3),
                (A125, 4),
                (A126, 5),
                (A127, 6),
                (A128, 7),
                (A129, 8),
                (A1210, 9),
                (A1211, 10),
            ],
        ),
    ];
    const SOLUTION: Option<&'static [(f64, usize)]> = Some(&[
        (B1, 0),
        (B6, 5),
        (B7, 6),
        (B8, 7),
        (B9, 8),
        (B10, 9),
        (B11, 10),
        (B12, 11),
    ]);
    const KEEP: Option<usize> = None;

    /// dop853.f's combined error estimate err5²/√(err5² + 0.01·err3²) in Hairer's RMS norm.
    fn error(x: &[f64], y: &[f64], k: &[&[f64]], hs: f64, settings: &Settings) -> f64 {
        let n = x.len();
        let (mut err5, mut err3) = (0.0, 0.0);
        for i in 0..n {
            let sk = settings.atol[i] + settings.rtol * x[i].abs().max(y[i].abs());
            let (e5, e3) = error_terms(k, i);
            err3 += (e3 / sk).powi(2);
            err5 += (e5 / sk).powi(2);
        }
        let mut deno = err5 + ERR3_WEIGHT * err3;
        if deno <= 0.0 {
            deno = 1.0;
        }
        hs.abs() * err5 * (1.0 / (n.max(1) as f64 * deno)).sqrt()
    }

    const ESTIMATES: usize = 2;

    /// `h·e5` and `h·e3`, the terms of [`Pair::error`].
    fn estimates(k: &[&[f64]], hs: f64, out: &mut [Vec<f64>]) {
        let [e5, e3] = out else {
            unreachable!("two estimates")
        };
        for i in 0..e5.len() {
            let (t5, t3) = error_terms(k, i);
            e5[i] = hs * t5;
            e3[i] = hs * t3;
        }
    }

    /// [`Pair::error`]'s norm with `h` inside the terms: `S5 / √(n (S5 + w S3))`.
    fn error_of(x: &[f64], y: &[f64], e: &[Vec<f64>], settings: &Settings) -> f64 {
        let (mut s5, mut s3) = (0.0, 0.0);
        for i in 0..x.len() {
            let sk = settings.atol[i] + settings.rtol * x[i].abs().max(y[i].abs());
            s5 += (e[0][i] / sk).powi(2);
            s3 += (e[1][i] / sk).powi(2);
        }
        let deno = s5 + ERR3_WEIGHT * s3;
        if deno <= 0.0 {
            return 0.0;
        }
        s5 / (x.len().max(1) as f64 * deno).sqrt()
    }

    /// The step's record (see [`Ahead::step`]) for its extension.
    fn record(x: &[f64], w: &Stages, k1: &[f64], f1: &[f64], _: f64, record: &mut Vec<f64>) {
        record.clear();
        let k6_to_k12 = w.k[4..].iter().map(|k| &k[..]);
        for block in [x, &w.y, k1].into_iter().chain(k6_to_k12).chain([f1]) {
            record.extend_from_slice(block);
        }
    }
}

/// Weight of the third-order estimate in the denominator of the combined estimate
/// (dop853.f: `DENO = ERR + 0.01*ERR2`): keeps the 5th-order estimate from vanishing
/// accidentally when the 3rd-order one does not.
const ERR3_WEIGHT: f64 = 0.01;
/// Order of the method, for the initial step `h₁⁸·max(‖f'‖, ‖f‖) = 0.01` (dop853.f IORD = 8).
const ORDER: i32 = 8;

// Dense output (dop853.f): nodes and stage weights of the three extra stages 14–16, and the
// coefficients d_ij of the order-7 continuous extension (CONTD8).
const C14: f64 = 0.1e+00;
const C15: f64 = 0.2e+00;
const C16: f64 = 0.777777777777777777777777777778e+00;
const A141: f64 = 5.61675022830479523392909219681e-2;
const A147: f64 = 2.53500210216624811088794765333e-1;
const A148: f64 = -2.46239037470802489917441475441e-1;
const A149: f64 = -1.24191423263816360469010140626e-1;
const A1410: f64 = 1.5329179827876569731206322685e-1;
const A1411: f64 = 8.20105229563468988491666602057e-3;
const A1412: f64 = 7.56789766054569976138603589584e-3;
const A1413: f64 = -8.298e-3;
const A151: f64 = 3.18346481635021405060768473261e-2;
const A156: f64 = 2.83009096723667755288322961402e-2;
const A157: f64 = 5.35419883074385676223797384372e-2;
const A158: f64 = -5.49237485713909884646569340306e-2;
const A1511: f64 = -1.08347328697249322858509316994e-4;
const A1512: f64 = 3.82571090835658412954920192323e-4;
const A1513: f64 = -3.40465008687404560802977114492e-4;
const A1514: f64 = 1.41312443674632500278074618366e-1;
const A161: f64 = -4.28896301583791923408573538692e-1;
const A166: f64 = -4.69762141536116384314449447206e0;
const A167: f64 = 7.68342119606259904184240953878e0;
const A168: f64 = 4.06898981839711007970213554331e0;
const A169: f64 = 3.56727187455281109270669543021e-1;
const A1613: f64 = -1.39902416515901462129418009734e-3;
const A1614: f64 = 2.9475147891527723389556272149e0;
const A1615: f64 = -9.15095847217987001081870187138e0;
/// Rows d4 … d7, each on the stages (1, 6, 7, 8, 9, 10, 11, 12, 13 = f(t+h, y₁), 14, 15, 16).
const D: [[f64; 12]; 4] = [
    [
        -0.84289382761090128651353491142e+01,
        0.56671495351937776962531783590e+00,
        -0.30689499459498916912797304727e+01,
        0.23846676565120698287728149680e+01,
        0.21170345824450282767155149946e+01,
        -0.87139158377797299206789907490e+00,
        0.22404374302607882758541771650e+01,
        0.63157877876946881815570249290e+00,
        -0.88990336451333310820698117400e-01,
        0.18148505520854727256656404962e+02,
        -0.91946323924783554000451984436e+01,
        -0.44360363875948939664310572000e+01,
    ],
    [
        0.10427508642579134603413151009e+02,
        0.24228349177525818288430175319e+03,
        0.16520045171727028198505394887e+03,
        -0.37454675472269020279518312152e+03,
        -0.22113666853125306036270938578e+02,
        0.77334326684722638389603898808e+01,
        -0.30674084731089398182061213626e+02,
        -0.93321305264302278729567221706e+01,
        0.15697238121770843886131091075e+02,
        -0.31139403219565177677282850411e+02,
        -0.93529243588444783865713862664e+01,
        0.35816841486394083752465898540e+02,
    ],
    [
        0.19985053242002433820987653617e+02,
        -0.38703730874935176555105901742e+03,
        -0.18917813819516756882830838328e+03,
        0.52780815920542364900561016686e+03,
        -0.11573902539959630126141871134e+02,
        0.68812326946963000169666922661e+01,
        -0.10006050966910838403183860980e+01,
        0.77771377980534432092869265740e+00,
        -0.27782057523535084065932004339e+01,
        -0.60196695231264120758267380846e+02,
        0.84320405506677161018159903784e+02,
        0.11992291136182789328035130030e+02,
    ],
    [
        -0.25693933462703749003312586129e+02,
        -0.15418974869023643374053993627e+03,
        -0.23152937917604549567536039109e+03,
        0.35763911791061412378285349910e+03,
        0.93405324183624310003907691704e+02,
        -0.37458323136451633156875139351e+02,
        0.10409964950896230045147246184e+03,
        0.29840293426660503123344363579e+02,
        -0.43533456590011143754432175058e+02,
        0.96324553959188282948394950600e+02,
        -0.39177261675615439165231486172e+02,
        -0.14972683625798562581422125276e+03,
    ],
];

/// Dense-output mode, as [`super::dopri5::Ahead`]: the integrator's own point at the end of
/// its last accepted step, ahead of the communication time, and what the continuous
/// extension of order 7 of that step (dop853.f CONTD8) is built from. The extension needs
/// three more stages, so it is built only when a communication point falls inside the step
/// (as scipy's DOP853 builds it only when its dense output is asked for): a point at a
/// step's end, or a step no point falls in, costs nothing more. Valid only while f is
/// unchanged.
#[derive(Clone, Debug, PartialEq)]
pub struct Ahead {
    /// The end of the last accepted step, its start and the controller's memory (carried as
    /// DOPRI5 does; no effect while dop853.f's BETA is 0).
    pub point: Point,
    /// The last accepted step, 11 blocks of n (see [`StepBlock`]): x(t0), the step's own
    /// end y (before any projection), and the stages k1, k6 … k12 and f(t, y); empty before
    /// the first step.
    pub step: Vec<f64>,
    /// The continuous extension of the last step, 8 blocks of n (dop853.f CONT); empty until
    /// a point inside the step is asked for.
    pub cont: Vec<f64>,
}

/// The blocks of [`Ahead::step`], in order.
#[derive(Clone, Copy)]
enum StepBlock {
    X0,
    Y,
    K1,
    /// k6 … k12 follow K6.
    K6,
    F1 = 10,
}

impl Ahead {
    /// The integrator at `point` ([`Point::start`]) before any step.
    pub fn new(point: Point) -> Ahead {
        let (step, cont) = (Vec::new(), Vec::new());
        Ahead { point, step, cont }
    }

    /// Forgets the last step: the point goes back to its start (t0, x(t0), f there).
    fn back_to_step_start(&mut self) {
        let p = &mut self.point;
        let n = p.x.len();
        if !self.step.is_empty() {
            let block = |b: StepBlock| &self.step[b as usize * n..(b as usize + 1) * n];
            p.x.copy_from_slice(block(StepBlock::X0));
            p.f.copy_from_slice(block(StepBlock::K1));
            p.t = p.t0;
            self.step.clear();
            self.cont.clear();
        }
    }

    /// x(`t`) for `t` in [`t0`, `t`] of the last step: the step's end itself, else the
    /// continuous extension (CONTD8), built first if it is not yet (3 evaluations of f).
    ///
    /// In the scratch of `work`: no allocation once it and the extension
    /// have held this size.
    pub fn point_in(
        &mut self,
        problem: &mut Problem,
        t: f64,
        out: &mut [f64],
        stats: &mut Stats,
        work: &mut Scratch,
    ) -> Result<(), Failure> {
        let p = &self.point;
        if t == p.t || self.step.is_empty() {
            out.copy_from_slice(&p.x);
            return Ok(());
        }
        if self.cont.is_empty() {
            let (t0, hs) = (p.t0, p.t - p.t0);
            let stages = &mut work.extension;
            extension(problem, t0, hs, &self.step, stats, stages, &mut self.cont)?;
        }
        let n = p.x.len();
        let s = (t - p.t0) / (p.t - p.t0);
        let s1 = 1.0 - s;
        let c = |j: usize, i: usize| self.cont[j * n + i];
        for (i, o) in out.iter_mut().enumerate() {
            let conpar = c(4, i) + s * (c(5, i) + s1 * (c(6, i) + s * c(7, i)));
            *o = c(0, i) + s * (c(1, i) + s1 * (c(2, i) + s * (c(3, i) + s1 * conpar)));
        }
        Ok(())
    }
}

impl Ahead {
    /// Its block of the FMU state (see [`super::Memory::write`]): the point, then the last
    /// step's record and its extension, each after a flag (empty before the first step /
    /// until built).
    pub(crate) fn write(&self, b: &mut Vec<u8>) {
        self.point.write(b);
        for block in [&self.step, &self.cont] {
            b.push(!block.is_empty() as u8);
            put_f64s(b, block.iter());
        }
    }

    /// Reads what [`Ahead::write`] wrote for `n` states, and checks it.
    pub(crate) fn read(r: &mut Reader, n: usize) -> Result<Ahead, String> {
        let point = Point::read(r, n)?;
        let step = if r.flag()? {
            r.f64s(11 * n)?
        } else {
            Vec::new()
        };
        let cont = if r.flag()? {
            r.f64s(8 * n)?
        } else {
            Vec::new()
        };
        let finite = step.iter().chain(&cont).all(|v| v.is_finite());
        let (t0, t) = (point.t0, point.t);
        let consistent = (step.is_empty() == (t0 == t)) && (cont.is_empty() || !step.is_empty());
        if !point.is_sound() || !finite || !consistent {
            return Err("FMU state holds an invalid DOP853 integrator point".into());
        }
        Ok(Ahead { point, step, cont })
    }
}

/// Dense mode (see [`Ahead`]) for one [`DenseCall`]: steps `ahead` until its last step
/// covers `t_out`, then writes x(`t_out`) into `out`. Steps are cut only to land on
/// `t_limit`, which the integrator never passes; `t_out` must lie in [`ahead.t0`,
/// `t_limit`]. `project` is applied after every accepted step (f is evaluated again where
/// it changed the state).
///
/// Counts: per accepted step 11 stages and f at its end (the next step's first stage); 11
/// per rejected step; one more for [`hinit`] if `memory.h == 0`; one per step the
/// projection changed; 3 for the extension of each step a point falls inside (not on its
/// end). So the work is bounded by the grid-free `15·steps` and shrinks to landing
/// mode's `12·steps` for points that are step ends. On failure `ahead` holds the last
/// accepted step and `memory.h` is reset. No allocation once the call's scratch has held
/// this size.
pub fn advance_dense_in(ahead: &mut Ahead, c: DenseCall<Scratch>) -> Result<(), Failure> {
    let (t_out, ends) = (c.t_out, (c.t_out, c.t_limit));
    let Point {
        t,
        x,
        f,
        t0,
        err_prev,
    } = &mut ahead.point;
    let point = (t, &mut x[..], f);
    let (settings, memory, work) = (c.settings, c.memory, c.work);
    let rk = &mut work.rk;
    let past = step_past::<Dop853>(
        &mut *c.problem,
        c.project,
        point,
        *err_prev,
        ends,
        settings,
        memory,
        rk,
    )?;
    if let Some(last) = past {
        *t0 = last.t0;
        std::mem::swap(&mut ahead.step, &mut rk.record);
        *err_prev = last.err_prev;
        ahead.cont.clear();
    }
    let result = ahead.point_in(c.problem, t_out, c.out, &mut memory.stats, work);
    if result.is_err() {
        // The step ends past `t_out` but its extension failed: the last good point not
        // past `t_out` is the step's start.
        memory.h = 0.0;
        ahead.back_to_step_start();
    }
    result
}

/// The continuous extension of an accepted step of size `hs` from `t0` (dop853.f, after
/// label 62) from its record `step` (see [`Ahead::step`]): three more stages (14, 15, 16)
/// in the scratch `stages`, then 8 blocks of n into `cont` (left alone on failure).
fn extension(
    problem: &mut Problem,
    t0: f64,
    hs: f64,
    step: &[f64],
    stats: &mut Stats,
    stages: &mut [Vec<f64>; 4],
    cont: &mut Vec<f64>,
) -> Result<(), Failure> {
    let n = step.len() / 11;
    let block = |b: usize| &step[b * n..(b + 1) * n];
    let (x, y) = (block(StepBlock::X0 as usize), block(StepBlock::Y as usize));
    let (k1, f1) = (block(StepBlock::K1 as usize), block(StepBlock::F1 as usize));
    let [k6, k7, k8, k9, k10, k11, k12] =
        std::array::from_fn(|j| block(StepBlock::K6 as usize + j));
    let bad = || Failure::NonFinite { t: t0 };
    let [yk, k14, k15, k16] = stages;
    let (yk, k14, k15, k16) = (sized(yk, n), sized(k14, n), sized(k15, n), sized(k16, n));
    let row14 = [
        (A141, k1),
        (A147, k7),
        (A148, k8),
        (A149, k9),
        (A1410, k10),
        (A1411, k11),
        (A1412, k12),
        (A1413, f1),
    ];
    stage(yk, x, hs, &row14);
    if !problem.eval(t0 + C14 * hs, yk, k14, stats) {
        return Err(bad());
    }
    let row15 = [
        (A151, k1),
        (A156, k6),
        (A157, k7),
        (A158, k8),
        (A1511, k11),
        (A1512, k12),
        (A1513, f1),
        (A1514, &k14[..]),
    ];
    stage(yk, x, hs, &row15);
    if !problem.eval(t0 + C15 * hs, yk, k15, stats) {
        return Err(bad());
    }
    let row16 = [
        (A161, k1),
        (A166, k6),
        (A167, k7),
        (A168, k8),
        (A169, k9),
        (A1613, f1),
        (A1614, &k14[..]),
        (A1615, &k15[..]),
    ];
    stage(yk, x, hs, &row16);
    if !problem.eval(t0 + C16 * hs, yk, k16, stats) {
        return Err(bad());
    }
    let stages: [&[f64]; 12] = [k1, k6, k7, k8, k9, k10, k11, k12, f1, k14, k15, k16];
    let cont = sized(cont, 8 * n);
    for i in 0..n {
        hermite_blocks(cont, (n, i), (x, y), hs, (k1, f1));
        for (j, d) in D.iter().enumerate() {
            let sum = d.iter().zip(&stages).fold(0.0, |s, (dj, k)| s + dj * k[i]);
            cont[(4 + j) * n + i] = hs * sum;
        }
    }
    Ok(())
}

/// DOP853's part of a [`Workspace`](super::Workspace): the pair's scratch (its record is
/// the last step of a dense call, swapped into [`Ahead::step`]) and the stages of the
/// continuous extension (its argument, k14, k15, k16).
#[derive(Default)]
pub struct Scratch {
    pub(super) rk: explicit_rk::Scratch,
    extension: [Vec<f64>; 4],
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{adaptive, broken_decay, decay, dense_call};
    use super::super::test_support::{oscillator, oscillator_error};
    use super::super::{self as integ, advance_with, Memory, Method, Stats};
    use super::*;

    fn settings(tol: f64, n: usize, step: f64) -> Settings {
        adaptive(Method::Dop853, tol, n, step)
    }

    /// Dense mode up to `t_out` (limit 10 s, no projection) in fresh scratch.
    fn dense_to(
        p: &mut Problem,
        ahead: &mut Ahead,
        t_out: f64,
        (s, memory): (&Settings, &mut Memory),
        out: &mut [f64],
    ) -> Result<(), Failure> {
        let work = &mut Scratch::default();
        advance_dense_in(
            ahead,
            dense_call(p, (t_out, 10.0), (s, memory), (out, work)),
        )
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
        let mut rhs = decay;
        let mut p = Problem::new(&mut rhs);
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [1.0]);
        let s = settings(tol, 1, step);
        advance_with(&mut p, &mut t, &mut x, t_end, &s, &mut memory).unwrap();
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
            advance_with(&mut p, &mut t, &mut x, 10.0, &s, &mut memory).unwrap();
            let e = oscillator_error(10.0, &x);
            let mut m5 = Memory::default();
            let (mut t5, mut x5) = (0.0, [1.0, 0.0]);
            let s5 = adaptive(Method::Dopri5, tol, 2, f64::INFINITY);
            integ::advance(&mut oscillator, &mut t5, &mut x5, 10.0, &s5, &mut m5).unwrap();
            let e5 = oscillator_error(10.0, &x5);
            eprintln!(
                "tol {tol:e}: DOP853 err {e:e}, {:?}; DOPRI5 err {e5:e}, {:?}",
                memory.stats, m5.stats
            );
            assert!(e < 100.0 * tol, "tol {tol:e}: err {e:e}");
            assert!(memory.stats.rhs_evals < m5.stats.rhs_evals);
        }
    }

    /// One dense step of `x' = −x` from x(0) = 1 capped at `step` (loose tolerance: the
    /// cap binds); the interpolant's error at `θ·step` and the work.
    fn one_dense_step(step: f64, theta: f64) -> (f64, Stats, Ahead) {
        let mut rhs = decay;
        let mut p = Problem::new(&mut rhs);
        let mut memory = Memory::default();
        let s = settings(1e3, 1, step);
        let mut ahead = Ahead::new(Point::start(p.rhs, 0.0, &[1.0], &mut memory.stats).unwrap());
        let mut out = [0.0];
        let t = theta * step;
        dense_to(&mut p, &mut ahead, t, (&s, &mut memory), &mut out).unwrap();
        assert_eq!((ahead.point.t0, ahead.point.t), (0.0, step));
        ((out[0] - (-t).exp()).abs(), memory.stats, ahead)
    }

    #[test]
    fn continuous_extension_is_of_order_7() {
        // Local error of an order-7 interpolant: O(h⁸), so halving the step divides the
        // error inside the step by 2⁸ = 256.
        for theta in [0.3, 0.5, 0.8] {
            let (e1, s1, _) = one_dense_step(0.5, theta);
            let (e2, _, _) = one_dense_step(0.25, theta);
            let ratio = e1 / e2;
            eprintln!("θ = {theta}: {e1:e} / {e2:e} = {ratio}");
            assert!(
                (200.0..320.0).contains(&ratio),
                "θ = {theta}: ratio {ratio}"
            );
            // f at the start, the initial-step probe, 11 stages, f at the end, 3 extra.
            assert_eq!(s1.rhs_evals, 1 + 1 + 11 + 1 + 3);
        }
        // Both ends of the step are the step's own values; the extension, built once,
        // costs nothing more.
        let (_, _, mut ahead) = one_dense_step(0.5, 0.5);
        let mut rhs = decay;
        let mut p = Problem::new(&mut rhs);
        let mut stats = Stats::default();
        let (mut start, mut end) = ([0.0], [0.0]);
        let work = &mut Scratch::default();
        ahead
            .point_in(&mut p, 0.0, &mut start, &mut stats, work)
            .unwrap();
        let t_end = 0.5 - 1e-16;
        ahead
            .point_in(&mut p, t_end, &mut end, &mut stats, work)
            .unwrap();
        assert_eq!(start, [1.0]);
        assert!(
            (end[0] - ahead.point.x[0]).abs() < 1e-15,
            "{end:?} {:?}",
            ahead.point.x
        );
        assert_eq!(stats.rhs_evals, 0);
    }

    #[test]
    fn a_point_at_a_step_end_does_not_build_the_extension() {
        // The point is the step's end (the limit cuts the step): landing mode's count.
        let (_, s, ahead) = one_dense_step(0.5, 1.0);
        assert!(ahead.cont.is_empty());
        assert_eq!(s.rhs_evals, 1 + 1 + 11 + 1);
        let (_, s, ahead) = one_dense_step(0.5, 0.999);
        assert!(!ahead.cont.is_empty());
        assert_eq!(s.rhs_evals, 1 + 1 + 11 + 1 + 3);
    }

    #[test]
    fn dense_points_are_as_accurate_as_the_steps_at_tight_tolerance() {
        // rtol 1e-10 over 10 s of the oscillator: the worst error at 1000 interpolated
        // points against the worst at the step ends (the integration's own error).
        let mut rhs = oscillator;
        let mut p = Problem::new(&mut rhs);
        let mut memory = Memory::default();
        let s = settings(1e-10, 2, f64::INFINITY);
        let mut ahead =
            Ahead::new(Point::start(p.rhs, 0.0, &[1.0, 0.0], &mut memory.stats).unwrap());
        let (mut dense, mut ends) = (0.0f64, 0.0f64);
        let mut out = [0.0; 2];
        // Steps a point fell strictly inside: each built its extension once.
        let mut extended = std::collections::BTreeSet::new();
        for i in 1..=1000 {
            let t = i as f64 / 100.0;
            dense_to(&mut p, &mut ahead, t, (&s, &mut memory), &mut out).unwrap();
            dense = dense.max(oscillator_error(t, &out));
            ends = ends.max(oscillator_error(ahead.point.t, &ahead.point.x));
            if t < ahead.point.t {
                extended.insert(ahead.point.t0.to_bits());
            }
        }
        let st = memory.stats;
        let built = extended.len() as u64;
        eprintln!("rtol 1e-10: dense {dense:e}, step ends {ends:e}, {st:?}, {built} extensions");
        assert!(dense < 1.5 * ends && dense < 1e-8, "{dense:e} vs {ends:e}");
        assert_eq!(
            st.rhs_evals,
            2 + 12 * st.steps + 11 * st.rejected + 3 * built
        );
    }

    #[test]
    fn a_failing_extension_goes_back_to_the_step_start() {
        // f is not finite only near the extension's stage 16 (t = 0.7778 h, h = 0.5 capped),
        // between the step's own nodes 0.6513 h and 0.8571 h: the step succeeds, the
        // extension for a point inside it does not.
        let mut rhs = |t: f64, y: &[f64], d: &mut [f64]| {
            d[0] = if (0.37..0.40).contains(&t) {
                f64::NAN
            } else {
                -y[0]
            };
        };
        let mut p = Problem::new(&mut rhs);
        let mut memory = Memory::default();
        let s = settings(1e3, 1, 0.5);
        let mut ahead = Ahead::new(Point::start(p.rhs, 0.0, &[1.0], &mut memory.stats).unwrap());
        let mut out = [0.0];
        let r = dense_to(&mut p, &mut ahead, 0.25, (&s, &mut memory), &mut out);
        assert_eq!(r, Err(Failure::NonFinite { t: 0.0 }));
        assert_eq!(
            (
                ahead.point.t,
                ahead.point.x.as_slice(),
                ahead.point.f.as_slice()
            ),
            (0.0, &[1.0][..], &[-1.0][..])
        );
        assert!(ahead.step.is_empty() && ahead.cont.is_empty());
        assert_eq!(memory.h, 0.0);
        // The step itself was accepted (its 12 evaluations finite); stage 14 (t = 0.05)
        // and 15 (t = 0.1) were evaluated, 16 failed.
        assert_eq!(memory.stats.steps, 1);
        assert_eq!(memory.stats.rhs_evals, 1 + 1 + 12 + 3);
    }

    #[test]
    fn dop853_nan_rhs_stops_at_last_good_state() {
        let mut rhs = broken_decay;
        let mut p = Problem::new(&mut rhs);
        let mut memory = Memory::default();
        let (mut t, mut x) = (0.0, [1.0]);
        let s = settings(1e-8, 1, 10.0);
        let r = advance_with(&mut p, &mut t, &mut x, 1.0, &s, &mut memory);
        assert_eq!(r, Err(Failure::NonFinite { t }.into()));
        assert!(t <= 0.5 && (x[0] - (-t).exp()).abs() < 1e-7, "t = {t}");
        assert_eq!(memory.h, 0.0);
    }
}
