//! A mechanism as data: rigid bodies joined in a tree by revolute, continuous, prismatic
//! and fixed joints, with URDF's conventions (a joint's child frame is its joint frame; a
//! joint's origin places that frame in the parent body's frame).
//!
//! Closed kinematic loops are not joints of the tree: a loop closure ([`Closure`],
//! [`Mechanism::closure`]) says that a point fixed in one body coincides with a point fixed
//! in another (or in the base) along some base-frame axes, and the model keeps it as a
//! holonomic constraint with its multipliers. Springs between bodies ([`Spring`]) add to
//! the potential energy. URDF has neither (it describes trees): only the builder declares
//! them.
//!
//! Written by hand with the builder ([`Mechanism::new`] … [`Mechanism::revolute`] …) or read
//! from a URDF file ([`super::urdf`]); [`Mechanism::validate`] checks it,
//! [`Mechanism::merge_fixed`] folds fixed joints away for the dynamics.

use super::spatial::{add, mat_mul, mat_vec, outer, scale, sub, transpose, M3, V3};
use std::fmt;

/// A rigid body (a URDF link).
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    pub name: String,
    /// kg; 0 for a massless frame.
    pub mass: f64,
    /// The centre of mass in the body frame (m).
    pub com: [f64; 3],
    /// The inertia about the centre of mass, in body-frame axes (kg m²).
    pub inertia: [[f64; 3]; 3],
}

impl Body {
    /// A massless body (a frame): what URDF calls a link with no `<inertial>`.
    pub fn massless(name: &str) -> Self {
        Body {
            name: name.to_string(),
            mass: 0.0,
            com: [0.0; 3],
            inertia: [[0.0; 3]; 3],
        }
    }

    /// A body of `mass` with its centre of mass at the frame origin and no inertia yet
    /// (set one with [`Body::inertia_diag`] or [`Body::inertia`]).
    pub fn new(name: &str, mass: f64) -> Self {
        Body {
            mass,
            ..Body::massless(name)
        }
    }

    pub fn com(mut self, com: [f64; 3]) -> Self {
        self.com = com;
        self
    }

    /// Principal moments about the centre of mass along the body axes.
    pub fn inertia_diag(mut self, d: [f64; 3]) -> Self {
        self.inertia = [[d[0], 0.0, 0.0], [0.0, d[1], 0.0], [0.0, 0.0, d[2]]];
        self
    }

    pub fn inertia(mut self, i: [[f64; 3]; 3]) -> Self {
        self.inertia = i;
        self
    }
}

/// How a joint moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum JointKind {
    /// A rotation about the axis (limits are data only: not enforced).
    Revolute,
    /// A rotation about the axis without limits; its coordinate is a plain angle.
    Continuous,
    /// A translation along the axis.
    Prismatic,
    /// No motion: the child is folded into the parent ([`Mechanism::merge_fixed`]).
    Fixed,
}

impl JointKind {
    pub fn name(self) -> &'static str {
        match self {
            JointKind::Revolute => "revolute",
            JointKind::Continuous => "continuous",
            JointKind::Prismatic => "prismatic",
            JointKind::Fixed => "fixed",
        }
    }
}

/// A rigid placement: `x_parent = rotation · x_child + xyz`. Written as URDF's xyz + rpy
/// ([`Origin::new`]); kept as a matrix so that placements compose exactly (merged fixed
/// joints).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Origin {
    pub xyz: [f64; 3],
    pub rotation: [[f64; 3]; 3],
}

impl Origin {
    pub const IDENTITY: Origin = Origin {
        xyz: [0.0; 3],
        rotation: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
    };

    /// URDF's `<origin xyz rpy>`: fixed-axis roll, pitch, yaw, `R = Rz(y) Ry(p) Rx(r)`.
    pub fn new(xyz: [f64; 3], rpy: [f64; 3]) -> Self {
        let (sr, cr) = rpy[0].sin_cos();
        let (sp, cp) = rpy[1].sin_cos();
        let (sy, cy) = rpy[2].sin_cos();
        Origin {
            xyz,
            rotation: [
                [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                [-sp, cp * sr, cp * cr],
            ],
        }
    }

    /// A translation only.
    pub fn xyz(xyz: [f64; 3]) -> Self {
        Origin {
            xyz,
            ..Origin::IDENTITY
        }
    }

    /// The roll, pitch, yaw of the rotation (pitch in [−π/2, π/2]; at ±π/2 roll is 0).
    pub fn rpy(&self) -> [f64; 3] {
        let r = &self.rotation;
        let pitch = (-r[2][0]).clamp(-1.0, 1.0).asin();
        if r[2][0].abs() > 1.0 - 1e-12 {
            [0.0, pitch, (-r[0][1]).atan2(r[1][1])]
        } else {
            [r[2][1].atan2(r[2][2]), pitch, r[1][0].atan2(r[0][0])]
        }
    }

    /// `self ∘ inner`: the placement of a frame given by `inner` in a frame placed by `self`.
    pub fn then(&self, inner: &Origin) -> Origin {
        Origin {
            xyz: add(&mat_vec(&self.rotation, &inner.xyz), &self.xyz),
            rotation: mat_mul(&self.rotation, &inner.rotation),
        }
    }
}

/// Optional joint limits, as URDF's `<limit>` (data only: the dynamics does not enforce
/// them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Limit {
    pub lower: Option<f64>,
    pub upper: Option<f64>,
    pub effort: Option<f64>,
    pub velocity: Option<f64>,
}

