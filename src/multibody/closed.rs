//! Loop closures on the tree's dynamics: the accelerations and the projection of a
//! mechanism whose closures may be redundant (Bricard's mechanism: a constraint Jacobian
//! rank-deficient everywhere) or singular at some configurations (the N four-bar when its
//! cranks are horizontal: N more degrees of freedom for an instant).
//!
//! The tree gives `M` (CRBA) and `f = τ − b` (RNEA); the closures `G = ∂Φ/∂q` and the
//! curvature `γ = q̇ᵀ∇²Φ q̇`. The accelerations are Gauss's principle: the `q̈` nearest the
//! tree's own `M⁻¹ f` in the kinetic metric among those with `G q̈ = −γ`,
//!
//! ```text
//! M q̈ = f + Gᵀ μ,   G q̈ = −γ   ⇒   (G M⁻¹ Gᵀ) μ = −γ − G M⁻¹ f,   q̈ = M⁻¹ (f + Gᵀ μ).
//! ```
//!
//! `q̈` is unique whatever G's rank (M is positive definite), μ is not where rows of G are
//! dependent: the Schur complement `S = G M⁻¹ Gᵀ` is factored by LDLᵀ in the closures'
//! own order, and a row whose pivot is not above [`RANK_TOLERANCE`] of S's largest
//! diagonal is dropped: its pivot is the squared distance (in M⁻¹'s metric) of its row of
//! G from the span of the rows kept before it, so its equation is a combination of
//! theirs (consistent, for a motion on the closures), and its multiplier is 0. Any
//! solution of `S μ = r` gives the same `q̈` (`S δ = 0` means `Gᵀ δ = 0`). Without a pivot
//! search S's envelope keeps (no fill outside it), and a singular position or a
//! redundant closure costs what a regular one does. (Diagonal pivoting, as LAPACK's
//! pstrf, picks the best conditioned rows; it ran here until the N four-bar needed S's
//! envelope all along. Bricard measured the same with both; A02's passages moved: see
//! [`RANK_TOLERANCE`].) The decisions look at the values' real parts only, so dual
//! numbers follow the f64 path.
//!
//! M is factored from the leaves up along the tree, G's rows are multiplied over their
//! closures' paths only ([`Structure`]), and the velocity is taken onto `G q̇ = 0` before
//! the accelerations are formed ([`Factored::tangent`]).
//!
//! The projection after each step moves q onto Φ = 0 by the same solve (the correction of
//! least kinetic metric), then q̇ onto G q̇ = 0.

use super::dynamics::Model;
use super::spatial::{add, cross, lift3, mat_vec, sub, V3};
use crate::model::Scalar;

/// The closures' residuals Φ (into `phi`), their Jacobian G (`g`: one row per residual,
/// model order, overwritten) and curvature `γ = Ġ q̇` (`curvature`), from one pass of
/// forward kinematics and each closure point's path to the base: per unit q̇_j a joint
/// moves a point p of a body it carries at `S_j × (p − o_j) + V_j` (its subspace in the
/// world, at its origin o_j), and that column's rate is
/// `(ω_j × S_j) × (p − o_j) + S_j × (ṗ − ȯ_j) + ω_j × V_j` (S_j and V_j turn with the
/// body j; ω_j and ȯ_j are its angular velocity and origin's velocity). O(bodies + the
/// closures' path lengths), against one forward-kinematics pass per column by dual
/// numbers; tests: equal to those to rounding.
pub fn kinematics<S: Scalar>(
    model: &Model,
    q: &[S],
    qd: &[S],
    phi: &mut [S],
    g: &mut [Vec<S>],
    curvature: &mut [S],
) {
    let n = model.nq();
    let poses = model.forward_kinematics(q);
    let zero = [S::zero(); 3];
    // Per body, in the world: the joint's subspace (S, V), angular velocity, origin velocity.
    let mut joint: Vec<(V3<S>, V3<S>)> = Vec::with_capacity(n);
    let mut omega: Vec<V3<S>> = Vec::with_capacity(n);
    let mut velocity: Vec<V3<S>> = Vec::with_capacity(n);
    for i in 0..n {
        let (r, o) = &poses[i];
        let s = mat_vec(r, &lift3(&model.subspace[i].ang));
        let v = mat_vec(r, &lift3(&model.subspace[i].lin));
        let scale = |a: &V3<S>| a.map(|x| x * qd[i]);
        let (w, ov) = match model.parent[i] {
            None => (scale(&s), scale(&v)),
            Some(p) => {
                let lever = sub(o, &poses[p].1);
                let ov = add(&add(&velocity[p], &cross(&omega[p], &lever)), &scale(&v));
                (add(&omega[p], &scale(&s)), ov)
            }
        };
        joint.push((s, v));
        omega.push(w);
        velocity.push(ov);
    }
    let mut k = 0;
    for c in &model.closures {
        let axes = k..k + c.axes.len();
        for row in &mut g[axes.clone()] {
            row.fill(S::zero());
        }
        let mut sep = zero;
        let mut rate = zero;
        for (body, point, sign) in [(c.body_a, &c.point_a, 1.0), (c.body_b, &c.point_b, -1.0)] {
            let Some(b) = body else {
                sep = add(&sep, &lift3::<S>(point).map(|x| x * sign));
                continue;
            };
            let (r, o) = &poses[b];
            let p = add(o, &mat_vec(r, &lift3(point)));
            let pd = add(&velocity[b], &cross(&omega[b], &sub(&p, o)));
            sep = add(&sep, &p.map(|x| x * sign));
            let mut j = Some(b);
            while let Some(i) = j {
                let (s, v) = &joint[i];
                let arm = sub(&p, &poses[i].1);
                let column = add(&cross(s, &arm), v);
                let turn = add(
                    &add(
                        &cross(&cross(&omega[i], s), &arm),
                        &cross(s, &sub(&pd, &velocity[i])),
                    ),
                    &cross(&omega[i], v),
                );
                for a in 0..3 {
                    rate[a] += turn[a] * (qd[i] * sign);
                }
                for (row, &axis) in g[axes.clone()].iter_mut().zip(&c.axes) {
                    row[i] += column[axis] * sign;
                }
                j = model.parent[i];
            }
        }
        for &axis in &c.axes {
            phi[k] = sep[axis];
            curvature[k] = rate[axis];
            k += 1;
        }
    }
}

/// A pivot of `G M⁻¹ Gᵀ` below this fraction of the largest is taken as 0 (its equation
/// dependent on those before it). A redundant row's pivot is rounding (≤ k ε cond M ≈
/// 1e-14 here). At a singular position the dropped direction's pivot σ goes to 0 like the
/// squared distance to it: dropped, the constraint force along it is left out, which at
/// the singular instant itself is right (Gauss's principle there leaves the extra
/// freedoms free: the N four-bar's cranks fall each as its neighbours let it); kept, σ
/// turns the defect along that direction (rounding in q̈, the step's O(tolerance) error in
/// the projection) into a response 1/√σ larger, which moves the state along the branch's
/// bifurcation and changes the energy. 1e-8 drops it within about 1e-4 rad of the
/// singular position. Measured on A02 (tests/n_four_bar.rs): with 1e-12, DOPRI5 at rtol
/// 1e-11 lost 2.2e-6 of E in one passage (B0 9.2e-4 m off the branch by 20 s) and stalled
/// at 1e-12; with 1e-8 B0 converges with the tolerance, 4.7e-5 m at 1e-8, 4.4e-6 at 1e-9,
/// 4.2e-7 at 1e-10, 2.6e-8 at 1e-11, 1.6e-8 at 3e-12, and DOP853 at 1e-12 is unchanged
/// (2.9e-8 m, energy 8.1e-11). What a passage leaves moves with rounding and with which
/// rows are dropped: in S's own order (now), 4.3e-7 m at 1e-10, 4.1e-8 at 1e-11, DOP853 at
/// 1e-12 6.3e-9 m and 9.4e-11 of E; DOP853 at 1e-10 showed 1.0e-5 of E in single samples
/// over lasting kicks of 4e-9 to 6e-8. Those came from steps that straddled a passage and
/// ended up to 1e-4 m off the closures while their projected solutions agreed; held to
/// the closures' defect as well (`integrators::Problem::defect`), DOP853 at 1e-10 keeps
/// E to 9.4e-10, at 1e-12 to 1.3e-11 (B0 1.4e-9 m).
pub const RANK_TOLERANCE: f64 = 1e-8;

