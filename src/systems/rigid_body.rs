//! Free rigid body in principal axes (notes 8.6, 8.7; Euler's equations 8.72), its
//! attitude carried by a unit quaternion so nothing is singular at pitch = ±90°.
//!
//! Attitude convention (notes 7.20–7.22, SAE axes, z down): `r′ = A r` maps inertial
//! components to body components, `A = B(φ) C(θ) D(ψ)` with yaw ψ about z, pitch θ about
//! the intermediate y, roll φ about the body x. The quaternion `q = (q0, q1, q2, q3)`
//! is body-to-inertial: its rotation matrix is `R(q) = Aᵀ = Rz(ψ) Ry(θ) Rx(φ)`.

use crate::model::{Scalar, Scene, System, Var};
use std::f64::consts::PI;

pub struct RigidBody;

/// Below this value of `cos θ` (relative to |q|²) the roll and the yaw are no longer
/// separately defined (only ψ ∓ φ is, at θ = ±90°): roll is set to 0 and the yaw takes
/// the whole rotation about the vertical. `cos θ` is known to a few 1e-16 from the
/// quaternion, so above 1e-12 the two `atan2` still resolve both angles to ~1e-4 rad
/// and the angles always reproduce the rotation matrix to rounding.
const GIMBAL_COS_THETA: f64 = 1e-12;

impl RigidBody {
    /// The unit quaternion (body-to-inertial) of the notes' Euler angles:
    /// `q = qz(ψ) ⊗ qy(θ) ⊗ qx(φ)`, i.e. `R(q) = Rz(ψ) Ry(θ) Rx(φ) = (B C D)ᵀ`.
    pub fn quaternion_from_euler(roll: f64, pitch: f64, yaw: f64) -> [f64; 4] {
        let (sr, cr) = (0.5 * roll).sin_cos();
        let (sp, cp) = (0.5 * pitch).sin_cos();
        let (sy, cy) = (0.5 * yaw).sin_cos();
        [
            cy * cp * cr + sy * sp * sr,
            cy * cp * sr - sy * sp * cr,
            cy * sp * cr + sy * cp * sr,
            sy * cp * cr - cy * sp * sr,
        ]
    }

    /// `R(q)`, body-to-inertial (inertial components = R · body components), for any
    /// non-zero `q`: the homogeneous form divided by |q|², exactly orthogonal in exact
    /// arithmetic whatever the norm of `q`.
    pub fn rotation_matrix<S: Scalar>(q: &[S]) -> [[S; 3]; 3] {
        crate::multibody::spatial::quat_to_matrix(&[q[0], q[1], q[2], q[3]])
    }

    /// The notes' Euler angles `(roll φ, pitch θ, yaw ψ)` of the attitude `q` (any
    /// non-zero norm): θ = atan2(−R20, √(R21² + R22²)) ∈ [−π/2, π/2] (full accuracy
    /// near ±90°, where asin(−R20) would lose half the digits), φ = atan2(R21, R22),
    /// ψ = atan2(R10, R00) ∈ (−π, π]. At θ = ±90° (gimbal lock) φ = 0 and
    /// ψ = atan2(−R01, R11).
    pub fn euler_angles<S: Scalar>(q: &[S]) -> (S, S, S) {
        // Unnormalised matrix entries: every atan2 is invariant to the common factor |q|².
        let (q0, q1, q2, q3) = (q[0], q[1], q[2], q[3]);
        let n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3;
        let r20 = (q1 * q3 - q0 * q2) * 2.0;
        let r21 = (q2 * q3 + q0 * q1) * 2.0;
        let r22 = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3;
        let r10 = (q1 * q2 + q0 * q3) * 2.0;
        let r00 = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3;
        let cos_theta = (r21 * r21 + r22 * r22).sqrt();
        let pitch = (-r20).atan2(cos_theta);
        if cos_theta.re() <= GIMBAL_COS_THETA * n2.re() {
            let r01 = (q1 * q2 - q0 * q3) * 2.0;
            let r11 = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3;
            (S::from(0.0), pitch, (-r01).atan2(r11))
        } else {
            (r21.atan2(r22), pitch, r10.atan2(r00))
        }
    }
}

