//! DOPRI5 inside `fmi2DoStep` runs ahead of the communication points with dense output:
//! a small communication step does not force small integration steps. Checked through the
//! instance API (the one the C glue calls) on the MassSpringDamper:
//! - the RHS count of a constant-input run is the same for communication steps 0.1 … 1e-4;
//! - every communication point agrees with the closed form to the tolerance;
//! - Get/SetFMUstate and the serialized state keep the integrator's point ahead, so a
//!   rollback continues bit for bit;
//! - a changed input restarts the integration at the communication point (an unchanged
//!   one does not).

use mbfmu::fmi::{Instance, Logger, ModelInfo, StepOutcome};
use mbfmu::systems::MassSpringDamper;

/// Default parameters of MassSpringDamper: m = 1, k = 100, c = 2 (ζ = 0.1).
const M: f64 = 1.0;
const K: f64 = 100.0;
const C: f64 = 2.0;
const TOL: f64 = 1e-9;

fn info() -> &'static ModelInfo {
    static INFO: std::sync::OnceLock<ModelInfo> = std::sync::OnceLock::new();
    INFO.get_or_init(ModelInfo::of::<MassSpringDamper>)
}

fn vr(name: &str) -> u32 {
    info().layout.vr_of(name).unwrap()
}

/// Underdamped response from rest at x = x0, v = v0 with constant force `f`.
fn closed_form(t: f64, x0: f64, v0: f64, f: f64) -> [f64; 2] {
    let (wn, zeta) = ((K / M).sqrt(), C / (2.0 * (K * M).sqrt()));
    let wd = wn * (1.0 - zeta * zeta).sqrt();
    let xs = f / K;
    let (a, b) = (x0 - xs, (v0 + zeta * wn * (x0 - xs)) / wd);
    let e = (-zeta * wn * t).exp();
    let (s, c) = (wd * t).sin_cos();
    let x = xs + e * (a * c + b * s);
    let v = e * (-zeta * wn * (a * c + b * s) + (-a * wd * s + b * wd * c));
    [x, v]
}

fn started(x0: f64) -> Instance<MassSpringDamper> {
    let mut inst = Instance::<MassSpringDamper>::new(info(), Logger::silent("dense"));
    inst.setup_experiment(Some(TOL), 0.0, Some(10.0)).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.set_real(&[vr("x")], &[x0]).unwrap();
    inst.set_integer(&[vr("solver")], &[2]).unwrap(); // DOPRI5
    inst.exit_initialization_mode().unwrap();
    inst
}

fn state(inst: &Instance<MassSpringDamper>) -> [f64; 2] {
    let mut x = [0.0; 2];
    inst.get_real(&[vr("x"), vr("v")], &mut x).unwrap();
    x
}

/// Error scaled like the bench: position by x0 = 0.1 m, velocity by ω·x0 = 1 m/s.
fn error(got: [f64; 2], want: [f64; 2]) -> f64 {
    ((got[0] - want[0]) / 0.1)
        .abs()
        .max((got[1] - want[1]).abs())
}

/// 10 s in communication steps of `h`: RHS evaluations and the worst error on the grid.
fn run(h: f64) -> (u64, f64) {
    let mut inst = started(0.1);
    let n = (10.0 / h).round() as usize;
    let mut worst = 0.0f64;
    for i in 0..n {
        let t = i as f64 * h;
        let h_i = if i + 1 == n { 10.0 - t } else { h };
        assert_eq!(inst.do_step(t, h_i).unwrap(), StepOutcome::Completed);
        worst = worst.max(error(state(&inst), closed_form(t + h_i, 0.1, 0.0, 0.0)));
    }
    (inst.stats().rhs_evals, worst)
}

#[test]
fn rhs_count_does_not_grow_as_the_communication_step_shrinks() {
    let runs: Vec<(f64, u64, f64)> = [0.1, 1e-2, 1e-3, 1e-4]
        .into_iter()
        .map(|h| {
            let (evals, err) = run(h);
            println!(
                "METRIC communication step {h:e}: {evals} RHS evaluations, worst error {err:.2e}"
            );
            (h, evals, err)
        })
        .collect();
    // The steps are the controller's alone, the same for every grid: equal counts.
    for (h, evals, _) in &runs {
        assert_eq!(*evals, runs[0].1, "h = {h}: {evals} vs {}", runs[0].1);
    }
    // Every communication point, stepped-to or interpolated, is as accurate as the
    // integration: the global error of rtol 1e-9 over 16 periods (measured 2.2e-9
    // scaled), the same on every grid.
    for (h, _, err) in &runs {
        assert!(*err < 1e-7, "h = {h}: worst error {err:e}");
        assert!(
            *err < 2.0 * runs[0].2 + 1e-9,
            "h = {h}: {err:e} vs {:e}",
            runs[0].2
        );
    }
}

