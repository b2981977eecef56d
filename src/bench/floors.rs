//! Hand-written floors for `mbfmu speed`: the equations of `../shared/systems.md` typed
//! by hand in plain `f64` on fixed-size arrays, and the same classic RK4 step the FMU
//! takes, with the same energy output. What a person writing the model by hand in C or
//! Rust would ship; they live here, never in an FMU.

/// A hand-written system: its right-hand side and its energy output.
pub trait Floor<const N: usize> {
    fn rhs(x: &[f64; N], p: &[f64]) -> [f64; N];
    fn energy(x: &[f64; N], p: &[f64]) -> f64;
}

/// One RK4 step of `h` and the energy at its end: the work of one fixed-step doStep.
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
