//! Forward dynamics specialised per model and emitted as straight-line Rust (the RobCoGen
//! idea): the model's numbers become constants, the zeros and ones of its axes and
//! placements fold away, and what runs is each remaining operation once.
//!
//! The pipeline: a [`Model`] is traced with the symbolic scalar
//! ([`Expr`](crate::model::symbolic::Expr)), q, q̇ and τ as leaves, through one of the
//! branch-free algorithms of [`Algorithm`]; the graph's q̈ roots (and, for the Jacobian,
//! their symbolic derivatives, [`Jacobian`]) are emitted by
//! [`straight_line`](crate::model::symbolic::emit::straight_line) as functions generic over
//! the scalar, so dual numbers still differentiate them:
//!
//! ```text
//! pub fn aba<S: Scalar>(q: &[S], qd: &[S], tau: &[S], qdd: &mut [S])
//! pub fn aba_derivatives<S: Scalar>(q, qd, tau, qdd, dqdd_dq, dqdd_dqd)   // n ≤ 9
//! ```
//!
//! (Longer mechanisms' Jacobians: [`super::derivatives`], analytical, O(n²) at run time.)
//!
//! **Damping is inside**, as in [`Model::aba`]: the joints' viscous damping acts as
//! `τ − d q̇`; a caller passes the applied joint forces only.
//!
//! Before tracing, rotation and axis entries within [`SNAP`] (1e-10) of 0 or ±1 are set to
//! exactly that: URDF placements written as `rpy = π/2` give `cos(π/2) = 6e-17`, and UR5's
//! `1.57079632679` (π/2 to 11 digits) gives 4.9e-12, which would otherwise keep every
//! product with them. The generated code is therefore the model of [`snapped`]: it equals
//! [`Model::aba`] of that model to rounding (tests: 1e-12 relative), and the literal URDF's
//! to the size of what was snapped (UR5: a few 1e-12 relative; tests: 1e-10, the
//! tolerance of the Pinocchio comparison).
//!
//! A floating base's code takes the base's pose and velocity after the joints' and gives
//! its acceleration after theirs ([`floating_dynamics`]); mimic joints' is the reduced
//! mass-matrix solve of [`Model::aba`], traced.
//!
//! The committed output for the benchmark models (UR5, Panda, the spatial chain of
//! [`spatial_chain_urdf`]; the Panda with its mimic finger, Go2 floating) is under
//! `src/multibody/generated/`; a test regenerates it and
//! compares (`MBFMU_REGENERATE=1` rewrites it).

use super::dynamics::{Data, Model};
use super::spatial::{
    cross, lift3, mat_t_vec, mat_vec, quat_to_matrix, Force, Motion, RigidInertia, Transform, M3,
    V3,
};
use crate::model::symbolic::emit::{straight_line, Straight};
use crate::model::symbolic::expr::with_graph;
use crate::model::symbolic::{diff, record, Arg, Expr, Graph, Id, Node};
use crate::model::Scalar;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Rotation and axis entries this close to 0 or ±1 are snapped to it before tracing (the
/// committed benchmark modules).
pub const SNAP: f64 = 1e-10;

/// The snapping of a robot's crate ([`robot_dynamics`]): only the rounding of an exact 0
/// or ±1 (`cos(π/2)` = 6e-17), so that its code is the URDF's model to rounding. [`SNAP`]
/// would also take UR5's `1.57079632679` (π/2 to 11 digits, 4.9e-12 off), which moves its
/// q̈ by up to 1.8e-10 relative (measured against `pin.aba` through the FMU), past the
/// 1e-10 of the Pinocchio comparison; kept, it costs UR5 more operations.
pub const EXACT_SNAP: f64 = 1e-14;

/// How q̈ is computed in the generated code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Algorithm {
    /// [`Model::aba`] as it is (Featherstone's table 7.1).
    Aba,
    /// The articulated-body algorithm restated for constant folding ([`aba_folded`]):
    /// symmetric inertias stored once, the joint rotation applied after the constant
    /// placement, the joint axis' zeros visible to the tracer.
    AbaFolded,
    /// Mass matrix (CRBA) and bias (RNEA at q̈ = 0), then a dense LDLᵀ solve: n³/6
    /// multiplications, competitive for short chains only.
    CrbaLdl,
}

/// One model to generate: module name, the model, the algorithm, whether the Jacobian is
/// emitted symbolically too.
pub struct Target {
    pub module: String,
    pub model: Model,
    /// Entries within this of 0 or ±1 are snapped ([`SNAP`], [`EXACT_SNAP`]).
    pub snap: f64,
    pub algorithm: Algorithm,
    /// The Jacobian emitted as `aba_derivatives`, if any.
    pub jacobian: Option<Jacobian>,
}

