//! Symbolic differentiation on the graph: forward (directional derivatives) and reverse
//! (gradients) sweeps whose results are new, hash-consed nodes of the same graph.
//!
//! Both walk only the nodes reachable from their roots, in index order (a topological
//! order, see [`expr`](super::expr)), and carry "structurally zero" as `None`, so a
//! derivative never builds nodes for the parts of the graph that do not depend on the
//! seeded leaves. Each rule is the textbook one written with the node's own value `z`
//! where that saves work (`d√a = da / 2z`, `d(a/b) = (da − z db) / b`).
//!
//! Why both modes: the equations of motion need the gradient `∂L/∂(q, q̇)` (one reverse
//! sweep shares every adjoint between the 2n components) and then derivatives *of* the
//! momenta along a direction (`∂p/∂q̇ⱼ` for the columns of M, `(∂p/∂q) q̇` for the mixed
//! term), which are forward sweeps over the momentum graph.

use super::expr::{with_graph, Arg, Expr, Fun, Id, Node};
use num_dual::DualNum;

fn zero() -> Expr {
    Expr::constant(0.0)
}

fn plus(a: Option<Expr>, b: Option<Expr>) -> Option<Expr> {
    match (a, b) {
        (Some(a), Some(b)) => Some(a + b),
        (a, None) => a,
        (None, b) => b,
    }
}

/// The derivative of `f` at `a` (value `z = f(a)`), as a factor to multiply by, or a divisor.
enum Factor {
    Times(Expr),
    Over(Expr),
    Zero,
}

fn factor(f: Fun, a: Expr, z: Expr) -> Factor {
    let one = || Expr::constant(1.0);
    match f {
        Fun::Recip => Factor::Times(-(z * z)),
        Fun::Sqrt => Factor::Over(z * 2.0),
        Fun::Cbrt => Factor::Over(z * z * 3.0),
        Fun::Exp => Factor::Times(z),
        Fun::Ln => Factor::Over(a),
        Fun::Sin => Factor::Times(a.cos()),
        Fun::Cos => Factor::Times(-a.sin()),
        Fun::Tan => Factor::Times(one() + z * z),
        Fun::Asin => Factor::Over((one() - a * a).sqrt()),
        Fun::Acos => Factor::Over(-(one() - a * a).sqrt()),
        Fun::Atan => Factor::Over(one() + a * a),
        Fun::Sinh => Factor::Times(a.cosh()),
        Fun::Cosh => Factor::Times(a.sinh()),
        Fun::Tanh => Factor::Times(one() - z * z),
        Fun::Abs => Factor::Times(Expr::fun(Fun::Signum, a)),
        Fun::Signum => Factor::Zero,
    }
}

fn apply(factor: &Factor, t: Expr) -> Option<Expr> {
    match *factor {
        Factor::Times(f) => Some(t * f),
        Factor::Over(f) => Some(t / f),
        Factor::Zero => None,
    }
}

/// The nodes reachable from `roots`, and one past the highest of them.
fn reach(roots: &[Expr]) -> (Vec<bool>, usize) {
    let ids: Vec<Id> = roots.iter().map(|r| r.id()).collect();
    let top = ids.iter().map(|&i| i as usize + 1).max().unwrap_or(0);
    (with_graph(|g| g.reachable(&ids)), top)
}

/// The directional derivatives of `roots` for the leaf tangents `seed(arg, i)` (`None`:
/// zero), one forward sweep.
pub fn forward(roots: &[Expr], seed: impl Fn(Arg, usize) -> Option<Expr>) -> Vec<Expr> {
    let (seen, top) = reach(roots);
    let mut tangent: Vec<Option<Expr>> = vec![None; top];
    for id in 0..top {
        if !seen[id] {
            continue;
        }
        let z = Expr::from_id(id as Id);
        let t = |i: Id| tangent[i as usize];
        let e = Expr::from_id;
        tangent[id] = match z.node() {
            Node::Const(_) => None,
            Node::Input(arg, i) => seed(arg, i as usize),
            Node::Neg(a) => t(a).map(|ta| -ta),
            Node::Add(a, b) => plus(t(a), t(b)),
            Node::Sub(a, b) => plus(t(a), t(b).map(|tb| -tb)),
            Node::Mul(a, b) => plus(t(a).map(|ta| ta * e(b)), t(b).map(|tb| e(a) * tb)),
            // (ta − z tb) / b
            Node::Div(a, b) => {
                plus(t(a), t(b).map(|tb| -(z * tb))).map(|numerator| numerator / e(b))
            }
            Node::Fun(f, a) => t(a).and_then(|ta| apply(&factor(f, e(a), z), ta)),
            Node::Powi(a, n) => t(a).map(|ta| ta * (Expr::int_power(e(a), n - 1) * f64::from(n))),
            Node::Powf(a, n) => {
                let n = f64::from_bits(n);
                t(a).map(|ta| ta * (Expr::real_power(e(a), n - 1.0) * n))
            }
            // (x ty − y tx) / (x² + y²)
            Node::Atan2(y, x) => {
                let (y, x) = (e(y), e(x));
                let numerator = plus(t(y.id()).map(|ty| x * ty), t(x.id()).map(|tx| -(y * tx)));
                numerator.map(|num| num / (x * x + y * y))
            }
        };
    }
    roots
        .iter()
        .map(|r| tangent[r.id() as usize].unwrap_or_else(zero))
        .collect()
}

