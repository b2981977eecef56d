//! Exact directional derivatives of a system's right-hand side and outputs, by
//! forward-mode dual numbers: one evaluation per direction, no step size to choose.

use super::System;
use num_dual::{Dual2_64, Dual64};

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

/// A point (t, x, u, p) with the inputs' first and second time derivatives there.
pub struct Moving<'a> {
    pub t: f64,
    pub x: &'a [f64],
    pub u: [&'a [f64]; 3],
    pub p: &'a [f64],
}

/// Time derivatives along the trajectory through a [`Moving`] point: of the states
/// (`x1 = ẋ = f`, `x2 = ẍ`) and of the extra outputs (`y1 = ẏ`, `y2 = ÿ`).
#[derive(Debug, Default, PartialEq)]
pub struct Rates {
    pub x1: Vec<f64>,
    pub x2: Vec<f64>,
    pub y1: Vec<f64>,
    pub y2: Vec<f64>,
}

/// [`Rates`] at `m`, exact: `ẋ = f`; `ẍ = f_x ẋ + f_u u̇` and `ẏ = g_x ẋ + g_u u̇` from one
/// evaluation in dual numbers seeded with (ẋ, u̇); `ÿ` from one in second-order dual
/// numbers seeded with x + ẋ s + ẍ s²/2 and u + u̇ s + ü s²/2 (their s² part is the second
/// derivative along s). `ẍ`, `ẏ`, `ÿ` leave out ∂/∂t: they are exact only where
/// [`System::explicit_time`] says f (`ẍ`, `ÿ`) and g (`ẏ`, `ÿ`) do not read t; the
/// caller refuses the others. Allocates (not on the doStep path).
pub fn rates<M: System>(m: &Moving, n_outputs: usize) -> Rates {
    let n = m.x.len();
    let mut x1 = vec![0.0; n];
    M::derivatives(m.t, m.x, m.u[0], m.p, &mut x1);
    let (mut x2, mut y1) = (vec![0.0; n], vec![0.0; n_outputs]);
    let zeros_p = vec![0.0; m.p.len()];
    let direction = Direction {
        t: m.t,
        x: (m.x, &x1),
        u: (m.u[0], m.u[1]),
        p: (m.p, &zeros_p),
    };
    Duals::default().directional::<M>(&direction, &mut x2, &mut y1);
    let seed2 = |v: &[f64], d1: &[f64], d2: &[f64]| -> Vec<Dual2_64> {
        (0..v.len())
            .map(|i| Dual2_64::new(v[i], d1[i], d2[i]))
            .collect()
    };
    let x = seed2(m.x, &x1, &x2);
    let u = seed2(m.u[0], m.u[1], m.u[2]);
    let p: Vec<Dual2_64> = m.p.iter().map(|&v| Dual2_64::from(v)).collect();
    let mut y = vec![Dual2_64::from(0.0); n_outputs];
    if n_outputs > 0 {
        M::extra_outputs(m.t, &x, &u, &p, &mut y);
    }
    let y2 = y.iter().map(|v| v.v2).collect();
    Rates { x1, x2, y1, y2 }
}

/// The highest order of output derivatives (fmi2GetRealOutputDerivatives) system `M`
/// gives exactly for every output at its default parameters: 2 when neither f nor g reads
/// t, 1 when only f does (ẏ needs no ∂f/∂t; ẍ and ÿ do), 0 when g does. Parameters that
/// make f read t (MassSpringDamper's forcing) make the instance refuse order 2.
pub fn output_derivative_order<M: System>() -> i32 {
    let p: Vec<f64> = M::parameters().iter().map(|v| v.start).collect();
    match M::explicit_time(&p) {
        (_, true) => 0,
        (true, false) => 1,
        (false, false) => 2,
    }
}
