//! The Jacobian of forward dynamics, `∂q̈/∂q` and `∂q̈/∂q̇`, analytically in O(n²) (for a
//! chain; O(n·depth) pairs for a tree) with a few dot products per pair of joints, through
//! inverse dynamics as Pinocchio's `computeABADerivatives` does (Carpentier & Mansard,
//! *Analytical derivatives of rigid body dynamics algorithms*, RSS 2018), written here from
//! the world-frame identities below. For `f64` at run time: the long chains' Jacobian,
//! where emitting symbolic derivatives as straight-line code no longer scales.
//!
//! `M(q) q̈ + b(q, q̇) = τ − d q̇` gives `∂q̈/∂q = −M⁻¹ ∂ID/∂q` and
//! `∂q̈/∂q̇ = −M⁻¹ (∂ID/∂q̇ + diag d)`, ID being RNEA at the fixed `q̈`.
//!
//! Everything in world coordinates (spatial vectors at the world origin): body i's motion
//! subspace `S_i`, velocity `v_i = v_λ + S_i q̇_i`, acceleration
//! `a_i = a_λ + S_i q̈_i + (v_i × S_i) q̇_i` (`a_0 = (0, −g)`), inertia `I_i`, force
//! `f_i = I_i a_i + v_i ×* I_i v_i`; `F_j`, `I^C_j`, `B^C_j` the sums over j's subtree of
//! `f_i`, `I_i` and `B_i = (v_i ×*) I_i + H(I_i v_i) − I_i (v_i ×)` (`H(h) w = w ×* h`), and
//! `τ_j = S_j · F_j`. Turning joint k turns its subtree rigidly about `S_k` while the
//! proximal side p = λ(k) stays: with `w = S_k × v_p`, `β = S_k × a_p − w × v_p`, a body
//! i ⪰ k gets `δf_i = S_k ×* f_i − I_i β − B_i w`; hence, with
//! `(S_k × S_j)·F_j = −S_j·(S_k ×* F_j)` cancelling the rigid part,
//!
//! - `∂τ_j/∂q_k = −S_j·(I^C_j β + B^C_j w)` for j ⪰ k, and
//!   `S_j·(S_k ×* F_k − I^C_k β − B^C_k w)` for j ≺ k;
//! - `∂τ_j/∂q̇_k = S_j·(B^C_j S_k − 2 I^C_j (S_k × v_k))` for j ⪰ k, the same with `k`'s
//!   composites for j ≺ k (a body i ⪰ k gets `δv_i = S_k`, `δa_i = S_k × v_i − 2 S_k × v_k`);
//! - `M_jk = S_j·(I^C_k S_k)` for j ⪯ k.
//!
//! Each pair is two or four 6-vector dot products once `I^C_j S_j` and `B^C_jᵀ S_j` are
//! kept per joint; M is factored as LDLᵀ and the 2n right-hand sides are solved together,
//! row by row (so the inner loops run along contiguous rows).

use super::dynamics::Model;
use super::spatial::{RigidInertia, Transform};
use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

type V6 = Vector6<f64>;
type M6 = Matrix6<f64>;

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v[2], v[1], v[2], 0.0, -v[0], -v[1], v[0], 0.0)
}

fn ang(v: &V6) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
}

fn lin(v: &V6) -> Vector3<f64> {
    Vector3::new(v[3], v[4], v[5])
}

fn join(a: Vector3<f64>, b: Vector3<f64>) -> V6 {
    V6::new(a[0], a[1], a[2], b[0], b[1], b[2])
}

/// `a ×m b`.
fn crm(a: &V6, b: &V6) -> V6 {
    let (w, v) = (ang(a), lin(a));
    join(w.cross(&ang(b)), w.cross(&lin(b)) + v.cross(&ang(b)))
}

/// `a ×* f`.
fn crf(a: &V6, f: &V6) -> V6 {
    let (w, v) = (ang(a), lin(a));
    join(w.cross(&ang(f)) + v.cross(&lin(f)), w.cross(&lin(f)))
}

