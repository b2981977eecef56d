//! The textbook systems, one file each: physics only, no FMI.

mod mass_spring_damper;
mod two_mass_chain;

pub use mass_spring_damper::MassSpringDamper;
pub use two_mass_chain::TwoMassChain;

use crate::model::{Scene, System};

/// What the CLI needs of one system, without knowing its type.
pub struct Entry {
    pub name: &'static str,
    pub description: &'static str,
    /// The cdylib crate under `fmu/` that exports this system.
    pub crate_name: &'static str,
    pub model_description: fn() -> String,
    pub documentation: fn() -> String,
    pub scenes: fn() -> Vec<Scene>,
}

fn entry<M: System>(crate_name: &'static str) -> Entry {
    Entry {
        name: M::NAME,
        description: M::DESCRIPTION,
        crate_name,
        model_description: crate::xml::model_description::<M>,
        documentation: crate::package::index_html::<M>,
        scenes: M::scenes,
    }
}

/// Every system with an FMU, in the order `mbfmu list` shows them.
pub fn all() -> Vec<Entry> {
    vec![
        entry::<MassSpringDamper>("mass_spring_damper"),
        entry::<TwoMassChain>("two_mass_chain"),
    ]
}
