//! The straight-line terms of a mechanism with loop closures ([`super::super::closed`]),
//! for its right-hand side at tree speed: what depends on q alone (M⁻¹, G, `Y = M⁻¹ Gᵀ`,
//! the Schur complement `S = G M⁻¹ Gᵀ`, the springs' gradient) in one function, what
//! depends on q̇ too (the bias by RNEA at q̈ = 0 and the curvature `γ = Ġ q̇`) in another,
//! both traced with the symbolic scalar through the same algorithms the interpreted path
//! runs ([`Model::crba`], [`Model::rnea`], [`closed::kinematics`](super::super::closed::kinematics),
//! the springs' energy by dual numbers), in the mechanism's coordinate order; and the
//! products the solve needs (`G x`, `x + Yᵀ r`, `M⁻¹ f`) over the terms' structural
//! nonzeros, which the trace knows (Andrews: 22 of G's 42 entries, 13 of M⁻¹'s 49). All of
//! it as the mechanism's [`closed::Code`](super::super::closed::Code); only the
//! rank-revealing factorisation of S is left to run time
//! ([`closed::Terms`](super::super::closed::Terms)): which rows it drops depends on the
//! values.
//!
//! Two functions, not one, because the velocity is taken onto `G q̇ = 0` between them
//! (with G and S of the first); the second reads the first's `sin qᵢ`, `cos qᵢ` (`sc`)
//! instead of computing them again (the trigonometry is most of a planar mechanism's
//! position terms: Andrews' seven `sin_cos` are 58 of its ~80 ns).
//!
//! M⁻¹ is traced as a dense LDLᵀ of the traced M ([`ldl_factor`]): the tree's zeros are
//! exact constants there and fold away, so what is emitted is the tree's sparse solve.
//! No snapping: the code is the declared model's to rounding (tests: 1e-12 relative).

use super::{fingerprint, ldl_factor, ldl_solve};
use crate::model::symbolic::emit::straight_line;
use crate::model::symbolic::{record, Arg, Expr, Fun, Graph, Id, Node};
use crate::multibody::dynamics::Model;
use num_dual::Dual;

