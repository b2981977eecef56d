//! fmi2SetRealInputDerivatives and fmi2GetRealOutputDerivatives (issue 16): argument
//! checks through the C API, polynomial inputs followed inside one long doStep against the
//! closed form, output derivatives against the model's own equations, and the input
//! derivatives as part of the FMU state.

mod common;
mod dense_common;

use common::*;
use dense_common::Case as Scene;
use mbfmu::fmi::{Instance, Status};
use mbfmu::integrators::Method;
use mbfmu::systems::MassSpringDamper;
use std::ffi::c_void;

const RK4: i32 = 1;
const DOPRI5: i32 = 2;

/// A named call that must be refused.
type Case<'a> = (&'a str, Box<dyn Fn() -> Status + 'a>);

/// Every bad call is refused with fmi2Error, one log line, and no change.
#[test]
fn bad_arguments_are_refused_with_one_log_line() {
    let f = Fmu::new("iod_bad");
    f.init(&[("F_amp", 0.0)]);
    let (fv, xv, mv) = (vr("F"), vr("x"), vr("m"));
    let mut out = 0.0;
    let out_ptr: *mut f64 = &mut out;
    let cases: Vec<Case> = vec![
        (
            "input derivative of an unknown vr",
            Box::new(|| unsafe { fmi2SetRealInputDerivatives(f.c, &999, 1, &1, &1.0) }),
        ),
        (
            "input derivative of a parameter",
            Box::new(|| unsafe { fmi2SetRealInputDerivatives(f.c, &mv, 1, &1, &1.0) }),
        ),
        (
            "input derivative of order 0",
            Box::new(|| unsafe { fmi2SetRealInputDerivatives(f.c, &fv, 1, &0, &1.0) }),
        ),
        (
            "input derivative of order 3",
            Box::new(|| unsafe { fmi2SetRealInputDerivatives(f.c, &fv, 1, &3, &1.0) }),
        ),
        (
            "input derivative NaN",
            Box::new(|| unsafe { fmi2SetRealInputDerivatives(f.c, &fv, 1, &1, &f64::NAN) }),
        ),
        (
            "input derivative +inf",
            Box::new(|| unsafe { fmi2SetRealInputDerivatives(f.c, &fv, 1, &2, &f64::INFINITY) }),
        ),
        (
            "input derivative NULL value",
            Box::new(|| unsafe { fmi2SetRealInputDerivatives(f.c, &fv, 1, &1, std::ptr::null()) }),
        ),
        (
            "output derivative of an input",
            Box::new(|| unsafe { fmi2GetRealOutputDerivatives(f.c, &fv, 1, &1, out_ptr) }),
        ),
        (
            "output derivative of a parameter",
            Box::new(|| unsafe { fmi2GetRealOutputDerivatives(f.c, &mv, 1, &1, out_ptr) }),
        ),
        (
            "output derivative of order 0",
            Box::new(|| unsafe { fmi2GetRealOutputDerivatives(f.c, &xv, 1, &0, out_ptr) }),
        ),
        (
            "output derivative of order 3",
            Box::new(|| unsafe { fmi2GetRealOutputDerivatives(f.c, &xv, 1, &3, out_ptr) }),
        ),
        (
            "output derivative NULL order",
            Box::new(|| unsafe {
                fmi2GetRealOutputDerivatives(f.c, &xv, 1, std::ptr::null(), out_ptr)
            }),
        ),
    ];
    let before = (f.get("x"), f.get("v"), f.get("F"));
    for (what, call) in cases {
        let n = f.errors();
        assert_eq!(call(), Status::Error, "{what}");
        let log = log_of(&f.name);
        assert_eq!(log.len(), n + 1, "{what}: expected one log line");
        assert!(!log[n].2.contains('\n'), "{what}");
        assert_eq!((f.get("x"), f.get("v"), f.get("F")), before, "{what}");
    }
    // A refused list sets none of its entries, even the valid ones before the bad one.
    let n = f.errors();
    let status = unsafe {
        fmi2SetRealInputDerivatives(
            f.c,
            [fv, fv].as_ptr(),
            2,
            [1, 5].as_ptr(),
            [3.0, 1.0].as_ptr(),
        )
    };
    assert_eq!((status, f.errors()), (Status::Error, n + 1));
    assert_eq!(fmi2DoStep(f.c, 0.0, 0.01, 1), Status::Ok);
    assert_eq!(
        f.get("F"),
        0.0,
        "the order-1 derivative of the refused call was not kept"
    );
}

