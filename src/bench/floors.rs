//! Hand-written floors for `mbfmu speed`: the equations of `../shared/systems.md` typed
//! by hand in plain `f64` on fixed-size arrays, and the same classic RK4 step the FMU
//! takes, with the same energy output. What a person writing the model by hand in C or
//! Rust would ship; they live here, never in an FMU.

/// A hand-written system: its right-hand side and its extra outputs (their sum, so that
/// none is optimised away), and its projection after a step where the FMU has one.
pub trait Floor<const N: usize> {
    fn rhs(x: &[f64; N], p: &[f64]) -> [f64; N];
    fn energy(x: &[f64; N], p: &[f64]) -> f64;
    fn project(_x: &mut [f64; N]) {}
}

/// One RK4 step of `h`, the projection, and the outputs at its end: the work of one
/// fixed-step doStep.
#[inline(never)]
pub fn rk4_step<F: Floor<N>, const N: usize>(x: &mut [f64; N], p: &[f64], h: f64) -> f64 {
    let add = |a: &[f64; N], k: &[f64; N], s: f64| -> [f64; N] {
        std::array::from_fn(|i| a[i] + s * k[i])
    };
    let k1 = F::rhs(x, p);
    let k2 = F::rhs(&add(x, &k1, 0.5 * h), p);
    let k3 = F::rhs(&add(x, &k2, 0.5 * h), p);
    let k4 = F::rhs(&add(x, &k3, h), p);
    for i in 0..N {
        x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    F::project(x);
    F::energy(x, p)
}

/// `m ẍ + c ẋ + k x = 0`; parameters `m k c` as the FMU's (forcing off).
pub struct MassSpringDamper;

impl Floor<2> for MassSpringDamper {
    fn rhs(x: &[f64; 2], p: &[f64]) -> [f64; 2] {
        let (m, k, c) = (p[0], p[1], p[2]);
        [x[1], -(c * x[1] + k * x[0]) / m]
    }
    fn energy(x: &[f64; 2], p: &[f64]) -> f64 {
        0.5 * p[0] * x[1] * x[1] + 0.5 * p[1] * x[0] * x[0]
    }
}

/// Wall–k1–m1–(k2 ∥ c2)–m2 (systems.md); parameters `m1 m2 k1 k2 c2` as the FMU's, no
/// force on m1; states `x1 x2 v1 v2`, output E.
pub struct TwoMassChain;

impl Floor<4> for TwoMassChain {
    fn rhs(x: &[f64; 4], p: &[f64]) -> [f64; 4] {
        let (m1, m2, k1, k2, c2) = (p[0], p[1], p[2], p[3], p[4]);
        let coupling = k2 * (x[1] - x[0]) + c2 * (x[3] - x[2]);
        [x[2], x[3], (coupling - k1 * x[0]) / m1, -coupling / m2]
    }
    fn energy(x: &[f64; 4], p: &[f64]) -> f64 {
        let (m1, m2, k1, k2) = (p[0], p[1], p[2], p[3]);
        let stretch = x[1] - x[0];
        0.5 * (m1 * x[2] * x[2] + m2 * x[3] * x[3] + k1 * x[0] * x[0] + k2 * stretch * stretch)
    }
}

/// Euler's equations and `q̇ = ½ q ⊗ (0, Ω)`; parameters `I1 I2 I3`, no torques; the
/// quaternion renormalised after the step, and the outputs roll, pitch, yaw (three atan2
/// of the attitude matrix), the inertial angular momentum H and the energy E, as the FMU
/// computes them.
pub struct RigidBody;

impl Floor<7> for RigidBody {
    fn rhs(x: &[f64; 7], p: &[f64]) -> [f64; 7] {
        let (i1, i2, i3) = (p[0], p[1], p[2]);
        let [w1, w2, w3, q0, q1, q2, q3] = *x;
        [
            (i2 - i3) * w2 * w3 / i1,
            (i3 - i1) * w3 * w1 / i2,
            (i1 - i2) * w1 * w2 / i3,
            -0.5 * (q1 * w1 + q2 * w2 + q3 * w3),
            0.5 * (q0 * w1 + q2 * w3 - q3 * w2),
            0.5 * (q0 * w2 + q3 * w1 - q1 * w3),
            0.5 * (q0 * w3 + q1 * w2 - q2 * w1),
        ]
    }
    fn energy(x: &[f64; 7], p: &[f64]) -> f64 {
        let (i1, i2, i3) = (p[0], p[1], p[2]);
        let [w1, w2, w3, q0, q1, q2, q3] = *x;
        let r00 = q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3;
        let r11 = q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3;
        let r22 = q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3;
        let (r01, r10) = (2.0 * (q1 * q2 - q0 * q3), 2.0 * (q1 * q2 + q0 * q3));
        let (r02, r20) = (2.0 * (q1 * q3 + q0 * q2), 2.0 * (q1 * q3 - q0 * q2));
        let (r12, r21) = (2.0 * (q2 * q3 - q0 * q1), 2.0 * (q2 * q3 + q0 * q1));
        let pitch = (-r20).atan2((r21 * r21 + r22 * r22).sqrt());
        let (roll, yaw) = (r21.atan2(r22), r10.atan2(r00));
        let h = [i1 * w1, i2 * w2, i3 * w3];
        let h_inertial = [
            r00 * h[0] + r01 * h[1] + r02 * h[2],
            r10 * h[0] + r11 * h[1] + r12 * h[2],
            r20 * h[0] + r21 * h[1] + r22 * h[2],
        ];
        let e = 0.5 * (i1 * w1 * w1 + i2 * w2 * w2 + i3 * w3 * w3);
        roll + pitch + yaw + h_inertial.iter().sum::<f64>() + e
    }
    fn project(x: &mut [f64; 7]) {
        let n = (x[3] * x[3] + x[4] * x[4] + x[5] * x[5] + x[6] * x[6]).sqrt();
        for q in &mut x[3..] {
            *q /= n;
        }
    }
}

/// `I_O θ̈ + m g l sin θ = τ` (systems.md); parameters `m l I_O g`, no torque.
pub struct CompoundPendulum;

impl Floor<2> for CompoundPendulum {
    fn rhs(x: &[f64; 2], p: &[f64]) -> [f64; 2] {
        let (m, l, i_o, g) = (p[0], p[1], p[2], p[3]);
        [x[1], -m * g * l * x[0].sin() / i_o]
    }
    fn energy(x: &[f64; 2], p: &[f64]) -> f64 {
        let (m, l, i_o, g) = (p[0], p[1], p[2], p[3]);
        0.5 * i_o * x[1] * x[1] - m * g * l * x[0].cos()
    }
}

/// The double pendulum of systems.md §5 in absolute angles, by Cramer's rule; parameters
/// `m1 m2 r1 l2 g`, no torques.
pub struct DoublePendulum;

impl Floor<4> for DoublePendulum {
    fn rhs(x: &[f64; 4], p: &[f64]) -> [f64; 4] {
        let (th, ph, thd, phd) = (x[0], x[1], x[2], x[3]);
        let (m1, m2, r1, l2, g) = (p[0], p[1], p[2], p[3], p[4]);
        let (s, c) = (ph - th).sin_cos();
        let a11 = (m1 + m2) * r1 * r1;
        let a12 = m2 * r1 * l2 * c;
        let a22 = m2 * l2 * l2;
        let b1 = m2 * r1 * l2 * phd * phd * s - (m1 + m2) * g * r1 * th.sin();
        let b2 = -m2 * r1 * l2 * thd * thd * s - m2 * g * l2 * ph.sin();
        let det = a11 * a22 - a12 * a12;
        [
            thd,
            phd,
            (b1 * a22 - a12 * b2) / det,
            (a11 * b2 - b1 * a12) / det,
        ]
    }
    fn energy(x: &[f64; 4], p: &[f64]) -> f64 {
        let (th, ph, thd, phd) = (x[0], x[1], x[2], x[3]);
        let (m1, m2, r1, l2, g) = (p[0], p[1], p[2], p[3], p[4]);
        let t = 0.5 * (m1 + m2) * r1 * r1 * thd * thd
            + 0.5 * m2 * l2 * l2 * phd * phd
            + m2 * r1 * l2 * thd * phd * (ph - th).cos();
        let v = -g * ((m1 + m2) * r1 * th.cos() + m2 * l2 * ph.cos());
        t + v
    }
}
