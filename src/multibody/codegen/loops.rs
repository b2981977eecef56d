//! The straight-line terms of a mechanism with loop closures ([`super::super::closed`]),
//! for its right-hand side at tree speed: what depends on q alone (M⁻¹, G, `Y = M⁻¹ Gᵀ`,
//! the Schur complement `S = G M⁻¹ Gᵀ`, the springs' gradient) in one function, what
//! depends on q̇ too (the bias by RNEA at q̈ = 0 and the curvature `γ = Ġ q̇`) in another,
//! both traced with the symbolic scalar through the same algorithms the interpreted path
//! runs ([`Model::crba`], [`Model::rnea`], [`closed::kinematics`](super::super::closed::kinematics),
//! the springs' energy by dual numbers), in the mechanism's coordinate
//! order. Only the rank-revealing solve on S is left to run time
//! ([`closed::Terms`](super::super::closed::Terms)): its pivots depend on the values.
//!
//! Two functions, not one, because the velocity is taken onto `G q̇ = 0` between them
//! (with G and S of the first); the second reads the first's `sin qᵢ`, `cos qᵢ` (`sc`)
//! instead of computing them again (the trigonometry is most of a planar mechanism's
//! position terms).
//!
//! M⁻¹ is traced as a dense LDLᵀ of the traced M ([`ldl_factor`]): the tree's zeros are
//! exact constants there and fold away, so what is emitted is the tree's sparse solve.
//! No snapping: the code is the declared model's to rounding (tests: 1e-12 relative).

use super::{fingerprint, ldl_factor, ldl_solve};
use crate::model::symbolic::emit::straight_line;
use crate::model::symbolic::expr::with_graph;
use crate::model::symbolic::{record, Arg, Expr, Fun, Graph, Id, Node};
use crate::multibody::dynamics::Model;
use num_dual::Dual;
use std::fmt::Write as _;

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
        new[id] = Some(match z.node() {
            Node::Const(_) | Node::Input(..) => z,
            Node::Neg(a) => -e(a),
            Node::Add(a, b) => e(a) + e(b),
            Node::Sub(a, b) => e(a) - e(b),
            Node::Mul(a, b) => e(a) * e(b),
            Node::Div(a, b) => e(a) / e(b),
            Node::Fun(f @ (Fun::Sin | Fun::Cos), a) => match Expr::from_id(a).node() {
                Node::Input(Arg::Q, k) => {
                    Expr::input(Arg::P, 2 * k as usize + (f == Fun::Cos) as usize)
                }
                _ => Expr::fun(f, e(a)),
            },
            Node::Fun(f, a) => Expr::fun(f, e(a)),
            Node::Powi(a, k) => Expr::int_power(e(a), k),
            Node::Powf(a, k) => Expr::real_power(e(a), f64::from_bits(k)),
            Node::Atan2(y, x) => Expr::arctan2(e(y), e(x)),
        });
    }
    ids.iter()
        .map(|&i| new[i as usize].expect("reached"))
        .collect()
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

/// `pub fn {name}<S: Scalar>({inputs}, {outputs})`: the inputs `(name, leaf, length)`,
/// each output `&mut [S]` of its roots' length. Returns the source and its operations.
fn function(
    graph: &Graph,
    name: &str,
    doc: &str,
    inputs: &[(&str, Arg, usize)],
    outputs: &[(&str, &[Id])],
) -> (String, usize) {
    let roots: Vec<Id> = outputs
        .iter()
        .flat_map(|(_, r)| r.iter().copied())
        .collect();
    let leaf = |arg: Arg| {
        inputs
            .iter()
            .find(|(_, a, _)| *a == arg)
            .map_or_else(|| format!("{arg:?}"), |(n, _, _)| n.to_string())
    };
    let st = straight_line(graph, &roots, &leaf);
    let mut src = String::new();
    for line in doc.lines() {
        writeln!(src, "/// {line}").unwrap();
    }
    let params: Vec<String> = inputs
        .iter()
        .map(|(n, arg, _)| {
            let used = if st.used_args[*arg as usize] { "" } else { "_" };
            format!("{used}{n}: &[S]")
        })
        .chain(outputs.iter().map(|(o, _)| format!("{o}: &mut [S]")))
        .collect();
    writeln!(
        src,
        "#[allow(clippy::too_many_arguments)]\npub fn {name}<S: Scalar>({}) {{",
        params.join(", ")
    )
    .unwrap();
    for (n, arg, len) in inputs {
        if st.used_args[*arg as usize] {
            writeln!(src, "        let {n} = &{n}[..{len}];").unwrap();
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
    (src, st.operations)
}

/// The generated module of a mechanism with loop closures (fixed base, no mimic joints):
/// `model` and its coordinate `order` (`order[c]` is coordinate c's model index), named
/// `name` in its header; the library named `krate`. Its `FINGERPRINT` is
/// [`closed_fingerprint`]; `position` and `velocity` as the module notes say.
pub fn generate(model: &Model, order: &[usize], name: &str, krate: &str) -> String {
    let (n, k) = (model.nq(), model.closure_residuals());
    let t = trace(model, order);
    let (position, pos_ops) = function(
        &t.graph,
        "position",
        "From q: `sc` = (sin q_c, cos q_c) per coordinate (what [`velocity`] reads), `m_inv` = M⁻¹\n\
         (n × n), `g` = G (k × n), `y` = (M⁻¹ Gᵀ)ᵀ (k × n: row i is M⁻¹ gᵢ), `s` = G M⁻¹ Gᵀ\n\
         (k × k), `springs` = ∂V_springs/∂q; row-major, coordinate order.",
        &[("q", Arg::Q, n)],
        &[
            ("sc", &t.sc),
            ("m_inv", &t.m_inv),
            ("g", &t.g),
            ("y", &t.y),
            ("s", &t.s),
            ("springs", &t.springs),
        ],
    );
    let (velocity, vel_ops) = function(
        &t.graph,
        "velocity",
        "From q, [`position`]'s `sc` at that q, and q̇: `bias` = RNEA(q, q̇, 0) (Coriolis and\n\
         centrifugal forces, gravity; not the damping), `gamma` = Ġ q̇ (the closures'\n\
         curvature); coordinate order.",
        &[("q", Arg::Q, n), ("sc", Arg::P, 2 * n), ("qd", Arg::Qd, n)],
        &[("bias", &t.bias), ("gamma", &t.gamma)],
    );
    let joints: Vec<&str> = order.iter().map(|&i| model.joints[i].as_str()).collect();
    format!(
        "//! Generated by `mbfmu::multibody::codegen::loops` from `{name}` ({n} coordinates: {joints};\n\
         //! {k} closure residuals): do not edit; a test checks it is current\n\
         //! (`MBFMU_REGENERATE=1 cargo test --release --lib generated_closed_terms` rewrites it).\n\
         //!\n\
         //! `position`: {pos_ops} operations; `velocity`: {vel_ops} operations.\n\n\
         use {krate}::model::Scalar;\n\n\
         /// [`closed_fingerprint`]({krate}::multibody::codegen::loops::closed_fingerprint) of the\n\
         /// model and coordinate order this code was generated from.\n\
         pub const FINGERPRINT: u64 = {fp:#018x};\n\
         /// Coordinates and closure residuals.\n\
         pub const N: usize = {n};\n\
         pub const K: usize = {k};\n\n\
         {position}\n{velocity}",
        joints = joints.join(", "),
        fp = closed_fingerprint(model, order),
    )
}
