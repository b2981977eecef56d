//! T and V as the FMU computes them: a Lagrangian's energies traced into an expression
//! graph ([`symbolic::record`](crate::model::symbolic::record)) and typeset as MathML, so
//! the page shows the code itself and cannot go stale when the model changes. Products are
//! flattened with their numbers in front and repeated factors as powers, sums with their
//! signs; an expression too long to read (the bicycle's) is left out, the page says so.

use super::mathml::{identifier, superscript};
use super::written;
use crate::model::symbolic::{Arg, Fun, Graph, Id, Node};

/// Leaves of an expanded expression beyond which it is not typeset.
const MAX_LEAVES: usize = 60;

/// `<math>` of `lhs = root` (`root` in `graph`); `name(arg, i)` is the identifier text of
/// a leaf (as the equation lines write it: `θ̇1`, `m`, `I_O`). `None` when the expression
/// is too long to read.
pub fn equation(
    lhs: &str,
    graph: &Graph,
    root: Id,
    name: &dyn Fn(Arg, u32) -> String,
) -> Option<String> {
    if leaves(graph, root, MAX_LEAVES + 1) > MAX_LEAVES {
        return None;
    }
    let r = Render { graph, name };
    Some(format!(
        "<math>{}<mo>=</mo>{}</math>",
        identifier(lhs),
        r.sum(root)
    ))
}

/// Leaves of the expanded tree of `id`, counted up to `cap`.
fn leaves(graph: &Graph, id: Id, cap: usize) -> usize {
    let (ops, k) = graph.node(id).operands();
    if k == 0 {
        return 1;
    }
    let mut n = 0;
    for &o in &ops[..k] {
        n += leaves(graph, o, cap - n.min(cap));
        if n >= cap {
            return n;
        }
    }
    n
}

struct Render<'a> {
    graph: &'a Graph,
    name: &'a dyn Fn(Arg, u32) -> String,
}

fn constant(graph: &Graph, id: Id) -> Option<f64> {
    match graph.node(id) {
        Node::Const(bits) => Some(f64::from_bits(bits)),
        _ => None,
    }
}

fn number(v: f64) -> String {
    if v == 0.5 {
        return "<mfrac><mn>1</mn><mn>2</mn></mfrac>".into();
    }
    if v == 0.25 {
        return "<mfrac><mn>1</mn><mn>4</mn></mfrac>".into();
    }
    format!("<mn>{}</mn>", written(v))
}

