//! The textbook systems, one file each: physics only, no FMI.

pub mod andrews_squeezer;
pub mod bricard;
mod compound_pendulum;
mod double_pendulum;
pub mod flyball_governor;
pub mod four_bar;
mod mass_spring_damper;
pub mod n_four_bar;
mod nonlinear_bicycle;
mod projectile;
mod pulled_pendulum;
mod rigid_body;
mod rolling_disk;
mod rolling_hoop;
mod rotating_hoop_bead;
pub mod slider_crank;
mod sphere_slide;
mod spring_rod_pendulum;
pub mod springy_pendulum;
mod two_mass_chain;
mod whipple_bicycle;

pub use andrews_squeezer::AndrewsSqueezer;
pub use bricard::Bricard;
pub use compound_pendulum::CompoundPendulum;
pub use double_pendulum::DoublePendulum;
pub use flyball_governor::FlyballGovernor;
pub use four_bar::FourBar;
pub use mass_spring_damper::MassSpringDamper;
pub use n_four_bar::NFourBar;
pub use nonlinear_bicycle::NonlinearBicycle;
pub use projectile::Projectile;
pub use pulled_pendulum::PulledPendulum;
pub use rigid_body::RigidBody;
pub use rolling_disk::RollingDisk;
pub use rolling_hoop::RollingHoop;
pub use rotating_hoop_bead::RotatingHoopBead;
pub use slider_crank::{SliderCrank, SliderCrankSurplus};
pub use sphere_slide::SphereSlide;
pub use spring_rod_pendulum::SpringRodPendulum;
pub use springy_pendulum::SpringyPendulum;
pub use two_mass_chain::TwoMassChain;
pub use whipple_bicycle::WhippleBicycle;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{System, Var};

    /// A value no computation produces: a NaN with a payload of its own.
    const UNWRITTEN: u64 = 0x7ff8_dead_beef_0001;

    /// `derivatives` and `extra_outputs` write every component (the contract the
    /// integrators' kept buffers rely on), at the start of every scene.
    fn writes_every_component<M: System>() {
        let starts = |vars: Vec<Var>, scene: &crate::model::Scene| -> Vec<f64> {
            vars.iter()
                .map(|v| {
                    let set = scene.start_values.iter().find(|(name, _)| *name == v.name);
                    set.map_or(v.start, |(_, value)| *value)
                })
                .collect()
        };
        for scene in M::scenes() {
            let (x, u, p) = (
                starts(M::states(), &scene),
                starts(M::inputs(), &scene),
                starts(M::parameters(), &scene),
            );
            let mut dx = vec![f64::from_bits(UNWRITTEN); x.len()];
            M::derivatives(0.0, &x, &u, &p, &mut dx);
            let mut y = vec![f64::from_bits(UNWRITTEN); M::outputs().len()];
            M::extra_outputs(0.0, &x, &u, &p, &mut y);
            for (what, v) in [("derivative", &dx), ("output", &y)] {
                let unwritten = v.iter().position(|v| v.to_bits() == UNWRITTEN);
                assert_eq!(unwritten, None, "{} {}: {what}", M::NAME, scene.name);
            }
        }
    }

    #[test]
    fn every_system_writes_every_derivative_and_output() {
        writes_every_component::<MassSpringDamper>();
        writes_every_component::<TwoMassChain>();
        writes_every_component::<WhippleBicycle>();
        writes_every_component::<RigidBody>();
        writes_every_component::<RollingHoop>();
        writes_every_component::<RollingDisk>();
        writes_every_component::<Projectile>();
        writes_every_component::<SpringyPendulum>();
        writes_every_component::<DoublePendulum>();
        writes_every_component::<CompoundPendulum>();
        writes_every_component::<SphereSlide>();
        writes_every_component::<SpringRodPendulum>();
        writes_every_component::<SliderCrank>();
        writes_every_component::<SliderCrankSurplus>();
        writes_every_component::<NonlinearBicycle>();
        writes_every_component::<RotatingHoopBead>();
        writes_every_component::<PulledPendulum>();
        writes_every_component::<FourBar>();
        writes_every_component::<AndrewsSqueezer>();
        writes_every_component::<NFourBar>();
        writes_every_component::<Bricard>();
        writes_every_component::<FlyballGovernor>();
    }
}
