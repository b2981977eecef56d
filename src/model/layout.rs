//! The flat variable list of an FMU, derived from a [`System`] declaration.
//!
//! Order (and so value reference = position, ScalarVariable index = position + 1):
//! model parameters, solver parameters, states, state derivatives, inputs, outputs.

use super::{System, Var};

/// What a variable is for the FMI layer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarKind {
    Parameter,
    State,
    Derivative,
    Input,
    Output,
    /// The integration method (Enumeration `Solver`), read with fmi2Get/SetInteger.
    SolverMethod,
    /// The fixed step of fixed-step methods (adaptive ones choose their own).
    SolverStep,
}

/// Where a variable's value lives: its kind and its index inside that kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slot {
    pub kind: VarKind,
    pub index: usize,
}

/// The derived variable list of one system.
#[derive(Clone, Debug)]
pub struct Layout {
    pub vars: Vec<(Slot, Var)>,
    pub n_params: usize,
    pub n_states: usize,
    pub n_inputs: usize,
    pub n_outputs: usize,
}

/// Default of the `solver_step` parameter (s).
pub const DEFAULT_SOLVER_STEP: f64 = 1e-3;

impl Layout {
    pub fn of<M: System>() -> Layout {
        let params = M::parameters();
        let states = M::states();
        let inputs = M::inputs();
        let outputs = M::outputs();
        let mut vars = Vec::new();
        let mut push = |kind, list: &[Var]| {
            for (index, v) in list.iter().enumerate() {
                vars.push((Slot { kind, index }, v.clone()));
            }
        };
        push(VarKind::Parameter, &params);
        push(
            VarKind::SolverMethod,
            &[Var::new(
                "solver",
                None,
                2.0,
                "Integration method inside doStep: 1 = RK4 (fixed step solver_step), 2 = DOPRI5 (adaptive, tolerance from fmi2SetupExperiment or the DefaultExperiment)",
            )],
        );
        push(
            VarKind::SolverStep,
            &[Var::new(
                "solver_step",
                Some("s"),
                DEFAULT_SOLVER_STEP,
                "Step of fixed-step methods (RK4); adaptive methods choose their own",
            )
            .min(1e-12)],
        );
        push(VarKind::State, &states);
        let derivs: Vec<Var> = states
            .iter()
            .map(|s| Var {
                name: format!("der({})", s.name).into(),
                description: format!("Time derivative of {}", s.name).into(),
                unit: Some(derivative_unit(s.unit.as_deref()).into()),
                start: 0.0,
                min: None,
                max: None,
                nominal: None,
                dependent: false,
            })
            .collect();
        push(VarKind::Derivative, &derivs);
        push(VarKind::Input, &inputs);
        push(VarKind::Output, &outputs);
        Layout {
            vars,
            n_params: params.len(),
            n_states: states.len(),
            n_inputs: inputs.len(),
            n_outputs: outputs.len(),
        }
    }

    /// Value reference of the variable with this name.
    pub fn vr_of(&self, name: &str) -> Option<u32> {
        self.vars
            .iter()
            .position(|(_, v)| v.name == name)
            .map(|i| i as u32)
    }

    /// Value reference (= position) of a slot.
    pub fn vr_of_slot(&self, kind: VarKind, index: usize) -> u32 {
        self.vars
            .iter()
            .position(|(s, _)| s.kind == kind && s.index == index)
            .expect("slot exists") as u32
    }

    pub fn slot(&self, vr: u32) -> Option<Slot> {
        self.vars.get(vr as usize).map(|(s, _)| *s)
    }
}

/// The unit of a time derivative: m → m/s, m/s → m/s2, rad → rad/s, rad/s → rad/s2.
pub fn derivative_unit(unit: Option<&str>) -> String {
    match unit {
        Some("m") => "m/s".into(),
        Some("m/s") => "m/s2".into(),
        Some("rad") => "rad/s".into(),
        Some("rad/s") => "rad/s2".into(),
        Some("1") | None => "1/s".into(),
        Some(other) => format!("{other}/s"),
    }
}