/// [`fingerprint`] of the model and of the coordinate order: the generated terms are in
/// the coordinates' order, so a reordered declaration must not run them either.
pub fn closed_fingerprint(model: &Model, order: &[usize]) -> u64 {
    let mut hash = fingerprint(model);
    for &i in order {
        for b in (i as u64).to_le_bytes() {
            hash = (hash ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }
    hash
}

/// The traced terms (graph node ids), coordinate order, row-major.
struct Traced {
    graph: Graph,
    sc: Vec<Id>,
    m_inv: Vec<Id>,
    g: Vec<Id>,
    y: Vec<Id>,
    s: Vec<Id>,
    springs: Vec<Id>,
    bias: Vec<Id>,
    gamma: Vec<Id>,
}

/// `roots` rebuilt with `sin q_k` and `cos q_k` read from the leaves `P[2k]`, `P[2k + 1]`.
fn sin_cos_as_leaves(roots: &[Expr]) -> Vec<Expr> {
    super::rebuild(roots, &|node| match node {
        Node::Fun(f @ (Fun::Sin | Fun::Cos), a) => match Expr::from_id(a).node() {
            Node::Input(Arg::Q, k) => Some(Expr::input(
                Arg::P,
                2 * k as usize + (f == Fun::Cos) as usize,
            )),
            _ => None,
        },
        _ => None,
    })
}

/// `∂V_springs/∂q_i` (model order) by a dual number along q_i.
fn spring_derivative(model: &Model, q: &[Expr], i: usize) -> Expr {
    if model.springs.is_empty() {
        return Expr::constant(0.0);
    }
    let mut qd: Vec<Dual<Expr>> = q.iter().map(|&v| Dual::from_re(v)).collect();
    qd[i].eps = Expr::constant(1.0);
    model.spring_energy(&qd).eps
}

fn trace(model: &Model, order: &[usize]) -> Traced {
    let (n, k) = (model.nq(), model.closure_residuals());
    assert_eq!(
        order.len(),
        n,
        "one coordinate per model joint (no mimic joints)"
    );
    let (t, graph) = record(|| {
        let q = Expr::inputs(Arg::Q, n);
        let qd = Expr::inputs(Arg::Qd, n);
        let mut qm = vec![Expr::constant(0.0); n];
        let mut qdm = vec![Expr::constant(0.0); n];
        for (c, &i) in order.iter().enumerate() {
            qm[i] = q[c];
            qdm[i] = qd[c];
        }
        let sc: Vec<Expr> = q
            .iter()
            .flat_map(|&x| [Expr::fun(Fun::Sin, x), Expr::fun(Fun::Cos, x)])
            .collect();
        // Position terms.
        let full = model.crba(&qm);
        let mut m: Vec<Vec<Expr>> = (0..n)
            .map(|r| (0..n).map(|c| full[order[r]][order[c]]).collect())
            .collect();
        let zero = vec![Expr::constant(0.0); n];
        let (mut phi, mut g_model, mut curv) = (
            vec![Expr::constant(0.0); k],
            vec![zero.clone(); k],
            vec![Expr::constant(0.0); k],
        );
        crate::multibody::closed::kinematics(model, &qm, &zero, &mut phi, &mut g_model, &mut curv);
        let g: Vec<Vec<Expr>> = g_model
            .iter()
            .map(|row| order.iter().map(|&i| row[i]).collect())
            .collect();
        let d_inv = ldl_factor(&mut m);
        let solve = |b: &[Expr]| {
            let mut x = b.to_vec();
            ldl_solve(&m, &d_inv, &mut x);
            x
        };
        let m_inv: Vec<Vec<Expr>> = (0..n)
            .map(|c| {
                let unit: Vec<Expr> = (0..n)
                    .map(|r| Expr::constant((r == c) as u8 as f64))
                    .collect();
                solve(&unit)
            })
            .collect();
        let y: Vec<Vec<Expr>> = g.iter().map(|row| solve(row)).collect();
        let dot = |a: &[Expr], b: &[Expr]| {
            a.iter()
                .zip(b)
                .fold(Expr::constant(0.0), |s, (&x, &y)| s + x * y)
        };
        let s: Vec<Expr> = (0..k * k)
            .map(|ij| {
                let (i, j) = (ij / k, ij % k);
                // Symmetric: the upper triangle's entry for both.
                let (i, j) = (i.min(j), i.max(j));
                dot(&g[i], &y[j])
            })
            .collect();
        let springs: Vec<Expr> = order
            .iter()
            .map(|&i| spring_derivative(model, &qm, i))
            .collect();
        // Velocity terms.
        let bias_model = model.rnea(&qm, &qdm, &zero);
        let bias: Vec<Expr> = order.iter().map(|&i| bias_model[i]).collect();
        let mut g_unused = vec![zero.clone(); k];
        let mut gamma = vec![Expr::constant(0.0); k];
        crate::multibody::closed::kinematics(model, &qm, &qdm, &mut phi, &mut g_unused, &mut gamma);
        let velocity = sin_cos_as_leaves(&[bias, gamma].concat());
        let ids = |v: &[Expr]| v.iter().map(|e| e.id()).collect::<Vec<Id>>();
        // M⁻¹ is symmetric: its columns are its rows.
        let m_inv: Vec<Expr> = (0..n * n).map(|rc| m_inv[rc % n][rc / n]).collect();
        (
            ids(&sc),
            ids(&m_inv),
            ids(&g.concat()),
            ids(&y.concat()),
            ids(&s),
            ids(&springs),
            ids(&velocity[..n]),
            ids(&velocity[n..]),
        )
    });
    assert!(
        graph.branches.is_empty(),
        "looked at values: {:?}",
        graph.branches
    );
    let (sc, m_inv, g, y, s, springs, bias, gamma) = t;
    Traced {
        graph,
        sc,
        m_inv,
        g,
        y,
        s,
        springs,
        bias,
        gamma,
    }
}

/// `[[a, b, …], …]`: `items` in rows of `width` (one row: `[a, b, …]` when `width` is
/// the whole).
fn array(items: &[String], width: usize) -> String {
    let rows: Vec<String> = items
        .chunks(width)
        .map(|r| format!("[{}]", r.join(", ")))
        .collect();
    if width == items.len() {
        rows.concat()
    } else {
        format!("[{}]", rows.join(", "))
    }
}

/// The statements computing `roots`, leaves named by `inputs` (`(name, leaf)`); each root's
/// expression after them.
fn body(graph: &Graph, roots: &[Id], inputs: &[(&str, Arg)]) -> (String, Vec<String>, usize) {
    let leaf = |arg: Arg| {
        inputs
            .iter()
            .find(|(_, a)| *a == arg)
            .map_or_else(|| format!("{arg:?}"), |(n, _)| n.to_string())
    };
    let st = straight_line(graph, roots, &leaf);
    (st.body, st.roots, st.operations)
}

/// `Σ_j a[{row}][j] * x[j]` over the `nonzero` j (`S::zero()` for none).
fn sparse_dot(a: &str, row: usize, x: &str, nonzero: impl Iterator<Item = usize>) -> String {
    let terms: Vec<String> = nonzero
        .map(|j| format!("{a}[{row}][{j}] * {x}[{j}]"))
        .collect();
    if terms.is_empty() {
        "S::zero()".into()
    } else {
        terms.join(" + ")
    }
}

/// The generated module of a mechanism with loop closures (fixed base, no mimic joints):
/// `model` and its coordinate `order` (`order[c]` is coordinate c's model index), named
/// `name` in its header; the library named `krate`. Its `FINGERPRINT` is
/// [`closed_fingerprint`]; `Code` implements
/// [`closed::Code`](crate::multibody::closed::Code): `position` and `velocity` as the
/// module notes say, the products over the traced terms' structural nonzeros.
pub fn generate(model: &Model, order: &[usize], name: &str, krate: &str) -> String {
    let (n, k) = (model.nq(), model.closure_residuals());
    let t = trace(model, order);
    let zero =
        |id: Id| matches!(t.graph.node(id), Node::Const(bits) if f64::from_bits(bits) == 0.0);
    let position_roots: Vec<Id> = [&t.sc, &t.m_inv, &t.g, &t.y, &t.s, &t.springs]
        .into_iter()
        .flatten()
        .copied()
        .collect();
    let (pos_body, pos_roots, pos_ops) = body(&t.graph, &position_roots, &[("q", Arg::Q)]);
    let mut at = 0;
    let mut take = |len: usize, width: usize| {
        let a = array(&pos_roots[at..at + len], width);
        at += len;
        a
    };
    let terms = format!(
        "Terms::new(\n            {},\n            {},\n            {},\n            {},\n            {},\n            {},\n        )",
        take(2 * n, 2),
        take(n * n, n),
        take(k * n, n),
        take(k * n, n),
        take(k * k, k),
        take(n, n),
    );
    let velocity_roots: Vec<Id> = t.bias.iter().chain(&t.gamma).copied().collect();
    let (vel_body, vel_roots, vel_ops) = body(
        &t.graph,
        &velocity_roots,
        &[("q", Arg::Q), ("scf", Arg::P), ("qd", Arg::Qd)],
    );
    let uses_q = vel_body.contains("q[") || vel_roots.iter().any(|r| r.contains("q["));
    let g_rows: Vec<String> = (0..k)
        .map(|i| sparse_dot("g", i, "x", (0..n).filter(|&j| !zero(t.g[i * n + j]))))
        .collect();
    let y_cols: String = (0..n)
        .filter_map(|j| {
            let terms: Vec<String> = (0..k)
                .filter(|&i| !zero(t.y[i * n + j]))
                .map(|i| format!("y[{i}][{j}] * r[{i}]"))
                .collect();
            (!terms.is_empty()).then(|| format!("        x[{j}] += {};\n", terms.join(" + ")))
        })
        .collect();
    let m_rows: Vec<String> = (0..n)
        .map(|i| {
            sparse_dot(
                "m_inv",
                i,
                "f",
                (0..n).filter(|&j| !zero(t.m_inv[i * n + j])),
            )
        })
        .collect();
    let joints: Vec<&str> = order.iter().map(|&i| model.joints[i].as_str()).collect();
    format!(
        "//! Generated by `mbfmu::multibody::codegen::loops` from `{name}` ({n} coordinates: {joints};\n\
         //! {k} closure residuals): do not edit; a test checks it is current\n\
         //! (`MBFMU_REGENERATE=1 cargo test --release --lib generated_closed_terms` rewrites it).\n\
         //!\n\
         //! `position`: {pos_ops} operations; `velocity`: {vel_ops} operations.\n\n\
         use {krate}::model::Scalar;\n\
         use {krate}::multibody::closed::{{self, Terms}};\n\n\
         /// [`closed_fingerprint`]({krate}::multibody::codegen::loops::closed_fingerprint) of the\n\
         /// model and coordinate order this code was generated from.\n\
         pub const FINGERPRINT: u64 = {fp:#018x};\n\
         /// Coordinates and closure residuals.\n\
         pub const N: usize = {n};\n\
         pub const K: usize = {k};\n\n\
         /// The terms and products of [`closed::Code`].\n\
         pub struct Code;\n\n\
         impl closed::Code<{n}, {k}> for Code {{\n\
         \x20   /// From q: sin and cos of each coordinate (what `velocity` reads), M⁻¹, G,\n\
         \x20   /// (M⁻¹ Gᵀ)ᵀ, G M⁻¹ Gᵀ, ∂V_springs/∂q; coordinate order.\n\
         \x20   fn position<S: Scalar>(q: &[S]) -> Terms<S, {n}, {k}> {{\n\
         \x20       let q = &q[..{n}];\n\
         {pos_body}        {terms}\n\
         \x20   }}\n\n\
         \x20   /// From q, sin and cos of q, and q̇: RNEA(q, q̇, 0) (Coriolis and centrifugal\n\
         \x20   /// forces, gravity; not the damping) and Ġ q̇.\n\
         \x20   fn velocity<S: Scalar>({q}: &[S], sc: &[[S; 2]; {n}], qd: &[S; {n}]) -> ([S; {n}], [S; {k}]) {{\n\
         \x20       let scf = sc.as_flattened();\n\
         {vel_body}        ({bias}, {gamma})\n\
         \x20   }}\n\n\
         \x20   fn g_times<S: Scalar>(g: &[[S; {n}]; {k}], x: &[S; {n}]) -> [S; {k}] {{\n\
         \x20       [{g_rows}]\n\
         \x20   }}\n\n\
         \x20   fn add_y_t_times<S: Scalar>(y: &[[S; {n}]; {k}], r: &[S; {k}], x: &mut [S; {n}]) {{\n\
         {y_cols}\x20   }}\n\n\
         \x20   fn m_inv_times<S: Scalar>(m_inv: &[[S; {n}]; {n}], f: &[S; {n}]) -> [S; {n}] {{\n\
         \x20       [{m_rows}]\n\
         \x20   }}\n\
         }}\n",
        joints = joints.join(", "),
        fp = closed_fingerprint(model, order),
        q = if uses_q { "q" } else { "_q" },
        bias = array(&vel_roots[..n], n),
        gamma = array(&vel_roots[n..], k),
        g_rows = g_rows.join(", "),
        m_rows = m_rows.join(", "),
    )
}