/// A joint between a parent and a child body.
#[derive(Clone, Debug, PartialEq)]
pub struct Joint {
    pub name: String,
    pub kind: JointKind,
    pub parent: String,
    pub child: String,
    /// The joint (= child) frame in the parent frame at zero joint position.
    pub origin: Origin,
    /// Unit axis in the joint frame (normalised by the builder and the URDF reader).
    pub axis: [f64; 3],
    /// Viscous damping: `τ_damp = −damping · q̇` (N m s/rad or N s/m).
    pub damping: f64,
    /// Coulomb friction (read and kept; not modelled by the dynamics yet).
    pub friction: f64,
    pub limit: Limit,
    /// URDF's `<mimic>`: the joint's position follows another joint's, and it has no
    /// coordinate of its own (ignored on a fixed joint).
    pub mimic: Option<Mimic>,
}

/// `q = multiplier · q_joint + offset`: a joint whose position follows joint `joint`'s
/// (URDF `<mimic joint multiplier offset>`, a gear or a coupled finger). Its velocity is
/// `multiplier · q̇_joint`; a force on it acts on `joint` through the multiplier.
#[derive(Clone, Debug, PartialEq)]
pub struct Mimic {
    pub joint: String,
    pub multiplier: f64,
    pub offset: f64,
}

impl Joint {
    pub fn new(name: &str, kind: JointKind, parent: &str, child: &str, origin: Origin) -> Self {
        Joint {
            name: name.to_string(),
            kind,
            parent: parent.to_string(),
            child: child.to_string(),
            origin,
            axis: [1.0, 0.0, 0.0],
            damping: 0.0,
            friction: 0.0,
            limit: Limit::default(),
            mimic: None,
        }
    }

    /// Sets the axis, normalised (a zero or non-finite axis is kept as given, and
    /// [`Mechanism::validate`] refuses it).
    pub fn axis(mut self, axis: [f64; 3]) -> Self {
        let n = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        self.axis = if n > 0.0 && n.is_finite() {
            [axis[0] / n, axis[1] / n, axis[2] / n]
        } else {
            axis
        };
        self
    }

    pub fn damping(mut self, damping: f64) -> Self {
        self.damping = damping;
        self
    }

    pub fn friction(mut self, friction: f64) -> Self {
        self.friction = friction;
        self
    }

    pub fn limit(mut self, limit: Limit) -> Self {
        self.limit = limit;
        self
    }

    /// Makes the joint follow `joint`: `q = multiplier · q_joint + offset` ([`Mimic`]).
    pub fn mimic(mut self, joint: &str, multiplier: f64, offset: f64) -> Self {
        self.mimic = Some(Mimic {
            joint: joint.to_string(),
            multiplier,
            offset,
        });
        self
    }

    /// Whether the joint moves (has a position, its own or a mimicked one).
    pub fn moves(&self) -> bool {
        self.kind != JointKind::Fixed
    }

    /// Whether the joint has a coordinate of its own: it moves and mimics no other.
    pub fn independent(&self) -> bool {
        self.moves() && self.mimic.is_none()
    }
}

/// What is wrong with a mechanism (or its URDF file): one line naming the element.
#[derive(Clone, Debug, PartialEq)]
pub struct Error {
    /// The file it was read from, if any.
    pub file: Option<String>,
    /// The line of that file where the element is.
    pub line: Option<usize>,
    /// The element, as `joint "elbow"` or `link "forearm"` (empty: the whole file).
    pub element: String,
    pub reason: String,
}

impl Error {
    pub fn new(element: String, reason: String) -> Self {
        Error {
            file: None,
            line: None,
            element,
            reason,
        }
    }

    pub fn joint(name: &str, reason: String) -> Self {
        Error::new(format!("joint \"{name}\""), reason)
    }

    pub fn link(name: &str, reason: String) -> Self {
        Error::new(format!("link \"{name}\""), reason)
    }

    pub fn in_file(mut self, file: &str) -> Self {
        self.file = Some(file.to_string());
        self
    }

    pub fn at_line(mut self, line: usize) -> Self {
        self.line = Some(line);
        self
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (&self.file, self.line) {
            (Some(file), Some(line)) => write!(f, "{file}:{line}: ")?,
            (Some(file), None) => write!(f, "{file}: ")?,
            (None, Some(line)) => write!(f, "line {line}: ")?,
            (None, None) => {}
        }
        if self.element.is_empty() {
            write!(f, "{}", self.reason)
        } else {
            write!(f, "{}: {}", self.element, self.reason)
        }
    }
}

impl std::error::Error for Error {}

/// A tree of bodies and joints hanging from one fixed root body.
#[derive(Clone, Debug, PartialEq)]
pub struct Mechanism {
    pub name: String,
    pub bodies: Vec<Body>,
    pub joints: Vec<Joint>,
    /// m/s², in the root frame.
    pub gravity: [f64; 3],
    /// Loop closures: constraints between bodies that close kinematic loops.
    pub closures: Vec<Closure>,
    /// Linear springs between points of two bodies (or a body and the base).
    pub springs: Vec<Spring>,
    /// The joints whose coordinates the closures determine (as many as closure
    /// residuals): consistent initialisation keeps the others as set and solves for these.
    pub dependent: Vec<String>,
    /// Start positions of joints (the rest start at 0, or mid-limits); with closures the
    /// dependent ones are a first guess, solved from the others.
    pub start: Vec<(String, f64)>,
    /// Start velocities of joints (the rest start at rest); with closures the dependent
    /// ones are solved from the others (consistent initialisation).
    pub start_velocity: Vec<(String, f64)>,
    /// Start values of joint inputs `tau_J` (the rest hold the start configuration).
    pub torques: Vec<(String, f64)>,
    /// The order of the coordinates, by joint name (empty: depth first from the root, the
    /// order of the dynamics).
    pub order: Vec<String>,
    /// Whether the root link floats (`mbfmu build --floating-base`): it moves freely in
    /// the world (six more degrees of freedom: a position and a unit quaternion, a linear
    /// and an angular velocity); otherwise it is bolted to the world.
    pub floating_base: bool,
    /// The outputs the FMU declares, by name, in this order (empty: all of them). A
    /// mechanism of many links declares what its scene is about (the N four-bar's B0 and
    /// E, not its 41 link poses and 160 closure outputs).
    pub outputs: Vec<String>,
}

