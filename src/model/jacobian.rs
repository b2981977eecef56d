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
pub fn directional<M: System>(d: &Direction, n_outputs: usize) -> (Vec<f64>, Vec<f64>) {
    let seed = |(v, dv): (&[f64], &[f64])| -> Vec<Dual64> {
        v.iter()
            .zip(dv)
            .map(|(&v, &dv)| Dual64::new(v, dv))
            .collect()
    };
    let (x, u, p) = (seed(d.x), seed(d.u), seed(d.p));
    let mut dx = vec![Dual64::from(0.0); x.len()];
    let mut y = vec![Dual64::from(0.0); n_outputs];
    M::derivatives(d.t, &x, &u, &p, &mut dx);
    if n_outputs > 0 {
        M::extra_outputs(d.t, &x, &u, &p, &mut y);
    }
    (
        dx.iter().map(|v| v.eps).collect(),
        y.iter().map(|v| v.eps).collect(),
    )
}