/// The spatial chain of `n` revolute links: joint i turns about z, y, x, z, … (i mod 3),
/// each link 0.3 m long along its z axis (the next joint at its end, no rotation in the
/// placement), 1 kg, centre of mass mid-link, inertia about it diag(0.0075, 0.0075, 0.001)
/// kg m² (a rod with some thickness); gravity 9.81 m/s² along −z, no damping. Written as a
/// URDF so that Pinocchio reads the same mechanism.
pub fn spatial_chain_urdf(n: usize) -> String {
    let mut s = format!(
        "<?xml version=\"1.0\"?>\n<robot name=\"spatial_chain_{n}\">\n  <link name=\"base\"/>\n"
    );
    for i in 0..n {
        let axis = ["0 0 1", "0 1 0", "1 0 0"][i % 3];
        let parent = if i == 0 {
            "base".to_string()
        } else {
            format!("link{}", i - 1)
        };
        let z = if i == 0 { 0.0 } else { 0.3 };
        write!(
            s,
            "  <link name=\"link{i}\">
    <inertial>
      <origin xyz=\"0 0 0.15\" rpy=\"0 0 0\"/>
      <mass value=\"1\"/>
      <inertia ixx=\"0.0075\" ixy=\"0\" ixz=\"0\" iyy=\"0.0075\" iyz=\"0\" izz=\"0.001\"/>
    </inertial>
  </link>
  <joint name=\"j{i}\" type=\"revolute\">
    <parent link=\"{parent}\"/>
    <child link=\"link{i}\"/>
    <origin xyz=\"0 0 {z}\" rpy=\"0 0 0\"/>
    <axis xyz=\"{axis}\"/>
    <limit lower=\"-6.3\" upper=\"6.3\" effort=\"100\" velocity=\"10\"/>
  </joint>
"
        )
        .unwrap();
    }
    s.push_str("</robot>\n");
    s
}

/// The chain sizes of the committed code and the benchmark.
pub const CHAIN_SIZES: [usize; 7] = [1, 2, 4, 8, 16, 32, 64];

/// Where the generated modules (and the robots' URDFs, under `urdf/`) live.
pub fn generated_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src/multibody/generated")
}

/// The model of a committed URDF (`ur5`, `panda`, `panda_mimic`; `go2_floating`: `go2`
/// with its floating base) or of `chain_N`.
pub fn benchmark_model(module: &str) -> Model {
    let (file, floating) = match module.strip_suffix("_floating") {
        Some(file) => (file, true),
        None => (module, false),
    };
    let mut mechanism = match file.strip_prefix("chain_") {
        Some(n) => {
            let n: usize = n.parse().expect("chain_N");
            super::urdf::parse(&spatial_chain_urdf(n), module)
        }
        None => super::urdf::load(&generated_dir().join(format!("urdf/{file}.urdf"))),
    }
    .unwrap_or_else(|e| panic!("{module}: {e}"));
    mechanism.floating_base = floating;
    Model::new(&mechanism).unwrap_or_else(|e| panic!("{module}: {e}"))
}

/// The committed models. Each gets the algorithm with the fewest operations after
/// folding ([`fewest_operations`]); the Jacobian is emitted symbolically for UR5, Panda and
/// the chains up to 8 links (beyond, the code grows past a megabyte; the analytical O(n²)
/// derivatives of [`super::derivatives`] run there instead). The Panda with its mimic
/// finger and Go2 floating are there for the benchmark of those paths (q̈ only).
pub fn targets() -> Vec<Target> {
    let mut modules: Vec<String> = vec!["ur5".into(), "panda".into()];
    modules.extend(CHAIN_SIZES.iter().map(|n| format!("chain_{n}")));
    modules.extend(["panda_mimic".into(), "go2_floating".into()]);
    modules
        .into_iter()
        .map(|module| {
            let model = benchmark_model(&module);
            let algorithm = fewest_operations(&model);
            Target {
                snap: SNAP,
                jacobian: (model.nq() <= 9 && algorithm != Algorithm::Aba)
                    .then(|| fewest_jacobian(&model, algorithm)),
                algorithm,
                module,
                model,
            }
        })
        .collect()
}

/// Of [`Algorithm::AbaFolded`] and [`Algorithm::CrbaLdl`], the one whose traced q̈ has
/// fewer operations (CRBA's n³/6 solve wins for short chains only; the tie goes to ABA).
pub fn fewest_operations(model: &Model) -> Algorithm {
    fewest_operations_within(model, SNAP)
}

/// [`fewest_operations`] with entries within `snap` of 0 or ±1 snapped.
///
/// A model with mimic joints or a floating base: [`Algorithm::Aba`], which is
/// [`Model::aba`]'s reduced mass-matrix solve for mimics and [`Model::aba_free_in`] for a
/// floating base ([`floating_dynamics`]; the other two know neither).
pub fn fewest_operations_within(model: &Model, snap: f64) -> Algorithm {
    if model.has_mimics() || model.free_base.is_some() {
        return Algorithm::Aba;
    }
    let ops = |alg| {
        let t = trace_within(model, alg, None, snap);
        straight_line(&t.graph, &t.qdd, &leaf_name).operations
    };
    if model.nq() > 16 || ops(Algorithm::AbaFolded) <= ops(Algorithm::CrbaLdl) {
        Algorithm::AbaFolded
    } else {
        Algorithm::CrbaLdl
    }
}

/// Of the two [`Jacobian`]s, the one whose code (q̈ and the Jacobian) has fewer operations.
pub fn fewest_jacobian(model: &Model, algorithm: Algorithm) -> Jacobian {
    let ops = |how| {
        let t = trace(model, algorithm, Some(how));
        let roots: Vec<Id> = t.qdd.iter().chain(&t.dq).chain(&t.dqd).copied().collect();
        straight_line(&t.graph, &roots, &leaf_name).operations
    };
    if ops(Jacobian::InverseDynamics) <= ops(Jacobian::ForwardOfForwardDynamics) {
        Jacobian::InverseDynamics
    } else {
        Jacobian::ForwardOfForwardDynamics
    }
}

/// `model` with rotation and axis entries within [`SNAP`] of 0 or ±1 set to exactly that.
pub fn snapped(model: &Model) -> Model {
    snapped_within(model, SNAP)
}

