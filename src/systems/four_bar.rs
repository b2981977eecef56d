//! A planar four-bar linkage declared as bodies, joints and one loop closure ([`FourBar`]):
//! the multibody layer's loop closures on the smallest closed chain.
//!
//! Ground link O2O4 of length d along x, crank O2A (a) turning about O2 = (0, 0), coupler
//! AB (b) hinged to the crank at A, rocker O4B (c) turning about O4 = (d, 0); the coupler's
//! end B is held on the rocker's end by the closure `B` (x and y). Link lengths
//! a = 0.1, b = 0.35, c = 0.3, d = 0.4 m: s + l = a + d = 0.5 ≤ p + q = b + c = 0.65 with
//! the shortest link the crank, a Grashof crank-rocker (the crank turns fully, the rocker
//! swings, and the linkage never locks: the transmission angle stays inside (0, π)).
//! Uniform bars (1 cm square section) of 0.2, 0.7 and 0.6 kg; gravity along −y.
//!
//! Coordinates: `crank` (θ2, the crank's angle from x), `coupler` (the coupler's angle
//! relative to the crank: its absolute angle is θ3 = θ2 + coupler), `rocker` (θ4, the
//! rocker's angle from x). The closure determines `coupler` and `rocker` from `crank`
//! (the open configuration, B above the ground link, is picked by the start values);
//! `tau_crank` drives the crank. Freudenstein's equation relates θ4 to θ2 in closed form:
//! `K1 cos θ4 − K2 cos θ2 + K3 = cos(θ2 − θ4)`, `K1 = d/a`, `K2 = d/c`,
//! `K3 = (a² − b² + c² + d²)/(2ac)`.

use crate::multibody::fmu::Robot;
use crate::multibody::{Body, Mechanism, Origin};

/// Crank O2A (m).
pub const A: f64 = 0.1;
/// Coupler AB (m).
pub const B: f64 = 0.35;
/// Rocker O4B (m).
pub const C: f64 = 0.3;
/// Ground link O2O4 (m).
pub const D: f64 = 0.4;
/// The bars' masses (kg): crank, coupler, rocker.
pub const MASSES: [f64; 3] = [0.2, 0.7, 0.6];
/// The bars' square section (m).
const SECTION: f64 = 0.01;
/// The crank angle (rad) at which [`mechanism`] holds the linkage at rest by
/// `tau_crank`'s start value, a stable equilibrium (V(θ2) is convex there, V'' ≈ 0.75 J; at
/// θ2 = 1 rad it is concave and a held start would drift off at rounding, growing like
/// e^{~10 t}).
pub const CRANK_START: f64 = -1.5;
/// The crank angle and speed (rad, rad/s) the FMU (its default experiment and its `run`
/// scene) starts from, no torques: enough to carry it over the top again and again.
pub const RUN_START: f64 = 1.0;
pub const RUN_SPEED: f64 = 10.0;

/// A uniform bar of `length` along its x axis from the frame origin.
fn bar(name: &str, mass: f64, length: f64) -> Body {
    let w2 = SECTION * SECTION;
    Body::new(name, mass)
        .com([0.5 * length, 0.0, 0.0])
        .inertia_diag([
            mass * 2.0 * w2 / 12.0,
            mass * (length * length + w2) / 12.0,
            mass * (length * length + w2) / 12.0,
        ])
}

/// The four-bar's bodies, joints and closure.
pub fn mechanism() -> Mechanism {
    let z = [0.0, 0.0, 1.0];
    Mechanism::new("FourBar")
        .gravity([0.0, -9.81, 0.0])
        .body(Body::massless("ground"))
        .body(bar("crank_bar", MASSES[0], A))
        .body(bar("coupler_bar", MASSES[1], B))
        .body(bar("rocker_bar", MASSES[2], C))
        .continuous("crank", "ground", "crank_bar", Origin::IDENTITY, z)
        .continuous(
            "coupler",
            "crank_bar",
            "coupler_bar",
            Origin::xyz([A, 0.0, 0.0]),
            z,
        )
        .continuous(
            "rocker",
            "ground",
            "rocker_bar",
            Origin::xyz([D, 0.0, 0.0]),
            z,
        )
        .closure(
            "B",
            "coupler_bar",
            [B, 0.0, 0.0],
            "rocker_bar",
            [C, 0.0, 0.0],
            "xy",
        )
        .dependent(&["coupler", "rocker"])
        .start("crank", CRANK_START)
        // First guesses of the open configuration (solved exactly when built).
        .start("coupler", 2.55)
        .start("rocker", 2.39)
}

/// The four-bar of the FMU: [`mechanism`] started at θ2 = [`RUN_START`] turning at
/// [`RUN_SPEED`] with no torques, so that its default experiment moves (the dependent
/// positions from their closed form, as Newton's first guess on the open branch; their
/// rates are solved from the crank's).
pub fn running() -> Mechanism {
    let rocker = freudenstein_rocker(RUN_START);
    mechanism()
        .start("crank", RUN_START)
        .start("coupler", open_coupler(RUN_START, rocker))
        .start("rocker", rocker)
        .start_velocity("crank", RUN_SPEED)
        .torque("crank", 0.0)
}

/// The coupler's angle relative to the crank (rad) where the crank is at `crank` and the
/// rocker at `rocker`: the direction from A to B.
fn open_coupler(crank: f64, rocker: f64) -> f64 {
    let (bx, by) = (D + C * rocker.cos(), C * rocker.sin());
    (by - A * crank.sin()).atan2(bx - A * crank.cos()) - crank
}

