//! Coulomb friction through the FMU's own Instance, against closed forms: a 2 kg block on
//! a horizontal prismatic joint with friction F = 3 N (URDF `<dynamics friction="3">`).
//! - Pushed by τ = 2 N < F from rest: it sticks, exactly at rest, the friction force −τ.
//! - Pushed by τ = 5 N > F: it slips at a = (τ − F)/m, q = ½ a t², friction −F.
//! - Launched at 2 m/s with τ = 1 N < F along the motion: it slows at (τ − F)/m = −1
//!   m/s², comes to rest at t = 2 s, q = 2 m (an event, located), and stays there exactly.
//! - Launched at 2 m/s with τ = −5 N: it slows at −4 m/s², turns at t = 0.5 s, q = 0.5 m,
//!   and slips back at −1 m/s² (the friction turned with the motion).
//!
//! Each by DOPRI5 and DOP853 at tolerance 1e-10: constant accelerations are integrated
//! exactly by both, so what is left is the location of the events and the band at rest
//! (STICK).

#[path = "common/instance.rs"]
mod instance;

use instance::{started, value_of};
use mbfmu::multibody::fmu::Robot;
use mbfmu::multibody::friction::STICK;
use mbfmu::multibody::{Body, Joint, JointKind, Mechanism, Origin};

const MASS: f64 = 2.0;
const FRICTION: f64 = 3.0;

/// The block on a horizontal slide (gravity along −z plays no part).
fn slide() -> Mechanism {
    Mechanism::new("friction_slide")
        .body(Body::massless("base"))
        .body(Body::new("block", MASS).inertia_diag([0.01, 0.01, 0.01]))
        .joint(
            Joint::new(
                "slide",
                JointKind::Prismatic,
                "base",
                "block",
                Origin::IDENTITY,
            )
            .axis([1.0, 0.0, 0.0])
            .friction(FRICTION),
        )
        .torque("slide", 0.0)
}

mbfmu::mechanism_fmu!(pub FrictionSlide, "FrictionSlide", slide);
type R = Robot<FrictionSlide>;

const DOPRI5: f64 = 2.0;
const DOP853: f64 = 9.0;
/// The adaptive explicit methods, which locate the events. Not RADAU5: its Newton
/// iteration fails where its stages straddle the edge of the band at rest (as at end-stop
/// impacts); not RK4: its fixed step straddles the turn of the force, its stages cancel,
/// and the joint can creep at ~h·F/m without its velocity ever changing sign.
const SOLVERS: [f64; 2] = [DOPRI5, DOP853];

/// Runs from t = 0 to `to` in doSteps of 0.1 s with `values` set; returns (q, q̇, the
/// friction force) after each doStep.
fn run(values: &[(&str, f64)], to: f64) -> Vec<(f64, f64, f64, f64)> {
    let (mut inst, info) = started::<R>("friction", values);
    let mut out = Vec::new();
    let h = 0.1;
    let steps = (to / h).round() as usize;
    for k in 0..steps {
        let t = k as f64 * h;
        let outcome = inst.do_step(t, h).unwrap();
        assert_eq!(outcome, mbfmu::fmi::StepOutcome::Completed);
        let get = |name| value_of(&inst, info, name);
        out.push((
            (k + 1) as f64 * h,
            get("slide"),
            get("slide_dot"),
            get("tau_friction_slide"),
        ));
    }
    out
}

#[test]
fn below_its_friction_the_block_sticks_exactly() {
    for solver in SOLVERS {
        let run = run(&[("tau_slide", 2.0), ("solver", solver)], 1.0);
        for &(_, q, v, f) in &run {
            assert_eq!((q, v), (0.0, 0.0), "solver {solver}");
            assert!((f + 2.0).abs() < 1e-12, "{f}");
        }
    }
}

#[test]
fn above_its_friction_the_block_slips_at_the_closed_form_acceleration() {
    let a = (5.0 - FRICTION) / MASS;
    for solver in SOLVERS {
        for (t, q, v, f) in run(&[("tau_slide", 5.0), ("solver", solver)], 1.0) {
            assert!((q - 0.5 * a * t * t).abs() < 1e-10, "{solver} {t} {q}");
            assert!((v - a * t).abs() < 1e-10, "{solver} {t} {v}");
            assert_eq!(f, -FRICTION);
        }
    }
}

#[test]
fn a_sliding_block_comes_to_rest_and_stays() {
    // Slowing at (1 − 3)/2 = −1 m/s² from 2 m/s: at rest at t = 2 s, q = 2 m.
    for solver in SOLVERS {
        let run = run(
            &[("tau_slide", 1.0), ("slide_dot", 2.0), ("solver", solver)],
            4.0,
        );
        for &(t, q, v, f) in &run {
            if t < 2.0 - 1e-9 {
                assert!((q - (2.0 * t - 0.5 * t * t)).abs() < 1e-10, "{t} {q}");
                assert!((v - (2.0 - t)).abs() < 1e-10, "{t} {v}");
                assert_eq!(f, -FRICTION);
            } else if t < 2.0 + 1e-9 {
                // The event lies within the integration's error of this point: at rest, or
                // within the band at rest (STICK) of it.
                assert!(
                    (q - 2.0).abs() < 1e-10 && v.abs() < 2.0 * STICK,
                    "{t} {q} {v}"
                );
            } else {
                assert!((q - 2.0).abs() < 1e-10, "{solver} {t} {q}");
                assert_eq!(v, 0.0, "{solver} {t}: at rest exactly");
                assert!((f + 1.0).abs() < 1e-12, "{f}");
            }
        }
        // Stuck: not a bit of drift from one doStep to the next.
        let rest: Vec<f64> = run.iter().filter(|r| r.0 > 2.05).map(|r| r.1).collect();
        assert!(rest.windows(2).all(|w| w[0] == w[1]), "{rest:?}");
    }
}

#[test]
fn a_block_pushed_back_harder_than_its_friction_turns_and_slides_back() {
    // Slowing at (−5 − 3)/2 = −4 m/s² from 2 m/s: turns at t = 0.5 s at q = 0.5 m, then
    // (−5 + 3)/2 = −1 m/s².
    let closed = |t: f64| {
        if t <= 0.5 {
            (2.0 * t - 2.0 * t * t, 2.0 - 4.0 * t, -FRICTION)
        } else {
            let s = t - 0.5;
            (0.5 - 0.5 * s * s, -s, FRICTION)
        }
    };
    for solver in SOLVERS {
        let run = run(
            &[("tau_slide", -5.0), ("slide_dot", 2.0), ("solver", solver)],
            2.0,
        );
        for (t, q, v, f) in run {
            let (cq, cv, cf) = closed(t);
            // The turn: the joint put at rest within STICK of it (the event) turns late by
            // up to STICK / (4 m/s²), and so runs behind the closed form by ≤ 3/4 STICK
            // (m/s) and ≤ 1/4 STICK (m) per second after.
            assert!((q - cq).abs() < 1e-10 + STICK, "{solver} {t} {q} {cq}");
            assert!((v - cv).abs() < 1e-10 + STICK, "{solver} {t} {v} {cv}");
            if (t - 0.5).abs() > 1e-9 {
                assert_eq!(f, cf, "{t}");
            }
        }
    }
}
