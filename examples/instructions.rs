//! Instruction counts (a count that does not drift with the machine's load, unlike the
//! times of `mbfmu speed`) of one doStep (RK4, 1 ms), one RHS and one Jacobian of the
//! Lagrangian systems, on their generated code and on automatic differentiation
//! (`AutoDiff<L>`), of the hand-written systems' FMU path (`fmu`), and of the hand-written
//! floors where the bench has one. Runs the operation COUNT times after setting up; run it under
//! `valgrind --tool=callgrind` with COUNT and with 0 and divide the difference by COUNT:
//!
//!     cargo build --release --example instructions
//!     valgrind --tool=callgrind --callgrind-out-file=/dev/null \
//!         target/release/examples/instructions DoublePendulum generated rhs 1000
//!
//! (`scripts/instructions` does that for every system and writes docs/bench/instructions.csv.)

use mbfmu::bench::floors::{self, rk4_step, Floor};
use mbfmu::fmi::{Instance, Logger, ModelInfo};
use mbfmu::model::jacobian::Duals;
use mbfmu::model::lagrangian::{AutoDiff, Lagrangian};
use mbfmu::model::System;
use mbfmu::systems::*;
use std::hint::black_box;

/// `what` (dostep, rhs or jacobian) `count` times on `M`, from its first scene.
fn run<M: System>(what: &str, count: usize) {
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<M>()));
    let vr = |name: &str| info.layout.vr_of(name).expect("variable");
    let mut inst = Instance::<M>::new(info, Logger::silent("instructions"));
    inst.setup_experiment(Some(1e-8), 0.0, None).unwrap();
    let scene = M::scenes().into_iter().next().expect("a scene");
    for (name, value) in &scene.start_values {
        inst.set_real(&[vr(name)], &[*value]).unwrap();
    }
    inst.set_real(&[vr("solver_step")], &[1e-3]).unwrap();
    inst.set_integer(&[vr("solver")], &[1]).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    let get = |names: Vec<mbfmu::model::Var>| -> Vec<f64> {
        let vrs: Vec<u32> = names.iter().map(|v| vr(&v.name)).collect();
        let mut v = vec![0.0; vrs.len()];
        inst.get_real(&vrs, &mut v).unwrap();
        v
    };
    let (x, u, p) = (get(M::states()), get(M::inputs()), get(M::parameters()));
    let n = x.len();
    // One of each first, so buffers are sized outside the counted part.
    let (mut dx, mut jac, mut duals) = (vec![0.0; n], vec![0.0; n * n], Duals::default());
    duals.jacobian::<M>(0.0, &x, &u, &p, &mut jac);
    let mut t = 0.0;
    match what {
        "dostep" => {
            for _ in 0..count {
                inst.do_step(black_box(t), 1e-3).unwrap();
                t += 1e-3;
            }
        }
        "rhs" => {
            for _ in 0..count {
                M::derivatives(0.0, black_box(&x), &u, &p, &mut dx);
                black_box(&dx);
            }
        }
        "jacobian" => {
            for _ in 0..count {
                duals.jacobian::<M>(0.0, black_box(&x), &u, &p, &mut jac);
                black_box(&jac);
            }
        }
        other => panic!("what: dostep, rhs or jacobian, not {other}"),
    }
}

/// The hand-written floor (`bench::floors`): an RK4 step with the energy, or one RHS, at a
/// generic state (the cost of the formulas does not depend on it).
fn floor<F: Floor<N>, const N: usize>(p: &[f64], what: &str, count: usize) {
    let mut x: [f64; N] = std::array::from_fn(|i| 0.3 + 0.1 * i as f64);
    for _ in 0..count {
        match what {
            "dostep" => {
                black_box(rk4_step::<F, N>(black_box(&mut x), p, 1e-3));
            }
            "rhs" => {
                black_box(F::rhs(black_box(&x), p));
            }
            other => panic!("the floors have dostep and rhs, not {other}"),
        }
    }
}

fn on<L: Lagrangian>(path: &str, what: &str, count: usize) {
    let p: Vec<f64> = L::parameters().iter().map(|v| v.start).collect();
    match (path, L::NAME) {
        ("generated", _) => run::<L>(what, count),
        ("ad", _) => run::<AutoDiff<L>>(what, count),
        ("floor", "CompoundPendulum") => floor::<floors::CompoundPendulum, 2>(&p, what, count),
        ("floor", "DoublePendulum") => floor::<floors::DoublePendulum, 4>(&p, what, count),
        (other, name) => {
            panic!("path: generated, ad (or floor, where there is one), not {other} for {name}")
        }
    }
}

/// A hand-written system: the FMU's path (`fmu`) or the floor.
fn hand<M: System, F: Floor<N>, const N: usize>(path: &str, what: &str, count: usize) {
    let p: Vec<f64> = M::parameters().iter().map(|v| v.start).collect();
    match path {
        "fmu" => run::<M>(what, count),
        "floor" => floor::<F, N>(&p, what, count),
        other => panic!("path of a hand-written system: fmu or floor, not {other}"),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [system, path, what, count] = &args[..] else {
        panic!("usage: instructions SYSTEM generated|ad|floor|fmu dostep|rhs|jacobian COUNT");
    };
    let count: usize = count.parse().expect("COUNT");
    match system.as_str() {
        "CompoundPendulum" => on::<CompoundPendulum>(path, what, count),
        "DoublePendulum" => on::<DoublePendulum>(path, what, count),
        "SliderCrank" => on::<SliderCrank>(path, what, count),
        "SliderCrankSurplus" => on::<SliderCrankSurplus>(path, what, count),
        "SpringRodPendulum" => on::<SpringRodPendulum>(path, what, count),
        "NonlinearBicycle" => on::<NonlinearBicycle>(path, what, count),
        "MassSpringDamper" => {
            hand::<MassSpringDamper, floors::MassSpringDamper, 2>(path, what, count)
        }
        "TwoMassChain" => hand::<TwoMassChain, floors::TwoMassChain, 4>(path, what, count),
        "RigidBody" => hand::<RigidBody, floors::RigidBody, 7>(path, what, count),
        other => panic!("not a system of this count: {other}"),
    }
}