#[test]
fn rollback_continues_bit_for_bit_through_the_point_ahead() {
    let h = 1e-3;
    let mut inst = started(0.1);
    for i in 0..50 {
        inst.do_step(i as f64 * h, h).unwrap();
    }
    let saved = inst.snapshot();
    assert!(
        saved.memory.ahead.is_some(),
        "DOPRI5 keeps a point ahead of the communication time"
    );
    let blob = inst.serialize(&saved);
    let mut forward = Vec::new();
    for i in 50..80 {
        inst.do_step(i as f64 * h, h).unwrap();
        forward.push(state(&inst));
    }
    let evals_forward = inst.stats().rhs_evals;
    for restore in [saved.clone(), inst.deserialize(&blob).unwrap()] {
        inst.restore(&restore).unwrap();
        let mut again = Vec::new();
        for i in 50..80 {
            inst.do_step(i as f64 * h, h).unwrap();
            again.push(state(&inst));
        }
        let bits = |v: &Vec<[f64; 2]>| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&again), bits(&forward));
        assert_eq!(inst.stats().rhs_evals, evals_forward);
    }
}

#[test]
fn a_changed_input_restarts_at_the_communication_point() {
    // Rest at x = 0; F = 1 N from t = 1 s on, set between doSteps of 0.01 s. Had the
    // integrator kept its point ahead (computed with F = 0), the force would start late.
    let h = 0.01;
    let mut inst = started(0.0);
    let mut worst = 0.0f64;
    for i in 0..300 {
        let t = i as f64 * h;
        if i >= 100 {
            // Setting an unchanged value every step must not cost anything.
            inst.set_real(&[vr("F")], &[1.0]).unwrap();
        }
        inst.do_step(t, h).unwrap();
        if i >= 100 {
            let exact = closed_form(t + h - 1.0, 0.0, 0.0, 1.0);
            // Scale: the static deflection F/k = 0.01 m, and its ω·F/k velocity.
            let e = ((state(&inst)[0] - exact[0]) / 0.01)
                .abs()
                .max((state(&inst)[1] - exact[1]).abs() / 0.1);
            worst = worst.max(e);
        }
    }
    println!("METRIC input step at t = 1 s: worst scaled error {worst:.2e}");
    assert!(worst < 1e-6, "worst error {worst:e}");

    // Unchanged inputs set every step: the same work as not setting them.
    let work = |set_every_step: bool| {
        let mut inst = started(0.1);
        for i in 0..1000 {
            if set_every_step {
                inst.set_real(&[vr("F")], &[0.0]).unwrap();
            }
            inst.do_step(i as f64 * 1e-3, 1e-3).unwrap();
        }
        (inst.stats().rhs_evals, state(&inst))
    };
    assert_eq!(work(true), work(false));
}

/// A free mass (k = c = 0) pushed by a force held over each communication step and changed
/// at every one, with no stop time: DOPRI5 integrates each piece exactly (a quadratic), so
/// its error estimate is zero and its step proposal grew tenfold per step without bound;
/// the state was then read off steps of up to 1e45 s, 0.54 m wrong after 1.6 s, then
/// fmi2Discard. Bounded run-ahead: the exact piecewise solution to rounding (2e-12 here,
/// positions of order 0.1 m after 3 s; the bound leaves 50×).
#[test]
fn a_step_the_error_estimate_cannot_judge_does_not_grow_without_bound() {
    let mut inst = Instance::<MassSpringDamper>::new(info(), Logger::silent("dense"));
    inst.setup_experiment(Some(TOL), 0.0, None).unwrap();
    inst.set_real(&[vr("k"), vr("c"), vr("x"), vr("v")], &[0.0; 4])
        .unwrap();
    inst.set_integer(&[vr("solver")], &[2]).unwrap(); // DOPRI5
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
    let (h, mut t, mut exact): (f64, f64, [f64; 2]) = (0.01, 0.0, [0.0, 0.0]);
    for _ in 0..300 {
        let f = (3.0 * t).sin();
        inst.set_real(&[vr("F")], &[f]).unwrap();
        assert_eq!(
            inst.do_step(t, h).unwrap(),
            StepOutcome::Completed,
            "t = {t}"
        );
        exact = [exact[0] + exact[1] * h + 0.5 * f * h * h, exact[1] + f * h];
        t += h;
        let got = state(&inst);
        assert!(
            (got[0] - exact[0]).abs() < 1e-10 && (got[1] - exact[1]).abs() < 1e-10,
            "t = {t}: {got:?} against {exact:?}"
        );
    }
}
