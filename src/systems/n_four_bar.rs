//! The N four-bar mechanism of the IFToMM benchmark A02 ([`NFourBar`]): N = 40 four-bar
//! windows side by side, a loop of closures that passes singular positions twice a turn.
//!
//! N + 1 = 41 vertical cranks A_i B_i on ground pivots A_i = (i, 0), i = 0…N, and N
//! horizontal couplers B_{i−1} B_i; every rod 1 m and 1 kg, uniform; gravity 9.81 m/s²
//! along −y (docs/iftomm-sources.md, from the benchmark's specification A02). As a tree:
//! crank i turns on the ground about A_i (joint `crank{i}`), coupler i hangs from crank
//! i − 1's tip B_{i−1} (joint `coupler{i}`, its angle relative to that crank), and the
//! closure `B{i}` holds coupler i's far end on crank i's tip B_i (x, y). `crank0` is the
//! independent coordinate; the 2N others are dependent.
//!
//! Starts with every crank vertical and B0 moving along +x at 1 m/s (ẋ(B0) = 1: every
//! crank at −1 rad/s, every coupler translating), no torques, 20 s. When the cranks are
//! horizontal the closures' Jacobian loses N of its 2N rows (the mechanism has N + 1
//! degrees of freedom for an instant) and a solver must keep to the branch on which
//! every crank has the same angle θ. On it the mechanism is one pendulum:
//! `J θ̈ = P sin θ` with `J = (N + 1) m L²/3 + N m L²` and `P = m g L ((N + 1)/2 + N)`
//! (θ from the vertical, clockwise), B0 = (sin θ, cos θ).
//!
//! Its FMU declares the specification's outputs only: `B0_x`, `B0_y` and `E` (its 41 link
//! poses and 160 closure residuals and forces are computed but not declared: no scene of
//! the benchmark is about them).

use crate::multibody::fmu::Robot;
use crate::multibody::{Body, Mechanism, Origin};

/// Four-bar windows.
pub const N: usize = 40;
/// Every rod's length (m) and mass (kg).
pub const LENGTH: f64 = 1.0;
pub const MASS: f64 = 1.0;
/// Gravity along −y (m/s²).
pub const G: f64 = 9.81;
/// The benchmark's span (s).
pub const END: f64 = 20.0;

/// A uniform slender rod of [`LENGTH`] from its frame's origin along `direction`: its
/// moment about z (the only one planar motion feels) is m L²/12 about its centre; the
/// moments about x and y are given the same value (they act on no planar motion).
fn rod(name: &str, direction: [f64; 3]) -> Body {
    let c = direction.map(|d| 0.5 * LENGTH * d);
    Body::new(name, MASS)
        .com(c)
        .inertia_diag([MASS * LENGTH * LENGTH / 12.0; 3])
}

/// The cranks, couplers, closures and the marker B0.
pub fn mechanism() -> Mechanism {
    let z = [0.0, 0.0, 1.0];
    let mut m = Mechanism::new("NFourBar")
        .gravity([0.0, -G, 0.0])
        .body(Body::massless("ground"));
    for i in 0..=N {
        m = m
            .body(rod(&format!("crank{i}_rod"), [0.0, 1.0, 0.0]))
            .continuous(
                &format!("crank{i}"),
                "ground",
                &format!("crank{i}_rod"),
                Origin::xyz([i as f64 * LENGTH, 0.0, 0.0]),
                z,
            );
    }
    for i in 1..=N {
        m = m
            .body(rod(&format!("coupler{i}_rod"), [1.0, 0.0, 0.0]))
            .continuous(
                &format!("coupler{i}"),
                &format!("crank{}_rod", i - 1),
                &format!("coupler{i}_rod"),
                Origin::xyz([0.0, LENGTH, 0.0]),
                z,
            )
            .closure(
                &format!("B{i}"),
                &format!("coupler{i}_rod"),
                [LENGTH, 0.0, 0.0],
                &format!("crank{i}_rod"),
                [0.0, LENGTH, 0.0],
                "xy",
            );
    }
    // B0, crank 0's tip: a frame whose position is an output (B0_x, B0_y).
    m = m.body(Body::massless("B0")).fixed(
        "B0_on_crank0",
        "crank0_rod",
        "B0",
        Origin::xyz([0.0, LENGTH, 0.0]),
    );
    let dependent: Vec<String> = (1..=N)
        .map(|i| format!("crank{i}"))
        .chain((1..=N).map(|i| format!("coupler{i}")))
        .collect();
    let dependent: Vec<&str> = dependent.iter().map(String::as_str).collect();
    m = m
        .dependent(&dependent)
        .start_velocity("crank0", -1.0)
        .outputs(&["B0_x", "B0_y", "E"]);
    for i in 0..=N {
        m = m.torque(&format!("crank{i}"), 0.0);
    }
    for i in 1..=N {
        m = m.torque(&format!("coupler{i}"), 0.0);
    }
    m
}

crate::mechanism_fmu!(
    /// The N four-bar's declaration (its FMU model is [`NFourBar`]).
    pub NFourBarMechanism,
    "NFourBar",
    mechanism,
    constraints = 2 * N,
    notes = [
        "IFToMM benchmark A02, the N four-bar: N = 40 windows, 41 vertical cranks on ground pivots A_i = (i, 0) and 40 couplers B_{i-1}B_i; every rod 1 m, 1 kg, uniform; gravity 9.81 m/s² along −y",
        "crank{i} turns crank i about A_i (from the vertical at 0); coupler{i} is coupler i's angle relative to crank i − 1, on whose tip it hangs; closure B{i} holds its far end on crank i's tip (x, y); crank0 independent, the 80 others dependent",
        "Start: every crank vertical, crank0_dot = −1 rad/s (B0 along +x at 1 m/s), no torques, 20 s; the cranks are horizontal (a singular position: the closures' Jacobian loses 40 of its 80 rows) twice a turn",
        "On the branch every crank keeps one angle θ: J θ̈ = P sin θ, J = (N + 1)/3 + N = 53.667 kg·m², P = g ((N + 1)/2 + N) = 593.505 N·m; B0 = (sin θ, cos θ)",
    ],
    {
        const DESCRIPTION: &'static str =
            "The N four-bar mechanism of the IFToMM benchmark A02 (N = 40): 81 rods, 40 loop closures, singular twice a turn";
        const DEFAULT_EXPERIMENT: (f64, f64, f64) = (END, 1e-8, 0.05);
    }
);

/// The N four-bar as a model: a [`Robot`] of its declaration.
pub type NFourBar = Robot<NFourBarMechanism>;

/// θ̈ / sin θ on the branch where every crank keeps one angle θ (the exact one-coordinate
/// reduction): `P / J`.
pub fn reduced_coefficient() -> f64 {
    let n = N as f64;
    let j = MASS * LENGTH * LENGTH * ((n + 1.0) / 3.0 + n);
    let p = MASS * G * LENGTH * ((n + 1.0) / 2.0 + n);
    p / j
}
