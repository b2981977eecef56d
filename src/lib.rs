//! mbfmu: multibody mechanics models exported as FMUs: FMI 2.0 and FMI 3.0, Co-Simulation
//! and Model Exchange, all four from one binary.
//!
//! - [`model`]: how a system is declared (variables, dynamics, scenes): physics only.
//! - [`systems`]: the textbook systems, one file each.
//! - [`integrators`]: the methods that advance a system inside a Co-Simulation doStep.
//! - [`fmi`]: the FMI boundary, FMI 2.0 and 3.0, Co-Simulation and Model Exchange (the only
//!   `unsafe` and `extern "C"` but the packager's dlopen in `package::library`).
//! - [`xml`]: modelDescription.xml (FMI 2.0 and 3.0) and its ModelStructure, generated from
//!   a system.
//! - [`package`]: the FMU archive and its documentation page.
//! - [`linearize`]: A, B, C, D at an operating point, exact, and their export formats.
//! - [`bench`]: the work–precision sweeps of `mbfmu bench`.
//! - [`docs`]: what an FMU carries to explain and check itself (reference result, page data).
//! - [`describe`]: what a compiled model answers the packager (its FMU contents, its
//!   linearisation), behind its cdylib's `mbfmu_describe`.
//! - [`own_model`]: a user's model in its own crate: `mbfmu new`, and building that crate.
//! - [`catalogue`]: every system with an FMU, and what the CLI does with each.

// What an FMU's binary runs, on every platform.
pub mod fmi;
pub mod integrators;
pub mod model;
pub mod multibody;
pub mod systems;
pub mod xml;

// What the host's build adds for the packager (feature `describe`): a binary cross-built
// for another platform carries FMI alone.
#[cfg(feature = "describe")]
pub mod describe;
#[cfg(feature = "describe")]
pub mod docs;
#[cfg(feature = "describe")]
pub mod linearize;
#[cfg(feature = "describe")]
pub mod package;

// What only the `mbfmu` command needs (feature `cli`).
#[cfg(feature = "cli")]
pub mod bench;
#[cfg(feature = "cli")]
pub mod catalogue;
#[cfg(feature = "cli")]
pub mod own_model;