/// What [`solve`] exploits, fixed per mechanism: each coordinate's parent in the tree
/// (parents before children), so that `M[i][j] ≠ 0` only where one is the other's
/// ancestor and its factorisation `M = Lᵀ D L` from the leaves up (Featherstone's LTDL)
/// fills nothing else: O(Σ depth²) and each solve O(Σ depth), against n³/6 and n²; per
/// row of G the columns that can be nonzero (the joints on the closure's two paths to the
/// base), so that `G M⁻¹ Gᵀ` costs k² times a path's length, not k² n; and what follows
/// from those two: where `M⁻¹ gᵢ` can be nonzero (`support`) and `S = G M⁻¹ Gᵀ`'s
/// envelope (`first`), in which its LDLᵀ in its own order stays (the N four-bar's S is
/// block-tridiagonal: 80 × 80, about 5 entries a row).
#[derive(Clone, Debug)]
pub struct Structure {
    pub parent: Vec<Option<usize>>,
    pub columns: Vec<Vec<usize>>,
    /// Per row i of G, the coordinates (ascending) where `M⁻¹ gᵢ` can be nonzero: the
    /// subtrees of the base's children that hold the row's columns (`M⁻¹ = L⁻¹ D⁻¹ L⁻ᵀ`
    /// couples two coordinates iff they share an ancestor).
    pub support: Vec<Vec<usize>>,
    /// Per row i of S, the first column j ≤ i where `S_ij` can be nonzero (row j's
    /// support meets row i's columns).
    pub first: Vec<usize>,
}

impl Structure {
    /// No structure: every coordinate the previous one's child (the factorisation is then
    /// the dense one), every column in every row.
    pub fn dense(n: usize, k: usize) -> Self {
        let parent = (0..n).map(|i| i.checked_sub(1)).collect();
        Structure::completed(parent, vec![(0..n).collect(); k])
    }

    /// The supports and the envelope of `parent` (parents before children) and `columns`.
    fn completed(parent: Vec<Option<usize>>, columns: Vec<Vec<usize>>) -> Self {
        let n = parent.len();
        let support: Vec<Vec<usize>> = columns
            .iter()
            .map(|cols| {
                let mut held = vec![false; n];
                for &c in cols {
                    let mut j = Some(c);
                    while let Some(i) = j {
                        held[i] = true;
                        j = parent[i];
                    }
                }
                // Then every descendant of those (a parent comes before its children).
                for x in 0..n {
                    held[x] = held[x] || parent[x].is_some_and(|p| held[p]);
                }
                (0..n).filter(|&x| held[x]).collect()
            })
            .collect();
        let first = columns
            .iter()
            .enumerate()
            .map(|(i, cols)| {
                (0..i)
                    .find(|&j| cols.iter().any(|c| support[j].binary_search(c).is_ok()))
                    .unwrap_or(i)
            })
            .collect();
        Structure {
            parent,
            columns,
            support,
            first,
        }
    }

    /// Of `model` in coordinates `order` (`order[k]` is coordinate k's model index; a
    /// mechanism without mimic joints, so every model coordinate is one): the tree's
    /// parents where the order puts parents first, else the dense chain.
    pub fn of(model: &Model, order: &[usize]) -> Self {
        let n = order.len();
        let at = |i: usize| order.iter().position(|&o| o == i);
        let tree: Vec<Option<usize>> = order
            .iter()
            .map(|&i| model.parent[i].and_then(at))
            .collect();
        let parents_first = tree
            .iter()
            .enumerate()
            .all(|(k, p)| p.is_none_or(|p| p < k))
            && order.len() == model.nq();
        let parent = if parents_first {
            tree
        } else {
            Structure::dense(n, 0).parent
        };
        let mut columns = Vec::new();
        for c in &model.closures {
            let mut on_path = vec![false; n];
            for body in [c.body_a, c.body_b] {
                let mut j = body;
                while let Some(i) = j {
                    if let Some(k) = at(i) {
                        on_path[k] = true;
                    }
                    j = model.parent[i];
                }
            }
            let cols: Vec<usize> = (0..n).filter(|&k| on_path[k]).collect();
            columns.extend(c.axes.iter().map(|_| cols.clone()));
        }
        Structure::completed(parent, columns)
    }
}

/// `M = Lᵀ D L` in place (`m` n × n row-major, symmetric positive definite with the tree
/// sparsity of `parent`): for k from the last coordinate up, `D_k = M_kk` and, for each
/// ancestor a of k, `L_ka = M_ka / D_k`, `M_ab −= L_ka M_kb` for a and its ancestors b.
/// L's entries take the strict lower triangle, D the diagonal.
fn tree_factor<S: Scalar>(m: &mut [S], parent: &[Option<usize>]) {
    let n = parent.len();
    for k in (0..n).rev() {
        let mut i = parent[k];
        while let Some(a) = i {
            let l = m[k * n + a] / m[k * n + k];
            let mut j = Some(a);
            while let Some(b) = j {
                let t = l * m[k * n + b];
                m[a * n + b] -= t;
                j = parent[b];
            }
            m[k * n + a] = l;
            i = parent[a];
        }
    }
}

/// Solves `Lᵀ D L x = b` in place (`x` holds b) with the factors of [`tree_factor`].
fn tree_solve<S: Scalar>(m: &[S], parent: &[Option<usize>], x: &mut [S]) {
    let n = parent.len();
    for k in (0..n).rev() {
        let mut i = parent[k];
        while let Some(a) = i {
            let t = m[k * n + a] * x[k];
            x[a] -= t;
            i = parent[a];
        }
    }
    for k in 0..n {
        x[k] /= m[k * n + k];
    }
    for k in 0..n {
        let mut i = parent[k];
        while let Some(a) = i {
            let t = m[k * n + a] * x[a];
            x[k] -= t;
            i = parent[a];
        }
    }
}

/// [`tree_solve`] for a `b` that is 0 outside `support` (ascending, closed under ancestors
/// and descendants: a [`Structure::support`]), outside which `x` then stays 0: the same
/// operations on those coordinates only.
fn tree_solve_on<S: Scalar>(m: &[S], parent: &[Option<usize>], support: &[usize], x: &mut [S]) {
    let n = parent.len();
    for &k in support.iter().rev() {
        let mut i = parent[k];
        while let Some(a) = i {
            let t = m[k * n + a] * x[k];
            x[a] -= t;
            i = parent[a];
        }
    }
    for &k in support {
        x[k] /= m[k * n + k];
    }
    for &k in support {
        let mut i = parent[k];
        while let Some(a) = i {
            let t = m[k * n + a] * x[a];
            x[k] -= t;
            i = parent[a];
        }
    }
}

