//! Rust source for [`Equations`]: one `impl Eom<N, K>` whose `eom` is straight-line code
//! generic over the scalar, so `f64` runs it fast and dual numbers still differentiate it.
//!
//! Every node the roots reach is computed once. A node gets its own `let` when it is used
//! more than once, when it is an elementary function (worth naming: the expensive part), or
//! when its expression would be long; otherwise it is written inline into its single user.
//! `sin x` and `cos x` of the same x become one `sin_cos()`. Constants are `f64` literals on
//! the right of an operator (`v * 0.5`, which every `Scalar` supports) or `S::from(c)` where
//! a scalar is needed. Operands keep the graph's association: `a * (b * c)` stays
//! parenthesised, so the code rounds exactly as the graph interpreter does.

use super::equations::Equations;
use super::expr::{Arg, Fun, Graph, Id, Node};
use std::fmt::Write as _;

/// A single-use expression longer than this gets a `let` anyway (readability).
const INLINE_MAX: usize = 60;

/// The generated source and its size.
pub struct Emitted {
    pub source: String,
    /// Nodes the code evaluates (leaves and constants included) and operations among them.
    pub nodes: usize,
    pub operations: usize,
    /// `let` statements and source lines.
    pub lets: usize,
    pub lines: usize,
}

/// Binding strength of an expression's outermost operator.
#[derive(Clone, Copy, PartialEq, PartialOrd)]
enum Prec {
    Sum,
    Product,
    Unary,
    Atom,
}

#[derive(Clone)]
struct Text {
    code: String,
    prec: Prec,
    /// A literal constant: valid as the right operand of an operator with a scalar.
    literal: Option<f64>,
}

impl Text {
    fn atom(code: String) -> Text {
        Text {
            code,
            prec: Prec::Atom,
            literal: None,
        }
    }

    /// As an operand that must bind at least as tightly as `min`.
    fn at(&self, min: Prec) -> String {
        if self.prec >= min {
            self.code.clone()
        } else {
            format!("({})", self.code)
        }
    }

    /// As a scalar-typed operand (a literal becomes `S::from(c)`).
    fn scalar(&self, min: Prec) -> String {
        match self.literal {
            Some(c) => format!("S::from({})", literal(c)),
            None => self.at(min),
        }
    }
}

fn literal(c: f64) -> String {
    if c.is_nan() {
        "f64::NAN".into()
    } else if c.is_infinite() {
        if c > 0.0 {
            "f64::INFINITY"
        } else {
            "f64::NEG_INFINITY"
        }
        .into()
    } else {
        format!("{c:?}")
    }
}

fn arg_name(arg: Arg) -> &'static str {
    match arg {
        Arg::Q => "q",
        Arg::Qd => "qd",
        Arg::U => "u",
        Arg::P => "p",
        Arg::T => "t",
    }
}

/// `a op b` with the operand rules of the module notes: a literal may only stand on the
/// right (`x * 0.5`); on the left it becomes `S::from(c)`.
fn binary(a: &Text, op: &str, b: &Text, prec: Prec) -> Text {
    let right_min = match prec {
        Prec::Sum => Prec::Product,
        _ => Prec::Unary,
    };
    // A literal, even negative, is a valid right operand: `x * -0.5`.
    let rhs = match b.literal {
        Some(c) => literal(c),
        None => b.at(right_min),
    };
    Text {
        code: format!("{} {op} {rhs}", a.scalar(prec)),
        prec,
        literal: None,
    }
}

/// Straight-line Rust statements (8-space indented `let`s) computing the nodes of a graph
/// that some roots reach, each once (see the module notes), and how each root then reads.
pub struct Straight {
    /// The `let` statements, one a line.
    pub body: String,
    /// For each root, an expression of the scalar type (a name, a short expression or
    /// `S::from(c)`), valid after `body`.
    pub roots: Vec<String>,
    /// Which argument vectors ([`Arg`] order) the code reads.
    pub used_args: [bool; 5],
    /// Nodes the code evaluates (leaves and constants included) and operations among them.
    pub nodes: usize,
    pub operations: usize,
    pub lets: usize,
}