/// A loop closure: the point `point_a` fixed in body `body_a` coincides with the point
/// `point_b` fixed in body `body_b` (which may be the base), along the base-frame
/// components `axes` (`"xy"` for a planar mechanism in the x–y plane, `"xyz"` for a
/// spherical joint closing the loop). One constraint residual per axis:
/// `Φ = (p_a − p_b)·e_axis`, in metres; its multiplier λ is the force on body B at the
/// point along that axis (body A feels −λ).
#[derive(Clone, Debug, PartialEq)]
pub struct Closure {
    pub name: String,
    pub body_a: String,
    /// In body A's frame (m).
    pub point_a: [f64; 3],
    pub body_b: String,
    /// In body B's frame (m).
    pub point_b: [f64; 3],
    /// Distinct letters of `"xyz"`, in that order.
    pub axes: String,
}

impl Closure {
    /// The base-frame components held, as indices 0, 1, 2.
    pub fn axis_indices(&self) -> Vec<usize> {
        self.axes.chars().filter_map(|c| "xyz".find(c)).collect()
    }
}

/// A linear spring from a point fixed in body A to a point fixed in body B (or the base):
/// `V = ½ k (ℓ − ℓ₀)²` with ℓ the distance between the points.
#[derive(Clone, Debug, PartialEq)]
pub struct Spring {
    pub name: String,
    pub body_a: String,
    pub point_a: [f64; 3],
    pub body_b: String,
    pub point_b: [f64; 3],
    /// N/m.
    pub stiffness: f64,
    /// ℓ₀ (m).
    pub rest_length: f64,
    /// C (N·s/m): a damper in parallel, force `C ℓ̇` along the line (0: none).
    pub damping: f64,
}

/// The tree structure of a valid mechanism, by index.
#[derive(Clone, Debug, PartialEq)]
pub struct Tree {
    pub root: usize,
    /// The joint whose child each body is (`None` for the root).
    pub parent_joint: Vec<Option<usize>>,
    /// The joints whose parent each body is, in declaration order.
    pub child_joints: Vec<Vec<usize>>,
}

/// A frame rigidly attached to a body of a merged mechanism: an original body's frame,
/// folded or not.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// The original body's name.
    pub name: String,
    /// The body of the merged mechanism it is attached to.
    pub body: String,
    /// Its placement in that body's frame (identity if it was not folded).
    pub offset: Origin,
    /// Whether the original body had no children (an end of a branch).
    pub leaf: bool,
}

/// A mechanism with its fixed joints folded away, and where the original bodies went.
#[derive(Clone, Debug, PartialEq)]
pub struct Merged {
    pub mechanism: Mechanism,
    /// Every original body, in the original order.
    pub frames: Vec<Frame>,
}

/// Relative tolerance of the inertia checks. URDF files print inertias with 4 to 6
/// significant digits (CAD exporters), so a flat plate, whose principal moments satisfy
/// `I₁ + I₂ = I₃` exactly, arrives breaking the triangle inequality by rounding, ~1e-5 of
/// its trace; 1e-4 of the trace is physically nothing and lets such files through.
pub const INERTIA_RTOL: f64 = 1e-4;

/// A principal moment down to −1e-9 of the largest is zero by rounding (hyq's feet:
/// −2.2e-22 beside 3e-6 kg m²); below, the inertia is refused.
pub const INERTIA_ZERO: f64 = 1e-9;

/// A body whose principal moments are all below this many kg m² per kg of its mass (a
/// radius of gyration of a micrometre) is a point mass.
pub const POINT_MASS: f64 = 1e-12;

impl Mechanism {
    /// An empty mechanism with gravity `[0, 0, −9.81]`.
    pub fn new(name: &str) -> Self {
        Mechanism {
            name: name.to_string(),
            bodies: Vec::new(),
            joints: Vec::new(),
            gravity: [0.0, 0.0, -9.81],
            closures: Vec::new(),
            springs: Vec::new(),
            dependent: Vec::new(),
            start: Vec::new(),
            start_velocity: Vec::new(),
            torques: Vec::new(),
            order: Vec::new(),
            floating_base: false,
            outputs: Vec::new(),
        }
    }

    /// The root link floats ([`Mechanism::floating_base`]).
    pub fn floating_base(mut self) -> Self {
        self.floating_base = true;
        self
    }

    pub fn gravity(mut self, g: [f64; 3]) -> Self {
        self.gravity = g;
        self
    }

    pub fn body(mut self, body: Body) -> Self {
        self.bodies.push(body);
        self
    }

    pub fn joint(mut self, joint: Joint) -> Self {
        self.joints.push(joint);
        self
    }

    /// A revolute joint about `axis` (in the joint frame).
    pub fn revolute(self, name: &str, parent: &str, child: &str, o: Origin, axis: V3<f64>) -> Self {
        self.joint(Joint::new(name, JointKind::Revolute, parent, child, o).axis(axis))
    }

    /// A continuous (unlimited revolute) joint about `axis`.
    pub fn continuous(
        self,
        name: &str,
        parent: &str,
        child: &str,
        o: Origin,
        axis: V3<f64>,
    ) -> Self {
        self.joint(Joint::new(name, JointKind::Continuous, parent, child, o).axis(axis))
    }

    /// A prismatic joint along `axis`.
    pub fn prismatic(
        self,
        name: &str,
        parent: &str,
        child: &str,
        o: Origin,
        axis: V3<f64>,
    ) -> Self {
        self.joint(Joint::new(name, JointKind::Prismatic, parent, child, o).axis(axis))
    }

