//! Bricard's mechanism, the IFToMM benchmark A04 ([`Bricard`]): five rods and six
//! revolute joints in one loop, whose closure equations are redundant everywhere.
//!
//! Five rods of 1 m and 1 kg, square section 0.1 m (inertia about the centre: m(2s²)/12
//! about the rod, m(L² + s²)/12 across), on the edges of a unit cube; gravity 9.81 m/s²
//! along −y; released from rest, 10 s (docs/iftomm-sources.md, "A04": the official
//! specification's body could not be retrieved, the numbers are those of three public
//! models that overlay the official curves). As a tree: `J1` turns rod 1 on the ground
//! at the origin about y, `J2` rod 2 on rod 1's tip (1, 0, 0) about z, `J3` rod 3 on rod
//! 2's tip P3 = (1, −1, 0) about x, `J4` rod 4 on (1, −1, 1) about y, `J5` rod 5 on
//! (0, −1, 1) about z; each angle right-handed about its axis, fixed in the parent. The
//! sixth joint, rod 5 on the ground at (0, 0, 1) about x, is the closure: `J6` holds rod
//! 5's point there (x, y, z) and `J6_axis` its point 1 m along the axis, (1, 0, 1), in y
//! and z — the five equations of a revolute joint.
//!
//! Grübler's count gives 6·5 − 5·6 = 0 degrees of freedom; the axes give the loop one. The
//! five residuals have rank four at every configuration (one of them is redundant, and
//! not always the same one), so initialisation solves them for four dependent joints
//! (`J2` … `J5`) by least squares, exact since the fifth equation follows from the
//! others, and the dynamics solve Gauss's principle with an LDLᵀ factorisation of
//! G M⁻¹ Gᵀ in the residuals' order that drops the row dependent on those before it
//! (`multibody::closed`). On the motion
//! `J1 = J3 = J5` runs from 0 to π and back (the cube and its mirror image in x = 0, where
//! the mechanism is at rest again), `J2 = J4` between 0 and −π/6; period 4.9917 s. The
//! stable equilibrium is half way, J1 = J3 = J5 = π/2, J2 = J4 = −π/6 (the potential's
//! minimum on the loop): the linearisation is taken there.

use crate::multibody::fmu::Robot;
use crate::multibody::{Body, Mechanism, Origin};

/// Every rod's length (m), mass (kg) and the side of its square section (m).
pub const LENGTH: f64 = 1.0;
pub const MASS: f64 = 1.0;
pub const SIDE: f64 = 0.1;
/// Gravity along −y (m/s²).
pub const G: f64 = 9.81;
/// The benchmark's span (s).
pub const END: f64 = 10.0;