impl System for RigidBody {
    const NAME: &'static str = "RigidBody";
    const DESCRIPTION: &'static str =
        "A free rigid body in principal axes (Euler's equations), attitude as a unit quaternion";
    const EQUATIONS: &'static [&'static str] = &[
        "I1 Ω̇1 − (I2 − I3) Ω2 Ω3 = N1",
        "I2 Ω̇2 − (I3 − I1) Ω3 Ω1 = N2",
        "I3 Ω̇3 − (I1 − I2) Ω1 Ω2 = N3",
        "q̇ = ½ q ⊗ (0, Ω): q = (q0, q1, q2, q3) is the body-to-inertial unit quaternion, Ω the body rates.",
        "No stabilisation term k(1 − |q|²) q: the exact flow keeps |q| (the matrix of ½ q ⊗ (0, Ω) is skew), so the only drift is the integrator's, at the tolerance; after every doStep q is renormalised (q ← q/|q|, the nearest unit quaternion), so drift cannot accumulate.",
        "Attitude convention of the notes (7.20–7.22, z down): r′ = A r with A = B(φ) C(θ) D(ψ), yaw ψ about z, pitch θ about the intermediate y, roll φ about the body x; the matrix of q is R(q) = Aᵀ.",
        "pitch = atan2(−R20, √(R21² + R22²)) ∈ [−90°, 90°], roll = atan2(R21, R22), yaw = atan2(R10, R00): the angles are outputs only, so nothing is singular at pitch = ±90°; there (gimbal lock) only yaw ∓ roll is defined, and roll = 0 is reported.",
        "H = R(q) (I1 Ω1, I2 Ω2, I3 Ω3): angular momentum in the inertial frame, constant without torque.",
        "E = ½ (I1 Ω1² + I2 Ω2² + I3 Ω3²)",
        "Spin Ω about axis 2 with I1 < I2 < I3 is unstable: perturbations grow as exp(λ t), λ = Ω √((I2 − I1)(I3 − I2)/(I1 I3)).",
    ];

    fn parameters() -> Vec<Var> {
        vec![
            Var::new(
                "I1",
                Some("kg.m2"),
                1.0,
                "Principal moment of inertia about body axis 1",
            )
            .min(1e-12),
            Var::new(
                "I2",
                Some("kg.m2"),
                2.0,
                "Principal moment of inertia about body axis 2",
            )
            .min(1e-12),
            Var::new(
                "I3",
                Some("kg.m2"),
                3.0,
                "Principal moment of inertia about body axis 3",
            )
            .min(1e-12),
        ]
    }

    fn inputs() -> Vec<Var> {
        vec![
            Var::new("N1", Some("N.m"), 0.0, "Torque about body axis 1"),
            Var::new("N2", Some("N.m"), 0.0, "Torque about body axis 2"),
            Var::new("N3", Some("N.m"), 0.0, "Torque about body axis 3"),
        ]
    }

    fn states() -> Vec<Var> {
        vec![
            Var::new(
                "omega1",
                Some("rad/s"),
                1.0,
                "Body angular velocity about axis 1",
            )
            .nominal(1.0),
            Var::new(
                "omega2",
                Some("rad/s"),
                0.5,
                "Body angular velocity about axis 2",
            )
            .nominal(1.0),
            Var::new(
                "omega3",
                Some("rad/s"),
                0.2,
                "Body angular velocity about axis 3",
            )
            .nominal(1.0),
            Var::new(
                "q0",
                None,
                1.0,
                "Attitude quaternion (body to inertial), scalar part",
            )
            .nominal(1.0),
            Var::new("q1", None, 0.0, "Attitude quaternion, x component").nominal(1.0),
            Var::new("q2", None, 0.0, "Attitude quaternion, y component").nominal(1.0),
            Var::new("q3", None, 0.0, "Attitude quaternion, z component").nominal(1.0),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![
            Var::new("roll", Some("rad"), 0.0, "Roll angle φ (notes' convention)"),
            Var::new("pitch", Some("rad"), 0.0, "Pitch angle θ, in [−90°, 90°]"),
            Var::new("yaw", Some("rad"), 0.0, "Yaw angle ψ (heading)"),
            Var::new(
                "H1",
                Some("kg.m2/s"),
                0.0,
                "Angular momentum, inertial x component",
            ),
            Var::new(
                "H2",
                Some("kg.m2/s"),
                0.0,
                "Angular momentum, inertial y component",
            ),
            Var::new(
                "H3",
                Some("kg.m2/s"),
                0.0,
                "Angular momentum, inertial z component",
            ),
            Var::new(
                "E",
                Some("J"),
                0.0,
                "Kinetic energy ½ (I1 Ω1² + I2 Ω2² + I3 Ω3²)",
            ),
        ]
    }

    /// Neither f nor g reads t.
    fn explicit_time(_p: &[f64]) -> (bool, bool) {
        (false, false)
    }

    #[inline(always)]
    fn derivatives<S: Scalar>(_t: f64, x: &[S], u: &[S], p: &[S], dx: &mut [S]) {
        let [i1, i2, i3] = [p[0], p[1], p[2]];
        let [w1, w2, w3] = [x[0], x[1], x[2]];
        let [q0, q1, q2, q3] = [x[3], x[4], x[5], x[6]];
        // Euler's equations (8.72).
        dx[0] = ((i2 - i3) * w2 * w3 + u[0]) / i1;
        dx[1] = ((i3 - i1) * w3 * w1 + u[1]) / i2;
        dx[2] = ((i1 - i2) * w1 * w2 + u[2]) / i3;
        // q̇ = ½ q ⊗ (0, Ω) = ½ (−q·Ω, q0 Ω + q × Ω).
        dx[3] = -(q1 * w1 + q2 * w2 + q3 * w3) * 0.5;
        dx[4] = (q0 * w1 + q2 * w3 - q3 * w2) * 0.5;
        dx[5] = (q0 * w2 + q3 * w1 - q1 * w3) * 0.5;
        dx[6] = (q0 * w3 + q1 * w2 - q2 * w1) * 0.5;
    }

    #[inline(always)]
    fn extra_outputs<S: Scalar>(_t: f64, x: &[S], _u: &[S], p: &[S], y: &mut [S]) {
        let [i1, i2, i3] = [p[0], p[1], p[2]];
        let [w1, w2, w3] = [x[0], x[1], x[2]];
        let q = &x[3..7];
        let (roll, pitch, yaw) = Self::euler_angles(q);
        y[0] = roll;
        y[1] = pitch;
        y[2] = yaw;
        let h = [i1 * w1, i2 * w2, i3 * w3];
        let r = Self::rotation_matrix(q);
        for (yi, row) in y[3..6].iter_mut().zip(&r) {
            *yi = row[0] * h[0] + row[1] * h[1] + row[2] * h[2];
        }
        y[6] = (i1 * w1 * w1 + i2 * w2 * w2 + i3 * w3 * w3) * 0.5;
    }

    fn scenes() -> Vec<Scene> {
        let identity = |s: Scene| {
            s.set("q0", 1.0)
                .set("q1", 0.0)
                .set("q2", 0.0)
                .set("q3", 0.0)
        };
        // gimbal: roll 90° turns body axis 3 horizontal along inertial y, so a steady spin
        // about it (the axis of largest inertia: stable) is a pure pitch rate of 10°/s,
        // from 80° through 90° exactly at t = 1 s (on a communication point).
        let q = Self::quaternion_from_euler(0.5 * PI, 80.0_f64.to_radians(), 0.0);
        vec![
            identity(Scene::new(
                "symmetric_top",
                "Symmetric top I = (1, 1, 2), Ω = (1, 0, 5): (Ω1, Ω2) rotate at 5 rad/s",
                10.0,
            ))
            .set("I1", 1.0)
            .set("I2", 1.0)
            .set("I3", 2.0)
            .set("omega1", 1.0)
            .set("omega2", 0.0)
            .set("omega3", 5.0),
            identity(Scene::new(
                "stable_spin",
                "Spin 5 rad/s about axis 3 (largest inertia), 1e-3 rad/s on axes 1, 2: stays small",
                20.0,
            ))
            .set("omega1", 1e-3)
            .set("omega2", 1e-3)
            .set("omega3", 5.0),
            identity(Scene::new(
                "intermediate_axis",
                "Spin 5 rad/s about axis 2 (intermediate), 1e-3 rad/s on axes 1, 3: the body flips periodically",
                20.0,
            ))
            .set("omega1", 1e-3)
            .set("omega2", 5.0)
            .set("omega3", 1e-3),
            Scene::new(
                "gimbal",
                "Roll 90°, pitch 80°, pitch rate 10°/s (steady spin about axis 3): pitch passes 90° at t = 1 s",
                3.0,
            )
            .set("omega1", 0.0)
            .set("omega2", 0.0)
            .set("omega3", -10.0_f64.to_radians())
            .set("q0", q[0])
            .set("q1", q[1])
            .set("q2", q[2])
            .set("q3", q[3]),
        ]
    }

    fn default_experiment() -> (f64, f64, f64) {
        (20.0, 1e-8, 1e-2)
    }

    /// Renormalises the quaternion, `q ← q / |q|`: the nearest unit quaternion (the
    /// orthogonal projection onto S³ in R⁴), so exact on the manifold (a unit `q` is left
    /// as it is, to rounding) and the attitude `R(q)` does not change at all, since
    /// `R` depends only on the direction of `q`. A zero or non-finite `q` is left alone.
    fn project(_t: f64, _p: &[f64], x: &mut [f64]) {
        let q = &mut x[3..7];
        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        if n.is_finite() && n > 0.0 {
            for v in q {
                *v /= n;
            }
        }
    }
}
