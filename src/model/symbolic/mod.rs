//! PROTOTYPE: equations of motion traced once into an expression graph, differentiated
//! symbolically and emitted as straight-line Rust, the route CasADi and OpenModelica take
//! to hand-written speed. Not wired into the FMUs: it exists to measure whether the route
//! reaches ≤ 2× the hand-derived equations (`mbfmu speed --symbolic`).
//!
//! # Why
//!
//! [`lagrangian`](crate::model::lagrangian) forms `M q̈ = Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇` by
//! nested dual numbers at every evaluation: n² + 2n evaluations of the user's T per
//! right-hand side, each with all its sines and cosines. One `f64` evaluation of
//! DoublePendulum's T costs about as much as the whole hand-written RHS, so no scheme that
//! re-evaluates T can get within 2× of it. Tracing T, V, Q, Φ once moves all of that to
//! generation time; what runs is each distinct subexpression of M, rhs, G, γ once.
//!
//! # The pipeline
//!
//! 1. [`expr`]: [`Expr`], a `Copy` handle into a hash-consed graph, implements
//!    `DualNum<f64>`, so the systems' unchanged generic `kinetic`, `potential`, `forces`,
//!    `constraints` run on it (and so do `Dual<Expr>` and `HyperDual<Expr>` inside them).
//!    Looking at a symbolic value (comparison, `re()`) is recorded, and refused later.
//! 2. [`diff`]: forward and reverse sweeps building derivative nodes in the same graph.
//! 3. [`equations`](mod@equations): M, rhs, G, γ of a [`Lagrangian`](crate::model::lagrangian::Lagrangian).
//! 4. [`emit`]: Rust source of `impl Eom<N, K>`, generic over the scalar so dual numbers
//!    still give exact Jacobians through it; [`runtime`] holds the trait and the solve.
//! 5. [`generated`]: the committed output for some systems, kept current by a test like
//!    modelDescription/ (`cargo run --bin mbfmu -- symbolic` rewrites it). Which systems,
//!    and the driver that writes them, sit above the systems, in
//!    [`bench::symbolic`](crate::bench::symbolic): this layer knows no system.

pub mod diff;
pub mod emit;
pub mod equations;
pub mod expr;
#[rustfmt::skip]
pub mod generated;
pub mod runtime;

pub use equations::{equations, Equations, TraceError};
pub use expr::{record, Arg, Expr, Fun, Graph, Id, Node};
pub use runtime::{Eom, Generated, Terms};