    /// A fixed joint.
    pub fn fixed(self, name: &str, parent: &str, child: &str, o: Origin) -> Self {
        self.joint(Joint::new(name, JointKind::Fixed, parent, child, o))
    }

    /// A loop closure `name`: `point_a` of `body_a` on `point_b` of `body_b` along the
    /// base-frame `axes` (`"xy"`, `"xyz"`, …). See [`Closure`].
    pub fn closure(
        mut self,
        name: &str,
        body_a: &str,
        point_a: V3<f64>,
        body_b: &str,
        point_b: V3<f64>,
        axes: &str,
    ) -> Self {
        self.closures.push(Closure {
            name: name.to_string(),
            body_a: body_a.to_string(),
            point_a,
            body_b: body_b.to_string(),
            point_b,
            axes: axes.to_string(),
        });
        self
    }

    /// A linear spring `name` of `stiffness` (N/m) and `rest_length` (m) from `point_a` of
    /// `body_a` to `point_b` of `body_b`. See [`Spring`].
    #[allow(clippy::too_many_arguments)]
    pub fn spring(
        self,
        name: &str,
        body_a: &str,
        point_a: V3<f64>,
        body_b: &str,
        point_b: V3<f64>,
        stiffness: f64,
        rest_length: f64,
    ) -> Self {
        let (a, b) = ((body_a, point_a), (body_b, point_b));
        self.spring_damper(name, a, b, stiffness, 0.0, rest_length)
    }

    /// A spring with a damper in parallel (the IFToMM flyball governor's): the force
    /// `K (ℓ − ℓ₀) + C ℓ̇` along the line between `a = (body, point)` and `b`, `stiffness`
    /// K (N/m), `damping` C (N·s/m), `rest_length` ℓ₀ (m).
    pub fn spring_damper(
        mut self,
        name: &str,
        (body_a, point_a): (&str, V3<f64>),
        (body_b, point_b): (&str, V3<f64>),
        stiffness: f64,
        damping: f64,
        rest_length: f64,
    ) -> Self {
        self.springs.push(Spring {
            name: name.to_string(),
            body_a: body_a.to_string(),
            point_a,
            body_b: body_b.to_string(),
            point_b,
            stiffness,
            rest_length,
            damping,
        });
        self
    }

    /// Declares the coordinates of these joints dependent (solved from the others by the
    /// closures); as many as the closures have residuals.
    pub fn dependent(mut self, joints: &[&str]) -> Self {
        self.dependent.extend(joints.iter().map(|j| j.to_string()));
        self
    }

    /// Declares only these outputs, in this order ([`Mechanism::outputs`]).
    pub fn outputs(mut self, names: &[&str]) -> Self {
        self.outputs = names.iter().map(|n| n.to_string()).collect();
        self
    }

    /// The start position of a joint (rad or m).
    pub fn start(mut self, joint: &str, value: f64) -> Self {
        self.start.push((joint.to_string(), value));
        self
    }

    /// The start velocity of a joint (rad/s or m/s).
    pub fn start_velocity(mut self, joint: &str, value: f64) -> Self {
        self.start_velocity.push((joint.to_string(), value));
        self
    }

    /// The start value of the input `tau_J` of a joint (N.m or N): a constant drive unless
    /// the importer changes it.
    pub fn torque(mut self, joint: &str, value: f64) -> Self {
        self.torques.push((joint.to_string(), value));
        self
    }

    /// The order of the coordinates (every moving joint once), when it is not the
    /// depth-first order of the tree.
    pub fn order(mut self, joints: &[&str]) -> Self {
        self.order = joints.iter().map(|j| j.to_string()).collect();
        self
    }

    /// The index of the body named `name`.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// Checks that the mechanism is a tree from one root with physical bodies, and returns
    /// that tree.
    pub fn validate(&self) -> Result<Tree, Error> {
        let n = self.bodies.len();
        if n == 0 {
            return Err(Error::new(
                format!("robot \"{}\"", self.name),
                "has no links".into(),
            ));
        }
        if !self.gravity.iter().all(|g| g.is_finite()) {
            return Err(Error::new(
                format!("robot \"{}\"", self.name),
                format!("gravity {:?} is not finite", self.gravity),
            ));
        }
        for (k, b) in self.bodies.iter().enumerate() {
            if self.bodies[..k].iter().any(|o| o.name == b.name) {
                return Err(Error::link(&b.name, "is declared twice".into()));
            }
        }
        let mut parent_joint: Vec<Option<usize>> = vec![None; n];
        let mut child_joints = vec![Vec::new(); n];
        for (k, j) in self.joints.iter().enumerate() {
            if self.joints[..k].iter().any(|o| o.name == j.name) {
                return Err(Error::joint(&j.name, "is declared twice".into()));
            }
            let find = |role: &str, link: &str| {
                self.body_index(link).ok_or_else(|| {
                    Error::joint(&j.name, format!("{role} link \"{link}\" does not exist"))
                })
            };
            let p = find("parent", &j.parent)?;
            let c = find("child", &j.child)?;
            if p == c {
                return Err(Error::joint(
                    &j.name,
                    format!("joins link \"{}\" to itself", j.parent),
                ));
            }
            if let Some(other) = parent_joint[c] {
                return Err(Error::link(
                    &j.child,
                    format!(
                        "has two parents: joints \"{}\" and \"{}\"",
                        self.joints[other].name, j.name
                    ),
                ));
            }
            check_joint(j)?;
            parent_joint[c] = Some(k);
            child_joints[p].push(k);
        }
        // Each body has at most one parent, so following parents from any body either ends
        // at a root or runs into a cycle.
        for start in 0..n {
            let mut seen = vec![false; n];
            let mut b = start;
            while let Some(j) = parent_joint[b] {
                if seen[b] {
                    let mut names = Vec::new();
                    let first = b;
                    loop {
                        let j = parent_joint[b].expect("on the cycle");
                        names.push(format!("\"{}\"", self.joints[j].name));
                        b = self.body_index(&self.joints[j].parent).expect("checked");
                        if b == first {
                            break;
                        }
                    }
                    names.reverse();
                    return Err(Error::link(
                        &self.bodies[first].name,
                        format!("is on a cycle of joints {}", names.join(" → ")),
                    ));
                }
                seen[b] = true;
                b = self.body_index(&self.joints[j].parent).expect("checked");
            }
        }
        let roots: Vec<usize> = (0..n).filter(|&b| parent_joint[b].is_none()).collect();
        if roots.len() > 1 {
            let names: Vec<String> = roots
                .iter()
                .map(|&b| format!("\"{}\"", self.bodies[b].name))
                .collect();
            return Err(Error::new(
                format!("robot \"{}\"", self.name),
                format!(
                    "has {} root links ({}): one tree from one fixed root is needed",
                    roots.len(),
                    names.join(", ")
                ),
            ));
        }
        let tree = Tree {
            root: roots[0],
            parent_joint,
            child_joints,
        };
        let base = self.fixed_base(&tree);
        for (k, b) in self.bodies.iter().enumerate() {
            // A point mass (no inertia of its own) on a fixed joint is folded into its
            // parent, whose combined inertia is checked after the merge.
            let folded = self
                .joints
                .iter()
                .any(|j| j.kind == JointKind::Fixed && j.child == b.name);
            check_body(b, folded, base[k])?;
        }
        self.check_mimics()?;
        self.check_singular(&tree)?;
        self.check_loops()?;
        Ok(tree)
    }

