//! Mechanisms as bodies and joints: the data model and its builder ([`mechanism`]), URDF
//! reading ([`urdf`]), and rigid-body dynamics generic over the scalar ([`dynamics`], on
//! the hand-written spatial algebra of [`spatial`]); a declared mechanism as a model with
//! FMU variables ([`fmu`]), and as the Rust source of its builder ([`source`]).
//!
//! A low layer like [`crate::model`]: it knows nothing of FMI, packaging or the CLI.

pub mod closed;
pub mod codegen;
pub mod derivatives;
pub mod dynamics;
pub mod fmu;
pub mod friction;
/// The benchmark models' generated dynamics (1.2 MB of source): for `mbfmu speed --robots`
/// and the tests only, so a crate of one's own (no `cli` feature) does not compile them.
#[cfg(any(test, feature = "cli"))]
#[rustfmt::skip]
pub mod generated;
pub mod mechanism;
pub mod runtime;
pub mod source;
pub mod spatial;
pub mod stops;
pub mod urdf;

pub use dynamics::{Data, Model};
pub use mechanism::{Body, Closure, Error, Joint, JointKind, Limit, Mechanism, Origin, Spring};

#[cfg(test)]
pub(crate) mod floating_tests;
#[cfg(test)]
mod tests;