/// `model` with rotation and axis entries within `within` of 0 or ±1 set to exactly that.
pub fn snapped_within(model: &Model, within: f64) -> Model {
    let snap = |x: f64| {
        if x.abs() < within {
            0.0
        } else if (x.abs() - 1.0).abs() < within {
            x.signum()
        } else {
            x
        }
    };
    let mut m = model.clone();
    for r in &mut m.rotation {
        for row in r.iter_mut() {
            for x in row.iter_mut() {
                *x = snap(*x);
            }
        }
    }
    for a in &mut m.axis {
        for x in a.iter_mut() {
            *x = snap(*x);
        }
    }
    for s in &mut m.subspace {
        for x in s.ang.iter_mut().chain(s.lin.iter_mut()) {
            *x = snap(*x);
        }
    }
    m
}

/// q̈ by `algorithm` (damping inside, `τ − d q̇`), generic over the scalar.
pub fn forward_dynamics<S: Scalar>(
    model: &Model,
    algorithm: Algorithm,
    q: &[S],
    qd: &[S],
    tau: &[S],
) -> Vec<S> {
    match algorithm {
        Algorithm::Aba => model.aba(q, qd, tau),
        Algorithm::AbaFolded => aba_folded(model, q, qd, tau),
        Algorithm::CrbaLdl => crba_ldl(model, q, qd, tau),
    }
}

/// The generated code's layout for a floating-base model ([`Model::free_base`]), `n` its
/// joints (mimic joints included):
/// - `q`: the joints' positions, then the base's `x y z` (world frame) and its unit
///   quaternion `w x y z` (world ← base): `n + 7`;
/// - `q̇`: the joints' velocities, then the base's `v` and `ω` (base frame): `n + 6`;
/// - `τ`: the joints' forces: `n`;
/// - out: the joints' `q̈`, then the base's `v̇` and `ω̇`: `n + 6`.
///
/// By [`Model::aba_free_in`] (its reduced path with mimic joints), the rotation from
/// [`quat_to_matrix`] (homogeneous: no branch, exact on the unit sphere). The base's
/// position plays no part (gravity is uniform).
pub fn floating_dynamics<S: Scalar>(model: &Model, q: &[S], qd: &[S], tau: &[S]) -> Vec<S> {
    let n = model.nq();
    assert_eq!((q.len(), qd.len(), tau.len()), (n + 7, n + 6, n));
    let rotation = quat_to_matrix(&[q[n + 3], q[n + 4], q[n + 5], q[n + 6]]);
    let velocity = Motion {
        ang: [qd[n + 3], qd[n + 4], qd[n + 5]],
        lin: [qd[n], qd[n + 1], qd[n + 2]],
    };
    let mut out = vec![S::zero(); n + 6];
    let (joints, base) = out.split_at_mut(n);
    let a0 = model.aba_free_in(
        &mut Data::new(model),
        &rotation,
        &velocity,
        &q[..n],
        &qd[..n],
        tau,
        joints,
    );
    base[..3].copy_from_slice(&a0.lin);
    base[3..].copy_from_slice(&a0.ang);
    out
}

/// CRBA + RNEA bias + dense LDLᵀ (no pivoting: M is positive definite).
pub fn crba_ldl<S: Scalar>(model: &Model, q: &[S], qd: &[S], tau: &[S]) -> Vec<S> {
    let n = model.nq();
    let mut m = model.crba(q);
    let bias = model.rnea(q, qd, &vec![S::zero(); n]);
    let mut x: Vec<S> = (0..n)
        .map(|i| tau[i] - qd[i] * model.damping[i] - bias[i])
        .collect();
    let d_inv = ldl_factor(&mut m);
    ldl_solve(&m, &d_inv, &mut x);
    x
}

/// LDLᵀ of a symmetric positive definite `m` in place, without pivoting: its strict lower
/// triangle becomes L (unit diagonal implied), its diagonal D; returns 1/D.
#[allow(clippy::needless_range_loop)] // triangular index arithmetic reads best as indices
pub fn ldl_factor<S: Scalar>(m: &mut [Vec<S>]) -> Vec<S> {
    let n = m.len();
    let mut d_inv = Vec::with_capacity(n);
    for j in 0..n {
        for k in 0..j {
            let t = m[j][k] * (m[j][k] * m[k][k]);
            m[j][j] -= t;
        }
        let inv = m[j][j].recip();
        for i in j + 1..n {
            let mut s = m[i][j];
            for k in 0..j {
                s -= m[i][k] * (m[j][k] * m[k][k]);
            }
            m[i][j] = s * inv;
        }
        d_inv.push(inv);
    }
    d_inv
}

/// Solves `L D Lᵀ x = b` in place (`x` holds b), with the factors of [`ldl_factor`].
#[allow(clippy::needless_range_loop)]
pub fn ldl_solve<S: Scalar>(m: &[Vec<S>], d_inv: &[S], x: &mut [S]) {
    let n = m.len();
    for i in 0..n {
        for k in 0..i {
            let t = m[i][k] * x[k];
            x[i] -= t;
        }
    }
    for i in 0..n {
        x[i] *= d_inv[i];
    }
    for i in (0..n).rev() {
        for k in i + 1..n {
            let t = m[k][i] * x[k];
            x[i] -= t;
        }
    }
}

// ----- the articulated-body algorithm restated for constant folding -------------------

/// A symmetric 3×3 matrix, its six distinct entries (xx, yy, zz, xy, xz, yz).
#[derive(Clone, Copy, Debug)]
struct Sym<S>([S; 6]);