/// The state machine: input derivatives before initialisation are kept (Instantiated is
/// allowed), output derivatives before it are refused.
#[test]
fn state_machine_masks() {
    let f = Fmu::new("iod_machine");
    let (fv, xv) = (vr("F"), vr("x"));
    let mut out = 0.0;
    let n = f.errors();
    assert_eq!(
        unsafe { fmi2GetRealOutputDerivatives(f.c, &xv, 1, &1, &mut out) },
        Status::Error
    );
    assert_eq!(f.errors(), n + 1);
    assert_eq!(
        unsafe { fmi2SetRealInputDerivatives(f.c, &fv, 1, &1, &2.0) },
        Status::Ok
    );
    f.init(&[("c", 0.0), ("x", 0.0)]);
    assert_eq!(fmi2DoStep(f.c, 0.0, 0.5, 1), Status::Ok);
    // F moved along its slope from 0: F(0.5) = 2·0.5.
    assert_eq!(f.get("F"), 1.0);
    assert_eq!(fmi2Terminate(f.c), Status::Ok);
    let n = f.errors();
    assert_eq!(
        unsafe { fmi2SetRealInputDerivatives(f.c, &fv, 1, &1, &2.0) },
        Status::Error,
        "not in Terminated"
    );
    assert_eq!(f.errors(), n + 1);
    assert_eq!(
        unsafe { fmi2GetRealOutputDerivatives(f.c, &xv, 1, &1, &mut out) },
        Status::Ok,
        "allowed in Terminated"
    );
}

/// m ẍ + k x = a t + b t²/2 from rest (c = 0, ω² = k/m): the ramp's and the parabola's
/// particular solutions plus the homogeneous one that starts at rest.
fn forced_closed_form(t: f64, a: f64, b: f64, k: f64, m: f64) -> f64 {
    let w = (k / m).sqrt();
    let ramp = a / k * (t - (w * t).sin() / w);
    let parabola = b / (2.0 * k) * t * t - b / (k * w * w) * (1.0 - (w * t).cos());
    ramp + parabola
}

fn started(solver: i32, tol: f64) -> (Scene<MassSpringDamper>, Instance<MassSpringDamper>) {
    let case = Scene::<MassSpringDamper>::new("free", &[], tol);
    let inst = case.started(solver, 1.0, 0.0, &[("x", 0.0), ("solver_step", 1e-3)]);
    (case, inst)
}

/// A ramp and a parabola given as value + derivatives at t = 0 are followed inside one
/// doStep of 1 s, to the integration's accuracy; held, they would be far off.
#[test]
fn polynomial_input_matches_the_closed_form_in_one_long_step() {
    let (a, b) = (3.0, -2.0);
    let exact = forced_closed_form(1.0, a, b, 100.0, 1.0);
    // ExactLinear: the input polynomial in the augmented exponential, no truncation error:
    // 1000 propagations of 1e-3 s round to ~1e3·ε·|x| (|x| < 0.1), so 1e-12 (issue 24).
    for (solver, tol, bound) in [(DOPRI5, 1e-10, 1e-8), (RK4, 1e-8, 1e-8), (11, 1e-8, 1e-12)] {
        let (case, mut inst) = started(solver, tol);
        let f = case.vr("F");
        inst.set_input_derivatives(&[f, f], &[1, 2], &[a, b])
            .unwrap();
        inst.do_step(0.0, 1.0).unwrap();
        let x = inst.snapshot().x[0];
        // DOPRI5 at rtol 1e-10 with nominal 0.1: atol 1e-11 per step, a few hundred steps;
        // RK4 with h = 1e-3 on ω = 10: error ~ (ωh)⁴/120·ω·|x| ≈ 1e-11. 1e-8 bounds both
        // with a wide margin and is 1e5 below the held input's error (next assertion).
        assert!(
            (x - exact).abs() < bound,
            "solver {solver}: x(1) = {x}, closed form {exact}"
        );
        // The inputs after the step are the polynomial's at t = 1: F = a + b/2, Ḟ = a + b.
        let s = inst.snapshot();
        assert_eq!(
            (s.u[0], s.u_der[0][0], s.u_der[1][0]),
            (a + b / 2.0, a + b, b)
        );
        // Held at F = 0 the mass would not move at all.
        let (_, mut held) = started(solver, tol);
        held.do_step(0.0, 1.0).unwrap();
        assert!((held.snapshot().x[0] - exact).abs() > 1e-3);
    }
}

