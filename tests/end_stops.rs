//! End stops (`limit_events = 2`, the default) through the FMU's own Instance, against
//! closed forms: a pendulum released above its stop comes to rest on it (restitution 0),
//! its reaction the gravity torque there, and leaves when a torque pulls it away; with
//! restitution e it rebounds to e² of its height (the kinetic energy at the impact times e²
//! is what is left), and its bounces end resting on the stop inside one doStep. A block
//! pushed up a prismatic joint rests on its upper stop with the reaction −(F − m g).

#[path = "common/instance.rs"]
mod instance;

use mbfmu::fmi::{Instance, ModelInfo, StepOutcome};
use mbfmu::multibody::fmu::Robot;
use mbfmu::multibody::{Body, Joint, JointKind, Limit, Mechanism, Origin};

const G: f64 = 9.81;
/// The bob's distance from the axis (m) and its mass (kg): a point mass, I = m l².
const L: f64 = 1.0;
const M: f64 = 1.0;
/// The stop the pendulum falls onto, and where it is released (rad from hanging).
const STOP: f64 = 0.5;
const RELEASE: f64 = 1.2;

/// A point mass on a massless rod, about y, hanging along −z at q = 0; limits (0.5, 2).
fn pendulum() -> Mechanism {
    Mechanism::new("stop_pendulum")
        .body(Body::massless("base"))
        .body(Body::new("bob", M).com([0.0, 0.0, -L]))
        .joint(
            Joint::new(
                "swing",
                JointKind::Revolute,
                "base",
                "bob",
                Origin::IDENTITY,
            )
            .axis([0.0, 1.0, 0.0])
            .limit(Limit {
                lower: Some(STOP),
                upper: Some(2.0),
                effort: None,
                velocity: None,
            }),
        )
        .start("swing", RELEASE)
        .torque("swing", 0.0)
}

mbfmu::mechanism_fmu!(pub StopPendulum, "StopPendulum", pendulum);
type P = Robot<StopPendulum>;

/// A 1 kg block on a vertical prismatic joint limited to (−0.1, 0.2) m.
fn lift() -> Mechanism {
    Mechanism::new("stop_lift")
        .body(Body::massless("base"))
        .body(Body::new("block", 1.0).inertia_diag([0.01, 0.01, 0.01]))
        .joint(
            Joint::new(
                "lift",
                JointKind::Prismatic,
                "base",
                "block",
                Origin::IDENTITY,
            )
            .axis([0.0, 0.0, 1.0])
            .limit(Limit {
                lower: Some(-0.1),
                upper: Some(0.2),
                effort: Some(50.0),
                velocity: None,
            }),
        )
}

mbfmu::mechanism_fmu!(pub StopLift, "StopLift", lift);
type B = Robot<StopLift>;

fn instance<R: mbfmu::model::System>(values: &[(&str, f64)]) -> (Instance<R>, &'static ModelInfo) {
    instance::started::<R>("stops", values)
}

fn get<R: mbfmu::model::System>(inst: &Instance<R>, info: &ModelInfo, name: &str) -> f64 {
    instance::value_of(inst, info, name)
}

/// The potential energy of the bob at q (V = 0 at the base origin).
fn potential(q: f64) -> f64 {
    -M * G * L * q.cos()
}

/// Restitution 0: the impact at the stop takes all the kinetic energy; then the bob rests
/// on the stop exactly (q = 0.5, q̇ = 0 to the last bit) with the reaction m g l sin 0.5
/// pushing it up, and a torque beyond that pulls it off.
#[test]
fn a_pendulum_comes_to_rest_on_its_stop_and_leaves_when_pulled() {
    let (mut inst, info) = instance::<P>(&[]);
    let e0 = get(&inst, info, "E");
    assert!((e0 - potential(RELEASE)).abs() < 1e-15);
    // To the impact (FMI 3.0's early return), then past it.
    assert_eq!(
        inst.do_step_until_event(0.0, 1.0).unwrap(),
        StepOutcome::Completed
    );
    let t_hit = inst.time();
    assert!(t_hit > 0.1 && t_hit < 1.0, "{t_hit}");
    assert_eq!(get(&inst, info, "swing"), STOP);
    assert_eq!(get(&inst, info, "swing_dot"), 0.0);
    assert_eq!(get(&inst, info, "E"), potential(STOP));
    let mut t = t_hit;
    for _ in 0..20 {
        assert_eq!(inst.do_step(t, 0.05).unwrap(), StepOutcome::Completed);
        t += 0.05;
        assert_eq!(get(&inst, info, "swing"), STOP);
        assert_eq!(get(&inst, info, "swing_dot"), 0.0);
        assert_eq!(get(&inst, info, "der(swing_dot)"), 0.0);
    }
    let hold = M * G * L * STOP.sin();
    let reaction = get(&inst, info, "tau_stop_swing");
    assert!(
        (reaction - hold).abs() < 1e-12 * hold,
        "{reaction} vs {hold}"
    );
    // A torque that pulls harder than gravity: it leaves, and the stop lets go.
    let vr = info.layout.vr_of("tau_swing").unwrap();
    inst.set_real(&[vr], &[2.0 * hold]).unwrap();
    assert_eq!(inst.do_step(t, 0.05).unwrap(), StepOutcome::Completed);
    assert!(get(&inst, info, "swing") > STOP);
    assert!(get(&inst, info, "swing_dot") > 0.0);
    assert_eq!(get(&inst, info, "tau_stop_swing"), 0.0);
}

