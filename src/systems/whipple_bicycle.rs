//! The linearised Whipple–Carvallo bicycle: the benchmark of Meijaard, Papadopoulos,
//! Ruina and Schwab, "Linearized dynamics equations for the balance and steer of a
//! bicycle: a benchmark and review", Proc. R. Soc. A 463 (2007) 1955–1982,
//! doi:10.1098/rspa.2007.1857.
//!
//! Four rigid bodies (rear wheel R, rear body and frame B, front handlebar and fork H,
//! front wheel F), knife-edge rolling without slip on level ground, linearised about
//! upright straight-ahead motion at forward speed `v`:
//!
//! `M q̈ + v C1 q̇ + (g K0 + v² K2) q = f`, `q = (φ, δ)` (roll, steer), `f = (T_φ, T_δ)`.
//!
//! The matrices are computed from the physical parameters of the paper's Table 1 with
//! the formulas of its Appendix A, generic over the scalar type so that dual numbers give
//! exact derivatives with respect to the parameters as well. The formulas were checked
//! term by term against `benchmark_par_to_canonical` of the BicycleParameters project
//! (J. K. Moore, github.com/moorepants/BicycleParameters), and the result against the
//! paper's published matrices and eigenvalues (tests/whipple_bicycle.rs).

use crate::model::{Scalar, Scene, System, Var};
use nalgebra::{Matrix2, Matrix4, Matrix4x2};
use std::f64::consts::PI;

pub struct WhippleBicycle;

/// Index of `g` in the parameter vector.
const G: usize = 3;
/// Index of `v` in the parameter vector.
const V: usize = 4;

/// The four 2×2 coefficient matrices of the linearised equations, row-major, in any
/// scalar type.
#[derive(Clone, Copy, Debug)]
struct Canonical<S> {
    m: [[S; 2]; 2],
    c1: [[S; 2]; 2],
    k0: [[S; 2]; 2],
    k2: [[S; 2]; 2],
}

