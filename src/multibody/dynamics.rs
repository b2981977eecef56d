//! Rigid-body dynamics of a [`Model`] built from a validated [`Mechanism`], generic over
//! the scalar ([`Scalar`]): forward kinematics, RNEA (inverse dynamics), CRBA (mass matrix),
//! ABA (forward dynamics), energies and the poses of the ends of branches.
//!
//! The algorithms are Featherstone's (*Rigid Body Dynamics Algorithms*, 2008: RNEA table
//! 5.1, CRBA table 6.2, ABA table 7.1), on the spatial algebra of [`super::spatial`]: body i
//! has the frame of its joint (URDF: the child link frame is the joint frame), its parent
//! λ(i) < i, and `i_X_λ(i) = X_J(q_i) X_T(i)` where `X_T` is the joint's fixed origin and
//! `X_J` the rotation about (or translation along) its unit axis. Velocities and
//! accelerations are spatial vectors in body coordinates; gravity enters as the base
//! acceleration `a₀ = (0, −g)`.
//!
//! Coordinates: one per moving joint, the joint position (a continuous joint's is a plain
//! angle, not (cos, sin)). Nothing compares or branches on scalar values (the structure is
//! fixed by the model), so dual numbers give exact derivatives and a tracing scalar can
//! record the whole computation as straight-line code.

use super::mechanism::{Error, JointKind, Mechanism};
use super::spatial::{
    add, axis_angle, lift3, lift33, mat_mul, mat_t_vec, mat_vec, quat_from_matrix, quat_mul, scale,
    transpose, ArticulatedInertia, Force, Motion, RigidInertia, Transform, M3, V3,
};
use crate::model::Scalar;

/// How a moving joint moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// Rotation about the unit axis (revolute and continuous joints).
    Rotation,
    /// Translation along it.
    Translation,
}

/// A frame whose pose is reported: the end of a branch of the original mechanism (possibly
/// a body folded into another by a fixed joint).
#[derive(Clone, Debug, PartialEq)]
pub struct Tip {
    pub name: String,
    /// The moving body it is attached to (`None`: the fixed base).
    pub body: Option<usize>,
    /// Its placement in that body's frame.
    pub rotation: M3<f64>,
    pub translation: V3<f64>,
    pub quaternion: [f64; 4],
}

/// A joint whose position follows another's (a mimic joint): `q_i = multiplier · q_joint +
/// offset`, `joint` being a model joint of its own coordinate (chains of mimics composed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Follows {
    pub joint: usize,
    pub multiplier: f64,
    pub offset: f64,
}

/// A mechanism precomputed for the dynamics: flat arrays, one entry per moving joint (=
/// per moving body, after fixed joints were merged), parents before children.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    pub name: String,
    /// The moving joints' names, in coordinate order.
    pub joints: Vec<String>,
    /// The merged bodies they move.
    pub bodies: Vec<String>,
    pub kinds: Vec<Axis>,
    /// λ(i): the parent body (`None`: the base).
    pub parent: Vec<Option<usize>>,
    /// The joint origin in the parent frame: `x_parent = rotation · x_joint + translation`.
    pub rotation: Vec<M3<f64>>,
    pub translation: Vec<V3<f64>>,
    /// The quaternion of `rotation` (w, x, y, z).
    pub quaternion: Vec<[f64; 4]>,
    /// Unit axis in the joint frame.
    pub axis: Vec<V3<f64>>,
    /// The motion subspace `S_i`: `(axis, 0)` or `(0, axis)`.
    pub subspace: Vec<Motion<f64>>,
    /// Spatial inertia of each body in its frame.
    pub inertia: Vec<RigidInertia<f64>>,
    /// Viscous damping per joint (ABA applies `τ − d q̇`; RNEA does not).
    pub damping: Vec<f64>,
    pub gravity: V3<f64>,
    /// The ends of branches of the original mechanism, in its body order.
    pub tips: Vec<Tip>,
    /// The loop closures, on the moving bodies (`None`: the base).
    pub closures: Vec<PointPair>,
    /// The springs, likewise.
    pub springs: Vec<PointPair>,
    /// Per joint: the joint it follows if it is a mimic joint ([`Follows`]). Every array
    /// here stays per joint, mimics included (the tree); [`Model::aba`] then solves the
    /// dynamics reduced to the independent joints.
    pub follows: Vec<Option<Follows>>,
    /// Per joint: the index of the joint that drives it (itself, or the one it follows)
    /// among the independent joints, in model order.
    pub driver_index: Vec<usize>,
    /// The root link when it floats ([`Mechanism::floating_base`]): it moves freely in
    /// the world, its joints' frames placed from it; `None`: the root is bolted to the world
    /// (the base frame is the world frame).
    pub free_base: Option<FreeBase>,
}

/// A floating root link: its name and its spatial inertia in its frame (the links fixed
/// joints fold into it included).
#[derive(Clone, Debug, PartialEq)]
pub struct FreeBase {
    pub body: String,
    pub inertia: RigidInertia<f64>,
}

/// Where a floating base is and how it moves: `rotation` world ← base (the base frame's
/// axes in world coordinates), `position` its origin in the world, `velocity` its spatial
/// velocity in base coordinates, `(ω, v)` (Pinocchio's free-flyer velocity, angular first
/// here as every [`Motion`] is).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaseState<S> {
    pub rotation: M3<S>,
    pub position: V3<S>,
    pub velocity: Motion<S>,
}

/// Two points fixed in bodies of the model (`None`: the base), in those bodies' frames: a
/// loop closure (with the base-frame axes it holds) or a spring (with its stiffness and
/// rest length).
/// The workspace of ABA, RNEA and CRBA (Pinocchio's `Data` beside its `Model`): made once
/// for a model and a scalar type, reused by every call, so that an evaluation allocates
/// nothing (`Model::aba_in`, `rnea_in`, `crba_in`; `aba`, `rnea`, `crba` make one each
/// call).
#[derive(Clone, Debug)]
pub struct Data<S> {
    xs: Vec<Transform<S>>,
    v: Vec<Motion<S>>,
    c: Vec<Motion<S>>,
    a: Vec<Motion<S>>,
    ia: Vec<ArticulatedInertia<S>>,
    /// ABA's bias forces; RNEA's body forces.
    pa: Vec<Force<S>>,
    u_vec: Vec<Force<S>>,
    d_inv: Vec<S>,
    u: Vec<S>,
    ic: Vec<RigidInertia<S>>,
    /// With mimic joints: the mass matrix, the bias forces, the reduced system.
    mass: Vec<S>,
    bias: Vec<S>,
    reduced: Vec<S>,
    rhs: Vec<S>,
    /// With mimic joints: `reduced` holds the factored reduced mass matrix of the q the
    /// next calls are at, so they skip forming and factoring it (O(n³) with a floating
    /// base). Set by a caller that evaluates the dynamics again at the same q with other
    /// velocities and forces (the end stops' and friction's inverse-mass columns), after a
    /// first call at that q; cleared by it after.
    pub mass_is_current: bool,
}