/// The statements computing `roots` of `graph`, reading leaf `Input(arg, k)` as
/// `{name(arg)}[k]`: the general entry point ([`emit`] uses it for [`Equations`]).
pub fn straight_line(graph: &Graph, roots: &[Id], name: &dyn Fn(Arg) -> String) -> Straight {
    let seen = graph.reachable(roots);
    let mut uses = vec![0usize; graph.len()];
    for (i, _) in seen.iter().enumerate().filter(|(_, &s)| s) {
        let (ops, k) = graph.node(i as Id).operands();
        for &o in &ops[..k] {
            uses[o as usize] += 1;
        }
    }
    for &r in roots {
        uses[r as usize] += 1;
    }
    // sin x and cos x of the same x, for one sin_cos().
    let mut partner = std::collections::HashMap::new();
    for (i, _) in seen.iter().enumerate().filter(|(_, &s)| s) {
        if let Node::Fun(f @ (Fun::Sin | Fun::Cos), a) = graph.node(i as Id) {
            partner.entry(a).or_insert([None, None])[(f == Fun::Cos) as usize] = Some(i as Id);
        }
    }

    let mut used_args = [false; 5];
    let mut text: Vec<Option<Text>> = vec![None; graph.len()];
    let mut body = String::new();
    let (mut nodes, mut operations, mut lets) = (0, 0, 0);
    for i in 0..graph.len() {
        if !seen[i] || text[i].is_some() {
            continue;
        }
        nodes += 1;
        let node = graph.node(i as Id);
        let t = |id: Id| text[id as usize].clone().expect("operands come first");
        let expr = match node {
            Node::Const(bits) => {
                let c = f64::from_bits(bits);
                text[i] = Some(Text {
                    code: literal(c),
                    prec: if c < 0.0 { Prec::Unary } else { Prec::Atom },
                    literal: Some(c),
                });
                continue;
            }
            Node::Input(arg, k) => {
                used_args[arg as usize] = true;
                text[i] = Some(Text::atom(format!("{}[{k}]", name(arg))));
                continue;
            }
            Node::Neg(a) => Text {
                code: format!("-{}", t(a).scalar(Prec::Unary)),
                prec: Prec::Unary,
                literal: None,
            },
            Node::Add(a, b) => binary(&t(a), "+", &t(b), Prec::Sum),
            Node::Sub(a, b) => binary(&t(a), "-", &t(b), Prec::Sum),
            Node::Mul(a, b) => binary(&t(a), "*", &t(b), Prec::Product),
            Node::Div(a, b) => binary(&t(a), "/", &t(b), Prec::Product),
            Node::Fun(f, a) => {
                if let Some(&[Some(s), Some(c)]) = partner.get(&a) {
                    // Both halves at once, at the first of the two.
                    let (vs, vc) = (format!("s{lets}"), format!("c{lets}"));
                    lets += 1;
                    nodes += 1;
                    operations += 2;
                    writeln!(
                        body,
                        "        let ({vs}, {vc}) = {}.sin_cos();",
                        t(a).scalar(Prec::Atom)
                    )
                    .unwrap();
                    text[s as usize] = Some(Text::atom(vs));
                    text[c as usize] = Some(Text::atom(vc));
                    continue;
                }
                Text::atom(format!("{}.{}()", t(a).scalar(Prec::Atom), f.method()))
            }
            Node::Powi(a, n) => Text::atom(format!("{}.powi({n})", t(a).scalar(Prec::Atom))),
            Node::Powf(a, n) => Text::atom(format!(
                "{}.powf({})",
                t(a).scalar(Prec::Atom),
                literal(f64::from_bits(n))
            )),
            Node::Atan2(y, x) => Text::atom(format!(
                "{}.atan2({})",
                t(y).scalar(Prec::Atom),
                t(x).scalar(Prec::Sum)
            )),
        };
        operations += 1;
        let named = uses[i] > 1
            || matches!(
                node,
                Node::Fun(..) | Node::Powi(..) | Node::Powf(..) | Node::Atan2(..)
            )
            || expr.code.len() > INLINE_MAX;
        text[i] = Some(if named {
            let v = format!("v{lets}");
            lets += 1;
            writeln!(body, "        let {v} = {};", expr.code).unwrap();
            Text::atom(v)
        } else {
            expr
        });
    }

    let roots = roots
        .iter()
        .map(|&id| {
            text[id as usize]
                .as_ref()
                .expect("roots are reached")
                .scalar(Prec::Sum)
        })
        .collect();
    Straight {
        body,
        roots,
        used_args,
        nodes,
        operations,
        lets,
    }
}

