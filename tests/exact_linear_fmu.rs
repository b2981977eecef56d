//! Solver 11, `ExactLinear`: the exact propagator e^{Ah} through the FMU's instance API.
//! Exact for a linear time-invariant system (MassSpringDamper without its harmonic
//! forcing, against the closed form), refused with a clear error for any other system.

use mbfmu::fmi::{Instance, Logger, ModelInfo, StepOutcome};
use mbfmu::model::System;
use mbfmu::systems::{CompoundPendulum, MassSpringDamper};

fn info<M: System>() -> &'static ModelInfo {
    Box::leak(Box::new(ModelInfo::of::<M>()))
}

#[test]
fn exact_linear_matches_the_closed_form_at_any_step() {
    let info = info::<MassSpringDamper>();
    let vr = |n: &str| info.layout.vr_of(n).unwrap();
    // m = 1, k = 100, c = 2: ζ = 0.1, released from x = 0.1 m.
    let (wn, zeta): (f64, f64) = (10.0, 0.1);
    let wd = wn * (1.0 - zeta * zeta).sqrt();
    let exact = |t: f64| {
        let e = (-zeta * wn * t).exp();
        let (s, c) = (wd * t).sin_cos();
        let b = zeta * wn / wd;
        [
            0.1 * e * (c + b * s),
            0.1 * e * (-zeta * wn * (c + b * s) + (-wd * s + b * wd * c)),
        ]
    };
    for solver_step in [1e-3, 0.05, 1.0] {
        let mut inst = Instance::<MassSpringDamper>::new(info, Logger::silent("exact"));
        inst.setup_experiment(None, 0.0, None).unwrap();
        inst.enter_initialization_mode().unwrap();
        inst.set_real(&[vr("x"), vr("solver_step")], &[0.1, solver_step])
            .unwrap();
        inst.set_integer(&[vr("solver")], &[11]).unwrap();
        inst.exit_initialization_mode().unwrap();
        let mut worst = 0.0f64;
        for i in 0..1000 {
            let t = i as f64 * 0.01;
            assert_eq!(inst.do_step(t, 0.01).unwrap(), StepOutcome::Completed);
            let mut x = [0.0; 2];
            inst.get_real(&[vr("x"), vr("v")], &mut x).unwrap();
            let e = exact(t + 0.01);
            worst = worst.max(((x[0] - e[0]) / 0.1).abs().max((x[1] - e[1]).abs()));
        }
        println!("METRIC ExactLinear solver_step {solver_step}: worst scaled error {worst:.2e} over 10 s");
        // No truncation error: rounding of 1000 propagations (and of the closed form).
        assert!(worst < 1e-13, "solver_step {solver_step}: {worst:e}");
    }
}

#[test]
fn exact_linear_is_refused_where_it_would_be_wrong() {
    // A nonlinear system: refused at fmi2SetInteger, nothing changed.
    let info_p = info::<CompoundPendulum>();
    let mut p = Instance::<CompoundPendulum>::new(info_p, Logger::silent("pend"));
    p.setup_experiment(None, 0.0, None).unwrap();
    let solver = info_p.layout.vr_of("solver").unwrap();
    let err = p.set_integer(&[solver], &[11]).unwrap_err();
    assert!(err.contains("linear time-invariant"), "{err}");
    // MassSpringDamper with its harmonic forcing switched on after choosing the method:
    // refused when initialisation ends, and the instance stays in Initialization Mode.
    let info = info::<MassSpringDamper>();
    let vr = |n: &str| info.layout.vr_of(n).unwrap();
    let mut inst = Instance::<MassSpringDamper>::new(info, Logger::silent("forced"));
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.set_integer(&[vr("solver")], &[11]).unwrap();
    inst.set_real(&[vr("F_amp")], &[1.0]).unwrap();
    let err = inst.exit_initialization_mode().unwrap_err();
    assert!(err.contains("linear time-invariant"), "{err}");
    inst.set_real(&[vr("F_amp")], &[0.0]).unwrap();
    inst.exit_initialization_mode().unwrap();
}
