//! The inputs over a doStep: held constant (FMI's default), or the polynomial the importer
//! gives with fmi2SetRealInputDerivatives, `u(t) = u + u̇ (t − t_c) + ü (t − t_c)²/2` from
//! the communication point `t_c` (FMI 2.0, 4.2.2: "inputs and their derivatives are set
//! with respect to the beginning of a communication time step").
//!
//! After a doStep the instance's inputs are that polynomial's value and derivatives at the
//! new time ([`advance`]): fmi2GetReal of an input, the outputs and their derivatives all
//! see the input the integration used there, and a master that sets nothing new continues
//! along the same polynomial.

use crate::integrators::sized;

/// Highest input derivative order fmi2SetRealInputDerivatives accepts.
pub const MAX_INPUT_DERIVATIVE_ORDER: i32 = 2;

/// The inputs `u` with their time derivatives `der` at `t_c`.
#[derive(Clone, Copy)]
pub struct Inputs<'a> {
    u: &'a [f64],
    der: &'a [Vec<f64>; 2],
    t_c: f64,
    /// Whether any derivative is set, found once here: [`Inputs::at`] is asked at every
    /// evaluation of the right-hand side.
    moving: bool,
}

impl<'a> Inputs<'a> {
    #[inline]
    pub fn new(u: &'a [f64], der: &'a [Vec<f64>; 2], t_c: f64) -> Self {
        Inputs {
            u,
            der,
            t_c,
            moving: moving(der),
        }
    }

    /// The inputs `u` held (no derivative set: the caller knows it), without looking.
    #[inline]
    pub fn held(u: &'a [f64], der: &'a [Vec<f64>; 2]) -> Self {
        Inputs {
            u,
            der,
            t_c: 0.0,
            moving: false,
        }
    }

    /// Whether any derivative is set (else the inputs are held: the fast paths).
    #[inline]
    pub fn moving(&self) -> bool {
        self.moving
    }

    /// `u(t)`: the held inputs themselves when nothing moves, else written into `buf`
    /// (sized to one entry per input only then).
    #[inline]
    pub fn at<'b>(&self, t: f64, buf: &'b mut Vec<f64>) -> &'b [f64]
    where
        'a: 'b,
    {
        if !self.moving {
            return self.u;
        }
        let s = t - self.t_c;
        let [d1, d2] = self.der;
        let buf = sized(buf, self.u.len());
        for (i, v) in buf.iter_mut().enumerate() {
            *v = value(self.u[i], d1[i], d2[i], s);
        }
        buf
    }
}

/// Whether any of the derivatives `der` is nonzero. (Asked at every doStep: one plain loop
/// over both orders, inlined, where `flatten` cost 30 instructions a call.)
#[inline]
pub fn moving(der: &[Vec<f64>; 2]) -> bool {
    let [d1, d2] = der;
    if d1.len() != d2.len() {
        return true; // (never: both hold one entry per input; the general path copes)
    }
    (0..d1.len()).any(|i| d1[i] != 0.0 || d2[i] != 0.0)
}

/// `u + u̇ s + ü s²/2`.
#[inline]
fn value(u: f64, d1: f64, d2: f64, s: f64) -> f64 {
    u + s * (d1 + 0.5 * s * d2)
}

/// Moves the inputs `u` and their derivatives `der` a time `s` along their polynomial:
/// the value and derivatives at `t_c + s` (the same arithmetic as [`Inputs::at`]).
pub fn advance(u: &mut [f64], der: &mut [Vec<f64>; 2], s: f64) {
    let [d1, d2] = der;
    for i in 0..u.len() {
        u[i] = value(u[i], d1[i], d2[i], s);
        d1[i] += s * d2[i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polynomial_and_its_advance_agree() {
        let der = [vec![2.0], vec![-4.0]];
        let inputs = Inputs::new(&[1.0], &der, 3.0);
        let mut buf = Vec::new();
        // u(3.5) = 1 + 2·0.5 − 4·0.25/2 = 1.5 (exact in binary).
        assert_eq!(inputs.at(3.5, &mut buf), &[1.5]);
        let (mut u, mut d) = (vec![1.0], der.clone());
        advance(&mut u, &mut d, 0.5);
        assert_eq!((u[0], d[0][0], d[1][0]), (1.5, 0.0, -4.0));
        let held = [vec![0.0], vec![0.0]];
        let inputs = Inputs::new(&[7.0], &held, 0.0);
        assert_eq!(inputs.at(1.0, &mut buf), &[7.0]);
    }
}
