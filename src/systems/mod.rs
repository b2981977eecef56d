//! The textbook systems, one file each: physics only, no FMI.

mod compound_pendulum;
mod double_pendulum;
mod mass_spring_damper;
mod projectile;
mod rigid_body;
mod rolling_disk;
mod rolling_hoop;
pub mod slider_crank;
mod sphere_slide;
mod spring_rod_pendulum;
pub mod springy_pendulum;
mod two_mass_chain;
mod whipple_bicycle;

pub use compound_pendulum::CompoundPendulum;
pub use double_pendulum::DoublePendulum;
pub use mass_spring_damper::MassSpringDamper;
pub use projectile::Projectile;
pub use rigid_body::RigidBody;
pub use rolling_disk::RollingDisk;
pub use rolling_hoop::RollingHoop;
pub use slider_crank::{SliderCrank, SliderCrankSurplus};
pub use sphere_slide::SphereSlide;
pub use spring_rod_pendulum::SpringRodPendulum;
pub use springy_pendulum::SpringyPendulum;
pub use two_mass_chain::TwoMassChain;
pub use whipple_bicycle::WhippleBicycle;