/// The matrix of `m ↦ v ×m m`.
fn crm_matrix(v: &V6) -> M6 {
    let (w, l) = (skew(&ang(v)), skew(&lin(v)));
    let mut m = M6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&w);
    m.fixed_view_mut::<3, 3>(3, 0).copy_from(&l);
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&w);
    m
}

/// The matrix of `w ↦ w ×* h`.
fn h_matrix(h: &V6) -> M6 {
    let (n, f) = (skew(&ang(h)), skew(&lin(h)));
    let mut m = M6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-n));
    m.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-f));
    m.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-f));
    m
}

/// `[[i, h×], [−h×, m 1]]`.
fn inertia_matrix(r: &RigidInertia<f64>) -> M6 {
    let hx = skew(&Vector3::from(r.h));
    let mut m = M6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&Matrix3::from_fn(|a, b| r.i[a][b]));
    m.fixed_view_mut::<3, 3>(0, 3).copy_from(&hx);
    m.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-hx));
    m.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(Matrix3::identity() * r.m));
    m
}

/// Scratch kept between calls (no allocation once sized).
#[derive(Default)]
pub struct Scratch {
    s: Vec<V6>,
    v: Vec<V6>,
    a: Vec<V6>,
    ic: Vec<M6>,
    bc: Vec<M6>,
    f: Vec<V6>,
    row_i: Vec<V6>,
    row_b: Vec<V6>,
    /// Each body's world inertia, the articulated inertias, U = I^A S and 1/D.
    iw: Vec<M6>,
    ia: Vec<M6>,
    u: Vec<V6>,
    d_inv: Vec<f64>,
    /// Per joint 6 rows of 2n: bias forces P on the way in, accelerations A on the way out.
    pa: Vec<f64>,

    /// The right-hand sides, row-major n × 2n: [∂τ/∂q | ∂τ/∂q̇ + diag d].
    rhs: Vec<f64>,
    /// Subtree ends: joint j's subtree is `j..end[j]` (depth-first order).
    end: Vec<usize>,
}

