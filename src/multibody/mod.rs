//! Mechanisms as bodies and joints: the data model and its builder ([`mechanism`]), URDF
//! reading ([`urdf`]), and rigid-body dynamics generic over the scalar ([`dynamics`], on
//! the hand-written spatial algebra of [`spatial`]).
//!
//! A low layer like [`crate::model`]: it knows nothing of FMI, packaging or the CLI.

pub mod codegen;
pub mod derivatives;
pub mod dynamics;
#[rustfmt::skip]
pub mod generated;
pub mod mechanism;
pub mod spatial;
pub mod urdf;

pub use dynamics::Model;
pub use mechanism::{Body, Error, Joint, JointKind, Limit, Mechanism, Origin};

#[cfg(test)]
mod tests;