impl<S: Scalar> Sym<S> {
    fn get(&self, i: usize, j: usize) -> S {
        const IDX: [[usize; 3]; 3] = [[0, 3, 4], [3, 1, 5], [4, 5, 2]];
        self.0[IDX[i][j]]
    }

    fn from_fn(f: impl Fn(usize, usize) -> S) -> Self {
        Sym([f(0, 0), f(1, 1), f(2, 2), f(0, 1), f(0, 2), f(1, 2)])
    }

    fn mul_vec(&self, v: &V3<S>) -> V3<S> {
        [0, 1, 2].map(|i| self.get(i, 0) * v[0] + self.get(i, 1) * v[1] + self.get(i, 2) * v[2])
    }

    fn add(&self, o: &Self) -> Self {
        Sym(std::array::from_fn(|k| self.0[k] + o.0[k]))
    }
}

/// An articulated-body inertia `[[a, b], [bᵀ, c]]` with `a`, `c` symmetric.
#[derive(Clone, Copy, Debug)]
struct Abi<S> {
    a: Sym<S>,
    b: M3<S>,
    c: Sym<S>,
}

impl<S: Scalar> Abi<S> {
    fn from_rigid(r: &RigidInertia<f64>) -> Self {
        let z = S::zero();
        let m = S::from(r.m);
        let h: V3<S> = lift3(&r.h);
        Abi {
            a: Sym::from_fn(|i, j| S::from(r.i[i][j])),
            // skew(h): b v = h × v.
            b: [[z, -h[2], h[1]], [h[2], z, -h[0]], [-h[1], h[0], z]],
            c: Sym([m, m, m, z, z, z]),
        }
    }

    fn apply(&self, v: &Motion<S>) -> Force<S> {
        let (w, l) = (&v.ang, &v.lin);
        let aw = self.a.mul_vec(w);
        let bl = mat_vec(&self.b, l);
        let btw = mat_t_vec(&self.b, w);
        let cl = self.c.mul_vec(l);
        Force {
            ang: [0, 1, 2].map(|i| aw[i] + bl[i]),
            lin: [0, 1, 2].map(|i| btw[i] + cl[i]),
        }
    }

    /// `I − u uᵀ / d`.
    fn minus_outer(&self, u: &Force<S>, d_inv: S) -> Self {
        let ua = u.ang.map(|x| x * d_inv);
        let ul = u.lin.map(|x| x * d_inv);
        Abi {
            a: Sym::from_fn(|i, j| self.a.get(i, j) - ua[i] * u.ang[j]),
            b: std::array::from_fn(|i| std::array::from_fn(|j| self.b[i][j] - ua[i] * u.lin[j])),
            c: Sym::from_fn(|i, j| self.c.get(i, j) - ul[i] * u.lin[j]),
        }
    }

    fn add(&self, o: &Self) -> Self {
        Abi {
            a: self.a.add(&o.a),
            b: std::array::from_fn(|i| std::array::from_fn(|j| self.b[i][j] + o.b[i][j])),
            c: self.c.add(&o.c),
        }
    }

    /// `Xᵀ I X` for `X = B_X_A` with `E = x.e`, `r = x.r` (as
    /// [`ArticulatedInertia::back`]): rotate by `R = Eᵀ` (`R a Rᵀ`, symmetric results
    /// computed once), then shift by `r`:
    /// `a'' = a' − b'[r]× + [r]× b'ᵀ − [r]× c' [r]×`, `b'' = b' + [r]× c'`, `c'' = c'`.
    fn back(&self, x: &Transform<S>) -> Self {
        let e = &x.e;
        // R m Rᵀ with R = Eᵀ: (Eᵀ m E)[i][j] = Σ_kl E[k][i] m[k][l] E[l][j].
        let rot_sym = |m: &Sym<S>| {
            // t = m E (3×3), then Eᵀ t, upper triangle only.
            let t: M3<S> = std::array::from_fn(|k| {
                std::array::from_fn(|j| {
                    m.get(k, 0) * e[0][j] + m.get(k, 1) * e[1][j] + m.get(k, 2) * e[2][j]
                })
            });
            Sym::from_fn(|i, j| e[0][i] * t[0][j] + e[1][i] * t[1][j] + e[2][i] * t[2][j])
        };
        let rot = |m: &M3<S>| -> M3<S> {
            let t: M3<S> = std::array::from_fn(|k| {
                std::array::from_fn(|j| m[k][0] * e[0][j] + m[k][1] * e[1][j] + m[k][2] * e[2][j])
            });
            std::array::from_fn(|i| {
                std::array::from_fn(|j| e[0][i] * t[0][j] + e[1][i] * t[1][j] + e[2][i] * t[2][j])
            })
        };
        let (a, b, c) = (rot_sym(&self.a), rot(&self.b), rot_sym(&self.c));
        let r = &x.r;
        // [r]× c (3×3): column j is r × c_j.
        let rxc: M3<S> = {
            let cols: [V3<S>; 3] =
                std::array::from_fn(|j| cross(r, &[c.get(0, j), c.get(1, j), c.get(2, j)]));
            std::array::from_fn(|i| std::array::from_fn(|j| cols[j][i]))
        };
        // a'' = a − P − Pᵀ − [r]× c [r]× with P = b [r]× (since [r]× bᵀ = −Pᵀ).
        let rx = [
            [S::zero(), -r[2], r[1]],
            [r[2], S::zero(), -r[0]],
            [-r[1], r[0], S::zero()],
        ];
        let p: M3<S> = std::array::from_fn(|i| {
            std::array::from_fn(|j| b[i][0] * rx[0][j] + b[i][1] * rx[1][j] + b[i][2] * rx[2][j])
        });
        // [r]× c [r]× = rxc · rx, symmetric (as −[r]× c [r]×ᵀ).
        let q =
            Sym::from_fn(|i, j| rxc[i][0] * rx[0][j] + rxc[i][1] * rx[1][j] + rxc[i][2] * rx[2][j]);
        Abi {
            a: Sym::from_fn(|i, j| a.get(i, j) - (p[i][j] + p[j][i]) - q.get(i, j)),
            b: std::array::from_fn(|i| std::array::from_fn(|j| b[i][j] + rxc[i][j])),
            c,
        }
    }
}