/// `∂q̈/∂q` and `∂q̈/∂q̇` (row-major n × n each) at `(q, q̇)` where forward dynamics gave
/// `qdd` (with the model's damping, as [`Model::aba`]).
pub fn aba_derivatives(
    model: &Model,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    scratch: &mut Scratch,
    dq: &mut [f64],
    dqd: &mut [f64],
) {
    let n = model.nq();
    let sc = scratch;
    sc.s.resize(n, V6::zeros());
    sc.v.resize(n, V6::zeros());
    sc.a.resize(n, V6::zeros());
    sc.ic.resize(n, M6::zeros());
    sc.bc.resize(n, M6::zeros());
    sc.f.resize(n, V6::zeros());
    sc.row_i.resize(n, V6::zeros());
    sc.row_b.resize(n, V6::zeros());
    sc.iw.resize(n, M6::zeros());
    sc.ia.resize(n, M6::zeros());
    sc.u.resize(n, V6::zeros());
    sc.d_inv.resize(n, 0.0);
    sc.rhs.resize(2 * n * n, 0.0);
    sc.end.resize(n, 0);

    // Forward: poses, S, v, a, I, B, f in world coordinates.
    let poses = model.forward_kinematics(q);
    let g = &model.gravity;
    let a0 = V6::new(0.0, 0.0, 0.0, -g[0], -g[1], -g[2]);
    for i in 0..n {
        let (r, p) = &poses[i];
        let r = Matrix3::from_fn(|a, b| r[a][b]);
        let p = Vector3::new(p[0], p[1], p[2]);
        // Motion body → world: (R ω, R v + p × R ω).
        let sb = &model.subspace[i];
        let w = r * Vector3::from(sb.ang);
        let s = join(w, r * Vector3::from(sb.lin) + p.cross(&w));
        // The body's inertia about the world origin, in world axes (`x = body_X_world`).
        let to_body = Transform {
            e: std::array::from_fn(|a| std::array::from_fn(|b| r[(b, a)])),
            r: [p[0], p[1], p[2]],
        };
        let iw = inertia_matrix(&model.inertia[i].back(&to_body));
        let (vp, ap) = match model.parent[i] {
            None => (V6::zeros(), a0),
            Some(k) => (sc.v[k], sc.a[k]),
        };
        let v = vp + s * qd[i];
        let a = ap + s * qdd[i] + crm(&v, &s) * qd[i];
        let h = iw * v;
        sc.f[i] = iw * a + crf(&v, &h);
        // B = (v ×*) I − I (v ×) + H(h) = −Pᵀ − P + H(h) with P = I (v ×) (I symmetric).
        let pm = iw * crm_matrix(&v);
        sc.bc[i] = h_matrix(&h) - pm - pm.transpose();
        sc.ic[i] = iw;
        sc.iw[i] = iw;
        sc.s[i] = s;
        sc.v[i] = v;
        sc.a[i] = a;
        sc.end[i] = i + 1;
    }
    // Backward: composites over subtrees, subtree ends.
    for i in (0..n).rev() {
        if let Some(p) = model.parent[i] {
            let (ic, bc, f, end) = (sc.ic[i], sc.bc[i], sc.f[i], sc.end[i]);
            sc.ic[p] += ic;
            sc.bc[p] += bc;
            sc.f[p] += f;
            sc.end[p] = sc.end[p].max(end);
        }
    }
    for j in 0..n {
        sc.row_i[j] = sc.ic[j] * sc.s[j];
        sc.row_b[j] = sc.bc[j].transpose() * sc.s[j];
    }
    // Pairs: ∂τ/∂q, ∂τ/∂q̇ into rhs (row j: [∂τ_j/∂q | ∂τ_j/∂q̇]); M's lower triangle.
    let w2 = 2 * n;
    sc.rhs.iter_mut().for_each(|x| *x = 0.0);
    for k in 0..n {
        let (vp, ap) = match model.parent[k] {
            None => (V6::zeros(), a0),
            Some(p) => (sc.v[p], sc.a[p]),
        };
        let sk = sc.s[k];
        let w = crm(&sk, &vp);
        let beta = crm(&sk, &ap) - crm(&w, &vp);
        let skvk = crm(&sk, &sc.v[k]);
        for j in k..sc.end[k] {
            let (ri, rb) = (&sc.row_i[j], &sc.row_b[j]);
            sc.rhs[j * w2 + k] = -(ri.dot(&beta) + rb.dot(&w));
            sc.rhs[j * w2 + n + k] = rb.dot(&sk) - 2.0 * ri.dot(&skvk);
        }
        let g_k = crf(&sk, &sc.f[k]) - sc.ic[k] * beta - sc.bc[k] * w;
        let h_k = sc.bc[k] * sk - sc.ic[k] * skvk * 2.0;
        let mut j = model.parent[k];
        while let Some(jj) = j {
            let sj = &sc.s[jj];
            sc.rhs[jj * w2 + k] = sj.dot(&g_k);
            sc.rhs[jj * w2 + n + k] = sj.dot(&h_k);
            j = model.parent[jj];
        }
    }
    for j in 0..n {
        sc.rhs[j * w2 + n + j] += model.damping[j];
    }
    // M X = rhs by the articulated-body recursion on all 2n columns at once (world
    // frame, no velocity, no gravity): articulated inertias I^A, U = I^A S, D = S·U, then
    // a backward pass of bias forces P (6 rows of 2n per joint) and a forward pass of
    // accelerations A. About 30 multiply-adds per joint and column, against the n of a
    // dense LDLᵀ solve.
    for i in 0..n {
        sc.ia[i] = sc.iw[i];
    }
    for i in (0..n).rev() {
        let u = sc.ia[i] * sc.s[i];
        let d = sc.s[i].dot(&u);
        sc.u[i] = u;
        sc.d_inv[i] = 1.0 / d;
        if let Some(p) = model.parent[i] {
            let child = sc.ia[i] - u * u.transpose() * sc.d_inv[i];
            sc.ia[p] += child;
        }
    }
    let blk = 6 * w2;
    sc.pa.resize(n * blk, 0.0);
    sc.pa.iter_mut().for_each(|x| *x = 0.0);
    let rhs = &mut sc.rhs;
    for i in (0..n).rev() {
        // u_i = rhs_i − S_i · P_i (kept in rhs row i), then P_λ += P_i + U_i u_i / D_i.
        let (s_i, u_i, d_inv) = (sc.s[i], sc.u[i], sc.d_inv[i]);
        let row = &mut rhs[i * w2..(i + 1) * w2];
        let pi = &sc.pa[i * blk..(i + 1) * blk];
        for r in 0..6 {
            if s_i[r] != 0.0 {
                let sr = s_i[r];
                row.iter_mut()
                    .zip(&pi[r * w2..(r + 1) * w2])
                    .for_each(|(x, p)| *x -= sr * p);
            }
        }
        if let Some(p) = model.parent[i] {
            let (lo, hi) = sc.pa.split_at_mut(i * blk);
            let (pp, pi) = (&mut lo[p * blk..(p + 1) * blk], &hi[..blk]);
            for r in 0..6 {
                let ur = u_i[r] * d_inv;
                pp[r * w2..(r + 1) * w2]
                    .iter_mut()
                    .zip(&pi[r * w2..(r + 1) * w2])
                    .zip(row.iter())
                    .for_each(|((x, p), u)| *x += p + ur * u);
            }
        }
    }
    // Forward: x_i = (u_i − U_i · A_λ) / D_i, A_i = A_λ + S_i x_i; A kept per joint in pa
    // (its P is no longer needed).
    for i in 0..n {
        let (s_i, u_i, d_inv) = (sc.s[i], sc.u[i], sc.d_inv[i]);
        let parent = model.parent[i];
        {
            let row = &mut rhs[i * w2..(i + 1) * w2];
            if let Some(p) = parent {
                let ap = &sc.pa[p * blk..(p + 1) * blk];
                for r in 0..6 {
                    if u_i[r] != 0.0 {
                        let ur = u_i[r];
                        row.iter_mut()
                            .zip(&ap[r * w2..(r + 1) * w2])
                            .for_each(|(x, a)| *x -= ur * a);
                    }
                }
            }
            row.iter_mut().for_each(|x| *x *= d_inv);
        }
        let row = &rhs[i * w2..(i + 1) * w2];
        match parent {
            Some(p) => {
                let (lo, hi) = sc.pa.split_at_mut(i * blk);
                let (ap, ai) = (&lo[p * blk..(p + 1) * blk], &mut hi[..blk]);
                for r in 0..6 {
                    let sr = s_i[r];
                    ai[r * w2..(r + 1) * w2]
                        .iter_mut()
                        .zip(&ap[r * w2..(r + 1) * w2])
                        .zip(row)
                        .for_each(|((x, a), q)| *x = a + sr * q);
                }
            }
            None => {
                let ai = &mut sc.pa[i * blk..(i + 1) * blk];
                for r in 0..6 {
                    let sr = s_i[r];
                    ai[r * w2..(r + 1) * w2]
                        .iter_mut()
                        .zip(row)
                        .for_each(|(x, q)| *x = sr * q);
                }
            }
        }
    }
    for i in 0..n {
        for j in 0..n {
            dq[i * n + j] = -rhs[i * w2 + j];
            dqd[i * n + j] = -rhs[i * w2 + n + j];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::multibody::urdf;
    use num_dual::Dual64;

    /// A tree with a branch, tilted placements, a prismatic joint and damping.
    fn tree() -> Model {
        let link = |name: &str, m: f64| {
            format!(
                r#"<link name="{name}"><inertial><origin xyz="0.05 -0.02 0.1" rpy="0.1 0.2 0.3"/>
                <mass value="{m}"/><inertia ixx="0.02" ixy="0.001" ixz="0" iyy="0.03" iyz="0.002" izz="0.025"/>
                </inertial></link>"#
            )
        };
        let joint = |name: &str,
                     kind: &str,
                     parent: &str,
                     child: &str,
                     xyz: &str,
                     rpy: &str,
                     axis: &str| {
            format!(
                r#"<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>
                <origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>
                <limit lower="-3" upper="3" effort="10" velocity="5"/><dynamics damping="0.2"/></joint>"#
            )
        };
        let text = format!(
            r#"<robot name="tree"><link name="base"/>{}{}{}{}{}{}{}{}{}{}</robot>"#,
            link("a", 2.0),
            link("b", 1.0),
            link("c", 1.5),
            link("d", 0.7),
            link("e", 0.4),
            joint("ja", "revolute", "base", "a", "0 0 0.1", "0 0 0", "0 0 1"),
            joint(
                "jb",
                "revolute",
                "a",
                "b",
                "0.2 0 0.3",
                "0.3 -0.2 0.1",
                "0 1 0"
            ),
            joint(
                "jc",
                "continuous",
                "a",
                "c",
                "-0.1 0.2 0.3",
                "0 0.5 0",
                "0.6 0 0.8"
            ),
            joint("jd", "prismatic", "c", "d", "0 0 0.4", "0.2 0 0", "1 0 0"),
            joint("je", "revolute", "d", "e", "0.1 0.1 0", "0 0 0.7", "1 0 0"),
        );
        Model::new(&urdf::parse(&text, "tree.urdf").unwrap()).unwrap()
    }

    /// ∂q̈/∂(q, q̇) by dual numbers through `Model::aba`.
    fn dual_jacobian(model: &Model, q: &[f64], qd: &[f64], tau: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let n = model.nq();
        let lift = |v: &[f64]| v.iter().map(|&x| Dual64::from(x)).collect::<Vec<_>>();
        let (mut dq, mut dqd) = (vec![0.0; n * n], vec![0.0; n * n]);
        for j in 0..n {
            for wrt_q in [true, false] {
                let (mut xq, mut xqd) = (lift(q), lift(qd));
                let (x, out) = if wrt_q {
                    (&mut xq[j], &mut dq)
                } else {
                    (&mut xqd[j], &mut dqd)
                };
                x.eps = 1.0;
                let qdd = model.aba(&xq, &xqd, &lift(tau));
                for i in 0..n {
                    out[i * n + j] = qdd[i].eps;
                }
            }
        }
        (dq, dqd)
    }

    #[test]
    fn analytical_derivatives_equal_dual_numbers() {
        let mut models = vec![("tree", tree())];
        for m in ["ur5", "panda", "chain_16"] {
            models.push((m, crate::multibody::codegen::benchmark_model(m)));
        }
        let mut scratch = Scratch::default();
        for (name, model) in models {
            let n = model.nq();
            for k in 0..3 {
                let q: Vec<f64> = (0..n).map(|i| 0.3 + 0.37 * (i + k) as f64).collect();
                let qd: Vec<f64> = (0..n).map(|i| -0.7 + 0.23 * (i * k) as f64).collect();
                let tau: Vec<f64> = (0..n).map(|i| 1.5 - 0.4 * i as f64).collect();
                let qdd = model.aba(&q, &qd, &tau);
                let (mut dq, mut dqd) = (vec![0.0; n * n], vec![0.0; n * n]);
                aba_derivatives(&model, &q, &qd, &qdd, &mut scratch, &mut dq, &mut dqd);
                let (wq, wqd) = dual_jacobian(&model, &q, &qd, &tau);
                for (got, want, what) in [(&dq, &wq, "∂q̈/∂q"), (&dqd, &wqd, "∂q̈/∂q̇")]
                {
                    let scale = want.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                    for (i, (a, b)) in got.iter().zip(want).enumerate() {
                        assert!(
                            (a - b).abs() <= 1e-10 * scale,
                            "{name} {what}[{i}]: {a} vs {b}"
                        );
                    }
                }
            }
        }
    }
}
