//! Prints the f64 bits every method gives through the FMU's doStep, so a refactoring of the
//! integrators can be checked to change no bit (issue 30): run before and after, compare.
//!
//!     cargo run --release --example bitcheck > before.txt
//!
//! One line per (system, method, run): a hash of the states' bits after every doStep,
//! the time and the counters at the end. The runs: dense output (the adaptive methods run
//! ahead) at two tolerances; landing (input derivatives set, where the system has inputs);
//! fmi2DoStep through a serialized and restored FMU state halfway; small solver steps.

use mbfmu::fmi::{Instance, Logger, ModelInfo, StepOutcome};
use mbfmu::integrators::Method;
use mbfmu::model::System;
use mbfmu::model::VarKind;
use mbfmu::systems::*;

/// FNV-1a over 64-bit words.
struct Hash(u64);

impl Hash {
    fn add(&mut self, v: u64) {
        for b in v.to_le_bytes() {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x100_0000_01b3);
        }
    }
}

fn vrs_of(info: &ModelInfo, kind: VarKind) -> Vec<u32> {
    let vars = &info.layout.vars;
    (0..vars.len() as u32)
        .filter(|&vr| vars[vr as usize].0.kind == kind)
        .collect()
}

fn started<M: System>(info: &'static ModelInfo, method: Method, tol: f64) -> Option<Instance<M>> {
    let mut inst = Instance::<M>::new(info, Logger::silent("bitcheck"));
    inst.setup_experiment(Some(tol), 0.0, None).unwrap();
    let scene = M::scenes().into_iter().next().expect("a scene");
    for (name, value) in &scene.start_values {
        let vr = info.layout.vr_of(name).expect("variable");
        inst.set_real(&[vr], &[*value]).unwrap();
    }
    let vr = |name: &str| info.layout.vr_of(name).expect("variable");
    inst.set_real(&[vr("solver_step")], &[2.5e-3]).unwrap();
    inst.set_integer(&[vr("solver")], &[method.code()]).ok()?;
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().ok()?;
    Some(inst)
}

#[derive(Clone, Copy, PartialEq)]
enum Run {
    Dense,
    Loose,
    Landing,
    Restored,
}

fn run<M: System>(name: &str) {
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<M>()));
    let states = vrs_of(info, VarKind::State);
    let inputs = vrs_of(info, VarKind::Input);
    for method in Method::ALL {
        for what in [Run::Dense, Run::Loose, Run::Landing, Run::Restored] {
            if what == Run::Landing && inputs.is_empty() {
                continue;
            }
            let tol = if what == Run::Loose { 1e-4 } else { 1e-8 };
            let Some(mut inst) = started::<M>(info, method, tol) else {
                continue;
            };
            let mut hash = Hash(0xcbf2_9ce4_8422_2325);
            let (h, n) = (1e-2, 60);
            let mut outcome = String::from("ok");
            for i in 0..n {
                let t = i as f64 * h;
                if what == Run::Landing {
                    let orders = vec![1; inputs.len()];
                    let values = vec![0.5 * (i % 3) as f64; inputs.len()];
                    inst.set_input_derivatives(&inputs, &orders, &values)
                        .unwrap();
                }
                if what == Run::Restored && i == n / 2 {
                    let blob = inst.serialize(&inst.snapshot());
                    let mut other = started::<M>(info, method, tol).unwrap();
                    let s = other.deserialize(&blob).unwrap();
                    other.restore(&s).unwrap();
                    inst = other;
                }
                match inst.do_step(t, h) {
                    Ok(StepOutcome::Completed) => {}
                    other => {
                        outcome = format!("stopped at step {i}: {other:?}");
                        break;
                    }
                }
                let mut x = vec![0.0; states.len()];
                inst.get_real(&states, &mut x).unwrap();
                for v in x {
                    hash.add(v.to_bits());
                }
            }
            let s = inst.stats();
            let mode = match what {
                Run::Dense => "dense",
                Run::Loose => "loose",
                Run::Landing => "landing",
                Run::Restored => "restored",
            };
            println!(
                "{name} {} {mode}: {:016x} t={:016x} rhs={} steps={} rejected={} jac={} {outcome}",
                method.name(),
                hash.0,
                inst.time().to_bits(),
                s.rhs_evals,
                s.steps,
                s.rejected,
                s.jacobians
            );
        }
    }
}

fn main() {
    run::<MassSpringDamper>("MassSpringDamper");
    run::<TwoMassChain>("TwoMassChain");
    run::<RigidBody>("RigidBody");
    run::<CompoundPendulum>("CompoundPendulum");
    run::<DoublePendulum>("DoublePendulum");
    run::<PulledPendulum>("PulledPendulum");
    run::<SphereSlide>("SphereSlide");
    run::<SliderCrankSurplus>("SliderCrankSurplus");
    run::<SpringyPendulum>("SpringyPendulum");
    run::<AndrewsSqueezer>("AndrewsSqueezer");
}