/// The articulated-body algorithm (Featherstone's table 7.1, the same steps as
/// [`Model::aba`]) written so that a tracing scalar folds more: the articulated
/// inertias' symmetric blocks are computed once (the upper triangle), and the spatial
/// products are the plain sums of [`Transform`] and [`Motion`] on constants the tracer
/// sees as exact zeros. Equal to [`Model::aba`] up to rounding.
pub fn aba_folded<S: Scalar>(model: &Model, q: &[S], qd: &[S], tau: &[S]) -> Vec<S> {
    let n = model.nq();
    assert_eq!(q.len(), n);
    assert_eq!(qd.len(), n);
    assert_eq!(tau.len(), n);
    let xs: Vec<Transform<S>> = (0..n).map(|i| model.joint_transform(i, q[i])).collect();
    let mut v: Vec<Motion<S>> = Vec::with_capacity(n);
    let mut c: Vec<Motion<S>> = Vec::with_capacity(n);
    let mut ia: Vec<Abi<S>> = Vec::with_capacity(n);
    let mut pa: Vec<Force<S>> = Vec::with_capacity(n);
    for i in 0..n {
        let s = &model.subspace[i];
        let vj = Motion::from_axis(s, qd[i]);
        let (vi, ci) = match model.parent[i] {
            None => (vj, Motion::zero()),
            Some(p) => {
                let vp = xs[i].motion(&v[p]);
                // v × vj with v = vp + vj: vj × vj = 0, so vp × vj.
                (vp.add(&vj), vp.cross_motion(&vj))
            }
        };
        let inertia = RigidInertia::<S>::lift(&model.inertia[i]);
        pa.push(vi.cross_force(&inertia.apply(&vi)));
        ia.push(Abi::from_rigid(&model.inertia[i]));
        v.push(vi);
        c.push(ci);
    }
    let mut u_vec: Vec<Force<S>> = vec![Force::zero(); n];
    let mut d_inv = vec![S::zero(); n];
    let mut u = vec![S::zero(); n];
    for i in (0..n).rev() {
        let s = &model.subspace[i];
        let ui = ia[i].apply(&Motion::from_axis(s, S::one()));
        let di_inv = ui.along(s).recip();
        let force = tau[i] - qd[i] * model.damping[i];
        u[i] = force - pa[i].along(s);
        if let Some(p) = model.parent[i] {
            let ia_child = ia[i].minus_outer(&ui, di_inv);
            let pa_child = pa[i]
                .add(&ia_child.apply(&c[i]))
                .add(&ui.scale(u[i] * di_inv));
            ia[p] = ia[p].add(&ia_child.back(&xs[i]));
            pa[p] = pa[p].add(&xs[i].force_back(&pa_child));
        }
        u_vec[i] = ui;
        d_inv[i] = di_inv;
    }
    let a0 = Motion {
        ang: [S::zero(); 3],
        lin: lift3(&model.gravity.map(|g| -g)),
    };
    let mut a: Vec<Motion<S>> = Vec::with_capacity(n);
    let mut qdd = vec![S::zero(); n];
    for i in 0..n {
        let ap = match model.parent[i] {
            None => xs[i].motion(&a0),
            Some(p) => xs[i].motion(&a[p]),
        }
        .add(&c[i]);
        qdd[i] = (u[i] - ap.dot(&u_vec[i])) * d_inv[i];
        a.push(ap.add(&Motion::from_axis(&model.subspace[i], qdd[i])));
    }
    qdd
}

// ----- tracing and emitting ---------------------------------------------------------

/// The traced q̈ (and, if asked, `∂q̈/∂q`, `∂q̈/∂q̇` row-major) of a model.
pub struct Traced {
    pub graph: Graph,
    pub qdd: Vec<Id>,
    pub dq: Vec<Id>,
    pub dqd: Vec<Id>,
}

/// How the emitted Jacobian is formed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Jacobian {
    /// Symbolic forward-mode derivatives of the traced q̈, one sweep per q_j and q̇_j.
    ForwardOfForwardDynamics,
    /// Through inverse dynamics, as Pinocchio's `computeABADerivatives` does:
    /// `M q̈ + b(q, q̇) = τ − d q̇` gives `∂q̈/∂q = −M⁻¹ ∂RNEA(q, q̇, a)/∂q` and
    /// `∂q̈/∂q̇ = −M⁻¹ (∂RNEA/∂q̇ + diag d)` at `a = q̈`: symbolic derivatives of RNEA with
    /// `a` held fixed (a leaf, replaced by the traced q̈ afterwards), then LDLᵀ solves with
    /// the traced mass matrix (CRBA), 2n right-hand sides.
    InverseDynamics,
}

