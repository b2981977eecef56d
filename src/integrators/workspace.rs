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

// Each method takes its own part (its `Scratch`, or the plain buffers below), so the methods
// never name this type: it sits above them, where the dispatch of `integrators` hands the
// parts out.

/// Scratch for every method; each uses its own part, sized on first use.
#[derive(Default)]
pub struct Workspace {
    /// The new state and f of the explicit fixed-step methods (Euler, Verlet).
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
