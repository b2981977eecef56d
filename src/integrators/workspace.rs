//! The scratch the integrators work in, kept between calls so that a call in steady state
//! allocates nothing.
//!
//! A [`Workspace`] holds capacity, not information: every buffer is written in full before
//! it is read, by the method or by f (a [`System`](crate::model::System) writes every
//! component of its derivative), or else zeroed as `vec![0.0; n]` gave it; and the one
//! cache it keeps (Gauss's factorized Newton matrix) is keyed on everything it is computed
//! from. So a result never depends on what an earlier call left here: a fresh
//! `Workspace::default()` gives the same bits as a used one, only with allocations. It is
//! not part of the FMU state.

use super::{dop853, dopri5, exact_linear, gauss, radau5, rattle};

/// Scratch for every method; each uses its own part, sized on first use.
#[derive(Default)]
pub struct Workspace {
    /// The fixed-step loop's new state and the one-stage methods' f (Euler, Verlet).
    pub(super) fixed: [Vec<f64>; 2],
    /// RK4's stages k1 … k4 and its new state.
    pub(super) rk4: [Vec<f64>; 5],
    pub(super) gauss: gauss::Scratch,
    pub(super) dopri5: dopri5::Scratch,
    pub(super) dop853: dop853::Scratch,
    pub(super) radau5: radau5::Scratch,
    pub(super) exact_linear: exact_linear::Scratch,
    pub(super) rattle: rattle::Scratch,
    /// The communication point read from a dense output.
    pub(super) point: Vec<f64>,
}

/// `v` as `n` zeros, as `vec![0.0; n]` would give, without allocating once `v` has held `n`.
pub(crate) fn zeroed(v: &mut Vec<f64>, n: usize) -> &mut [f64] {
    v.clear();
    v.resize(n, 0.0);
    v
}

/// `v` with `n` entries, for a buffer written in full before it is read (its old values are
/// left: no clearing in the hot loops), without allocating once `v` has held `n`.
#[inline]
pub(crate) fn sized(v: &mut Vec<f64>, n: usize) -> &mut [f64] {
    // (The test first: `resize` is not inlined, and the hot paths call this each step.)
    if v.len() != n {
        v.resize(n, 0.0);
    }
    v
}

/// `v` holding a copy of `x`, without allocating once `v` has held as many.
#[inline]
pub(crate) fn copied<'a>(v: &'a mut Vec<f64>, x: &[f64]) -> &'a mut [f64] {
    let v = sized(v, x.len());
    v.copy_from_slice(x);
    v
}