    /// The inertias [`Mechanism::validate`] accepts with a warning, one line each naming
    /// the link (a point mass on a moving joint, a zero principal moment, the triangle
    /// inequality broken beyond rounding); empty for a mechanism that does not validate.
    pub fn inertia_warnings(&self) -> Vec<String> {
        let Ok(tree) = self.validate() else {
            return Vec::new();
        };
        let base = self.fixed_base(&tree);
        self.bodies
            .iter()
            .enumerate()
            .filter_map(|(k, b)| {
                let folded = self
                    .joints
                    .iter()
                    .any(|j| j.kind == JointKind::Fixed && j.child == b.name);
                let warning = check_body(b, folded, base[k]).ok().flatten()?;
                Some(format!("link \"{}\": {warning}", b.name))
            })
            .collect()
    }

    /// Which bodies are the fixed base: the root and what fixed joints fold into it. Their
    /// inertia plays no part in the dynamics (the base does not move), so it is not checked.
    fn fixed_base(&self, tree: &Tree) -> Vec<bool> {
        let mut base = vec![false; self.bodies.len()];
        let mut stack = vec![tree.root];
        while let Some(b) = stack.pop() {
            base[b] = true;
            for &j in &tree.child_joints[b] {
                if !self.joints[j].moves() {
                    stack.push(self.body_index(&self.joints[j].child).expect("validated"));
                }
            }
        }
        base
    }

    /// The independent joint a mimic joint follows at the end of its chain, with the
    /// composed multiplier and offset (`q = r q_root + o`); `None` for a joint that mimics
    /// nothing, and for a chain that never ends (a cycle) or names a missing joint (which
    /// [`Mechanism::validate`] refuses).
    pub fn mimic_root(&self, joint: &Joint) -> Option<(String, f64, f64)> {
        let mut m = joint.mimic.as_ref()?;
        let (mut r, mut o) = (m.multiplier, m.offset);
        for _ in 0..self.joints.len() {
            let next = self.joints.iter().find(|k| k.name == m.joint)?;
            match &next.mimic {
                Some(n) if next.moves() => {
                    // q = r (r' q'' + o') + o
                    o += r * n.offset;
                    r *= n.multiplier;
                    m = n;
                }
                _ => return Some((next.name.clone(), r, o)),
            }
        }
        None
    }

    /// Mimic joints name a moving joint, with finite numbers, and their chains end at a
    /// joint of its own coordinate; a mechanism with mimics has no loop closures.
    fn check_mimics(&self) -> Result<(), Error> {
        for j in self.joints.iter().filter(|j| j.moves()) {
            let Some(m) = &j.mimic else { continue };
            let err = |why: String| Err(Error::joint(&j.name, why));
            if !(m.multiplier.is_finite() && m.offset.is_finite()) {
                return err(format!(
                    "<mimic multiplier=\"{}\" offset=\"{}\">: not finite numbers",
                    m.multiplier, m.offset
                ));
            }
            match self.joints.iter().find(|k| k.name == m.joint) {
                None => {
                    return err(format!(
                        "mimics joint \"{}\", which does not exist",
                        m.joint
                    ))
                }
                Some(k) if !k.moves() => {
                    return err(format!(
                        "mimics joint \"{}\", which is fixed (it has no position to follow)",
                        m.joint
                    ))
                }
                Some(_) => {}
            }
        }
        // Every link of every chain exists: a chain without an end is a cycle.
        for j in self.joints.iter().filter(|j| j.moves()) {
            let err = |why: String| Err(Error::joint(&j.name, why));
            if j.mimic.is_some() && self.mimic_root(j).is_none() {
                let mut names = vec![format!("\"{}\"", j.name)];
                let mut at = j;
                while let Some(next) = at
                    .mimic
                    .as_ref()
                    .and_then(|m| self.joints.iter().find(|k| k.name == m.joint))
                {
                    names.push(format!("\"{}\"", next.name));
                    if next.name == j.name || names.len() > self.joints.len() {
                        break;
                    }
                    at = next;
                }
                return err(format!(
                    "is on a cycle of mimic joints {} (each follows the next: none has a coordinate of its own)",
                    names.join(" → ")
                ));
            }
            if j.mimic.is_some() && !self.closures.is_empty() {
                return err(
                    "is a mimic joint in a mechanism with loop closures: the two together are not supported"
                        .into(),
                );
            }
        }
        Ok(())
    }

