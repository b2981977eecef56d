//! Exact directional derivatives of a system's right-hand side and outputs, by
//! forward-mode dual numbers: one evaluation per direction, no step size to choose.

use super::System;
use num_dual::Dual64;

/// A point (t, x, u, p) and a direction (δx, δu, δp) in the space of knowns.
pub struct Direction<'a> {
    pub t: f64,
    pub x: (&'a [f64], &'a [f64]),
    pub u: (&'a [f64], &'a [f64]),
    pub p: (&'a [f64], &'a [f64]),
}

/// `(∂f/∂(x,u,p)·δ, ∂g/∂(x,u,p)·δ)`: the change of the state derivatives and of the
/// extra outputs along the direction. With `n_outputs == 0` only f is evaluated.
/// ([`Duals::directional`] without allocating.)
pub fn directional<M: System>(d: &Direction, n_outputs: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut df, mut dg) = (vec![0.0; d.x.0.len()], vec![0.0; n_outputs]);
    Duals::default().directional::<M>(d, &mut df, &mut dg);
    (df, dg)
}

/// The dual numbers [`directional`] and the Jacobian evaluate a system in, kept between
/// calls: no allocation once they have held these sizes. Holds no information (every
/// value is set before each evaluation).
#[derive(Default)]
pub struct Duals {
    x: Vec<Dual64>,
    u: Vec<Dual64>,
    p: Vec<Dual64>,
    dx: Vec<Dual64>,
    y: Vec<Dual64>,
}

/// `v` holding the duals `(value, eps)`.
fn seed(v: &mut Vec<Dual64>, (value, eps): (&[f64], &[f64])) {
    v.clear();
    v.extend(value.iter().zip(eps).map(|(&v, &dv)| Dual64::new(v, dv)));
}

/// `v` holding the duals `(value, 0)`: held in a derivative.
fn held(v: &mut Vec<Dual64>, value: &[f64]) {
    v.clear();
    v.extend(value.iter().map(|&v| Dual64::new(v, 0.0)));
}

/// `v` as `n` dual zeros.
fn zeros(v: &mut Vec<Dual64>, n: usize) {
    v.clear();
    v.resize(n, Dual64::from(0.0));
}

impl Duals {
    /// [`directional`] into `df` (one per state) and `dg` (one per extra output; empty:
    /// only f is evaluated).
    pub fn directional<M: System>(&mut self, d: &Direction, df: &mut [f64], dg: &mut [f64]) {
        seed(&mut self.x, d.x);
        seed(&mut self.u, d.u);
        seed(&mut self.p, d.p);
        zeros(&mut self.dx, self.x.len());
        zeros(&mut self.y, dg.len());
        M::derivatives(d.t, &self.x, &self.u, &self.p, &mut self.dx);
        if !dg.is_empty() {
            M::extra_outputs(d.t, &self.x, &self.u, &self.p, &mut self.y);
        }
        for (o, v) in df.iter_mut().zip(&self.dx) {
            *o = v.eps;
        }
        for (o, v) in dg.iter_mut().zip(&self.y) {
            *o = v.eps;
        }
    }

    /// `∂f/∂x` at `(t, x, u, p)`, row-major n×n into `jac`: column j is [`directional`]
    /// along the unit vector of state j (the same bits), with inputs and parameters held.
    pub fn jacobian<M: System>(
        &mut self,
        t: f64,
        x: &[f64],
        u: &[f64],
        p: &[f64],
        jac: &mut [f64],
    ) {
        let n = x.len();
        held(&mut self.x, x);
        held(&mut self.u, u);
        held(&mut self.p, p);
        for j in 0..n {
            if j > 0 {
                self.x[j - 1].eps = 0.0;
            }
            self.x[j].eps = 1.0;
            zeros(&mut self.dx, n);
            M::derivatives(t, &self.x, &self.u, &self.p, &mut self.dx);
            for (i, v) in self.dx.iter().enumerate() {
                jac[i * n + j] = v.eps;
            }
        }
    }
}