/// `S = L D Lᵀ` in S's own order, row i of L over the envelope's columns `first[i]..i`
/// (packed from `start[i]`), D⁻¹ on the diagonal slots (0 for a dropped row).
struct Envelope<S> {
    start: Vec<usize>,
    ld: Vec<S>,
    rank: usize,
}

impl<S: Scalar> Envelope<S> {
    /// Factors S given by its envelope (`s` packed as `start`) by LDLᵀ in its own order,
    /// dropping each row whose pivot is not above [`RANK_TOLERANCE`] of S's largest
    /// diagonal: its D⁻¹ becomes 0, so that its L column is 0, it takes no part in what
    /// follows and its unknown is 0. S is positive semidefinite, so row i's pivot is
    /// the squared distance (in M⁻¹'s metric) of gᵢ from the span of the rows kept before
    /// it: a dropped row is a combination of those to the tolerance. No pivot search, so
    /// the envelope keeps (no fill outside it) and the cost is the same at a singular
    /// position as away from it. A NaN pivot is kept (it reaches the result).
    fn factor(first: &[usize], start: Vec<usize>, mut ld: Vec<S>) -> Self {
        let k = first.len();
        let at = |i: usize, j: usize| start[i] + j - first[i];
        let largest = (0..k).fold(0.0f64, |m, i| m.max(ld[at(i, i)].re()));
        let mut u = vec![S::zero(); k];
        let mut rank = 0;
        for i in 0..k {
            let fi = first[i];
            // u_j = l_ij d_j, then l_ij; d_i = s_ii − Σ u_j l_ij (a dropped j: l_ij = 0).
            for j in fi..i {
                let lo = fi.max(first[j]);
                let mut v = ld[at(i, j)];
                for m in lo..j {
                    v -= u[m] * ld[at(j, m)];
                }
                u[j] = v;
                ld[at(i, j)] = v * ld[at(j, j)];
            }
            let mut d = ld[at(i, i)];
            for j in fi..i {
                d -= u[j] * ld[at(i, j)];
            }
            // (A dropped row's L entries are then read only times its D⁻¹, 0.)
            ld[at(i, i)] = if d.re() <= RANK_TOLERANCE * largest {
                S::zero()
            } else {
                rank += 1;
                S::one() / d
            };
        }
        Envelope { start, ld, rank }
    }

    /// Solves `L D Lᵀ x = r` in place (a dropped row's unknown 0).
    fn substitute(&self, first: &[usize], r: &mut [S]) {
        let at = |i: usize, j: usize| self.start[i] + j - first[i];
        for i in 0..r.len() {
            for j in first[i]..i {
                let t = self.ld[at(i, j)] * r[j];
                r[i] -= t;
            }
        }
        for (i, v) in r.iter_mut().enumerate() {
            *v *= self.ld[at(i, i)];
        }
        for i in (0..r.len()).rev() {
            for j in first[i]..i {
                let t = self.ld[at(i, j)] * r[i];
                r[j] -= t;
            }
        }
    }
}

/// `M` and `S = G M⁻¹ Gᵀ` factored for one configuration: what [`Factored::accelerations`]
/// and [`Factored::tangent`] solve with.
pub struct Factored<'a, S> {
    structure: &'a Structure,
    g: &'a [Vec<S>],
    /// M's `Lᵀ D L` ([`tree_factor`]).
    m: Vec<S>,
    /// `Y = M⁻¹ Gᵀ`, one column per row of G, on that row's support only.
    y: Vec<Vec<S>>,
    schur: Envelope<S>,
}

impl<'a, S: Scalar> Factored<'a, S> {
    /// Factors `m` (M, n × n row-major, symmetric positive definite) and the Schur
    /// complement of the k rows `g` of G, with their sparsity `structure`: S over its
    /// envelope, factored in its own order, its dependent rows dropped ([`Envelope`]).
    pub fn new(mut m: Vec<S>, structure: &'a Structure, g: &'a [Vec<S>]) -> Self {
        let (parent, k, n) = (&structure.parent, g.len(), structure.parent.len());
        tree_factor(&mut m, parent);
        let mut x = vec![S::zero(); n];
        let y: Vec<Vec<S>> = (0..k)
            .map(|i| {
                for &c in &structure.columns[i] {
                    x[c] = g[i][c];
                }
                let support = &structure.support[i];
                tree_solve_on(&m, parent, support, &mut x);
                support
                    .iter()
                    .map(|&c| std::mem::replace(&mut x[c], S::zero()))
                    .collect()
            })
            .collect();
        // S over its envelope: S_ij = gᵢ · yⱼ over gᵢ's columns (scattered into x).
        let first = &structure.first;
        let mut start = Vec::with_capacity(k);
        let mut s = Vec::new();
        for i in 0..k {
            start.push(s.len());
            for &c in &structure.columns[i] {
                x[c] = g[i][c];
            }
            let envelope = structure.support[first[i]..=i].iter().zip(&y[first[i]..=i]);
            for (support, yj) in envelope {
                let sj = support.iter().zip(yj);
                s.push(sj.fold(S::zero(), |a, (&c, &v)| a + x[c] * v));
            }
            for &c in &structure.columns[i] {
                x[c] = S::zero();
            }
        }
        let schur = Envelope::factor(first, start, s);
        Factored {
            structure,
            g,
            m,
            y,
            schur,
        }
    }

    /// The rank found for G.
    pub fn rank(&self) -> usize {
        self.schur.rank
    }

    /// Row i of G against `b`, over the row's columns only.
    fn row_dot(&self, i: usize, b: &[S]) -> S {
        self.structure.columns[i]
            .iter()
            .fold(S::zero(), |s, &l| s + self.g[i][l] * b[l])
    }

    /// `x += Y S⁺ r` for `r` given as `c − G x` (`c` None: `−G x`), returning S⁺ r.
    fn correct(&self, c: Option<&[S]>, x: &mut [S]) -> Vec<S> {
        let k = self.g.len();
        let mut r: Vec<S> = (0..k)
            .map(|i| c.map_or(S::zero(), |c| c[i]) - self.row_dot(i, x))
            .collect();
        self.schur.substitute(&self.structure.first, &mut r);
        for ((yi, support), &mi) in self.y.iter().zip(&self.structure.support).zip(&r) {
            for (&c, &v) in support.iter().zip(yi) {
                x[c] += v * mi;
            }
        }
        r
    }

    /// `q̈` (into `qdd`) and `μ` (into `mu`) of `M q̈ = f + Gᵀ μ`, `G q̈ = c` (see the
    /// module notes). Dependent rows get μ = 0.
    pub fn accelerations(&self, f: &[S], c: &[S], qdd: &mut [S], mu: &mut [S]) {
        qdd.copy_from_slice(f);
        tree_solve(&self.m, &self.structure.parent, qdd);
        mu.copy_from_slice(&self.correct(Some(c), qdd));
    }

    /// `q̇` moved onto `G q̇ = 0` (the change of least kinetic metric): near a singular
    /// position a velocity off the closures by rounding along a direction G nearly loses
    /// would be answered by accelerations ~1/distance² large; the accelerations of the
    /// velocity on them are the branch's.
    pub fn tangent(&self, qd: &mut [S]) {
        self.correct(None, qd);
    }
}