/// The dependent positions of the linkage held at θ2 = [`CRANK_START`], from their closed
/// form (Newton from the running start does not reach them): `coupler`, `rocker`.
fn held_dependent_positions() -> [(&'static str, f64); 2] {
    let rocker = freudenstein_rocker(CRANK_START);
    [
        ("coupler", open_coupler(CRANK_START, rocker)),
        ("rocker", rocker),
    ]
}

crate::mechanism_fmu!(
    /// The four-bar's declaration (its FMU model is [`FourBar`]).
    pub FourBarMechanism,
    "FourBar",
    running,
    constraints = 2,
    notes = [
        "Planar four-bar, Grashof crank-rocker: crank a = 0.1 m about O2 = (0, 0), coupler b = 0.35 m, rocker c = 0.3 m about O4 = (0.4, 0); uniform bars of 0.2, 0.7, 0.6 kg; gravity along −y",
        "crank = θ2 and rocker = θ4 from the x axis, coupler = θ3 − θ2 relative to the crank; closure B: the coupler's end on the rocker's end (x, y); coupler and rocker are dependent",
        "Freudenstein: K1 cos θ4 − K2 cos θ2 + K3 = cos(θ2 − θ4), K1 = d/a, K2 = d/c, K3 = (a² − b² + c² + d²)/(2ac)",
    ],
    {
        const DESCRIPTION: &'static str =
            "Planar four-bar linkage (Grashof crank-rocker) declared as bodies, joints and one loop closure, with gravity and a crank torque";
        crate::generated_closed_terms!(crate::systems::generated::four_bar);

        /// The linkage held at rest at θ2 = CRANK_START by its holding torques
        /// (HeldFourBar's start values, the dependent positions from their closed form): a
        /// stable equilibrium (V convex there), which the running start is not.
        fn linearization_point() -> Vec<(String, f64)> {
            let held = HeldFourBar::built();
            let dependent = held_dependent_positions().map(|(n, v)| (n.to_string(), v));
            held.coordinates
                .iter()
                .chain(&held.velocities)
                .chain(&held.inputs)
                .map(|v| (v.name.to_string(), v.start))
                .chain(dependent)
                .collect()
        }

        fn scenes(generated: Vec<crate::model::Scene>) -> Vec<crate::model::Scene> {
            // `step` from the linkage held at θ2 = CRANK_START (held at the running start,
            // 1 rad, the equilibrium is unstable), its dependent positions said too:
            // Newton from the running start does not reach them.
            let [coupler, rocker] = held_dependent_positions();
            let held_step = HeldFourBar::built()
                .scenes
                .iter()
                .find(|s| s.name == "step")
                .cloned()
                .map(|s| s.set(coupler.0, coupler.1).set(rocker.0, rocker.1));
            let mut generated: Vec<crate::model::Scene> = generated
                .into_iter()
                .flat_map(|s| if s.name == "step" { held_step.clone() } else { Some(s) })
                .collect();
            // The default experiment's start, every value said (scripts name this scene):
            // the dependent positions too (their closed form, which initialisation keeps),
            // so that Newton starts on the open branch.
            let rocker = freudenstein_rocker(RUN_START);
            let coupler = open_coupler(RUN_START, rocker);
            generated.push(
                crate::model::Scene::new(
                    "run",
                    "The crank started at 10 rad/s from θ2 = 1 rad, no torques: it turns over the top again and again, energy conserved",
                    2.0,
                )
                .set("crank", RUN_START)
                .set("coupler", coupler)
                .set("rocker", rocker)
                .set("crank_dot", RUN_SPEED)
                .set("tau_crank", 0.0)
                .set("tau_coupler", 0.0)
                .set("tau_rocker", 0.0),
            );
            generated
        }
    }
);

crate::mechanism_fmu!(
    /// The linkage held at rest at θ2 = [`CRANK_START`] by its start torques ([`mechanism`]):
    /// what FourBar's `step` scene starts from.
    pub HeldFourBar,
    "FourBar",
    mechanism,
    constraints = 2
);

/// The four-bar as a model: a [`Robot`] of its declaration.
pub type FourBar = Robot<FourBarMechanism>;

/// θ4 from θ2 by Freudenstein's equation, the open configuration (B above O2O4 where the
/// crank is up): with `P = cos θ2 − K1 − K2 cos θ2 + K3`, `Q = −2 sin θ2`,
/// `R = K1 − (K2 + 1) cos θ2 + K3`, `θ4 = 2 atan((−Q − √(Q² − 4PR)) / (2P))`.
pub fn freudenstein_rocker(theta2: f64) -> f64 {
    let (k1, k2) = (D / A, D / C);
    let k3 = (A * A - B * B + C * C + D * D) / (2.0 * A * C);
    let (s, c) = theta2.sin_cos();
    let p = c - k1 - k2 * c + k3;
    let q = -2.0 * s;
    let r = k1 - (k2 + 1.0) * c + k3;
    2.0 * ((-q - (q * q - 4.0 * p * r).sqrt()) / (2.0 * p)).atan()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::fmu::Declared;

    /// The generated closed terms against the interpreted path
    /// ([`crate::systems::check_generated_closed`]) on and off the closures.
    #[test]
    fn generated_closed_terms_equal_the_interpreted_path() {
        let start = FourBarMechanism::built().start.clone();
        crate::systems::check_generated_closed::<FourBarMechanism>(
            &[(start.clone(), 0.0), (start, 1.0)],
            20.0,
            1.0,
            f64::MIN_POSITIVE,
        );
    }
}
