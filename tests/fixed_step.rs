//! The fixed-step doStep (RK4, inputs held, no event: `Instance::fixed_step`, the state
//! on the stack and the right-hand side inlined into the stages) gives what the general
//! integrator gives, bit for bit: the states after each doStep against
//! `integrators::advance` with `Method::Rk4` on the model's own right-hand side followed
//! by its projection, and the outputs against `extra_outputs` there. Systems of every
//! size the fast path knows (2, 4, 7 states) and of one it does not (the nonlinear
//! bicycle, 16: the general path), hand-written and Lagrangian (generated equations,
//! projection onto constraints), with one internal step per doStep and with several (the
//! last one shortened), far from t = 0.

use mbfmu::fmi::{Instance, Logger, ModelInfo, StepOutcome};
use mbfmu::integrators::{self, Memory, Method, Settings, MAX_STEPS};
use mbfmu::model::System;
use mbfmu::systems::*;

/// `steps` doSteps of `h` from `start` with RK4 at `solver_step`, from the first scene.
fn same_as_general_path<M: System>(start: f64, h: f64, solver_step: f64, steps: usize) {
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<M>()));
    let vr = |name: &str| info.layout.vr_of(name).expect("variable");
    let vrs =
        |vars: Vec<mbfmu::model::Var>| -> Vec<u32> { vars.iter().map(|v| vr(&v.name)).collect() };
    let mut inst = Instance::<M>::new(info, Logger::silent("fixed_step"));
    inst.setup_experiment(None, start, None).unwrap();
    let scene = M::scenes().into_iter().next().expect("a scene");
    for (name, value) in &scene.start_values {
        inst.set_real(&[vr(name)], &[*value]).unwrap();
    }
    inst.set_real(&[vr("solver_step")], &[solver_step]).unwrap();
    inst.set_integer(&[vr("solver")], &[1]).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    let (x_vr, y_vr) = (vrs(M::states()), vrs(M::outputs()));
    let get = |inst: &Instance<M>, vrs: &[u32]| -> Vec<f64> {
        let mut v = vec![0.0; vrs.len()];
        inst.get_real(vrs, &mut v).unwrap();
        v
    };
    let (u, p) = (
        get(&inst, &vrs(M::inputs())),
        get(&inst, &vrs(M::parameters())),
    );
    let mut x = get(&inst, &x_vr);
    let settings = Settings {
        method: Method::Rk4,
        rtol: 0.0,
        atol: vec![],
        step: solver_step,
        max_steps: MAX_STEPS,
    };
    let mut memory = Memory::default();
    let mut y = vec![0.0; y_vr.len()];
    let mut current = start;
    for k in 0..steps {
        assert_eq!(inst.do_step(current, h).unwrap(), StepOutcome::Completed);
        let (mut t, t_end) = (current, current + h);
        let mut rhs = |t: f64, x: &[f64], dx: &mut [f64]| M::derivatives(t, x, &u, &p, dx);
        integrators::advance(&mut rhs, &mut t, &mut x, t_end, &settings, &mut memory).unwrap();
        M::project(t, &p, &mut x);
        M::extra_outputs(t, &x, &u, &p, &mut y);
        let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        let name = M::NAME;
        assert_eq!(
            bits(&get(&inst, &x_vr)),
            bits(&x),
            "{name}: states after doStep {k}"
        );
        assert_eq!(
            bits(&get(&inst, &y_vr)),
            bits(&y),
            "{name}: outputs after doStep {k}"
        );
        current = t_end;
    }
}

fn every_plan<M: System>() {
    same_as_general_path::<M>(0.0, 1e-3, 1e-3, 40);
    same_as_general_path::<M>(123.4, 1e-3, 1e-3, 40);
    // Eleven internal steps, the last one shortened to 0.5 ms.
    same_as_general_path::<M>(0.25, 0.0105, 1e-3, 8);
}

#[test]
fn hand_written_systems() {
    every_plan::<MassSpringDamper>();
    every_plan::<TwoMassChain>();
    every_plan::<RigidBody>(); // the quaternion renormalised after each doStep
}

#[test]
fn lagrangian_systems_on_generated_equations() {
    every_plan::<CompoundPendulum>();
    every_plan::<DoublePendulum>();
    every_plan::<SliderCrank>(); // projected onto its constraints
}

#[test]
fn a_state_larger_than_the_fast_path_knows() {
    assert!(NonlinearBicycle::states().len() > 8);
    same_as_general_path::<NonlinearBicycle>(0.0, 1e-3, 1e-3, 5);
}
