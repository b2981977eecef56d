//! The flat variable list of an FMU, derived from a [`System`] declaration.
//!
//! Order (and so value reference = position, ScalarVariable index = position + 1):
//! model parameters, solver parameters (`solver`, `solver_step`), states, state
//! derivatives, inputs, outputs, then the variables added since, in the order they were
//! added (`solver_max_steps`, `me_projection`). A new variable goes at the end, never in between: every
//! existing value reference stays what it was, since tools outside script them.

use super::{System, Var, VarType};
use crate::integrators::Method;

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
    /// The most internal steps one doStep may take (Integer `solver_max_steps`), read with
    /// fmi2Get/SetInteger.
    SolverMaxSteps,
    /// Whether Model Exchange projects a constrained system onto its constraints at step
    /// events (Integer `me_projection`, 1 or 0), read with fmi2Get/SetInteger; Co-Simulation
    /// ignores it (doStep always projects).
    MeProjection,
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

/// Default of the `solver_max_steps` parameter: most internal steps in one doStep, so that
/// a doStep no importer would wait for answers fmi2Discard within about a second. Measured
/// on the 2-core build machine (release) on the costliest case here, SliderCrankSurplus
/// `driven` with a 1.2–3.6 mm crank under DOPRI5 at rtol 1e-8 (19–21 µs an attempt: 7
/// evaluations of f and the projection): 10⁵ attempts take 1.9–2.1 s, 5·10⁴ take 0.94 s
/// (DOP853 and RADAU5 1.7–1.8 s); the integrators' own guard of 10⁶ took 19 s here and
/// 36 s in the report that asked for this parameter.
pub const DEFAULT_SOLVER_MAX_STEPS: i32 = 50_000;

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
        // The descriptions list every method, from Method::ALL (so they cannot fall behind).
        let mut solver = Var::new("solver", None, M::DEFAULT_METHOD.code() as f64, "");
        solver.description = format!(
            "Integration method inside doStep: {}. The adaptive ones ({}) take the tolerance of fmi2SetupExperiment (else of the DefaultExperiment); the others step by solver_step. A method the system cannot run is refused (see the Solver items)",
            Method::codes(),
            Method::names_where_adaptive(true)
        )
        .into();
        push(VarKind::SolverMethod, &[solver]);
        let mut solver_step =
            Var::new("solver_step", Some("s"), DEFAULT_SOLVER_STEP, "").min(1e-12);
        solver_step.description = format!(
            "Step of the fixed-step methods ({}); the adaptive ones ({}) choose their own",
            Method::names_where_adaptive(false),
            Method::names_where_adaptive(true)
        )
        .into();
        push(VarKind::SolverStep, &[solver_step]);
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
                ty: VarType::Real,
            })
            .collect();
        push(VarKind::Derivative, &derivs);
        push(VarKind::Input, &inputs);
        push(VarKind::Output, &outputs);
        // Added after the outputs (see the module doc): every older value reference stays.
        push(
            VarKind::SolverMaxSteps,
            &[Var::new(
                "solver_max_steps",
                None,
                DEFAULT_SOLVER_MAX_STEPS as f64,
                "Most internal steps in one doStep (adaptive methods: accepted + rejected attempts; fixed-step methods: planned steps, refused before any is taken); a doStep that needs more returns fmi2Discard. The default answers within about a second on these systems",
            )
            .min(1.0)
            .max(i32::MAX as f64)],
        );
        push(
            VarKind::MeProjection,
            &[Var::new(
                "me_projection",
                None,
                1.0,
                "Model Exchange only: 1 (default) keeps a constrained system on its constraints: fmi2CompletedIntegratorStep asks for event mode when the state has left them by more than 10 × the tolerance (of each state's magnitude or nominal), and fmi2NewDiscreteStates projects it back (valuesOfContinuousStatesChanged); 0 leaves the importer's states as integrated (the constraints drift). No effect on a system without constraints, nor in Co-Simulation, whose doStep always projects",
            )
            .min(0.0)
            .max(1.0)],
        );
        check_types(&vars);
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

    /// The value references FMI 3.0 adds after these (FMI 2.0's): `time`, then the event
    /// indicator of a model with `event_indicators` > 0.
    pub fn fmi3_extra_vrs(&self, event_indicators: usize) -> (u32, Option<u32>) {
        let time = self.vars.len() as u32;
        (time, (event_indicators > 0).then_some(time + 1))
    }
}

/// The declaration rules of the Integer and Enumeration parameters (a system that breaks
/// one is a programming error: it panics, naming the variable). Only a parameter may be
/// one; an Integer's start value passes its own check; an enumeration has no unit, min,
/// max or nominal, item names that are distinct and not empty, a start value that is one
/// of its codes, and a type name ([`Var::type_name`]) that no other type (`Solver`, another
/// enumeration's) and no variable has (FMI 2.0, section 2.2.3).
fn check_types(vars: &[(Slot, Var)]) {
    let mut type_names = vec!["Solver".to_string()];
    for (slot, var) in vars {
        let name = &var.name;
        if var.ty == VarType::Real {
            continue;
        }
        assert!(
            slot.kind == VarKind::Parameter,
            "{name}: only a parameter may be an Integer or an Enumeration"
        );
        if let Err(e) = var.check(var.start) {
            panic!("{name}: the start value is not legal: {e}");
        }
        let VarType::Enumeration(items) = var.ty else {
            continue;
        };
        assert!(
            var.unit.is_none() && var.min.is_none() && var.max.is_none() && var.nominal.is_none(),
            "{name}: an enumeration has no unit, min, max or nominal (its items are its range)"
        );
        for (i, (item, _)) in items.iter().enumerate() {
            assert!(
                !item.trim().is_empty() && !items[..i].iter().any(|(other, _)| other == item),
                "{name}: the item names must be distinct and not empty ({item:?})"
            );
        }
        let type_name = var.type_name().expect("an enumeration");
        assert!(
            !type_name.is_empty()
                && !type_names.contains(&type_name)
                && !vars.iter().any(|(_, v)| v.name == type_name),
            "{name}: its type name {type_name:?} is empty or taken by another type or a variable; rename the variable"
        );
        type_names.push(type_name);
    }
}

/// The unit of a time derivative: m → m/s, m/s → m/s2, rad → rad/s, rad/s → rad/s2.
pub fn derivative_unit(unit: Option<&str>) -> String {
    match unit {
        Some("m") => "m/s".into(),
        Some("m/s") => "m/s2".into(),
        Some("rad") => "rad/s".into(),
        Some("rad/s") => "rad/s2".into(),
        Some("J") => "W".into(),
        Some("1") | None => "1/s".into(),
        Some(other) => format!("{other}/s"),
    }
}
