//! The nonlinear Whipple bicycle of the benchmark (Meijaard, Papadopoulos, Ruina, Schwab,
//! Proc. R. Soc. A 463 (2007) 1955–1982; systems.md section 12), written as a
//! [`Lagrangian`]: four rigid bodies placed by rotations, the kinetic energy from their
//! poses ([`kinematics`]), gravity, the front wheel's ground contact as a holonomic
//! constraint and the rolling of both wheels as four velocity constraints. No equation of
//! motion is derived by hand; [`WhippleBicycle`](super::WhippleBicycle) is the paper's
//! linearisation, an independent derivation this one must meet (tests/nonlinear_bicycle.rs).
//!
//! # Geometry (the benchmark's axes: X forward, Y right, Z down)
//!
//! ```text
//! q = (x, y, yaw ψ, roll φ, pitch θ, steer δ, rear_wheel θR, front_wheel θF)
//! R_B = Rz(ψ) Rx(φ) Ry(θ)                 rear frame; its origin the rear wheel centre
//! C_R = (x, y, 0) + Rz(ψ) Rx(φ) (0, 0, −rR)
//! R_H = R_B R_u(δ), u = (sin λ, 0, cos λ)  the steer axis through (w + c, 0, rR) in B
//! R_R = R_B Ry(θR), R_F = R_H Ry(θF)       wheels turn about their axles
//! ```
//!
//! Every point of B and H is placed by its reference-configuration coordinates (Table 1:
//! `(xB, 0, zB)`, `(xH, 0, zH)`, front wheel centre `(w, 0, −rF)`, relative to the rear
//! contact), and the inertias of Table 1 are body-fixed in those axes. The front contact
//! is the lowest point of the front wheel, `C_F + rF d` with `d` the unit vector in the
//! wheel plane pointing most downward (`|e_z − a_z a|`, a the front axle):
//! `Φ = z(C_F) + rF √(1 − a_z²) = 0`. Rolling: the material point of each wheel at its
//! contact has no horizontal velocity.

use crate::model::kinematics::{
    self, add, along, apply, column, constant, mul, point_velocity, rot_axis, rot_x, rot_y, rot_z,
    scale, sub, vec3, Inertia, Pose, Vec3,
};
use crate::model::lagrangian::{self, Lagrangian};
use crate::model::{Scalar, Scene, Var};
use std::f64::consts::PI;

pub struct NonlinearBicycle;

/// Coordinate indices.
const X: usize = 0;
const Y: usize = 1;
const YAW: usize = 2;
const ROLL: usize = 3;
const PITCH: usize = 4;
const STEER: usize = 5;
const REAR: usize = 6;
const FRONT: usize = 7;
/// Coordinates.
const N: usize = 8;

/// Parameter indices (Table 1, the order of `WhippleBicycle` without `v`).
const W: usize = 0;
const C: usize = 1;
const LAMBDA: usize = 2;
const G: usize = 3;
const RR: usize = 4;
const XB: usize = 8;
const ZB: usize = 9;
const XH: usize = 15;
const ZH: usize = 16;
const RF: usize = 22;
const ROLL_MAX: usize = 26;
/// Parameters.
const P: usize = 27;

/// The four bodies where they are, and the two contact points.
struct Bicycle<T> {
    rear: Pose<T>,
    frame: Pose<T>,
    fork: Pose<T>,
    front: Pose<T>,
    rear_contact: Vec3<T>,
    front_contact: Vec3<T>,
}