/// Output derivatives are the model's own: ẋ = v, ẍ = v̇ = (F − c v − k x)/m, and for
/// E = ½ m v² + ½ k x², Ė = (m v̇ + k x) v; with an input slope Ḟ, v̈ = (Ḟ − c v̇ − k v)/m.
#[test]
fn output_derivatives_follow_the_equations_of_motion() {
    let (case, mut inst) = started(DOPRI5, 1e-8);
    let (f, x, v, e) = (case.vr("F"), case.vr("x"), case.vr("v"), case.vr("E"));
    inst.set_real(&[f], &[0.7]).unwrap();
    inst.set_input_derivatives(&[f], &[1], &[5.0]).unwrap();
    inst.do_step(0.0, 0.1).unwrap();
    let s = inst.snapshot();
    let (m, k, c) = (s.params[0], s.params[1], s.params[2]);
    let (xx, vv, ff, fd) = (s.x[0], s.x[1], s.u[0], s.u_der[0][0]);
    let acc = (ff - c * vv - k * xx) / m;
    let jerk = (fd - c * acc - k * vv) / m;
    let energy_rate = (m * acc + k * xx) * vv;
    let energy_acc = (m * jerk + k * vv) * vv + (m * acc + k * xx) * acc;
    let vrs = [x, x, v, v, e, e];
    let orders = [1, 2, 1, 2, 1, 2];
    let mut out = [0.0; 6];
    inst.output_derivatives(&vrs, &orders, &mut out).unwrap();
    let expected = [vv, acc, acc, jerk, energy_rate, energy_acc];
    for (i, (got, want)) in out.iter().zip(expected).enumerate() {
        // Same arithmetic up to reassociation: a few ulps of the largest term.
        let scale = 1.0 + want.abs().max(k * xx.abs()).max(k * vv.abs());
        assert!(
            (got - want).abs() < 1e-13 * scale,
            "entry {i}: {got} vs {want}"
        );
    }
}

/// With the harmonic forcing on, f reads t: order 1 stays exact (ẋ = f, Ė needs no ∂f/∂t),
/// order 2 is refused rather than returned without the ∂f/∂t term.
#[test]
fn explicit_time_refuses_order_two() {
    let case = Scene::<MassSpringDamper>::new("resonance", &[], 1e-8);
    let mut inst = case.started(DOPRI5, 0.01, 0.0, &[]);
    inst.do_step(0.0, 0.1).unwrap();
    let (x, e) = (case.vr("x"), case.vr("E"));
    let mut out = [0.0; 2];
    inst.output_derivatives(&[x, e], &[1, 1], &mut out).unwrap();
    assert_eq!(out[0], inst.snapshot().x[1]);
    let err = inst
        .output_derivatives(&[x], &[2], &mut out[..1])
        .unwrap_err();
    assert!(err.contains("∂/∂t"), "{err}");
}