/// M, C1, K0, K2 from the Table 1 parameters (declaration order), Appendix A of
/// Meijaard et al. (2007). The (A n) labels follow the order of the formulas in Appendix A;
/// they were not checked against the printed paper, the formulas themselves were.
fn canonical<S: Scalar>(p: &[S]) -> Canonical<S> {
    // Table 1, in declaration order; p[3] = g and p[4] = v scale the matrices later,
    // p[13] = IByy and p[20] = IHyy do not enter the linearised equations.
    let [w, c, lambda] = [p[0], p[1], p[2]];
    let [r_r, m_r, i_rxx, i_ryy] = [p[5], p[6], p[7], p[8]];
    let [x_b, z_b, m_b, i_bxx, i_bzz, i_bxz] = [p[9], p[10], p[11], p[12], p[14], p[15]];
    let [x_h, z_h, m_h, i_hxx, i_hzz, i_hxz] = [p[16], p[17], p[18], p[19], p[21], p[22]];
    let [r_f, m_f, i_fxx, i_fyy] = [p[23], p[24], p[25], p[26]];
    let (sin_l, cos_l) = (lambda.sin(), lambda.cos());

    // (A 1)–(A 3): total mass and its centre of mass, relative to the rear contact point
    // (x forward, z down).
    let m_t = m_r + m_b + m_h + m_f;
    let x_t = (x_b * m_b + x_h * m_h + w * m_f) / m_t;
    let z_t = (-r_r * m_r + z_b * m_b + z_h * m_h - r_f * m_f) / m_t;

    // (A 4), (A 5): moments and product of inertia of the whole bicycle about the rear
    // contact point, along the global axes.
    let i_txx = i_rxx
        + i_bxx
        + i_hxx
        + i_fxx
        + m_r * r_r * r_r
        + m_b * z_b * z_b
        + m_h * z_h * z_h
        + m_f * r_f * r_f;
    let i_txz = i_bxz + i_hxz - m_b * x_b * z_b - m_h * x_h * z_h + m_f * w * r_f;
    // (A 6): the wheels are axisymmetric, I_zz = I_xx.
    let (i_rzz, i_fzz) = (i_rxx, i_fxx);
    // (A 7)
    let i_tzz = i_rzz + i_bzz + i_hzz + i_fzz + m_b * x_b * x_b + m_h * x_h * x_h + m_f * w * w;

    // (A 8), (A 9): the front assembly A = H + F, its mass and centre of mass.
    let m_a = m_h + m_f;
    let x_a = (x_h * m_h + w * m_f) / m_a;
    let z_a = (z_h * m_h - r_f * m_f) / m_a;

    // (A 10)–(A 12): inertia of the front assembly about its own centre of mass.
    let i_axx = i_hxx + i_fxx + m_h * (z_h - z_a) * (z_h - z_a) + m_f * (r_f + z_a) * (r_f + z_a);
    let i_axz = i_hxz - m_h * (x_h - x_a) * (z_h - z_a) + m_f * (w - x_a) * (r_f + z_a);
    let i_azz = i_hzz + i_fzz + m_h * (x_h - x_a) * (x_h - x_a) + m_f * (w - x_a) * (w - x_a);

    // (A 13): perpendicular distance of the front assembly's centre of mass ahead of
    // the steer axis.
    let u_a = (x_a - w - c) * cos_l - z_a * sin_l;

    // (A 14)–(A 16): front-assembly inertia about the steer axis λ = (sin λ, 0, cos λ),
    // and its products with the x and z axes (relative to the point where the steer
    // axis meets the ground).
    let i_all = m_a * u_a * u_a
        + i_axx * sin_l * sin_l
        + i_axz * sin_l * cos_l * 2.0
        + i_azz * cos_l * cos_l;
    let i_alx = -m_a * u_a * z_a + i_axx * sin_l + i_axz * cos_l;
    let i_alz = m_a * u_a * x_a + i_axz * sin_l + i_azz * cos_l;

    // (A 17): mechanical trail over wheelbase.
    let mu = c / w * cos_l;

    // (A 18): gyrostatic coefficients (wheel spin angular momenta per unit speed).
    let s_r = i_ryy / r_r;
    let s_f = i_fyy / r_f;
    let s_t = s_r + s_f;
    // (A 19): a static moment term.
    let s_a = m_a * u_a + mu * m_t * x_t;

    let zero = S::from(0.0);
    Canonical {
        // (A 20): mass matrix, symmetric.
        m: [
            [i_txx, i_alx + mu * i_txz],
            [
                i_alx + mu * i_txz,
                i_all + mu * i_alz * 2.0 + mu * mu * i_tzz,
            ],
        ],
        // (A 21): gravity stiffness, symmetric.
        k0: [[m_t * z_t, -s_a], [-s_a, -s_a * sin_l]],
        // (A 22): speed-squared stiffness.
        k2: [
            [zero, (s_t - m_t * z_t) / w * cos_l],
            [zero, (s_a + s_f * sin_l) / w * cos_l],
        ],
        // (A 23): speed-proportional "damping" (gyroscopic and non-holonomic terms).
        c1: [
            [
                zero,
                mu * s_t + s_f * cos_l + i_txz / w * cos_l - mu * m_t * z_t,
            ],
            [
                -(mu * s_t + s_f * cos_l),
                i_alz / w * cos_l + mu * (s_a + i_tzz / w * cos_l),
            ],
        ],
    }
}

