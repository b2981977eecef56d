//! The harness of the dense-output tests (tests/dense_*.rs): a system's scene driven through the instance API.
#![allow(dead_code)] // each test crate uses its own part

use mbfmu::fmi::{Instance, Logger, ModelInfo, StepOutcome};
use mbfmu::integrators::Stats;
use mbfmu::model::System;

pub const DOP853: i32 = 9;
pub const RADAU5: i32 = 10;
pub const EXACT_LINEAR: i32 = 11;

fn info<S: System>() -> &'static ModelInfo {
    Box::leak(Box::new(ModelInfo::of::<S>()))
}

/// A system under test: its model info, the scene and the names of its states.
pub struct Case<S: System> {
    pub info: &'static ModelInfo,
    pub scene: &'static str,
    pub states: &'static [&'static str],
    /// The experiment's tolerance.
    pub tol: f64,
    _s: std::marker::PhantomData<S>,
}

impl<S: System> Case<S> {
    pub fn new(scene: &'static str, states: &'static [&'static str], tol: f64) -> Self {
        Case {
            info: info::<S>(),
            scene,
            states,
            tol,
            _s: std::marker::PhantomData,
        }
    }

    pub fn vr(&self, name: &str) -> u32 {
        self.info.layout.vr_of(name).unwrap()
    }

    pub fn stop_time(&self) -> f64 {
        self.scene().stop_time
    }

    pub fn scene(&self) -> mbfmu::model::Scene {
        S::scenes()
            .into_iter()
            .find(|s| s.name == self.scene)
            .unwrap()
    }

    /// An instance in step mode at `start` with the scene's start values, `solver`, and
    /// `extra` values set in initialization mode (ExactLinear steps by the communication
    /// step `comm`).
    pub fn started(
        &self,
        solver: i32,
        comm: f64,
        start: f64,
        extra: &[(&str, f64)],
    ) -> Instance<S> {
        let scene = self.scene();
        let mut inst = Instance::<S>::new(self.info, Logger::silent("dense_radau5"));
        inst.setup_experiment(Some(self.tol), start, Some(scene.stop_time))
            .unwrap();
        for (name, value) in scene.start_values.iter().chain(extra) {
            inst.set_real(&[self.vr(name)], &[*value]).unwrap();
        }
        if solver == EXACT_LINEAR {
            inst.set_real(&[self.vr("solver_step")], &[comm]).unwrap();
        }
        inst.set_integer(&[self.vr("solver")], &[solver]).unwrap();
        inst.enter_initialization_mode().unwrap();
        inst.exit_initialization_mode().unwrap();
        inst
    }

    /// max_t |x_i(t)| of the exact trajectory on a 1e-2 s grid (the bench's error scale).
    pub fn scale(&self) -> Vec<f64> {
        let (grid, _) = self.run(EXACT_LINEAR, 1e-2);
        (0..self.states.len())
            .map(|i| grid.iter().fold(0.0f64, |m, x| m.max(x[i].abs())))
            .collect()
    }

    pub fn state(&self, inst: &Instance<S>) -> Vec<f64> {
        let vrs: Vec<u32> = self.states.iter().map(|n| self.vr(n)).collect();
        let mut x = vec![0.0; vrs.len()];
        inst.get_real(&vrs, &mut x).unwrap();
        x
    }

    /// doSteps of `comm` over the scene: the states at every communication point, and the
    /// stats.
    pub fn run(&self, solver: i32, comm: f64) -> (Vec<Vec<f64>>, Stats) {
        let mut inst = self.started(solver, comm, 0.0, &[]);
        let n = (self.stop_time() / comm).round() as usize;
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let t = i as f64 * comm;
            let h = if i + 1 == n {
                self.stop_time() - t
            } else {
                comm
            };
            assert_eq!(inst.do_step(t, h).unwrap(), StepOutcome::Completed);
            out.push(self.state(&inst));
        }
        (out, inst.stats())
    }
}

/// After an input switch: `solver` started afresh at `t0` from the states `x0` with the
/// input `(name, value)`, then `n` doSteps of `comm`; the states after each.
pub fn fresh_from<S: System>(
    case: &Case<S>,
    solver: i32,
    (t0, x0): (f64, &[f64]),
    input: (&str, f64),
    comm: f64,
    n: usize,
) -> Vec<Vec<f64>> {
    let start: Vec<(&str, f64)> = case
        .states
        .iter()
        .copied()
        .zip(x0.iter().copied())
        .chain([input])
        .collect();
    let mut inst = case.started(solver, comm, t0, &start);
    (0..n)
        .map(|i| {
            let t = t0 + i as f64 * comm;
            assert_eq!(inst.do_step(t, comm).unwrap(), StepOutcome::Completed);
            case.state(&inst)
        })
        .collect()
}