/// Traces q̈ of the snapped `model` by `algorithm`; with `jacobian`, also ∂q̈/∂q and
/// ∂q̈/∂q̇ (row-major) formed as it says.
pub fn trace(model: &Model, algorithm: Algorithm, jacobian: Option<Jacobian>) -> Traced {
    trace_within(model, algorithm, jacobian, SNAP)
}

/// [`trace`] with entries within `snap` of 0 or ±1 snapped.
pub fn trace_within(
    model: &Model,
    algorithm: Algorithm,
    jacobian: Option<Jacobian>,
    snap: f64,
) -> Traced {
    let model = snapped_within(model, snap);
    let n = model.nq();
    let [nq, nqd, ntau] = leaf_lengths(&model);
    assert!(
        jacobian.is_none() || nq == n,
        "no symbolic Jacobian for a floating base"
    );
    let ((qdd, dq, dqd), graph) = record(|| {
        let q = Expr::inputs(Arg::Q, nq);
        let qd = Expr::inputs(Arg::Qd, nqd);
        let tau = Expr::inputs(Arg::U, ntau);
        let qdd = if model.free_base.is_some() {
            floating_dynamics(&model, &q, &qd, &tau)
        } else {
            forward_dynamics(&model, algorithm, &q, &qd, &tau)
        };
        let (mut dq, mut dqd) = (vec![0; n * n], vec![0; n * n]);
        match jacobian {
            None => {}
            Some(Jacobian::ForwardOfForwardDynamics) => {
                for (arg, out) in [(Arg::Q, &mut dq), (Arg::Qd, &mut dqd)] {
                    for j in 0..n {
                        let col = diff::forward(&qdd, |a, i| {
                            (a == arg && i == j).then(|| Expr::constant(1.0))
                        });
                        for (i, d) in col.iter().enumerate() {
                            out[i * n + j] = d.id();
                        }
                    }
                }
            }
            Some(Jacobian::InverseDynamics) => {
                let a = Expr::inputs(Arg::P, n);
                let id = model.rnea(&q, &qd, &a);
                let mut m = model.crba(&q);
                let d_inv = ldl_factor(&mut m);
                for (arg, out) in [(Arg::Q, &mut dq), (Arg::Qd, &mut dqd)] {
                    for j in 0..n {
                        let col = diff::forward(&id, |b, i| {
                            (b == arg && i == j).then(|| Expr::constant(1.0))
                        });
                        let mut x = substitute(&col, &|b, k| (b == Arg::P).then(|| qdd[k]));
                        if arg == Arg::Qd {
                            x[j] += model.damping[j];
                        }
                        ldl_solve(&m, &d_inv, &mut x);
                        for (i, d) in x.iter().enumerate() {
                            out[i * n + j] = (-*d).id();
                        }
                    }
                }
            }
        }
        let ids = |v: &[Expr]| v.iter().map(|e| e.id()).collect::<Vec<Id>>();
        (ids(&qdd), dq, dqd)
    });
    assert!(
        graph.branches.is_empty(),
        "looked at values: {:?}",
        graph.branches
    );
    let (dq, dqd) = if jacobian.is_some() {
        (dq, dqd)
    } else {
        (vec![], vec![])
    };
    Traced {
        graph,
        qdd,
        dq,
        dqd,
    }
}

/// The lengths of the generated code's `q`, `q̇` and `τ`: `n` each, or for a floating
/// base `n + 7`, `n + 6`, `n` ([`floating_dynamics`]).
pub fn leaf_lengths(model: &Model) -> [usize; 3] {
    let n = model.nq();
    if model.free_base.is_some() {
        [n + 7, n + 6, n]
    } else {
        [n; 3]
    }
}

/// `roots` with the leaves `map` names replaced (the others kept), rebuilt node by node
/// in the current recording (so the constructors simplify again).
pub fn substitute(roots: &[Expr], map: &dyn Fn(Arg, usize) -> Option<Expr>) -> Vec<Expr> {
    rebuild(roots, &|node| match node {
        Node::Input(arg, k) => map(arg, k as usize),
        _ => None,
    })
}

/// `roots` rebuilt node by node in the current recording (so the constructors simplify
/// again), each node reached replaced by what `swap` gives for it (from the original
/// operands), else rebuilt from its rebuilt operands.
pub fn rebuild(roots: &[Expr], swap: &dyn Fn(Node) -> Option<Expr>) -> Vec<Expr> {
    let ids: Vec<Id> = roots.iter().map(|r| r.id()).collect();
    let top = ids.iter().map(|&i| i as usize + 1).max().unwrap_or(0);
    let seen = with_graph(|g| g.reachable(&ids));
    let mut new: Vec<Option<Expr>> = vec![None; top];
    for id in 0..top {
        if !seen[id] {
            continue;
        }
        let e = |i: Id| new[i as usize].expect("operands first");
        let z = Expr::from_id(id as Id);
        let node = z.node();
        new[id] = Some(swap(node).unwrap_or_else(|| match node {
            Node::Const(_) | Node::Input(..) => z,
            Node::Neg(a) => -e(a),
            Node::Add(a, b) => e(a) + e(b),
            Node::Sub(a, b) => e(a) - e(b),
            Node::Mul(a, b) => e(a) * e(b),
            Node::Div(a, b) => e(a) / e(b),
            Node::Fun(f, a) => Expr::fun(f, e(a)),
            Node::Powi(a, k) => Expr::int_power(e(a), k),
            Node::Powf(a, k) => Expr::real_power(e(a), f64::from_bits(k)),
            Node::Atan2(y, x) => Expr::arctan2(e(y), e(x)),
        }));
    }
    ids.iter()
        .map(|&i| new[i as usize].expect("reached"))
        .collect()
}