/// `q̈ = M⁻¹ (f − v C1 q̇ − (g K0 + v² K2) q)`, the 2×2 inverse written out (Cramer).
fn accelerations<S: Scalar>(k: &Canonical<S>, g: S, v: S, x: &[S], u: &[S]) -> [S; 2] {
    let (q, qd) = ([x[0], x[1]], [x[2], x[3]]);
    let rhs: [S; 2] = std::array::from_fn(|i| {
        let mut r = u[i];
        for j in 0..2 {
            r -= v * k.c1[i][j] * qd[j] + (g * k.k0[i][j] + v * v * k.k2[i][j]) * q[j];
        }
        r
    });
    let m = k.m;
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    [
        (m[1][1] * rhs[0] - m[0][1] * rhs[1]) / det,
        (m[0][0] * rhs[1] - m[1][0] * rhs[0]) / det,
    ]
}

fn to_matrix2(a: [[f64; 2]; 2]) -> Matrix2<f64> {
    Matrix2::new(a[0][0], a[0][1], a[1][0], a[1][1])
}

/// The closed forms, for control design and tests. They are associated functions so that
/// `mbfmu::systems::WhippleBicycle` is the one path to everything of this system.
impl WhippleBicycle {
    /// The benchmark's M, C1, K0, K2 from the parameter vector in declaration order
    /// (`v` and `g` are ignored: they only scale C1, K0 and K2).
    pub fn benchmark_matrices(
        p: &[f64],
    ) -> (Matrix2<f64>, Matrix2<f64>, Matrix2<f64>, Matrix2<f64>) {
        let k = canonical(p);
        (
            to_matrix2(k.m),
            to_matrix2(k.c1),
            to_matrix2(k.k0),
            to_matrix2(k.k2),
        )
    }

    /// `ẋ = A x + B u` at forward speed `v` (the `v` of `p` is ignored, `g` is `p`'s),
    /// with x = (φ, δ, φ̇, δ̇), u = (T_φ, T_δ):
    /// `A = [[0, I], [−M⁻¹(g K0 + v² K2), −v M⁻¹ C1]]`, `B = [[0], [M⁻¹]]`.
    pub fn state_matrix(p: &[f64], v: f64) -> (Matrix4<f64>, Matrix4x2<f64>) {
        let (m, c1, k0, k2) = Self::benchmark_matrices(p);
        let m_inv = m.try_inverse().expect("the mass matrix M is singular");
        let stiffness = -m_inv * (k0 * p[G] + k2 * (v * v));
        let damping = -m_inv * c1 * v;
        let mut a = Matrix4::zeros();
        a.fixed_view_mut::<2, 2>(0, 2).fill_with_identity();
        a.fixed_view_mut::<2, 2>(2, 0).copy_from(&stiffness);
        a.fixed_view_mut::<2, 2>(2, 2).copy_from(&damping);
        let mut b = Matrix4x2::zeros();
        b.fixed_view_mut::<2, 2>(2, 0).copy_from(&m_inv);
        (a, b)
    }
}