    /// A moving joint that carries no mass (prismatic) or neither mass nor rotational
    /// inertia (revolute) gives the mass matrix a zero row: refused. This is the structural
    /// check (it covers a massless leaf on a moving joint); configurations where two
    /// joints' motions coincide (coaxial joints with only a massless link between them)
    /// are not detected.
    fn check_singular(&self, tree: &Tree) -> Result<(), Error> {
        for j in &self.joints {
            if !j.independent() {
                continue;
            }
            // What the coordinate moves: its joint's subtree and those of its mimics.
            let mut stack: Vec<usize> = self
                .joints
                .iter()
                .filter(|k| {
                    k.name == j.name
                        || (k.moves() && self.mimic_root(k).is_some_and(|(r, ..)| r == j.name))
                })
                .map(|k| self.body_index(&k.child).expect("validated"))
                .collect();
            let (mut mass, mut inertia) = (0.0, 0.0);
            let mut names = Vec::new();
            while let Some(b) = stack.pop() {
                let body = &self.bodies[b];
                names.push(format!("\"{}\"", body.name));
                mass += body.mass;
                inertia += body.inertia[0][0] + body.inertia[1][1] + body.inertia[2][2];
                for &k in &tree.child_joints[b] {
                    stack.push(self.body_index(&self.joints[k].child).expect("validated"));
                }
            }
            let carries = match j.kind {
                JointKind::Prismatic => mass > 0.0,
                _ => mass > 0.0 || inertia > 0.0,
            };
            if !carries {
                return Err(Error::joint(
                    &j.name,
                    format!(
                        "moves only massless links ({}): the mass matrix would be singular",
                        names.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The closures, springs and the joint lists: bodies and joints that exist, finite
    /// points, axes among x, y, z, names used once.
    fn check_loops(&self) -> Result<(), Error> {
        let robot = || format!("robot \"{}\"", self.name);
        let mut names: Vec<&str> = Vec::new();
        let finite = |p: &[f64; 3]| p.iter().all(|x| x.is_finite());
        for c in &self.closures {
            let err = |why: String| Err(Error::new(format!("closure \"{}\"", c.name), why));
            if c.name.is_empty() || names.contains(&c.name.as_str()) {
                return err("has no name, or one already used by a closure or spring".into());
            }
            names.push(&c.name);
            for (role, body, point) in [("A", &c.body_a, &c.point_a), ("B", &c.body_b, &c.point_b)]
            {
                if self.body_index(body).is_none() {
                    return err(format!("body {role} \"{body}\" does not exist"));
                }
                if !finite(point) {
                    return err(format!("point {point:?} on body \"{body}\" is not finite"));
                }
            }
            if c.body_a == c.body_b {
                return err(format!("joins body \"{}\" to itself", c.body_a));
            }
            let idx = c.axis_indices();
            let ordered = idx.windows(2).all(|w| w[0] < w[1]);
            if idx.is_empty() || idx.len() != c.axes.chars().count() || !ordered {
                return err(format!(
                    "axes \"{}\" are not distinct letters of \"xyz\" in that order (\"xy\", \"xyz\", …)",
                    c.axes
                ));
            }
        }
        for sp in &self.springs {
            let err = |why: String| Err(Error::new(format!("spring \"{}\"", sp.name), why));
            if sp.name.is_empty() || names.contains(&sp.name.as_str()) {
                return err("has no name, or one already used by a closure or spring".into());
            }
            names.push(&sp.name);
            for (role, body, point) in [
                ("A", &sp.body_a, &sp.point_a),
                ("B", &sp.body_b, &sp.point_b),
            ] {
                if self.body_index(body).is_none() {
                    return err(format!("body {role} \"{body}\" does not exist"));
                }
                if !finite(point) {
                    return err(format!("point {point:?} on body \"{body}\" is not finite"));
                }
            }
            if !(sp.stiffness.is_finite() && sp.stiffness >= 0.0) {
                return err(format!(
                    "stiffness {} is not a finite number ≥ 0",
                    sp.stiffness
                ));
            }
            if !(sp.rest_length.is_finite() && sp.rest_length >= 0.0) {
                return err(format!(
                    "rest length {} is not a finite number ≥ 0",
                    sp.rest_length
                ));
            }
            if !(sp.damping.is_finite() && sp.damping >= 0.0) {
                return err(format!("damping {} is not a finite number ≥ 0", sp.damping));
            }
        }
        let moving = |what: &str, j: &str| -> Result<(), Error> {
            match self.joints.iter().find(|k| k.name == j) {
                Some(k) if k.independent() => Ok(()),
                Some(k) if k.moves() => Err(Error::joint(
                    j,
                    format!(
                        "mimics joint \"{}\": it has no coordinate of its own to be {what}",
                        k.mimic.as_ref().map_or("", |m| m.joint.as_str())
                    ),
                )),
                Some(_) => Err(Error::joint(
                    j,
                    format!("is fixed: it has no coordinate to be {what}"),
                )),
                None => Err(Error::new(
                    robot(),
                    format!("{what} joint \"{j}\" does not exist"),
                )),
            }
        };
        for (k, j) in self.dependent.iter().enumerate() {
            moving("dependent", j)?;
            if self.dependent[..k].contains(j) {
                return Err(Error::joint(j, "is declared dependent twice".into()));
            }
        }
        for (j, v) in &self.start {
            moving("started", j)?;
            if !v.is_finite() {
                return Err(Error::joint(j, format!("start position {v} is not finite")));
            }
        }
        for (j, v) in &self.start_velocity {
            moving("started", j)?;
            if !v.is_finite() {
                return Err(Error::joint(j, format!("start velocity {v} is not finite")));
            }
        }
        for (j, v) in &self.torques {
            moving("driven", j)?;
            if !v.is_finite() {
                return Err(Error::joint(j, format!("start torque {v} is not finite")));
            }
        }
        if !self.order.is_empty() {
            for (k, j) in self.order.iter().enumerate() {
                moving("ordered", j)?;
                if self.order[..k].contains(j) {
                    return Err(Error::joint(
                        j,
                        "is listed twice in the coordinate order".into(),
                    ));
                }
            }
            if let Some(j) = self
                .joints
                .iter()
                .find(|j| j.independent() && !self.order.contains(&j.name))
            {
                return Err(Error::joint(
                    &j.name,
                    "is missing from the coordinate order".into(),
                ));
            }
        }
        let residuals: usize = self.closures.iter().map(|c| c.axis_indices().len()).sum();
        // As many dependent joints as the closures' rank: their residuals, or fewer where
        // the closures are redundant (checked against the rank at the start, `Built::new`).
        if self.dependent.len() > residuals || (residuals > 0 && self.dependent.is_empty()) {
            return Err(Error::new(
                robot(),
                format!(
                    "its closures have {residuals} residuals but {} joints are declared dependent (`.dependent([…])`): initialisation solves the closures for as many joints as they have independent residuals (all of them, unless some are redundant)",
                    self.dependent.len()
                ),
            ));
        }
        Ok(())
    }

    /// Folds every body attached by a fixed joint into its parent (mass, centre of mass and
    /// inertia combined, the parallel-axis theorem), re-attaching its children with the
    /// composed origins. The result has moving joints only; `frames` says where each
    /// original body went.
    pub fn merge_fixed(&self) -> Result<Merged, Error> {
        let tree = self.validate()?;
        // For every original body: the body it ends up in and its offset there.
        let n = self.bodies.len();
        let mut host = vec![0usize; n];
        let mut offset = vec![Origin::IDENTITY; n];
        let mut order = vec![tree.root];
        host[tree.root] = tree.root;
        let mut k = 0;
        while k < order.len() {
            let b = order[k];
            k += 1;
            for &j in &tree.child_joints[b] {
                let joint = &self.joints[j];
                let c = self.body_index(&joint.child).expect("validated");
                if joint.moves() {
                    host[c] = c;
                } else {
                    host[c] = host[b];
                    offset[c] = offset[b].then(&joint.origin);
                }
                order.push(c);
            }
        }
        let mut bodies: Vec<Body> = Vec::new();
        let mut slot = vec![usize::MAX; n];
        for &b in &order {
            if host[b] == b {
                slot[b] = bodies.len();
                bodies.push(Body::massless(&self.bodies[b].name));
            }
        }
        // Combine: total mass, centre of mass, inertia about it (parallel axes).
        for (h, merged) in bodies.iter_mut().enumerate() {
            let parts: Vec<(f64, V3<f64>, M3<f64>)> = (0..n)
                .filter(|&b| slot[host[b]] == h)
                .map(|b| {
                    let body = &self.bodies[b];
                    let o = &offset[b];
                    let r = &o.rotation;
                    let com = add(&mat_vec(r, &body.com), &o.xyz);
                    let i = mat_mul(&mat_mul(r, &body.inertia), &transpose(r));
                    (body.mass, com, i)
                })
                .collect();
            let mass: f64 = parts.iter().map(|p| p.0).sum();
            let com = if mass > 0.0 {
                let s = parts
                    .iter()
                    .fold([0.0; 3], |s, p| add(&s, &scale(&p.1, p.0)));
                scale(&s, 1.0 / mass)
            } else {
                [0.0; 3]
            };
            let mut inertia = [[0.0; 3]; 3];
            for (m, c, i) in &parts {
                let d = sub(c, &com);
                let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                let ddt = outer(&d, &d, *m);
                for r in 0..3 {
                    for s in 0..3 {
                        let eye = if r == s { dd } else { 0.0 };
                        inertia[r][s] += i[r][s] + m * eye - ddt[r][s];
                    }
                }
            }
            merged.mass = mass;
            merged.com = com;
            merged.inertia = inertia;
        }
        let mut joints = Vec::new();
        for &b in &order {
            for &j in &tree.child_joints[b] {
                let joint = &self.joints[j];
                if joint.moves() {
                    let mut moved = joint.clone();
                    moved.parent = self.bodies[host[b]].name.clone();
                    moved.origin = offset[b].then(&joint.origin);
                    joints.push(moved);
                }
            }
        }
        let frames = (0..n)
            .map(|b| Frame {
                name: self.bodies[b].name.clone(),
                body: self.bodies[host[b]].name.clone(),
                offset: offset[b],
                leaf: tree.child_joints[b].is_empty(),
            })
            .collect();
        // Closures and springs move with their bodies: onto the host, the point placed by
        // the folded body's offset.
        let on_host = |body: &str, point: &V3<f64>| {
            let b = self.body_index(body).expect("validated");
            let o = &offset[b];
            (
                self.bodies[host[b]].name.clone(),
                add(&mat_vec(&o.rotation, point), &o.xyz),
            )
        };
        let closures = self
            .closures
            .iter()
            .map(|c| {
                let (body_a, point_a) = on_host(&c.body_a, &c.point_a);
                let (body_b, point_b) = on_host(&c.body_b, &c.point_b);
                Closure {
                    body_a,
                    point_a,
                    body_b,
                    point_b,
                    ..c.clone()
                }
            })
            .collect();
        let springs = self
            .springs
            .iter()
            .map(|sp| {
                let (body_a, point_a) = on_host(&sp.body_a, &sp.point_a);
                let (body_b, point_b) = on_host(&sp.body_b, &sp.point_b);
                Spring {
                    body_a,
                    point_a,
                    body_b,
                    point_b,
                    ..sp.clone()
                }
            })
            .collect();
        Ok(Merged {
            mechanism: Mechanism {
                name: self.name.clone(),
                bodies,
                joints,
                gravity: self.gravity,
                closures,
                springs,
                dependent: self.dependent.clone(),
                start: self.start.clone(),
                start_velocity: self.start_velocity.clone(),
                torques: self.torques.clone(),
                floating_base: self.floating_base,
                order: self.order.clone(),
                outputs: self.outputs.clone(),
            },
            frames,
        })
    }
}

/// `folded`: the body hangs on a fixed joint, so a point mass (mass > 0, no inertia: a
/// sensor's mass in URDFs such as Talos's) is allowed; merged into its parent it adds
/// m (|d|² 1 − d dᵀ) to an inertia that must still pass these checks.
///
/// `base`: the body is (folded into) the fixed base, whose inertia plays no part: only its
/// numbers' finiteness and the mass's sign are checked.
///
/// Refused: a negative or non-finite mass, a non-finite or non-symmetric inertia, and a
/// principal moment negative beyond rounding (below −[`INERTIA_ZERO`] of the largest): not a
/// body. Accepted with a warning (the returned line), the inertia used as given, as
/// Pinocchio uses it: a point mass on a moving joint, a zero principal moment (a thin rod
/// about its axis), and principal moments that break the triangle inequality by more than
/// [`INERTIA_RTOL`] of the trace (no rigid body has them, but the mass matrix stays positive
/// definite; by less, it is the rounding of printed digits, accepted silently).
/// [`Mechanism::validate`]'s structural check and the start configuration's mass matrix
/// ([`super::fmu::Built::new`]) catch what would make the dynamics singular.
fn check_body(b: &Body, folded: bool, base: bool) -> Result<Option<String>, Error> {
    let err = |why: String| Err(Error::link(&b.name, why));
    if !b.mass.is_finite() || b.mass < 0.0 {
        return err(format!("mass {} is not a finite number ≥ 0", b.mass));
    }
    if !b.com.iter().all(|c| c.is_finite()) {
        return err(format!("centre of mass {:?} is not finite", b.com));
    }
    let i = &b.inertia;
    if !i.iter().flatten().all(|x| x.is_finite()) {
        return err("inertia is not finite".into());
    }
    let trace = i[0][0] + i[1][1] + i[2][2];
    let all_zero = i.iter().flatten().all(|&x| x == 0.0);
    if base || (all_zero && (b.mass == 0.0 || folded)) {
        return Ok(None);
    }
    let sym_tol = 1e-9 * trace.abs();
    for (r, s) in [(0, 1), (0, 2), (1, 2)] {
        if (i[r][s] - i[s][r]).abs() > sym_tol {
            return err(format!(
                "inertia is not symmetric (I[{r}][{s}] = {}, I[{s}][{r}] = {})",
                i[r][s], i[s][r]
            ));
        }
    }
    let m = nalgebra::Matrix3::from_fn(|r, s| 0.5 * (i[r][s] + i[s][r]));
    let mut e: Vec<f64> = m.symmetric_eigenvalues().iter().copied().collect();
    e.sort_by(f64::total_cmp);
    let moments = format!("principal moments {:.6e}, {:.6e}, {:.6e}", e[0], e[1], e[2]);
    // A point mass: no rotational inertia of its own beyond noise (radius of gyration
    // under a micrometre: icub's head, 1.3 kg with 2.4e-35 kg m²).
    if b.mass > 0.0 && e[2].max(-e[0]) <= POINT_MASS * b.mass {
        return Ok(Some(format!(
            "a point mass ({} kg, {moments}): no rotational inertia of its own",
            b.mass
        )));
    }
    if e[0] < -INERTIA_ZERO * e[2].abs() || e[2] <= 0.0 {
        return err(format!(
            "inertia is not positive definite ({moments}; negative beyond rounding)"
        ));
    }
    if e[0] <= 0.0 {
        return Ok(Some(format!(
            "inertia has a zero principal moment ({moments}; a thin rod about its axis): used as given"
        )));
    }
    let excess = e[2] - e[0] - e[1];
    if excess > INERTIA_RTOL * trace {
        return Ok(Some(format!(
            "inertia breaks the triangle inequality ({moments}: {:.6e} + {:.6e} < {:.6e}, by {:.1}% of the largest): no rigid body has it; used as given, as Pinocchio does",
            e[0],
            e[1],
            e[2],
            100.0 * excess / e[2]
        )));
    }
    Ok(None)
}

fn check_joint(j: &Joint) -> Result<(), Error> {
    let err = |why: String| Err(Error::joint(&j.name, why));
    let o = &j.origin;
    if !o
        .xyz
        .iter()
        .chain(o.rotation.iter().flatten())
        .all(|x| x.is_finite())
    {
        return err("origin is not finite".into());
    }
    if j.moves() {
        let n = (j.axis[0] * j.axis[0] + j.axis[1] * j.axis[1] + j.axis[2] * j.axis[2]).sqrt();
        if !(n.is_finite() && (n - 1.0).abs() < 1e-9) {
            return err(format!(
                "axis {:?} is not a unit vector (a zero axis has no direction)",
                j.axis
            ));
        }
    }
    if !(j.damping.is_finite() && j.damping >= 0.0) {
        return err(format!("damping {} is not a finite number ≥ 0", j.damping));
    }
    if !(j.friction.is_finite() && j.friction >= 0.0) {
        return err(format!(
            "friction {} is not a finite number ≥ 0",
            j.friction
        ));
    }
    Ok(())
}