/// The Rust source of `eq` as `impl Eom<n, k> for {type_name}`, with `doc` as the file's
/// first doc lines. `krate` is how the code names this library: `crate` inside it,
/// `mbfmu` from a test or another crate.
pub fn emit(eq: &Equations, type_name: &str, doc: &str, krate: &str) -> Emitted {
    let all = eq.roots();
    let Straight {
        mut body,
        roots: root_text,
        used_args,
        nodes,
        operations,
        lets,
    } = straight_line(&eq.graph, &all, &|arg| arg_name(arg).to_string());
    let position: std::collections::HashMap<Id, usize> =
        all.iter().enumerate().map(|(k, &id)| (id, k)).collect();
    let root = |id: Id| root_text[position[&id]].clone();
    for i in 0..eq.n {
        for j in i..eq.n {
            writeln!(body, "        out.m[{i}][{j}] = {};", root(eq.m[i][j])).unwrap();
        }
    }
    for i in 0..eq.n {
        for j in 0..i {
            writeln!(body, "        out.m[{i}][{j}] = out.m[{j}][{i}];").unwrap();
        }
    }
    for (i, &r) in eq.rhs.iter().enumerate() {
        writeln!(body, "        out.rhs[{i}] = {};", root(r)).unwrap();
    }
    for (k, row) in eq.g.iter().enumerate() {
        for (j, &r) in row.iter().enumerate() {
            writeln!(body, "        out.g[{k}][{j}] = {};", root(r)).unwrap();
        }
    }
    for (k, &r) in eq.gamma.iter().enumerate() {
        writeln!(body, "        out.gamma[{k}] = {};", root(r)).unwrap();
    }

    let lens = [eq.n, eq.n, eq.inputs, eq.parameters, 1];
    let param = |arg: Arg| {
        let name = arg_name(arg);
        if used_args[arg as usize] {
            name.to_string()
        } else {
            format!("_{name}")
        }
    };
    let slices: Vec<String> = [Arg::Q, Arg::Qd, Arg::U, Arg::P, Arg::T]
        .into_iter()
        .filter(|&a| used_args[a as usize])
        .map(|a| match a {
            // The time is an f64 argument; the code reads it as the leaf t[0].
            Arg::T => "        let t = [S::from(t)];\n".to_string(),
            _ => {
                let name = arg_name(a);
                format!("        let {name} = &{name}[..{}];\n", lens[a as usize])
            }
        })
        .collect();
    let (n, k) = (eq.n, eq.k);
    let velocity = eq.k - eq.holonomic;
    let constraints = if velocity == 0 {
        format!("{k} constraints")
    } else {
        format!(
            "{} holonomic and {velocity} velocity constraints",
            eq.holonomic
        )
    };
    let mut source = String::new();
    for line in doc.lines() {
        writeln!(source, "//! {line}").unwrap();
    }
    write!(
        source,
        "//!
//! {nodes} nodes ({operations} operations) in {lets} `let`s.

use {krate}::model::symbolic::{{Eom, Generated, Terms}};
use {krate}::model::Scalar;

/// The equations of motion of `{name}` ({n} coordinates, {constraints}).
pub struct {type_name};

impl Generated for {type_name} {{
    const NAME: &'static str = \"{name}\";
    const NODES: usize = {nodes};
    const INPUTS: usize = {inputs};
}}

impl Eom<{n}, {k}> for {type_name} {{
    /// The slices' lengths are checked once, up front.
    fn eom<S: Scalar>(
        {t}: f64,
        {q}: &[S],
        {qd}: &[S],
        {u}: &[S],
        {p}: &[S],
        out: &mut Terms<S, {n}, {k}>,
    ) {{
{slices}{body}    }}
}}
",
        name = eq.name,
        constraints = constraints,
        inputs = eq.inputs,
        q = param(Arg::Q),
        qd = param(Arg::Qd),
        u = param(Arg::U),
        p = param(Arg::P),
        t = param(Arg::T),
        slices = slices.concat(),
    )
    .unwrap();
    let lines = source.lines().count();
    Emitted {
        source,
        nodes,
        operations,
        lets,
        lines,
    }
}