/// `q̈` (into `qdd`) and `μ` (into `mu`) of `M q̈ = f + Gᵀ μ`, `G q̈ = c` (see the module
/// notes): `m` is M (n × n row-major, symmetric positive definite), `g` the k rows of G
/// (each of n), `c` the k right-hand sides, `structure` their sparsity. Returns the rank
/// found for G. Dependent rows get μ = 0.
pub fn solve<S: Scalar>(
    m: Vec<S>,
    structure: &Structure,
    g: &[Vec<S>],
    f: &[S],
    c: &[S],
    qdd: &mut [S],
    mu: &mut [S],
) -> usize {
    let factored = Factored::new(m, structure, g);
    factored.accelerations(f, c, qdd, mu);
    factored.rank()
}

/// The terms of one configuration as generated code gives them (dense, row-major,
/// coordinate order; [`codegen::loops`](super::codegen::loops)), of a mechanism of `N`
/// coordinates and `K` closure residuals, and the same solve as [`Factored`] on them:
/// fixed sizes, so it lives on the stack (no allocation) and its loops are unrolled. M
/// comes as M⁻¹, and `Y = M⁻¹ Gᵀ` and `S = G M⁻¹ Gᵀ` ready made: what is left is S's
/// rank-revealing factorisation (the pivots depend on the values) and the products.
pub struct Terms<S, const N: usize, const K: usize> {
    /// `sin q_c`, `cos q_c` per coordinate (what the velocity terms read).
    pub sc: [[S; 2]; N],
    /// M⁻¹.
    pub m_inv: [[S; N]; N],
    /// G.
    pub g: [[S; N]; K],
    /// `(M⁻¹ Gᵀ)ᵀ`: row i is M⁻¹ gᵢ.
    pub y: [[S; N]; K],
    /// `G M⁻¹ Gᵀ` ([`Terms::factor`] leaves it as it is).
    pub s: [[S; K]; K],
    /// `∂V_springs/∂q`.
    pub springs: [S; N],
    /// RNEA at q̈ = 0.
    pub bias: [S; N],
    /// `γ = Ġ q̇`.
    pub gamma: [S; K],
    /// S⁺ ([`Terms::factor`]).
    w: [[S; K]; K],
    /// S⁺ r of the last [`Terms::correct`].
    r: [S; K],
}

/// A mechanism's generated closed terms ([`codegen::loops`](super::codegen::loops)), of
/// `N` coordinates and `K` closure residuals: the position and velocity terms, and the
/// products with them over their structural nonzeros only (known when generating: the
/// tree's and the closures' zeros), which [`Terms`] solves with.
pub trait Code<const N: usize, const K: usize> {
    /// The position terms at q ([`Terms`]' public fields but the velocity terms, 0).
    fn position<S: Scalar>(q: &[S]) -> Terms<S, N, K>;
    /// The bias (RNEA at q̈ = 0) and γ = Ġ q̇ at (q, q̇), reading sin and cos of q (`sc`).
    fn velocity<S: Scalar>(q: &[S], sc: &[[S; 2]; N], qd: &[S; N]) -> ([S; N], [S; K]);
    /// `G x`.
    fn g_times<S: Scalar>(g: &[[S; N]; K], x: &[S; N]) -> [S; K];
    /// `x += Yᵀ r` (`Y = M⁻¹ Gᵀ`, stored as its transpose: row i is M⁻¹ gᵢ).
    fn add_y_t_times<S: Scalar>(y: &[[S; N]; K], r: &[S; K], x: &mut [S; N]);
    /// `M⁻¹ f`.
    fn m_inv_times<S: Scalar>(m_inv: &[[S; N]; N], f: &[S; N]) -> [S; N];
}

impl<S: Scalar, const N: usize, const K: usize> Terms<S, N, K> {
    /// The position terms (what [`Code::position`] computes); the velocity terms 0.
    pub fn new(
        sc: [[S; 2]; N],
        m_inv: [[S; N]; N],
        g: [[S; N]; K],
        y: [[S; N]; K],
        s: [[S; K]; K],
        springs: [S; N],
    ) -> Self {
        let z = S::zero();
        Terms {
            sc,
            m_inv,
            g,
            y,
            s,
            springs,
            bias: [z; N],
            gamma: [z; K],
            w: [[z; K]; K],
            r: [z; K],
        }
    }

    /// Factors `s` as [`Factored::new`] does (LDLᵀ in S's own order, a row whose pivot is
    /// not above [`RANK_TOLERANCE`] of the largest diagonal dropped: the same decisions),
    /// then forms S⁺ = L⁻ᵀ D⁺ L⁻¹ (a dropped row's and column's 0) into `w`, so that the
    /// two solves per right-hand side are products: a triangular solve is a chain of
    /// dependent operations, a product is not (measured for 6 × 6: substitution ~33 ns,
    /// product 9 ns). The pivot is divided once and multiplied by. Its loops have fixed
    /// bounds, which the compiler unrolls. Returns the rank found for G.
    pub fn factor(&mut self) -> usize {
        let largest = (0..K).fold(0.0f64, |m, i| m.max(self.s[i][i].re()));
        let floor = RANK_TOLERANCE * largest;
        // Every row kept is the common case: first without a decision in the loop (which
        // the compiler then unrolls: Andrews' factor 79 → 33 ns), again with them where a
        // pivot is not above the floor (the same pivots up to the first such).
        let (mut a, mut d_inv, mut rank) = in_order_ldl(&self.s, floor, false);
        if rank < K {
            (a, d_inv, rank) = in_order_ldl(&self.s, floor, true);
        }
        self.w = inverse_of_ldl(&a, &d_inv);
        rank
    }

    /// `x += Y S⁺ r` for `r = c − G x` (`c` None: `−G x`), as [`Factored`]'s, with `C`'s
    /// products; S⁺ r is left in `self.r`.
    fn correct<C: Code<N, K>>(&mut self, c: Option<&[S; K]>, x: &mut [S; N]) {
        let gx = C::g_times(&self.g, x);
        let r: [S; K] = std::array::from_fn(|i| c.map_or(S::zero(), |c| c[i]) - gx[i]);
        self.r = std::array::from_fn(|i| {
            self.w[i]
                .iter()
                .zip(&r)
                .fold(S::zero(), |s, (&a, &b)| s + a * b)
        });
        C::add_y_t_times(&self.y, &self.r, x);
    }

    /// `x` of least kinetic metric with `G x = c` (`M x = Gᵀ μ`): a Newton step of
    /// [`project`] for `c = −Φ`.
    pub fn solve<C: Code<N, K>>(&mut self, c: &[S; K]) -> [S; N] {
        let mut x = [S::zero(); N];
        self.correct::<C>(Some(c), &mut x);
        x
    }

    /// [`Factored::tangent`]: `q̇` onto `G q̇ = 0`.
    pub fn tangent<C: Code<N, K>>(&mut self, qd: &mut [S; N]) {
        self.correct::<C>(None, qd);
    }

    /// [`Factored::accelerations`] with `c = −γ` (this configuration's `gamma`): `q̈` of
    /// `M q̈ = f + Gᵀ μ`, `G q̈ = −γ`, into `qdd`; returns μ.
    pub fn accelerations<C: Code<N, K>>(&mut self, f: &[S; N], qdd: &mut [S; N]) -> [S; K] {
        *qdd = C::m_inv_times(&self.m_inv, f);
        let c = self.gamma.map(|g| -g);
        self.correct::<C>(Some(&c), qdd);
        self.r
    }
}