/// ExactLinear follows input derivatives (issue 24: it refused them, though every FMU
/// declares canInterpolateInputs): accepted in either order with the solver, and a ramp
/// F = t N gives DOPRI5's answer at a tight tolerance.
#[test]
fn exact_linear_follows_input_derivatives() {
    let case = Scene::<MassSpringDamper>::new("free", &[], 1e-12);
    let f = case.vr("F");
    let mut exact = case.started(11, 0.01, 0.0, &[]);
    exact.set_input_derivatives(&[f], &[1], &[1.0]).unwrap();
    let mut reference = case.started(DOPRI5, 0.01, 0.0, &[]);
    reference.set_input_derivatives(&[f], &[1], &[1.0]).unwrap();
    exact.do_step(0.0, 0.5).unwrap();
    reference.do_step(0.0, 0.5).unwrap();
    let (a, b) = (exact.snapshot(), reference.snapshot());
    for (x, y) in a.x.iter().zip(&b.x) {
        assert!((x - y).abs() < 1e-10, "{:?} against {:?}", a.x, b.x);
    }
    assert_eq!(a.u, vec![0.5], "the input moved along its ramp");
    let mut inst = Instance::<MassSpringDamper>::new(case.info, mbfmu::fmi::Logger::silent("x"));
    inst.set_input_derivatives(&[f], &[2], &[1.0]).unwrap();
    inst.set_integer(&[case.vr("solver")], &[Method::ExactLinear.code()])
        .unwrap();
}

/// Input derivatives are part of the FMU state: a serialized state restores them, and the
/// run continues bit for bit; a changed derivative drops DOPRI5's point ahead.
#[test]
fn input_derivatives_round_trip_through_the_fmu_state() {
    let (case, mut inst) = started(DOPRI5, 1e-8);
    let f = case.vr("F");
    inst.do_step(0.0, 0.1).unwrap();
    assert!(
        inst.snapshot().memory.ahead.is_some(),
        "dense output runs ahead"
    );
    inst.set_input_derivatives(&[f, f], &[1, 2], &[0.5, -0.25])
        .unwrap();
    assert!(
        inst.snapshot().memory.ahead.is_none(),
        "a new derivative drops it"
    );
    inst.do_step(0.1, 0.1).unwrap();
    assert!(inst.snapshot().memory.ahead.is_none(), "moving inputs land");
    let blob = inst.serialize(&inst.snapshot());
    let restored = inst.deserialize(&blob).unwrap();
    assert_eq!(restored, inst.snapshot());
    assert_eq!(restored.u_der, [vec![0.5 - 0.25 * 0.1], vec![-0.25]]);
    let (_, mut other) = started(DOPRI5, 1e-8);
    other.restore(&restored).unwrap();
    inst.do_step(0.2, 0.3).unwrap();
    other.do_step(0.2, 0.3).unwrap();
    assert_eq!(other.snapshot(), inst.snapshot());
    // A state with derivatives and a point ahead is not one this FMU makes.
    let mut forged = restored.clone();
    forged.memory = {
        let (_, mut held) = started(DOPRI5, 1e-8);
        held.do_step(0.0, 0.2).unwrap();
        held.snapshot().memory
    };
    assert!(other.restore(&forged).is_err());
    // Non-finite derivatives in a blob are refused.
    let mut bad = restored;
    bad.u_der[1][0] = f64::NAN;
    let err = other.restore(&bad).unwrap_err();
    assert!(err.contains("not finite"), "{err}");
}

/// FMU state through the C API keeps the derivatives (get, set on a fresh instance).
#[test]
fn fmu_state_pointer_keeps_input_derivatives() {
    let f = Fmu::new("iod_state");
    f.init(&[("x", 0.0), ("c", 0.0)]);
    let fv = vr("F");
    assert_eq!(
        unsafe { fmi2SetRealInputDerivatives(f.c, &fv, 1, &1, &4.0) },
        Status::Ok
    );
    let mut s: *mut c_void = std::ptr::null_mut();
    assert_eq!(unsafe { fmi2GetFMUstate(f.c, &mut s) }, Status::Ok);
    assert_eq!(fmi2DoStep(f.c, 0.0, 0.25, 1), Status::Ok);
    let after = (f.get("x"), f.get("F"));
    assert_eq!(after.1, 1.0);
    assert_eq!(unsafe { fmi2SetFMUstate(f.c, s) }, Status::Ok);
    assert_eq!(f.get("F"), 0.0);
    assert_eq!(fmi2DoStep(f.c, 0.0, 0.25, 1), Status::Ok);
    assert_eq!((f.get("x"), f.get("F")), after);
    assert_eq!(unsafe { fmi2FreeFMUstate(f.c, &mut s) }, Status::Ok);
}