/// Places the bodies at `q` (any scalar: `f64`, dual numbers moving along q̇, symbols).
fn place<T: Scalar>(q: &[T], p: &[T]) -> Bicycle<T> {
    let zero = T::from(0.0);
    let (r_r, r_f, lambda) = (p[RR], p[RF], p[LAMBDA]);
    let heading = mul(&rot_z(q[YAW]), &rot_x(q[ROLL]));
    let frame_rot = mul(&heading, &rot_y(q[PITCH]));
    let rear_contact = [q[X], q[Y], zero];
    let rear_centre = add(rear_contact, apply(&heading, [zero, zero, -r_r]));
    // A point of B given relative to the rear contact in the reference configuration.
    let in_frame = |v: Vec3<T>| {
        let from_axle = [v[0], v[1], v[2] + r_r];
        add(rear_centre, apply(&frame_rot, from_axle))
    };
    let axis = [lambda.sin(), zero, lambda.cos()];
    let steer_rot = rot_axis(axis, q[STEER]);
    let steer_point = [p[W] + p[C], zero, zero];
    // A point of H given like those of B, turned about the steer axis.
    let in_fork = |v: Vec3<T>| in_frame(add(steer_point, apply(&steer_rot, sub(v, steer_point))));
    let fork_rot = mul(&frame_rot, &steer_rot);
    let front_centre = in_fork([p[W], zero, -r_f]);
    // The lowest point of the front wheel: down the wheel plane from its centre.
    let axle = column(&fork_rot, 1);
    let down = sub(vec3(0.0, 0.0, 1.0), scale(axle[2], axle));
    let front_contact = add(
        front_centre,
        scale(r_f / (T::from(1.0) - axle[2] * axle[2]).sqrt(), down),
    );
    Bicycle {
        rear: Pose {
            com: rear_centre,
            rot: mul(&frame_rot, &rot_y(q[REAR])),
        },
        frame: Pose {
            com: in_frame([p[XB], zero, p[ZB]]),
            rot: frame_rot,
        },
        fork: Pose {
            com: in_fork([p[XH], zero, p[ZH]]),
            rot: fork_rot,
        },
        front: Pose {
            com: front_centre,
            rot: mul(&fork_rot, &rot_y(q[FRONT])),
        },
        rear_contact,
        front_contact,
    }
}

/// Masses and inertias of rear wheel, frame, fork, front wheel (Table 1; wheels
/// axisymmetric, `Izz = Ixx`).
fn inertias<S: Scalar>(p: &[S]) -> [Inertia<S>; 4] {
    let z = S::from(0.0);
    [
        Inertia::xz_symmetric(p[5], p[6], p[7], p[6], z),
        Inertia::xz_symmetric(p[10], p[11], p[12], p[13], p[14]),
        Inertia::xz_symmetric(p[17], p[18], p[19], p[20], p[21]),
        Inertia::xz_symmetric(p[23], p[24], p[25], p[24], z),
    ]
}

/// The bicycle placed at `q + ε q̇`: its ε parts are the velocities.
fn moving<S: Scalar>(q: &[S], qd: &[S], p: &[S]) -> Bicycle<num_dual::Dual<S>> {
    place(&along::<S, N>(q, qd), &constant::<S, P>(p))
}

/// The slip velocities of the wheels' material contact points, `(rear x, rear y, front x,
/// front y)` in world axes, of the bicycle placed at `q + ε q̇` ([`moving`]): the velocity
/// constraints, linear in q̇.
fn slips<S: Scalar>(moving: &Bicycle<num_dual::Dual<S>>) -> [S; 4] {
    let at = |c: Vec3<num_dual::Dual<S>>| c.map(|v| v.re);
    let rear = point_velocity(&moving.rear, at(moving.rear_contact));
    let front = point_velocity(&moving.front, at(moving.front_contact));
    [rear[0], rear[1], front[0], front[1]]
}

/// The bodies' poses and the contact points, for checks and pictures outside the model.
impl NonlinearBicycle {
    /// Poses of rear wheel, rear frame, front frame, front wheel at `q` (any scalar), then
    /// the rear and front contact points.
    pub fn poses<T: Scalar>(q: &[T], p: &[T]) -> ([Pose<T>; 4], [Vec3<T>; 2]) {
        let b = place(q, p);
        (
            [b.rear, b.frame, b.fork, b.front],
            [b.rear_contact, b.front_contact],
        )
    }