impl<S: Scalar> Data<S> {
    pub fn new(model: &Model) -> Data<S> {
        let n = model.nq();
        Data {
            xs: Vec::with_capacity(n),
            v: Vec::with_capacity(n),
            c: Vec::with_capacity(n),
            a: Vec::with_capacity(n),
            ia: Vec::with_capacity(n),
            pa: Vec::with_capacity(n),
            u_vec: Vec::with_capacity(n),
            d_inv: Vec::with_capacity(n),
            u: Vec::with_capacity(n),
            ic: Vec::with_capacity(n),
            mass: Vec::new(),
            bias: Vec::new(),
            reduced: Vec::new(),
            rhs: Vec::new(),
            mass_is_current: false,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct PointPair {
    pub name: String,
    pub body_a: Option<usize>,
    pub point_a: V3<f64>,
    pub body_b: Option<usize>,
    pub point_b: V3<f64>,
    /// A closure's base-frame components (0, 1, 2); empty for a spring.
    pub axes: Vec<usize>,
    /// A spring's stiffness (N/m), rest length (m) and damping (N·s/m); zero for a
    /// closure.
    pub stiffness: f64,
    pub rest_length: f64,
    pub damping: f64,
}

impl Model {
    /// Validates `mechanism`, merges its fixed joints and lays it out depth-first from the
    /// root, children in declaration order.
    pub fn new(mechanism: &Mechanism) -> Result<Model, Error> {
        let merged = mechanism.merge_fixed()?;
        let m = &merged.mechanism;
        let tree = m.validate()?;
        let mut model = Model {
            name: m.name.clone(),
            joints: Vec::new(),
            bodies: Vec::new(),
            kinds: Vec::new(),
            parent: Vec::new(),
            rotation: Vec::new(),
            translation: Vec::new(),
            quaternion: Vec::new(),
            axis: Vec::new(),
            subspace: Vec::new(),
            inertia: Vec::new(),
            damping: Vec::new(),
            gravity: m.gravity,
            tips: Vec::new(),
            closures: Vec::new(),
            springs: Vec::new(),
            follows: Vec::new(),
            driver_index: Vec::new(),
            free_base: None,
        };
        // Pre-order walk from the root, children in declaration order: (joint, parent).
        let mut order: Vec<(usize, Option<usize>)> = Vec::new();
        fn walk(
            m: &Mechanism,
            tree: &super::mechanism::Tree,
            b: usize,
            parent: Option<usize>,
            order: &mut Vec<(usize, Option<usize>)>,
        ) {
            for &j in &tree.child_joints[b] {
                order.push((j, parent));
                let here = order.len() - 1;
                let c = m.body_index(&m.joints[j].child).expect("validated");
                walk(m, tree, c, Some(here), order);
            }
        }
        walk(m, &tree, tree.root, None, &mut order);
        for &(j, parent) in &order {
            let joint = &m.joints[j];
            let body = &m.bodies[m.body_index(&joint.child).expect("validated")];
            let kind = match joint.kind {
                JointKind::Revolute | JointKind::Continuous => Axis::Rotation,
                JointKind::Prismatic => Axis::Translation,
                JointKind::Fixed => unreachable!("merged"),
            };
            let z = [0.0; 3];
            model.joints.push(joint.name.clone());
            model.bodies.push(body.name.clone());
            model.kinds.push(kind);
            model.parent.push(parent);
            model.rotation.push(joint.origin.rotation);
            model.translation.push(joint.origin.xyz);
            model
                .quaternion
                .push(quat_from_matrix(&joint.origin.rotation));
            model.axis.push(joint.axis);
            model.subspace.push(match kind {
                Axis::Rotation => Motion {
                    ang: joint.axis,
                    lin: z,
                },
                Axis::Translation => Motion {
                    ang: z,
                    lin: joint.axis,
                },
            });
            model
                .inertia
                .push(RigidInertia::from_com(body.mass, &body.com, &body.inertia));
            model.damping.push(joint.damping);
        }
        for f in merged.frames.iter().filter(|f| f.leaf) {
            let body = model.bodies.iter().position(|b| *b == f.body);
            model.tips.push(Tip {
                name: f.name.clone(),
                body,
                rotation: f.offset.rotation,
                translation: f.offset.xyz,
                quaternion: quat_from_matrix(&f.offset.rotation),
            });
        }
        let on = |body: &str| model.bodies.iter().position(|b| b == body);
        let closures = m
            .closures
            .iter()
            .map(|c| PointPair {
                name: c.name.clone(),
                body_a: on(&c.body_a),
                point_a: c.point_a,
                body_b: on(&c.body_b),
                point_b: c.point_b,
                axes: c.axis_indices(),
                stiffness: 0.0,
                rest_length: 0.0,
                damping: 0.0,
            })
            .collect();
        let springs = m
            .springs
            .iter()
            .map(|sp| PointPair {
                name: sp.name.clone(),
                body_a: on(&sp.body_a),
                point_a: sp.point_a,
                body_b: on(&sp.body_b),
                point_b: sp.point_b,
                axes: Vec::new(),
                stiffness: sp.stiffness,
                rest_length: sp.rest_length,
                damping: sp.damping,
            })
            .collect();
        model.closures = closures;
        model.springs = springs;
        model.follows = order
            .iter()
            .map(|&(j, _)| {
                let (root, multiplier, offset) = m.mimic_root(&m.joints[j])?;
                let joint = model.joints.iter().position(|n| *n == root)?;
                Some(Follows {
                    joint,
                    multiplier,
                    offset,
                })
            })
            .collect();
        let rank = |i: usize| model.follows[..i].iter().filter(|f| f.is_none()).count();
        model.driver_index = (0..model.nq()).map(|i| rank(model.driver(i).0)).collect();
        if mechanism.floating_base {
            let root = &m.bodies[tree.root];
            model.free_base = Some(FreeBase {
                body: root.name.clone(),
                inertia: RigidInertia::from_com(root.mass, &root.com, &root.inertia),
            });
        }
        Ok(model)
    }

    /// The number of independent joints (the coordinates, mimic joints left out).
    pub fn ndof(&self) -> usize {
        self.follows.iter().filter(|f| f.is_none()).count()
    }

    /// Whether some joint follows another (mimic joints): q̈ then comes from the mass
    /// matrix reduced to the independent joints, not from the articulated-body algorithm.
    pub fn has_mimics(&self) -> bool {
        self.follows.iter().any(Option::is_some)
    }

    /// The joint whose coordinate moves joint `i` (itself unless it is a mimic), and the
    /// ratio of their velocities.
    pub fn driver(&self, i: usize) -> (usize, f64) {
        match self.follows[i] {
            Some(f) => (f.joint, f.multiplier),
            None => (i, 1.0),
        }
    }

    /// How many residuals the loop closures have (one per closure axis).
    pub fn closure_residuals(&self) -> usize {
        self.closures.iter().map(|c| c.axes.len()).sum()
    }

    /// A point fixed in a body (`None`: the base), in the base frame.
    fn point_at<S: Scalar>(
        poses: &[(M3<S>, V3<S>)],
        body: Option<usize>,
        point: &V3<f64>,
    ) -> V3<S> {
        let p: V3<S> = lift3(point);
        match body {
            None => p,
            Some(b) => {
                let (r, o) = &poses[b];
                add(o, &mat_vec(r, &p))
            }
        }
    }

    /// `p_a − p_b` of a point pair in the base frame.
    fn separation<S: Scalar>(poses: &[(M3<S>, V3<S>)], pair: &PointPair) -> V3<S> {
        let a = Self::point_at(poses, pair.body_a, &pair.point_a);
        let b = Self::point_at(poses, pair.body_b, &pair.point_b);
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }

    /// The loop-closure residuals `Φ(q)`: for each closure, `(p_a − p_b)` along each of its
    /// axes, in declaration order, by forward kinematics (zero when the loops are closed).
    pub fn closure_residuals_at<S: Scalar>(&self, q: &[S], phi: &mut [S]) {
        let poses = self.forward_kinematics(q);
        let mut k = 0;
        for c in &self.closures {
            let d = Self::separation(&poses, c);
            for &axis in &c.axes {
                phi[k] = d[axis];
                k += 1;
            }
        }
    }

    /// The springs' potential energy `Σ ½ k (ℓ − ℓ₀)²`, ℓ = |p_a − p_b|.
    pub fn spring_energy<S: Scalar>(&self, q: &[S]) -> S {
        if self.springs.is_empty() {
            return S::zero();
        }
        let poses = self.forward_kinematics(q);
        let mut v = S::zero();
        for sp in &self.springs {
            let d = Self::separation(&poses, sp);
            let stretch = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() - sp.rest_length;
            v += stretch * stretch * (0.5 * sp.stiffness);
        }
        v
    }

    /// Whether a spring has a damper in parallel ([`PointPair::damping`]).
    pub fn has_dampers(&self) -> bool {
        self.springs.iter().any(|sp| sp.damping != 0.0)
    }

    /// The dampers' generalised force `Σ C ℓ̇ ∇ℓ` into `out` (model order; it opposes the
    /// motion, so it is subtracted from τ as the springs' gradient is), and the power they
    /// take out, `Σ C ℓ̇²` (≥ 0). `∇ℓ` by one dual pass of forward kinematics per
    /// coordinate (as the springs' gradient), `ℓ̇ = ∇ℓ · q̇`.
    pub fn damper_forces<S: Scalar>(&self, q: &[S], qd: &[S], out: &mut [S]) -> S {
        out.fill(S::zero());
        let dampers: Vec<&PointPair> = self.springs.iter().filter(|sp| sp.damping != 0.0).collect();
        if dampers.is_empty() {
            return S::zero();
        }
        let n = q.len();
        let mut gradients = vec![vec![S::zero(); n]; dampers.len()];
        use num_dual::DualNum as _;
        let mut along: Vec<num_dual::Dual<S>> =
            q.iter().map(|&v| num_dual::Dual::from_re(v)).collect();
        for j in 0..n {
            along[j].eps = S::one();
            let poses = self.forward_kinematics(&along);
            for (gradient, sp) in gradients.iter_mut().zip(&dampers) {
                let d = Self::separation(&poses, sp);
                gradient[j] = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().eps;
            }
            along[j].eps = S::zero();
        }
        let mut power = S::zero();
        for (gradient, sp) in gradients.iter().zip(&dampers) {
            let rate = gradient
                .iter()
                .zip(qd)
                .fold(S::zero(), |s, (&g, &v)| s + g * v);
            let force = rate * sp.damping;
            for (o, &g) in out.iter_mut().zip(gradient) {
                *o += force * g;
            }
            power += force * rate;
        }
        power
    }

    /// The number of coordinates (= velocities = moving joints).
    pub fn nq(&self) -> usize {
        self.joints.len()
    }

    /// `i_X_λ(i)` at joint position `q`: `E = R_J(q)ᵀ R₀ᵀ`, `r = p₀ (+ R₀ a q, prismatic)`.
    pub fn joint_transform<S: Scalar>(&self, i: usize, q: S) -> Transform<S> {
        let r0: M3<S> = lift33(&self.rotation[i]);
        let p0: V3<S> = lift3(&self.translation[i]);
        match self.kinds[i] {
            Axis::Rotation => {
                let rj = axis_angle(&self.axis[i], q);
                Transform {
                    e: transpose(&mat_mul(&r0, &rj)),
                    r: p0,
                }
            }
            Axis::Translation => {
                let along = mat_vec(&r0, &lift3(&self.axis[i]));
                Transform {
                    e: transpose(&r0),
                    r: add(&p0, &scale(&along, q)),
                }
            }
        }
    }

    fn transforms<S: Scalar>(&self, q: &[S]) -> Vec<Transform<S>> {
        let mut xs = Vec::with_capacity(self.nq());
        self.transforms_into(q, &mut xs);
        xs
    }

    fn transforms_into<S: Scalar>(&self, q: &[S], xs: &mut Vec<Transform<S>>) {
        assert_eq!(q.len(), self.nq(), "q has {} entries, not nq", q.len());
        xs.clear();
        xs.extend((0..self.nq()).map(|i| self.joint_transform(i, q[i])));
    }

    fn base_acceleration<S: Scalar>(&self) -> Motion<S> {
        Motion {
            ang: [S::zero(); 3],
            lin: lift3(&[-self.gravity[0], -self.gravity[1], -self.gravity[2]]),
        }
    }

    /// The pose of every moving body in the base frame: `(R, p)` with
    /// `x_base = R x_body + p`.
    pub fn forward_kinematics<S: Scalar>(&self, q: &[S]) -> Vec<(M3<S>, V3<S>)> {
        let xs = self.transforms(q);
        let mut poses: Vec<(M3<S>, V3<S>)> = Vec::with_capacity(self.nq());
        for (i, x) in xs.iter().enumerate() {
            let r_local = transpose(&x.e);
            let pose = match self.parent[i] {
                None => (r_local, x.r),
                Some(p) => {
                    let (rp, pp) = &poses[p];
                    (mat_mul(rp, &r_local), add(pp, &mat_vec(rp, &x.r)))
                }
            };
            poses.push(pose);
        }
        poses
    }

    /// The position and unit quaternion `(w, x, y, z)` of every tip (end of a branch) in
    /// the base frame, in [`Model::tips`] order. The quaternion is composed along the
    /// chain (`q_parent ⊗ q_origin ⊗ (cos q/2, a sin q/2)`), which needs no branch; its
    /// sign is whatever that product gives (consistent, not normalised to w ≥ 0).
    pub fn tip_poses<S: Scalar>(&self, q: &[S]) -> Vec<(V3<S>, [S; 4])> {
        let poses = self.forward_kinematics(q);
        let mut quats: Vec<[S; 4]> = Vec::with_capacity(self.nq());
        for (i, &qi) in q.iter().enumerate() {
            let origin = self.quaternion[i].map(S::from);
            let motion = match self.kinds[i] {
                Axis::Rotation => {
                    let half = qi * 0.5;
                    let (s, c) = (half.sin(), half.cos());
                    let a = self.axis[i];
                    [c, s * a[0], s * a[1], s * a[2]]
                }
                Axis::Translation => [S::one(), S::zero(), S::zero(), S::zero()],
            };
            let local = quat_mul(&origin, &motion);
            quats.push(match self.parent[i] {
                None => local,
                Some(p) => quat_mul(&quats[p], &local),
            });
        }
        self.tips
            .iter()
            .map(|tip| {
                let offset = lift3(&tip.translation);
                let q_off = tip.quaternion.map(S::from);
                match tip.body {
                    None => (offset, q_off),
                    Some(b) => {
                        let (r, p) = &poses[b];
                        (add(p, &mat_vec(r, &offset)), quat_mul(&quats[b], &q_off))
                    }
                }
            })
            .collect()
    }

    /// Body velocities `v_i` (body coordinates) and the transforms; `v0` the base's
    /// velocity in base coordinates (`None`: a fixed base).
    fn velocities<S: Scalar>(
        &self,
        v0: Option<&Motion<S>>,
        q: &[S],
        qd: &[S],
    ) -> (Vec<Transform<S>>, Vec<Motion<S>>) {
        let mut d = Data::new(self);
        self.velocities_into(v0, q, qd, &mut d);
        (d.xs, d.v)
    }

    /// Body velocities `v_i` (body coordinates) and the transforms, into `d.xs` and `d.v`.
    fn velocities_into<S: Scalar>(
        &self,
        v0: Option<&Motion<S>>,
        q: &[S],
        qd: &[S],
        d: &mut Data<S>,
    ) {
        self.transforms_into(q, &mut d.xs);
        let (xs, v) = (&d.xs, &mut d.v);
        v.clear();
        for i in 0..self.nq() {
            let vj = Motion::from_axis(&self.subspace[i], qd[i]);
            let vi = match (self.parent[i], v0) {
                (None, None) => vj,
                (None, Some(v0)) => xs[i].motion(v0).add(&vj),
                (Some(p), _) => xs[i].motion(&v[p]).add(&vj),
            };
            v.push(vi);
        }
    }

    /// Inverse dynamics (RNEA): the joint forces `τ` that give accelerations `qdd` at
    /// `(q, qd)` under gravity. Damping is not included (`τ` is what acts on the bodies).
    pub fn rnea<S: Scalar>(&self, q: &[S], qd: &[S], qdd: &[S]) -> Vec<S> {
        let mut tau = vec![S::zero(); self.nq()];
        self.rnea_in(&mut Data::new(self), q, qd, qdd, &mut tau);
        tau
    }

    /// [`Model::rnea`] into `tau`, with the workspace `d`: no allocation.
    pub fn rnea_in<S: Scalar>(&self, d: &mut Data<S>, q: &[S], qd: &[S], qdd: &[S], tau: &mut [S]) {
        self.rnea_tree(d, None, &self.base_acceleration::<S>(), q, qd, qdd, tau);
    }

    /// RNEA's two passes over the tree from a base moving with velocity `v0` (`None`: a
    /// fixed base) and fictitious acceleration `a0` (gravity included, base coordinates):
    /// the joint forces into `tau`, and the wrench the joints pass to the base (base frame;
    /// zero for a fixed base, whose children's wrenches are not needed).
    #[allow(clippy::too_many_arguments)]
    fn rnea_tree<S: Scalar>(
        &self,
        d: &mut Data<S>,
        v0: Option<&Motion<S>>,
        a0: &Motion<S>,
        q: &[S],
        qd: &[S],
        qdd: &[S],
        tau: &mut [S],
    ) -> Force<S> {
        let n = self.nq();
        self.velocities_into(v0, q, qd, d);
        let Data {
            xs, v, a, pa: f, ..
        } = d;
        a.clear();
        f.clear();
        for i in 0..n {
            let ai = match self.parent[i] {
                None => xs[i].motion(a0),
                Some(p) => xs[i].motion(&a[p]),
            }
            .add(&Motion::from_axis(&self.subspace[i], qdd[i]))
            .add(&v[i].cross_motion(&Motion::from_axis(&self.subspace[i], qd[i])));
            let inertia = RigidInertia::<S>::lift(&self.inertia[i]);
            f.push(
                inertia
                    .apply(&ai)
                    .add(&v[i].cross_force(&inertia.apply(&v[i]))),
            );
            a.push(ai);
        }
        let mut f0 = Force::zero();
        for i in (0..n).rev() {
            tau[i] = f[i].along(&self.subspace[i]);
            match (self.parent[i], v0) {
                (Some(p), _) => f[p] = f[p].add(&xs[i].force_back(&f[i])),
                (None, Some(_)) => f0 = f0.add(&xs[i].force_back(&f[i])),
                (None, None) => {}
            }
        }
        f0
    }

    /// The joint-space mass matrix `M(q)` (CRBA), row-major, symmetric.
    pub fn crba<S: Scalar>(&self, q: &[S]) -> Vec<Vec<S>> {
        let n = self.nq();
        let mut m = vec![S::zero(); n * n];
        self.crba_in(&mut Data::new(self), q, &mut m);
        m.chunks(n.max(1)).take(n).map(<[S]>::to_vec).collect()
    }

    /// [`Model::crba`] into `m` (n × n, row-major), with the workspace `d`: no allocation.
    pub fn crba_in<S: Scalar>(&self, d: &mut Data<S>, q: &[S], m: &mut [S]) {
        self.crba_tree(d, None, q, m);
    }

    /// The mass matrix of a floating-base model ([`Model::free_base`]), `(6 + n)` square,
    /// row-major: the base's acceleration `(ω̇, v̇)` in its own frame first, then the
    /// joints. CRBA with the base as the root of every composite: the base block is the
    /// whole robot's inertia about the base origin, a joint's base column its subtree's
    /// composite inertia times its axis carried back to the base (the joints' block is
    /// [`Model::crba_in`]'s: it does not depend on the base's pose). O(n d), where forming
    /// it by inverse dynamics column by column is O(n²).
    pub fn crba_free_in<S: Scalar>(&self, d: &mut Data<S>, q: &[S], m: &mut [S]) {
        let fb = self.free_base.as_ref().expect("a floating base");
        self.crba_tree(d, Some(&fb.inertia), q, m);
    }

    /// CRBA from a fixed base (`base = None`: `m` is n square) or a floating one (its
    /// inertia: `m` is `6 + n` square, the base's `(ω̇, v̇)` first).
    fn crba_tree<S: Scalar>(
        &self,
        d: &mut Data<S>,
        base: Option<&RigidInertia<f64>>,
        q: &[S],
        m: &mut [S],
    ) {
        let n = self.nq();
        let o = if base.is_some() { 6 } else { 0 };
        let size = o + n;
        assert_eq!(
            m.len(),
            size * size,
            "m has {} entries, not {size}²",
            m.len()
        );
        self.transforms_into(q, &mut d.xs);
        let Data { xs, ic, .. } = d;
        ic.clear();
        ic.extend(self.inertia.iter().map(RigidInertia::lift));
        let mut whole = base.map(RigidInertia::<S>::lift);
        for i in (0..n).rev() {
            match (self.parent[i], whole.as_mut()) {
                (Some(p), _) => ic[p] = ic[p].add(&ic[i].back(&xs[i])),
                (None, Some(w)) => *w = w.add(&ic[i].back(&xs[i])),
                (None, None) => {}
            }
        }
        m.fill(S::zero());
        // A base column `c`: the wrench `f` (ang, lin) in both its row and its column.
        let put = |m: &mut [S], c: usize, f: &Force<S>| {
            for k in 0..3 {
                m[k * size + c] = f.ang[k];
                m[(3 + k) * size + c] = f.lin[k];
                m[c * size + k] = f.ang[k];
                m[c * size + 3 + k] = f.lin[k];
            }
        };
        if let Some(w) = &whole {
            for k in 0..6 {
                let mut unit = Motion::zero();
                if k < 3 {
                    unit.ang[k] = S::one();
                } else {
                    unit.lin[k - 3] = S::one();
                }
                put(m, k, &w.apply(&unit));
            }
        }
        for (i, composite) in ic.iter().enumerate() {
            let mut f = composite.apply(&Motion::from_axis(&self.subspace[i], S::one()));
            let c = o + i;
            m[c * size + c] = f.along(&self.subspace[i]);
            let mut j = i;
            while let Some(p) = self.parent[j] {
                f = xs[j].force_back(&f);
                j = p;
                m[c * size + o + j] = f.along(&self.subspace[j]);
                m[(o + j) * size + c] = m[c * size + o + j];
            }
            if whole.is_some() {
                put(m, c, &xs[j].force_back(&f));
            }
        }
    }

    /// Forward dynamics (ABA): `q̈` from `(q, q̇, τ)` under gravity, with the joints'
    /// viscous damping applied as `τ − d q̇`.
    pub fn aba<S: Scalar>(&self, q: &[S], qd: &[S], tau: &[S]) -> Vec<S> {
        let mut qdd = vec![S::zero(); self.nq()];
        self.aba_in(&mut Data::new(self), q, qd, tau, &mut qdd);
        qdd
    }

    /// [`Model::aba`] into `qdd`, with the workspace `d`: no allocation.
    ///
    /// With mimic joints ([`Model::follows`]), `q` and `q̇` must be consistent with them,
    /// and `q̈` (every joint's, consistent too) solves the dynamics reduced to the
    /// independent joints, `Gᵀ M G q̈ᵣ = Gᵀ (τ − d q̇ − b)` with `q̇ = G q̇ᵣ`
    /// ([`Model::reduced_in`]): a force on a mimic joint acts on the joint it follows
    /// through the multiplier, and so does its damping (`−r² d q̇ᵣ`).
    pub fn aba_in<S: Scalar>(&self, d: &mut Data<S>, q: &[S], qd: &[S], tau: &[S], qdd: &mut [S]) {
        let n = self.nq();
        assert_eq!(tau.len(), n, "tau has {} entries, not nq", tau.len());
        if self.has_mimics() {
            self.reduced_in(d, q, qd, tau, qdd);
            return;
        }
        self.aba_tree(d, None, q, qd, tau, qdd);
    }

    /// Forward dynamics of a floating-base model ([`Model::free_base`]): `q̈` into `qdd`,
    /// and the base's acceleration returned, `d/dt` of its velocity's base-frame
    /// components (`(ω̇, v̇)`: Pinocchio's free-flyer `a`), under gravity, with no force on
    /// the base but its joints'. The base's orientation `rotation` (world ← base) places
    /// gravity; its position plays no part. The articulated-body algorithm (Featherstone
    /// 2008, §9.3: the base solved from its articulated inertia, a 6 × 6 LDLᵀ); with mimic
    /// joints, the mass matrix reduced to the base and the independent joints
    /// ([`Model::reduced_free_in`]).
    #[allow(clippy::too_many_arguments)] // the base's state beside the joints'
    pub fn aba_free_in<S: Scalar>(
        &self,
        d: &mut Data<S>,
        rotation: &M3<S>,
        velocity: &Motion<S>,
        q: &[S],
        qd: &[S],
        tau: &[S],
        qdd: &mut [S],
    ) -> Motion<S> {
        assert!(self.free_base.is_some(), "{}: no floating base", self.name);
        assert_eq!(
            tau.len(),
            self.nq(),
            "tau has {} entries, not nq",
            tau.len()
        );
        if self.has_mimics() {
            return self.reduced_free_in(d, rotation, velocity, q, qd, tau, qdd);
        }
        self.aba_tree(d, Some((rotation, velocity)), q, qd, tau, qdd)
    }

    /// Inverse dynamics of a floating-base model: the joint forces into `tau` and the
    /// wrench on the base returned (base frame, about its origin) that give the base the
    /// acceleration `a0` (as [`Model::aba_free_in`] returns it) and the joints `qdd`, at
    /// the base velocity `velocity` and `(q, q̇)`; under gravity when `gravity`, else
    /// without (the mass matrix's columns). Damping is not included.
    #[allow(clippy::too_many_arguments)] // the base's state beside the joints'
    pub fn rnea_free_in<S: Scalar>(
        &self,
        d: &mut Data<S>,
        (rotation, velocity, a0): (&M3<S>, &Motion<S>, &Motion<S>),
        q: &[S],
        qd: &[S],
        qdd: &[S],
        gravity: bool,
        tau: &mut [S],
    ) -> Force<S> {
        let fb = self.free_base.as_ref().expect("a floating base");
        // The fictitious acceleration of gravity (see `aba_tree`): â₀ = a₀ − (0, Rᵀ g).
        let down = if gravity {
            mat_t_vec(rotation, &lift3(&self.gravity))
        } else {
            [S::zero(); 3]
        };
        let a0 = Motion {
            ang: a0.ang,
            lin: [
                a0.lin[0] - down[0],
                a0.lin[1] - down[1],
                a0.lin[2] - down[2],
            ],
        };
        let joints = self.rnea_tree(d, Some(velocity), &a0, q, qd, qdd, tau);
        let inertia = RigidInertia::<S>::lift(&fb.inertia);
        inertia
            .apply(&a0)
            .add(&velocity.cross_force(&inertia.apply(velocity)))
            .add(&joints)
    }

    /// [`Model::aba_free_in`] with mimic joints: the dynamics reduced to the base and the
    /// independent joints, `Gᵀ M G [a₀; q̈ᵣ] = Gᵀ ([0; τ − d q̇] − b)`, as
    /// [`Model::reduced_in`] for a fixed base: M by CRBA with the base
    /// ([`Model::crba_free_in`], O(n d)), b the inverse dynamics at zero acceleration
    /// ([`Model::rnea_free_in`]), solved by LDLᵀ (O(n³), skipped where the factor is
    /// current: [`Data::mass_is_current`]).
    #[allow(clippy::too_many_arguments)]
    fn reduced_free_in<S: Scalar>(
        &self,
        d: &mut Data<S>,
        rotation: &M3<S>,
        velocity: &Motion<S>,
        q: &[S],
        qd: &[S],
        tau: &[S],
        qdd: &mut [S],
    ) -> Motion<S> {
        let (n, nr, rank) = (self.nq(), self.ndof(), &self.driver_index);
        let size = 6 + nr;
        // Gᵀ of a base wrench and joint forces: (wrench; Σ r τ per independent joint).
        let reduce = |f0: &Force<S>, t: &[S], out: &mut [S]| {
            out[..3].copy_from_slice(&f0.ang);
            out[3..6].copy_from_slice(&f0.lin);
            out[6..].fill(S::zero());
            for i in 0..n {
                out[6 + rank[i]] += t[i] * self.driver(i).1;
            }
        };
        let mut mass = std::mem::take(&mut d.reduced);
        let mut t = vec![S::zero(); n];
        let still = Motion::zero();
        if !d.mass_is_current {
            // The full mass matrix by CRBA, then Gᵀ M G: the base's six pass through, a
            // mimic joint's row and column add to its driver's, times its multiplier.
            let full = 6 + n;
            let mut m = std::mem::take(&mut d.mass);
            m.clear();
            m.resize(full * full, S::zero());
            self.crba_free_in(d, q, &mut m);
            self.reduce_mass_into(&m, 6, &mut mass);
            ldl_factor_flat(&mut mass, size);
            d.mass = m;
        }
        qdd.fill(S::zero());
        let f0 = self.rnea_free_in(d, (rotation, velocity, &still), q, qd, qdd, true, &mut t);
        let mut rhs = vec![S::zero(); size];
        for i in 0..n {
            t[i] = tau[i] - qd[i] * self.damping[i] - t[i];
        }
        reduce(&Force::zero().sub(&f0), &t, &mut rhs);
        ldl_substitute_flat(&mass, size, &mut rhs);
        for i in 0..n {
            qdd[i] = rhs[6 + rank[i]] * self.driver(i).1;
        }
        d.reduced = mass;
        Motion {
            ang: [rhs[0], rhs[1], rhs[2]],
            lin: [rhs[3], rhs[4], rhs[5]],
        }
    }

    /// The articulated-body algorithm on the tree from a fixed base (`base = None`) or a
    /// floating one (its rotation world ← base and velocity): `q̈` into `qdd`, and the
    /// floating base's acceleration (zero for a fixed base).
    ///
    /// Gravity is the fictitious acceleration `(0, −g)` of the world (Featherstone's
    /// trick): every body's acceleration here is its own plus `X (0, −g)`. A fixed base's
    /// is then `(0, −g)`; a floating base's, `â₀ = −I₀ᴬ⁻¹ p₀ᴬ` (no force on it but its
    /// joints'), and its own is `â₀ − (0, −Rᵀg)`.
    fn aba_tree<S: Scalar>(
        &self,
        d: &mut Data<S>,
        base: Option<(&M3<S>, &Motion<S>)>,
        q: &[S],
        qd: &[S],
        tau: &[S],
        qdd: &mut [S],
    ) -> Motion<S> {
        let n = self.nq();
        self.velocities_into(base.map(|b| b.1), q, qd, d);
        let Data {
            xs,
            v,
            c,
            a,
            ia,
            pa,
            u_vec,
            d_inv,
            u,
            ..
        } = d;
        c.clear();
        ia.clear();
        pa.clear();
        for i in 0..n {
            c.push(v[i].cross_motion(&Motion::from_axis(&self.subspace[i], qd[i])));
            let inertia = RigidInertia::<S>::lift(&self.inertia[i]);
            ia.push(ArticulatedInertia::from_rigid(&inertia));
            pa.push(v[i].cross_force(&inertia.apply(&v[i])));
        }
        // The floating base's articulated inertia and bias force, its joints' added below.
        let mut root = match (base, &self.free_base) {
            (Some((_, v0)), Some(fb)) => {
                let inertia = RigidInertia::<S>::lift(&fb.inertia);
                Some((
                    ArticulatedInertia::from_rigid(&inertia),
                    v0.cross_force(&inertia.apply(v0)),
                ))
            }
            _ => None,
        };
        u_vec.clear();
        u_vec.resize(n, Force::zero());
        d_inv.clear();
        d_inv.resize(n, S::zero());
        u.clear();
        u.resize(n, S::zero());
        for i in (0..n).rev() {
            let s = &self.subspace[i];
            let ui = ia[i].apply(&Motion::from_axis(s, S::one()));
            let di_inv = ui.along(s).recip();
            let force = tau[i] - qd[i] * self.damping[i];
            u[i] = force - pa[i].along(s);
            if self.parent[i].is_some() || root.is_some() {
                let ia_child = ia[i].minus_outer(&ui, di_inv);
                let pa_child = pa[i]
                    .add(&ia_child.apply(&c[i]))
                    .add(&ui.scale(u[i] * di_inv));
                let (ia_back, pa_back) = (ia_child.back(&xs[i]), xs[i].force_back(&pa_child));
                let (ia_p, pa_p) = match (self.parent[i], root.as_mut()) {
                    (Some(p), _) => (&mut ia[p], &mut pa[p]),
                    (None, Some((ia0, pa0))) => (ia0, pa0),
                    (None, None) => unreachable!("tested above"),
                };
                *ia_p = ia_p.add(&ia_back);
                *pa_p = pa_p.add(&pa_back);
            }
            u_vec[i] = ui;
            d_inv[i] = di_inv;
        }
        let (a0, own) = match (root, base) {
            (Some((ia0, pa0)), Some((r, _))) => {
                let a0 = solve_articulated(&ia0, &pa0.scale(-S::one()));
                let up = mat_t_vec(r, &lift3(&self.gravity));
                let own = Motion {
                    ang: a0.ang,
                    lin: add(&a0.lin, &up),
                };
                (a0, own)
            }
            _ => (self.base_acceleration::<S>(), Motion::zero()),
        };
        a.clear();
        for i in 0..n {
            let ap = match self.parent[i] {
                None => xs[i].motion(&a0),
                Some(p) => xs[i].motion(&a[p]),
            }
            .add(&c[i]);
            qdd[i] = (u[i] - ap.dot(&u_vec[i])) * d_inv[i];
            a.push(ap.add(&Motion::from_axis(&self.subspace[i], qdd[i])));
        }
        own
    }

    /// q̈ of a model with mimic joints: the mass matrix (CRBA) and the bias forces
    /// `b = RNEA(q, q̇, 0)` of the tree, reduced by `G` (`q̇ = G q̇ᵣ`: a 1 in each independent
    /// joint's column for itself, the multiplier for each joint following it), solved by
    /// LDLᵀ (`Gᵀ M G` is positive definite when the reduced mechanism has mass on every
    /// coordinate), and `q̈ = G q̈ᵣ`. Allocates nothing after the first call on `d`.
    fn reduced_in<S: Scalar>(&self, d: &mut Data<S>, q: &[S], qd: &[S], tau: &[S], qdd: &mut [S]) {
        let n = self.nq();
        let mut mass = std::mem::take(&mut d.mass);
        if !d.mass_is_current {
            mass.resize(n * n, S::zero());
            self.crba_in(d, q, &mut mass);
        }
        let mut bias = std::mem::take(&mut d.bias);
        bias.clear();
        bias.resize(n, S::zero());
        // q̈ = 0 for the bias: `qdd` is overwritten below.
        qdd.fill(S::zero());
        self.rnea_in(d, q, qd, qdd, &mut bias);
        let (rank, nr) = (&self.driver_index, self.ndof());
        let (reduced, rhs) = (&mut d.reduced, &mut d.rhs);
        if !d.mass_is_current {
            self.reduce_mass_into(&mass, 0, reduced);
            ldl_factor_flat(reduced, nr);
        }
        rhs.clear();
        rhs.resize(nr, S::zero());
        for i in 0..n {
            rhs[rank[i]] += (tau[i] - qd[i] * self.damping[i] - bias[i]) * self.driver(i).1;
        }
        ldl_substitute_flat(reduced, nr, rhs);
        for i in 0..n {
            qdd[i] = rhs[rank[i]] * self.driver(i).1;
        }
        d.mass = mass;
        d.bias = bias;
    }

    /// `Gᵀ M G` into `reduced` (`base + ndof` square, row-major) from the mass matrix `mass`
    /// (`base + nq` square) whose first `base` coordinates (0, or a floating base's 6) pass
    /// through: a mimic joint's row and column add to its driver's, times its multiplier.
    /// `M` itself without mimic joints.
    fn reduce_mass_into<S: Scalar>(&self, mass: &[S], base: usize, reduced: &mut Vec<S>) {
        let (full, size) = (base + self.nq(), base + self.ndof());
        let at = |a: usize| -> (usize, f64) {
            if a < base {
                (a, 1.0)
            } else {
                (base + self.driver_index[a - base], self.driver(a - base).1)
            }
        };
        reduced.clear();
        reduced.resize(size * size, S::zero());
        for a in 0..full {
            let (ra, fa) = at(a);
            for b in 0..full {
                let (rb, fb) = at(b);
                reduced[ra * size + rb] += mass[a * full + b] * (fa * fb);
            }
        }
    }

    /// The first independent joint (model index) at which the LDLᵀ factorisation of the
    /// reduced mass matrix `Gᵀ M(q) G` meets a pivot below `1e-12` of that joint's diagonal
    /// entry (or a non-positive one): the dynamics is singular there (a joint moving no
    /// inertia about its axis). `None`: positive definite.
    pub fn singular_joint(&self, q: &[f64]) -> Option<usize> {
        let (n, nr) = (self.nq(), self.ndof());
        let mut mass = vec![0.0; n * n];
        self.crba_in(&mut Data::new(self), q, &mut mass);
        let mut m = Vec::new();
        self.reduce_mass_into(&mass, 0, &mut m);
        let diagonal: Vec<f64> = (0..nr).map(|k| m[k * nr + k]).collect();
        ldl_factor_flat(&mut m, nr);
        // The pivots in order: a bad one spoils only those after it.
        let bad = (0..nr).find(|&j| {
            // (NaN fails both comparisons: singular too.)
            let positive = m[j * nr + j] > 1e-12 * diagonal[j] && diagonal[j] > 0.0;
            !positive
        })?;
        (0..n).find(|&i| self.follows[i].is_none() && self.driver_index[i] == bad)
    }

    /// Kinetic energy `½ Σ v_iᵀ I_i v_i`.
    pub fn kinetic_energy<S: Scalar>(&self, q: &[S], qd: &[S]) -> S {
        self.kinetic(None, q, qd)
    }

    /// Kinetic energy of a floating-base model, the base's `½ v₀ᵀ I₀ v₀` included
    /// (`velocity` the base's, in base coordinates).
    pub fn kinetic_energy_free<S: Scalar>(&self, velocity: &Motion<S>, q: &[S], qd: &[S]) -> S {
        let fb = self.free_base.as_ref().expect("a floating base");
        let inertia = RigidInertia::<S>::lift(&fb.inertia);
        velocity.dot(&inertia.apply(velocity)) * 0.5 + self.kinetic(Some(velocity), q, qd)
    }

    fn kinetic<S: Scalar>(&self, v0: Option<&Motion<S>>, q: &[S], qd: &[S]) -> S {
        let (_, v) = self.velocities(v0, q, qd);
        let mut t = S::zero();
        for (vi, inertia) in v.iter().zip(&self.inertia) {
            t += vi.dot(&RigidInertia::<S>::lift(inertia).apply(vi)) * 0.5;
        }
        t
    }

    /// `Σ m_i c_i` of the moving bodies in the base frame (c_i the centre of mass).
    fn first_moment<S: Scalar>(&self, q: &[S]) -> V3<S> {
        let poses = self.forward_kinematics(q);
        let mut sum = [S::zero(); 3];
        for ((r, p), inertia) in poses.iter().zip(&self.inertia) {
            // m c_base = R h + m p.
            let mc = add(
                &mat_vec(r, &lift3(&inertia.h)),
                &scale(p, S::from(inertia.m)),
            );
            sum = add(&sum, &mc);
        }
        sum
    }

    /// Potential energy `−Σ m_i g · c_i` of the moving bodies (c_i the centre of mass in
    /// the base frame): zero with every centre of mass at the base origin; the fixed base
    /// (and what is folded into it) is left out, being constant.
    pub fn potential_energy<S: Scalar>(&self, q: &[S]) -> S {
        let poses = self.forward_kinematics(q);
        let g: V3<S> = lift3(&self.gravity);
        let mut v = S::zero();
        for ((r, p), inertia) in poses.iter().zip(&self.inertia) {
            // m c_world = R h + m p.
            let mc = add(
                &mat_vec(r, &lift3(&inertia.h)),
                &scale(p, S::from(inertia.m)),
            );
            v -= mc[0] * g[0] + mc[1] * g[1] + mc[2] * g[2];
        }
        v
    }

    /// Potential energy of a floating-base model, `−Σ m_i g · c_i` over every body, the
    /// base's included, with the centres of mass in the world (`rotation` world ← base,
    /// `position` the base's origin): zero with them all at the world origin.
    pub fn potential_energy_free<S: Scalar>(
        &self,
        rotation: &M3<S>,
        position: &V3<S>,
        q: &[S],
    ) -> S {
        let fb = self.free_base.as_ref().expect("a floating base");
        let m = self.inertia.iter().map(|i| i.m).sum::<f64>() + fb.inertia.m;
        let local = add(&self.first_moment(q), &lift3(&fb.inertia.h));
        let mc = add(&scale(position, S::from(m)), &mat_vec(rotation, &local));
        let g: V3<S> = lift3(&self.gravity);
        -(mc[0] * g[0] + mc[1] * g[1] + mc[2] * g[2])
    }
}

/// `x` with `I x = f` for a symmetric positive definite 6 × 6 inertia (a floating base's
/// articulated inertia), by LDLᵀ without pivoting (no branch on values: dual numbers and
/// the tracer go through it).
pub fn solve_articulated<S: Scalar>(inertia: &ArticulatedInertia<S>, f: &Force<S>) -> Motion<S> {
    let (a, b, c) = (&inertia.a, &inertia.b, &inertia.c);
    let mut m = [S::zero(); 36];
    for r in 0..3 {
        for k in 0..3 {
            m[r * 6 + k] = a[r][k];
            m[r * 6 + 3 + k] = b[r][k];
            m[(3 + r) * 6 + k] = b[k][r];
            m[(3 + r) * 6 + 3 + k] = c[r][k];
        }
    }
    let mut x = [f.ang[0], f.ang[1], f.ang[2], f.lin[0], f.lin[1], f.lin[2]];
    ldl_factor_flat(&mut m, 6);
    ldl_substitute_flat(&m, 6, &mut x);
    Motion {
        ang: [x[0], x[1], x[2]],
        lin: [x[3], x[4], x[5]],
    }
}

/// LDLᵀ of `m` (n × n row-major, symmetric positive definite) in place, without pivoting
/// or branches, so that dual numbers and the tracer go through it: its strict lower
/// triangle becomes L (unit diagonal implied), its diagonal D.
#[allow(clippy::needless_range_loop)] // triangular index arithmetic reads best as indices
pub fn ldl_factor_flat<S: Scalar>(m: &mut [S], n: usize) {
    for j in 0..n {
        for k in 0..j {
            let t = m[j * n + k] * (m[j * n + k] * m[k * n + k]);
            m[j * n + j] -= t;
        }
        let inv = m[j * n + j].recip();
        for i in j + 1..n {
            let mut s = m[i * n + j];
            for k in 0..j {
                s -= m[i * n + k] * (m[j * n + k] * m[k * n + k]);
            }
            m[i * n + j] = s * inv;
        }
    }
}

/// Solves `L D Lᵀ x = b` in place (`x` holds b), with the factors of [`ldl_factor_flat`].
#[allow(clippy::needless_range_loop)]
pub fn ldl_substitute_flat<S: Scalar>(m: &[S], n: usize, x: &mut [S]) {
    for i in 0..n {
        for k in 0..i {
            let t = m[i * n + k] * x[k];
            x[i] -= t;
        }
    }
    for i in 0..n {
        x[i] /= m[i * n + i];
    }
    for i in (0..n).rev() {
        for k in i + 1..n {
            let t = m[k * n + i] * x[k];
            x[i] -= t;
        }
    }
}
