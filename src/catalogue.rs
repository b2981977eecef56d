//! The catalogue: every system with an FMU, and what the CLI does with each (XML,
//! documentation, linearisation, bench) without knowing its type. It sits above the
//! layers it ties together, beside the CLI: `systems` is physics only and knows none
//! of them.

use crate::bench::speed::{self, SpeedRow};
use crate::bench::{BenchConfig, BenchRow};
use crate::linearize::{self, Linearization, OperatingPoint, States, Trim};
use crate::model::{Scene, System};
use crate::systems::*;

/// Linearise at the start values with these `name = value` overrides, after an optional
/// trim, in these states.
pub type LinearizeFn = fn(&[(String, f64)], Option<Trim>, &States) -> Result<Linearization, String>;

/// What the CLI needs of one system, without knowing its type.
pub struct Entry {
    pub name: &'static str,
    pub description: &'static str,
    /// The cdylib crate under `fmu/` that exports this system.
    pub crate_name: &'static str,
    pub model_description: fn() -> String,
    pub documentation: fn() -> String,
    pub scenes: fn() -> Vec<Scene>,
    pub linearize: LinearizeFn,
    /// Work–precision runs of every scene and method (`mbfmu bench`).
    pub bench: fn(&BenchConfig) -> Vec<BenchRow>,
    /// Cost of one doStep, RHS and Jacobian, best of this many repetitions (`mbfmu speed`).
    pub speed: fn(usize) -> SpeedRow,
}

fn linearize_at<M: System>(
    overrides: &[(String, f64)],
    trim: Option<Trim>,
    states: &States,
) -> Result<Linearization, String> {
    let (mut op, warnings) = OperatingPoint::consistent::<M>(overrides)?;
    if let Some(what) = trim {
        linearize::trim::<M>(&mut op, what)?;
    }
    let mut lin = linearize::linearize::<M>(&op);
    lin = match states {
        States::All => lin,
        States::Independent => linearize::reduced::<M>(&lin, None)?,
        States::Only(keep) => linearize::reduced::<M>(&lin, Some(keep))?,
    };
    lin.warnings = warnings;
    let finite = |m: &nalgebra::DMatrix<f64>| m.iter().all(|v| v.is_finite());
    let all_finite = finite(&lin.a)
        && finite(&lin.b)
        && finite(&lin.c)
        && finite(&lin.d)
        && lin.y0.iter().all(|v| v.is_finite());
    if !all_finite {
        return Err(format!(
            "{}: the linearisation at this point is not finite (a derivative is singular there)",
            M::NAME
        ));
    }
    Ok(lin)
}

fn entry<M: System>(crate_name: &'static str) -> Entry {
    Entry {
        name: M::NAME,
        description: M::DESCRIPTION,
        crate_name,
        model_description: crate::xml::model_description::<M>,
        documentation: crate::package::index_html::<M>,
        scenes: M::scenes,
        linearize: linearize_at::<M>,
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
    ]
}