/// The joints of the tree, in order: name, position in the parent's frame (the parent
/// rod's tip; the ground's origin for `J1`), axis.
const JOINTS: [(&str, [f64; 3], [f64; 3]); 5] = [
    ("J1", [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ("J2", [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
    ("J3", [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]),
    ("J4", [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
    ("J5", [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
];

/// Where each rod runs from its joint (unit vectors, in its frame: the world's at the
/// start).
const RODS: [[f64; 3]; 5] = [
    [1.0, 0.0, 0.0],
    [0.0, -1.0, 0.0],
    [0.0, 0.0, 1.0],
    [-1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
];

/// A uniform rod of [`LENGTH`] and square section [`SIDE`] from its frame's origin along
/// the unit vector `direction` (a frame axis).
fn rod(name: &str, direction: [f64; 3]) -> Body {
    let axial = MASS * 2.0 * SIDE * SIDE / 12.0;
    let across = MASS * (LENGTH * LENGTH + SIDE * SIDE) / 12.0;
    Body::new(name, MASS)
        .com(direction.map(|d| 0.5 * LENGTH * d))
        .inertia_diag(direction.map(|d| if d != 0.0 { axial } else { across }))
}

/// The rods, joints, the closure of the sixth joint and the marker P3.
pub fn mechanism() -> Mechanism {
    let mut m = Mechanism::new("Bricard")
        .gravity([0.0, -G, 0.0])
        .body(Body::massless("ground"));
    let mut parent = "ground".to_string();
    for (k, ((joint, at, axis), direction)) in JOINTS.iter().zip(RODS).enumerate() {
        let name = format!("rod{}", k + 1);
        m = m.body(rod(&name, direction)).continuous(
            joint,
            &parent,
            &name,
            Origin::xyz(*at),
            *axis,
        );
        parent = name;
    }
    // Rod 5 runs from (0, −1, 1) to the sixth joint at (0, 0, 1), about x.
    m = m
        .closure(
            "J6",
            "rod5",
            [0.0, LENGTH, 0.0],
            "ground",
            [0.0, 0.0, 1.0],
            "xyz",
        )
        .closure(
            "J6_axis",
            "rod5",
            [1.0, LENGTH, 0.0],
            "ground",
            [1.0, 0.0, 1.0],
            "yz",
        );
    // P3, rod 2's tip (where rod 3 hangs): a frame whose position is an output.
    m = m.body(Body::massless("P3")).fixed(
        "P3_on_rod2",
        "rod2",
        "P3",
        Origin::xyz([0.0, -LENGTH, 0.0]),
    );
    m = m.dependent(&["J2", "J3", "J4", "J5"]).outputs(&[
        "P3_x",
        "P3_y",
        "P3_z",
        "E",
        "residual_J6_x",
        "residual_J6_y",
        "residual_J6_z",
        "residual_J6_axis_y",
        "residual_J6_axis_z",
    ]);
    for (joint, ..) in JOINTS {
        m = m.torque(joint, 0.0);
    }
    m
}

/// The stable equilibrium: J1 = J3 = J5 = π/2, J2 = J4 = −π/6 (the loop closes there
/// exactly: rod 1 along −z, rod 2 turned 30° down from it, …).
pub fn equilibrium() -> [(&'static str, f64); 5] {
    let (half, sixth) = (std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_6);
    [
        ("J1", half),
        ("J2", -sixth),
        ("J3", half),
        ("J4", -sixth),
        ("J5", half),
    ]
}

crate::mechanism_fmu!(
    /// Bricard's mechanism's declaration (its FMU model is [`Bricard`]).
    pub BricardMechanism,
    "Bricard",
    mechanism,
    constraints = 5,
    notes = [
        "IFToMM benchmark A04, Bricard's mechanism: five rods of 1 m, 1 kg, square section 0.1 m, on the edges of a unit cube, six revolute joints in one loop; gravity 9.81 m/s² along −y; released from rest, 10 s",
        "J1 turns rod 1 about y at the origin, J2 rod 2 about z at (1, 0, 0), J3 rod 3 about x at P3 = (1, −1, 0), J4 rod 4 about y at (1, −1, 1), J5 rod 5 about z at (0, −1, 1); the sixth joint (rod 5 on the ground about x at (0, 0, 1)) is the closure J6 (x, y, z) with J6_axis (y, z at (1, 0, 1))",
        "Gruebler's count: 0 degrees of freedom; the axes give 1. The five residuals have rank 4 everywhere (redundant): J2 … J5 are solved from J1 by least squares, Gauss's principle drops the dependent row",
        "On the motion J1 = J3 = J5 runs 0 → π → 0, J2 = J4 between 0 and −π/6; period 4.9917 s; stable equilibrium J1 = J3 = J5 = π/2, J2 = J4 = −π/6",
    ],
    {
        const DESCRIPTION: &'static str =
            "Bricard's mechanism of the IFToMM benchmark A04: five rods, six revolute joints, one degree of freedom from redundant loop equations";
        const DEFAULT_EXPERIMENT: (f64, f64, f64) = (END, 1e-10, 0.05);
        crate::generated_closed_terms!(crate::systems::generated::bricard);

        fn linearization_point() -> Vec<(String, f64)> {
            equilibrium()
                .iter()
                .map(|&(joint, q)| (joint.to_string(), q))
                .collect()
        }
    }
);

/// Bricard's mechanism as a model: a [`Robot`] of its declaration.
pub type Bricard = Robot<BricardMechanism>;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::fmu::Declared;

    /// The generated closed terms against the interpreted path
    /// ([`crate::systems::check_generated_closed`]) on the closures, at the start and at
    /// the equilibrium, where the five residuals have rank 4 (the factorisation drops a
    /// row, as on the interpreted path). Not off them: there the residuals have rank 5
    /// on five coordinates, no motion is left (q̇ is taken to 0, q̈ is 0 but for rounding
    /// amplified by S's conditioning), nothing to compare.
    #[test]
    fn generated_closed_terms_equal_the_interpreted_path() {
        let start = BricardMechanism::built().start.clone();
        let rest: Vec<f64> = equilibrium().iter().map(|&(_, q)| q).collect();
        crate::systems::check_generated_closed::<BricardMechanism>(
            &[(start, 0.0), (rest, 0.0)],
            3.0,
            1.0,
            // Some derivatives along q̇ are 0 but for rounding (2.5e-16 measured): they
            // are held to the accelerations' scale, about 1 here, not their own.
            1.0,
        );
    }
}