impl System for WhippleBicycle {
    const NAME: &'static str = "WhippleBicycle";
    const DESCRIPTION: &'static str =
        "The linearised Whipple–Carvallo bicycle (benchmark of Meijaard et al. 2007): roll and steer at constant forward speed";
    /// States are (positions, velocities).
    fn second_order() -> bool {
        true
    }
    const EQUATIONS: &'static [&'static str] = &[
        "M q̈ + v C1 q̇ + (g K0 + v² K2) q = f, q = (phi, delta), f = (T_phi, T_delta)",
        "Linearised about upright, straight-ahead rolling at constant forward speed v; four rigid bodies (rear wheel R, rear frame B, front fork and handlebar H, front wheel F), knife-edge wheels rolling without slip on level ground.",
        "M, C1, K0, K2 follow from the physical parameters (Table 1 of Meijaard, Papadopoulos, Ruina, Schwab, Proc. R. Soc. A 463 (2007) 1955–1982) by the formulas of its Appendix A:",
        "mT = mR + mB + mH + mF, xT = (xB mB + xH mH + w mF)/mT, zT = (−rR mR + zB mB + zH mH − rF mF)/mT",
        "ITxx = IRxx + IBxx + IHxx + IFxx + mR rR² + mB zB² + mH zH² + mF rF², ITxz = IBxz + IHxz − mB xB zB − mH xH zH + mF w rF",
        "ITzz = IRxx + IBzz + IHzz + IFxx + mB xB² + mH xH² + mF w² (axisymmetric wheels: IRzz = IRxx, IFzz = IFxx)",
        "Front assembly A = H + F: mA = mH + mF, xA = (xH mH + w mF)/mA, zA = (zH mH − rF mF)/mA",
        "IAxx = IHxx + IFxx + mH (zH − zA)² + mF (rF + zA)², IAxz = IHxz − mH (xH − xA)(zH − zA) + mF (w − xA)(rF + zA), IAzz = IHzz + IFzz + mH (xH − xA)² + mF (w − xA)²",
        "uA = (xA − w − c) cos λ − zA sin λ",
        "IAλλ = mA uA² + IAxx sin²λ + 2 IAxz sin λ cos λ + IAzz cos²λ, IAλx = −mA uA zA + IAxx sin λ + IAxz cos λ, IAλz = mA uA xA + IAxz sin λ + IAzz cos λ",
        "μ = (c/w) cos λ, SR = IRyy/rR, SF = IFyy/rF, ST = SR + SF, SA = mA uA + μ mT xT",
        "M = [[ITxx, IAλx + μ ITxz], [IAλx + μ ITxz, IAλλ + 2 μ IAλz + μ² ITzz]]",
        "K0 = [[mT zT, −SA], [−SA, −SA sin λ]]",
        "K2 = [[0, (ST − mT zT) cos λ / w], [0, (SA + SF sin λ) cos λ / w]]",
        "C1 = [[0, μ ST + SF cos λ + ITxz cos λ / w − μ mT zT], [−(μ ST + SF cos λ), IAλz cos λ / w + μ (SA + ITzz cos λ / w)]]",
        "With the Table 1 defaults the upright bicycle is self-stable for 4.2924 m/s < v < 6.0243 m/s (weave and capsize speeds).",
        "IByy and IHyy are listed in Table 1 but do not enter the linearised equations.",
    ];

    fn parameters() -> Vec<Var> {
        let mass = |name, start, what| Var::new(name, Some("kg"), start, what).min(0.0);
        let inertia = |name, start, what| Var::new(name, Some("kg.m2"), start, what);
        vec![
            Var::new("w", Some("m"), 1.02, "Wheelbase").min(1e-12),
            Var::new("c", Some("m"), 0.08, "Trail"),
            Var::new(
                "lambda",
                Some("rad"),
                PI / 10.0,
                "Steer axis tilt (π/2 − head angle)",
            ),
            Var::new("g", Some("m/s2"), 9.81, "Gravitational acceleration"),
            Var::new("v", Some("m/s"), 5.0, "Forward speed"),
            Var::new("rR", Some("m"), 0.3, "Rear wheel radius").min(1e-12),
            mass("mR", 2.0, "Rear wheel mass"),
            inertia(
                "IRxx",
                0.0603,
                "Rear wheel moment of inertia about a diameter",
            ),
            inertia("IRyy", 0.12, "Rear wheel moment of inertia about its axle"),
            Var::new(
                "xB",
                Some("m"),
                0.3,
                "Rear body and frame centre of mass, forward of the rear contact point",
            ),
            Var::new(
                "zB",
                Some("m"),
                -0.9,
                "Rear body and frame centre of mass, z (down) from the rear contact point",
            ),
            mass("mB", 85.0, "Rear body and frame mass"),
            inertia(
                "IBxx",
                9.2,
                "Rear body and frame inertia Ixx about its centre of mass",
            ),
            inertia(
                "IByy",
                11.0,
                "Rear body and frame inertia Iyy (does not enter the linearised equations)",
            ),
            inertia(
                "IBzz",
                2.8,
                "Rear body and frame inertia Izz about its centre of mass",
            ),
            inertia(
                "IBxz",
                2.4,
                "Rear body and frame inertia Ixz about its centre of mass",
            ),
            Var::new(
                "xH",
                Some("m"),
                0.9,
                "Handlebar and fork centre of mass, forward of the rear contact point",
            ),
            Var::new(
                "zH",
                Some("m"),
                -0.7,
                "Handlebar and fork centre of mass, z (down) from the rear contact point",
            ),
            mass("mH", 4.0, "Handlebar and fork mass"),
            inertia(
                "IHxx",
                0.05892,
                "Handlebar and fork inertia Ixx about its centre of mass",
            ),
            inertia(
                "IHyy",
                0.06,
                "Handlebar and fork inertia Iyy (does not enter the linearised equations)",
            ),
            inertia(
                "IHzz",
                0.00708,
                "Handlebar and fork inertia Izz about its centre of mass",
            ),
            inertia(
                "IHxz",
                -0.00756,
                "Handlebar and fork inertia Ixz about its centre of mass",
            ),
            Var::new("rF", Some("m"), 0.35, "Front wheel radius").min(1e-12),
            mass("mF", 3.0, "Front wheel mass"),
            inertia(
                "IFxx",
                0.1405,
                "Front wheel moment of inertia about a diameter",
            ),
            inertia("IFyy", 0.28, "Front wheel moment of inertia about its axle"),
        ]
    }

    fn inputs() -> Vec<Var> {
        vec![
            Var::new("T_phi", Some("N.m"), 0.0, "Roll torque on the rear frame"),
            Var::new(
                "T_delta",
                Some("N.m"),
                0.0,
                "Steer torque between the rear frame and the front assembly",
            ),
        ]
    }

    fn states() -> Vec<Var> {
        vec![
            Var::new(
                "phi",
                Some("rad"),
                0.05,
                "Roll angle of the rear frame (lean to the right positive)",
            )
            .nominal(0.1),
            Var::new(
                "delta",
                Some("rad"),
                0.0,
                "Steer angle of the front assembly relative to the rear frame",
            )
            .nominal(0.1),
            Var::new("phi_dot", Some("rad/s"), 0.0, "Roll rate").nominal(1.0),
            Var::new("delta_dot", Some("rad/s"), 0.0, "Steer rate").nominal(1.0),
        ]
    }

    fn outputs() -> Vec<Var> {
        Vec::new()
    }

    /// Neither f nor g reads t.
    fn explicit_time(_p: &[f64]) -> (bool, bool) {
        (false, false)
    }

    #[inline(always)]
    fn derivatives<S: Scalar>(_t: f64, x: &[S], u: &[S], p: &[S], dx: &mut [S]) {
        let k = canonical(p);
        let [phi_dd, delta_dd] = accelerations(&k, p[G], p[V], x, u);
        dx[0] = x[2];
        dx[1] = x[3];
        dx[2] = phi_dd;
        dx[3] = delta_dd;
    }

    fn extra_outputs<S: Scalar>(_t: f64, _x: &[S], _u: &[S], _p: &[S], _y: &mut [S]) {}

    /// The linearised bicycle: `ẋ = A(v) x + B u` at a fixed speed.
    fn linear_time_invariant(_p: &[f64]) -> bool {
        true
    }

    fn scenes() -> Vec<Scene> {
        vec![
            Scene::new(
                "stable",
                "v = 5 m/s, inside the self-stable range: a roll of 0.05 rad decays",
                10.0,
            )
            .set("v", 5.0)
            .set("phi", 0.05),
            Scene::new(
                "weave",
                "v = 2 m/s, below the weave speed: a roll of 0.01 rad grows in an oscillating weave",
                5.0,
            )
            .set("v", 2.0)
            .set("phi", 0.01),
            Scene::new(
                "capsize",
                "v = 8 m/s, above the capsize speed: a roll of 0.01 rad slowly diverges (capsize)",
                20.0,
            )
            .set("v", 8.0)
            .set("phi", 0.01),
        ]
    }
}
