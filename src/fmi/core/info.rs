//! What the core knows of its model (computed once per process) and how a call ended: the
//! two things every layer of the FMI wing speaks of.

use crate::model::{Layout, System};

/// How a call ended: fmi2Status, and fmi3Status (the same values but Pending, which
/// FMI 3.0 does not have and these FMUs never return).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
    Pending = 5,
}

/// What the FMU knows of its model, computed once per process.
#[derive(Debug)]
pub struct ModelInfo {
    pub name: &'static str,
    pub layout: Layout,
    pub guid: String,
    /// DefaultExperiment tolerance: used when fmi2SetupExperiment defines none.
    pub default_tolerance: f64,
    /// What Model Exchange declares: event indicators, projection, `reinit` states.
    pub probe: crate::model::Probe,
}

impl ModelInfo {
    pub fn of<M: System>() -> ModelInfo {
        let layout = Layout::of::<M>();
        ModelInfo {
            name: M::name(),
            probe: crate::model::Probe::of::<M>(&layout),
            layout,
            guid: crate::xml::guid::<M>(),
            default_tolerance: M::default_experiment().1,
        }
    }
}