impl Render<'_> {
    /// The terms of a sum, each with its sign (`true`: subtracted).
    fn terms(&self, id: Id, neg: bool, out: &mut Vec<(bool, Id)>) {
        match self.graph.node(id) {
            Node::Add(a, b) => {
                self.terms(a, neg, out);
                self.terms(b, neg, out);
            }
            Node::Sub(a, b) => {
                self.terms(a, neg, out);
                self.terms(b, !neg, out);
            }
            Node::Neg(a) => self.terms(a, !neg, out),
            _ => out.push((neg, id)),
        }
    }

    /// The factors of a product: its number, and the other factors with their powers.
    fn factors(&self, id: Id, c: &mut f64, out: &mut Vec<(Id, i32)>) {
        match self.graph.node(id) {
            Node::Mul(a, b) => {
                self.factors(a, c, out);
                self.factors(b, c, out);
            }
            Node::Neg(a) => {
                *c = -*c;
                self.factors(a, c, out);
            }
            Node::Const(bits) => *c *= f64::from_bits(bits),
            Node::Powi(a, n) if constant(self.graph, a).is_none() => {
                match out.iter_mut().find(|(f, _)| *f == a) {
                    Some((_, p)) => *p += n,
                    None => out.push((a, n)),
                }
            }
            _ => match out.iter_mut().find(|(f, _)| *f == id) {
                Some((_, p)) => *p += 1,
                None => out.push((id, 1)),
            },
        }
    }

    fn sum(&self, id: Id) -> String {
        let mut terms = Vec::new();
        self.terms(id, false, &mut terms);
        let mut s = String::new();
        for (i, (neg, t)) in terms.iter().enumerate() {
            // A term's own leading minus (a negative number) joins its sign.
            let (mut c, mut fs) = (1.0, Vec::new());
            self.factors(*t, &mut c, &mut fs);
            let neg = *neg != (c < 0.0);
            if neg {
                s.push_str("<mo>−</mo>");
            } else if i > 0 {
                s.push_str("<mo>+</mo>");
            }
            s.push_str(&self.product(c.abs(), &fs));
        }
        if terms.len() > 1 {
            format!("<mrow>{s}</mrow>")
        } else {
            s
        }
    }

    fn product(&self, c: f64, factors: &[(Id, i32)]) -> String {
        // As one writes a term: parameters, time, coordinates, velocities, inputs, then the
        // rest (functions, sums), each group in the order of its declaration.
        let rank = |&(f, _): &(Id, i32)| match self.graph.node(f) {
            Node::Input(arg, i) => {
                let group = match arg {
                    Arg::P => 0,
                    Arg::T => 1,
                    Arg::Q => 2,
                    Arg::Qd => 3,
                    Arg::U => 4,
                };
                (group, i)
            }
            _ => (5, 0),
        };
        let mut factors = factors.to_vec();
        factors.sort_by_key(rank);
        let mut s = String::new();
        if c != 1.0 || factors.is_empty() {
            s.push_str(&number(c));
        }
        for (f, p) in factors {
            let base = self.atom(f);
            s.push_str(&match p {
                1 => base,
                p => superscript(&base, &format!("<mn>{p}</mn>")),
            });
        }
        format!("<mrow>{s}</mrow>")
    }

    /// `id` as a factor: parenthesised unless it is a leaf, a function or a fraction.
    fn atom(&self, id: Id) -> String {
        match self.graph.node(id) {
            Node::Input(arg, i) => identifier(&(self.name)(arg, i)),
            Node::Const(bits) => number(f64::from_bits(bits)),
            Node::Fun(f, a) => self.function(f, a),
            Node::Div(a, b) => format!("<mfrac>{}{}</mfrac>", self.sum(a), self.sum(b)),
            Node::Powi(a, n) => superscript(&self.atom(a), &format!("<mn>{n}</mn>")),
            Node::Powf(a, bits) => superscript(&self.atom(a), &number(f64::from_bits(bits))),
            Node::Mul(..) => self.sum(id),
            _ => format!("<mrow><mo>(</mo>{}<mo>)</mo></mrow>", self.sum(id)),
        }
    }

    fn function(&self, f: Fun, a: Id) -> String {
        // A function of a function is written with parentheses, sin(arcsin x), not
        // sin arcsin x.
        let arg = match self.graph.node(a) {
            Node::Fun(g, _) if !matches!(g, Fun::Sqrt | Fun::Recip | Fun::Abs) => {
                format!("<mrow><mo>(</mo>{}<mo>)</mo></mrow>", self.atom(a))
            }
            _ => self.atom(a),
        };
        match f {
            Fun::Sqrt => format!("<msqrt>{}</msqrt>", self.sum(a)),
            Fun::Recip => format!("<mfrac><mn>1</mn>{}</mfrac>", self.sum(a)),
            Fun::Abs => format!("<mrow><mo>|</mo>{}<mo>|</mo></mrow>", self.sum(a)),
            f => format!(
                "<mrow><mi>{}</mi><mo>&#x2061;</mo>{arg}</mrow>",
                match f {
                    Fun::Ln => "ln",
                    Fun::Asin => "arcsin",
                    Fun::Acos => "arccos",
                    Fun::Atan => "arctan",
                    f => f.method(),
                }
            ),
        }
    }
}

/// A variable name as the equation lines write it: `theta1` → `θ1`, `I_O` stays.
pub fn greek(name: &str) -> String {
    const LETTERS: &[(&str, &str)] = &[
        ("alpha", "α"),
        ("beta", "β"),
        ("gamma", "γ"),
        ("delta", "δ"),
        ("epsilon", "ε"),
        ("zeta", "ζ"),
        ("theta", "θ"),
        ("lambda", "λ"),
        ("phi", "φ"),
        ("psi", "ψ"),
        ("Omega", "Ω"),
        ("omega", "ω"),
        ("rho", "ρ"),
        ("tau", "τ"),
    ];
    for (word, letter) in LETTERS {
        if let Some(rest) = name.strip_prefix(word) {
            if rest.is_empty() || rest.starts_with(|c: char| c.is_ascii_digit() || c == '_') {
                return format!("{letter}{rest}");
            }
        }
    }
    name.to_string()
}

/// `name` with a dot over its letter (a velocity): `θ1` → `θ̇1`, `x` → `ẋ`.
pub fn dotted(name: &str) -> String {
    let mut chars = name.chars();
    match chars.next() {
        Some(first) => format!("{first}\u{0307}{}", chars.as_str()),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::symbolic::{record, Expr};
    use num_dual::DualNum;

    /// SliderCrank's V holds sin(asin(l₁ sin θ / l₂)): the inner function is parenthesised
    /// and named as people write it (its page read "sin asin").
    #[test]
    fn a_function_of_a_function_has_parentheses() {
        let (root, graph) = record(|| Expr::input(Arg::Q, 0).asin().sin().id());
        let name = |_: Arg, _: u32| "x".to_string();
        let math = equation("V", &graph, root, &name).unwrap();
        assert!(math.contains("<mi>arcsin</mi>"), "{math}");
        assert!(
            math.contains("<mo>&#x2061;</mo><mrow><mo>(</mo><mrow><mi>arcsin</mi>"),
            "{math}"
        );
    }
}