/// The largest error over a grid, component i scaled by `scale[i]`.
pub fn worst_error(got: &[Vec<f64>], reference: &[Vec<f64>], scale: &[f64]) -> f64 {
    let dim = scale.len();
    got.iter().zip(reference).fold(0.0f64, |m, (x, r)| {
        (0..dim).fold(m, |m, i| m.max((x[i] - r[i]).abs() / scale[i]))
    })
}

pub fn bits(v: &[Vec<f64>]) -> Vec<u64> {
    v.iter().flatten().map(|x| x.to_bits()).collect()
}

/// doSteps of `comm` from `from` to `to` (indices), the states after each.
pub fn steps<S: System>(
    case: &Case<S>,
    inst: &mut Instance<S>,
    comm: f64,
    from: usize,
    to: usize,
) -> Vec<Vec<f64>> {
    (from..to)
        .map(|i| {
            assert_eq!(
                inst.do_step(i as f64 * comm, comm).unwrap(),
                StepOutcome::Completed
            );
            case.state(inst)
        })
        .collect()
}

/// Stats and worst errors for communication steps stop time, 1e-2, 1e-3, 1e-4.
pub fn sweep<S: System>(case: &Case<S>, solver: i32) -> Vec<(f64, Stats, f64)> {
    let scale = case.scale();
    [case.stop_time(), 1e-2, 1e-3, 1e-4]
        .into_iter()
        .map(|comm| {
            let (x, stats) = case.run(solver, comm);
            let (reference, _) = case.run(EXACT_LINEAR, comm);
            let err = worst_error(&x, &reference, &scale);
            println!(
                "METRIC solver {solver} {} comm {comm:e}: {} RHS, {} steps, worst error {err:.2e}",
                case.scene, stats.rhs_evals, stats.steps
            );
            (comm, stats, err)
        })
        .collect()
}

/// The steps taken do not depend on the grid, and the RHS count of a grid exceeds the
/// coarsest's by at most `extension` evaluations per step: the stages of a continuous
/// extension built only for steps a point falls inside (DOP853: 3; 0 for methods whose
/// extension is free, so the counts are equal).
fn same_work(fine: &Stats, coarse: &Stats, extension: u64, what: &str) {
    assert_eq!(
        (fine.steps, fine.rejected),
        (coarse.steps, coarse.rejected),
        "{what}"
    );
    let most = coarse.rhs_evals + extension * coarse.steps;
    assert!(
        (coarse.rhs_evals..=most).contains(&fine.rhs_evals),
        "{what}: {} RHS, not in {} ..= {most}",
        fine.rhs_evals,
        coarse.rhs_evals
    );
}

pub fn check_sweep(runs: &[(f64, Stats, f64)], bound: f64, extension: u64) {
    for (comm, stats, err) in runs {
        same_work(stats, &runs[0].1, extension, &format!("comm {comm}"));
        assert!(*err < bound, "comm {comm}: worst error {err:e}");
    }
}

/// Grids of 1/8, 1/64 and 1/512 s (exact in binary, so the points meet exactly): the
/// states where they meet are the same bits, as from one run read at those points, with
/// the same steps (see [`same_work`] for `extension`).
pub fn grids_agree<S: System>(case: &Case<S>, solver: i32, extension: u64) {
    let coarse = 0.125;
    let (x8, s8) = case.run(solver, coarse);
    for fine in [coarse / 8.0, coarse / 64.0] {
        let (x, s) = case.run(solver, fine);
        let every = (coarse / fine) as usize;
        let met: Vec<Vec<f64>> = x.into_iter().skip(every - 1).step_by(every).collect();
        assert_eq!(bits(&met), bits(&x8), "{} at {fine}", case.scene);
        same_work(&s, &s8, extension, &format!("{} at {fine}", case.scene));
    }
}

/// Get/SetFMUstate and a serialized copy continue a run bit for bit.
pub fn rollback<S: System>(case: &Case<S>, solver: i32) {
    let comm = 1e-3;
    let mut inst = case.started(solver, comm, 0.0, &[]);
    steps(case, &mut inst, comm, 0, 300);
    let saved = inst.snapshot();
    let m = &saved.memory;
    let kept = m.ahead.as_ref().map(|a| a.method().code()) == Some(solver);
    assert!(
        kept,
        "solver {solver} keeps its state ahead of the communication time"
    );
    let blob = inst.serialize(&saved);
    let forward = steps(case, &mut inst, comm, 300, 700);
    let stats = inst.stats();
    for restore in [saved.clone(), inst.deserialize(&blob).unwrap()] {
        assert_eq!(restore, saved);
        inst.restore(&restore).unwrap();
        let again = steps(case, &mut inst, comm, 300, 700);
        assert_eq!(bits(&again), bits(&forward), "{}", case.scene);
        assert_eq!(inst.stats(), stats);
    }
}
