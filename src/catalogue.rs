//! The catalogue: every system with an FMU, and what the CLI does with each (XML,
//! linearisation, bench, speed) without knowing its type. It sits above the
//! layers it ties together, beside the CLI: `systems` is physics only and knows none
//! of them.

use crate::bench::speed::{self, SpeedRow};
use crate::bench::{BenchConfig, BenchRow};
use crate::model::{Scene, System};
use crate::systems::*;

/// What the CLI needs of one system, without knowing its type.
pub struct Entry {
    pub name: &'static str,
    pub description: &'static str,
    /// The cdylib crate under `fmu/` that exports this system.
    pub crate_name: &'static str,
    pub model_description: fn() -> String,
    pub scenes: fn() -> Vec<Scene>,
    /// What this system's cdylib answers through `mbfmu_describe`, in process
    /// ([`crate::describe::respond`]): `mbfmu linearize` asks it as it asks a user's crate.
    pub describe: fn(&str) -> String,
    /// Work–precision runs of every scene and method (`mbfmu bench`).
    pub bench: fn(&BenchConfig) -> Vec<BenchRow>,
    /// Cost of one doStep, RHS and Jacobian, best of this many repetitions (`mbfmu speed`).
    pub speed: fn(usize) -> SpeedRow,
}

fn entry<M: System>(crate_name: &'static str) -> Entry {
    Entry {
        name: M::NAME,
        description: M::DESCRIPTION,
        crate_name,
        model_description: crate::xml::model_description::<M>,
        scenes: M::scenes,
        describe: crate::describe::respond::<M>,
        bench: crate::bench::bench_system::<M>,
        speed: |reps| speed::measure::<M>(reps, speed::floor_of(M::NAME)),
    }
}

/// Every system with an FMU, in the order `mbfmu list` shows them.
pub fn all() -> Vec<Entry> {
    vec![
        entry::<MassSpringDamper>("mass_spring_damper"),
        entry::<TwoMassChain>("two_mass_chain"),
        entry::<WhippleBicycle>("whipple_bicycle"),
        entry::<RigidBody>("rigid_body"),
        entry::<RollingHoop>("rolling_hoop"),
        entry::<RollingDisk>("rolling_disk"),
        entry::<Projectile>("projectile"),
        entry::<SpringyPendulum>("springy_pendulum"),
        entry::<DoublePendulum>("double_pendulum"),
        entry::<CompoundPendulum>("compound_pendulum"),
        entry::<SphereSlide>("sphere_slide"),
        entry::<SpringRodPendulum>("spring_rod_pendulum"),
        entry::<SliderCrank>("slider_crank"),
        entry::<SliderCrankSurplus>("slider_crank_surplus"),
        entry::<NonlinearBicycle>("nonlinear_bicycle"),
        entry::<RotatingHoopBead>("rotating_hoop_bead"),
        entry::<PulledPendulum>("pulled_pendulum"),
        entry::<FourBar>("four_bar"),
        entry::<AndrewsSqueezer>("andrews_squeezer"),
        entry::<NFourBar>("n_four_bar"),
        entry::<Bricard>("bricard"),
        entry::<FlyballGovernor>("flyball_governor"),
    ]
}