/// The gradient of `root` with respect to the leaves `wrt`, one reverse sweep.
pub fn gradient(root: Expr, wrt: &[Expr]) -> Vec<Expr> {
    let (seen, top) = reach(&[root]);
    let mut adjoint: Vec<Option<Expr>> = vec![None; top];
    adjoint[root.id() as usize] = Some(Expr::constant(1.0));
    let e = Expr::from_id;
    for id in (0..top).rev() {
        let Some(w) = adjoint[id].filter(|_| seen[id]) else {
            continue;
        };
        let z = e(id as Id);
        let mut add = |i: Id, v: Option<Expr>| {
            let slot = &mut adjoint[i as usize];
            *slot = plus(*slot, v);
        };
        match z.node() {
            Node::Const(_) | Node::Input(..) => {}
            Node::Neg(a) => add(a, Some(-w)),
            Node::Add(a, b) => {
                add(a, Some(w));
                add(b, Some(w));
            }
            Node::Sub(a, b) => {
                add(a, Some(w));
                add(b, Some(-w));
            }
            Node::Mul(a, b) => {
                add(a, Some(w * e(b)));
                add(b, Some(e(a) * w));
            }
            // ∂/∂a = 1/b, ∂/∂b = −z/b: one division shared.
            Node::Div(a, b) => {
                let v = w / e(b);
                add(a, Some(v));
                add(b, Some(-(v * z)));
            }
            Node::Fun(f, a) => add(a, apply(&factor(f, e(a), z), w)),
            Node::Powi(a, n) => add(a, Some(w * (Expr::int_power(e(a), n - 1) * f64::from(n)))),
            Node::Powf(a, n) => {
                let n = f64::from_bits(n);
                add(a, Some(w * (Expr::real_power(e(a), n - 1.0) * n)));
            }
            Node::Atan2(y, x) => {
                let v = w / (e(x) * e(x) + e(y) * e(y));
                add(y, Some(v * e(x)));
                add(x, Some(-(v * e(y))));
            }
        }
    }
    wrt.iter()
        .map(|l| {
            adjoint
                .get(l.id() as usize)
                .copied()
                .flatten()
                .unwrap_or_else(zero)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::expr::record;
    use super::*;
    use num_dual::Dual64;

    /// A function using every rule, at a point where all are defined.
    fn f<S: crate::model::Scalar>(x: S, y: S) -> S {
        let a = x.sin() * y.cos() + (x * y).sqrt() / y.exp() - x.ln().powi(3);
        let b = y.atan2(x) + x.tan().recip() - (x * 0.3).asin() + (y * 0.2).acos();
        let c = x.atan() * y.tanh() + x.sinh() / y.cosh() + x.powf(1.7) * y.cbrt() - (-x).abs();
        a * b - c / (x + y)
    }

    #[test]
    fn forward_and_reverse_agree_with_dual_numbers() {
        let (x0, y0) = (0.7, 1.3);
        let ((fx, fy, rx, ry), g) = record(|| {
            let (x, y) = (Expr::input(Arg::Q, 0), Expr::input(Arg::Q, 1));
            let z = f(x, y);
            let fx = forward(&[z], |_, i| (i == 0).then(|| Expr::constant(1.0)))[0];
            let fy = forward(&[z], |_, i| (i == 1).then(|| Expr::constant(1.0)))[0];
            let r = gradient(z, &[x, y]);
            (fx.id(), fy.id(), r[0].id(), r[1].id())
        });
        assert!(g.branches.is_empty(), "{:?}", g.branches);
        let v = g.eval(&[fx, fy, rx, ry], [&[x0, y0], &[], &[], &[], &[]]);
        let dx = f(Dual64::new(x0, 1.0), Dual64::from(y0)).eps;
        let dy = f(Dual64::from(x0), Dual64::new(y0, 1.0)).eps;
        for (got, want) in [(v[0], dx), (v[1], dy), (v[2], dx), (v[3], dy)] {
            assert!((got - want).abs() <= 1e-14 * want.abs(), "{got} vs {want}");
        }
    }

    #[test]
    fn derivatives_of_what_does_not_depend_on_the_seed_build_nothing() {
        record(|| {
            let (x, y) = (Expr::input(Arg::Q, 0), Expr::input(Arg::Qd, 0));
            let z = x.sin() * x.cos();
            let before = with_graph(|g| g.len());
            let d = forward(&[z], |arg, _| (arg == Arg::Qd).then(|| Expr::constant(1.0)));
            assert_eq!(d[0].as_const(), Some(0.0));
            assert!(with_graph(|g| g.len()) <= before + 1, "only the constant 0");
            // Reverse mode builds every adjoint of the sweep, but still no gradient for y.
            assert_eq!(gradient(z, &[y])[0].as_const(), Some(0.0));
        });
    }
}