/// Restitution e: at the impact the velocity becomes −e times what it was (kinetic energy
/// × e²), so the bob rises to e² of its release height above the stop; the bounces that
/// follow (heights e⁴, e⁶ … of it) end resting on the stop.
#[test]
fn a_pendulum_bounces_to_e_squared_of_its_height() {
    let e = 0.6;
    let (mut inst, info) = instance::<P>(&[("restitution", e)]);
    let e0 = get(&inst, info, "E");
    inst.do_step_until_event(0.0, 1.0).unwrap();
    let t_hit = inst.time();
    assert_eq!(get(&inst, info, "swing"), STOP);
    let kinetic_before = e0 - potential(STOP);
    let kinetic_after = get(&inst, info, "E") - potential(STOP);
    assert!(
        (kinetic_after - e * e * kinetic_before).abs() < 1e-9 * kinetic_before,
        "{kinetic_after} vs {}",
        e * e * kinetic_before
    );
    assert!(get(&inst, info, "swing_dot") > 0.0);
    // The highest point of the rebound, sampled finely: its height above the stop.
    let (mut t, h) = (t_hit, 1e-3);
    let mut top: f64 = STOP;
    while get(&inst, info, "swing_dot") >= 0.0 {
        inst.do_step(t, h).unwrap();
        t += h;
        top = top.max(get(&inst, info, "swing"));
    }
    let height = |q: f64| L * (STOP.cos() - q.cos());
    let want = e * e * height(RELEASE);
    // Sampled every ms: the top is missed by at most ½ q̈ (0.5 ms)² in q.
    assert!(
        (height(top) - want).abs() < 1e-6 * height(RELEASE),
        "{} vs {want}",
        height(top)
    );
    // Energy is kept between impacts.
    let e1 = get(&inst, info, "E");
    assert!((e1 - (potential(STOP) + e * e * kinetic_before)).abs() < 1e-9);
    // The bounces (geometric: each e² of the last) end on the stop within a few seconds,
    // one doStep taking many of them.
    assert_eq!(inst.do_step(t, 5.0).unwrap(), StepOutcome::Completed);
    assert_eq!(get(&inst, info, "swing"), STOP);
    assert_eq!(get(&inst, info, "swing_dot"), 0.0);
}

/// A block pushed up by 20 N from rest hits its upper stop at t* = √(0.4 / (20 − g)) and
/// rests there: the stop's reaction is −(20 − g) N (`limit_events = 1` and 0, discard and
/// ignore, in tests/urdf_fmu.rs).
#[test]
fn a_block_rests_on_its_upper_stop() {
    let a = 20.0 - G;
    let t_star = (0.4f64 / a).sqrt();
    let (mut inst, info) = instance::<B>(&[("tau_lift", 20.0)]);
    inst.do_step_until_event(0.0, 1.0).unwrap();
    assert!((inst.time() - t_star).abs() < 1e-9, "{}", inst.time());
    assert_eq!(
        inst.do_step(inst.time(), 1.0).unwrap(),
        StepOutcome::Completed
    );
    assert_eq!(get(&inst, info, "lift"), 0.2);
    assert_eq!(get(&inst, info, "lift_dot"), 0.0);
    let reaction = get(&inst, info, "tau_stop_lift");
    assert!((reaction + a).abs() < 1e-12 * a, "{reaction}");
}