/// LDLᵀ of `s` in its own order: L below the diagonal of the result, D⁻¹ and the count of
/// pivots kept (above `floor`, or NaN). With `drop`, a row whose pivot is not above
/// `floor` is dropped (its D⁻¹ 0, its L column 0: [`Terms::factor`]); without, every pivot
/// is inverted.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // triangular index arithmetic reads best as indices
fn in_order_ldl<S: Scalar, const K: usize>(
    s: &[[S; K]; K],
    floor: f64,
    drop: bool,
) -> ([[S; K]; K], [S; K], usize) {
    let mut a = *s;
    let mut d_inv = [S::zero(); K];
    let mut rank = 0;
    for j in 0..K {
        let row = a[j];
        let kept = row[j].re() > floor || row[j].re().is_nan(); // (a NaN reaches the result)
        rank += kept as usize;
        if drop && !kept {
            for r in j + 1..K {
                a[r][j] = S::zero();
            }
            continue;
        }
        let di = S::one() / row[j];
        d_inv[j] = di;
        for r in j + 1..K {
            let l = row[r] * di;
            for c in j + 1..K {
                a[r][c] -= l * row[c];
            }
            a[r][j] = l;
        }
    }
    (a, d_inv, rank)
}

/// `L⁻ᵀ D⁺ L⁻¹` from L (unit lower: its entries below the diagonal) and D⁺ (a dropped
/// row's 0): L⁻¹ column by column, then `Σ_m L⁻¹[m][i] D⁺[m] L⁻¹[m][j]`.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // triangular index arithmetic reads best as indices
fn inverse_of_ldl<S: Scalar, const K: usize>(l: &[[S; K]; K], d_inv: &[S; K]) -> [[S; K]; K] {
    let mut li = [[S::zero(); K]; K];
    for j in 0..K {
        li[j][j] = S::one();
        for i in j + 1..K {
            let mut v = S::zero();
            for m in j..i {
                v -= l[i][m] * li[m][j];
            }
            li[i][j] = v;
        }
    }
    let mut w = [[S::zero(); K]; K];
    for i in 0..K {
        for j in i..K {
            let mut v = S::zero();
            for m in j..K {
                v += li[m][i] * (d_inv[m] * li[m][j]);
            }
            w[i][j] = v;
            w[j][i] = v;
        }
    }
    w
}

/// Newton iterations of the projection, at most (quadratic from the O(tolerance)
/// violation one step leaves; more only at a singular position, where they are linear).
pub const PROJECTION_ITERATIONS: usize = 8;