    /// Masses and inertia tensors (body axes) in the order of [`NonlinearBicycle::poses`].
    pub fn inertias<S: Scalar>(p: &[S]) -> [Inertia<S>; 4] {
        inertias(p)
    }
}

impl Lagrangian for NonlinearBicycle {
    /// Forces and outputs take t only into T, V and the constraints.
    const TIME_IN_FORCES_OR_OUTPUTS: bool = false;
    const NAME: &'static str = "NonlinearBicycle";
    crate::generated_eom!(crate::model::symbolic::generated::NonlinearBicycleEom);
    const DESCRIPTION: &'static str =
        "The nonlinear Whipple bicycle of the benchmark (Meijaard et al. 2007): four rigid bodies, knife-edge wheels rolling without slip, equations from its energies and constraints";
    const EQUATIONS: &'static [&'static str] = &[
        "q = (x, y, ψ, φ, θ, δ, θR, θF): rear contact point, yaw, roll (lean right positive), pitch of the rear frame (0 upright), steer (about the downward steer axis, right positive), rear and front wheel angles relative to their frames (rolling forward makes them decrease: v = −rR θ̇R)",
        "Axes X forward, Y right, Z down. R_B = Rz(ψ) Rx(φ) Ry(θ); rear wheel centre C_R = (x, y, 0) + Rz(ψ) Rx(φ) (0, 0, −rR); front frame R_H = R_B R_u(δ) about u = (sin λ, 0, cos λ) through (w + c, 0, 0); wheels R_B Ry(θR), R_H Ry(θF)",
        "Points and inertias of B and H are those of Table 1 in the reference configuration (upright, δ = 0), carried with their bodies",
        "T = Σ ½ m |v|² + ½ ωᵀ I ω over the four bodies, velocities by differentiating the poses along q̇ (dual numbers); V = −g Σ m z",
        "Holonomic: the front wheel touches the ground, z(C_F) + rF √(1 − a_z²) = 0 (a: front axle); it fixes θ given φ and δ",
        "Nonholonomic: the material contact point of each wheel has no horizontal velocity (4 constraints); so 3 velocity degrees of freedom φ̇, δ̇, θ̇R",
        "Generalised forces: T_phi on the roll, T_delta on the steer",
        "Equations of motion, formed by automatic differentiation of L = T − V: M q̈ + Gᵀ λ = Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇ with the constraints differentiated to acceleration level (λ-method); the state is projected back onto all five after every doStep",
        "Linearised about upright straight running at v = −rR θ̇R it reproduces the benchmark's M q̈ + v C1 q̇ + (g K0 + v² K2) q = f (WhippleBicycle): self-stable for 4.29 < v < 6.02 m/s",
        "Validity: the frame's and rider's contact with the ground is not modelled; at |φ| = roll_max the bicycle has fallen and doStep returns fmi2Discard there",
    ];

    fn parameters() -> Vec<Var> {
        let mut table_1 = <super::WhippleBicycle as crate::model::System>::parameters();
        table_1.retain(|v| v.name != "v");
        table_1.push(
            Var::new(
                "roll_max",
                Some("rad"),
                PI / 3.0,
                "Roll at which the bicycle counts as fallen (frame and rider would touch the ground): doStep stops there with fmi2Discard",
            )
            .min(1e-3)
            .max(1.5),
        );
        table_1
    }

    fn inputs() -> Vec<Var> {
        <super::WhippleBicycle as crate::model::System>::inputs()
    }

    fn coordinates() -> Vec<Var> {
        vec![
            Var::new("x", Some("m"), 0.0, "Rear contact point, forward").nominal(1.0),
            Var::new("y", Some("m"), 0.0, "Rear contact point, right").nominal(1.0),
            Var::new("yaw", Some("rad"), 0.0, "Heading of the rear frame").nominal(1.0),
            Var::new(
                "roll",
                Some("rad"),
                0.05,
                "Lean of the rear frame, right positive",
            )
            .nominal(0.1),
            Var::new(
                "pitch",
                Some("rad"),
                0.0,
                "Pitch of the rear frame about its lateral axis (computed: the front wheel touches the ground)",
            )
            .nominal(0.1)
            .dependent(),
            Var::new(
                "steer",
                Some("rad"),
                0.0,
                "Steer angle of the front frame about the steer axis, right positive",
            )
            .nominal(0.1),
            Var::new(
                "rear_wheel",
                Some("rad"),
                0.0,
                "Rear wheel angle relative to the rear frame",
            )
            .nominal(1.0),
            Var::new(
                "front_wheel",
                Some("rad"),
                0.0,
                "Front wheel angle relative to the front frame",
            )
            .nominal(1.0),
        ]
    }

    fn velocities() -> Vec<Var> {
        // Start values: the consistent ones of the default state (5 m/s, lean 0.05).
        let computed = |name, unit, start, what| {
            Var::new(name, Some(unit), start, what)
                .nominal(1.0)
                .dependent()
        };
        vec![
            computed(
                "x_dot",
                "m/s",
                5.0,
                "Rear contact velocity, forward (computed: rolling)",
            ),
            computed(
                "y_dot",
                "m/s",
                0.0,
                "Rear contact velocity, right (computed: rolling)",
            ),
            computed(
                "yaw_dot",
                "rad/s",
                0.0,
                "Yaw rate (computed: rolling of the front wheel)",
            ),
            Var::new("roll_dot", Some("rad/s"), 0.0, "Roll rate").nominal(1.0),
            computed(
                "pitch_dot",
                "rad/s",
                0.0,
                "Pitch rate (computed: the front wheel stays on the ground)",
            ),
            Var::new("steer_dot", Some("rad/s"), 0.0, "Steer rate").nominal(1.0),
            Var::new(
                "rear_wheel_dot",
                Some("rad/s"),
                -5.0 / 0.3,
                "Rear wheel rate relative to the rear frame (forward speed upright: −rR · rear_wheel_dot)",
            )
            .nominal(10.0),
            computed(
                "front_wheel_dot",
                "rad/s",
                -5.0 / 0.35,
                "Front wheel rate relative to the front frame (computed: rolling)",
            ),
        ]
    }

    fn outputs() -> Vec<Var> {
        vec![
            Var::new(
                "speed",
                Some("m/s"),
                0.0,
                "Forward speed of the rear contact point, ẋ cos ψ + ẏ sin ψ",
            ),
            Var::new("E", Some("J"), 0.0, "Mechanical energy T + V (V = 0 at the ground)"),
            Var::new(
                "residual_contact",
                Some("m"),
                0.0,
                "Height of the front wheel's lowest point below the ground (the holonomic constraint Φ)",
            ),
            Var::new(
                "residual_contact_rate",
                Some("m/s"),
                0.0,
                "dΦ/dt = G q̇",
            ),
            Var::new(
                "slip_rear_x",
                Some("m/s"),
                0.0,
                "Velocity of the rear wheel's material contact point, X",
            ),
            Var::new(
                "slip_rear_y",
                Some("m/s"),
                0.0,
                "Velocity of the rear wheel's material contact point, Y",
            ),
            Var::new(
                "slip_front_x",
                Some("m/s"),
                0.0,
                "Velocity of the front wheel's material contact point, X",
            ),
            Var::new(
                "slip_front_y",
                Some("m/s"),
                0.0,
                "Velocity of the front wheel's material contact point, Y",
            ),
        ]
    }

    fn kinetic<S: Scalar>(_t: S, q: &[S], qd: &[S], p: &[S]) -> S {
        let moving = moving(q, qd, p);
        let [rear, frame, fork, front] = inertias(p);
        kinematics::kinetic_energy(&moving.rear, &rear)
            + kinematics::kinetic_energy(&moving.frame, &frame)
            + kinematics::kinetic_energy(&moving.fork, &fork)
            + kinematics::kinetic_energy(&moving.front, &front)
    }

    fn potential<S: Scalar>(_t: S, q: &[S], p: &[S]) -> S {
        let b = place(q, p);
        let [rear, frame, fork, front] = inertias(p);
        -p[G]
            * (rear.mass * b.rear.com[2]
                + frame.mass * b.frame.com[2]
                + fork.mass * b.fork.com[2]
                + front.mass * b.front.com[2])
    }

    fn forces<S: Scalar>(_t: f64, _q: &[S], _qd: &[S], u: &[S], _p: &[S], out: &mut [S]) {
        out.fill(S::from(0.0));
        out[ROLL] = u[0];
        out[STEER] = u[1];
    }

    const CONSTRAINTS: usize = 1;

    fn constraints<S: Scalar>(_t: S, q: &[S], p: &[S], phi: &mut [S]) {
        phi[0] = place(q, p).front_contact[2];
    }

    const VELOCITY_CONSTRAINTS: usize = 4;

    fn velocity_constraints<S: Scalar>(_t: S, q: &[S], qd: &[S], p: &[S], out: &mut [S]) {
        out.copy_from_slice(&slips(&moving(q, qd, p)));
    }

    fn extra_outputs<S: Scalar>(t: f64, q: &[S], qd: &[S], _u: &[S], p: &[S], y: &mut [S]) {
        let moving = moving(q, qd, p);
        y[0] = qd[X] * q[YAW].cos() + qd[Y] * q[YAW].sin();
        y[1] = lagrangian::energy::<Self, S>(t, q, qd, p);
        y[2] = moving.front_contact[2].re;
        y[3] = moving.front_contact[2].eps;
        y[4..8].copy_from_slice(&slips(&moving));
    }

    fn scenes() -> Vec<Scene> {
        let r_r = 0.3;
        let at = |v: f64| -v / r_r;
        vec![
            Scene::new(
                "stable",
                "5 m/s, inside the self-stable speed range: a lean of 0.05 rad decays and the bicycle runs upright",
                10.0,
            )
            .set("rear_wheel_dot", at(5.0))
            .set("roll", 0.05),
            Scene::new(
                "weave",
                "2 m/s, below the weave speed: a lean of 0.05 rad grows fast; the bicycle falls (|roll| = roll_max, fmi2Discard) at t = 1.89 s, just after this scene ends",
                1.5,
            )
            .set("rear_wheel_dot", at(2.0))
            .set("roll", 0.05),
            Scene::new(
                "capsize",
                "8 m/s, above the capsize speed: a lean of 0.01 rad slowly grows, the bicycle spirals in",
                10.0,
            )
            .set("rear_wheel_dot", at(8.0))
            .set("roll", 0.01),
            Scene::new(
                "turn",
                "5 m/s upright, a steer torque of 0.1 N.m from the start: the bicycle settles into a steady turn",
                10.0,
            )
            .set("rear_wheel_dot", at(5.0))
            .set("roll", 0.0)
            .set("T_delta", 0.1),
        ]
    }

    fn default_experiment() -> (f64, f64, f64) {
        (10.0, 1e-8, 1e-2)
    }

    /// Positive while the lean is inside `roll_max`.
    fn event_indicator(_t: f64, q: &[f64], _qd: &[f64], _u: &[f64], p: &[f64]) -> Option<f64> {
        Some(p[ROLL_MAX] - q[ROLL].abs())
    }

    /// The lean reached `roll_max`: the bicycle has fallen, and the model (no frame or
    /// rider touching the ground) no longer holds.
    fn on_event(
        t: f64,
        _q: &mut [f64],
        _qd: &mut [f64],
        _u: &[f64],
        p: &[f64],
    ) -> Result<(), String> {
        Err(format!(
            "the bicycle has fallen: |roll| reached roll_max = {} rad at t = {t} s, where the frame and rider would touch the ground (not modelled)",
            p[ROLL_MAX]
        ))
    }
}
