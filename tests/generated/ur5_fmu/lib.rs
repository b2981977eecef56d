//! ur5: a mechanism as bodies and joints, from src/multibody/generated/urdf/ur5.urdf (`mbfmu build --urdf src/multibody/generated/urdf/ur5.urdf`).
//! Edit it (a mass, an origin, a damping, a limit; add a link and its joint), then build
//! the FMU:
//!
//! ```text
//! mbfmu build --manifest-path Cargo.toml      # writes target/fmu/ur5.fmu
//! ```
//!
//! Bodies are URDF links: mass (kg), centre of mass and inertia about it (kg m²) in the
//! link frame. A joint's origin places its frame (= the child link's frame) in the parent
//! link's frame: `Origin::new(xyz, rpy)` as URDF's `<origin>`; the axis is in that frame.
//! Joint kinds: revolute, continuous, prismatic, fixed (fixed joints merge their links).
//! The FMU: one coordinate per moving joint (named as the joint) and its `_dot`, an input
//! `tau_JOINT` per joint (effort limits as min/max), outputs `E` and the pose of the end of
//! each branch (`LINK_x` … `LINK_q3`); README.md says more.

#[allow(unused_imports)]
use mbfmu::multibody::{Body, Joint, JointKind, Limit, Mechanism, Origin};

/// q̈ generated for `mechanism()` below (straight-line code; `mbfmu build` rewrites it when
/// the mechanism changes, and until then the articulated-body algorithm runs instead).
#[rustfmt::skip]
#[allow(dead_code, clippy::all, clippy::approx_constant, clippy::excessive_precision, clippy::unreadable_literal)]
mod dynamics;

mbfmu::mechanism_fmu!(
    /// The mechanism; its FMU is ur5.fmu.
    pub Ur5,
    "ur5",
    mechanism,
    notes = ["Velocity limits of 6 joints are not enforced (the build warning names them)"],
    {
        const GENERATED_FROM: Option<u64> = Some(dynamics::FINGERPRINT);
        fn generated_aba<S: mbfmu::model::Scalar>(q: &[S], qd: &[S], tau: &[S], qdd: &mut [S]) -> bool {
            dynamics::aba(q, qd, tau, qdd);
            true
        }
    }
);

/// The bodies and joints.
#[rustfmt::skip]
fn mechanism() -> Mechanism {
    Mechanism::new("ur5")
        .body(Body::new("base_link", 4.0)
            .inertia_diag([0.00443333156, 0.00443333156, 0.0072]))
        .body(Body::new("shoulder_link", 3.7)
            .inertia_diag([0.010267495893, 0.010267495893, 0.00666]))
        .body(Body::new("upper_arm_link", 8.393)
            .com([0.0, 0.0, 0.28])
            .inertia_diag([0.22689067591, 0.22689067591, 0.0151074]))
        .body(Body::new("forearm_link", 2.275)
            .com([0.0, 0.0, 0.25])
            .inertia_diag([0.049443313556, 0.049443313556, 0.004095]))
        .body(Body::new("wrist_1_link", 1.219)
            .inertia_diag([0.111172755531, 0.111172755531, 0.21942]))
        .body(Body::new("wrist_2_link", 1.219)
            .inertia_diag([0.111172755531, 0.111172755531, 0.21942]))
        .body(Body::new("wrist_3_link", 0.1879)
            .inertia_diag([0.0171364731454, 0.0171364731454, 0.033822]))
        .body(Body::massless("ee_link"))
        .body(Body::massless("base"))
        .body(Body::massless("tool0"))
        .body(Body::massless("world"))
        .joint(Joint::new("shoulder_pan_joint", JointKind::Revolute, "base_link", "shoulder_link", Origin::new([0.0, 0.0, 0.089159], [0.0, 0.0, 0.0]))
            .axis([0.0, 0.0, 1.0])
            .limit(Limit { lower: Some(-6.28318530718), upper: Some(6.28318530718), effort: Some(150.0), velocity: Some(3.15) }))
        .joint(Joint::new("shoulder_lift_joint", JointKind::Revolute, "shoulder_link", "upper_arm_link", Origin::new([0.0, 0.13585, 0.0], [0.0, 1.57079632679, 0.0]))
            .axis([0.0, 1.0, 0.0])
            .limit(Limit { lower: Some(-6.28318530718), upper: Some(6.28318530718), effort: Some(150.0), velocity: Some(3.15) }))
        .joint(Joint::new("elbow_joint", JointKind::Revolute, "upper_arm_link", "forearm_link", Origin::new([0.0, -0.1197, 0.425], [0.0, 0.0, 0.0]))
            .axis([0.0, 1.0, 0.0])
            .limit(Limit { lower: Some(-3.14159265359), upper: Some(3.14159265359), effort: Some(150.0), velocity: Some(3.15) }))
        .joint(Joint::new("wrist_1_joint", JointKind::Revolute, "forearm_link", "wrist_1_link", Origin::new([0.0, 0.0, 0.39225], [0.0, 1.57079632679, 0.0]))
            .axis([0.0, 1.0, 0.0])
            .limit(Limit { lower: Some(-6.28318530718), upper: Some(6.28318530718), effort: Some(28.0), velocity: Some(3.2) }))
        .joint(Joint::new("wrist_2_joint", JointKind::Revolute, "wrist_1_link", "wrist_2_link", Origin::new([0.0, 0.093, 0.0], [0.0, 0.0, 0.0]))
            .axis([0.0, 0.0, 1.0])
            .limit(Limit { lower: Some(-6.28318530718), upper: Some(6.28318530718), effort: Some(28.0), velocity: Some(3.2) }))
        .joint(Joint::new("wrist_3_joint", JointKind::Revolute, "wrist_2_link", "wrist_3_link", Origin::new([0.0, 0.0, 0.09465], [0.0, 0.0, 0.0]))
            .axis([0.0, 1.0, 0.0])
            .limit(Limit { lower: Some(-6.28318530718), upper: Some(6.28318530718), effort: Some(28.0), velocity: Some(3.2) }))
        .joint(Joint::new("ee_fixed_joint", JointKind::Fixed, "wrist_3_link", "ee_link", Origin::new([0.0, 0.0823, 0.0], [0.0, 0.0, 1.57079632679])))
        .joint(Joint::new("base_link-base_fixed_joint", JointKind::Fixed, "base_link", "base", Origin { xyz: [0.0, 0.0, 0.0], rotation: [[-1.0, -2.0682310711021444e-13, 0.0], [2.0682310711021444e-13, -1.0, 0.0], [-0.0, 0.0, 1.0]] } /* rpy ≈ [0.0, 0.0, 3.1415926535895866] */))
        .joint(Joint::new("wrist_3_link-tool0_fixed_joint", JointKind::Fixed, "wrist_3_link", "tool0", Origin::new([0.0, 0.0823, 0.0], [-1.57079632679, 0.0, 0.0])))
        .joint(Joint::new("world_joint", JointKind::Fixed, "world", "base_link", Origin::new([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])))
}

// The complete FMI 2.0 Co-Simulation API of this cdylib, and the description the
// packager reads from it (`mbfmu build`).
mbfmu::export_fmu!(mechanism Ur5);
