//! One doStep's work is bounded ([`mbfmu::fmi::DOSTEP_WORK`]): whatever values were accepted
//! before it, a doStep answers once it has spent that many state-component evaluations
//! (an evaluation of f counts n, a Jacobian 6n²), with fmi2Discard at the last good state
//! and a message that names the bound. `solver_max_steps` bounds the number of steps; the
//! costly ones (a 16-state implicit step with its Jacobian) reached seconds within it.
//! Counts are asserted, never time (the times printed are for the documentation).

use mbfmu::fmi::{Instance, Logger, ModelInfo, StepOutcome, DOSTEP_WORK};
use mbfmu::model::System;
use mbfmu::systems::{MassSpringDamper, NonlinearBicycle};
use std::time::Instant;

fn info<M: System>() -> &'static ModelInfo {
    Box::leak(Box::new(ModelInfo::of::<M>()))
}

/// An instance of `M` initialised with `solver`, `solver_step` and `tolerance`.
fn started<M: System>(solver: i32, solver_step: f64, tolerance: f64) -> Instance<M> {
    let info = info::<M>();
    let vr = |n: &str| info.layout.vr_of(n).unwrap();
    let mut inst = Instance::<M>::new(info, Logger::silent("work"));
    inst.setup_experiment(Some(tolerance), 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.set_real(&[vr("solver_step")], &[solver_step]).unwrap();
    inst.set_integer(&[vr("solver")], &[solver]).unwrap();
    inst.exit_initialization_mode().unwrap();
    inst
}

/// The work a doStep of `h` did, its outcome, and how long it took.
fn step<M: System>(inst: &mut Instance<M>, h: f64) -> (u64, StepOutcome, f64) {
    let n = M::states().len();
    let before = inst.stats().work(n);
    let t0 = Instant::now();
    let outcome = inst.do_step(inst.time(), h).unwrap();
    let seconds = t0.elapsed().as_secs_f64();
    (inst.stats().work(n) - before, outcome, seconds)
}

/// Gauss6 with 1e-5 s steps over 0.5 s is 50 000 planned steps, as many as
/// `solver_max_steps` allows: each with a Jacobian of the 16 states (96 evaluations of f)
/// and Newton's evaluations. It stops at the bound, at the last good state, and says why.
#[test]
fn an_implicit_do_step_of_the_bicycle_stops_at_the_work_bound() {
    for (solver, name) in [(8, "Gauss6"), (10, "RADAU5")] {
        let (solver_step, tolerance) = if solver == 8 {
            (1e-5, 1e-8)
        } else {
            (1e-3, 1e-13)
        };
        let mut inst = started::<NonlinearBicycle>(solver, solver_step, tolerance);
        let (work, outcome, seconds) = step(&mut inst, 0.5);
        println!(
            "METRIC NonlinearBicycle {name}: doStep of 0.5 s: {work} state-component evaluations in {seconds:.3} s ({outcome:?})"
        );
        // One step (or attempt) more than the bound at most: the check comes before each.
        let one_step = 16 * (6 * 16 + 3 * 50 + 1);
        assert!(work <= DOSTEP_WORK + one_step, "{name}: {work}");
        if solver == 8 {
            let StepOutcome::Discarded(why) = outcome else {
                panic!("{name}: 50 000 Gauss6 steps of the bicycle fit the bound?")
            };
            assert!(why.contains("the bound on one doStep's work"), "{why}");
            assert!(inst.time() > 0.0 && inst.time() < 0.5, "{}", inst.time());
        }
    }
}

/// A cheap system is not held back: the same 50 000 Gauss6 steps of MassSpringDamper
/// (2 states) fit the bound.
#[test]
fn a_cheap_system_takes_its_steps() {
    let mut inst = started::<MassSpringDamper>(8, 1e-5, 1e-8);
    let (work, outcome, seconds) = step(&mut inst, 0.5);
    println!("METRIC MassSpringDamper Gauss6: 50 000 steps: {work} state-component evaluations in {seconds:.3} s");
    assert_eq!(outcome, StepOutcome::Completed);
    assert!(work < DOSTEP_WORK);
}

/// A model whose evaluations cost more per state ([`System::EVALUATION_WEIGHT`]: a closed
/// loop on the interpreted path, weight 5: the four-bar as HeldFourBar declares it, which
/// has no generated terms) gets the bound divided by that weight, and its Discard names the
/// bound it applied, not the unweighted one. (AndrewsSqueezer and FourBar, here before, run
/// generated closed terms: weight 1.)
#[test]
fn a_costly_model_is_bounded_by_its_weighted_work_and_says_so() {
    type A = mbfmu::multibody::fmu::Robot<mbfmu::systems::four_bar::HeldFourBar>;
    assert_eq!(
        <mbfmu::systems::AndrewsSqueezer as System>::EVALUATION_WEIGHT,
        1
    );
    assert_eq!(<mbfmu::systems::FourBar as System>::EVALUATION_WEIGHT, 1);
    let weight = <A as System>::EVALUATION_WEIGHT;
    assert!(weight > 1);
    let bound = DOSTEP_WORK / weight;
    // Gauss6 with 30 000 fixed steps of 1 µs over 0.03 s.
    let mut inst = started::<A>(8, 1e-6, 1e-13);
    let (work, outcome, seconds) = step(&mut inst, 0.03);
    println!("METRIC HeldFourBar Gauss6 h 1e-6: doStep of 0.03 s: {work} state-component evaluations in {seconds:.3} s ({outcome:?})");
    let n = A::states().len() as u64;
    let one_step = n * (6 * n + 3 * 50 + 1);
    assert!(work <= bound + one_step, "{work} > {bound}");
    let StepOutcome::Discarded(why) = outcome else {
        panic!("30 000 Gauss6 steps fit the weighted bound?")
    };
    assert!(
        why.contains(&format!("{bound:e} state-component evaluations")),
        "{why}"
    );
    assert!(
        why.contains(&format!(
            "divided by this model's cost of an evaluation, {weight}"
        )),
        "{why}"
    );
}