fn leaf_name(arg: Arg) -> String {
    match arg {
        Arg::Q => "q",
        Arg::Qd => "qd",
        Arg::U => "tau",
        Arg::P => "p",
        Arg::T => "t",
    }
    .into()
}

/// One generated module.
pub struct Generated {
    pub module: String,
    pub nq: usize,
    pub algorithm: Algorithm,
    /// Operations of `aba` and (if emitted) of `aba_derivatives`.
    pub aba_operations: usize,
    pub derivative_operations: Option<usize>,
    pub source: String,
}

/// A function `name` computing `outputs` (`(slice, roots)`) from q, q̇, τ.
fn function(
    graph: &Graph,
    name: &str,
    doc: &str,
    lengths: [usize; 3],
    outputs: &[(&str, &[Id])],
) -> (String, Straight) {
    let roots: Vec<Id> = outputs
        .iter()
        .flat_map(|(_, r)| r.iter().copied())
        .collect();
    let st = straight_line(graph, &roots, &leaf_name);
    let mut src = String::new();
    for line in doc.lines() {
        writeln!(src, "/// {line}").unwrap();
    }
    let param = |arg: Arg, name: &str| {
        if st.used_args[arg as usize] {
            name.to_string()
        } else {
            format!("_{name}")
        }
    };
    let outs: String = outputs
        .iter()
        .map(|(o, _)| format!(", {o}: &mut [S]"))
        .collect();
    writeln!(
        src,
        "pub fn {name}<S: Scalar>({}: &[S], {}: &[S], {}: &[S]{outs}) {{",
        param(Arg::Q, "q"),
        param(Arg::Qd, "qd"),
        param(Arg::U, "tau")
    )
    .unwrap();
    for ((arg, a), n) in [(Arg::Q, "q"), (Arg::Qd, "qd"), (Arg::U, "tau")]
        .into_iter()
        .zip(lengths)
    {
        if st.used_args[arg as usize] {
            writeln!(src, "        let {a} = &{a}[..{n}];").unwrap();
        }
    }
    for (o, r) in outputs {
        writeln!(src, "        let {o} = &mut {o}[..{}];", r.len()).unwrap();
    }
    src.push_str(&st.body);
    let mut at = 0;
    for (o, r) in outputs {
        for i in 0..r.len() {
            writeln!(src, "        {o}[{i}] = {};", st.roots[at]).unwrap();
            at += 1;
        }
    }
    src.push_str("}\n");
    (src, st)
}

/// Traces and emits one target. `krate` is the path the code names the mbfmu library by:
/// `crate` for the committed modules (in mbfmu itself), `mbfmu` for a robot's crate
/// ([`robot_dynamics`]).
pub fn generate(target: &Target, krate: &str) -> Generated {
    let model = &target.model;
    let n = model.nq();
    let traced = trace_within(model, target.algorithm, target.jacobian, target.snap);
    let lengths = leaf_lengths(model);
    let doc = if model.free_base.is_some() {
        "q̈ and the floating base's acceleration from (q, q̇, τ), as `codegen::floating_dynamics`:\n\
         `q` the joints' positions, then the base's x y z and quaternion w x y z (world ← base);\n\
         `qd` the joints' velocities, then the base's v and ω (base frame); `tau` the joints';\n\
         `qdd` the joints' q̈, then the base's v̇ and ω̇. The joints' viscous damping acts\n\
         inside, as `τ − d q̇`. The slices' lengths are checked once, up front."
    } else {
        "q̈ from (q, q̇, τ): the joints' viscous damping acts inside, as `τ − d q̇` (as\n\
         `Model::aba`). The slices' lengths are checked once, up front."
    };
    let (aba_src, aba_st) = function(&traced.graph, "aba", doc, lengths, &[("qdd", &traced.qdd)]);
    let mut source = String::new();
    let joints = model.joints.join(", ");
    let derivatives = target.jacobian.map(|how| {
        function(
            &traced.graph,
            "aba_derivatives",
            &format!(
                "q̈ and its Jacobian, `dqdd_dq[i * n + j] = ∂q̈_i/∂q_j` and `dqdd_dqd` alike\n\
                 (row-major), from symbolic derivatives ({how:?})."
            ),
            lengths,
            &[
                ("qdd", &traced.qdd),
                ("dqdd_dq", &traced.dq),
                ("dqdd_dqd", &traced.dqd),
            ],
        )
    });
    let regenerate = if krate == "crate" {
        "a test checks it is current (`MBFMU_REGENERATE=1 cargo test --release --lib\n\
         //! multibody::codegen` rewrites it)"
    } else {
        "`mbfmu build` rewrites it when the\n\
         //! mechanism changes, and it runs only while [`FINGERPRINT`] is the mechanism's"
    };
    write!(
        source,
        "//! Generated by `mbfmu::multibody::codegen` from `{module}` ({n} joints: {joints}): do not\n\
         //! edit; {regenerate}. Algorithm: {algorithm:?}{base}.\n\
         //!\n\
         //! `aba`: {aba_ops} operations in {aba_lets} `let`s.{der}\n\n\
         use {krate}::model::Scalar;\n\n\
         /// The model's name and its number of joints.\n\
         pub const NAME: &str = \"{name}\";\n\
         pub const NQ: usize = {n};\n\
         /// Operations of [`aba`].\n\
         pub const OPERATIONS: usize = {aba_ops};\n\n",
        module = target.module,
        base = if model.free_base.is_some() {
            ", with the floating base"
        } else {
            ""
        },
        name = model.name,
        algorithm = target.algorithm,
        aba_ops = aba_st.operations,
        aba_lets = aba_st.lets,
        der = derivatives.as_ref().map_or(String::new(), |(_, st)| format!(
            "\n//! `aba_derivatives`: {} operations in {} `let`s.",
            st.operations, st.lets
        )),
    )
    .unwrap();
    source.push_str(&aba_src);
    if let Some((src, _)) = &derivatives {
        source.push('\n');
        source.push_str(src);
    }
    Generated {
        module: target.module.clone(),
        nq: n,
        algorithm: target.algorithm,
        aba_operations: aba_st.operations,
        derivative_operations: derivatives.as_ref().map(|(_, st)| st.operations),
        source,
    }
}