/// Moves `q` onto `Φ(q) = 0` by Newton steps of least kinetic metric (`M Δq = Gᵀ μ`,
/// `G Δq = −Φ`, by [`solve`]), until Φ is at rounding of `q`'s size; then `q̇` onto
/// `G q̇ = 0` the same way. `mass(q)` is M (row-major), `closures(q)` `(Φ, G)`. Leaves the
/// state as it is where a solve is not finite.
pub fn project(
    q: &mut [f64],
    qd: &mut [f64],
    structure: &Structure,
    mass: impl Fn(&[f64]) -> Vec<f64>,
    closures: impl Fn(&[f64]) -> (Vec<f64>, Vec<Vec<f64>>),
) {
    let n = q.len();
    let correct = |q: &[f64], g: &[Vec<f64>], defect: &[f64]| -> Option<Vec<f64>> {
        let c: Vec<f64> = defect.iter().map(|d| -d).collect();
        let (mut dq, mut mu) = (vec![0.0; n], vec![0.0; g.len()]);
        solve(mass(q), structure, g, &vec![0.0; n], &c, &mut dq, &mut mu);
        dq.iter().all(|v| v.is_finite()).then_some(dq)
    };
    for _ in 0..PROJECTION_ITERATIONS {
        let (phi, g) = closures(q);
        let scale = q.iter().fold(1.0f64, |s, v| s.max(v.abs()));
        if phi.iter().all(|v| v.abs() <= 4.0 * f64::EPSILON * scale) {
            break;
        }
        let Some(dq) = correct(q, &g, &phi) else {
            return;
        };
        q.iter_mut().zip(&dq).for_each(|(x, d)| *x += d);
    }
    let (_, g) = closures(q);
    let defect: Vec<f64> = g
        .iter()
        .map(|row| row.iter().zip(&*qd).map(|(a, b)| a * b).sum())
        .collect();
    if let Some(dv) = correct(q, &g, &defect) {
        qd.iter_mut().zip(&dv).for_each(|(v, d)| *v += d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::codegen::tests::Rng;
    use crate::multibody::fmu::closure_jacobian;

    /// A point mass in the plane (M = diag(2, 3)) held on the x axis by the same constraint
    /// written twice and once scaled (rank 1 of 3 rows): q̈ is the free one with its y
    /// component removed, whatever the redundancy; the multipliers of the dependent rows
    /// are 0 and the kept one carries the whole reaction.
    #[test]
    fn redundant_rows_give_the_unique_accelerations() {
        let g = vec![vec![0.0, 1.0], vec![0.0, 2.0], vec![0.0, 1.0]];
        let (f, c) = ([4.0, -9.0], [0.0, 0.0, 0.0]);
        let (mut qdd, mut mu) = ([0.0; 2], [0.0; 3]);
        let rank = solve(
            vec![2.0, 0.0, 0.0, 3.0],
            &Structure::dense(2, 3),
            &g,
            &f,
            &c,
            &mut qdd,
            &mut mu,
        );
        assert_eq!(rank, 1);
        assert_eq!(qdd, [2.0, 0.0]);
        // The reaction Gᵀ μ holds the weight: 9 N along y.
        let reaction: f64 = g.iter().zip(&mu).map(|(row, m)| row[1] * m).sum();
        assert!((reaction - 9.0).abs() < 1e-15, "{mu:?}");
        assert_eq!(mu.iter().filter(|&&m| m != 0.0).count(), 1);
    }

    /// `S = A Aᵀ` (k × k, row-major rows) of `a`.
    fn gram(a: &[Vec<f64>]) -> Vec<Vec<f64>> {
        a.iter()
            .map(|x| {
                a.iter()
                    .map(|y| x.iter().zip(y).map(|(u, v)| u * v).sum())
                    .collect()
            })
            .collect()
    }

    /// [`Envelope::factor`] of a dense symmetric `s` (its envelope the whole lower triangle).
    fn dense_envelope(s: &[Vec<f64>]) -> (Vec<usize>, Envelope<f64>) {
        let k = s.len();
        let (mut start, mut packed) = (Vec::new(), Vec::new());
        for (i, row) in s.iter().enumerate() {
            start.push(packed.len());
            packed.extend(&row[..=i]);
        }
        let first = vec![0; k];
        let envelope = Envelope::factor(&first, start, packed);
        (first, envelope)
    }

    /// [`Terms::factor`]'s S⁺ against the interpreted [`Envelope`]'s substitution applied
    /// to each unit vector (the same decisions, the same solution to rounding), for S = A Aᵀ
    /// of rank 6, of rank 5 (a row of A the sum of two others) and numerically of rank 5
    /// (that row moved by 1e-6: its pivot about 1e-12 of the largest diagonal, below
    /// [`RANK_TOLERANCE`]).
    #[test]
    fn generated_terms_factor_as_the_envelope_decides() {
        let mut rng = Rng(0xfac7);
        for (case, (dependent, nudge, rank)) in [(false, 0.0, 6), (true, 0.0, 5), (true, 1e-6, 5)]
            .into_iter()
            .enumerate()
        {
            let mut a = vec![vec![0.0; 6]; 6];
            for row in a.iter_mut() {
                row.iter_mut().for_each(|v| *v = rng.uniform(-1.0, 1.0));
            }
            if dependent {
                a[4] = (0..6)
                    .map(|c| a[1][c] + a[2][c] + nudge * (c as f64))
                    .collect();
            }
            let s = gram(&a);
            let fixed: [[f64; 6]; 6] = std::array::from_fn(|i| std::array::from_fn(|j| s[i][j]));
            let z = [[0.0; 1]; 6];
            let mut t =
                Terms::<f64, 1, 6>::new([[0.0; 2]; 1], [[0.0; 1]; 1], z, z, fixed, [0.0; 1]);
            assert_eq!(t.factor(), rank, "case {case}");
            let (first, envelope) = dense_envelope(&s);
            assert_eq!(envelope.rank, rank, "case {case}");
            let scale = t.w.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
            for j in 0..6 {
                let mut e = [0.0; 6];
                e[j] = 1.0;
                envelope.substitute(&first, &mut e);
                for (i, e) in e.iter().enumerate() {
                    assert!(
                        (t.w[i][j] - e).abs() <= 1e-12 * scale,
                        "case {case}: S⁺[{i}][{j}] {} vs {}",
                        t.w[i][j],
                        e
                    );
                }
            }
        }
    }

    /// A NaN in S (a configuration gone non-finite) reaches the solution of both
    /// factorisations: it is never dropped as a dependent row, which would hide it.
    #[test]
    fn a_nan_is_not_taken_for_a_dependent_row() {
        let mut s = vec![vec![0.0; 3]; 3];
        for (i, row) in s.iter_mut().enumerate() {
            row[i] = 1.0 + i as f64;
        }
        s[1][1] = f64::NAN;
        let fixed: [[f64; 3]; 3] = std::array::from_fn(|i| std::array::from_fn(|j| s[i][j]));
        let z = [[0.0; 1]; 3];
        let mut t = Terms::<f64, 1, 3>::new([[0.0; 2]; 1], [[0.0; 1]; 1], z, z, fixed, [0.0; 1]);
        assert_eq!(t.factor(), 3);
        assert!(t.w[1][1].is_nan());
        let (first, envelope) = dense_envelope(&s);
        assert_eq!(envelope.rank, 3);
        let mut r = vec![1.0; 3];
        envelope.substitute(&first, &mut r);
        assert!(r[1].is_nan(), "{r:?}");
    }

    /// [`Envelope`] on banded S = A Aᵀ (each row of A nonzero on three neighbouring
    /// columns: S's envelope is two below the diagonal), row 5 moved towards the span of
    /// rows 4 and 6 by a factor from 1 to 1e-5 and then to 0. In S's order row 6 is then
    /// the one that follows from those before it. Where S is well conditioned, every row is
    /// kept and the solution is the dense one (nalgebra's Cholesky factorisation); where
    /// every row is kept, a consistent right-hand side (r = S z) is met to rounding however
    /// ill-conditioned S is; where a row is dropped (exact dependence always), it is row 6
    /// alone, its unknown is 0, and r is still met: the equations kept to rounding, row 6's
    /// to its pivot's size (what the tolerance accepts).
    #[test]
    fn the_envelope_drops_the_rows_that_follow_from_those_before() {
        let (k, cols) = (8, 10);
        // (Row 5 becomes a combination of rows 4 and 6, columns 4 to 8: it meets row 2.)
        let mut first: Vec<usize> = (0..k).map(|i: usize| i.saturating_sub(2)).collect();
        first[5] = 2;
        first[6] = 3;
        first[7] = 3;
        let mut rng = Rng(0xe17e);
        let (mut kept, mut dropped) = (0, 0);
        for case in 0..70 {
            let mut a = vec![vec![0.0; cols]; k];
            for (i, row) in a.iter_mut().enumerate() {
                for v in &mut row[i..i + 3] {
                    *v = rng.uniform(-1.0, 1.0);
                }
            }
            let independent = if case >= 60 {
                0.0
            } else {
                10f64.powi(-(case / 10))
            };
            let (c4, c6) = (rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
            a[5] = (0..cols)
                .map(|c| c4 * a[4][c] + c6 * a[6][c] + independent * a[5][c])
                .collect();
            let s = gram(&a);
            let (mut start, mut packed) = (Vec::new(), Vec::new());
            for i in 0..k {
                start.push(packed.len());
                packed.extend((first[i]..=i).map(|j| s[i][j]));
            }
            let envelope = Envelope::factor(&first, start, packed);
            let z: Vec<f64> = (0..k).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let r: Vec<f64> = s
                .iter()
                .map(|row| row.iter().zip(&z).map(|(u, v)| u * v).sum())
                .collect();
            let mut x = r.clone();
            envelope.substitute(&first, &mut x);
            let largest = (0..k).fold(0.0f64, |m, i| m.max(s[i][i]));
            let defect = |i: usize| (0..k).map(|j| s[i][j] * x[j]).sum::<f64>() - r[i];
            if independent >= 1e-2 {
                assert_eq!(envelope.rank, k, "case {case}");
                let dense = nalgebra::DMatrix::from_fn(k, k, |i, j| s[i][j]);
                let exact = dense
                    .cholesky()
                    .expect("positive definite")
                    .solve(&nalgebra::DVector::from_column_slice(&r));
                let cond = 1e4 / independent.powi(2);
                for (u, v) in x.iter().zip(exact.iter()) {
                    assert!((u - v).abs() <= 1e-15 * cond, "case {case}: {u} vs {v}");
                }
            }
            if independent == 0.0 {
                assert_eq!(envelope.rank, k - 1, "case {case}");
            }
            if envelope.rank == k {
                // Backward stable however ill-conditioned S is (positive definite).
                let size = x.iter().fold(1.0f64, |m, v| m.max(v.abs()));
                for i in 0..k {
                    assert!(
                        defect(i).abs() <= 1e-12 * largest * size,
                        "case {case}: row {i}"
                    );
                }
                kept += 1;
                continue;
            }
            dropped += 1;
            assert_eq!((envelope.rank, x[6]), (k - 1, 0.0), "case {case}");
            for i in (0..k).filter(|&i| i != 6) {
                assert!(
                    defect(i).abs() <= 1e-12 * largest,
                    "case {case}: row {i}: {}",
                    defect(i)
                );
            }
            assert!(
                defect(6).abs() <= 10.0 * RANK_TOLERANCE * largest,
                "case {case}: {}",
                defect(6)
            );
        }
        println!("{kept} kept, {dropped} dropped");
        assert!(
            kept >= 20 && dropped >= 10,
            "{kept} kept, {dropped} dropped"
        );
    }

    /// A full-rank system against the augmented KKT solve of `crate::model::lagrangian`:
    /// a 4 × 4 mass matrix with couplings and two independent constraint rows.
    #[test]
    fn full_rank_equals_the_augmented_solve() {
        let m = [
            [4.0, 1.0, 0.5, 0.0],
            [1.0, 3.0, 0.2, 0.1],
            [0.5, 0.2, 2.0, 0.3],
            [0.0, 0.1, 0.3, 1.0],
        ];
        let g = vec![vec![1.0, -1.0, 0.5, 0.0], vec![0.0, 2.0, 1.0, -1.0]];
        let (f, c) = ([1.0, -2.0, 0.5, 3.0], [0.3, -0.7]);
        let flat: Vec<f64> = m.iter().flatten().copied().collect();
        let (mut qdd, mut mu) = ([0.0; 4], [0.0; 2]);
        assert_eq!(
            solve(
                flat.clone(),
                &Structure::dense(4, 2),
                &g,
                &f,
                &c,
                &mut qdd,
                &mut mu
            ),
            2
        );
        // [M −Gᵀ; G 0] [q̈; μ] = [f; c].
        let mut a = vec![vec![0.0; 6]; 6];
        for i in 0..4 {
            a[i][..4].copy_from_slice(&m[i]);
            for r in 0..2 {
                a[i][4 + r] = -g[r][i];
                a[4 + r][i] = g[r][i];
            }
        }
        let mut b = vec![f[0], f[1], f[2], f[3], c[0], c[1]];
        crate::model::lagrangian::solve(&mut a, &mut b);
        for i in 0..4 {
            assert!((qdd[i] - b[i]).abs() < 1e-14, "{qdd:?} vs {b:?}");
        }
        for r in 0..2 {
            assert!((mu[r] - b[4 + r]).abs() < 1e-14, "{mu:?} vs {b:?}");
        }
    }

    /// The N four-bar of the IFToMM benchmark A02 (rods of 1 m and 1 kg, gravity −y), here
    /// N = 3: N + 1 cranks on the ground 1 m apart, a coupler hung from each crank's tip
    /// and closed on the next crank's tip.
    fn n_four_bar(n: usize) -> crate::multibody::Model {
        use crate::multibody::{Body, Mechanism, Origin};
        let z = [0.0, 0.0, 1.0];
        let rod =
            |name: &str, com: [f64; 3]| Body::new(name, 1.0).com(com).inertia_diag([1.0 / 12.0; 3]);
        let mut m = Mechanism::new("nfourbar")
            .gravity([0.0, -9.81, 0.0])
            .body(Body::massless("ground"));
        for i in 0..=n {
            m = m
                .body(rod(&format!("crank{i}"), [0.0, 0.5, 0.0]))
                .continuous(
                    &format!("c{i}"),
                    "ground",
                    &format!("crank{i}"),
                    Origin::xyz([i as f64, 0.0, 0.0]),
                    z,
                );
        }
        for i in 1..=n {
            m = m
                .body(rod(&format!("coupler{i}"), [0.5, 0.0, 0.0]))
                .continuous(
                    &format!("k{i}"),
                    &format!("crank{}", i - 1),
                    &format!("coupler{i}"),
                    Origin::xyz([0.0, 1.0, 0.0]),
                    z,
                )
                .closure(
                    &format!("B{i}"),
                    &format!("coupler{i}"),
                    [1.0, 0.0, 0.0],
                    &format!("crank{i}"),
                    [0.0, 1.0, 0.0],
                    "xy",
                );
        }
        let cranks: Vec<String> = (1..=n).map(|i| format!("c{i}")).collect();
        let couplers: Vec<String> = (1..=n).map(|i| format!("k{i}")).collect();
        let dependent: Vec<&str> = cranks.iter().chain(&couplers).map(String::as_str).collect();
        crate::multibody::Model::new(&m.dependent(&dependent)).expect("a valid mechanism")
    }

    /// q̈ of a model with closures, as the FMU forms it: CRBA, RNEA, G and γ by dual
    /// numbers, [`solve`].
    fn accelerations(model: &crate::multibody::Model, q: &[f64], qd: &[f64]) -> Vec<f64> {
        use num_dual::HyperDual64;
        let (n, k) = (model.nq(), model.closure_residuals());
        let m: Vec<f64> = model.crba(q).into_iter().flatten().collect();
        let f: Vec<f64> = model
            .rnea(q, qd, &vec![0.0; n])
            .iter()
            .map(|b| -b)
            .collect();
        let g = closure_jacobian(model, q);
        let qh: Vec<HyperDual64> = q
            .iter()
            .zip(qd)
            .map(|(&a, &v)| HyperDual64::new(a, v, v, 0.0))
            .collect();
        let mut curv = vec![HyperDual64::from(0.0); k];
        model.closure_residuals_at(&qh, &mut curv);
        let c: Vec<f64> = curv.iter().map(|v| -v.eps1eps2).collect();
        let (mut qdd, mut mu) = (vec![0.0; n], vec![0.0; k]);
        let order: Vec<usize> = (0..n).collect();
        solve(
            m,
            &Structure::of(model, &order),
            &g,
            &f,
            &c,
            &mut qdd,
            &mut mu,
        );
        qdd
    }

    /// IFToMM A02's difficulty, on N = 3 windows: started with every crank vertical and B0
    /// moving at 1 m/s, the mechanism passes its singular positions (every crank
    /// horizontal: N more degrees of freedom for an instant, G of rank 2N − N) twice a
    /// turn, and stays on its branch: every crank at the same angle θ, which follows the
    /// exact one-coordinate reduction `J θ̈ = P sin θ`, `J = (N + 1)/3 + N`,
    /// `P = g ((N + 1)/2 + N)` (m = L = 1). Both by RK4 at h = 1e-3 over 4 s (three
    /// horizontal passages and more), the mechanism projected onto its closures after
    /// each step.
    #[test]
    fn the_n_four_bar_passes_its_singular_positions_on_its_branch() {
        let n = 3;
        let model = n_four_bar(n);
        let nq = model.nq();
        let index = |name: &str| model.joints.iter().position(|j| j == name).expect(name);
        let cranks: Vec<usize> = (0..=n).map(|i| index(&format!("c{i}"))).collect();
        let (mut q, mut qd) = (vec![0.0; nq], vec![0.0; nq]);
        for i in 0..=n {
            qd[cranks[i]] = -1.0; // clockwise: B0 moves along +x at 1 m/s
        }
        for i in 1..=n {
            qd[index(&format!("k{i}"))] = 1.0; // the couplers translate
        }
        let (jr, pr) = (
            (n as f64 + 1.0) / 3.0 + n as f64,
            9.81 * ((n as f64 + 1.0) / 2.0 + n as f64),
        );
        let (mut theta, mut omega) = (0.0f64, 1.0f64);
        let reduced = |th: f64| pr / jr * th.sin();
        let h = 1e-3;
        let mut passages = 0;
        let mut worst = (0.0f64, 0.0f64);
        for _ in 0..4000 {
            // RK4 on (q, q̇).
            let rate = |q: &[f64], v: &[f64]| accelerations(&model, q, v);
            let step = |x: &[f64], dx: &[f64], s: f64| -> Vec<f64> {
                x.iter().zip(dx).map(|(a, b)| a + s * b).collect()
            };
            let a1 = rate(&q, &qd);
            let (q2, v2) = (step(&q, &qd, h / 2.0), step(&qd, &a1, h / 2.0));
            let a2 = rate(&q2, &v2);
            let (q3, v3) = (step(&q, &v2, h / 2.0), step(&qd, &a2, h / 2.0));
            let a3 = rate(&q3, &v3);
            let (q4, v4) = (step(&q, &v3, h), step(&qd, &a3, h));
            let a4 = rate(&q4, &v4);
            let y_before = q[cranks[0]].cos();
            for i in 0..nq {
                q[i] += h / 6.0 * (qd[i] + 2.0 * v2[i] + 2.0 * v3[i] + v4[i]);
                qd[i] += h / 6.0 * (a1[i] + 2.0 * a2[i] + 2.0 * a3[i] + a4[i]);
            }
            project(
                &mut q,
                &mut qd,
                &Structure::of(&model, &(0..nq).collect::<Vec<_>>()),
                |q| model.crba(q).into_iter().flatten().collect(),
                |q| {
                    let mut phi = vec![0.0; model.closure_residuals()];
                    model.closure_residuals_at(q, &mut phi);
                    (phi, closure_jacobian(&model, q))
                },
            );
            if y_before * q[cranks[0]].cos() < 0.0 {
                passages += 1;
            }
            // The reduced model, RK4 alike.
            let (k1, l1) = (omega, reduced(theta));
            let (k2, l2) = (omega + h / 2.0 * l1, reduced(theta + h / 2.0 * k1));
            let (k3, l3) = (omega + h / 2.0 * l2, reduced(theta + h / 2.0 * k2));
            let (k4, l4) = (omega + h * l3, reduced(theta + h * k3));
            theta += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            omega += h / 6.0 * (l1 + 2.0 * l2 + 2.0 * l3 + l4);
            let parallel = cranks
                .iter()
                .map(|&c| (q[c] - q[cranks[0]]).abs())
                .fold(0.0, f64::max);
            worst.0 = worst.0.max(parallel);
            worst.1 = worst.1.max((-q[cranks[0]] - theta).abs());
        }
        // At the singular position itself (every crank horizontal, G of rank N of 2N): finite
        // accelerations (Gauss's principle with the extra freedoms free, not the branch's:
        // see RANK_TOLERANCE).
        let (mut q, mut qd) = (vec![0.0; nq], vec![0.0; nq]);
        for i in 0..=n {
            q[cranks[i]] = -std::f64::consts::FRAC_PI_2;
            qd[cranks[i]] = -2.0;
        }
        for i in 1..=n {
            q[index(&format!("k{i}"))] = std::f64::consts::FRAC_PI_2;
            qd[index(&format!("k{i}"))] = 2.0;
        }
        let a = accelerations(&model, &q, &qd);
        assert!(a.iter().all(|x| x.is_finite()), "{a:?}");
        // 1e-3 rad off it (outside the ~1e-4 rad where RANK_TOLERANCE drops the direction
        // the branch is about to lose), the branch's: θ̈ = (P/J) sin θ for every crank.
        let off = 1e-3f64;
        for i in 0..=n {
            q[cranks[i]] += off;
        }
        for i in 1..=n {
            q[index(&format!("k{i}"))] -= off;
        }
        let a = accelerations(&model, &q, &qd);
        for i in 0..=n {
            assert!((a[cranks[i]] + pr / jr * off.cos()).abs() < 1e-8, "{a:?}");
        }
        println!("N four-bar, N = {n}: {passages} horizontal passages in 4 s; cranks parallel to {:.1e} rad, θ against the reduction {:.1e} rad", worst.0, worst.1);
        assert!(passages >= 3, "{passages}");
        assert!(worst.0 < 1e-9 && worst.1 < 1e-8, "{worst:?}");
    }

    /// The tree's structure (LTDL from the leaves, G's rows over their paths only) gives
    /// the dense solve's q̈ and μ: the N four-bar (N = 3) at random states, off the
    /// closures and on no branch (the formulas hold anywhere), and a declared order that
    /// puts a child before its parent falls back to the dense chain.
    #[test]
    fn the_trees_structure_gives_the_dense_solution() {
        let model = n_four_bar(3);
        let (n, k) = (model.nq(), model.closure_residuals());
        let mut rng = Rng(0x2545f4914f6cdd1d);
        let mut uniform = || rng.uniform(-1.0, 1.0);
        let natural: Vec<usize> = (0..n).collect();
        let tree = Structure::of(&model, &natural);
        assert!(
            tree.parent.iter().filter(|p| p.is_none()).count() > 1,
            "a tree, not a chain"
        );
        assert!(
            tree.columns.iter().all(|c| c.len() <= 3),
            "{:?}",
            tree.columns
        );
        let mut reversed = natural.clone();
        reversed.reverse();
        assert_eq!(
            Structure::of(&model, &reversed).parent,
            Structure::dense(n, 0).parent
        );
        for _ in 0..5 {
            let q: Vec<f64> = (0..n).map(|_| 3.0 * uniform()).collect();
            let g = closure_jacobian(&model, &q);
            let f: Vec<f64> = (0..n).map(|_| uniform()).collect();
            let c: Vec<f64> = (0..k).map(|_| uniform()).collect();
            let mut out = Vec::new();
            for s in [&tree, &Structure::dense(n, k)] {
                let m: Vec<f64> = model.crba(&q).into_iter().flatten().collect();
                let (mut qdd, mut mu) = (vec![0.0; n], vec![0.0; k]);
                solve(m, s, &g, &f, &c, &mut qdd, &mut mu);
                out.push((qdd, mu));
            }
            let scale = out[1]
                .0
                .iter()
                .chain(&out[1].1)
                .fold(1.0f64, |a, v| a.max(v.abs()));
            for (a, b) in out[0]
                .0
                .iter()
                .chain(&out[0].1)
                .zip(out[1].0.iter().chain(&out[1].1))
            {
                assert!((a - b).abs() < 1e-11 * scale, "{a} vs {b} (scale {scale})");
            }
        }
    }

    /// [`kinematics`] against dual numbers through forward kinematics (Φ, G column by
    /// column, γ = q̇ᵀ∇²Φ q̇ by hyper-dual numbers): a spatial arm (tilted axes, a
    /// prismatic joint) closed on its own first link in all three axes, and the N four-bar,
    /// at random states (not on the closures: the formulas hold anywhere).
    #[test]
    fn analytical_closure_kinematics_equal_dual_numbers() {
        use num_dual::{Dual64, HyperDual64};
        let arm = {
            let m =
                crate::multibody::urdf::parse(crate::multibody::floating_tests::ARM, "arm.urdf")
                    .unwrap()
                    .closure(
                        "loop",
                        "hand",
                        [0.1, 0.2, 0.3],
                        "upper",
                        [0.0, 0.1, -0.2],
                        "xyz",
                    )
                    .dependent(&["shoulder", "slide", "wrist"]);
            Model::new(&m).unwrap()
        };
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
        let mut next = || rng.uniform(-2.0, 2.0);
        for model in [arm, n_four_bar(3)] {
            let (n, k) = (model.nq(), model.closure_residuals());
            for _ in 0..5 {
                let q: Vec<f64> = (0..n).map(|_| next()).collect();
                let qd: Vec<f64> = (0..n).map(|_| next()).collect();
                let (mut phi, mut g, mut curv) =
                    (vec![0.0; k], vec![vec![0.0; n]; k], vec![0.0; k]);
                kinematics(&model, &q, &qd, &mut phi, &mut g, &mut curv);
                let mut want = vec![0.0; k];
                model.closure_residuals_at(&q, &mut want);
                for (a, b) in phi.iter().zip(&want) {
                    assert!((a - b).abs() < 1e-14, "Φ {phi:?} vs {want:?}");
                }
                for j in 0..n {
                    let mut qj: Vec<Dual64> = q.iter().map(|&v| v.into()).collect();
                    qj[j].eps = 1.0;
                    let mut d = vec![Dual64::from(0.0); k];
                    model.closure_residuals_at(&qj, &mut d);
                    for r in 0..k {
                        assert!(
                            (g[r][j] - d[r].eps).abs() < 1e-13,
                            "G[{r}][{j}]: {} vs {}",
                            g[r][j],
                            d[r].eps
                        );
                    }
                }
                let qh: Vec<HyperDual64> = q
                    .iter()
                    .zip(&qd)
                    .map(|(&a, &v)| HyperDual64::new(a, v, v, 0.0))
                    .collect();
                let mut h = vec![HyperDual64::from(0.0); k];
                model.closure_residuals_at(&qh, &mut h);
                for r in 0..k {
                    assert!(
                        (curv[r] - h[r].eps1eps2).abs() < 1e-12,
                        "γ[{r}]: {} vs {}",
                        curv[r],
                        h[r].eps1eps2
                    );
                }
            }
        }
    }
}