/// Every committed module and `mod.rs`: (file name, source).
pub fn generate_all() -> (Vec<Generated>, Vec<(String, String)>) {
    let generated: Vec<Generated> = targets().iter().map(|t| generate(t, "crate")).collect();
    let mut files: Vec<(String, String)> = generated
        .iter()
        .map(|g| (format!("{}.rs", g.module), g.source.clone()))
        .collect();
    let mut index = String::from(
        "//! Forward dynamics generated by `mbfmu::multibody::codegen` for the benchmark models:\n\
         //! do not edit; a test checks they are current. Not formatted by rustfmt\n\
         //! (`#[rustfmt::skip]` on `mod generated`): the generator's layout is what the test\n\
         //! compares.\n\n",
    );
    for g in &generated {
        index.push_str(&format!(
            "#[allow(clippy::approx_constant, clippy::excessive_precision, clippy::unreadable_literal)]\npub mod {};\n",
            g.module
        ));
    }
    files.push(("mod.rs".into(), index));
    (generated, files)
}

/// FNV-1a (64 bits) of the model's `{:?}` (every number in its shortest exact form): what
/// a robot's generated dynamics record as [`FINGERPRINT`](robot_dynamics) and
/// [`Built`](super::fmu::Built) computes of the declared mechanism, so that code generated
/// from another mechanism (an edited crate, a stale file) is never run.
pub fn fingerprint(model: &Model) -> u64 {
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    // A fixed base hashes as before `Model::free_base` existed: the code generated for
    // fixed-base robots then (committed, and in users' crates) stays current.
    let text = format!("{model:?}").replace(", free_base: None }", " }");
    for b in text.bytes() {
        hash = (hash ^ b as u64).wrapping_mul(0x0100_0000_01b3);
    }
    hash
}

/// The most operations a robot's generated `aba` may take ([`robot_dynamics`]). rustc's
/// time grows faster than the code: the crate of Go2 floating (5 000 operations) compiles
/// in 37 s on 2 cores, Talos full floating with its 12 mimic joints (38 491: the reduced
/// mass matrix's CRBA and LDLᵀ) in 10 min (the function is compiled for f64 and for the
/// dual numbers of the derivatives). Beyond this the interpreted algorithm runs (Talos
/// full floating: 23 µs per q̈, `docs/benchmarks.md`).
pub const MAX_OPERATIONS: usize = 20_000;

/// The straight-line dynamics of a mechanism for its own crate (`src/dynamics.rs` of the
/// crates `mbfmu build --urdf` and `mbfmu new --from-urdf` write), naming the library as
/// `krate`: `aba` of the model snapped within [`EXACT_SNAP`] only (the URDF's model to
/// rounding), by the algorithm with the fewest operations ([`fewest_operations`]), and
/// `pub const FINGERPRINT: u64`, the [`fingerprint`] of the model it was generated from
/// (the crate's declaration runs it only while its mechanism has that fingerprint).
///
/// q̈ only: the FMU's directional derivatives are dual numbers through this `aba` (one
/// evaluation per direction, any n; the symbolic `aba_derivatives` gives the whole
/// Jacobian in one call but not ∂q̈/∂τ, and would triple the code the build compiles).
/// `Ok(None)` for a mechanism with loop closures (the λ-method runs, on automatic
/// differentiation), without a moving joint, or whose `aba` would take more than
/// [`MAX_OPERATIONS`] (the interpreted algorithm runs).
pub fn robot_dynamics(
    mechanism: &super::Mechanism,
    krate: &str,
) -> Result<Option<Generated>, super::Error> {
    let model = Model::new(mechanism)?;
    if !mechanism.closures.is_empty() || model.nq() == 0 {
        return Ok(None);
    }
    let target = Target {
        module: mechanism.name.clone(),
        snap: EXACT_SNAP,
        algorithm: fewest_operations_within(&model, EXACT_SNAP),
        jacobian: None,
        model,
    };
    let mut g = generate(&target, krate);
    if g.aba_operations > MAX_OPERATIONS {
        return Ok(None);
    }
    let at = g.source.find("/// The model's name").expect("the header");
    g.source.insert_str(
        at,
        &format!(
            "/// [`fingerprint`](mbfmu::multibody::codegen::fingerprint) of the model this code\n\
             /// was generated from.\n\
             pub const FINGERPRINT: u64 = {:#018x};\n",
            fingerprint(&target.model)
        ),
    );
    Ok(Some(g))
}

pub mod loops;

#[cfg(test)]
pub(crate) mod tests;
