//! The expression graph and its handle [`Expr`].
//!
//! A recording ([`record`]) owns one [`Graph`]: an append-only arena of [`Node`]s in which
//! every node refers only to nodes created before it (so the index order is a topological
//! order) and no node exists twice (hash-consing: building `a * b` a second time returns the
//! first node, so equal subexpressions are shared without a separate CSE pass).
//!
//! [`Expr`] is a `Copy` index into the graph of the current thread's recording. It has to be
//! `Copy` and built by bare operators (`a * b`, `x.sin()`) because that is all
//! `Lagrangian::kinetic` and friends do with their scalar; there is no room for a context
//! argument, hence the thread-local. Constructors simplify as they go: constants fold,
//! `x + 0`, `x·1`, `x·0`, `−(−x)`, `x − x`, `x + x = 2x` disappear, negations move outwards
//! and the operands of `+` and `·` are put in a canonical order, so that the derivatives of
//! the next modules stay small.
//!
//! Values cannot be looked at: a comparison, `re()` or `is_zero()` on a non-constant `Expr`
//! has no faithful answer (the branch it feeds would be baked into the graph for whatever
//! answer was given). Such queries are recorded in [`Graph::branches`] and the code generator
//! refuses the model. The few operations with no symbolic form here (`%`, `sph_j0`, …)
//! panic with the operation's name.

use num_dual::{DualNum, DualStruct, Mappable};
use num_traits::{FromPrimitive, Inv, Num, One, Signed, Zero};
use std::cell::RefCell;
use std::collections::HashMap;
use std::fmt;
use std::iter::{Product, Sum};
use std::ops::{
    Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Rem, RemAssign, Sub, SubAssign,
};

/// The index of a node in its graph.
pub type Id = u32;

/// The argument vectors of the equations of motion an input leaf belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Arg {
    /// Coordinates q.
    Q,
    /// Velocities q̇.
    Qd,
    /// Inputs u.
    U,
    /// Parameters p.
    P,
    /// The time t (one leaf): rheonomic systems' T, V and constraints depend on it.
    T,
}

/// Elementary functions of one argument.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Fun {
    Recip,
    Sqrt,
    Cbrt,
    Exp,
    Ln,
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Sinh,
    Cosh,
    Tanh,
    Abs,
    Signum,
}

impl Fun {
    /// The method of `DualNum` (and of `f64`) that evaluates it.
    pub fn method(self) -> &'static str {
        match self {
            Fun::Recip => "recip",
            Fun::Sqrt => "sqrt",
            Fun::Cbrt => "cbrt",
            Fun::Exp => "exp",
            Fun::Ln => "ln",
            Fun::Sin => "sin",
            Fun::Cos => "cos",
            Fun::Tan => "tan",
            Fun::Asin => "asin",
            Fun::Acos => "acos",
            Fun::Atan => "atan",
            Fun::Sinh => "sinh",
            Fun::Cosh => "cosh",
            Fun::Tanh => "tanh",
            Fun::Abs => "abs",
            Fun::Signum => "signum",
        }
    }

    /// Its value at a number (constant folding and the interpreter).
    pub fn apply(self, x: f64) -> f64 {
        match self {
            Fun::Recip => x.recip(),
            Fun::Sqrt => x.sqrt(),
            Fun::Cbrt => x.cbrt(),
            Fun::Exp => x.exp(),
            Fun::Ln => x.ln(),
            Fun::Sin => x.sin(),
            Fun::Cos => x.cos(),
            Fun::Tan => x.tan(),
            Fun::Asin => x.asin(),
            Fun::Acos => x.acos(),
            Fun::Atan => x.atan(),
            Fun::Sinh => x.sinh(),
            Fun::Cosh => x.cosh(),
            Fun::Tanh => x.tanh(),
            Fun::Abs => x.abs(),
            Fun::Signum => x.signum(),
        }
    }
}

/// One operation of the graph; operands are indices of earlier nodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// A number, by its bits (−0 is stored as +0, so `0` is one node).
    Const(u64),
    /// Element `i` of an argument vector.
    Input(Arg, u32),
    Neg(Id),
    Add(Id, Id),
    Sub(Id, Id),
    Mul(Id, Id),
    Div(Id, Id),
    Fun(Fun, Id),
    Powi(Id, i32),
    /// `x^n` for a constant exponent n (bits).
    Powf(Id, u64),
    /// `atan2(y, x)`.
    Atan2(Id, Id),
}

impl Node {
    /// The operands, in order.
    pub fn operands(&self) -> ([Id; 2], usize) {
        match *self {
            Node::Const(_) | Node::Input(..) => ([0, 0], 0),
            Node::Neg(a) | Node::Fun(_, a) | Node::Powi(a, _) | Node::Powf(a, _) => ([a, 0], 1),
            Node::Add(a, b)
            | Node::Sub(a, b)
            | Node::Mul(a, b)
            | Node::Div(a, b)
            | Node::Atan2(a, b) => ([a, b], 2),
        }
    }
}

/// The graph of one recording.
#[derive(Default)]
pub struct Graph {
    nodes: Vec<Node>,
    index: HashMap<Node, Id>,
    /// What looked at a value during the recording (`"PartialOrd"`, `"re()"`, …), once each:
    /// non-empty means some branch of the traced code may have been baked in.
    pub branches: Vec<&'static str>,
}

impl Graph {
    /// The node of an index.
    pub fn node(&self, id: Id) -> Node {
        self.nodes[id as usize]
    }

    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    fn intern(&mut self, node: Node) -> Id {
        if let Some(&id) = self.index.get(&node) {
            return id;
        }
        let id = Id::try_from(self.nodes.len()).expect("fewer than 2³² nodes");
        self.nodes.push(node);
        self.index.insert(node, id);
        id
    }

    /// Marks the nodes reachable from `roots`.
    pub fn reachable(&self, roots: &[Id]) -> Vec<bool> {
        let mut seen = vec![false; self.nodes.len()];
        let mut stack: Vec<Id> = roots.to_vec();
        while let Some(id) = stack.pop() {
            if std::mem::replace(&mut seen[id as usize], true) {
                continue;
            }
            let (ops, k) = self.node(id).operands();
            stack.extend_from_slice(&ops[..k]);
        }
        seen
    }

    /// Evaluates `roots` in `f64` at the given argument vectors (indexed by [`Arg`]): the
    /// graph as an interpreter, to check it without compiling generated code.
    pub fn eval(&self, roots: &[Id], args: [&[f64]; 5]) -> Vec<f64> {
        let seen = self.reachable(roots);
        let mut v = vec![0.0; self.nodes.len()];
        for (i, node) in self.nodes.iter().enumerate() {
            if !seen[i] {
                continue;
            }
            let x = |id: Id| v[id as usize];
            v[i] = match *node {
                Node::Const(bits) => f64::from_bits(bits),
                Node::Input(arg, k) => args[arg as usize][k as usize],
                Node::Neg(a) => -x(a),
                Node::Add(a, b) => x(a) + x(b),
                Node::Sub(a, b) => x(a) - x(b),
                Node::Mul(a, b) => x(a) * x(b),
                Node::Div(a, b) => x(a) / x(b),
                Node::Fun(f, a) => f.apply(x(a)),
                Node::Powi(a, n) => x(a).powi(n),
                Node::Powf(a, n) => x(a).powf(f64::from_bits(n)),
                Node::Atan2(a, b) => x(a).atan2(x(b)),
            };
        }
        roots.iter().map(|&r| v[r as usize]).collect()
    }
}

thread_local! {
    static GRAPH: RefCell<Option<Graph>> = const { RefCell::new(None) };
}

/// Reads the current recording's graph.
pub fn with_graph<R>(f: impl FnOnce(&Graph) -> R) -> R {
    with(|g| f(g))
}

fn with<R>(f: impl FnOnce(&mut Graph) -> R) -> R {
    GRAPH.with(|g| {
        let mut g = g.borrow_mut();
        let graph = g
            .as_mut()
            .expect("symbolic::Expr used outside symbolic::record");
        f(graph)
    })
}

/// Clears the thread's graph even when the recorded code panics, so a failed recording does
/// not poison the next one on the same thread.
struct Recording;

impl Drop for Recording {
    fn drop(&mut self) {
        GRAPH.with(|g| g.borrow_mut().take());
    }
}

/// Runs `f` with a fresh graph for this thread's [`Expr`]s and returns its result with the
/// graph. The `Expr`s `f` returns are indices into that graph; they mean nothing after.
pub fn record<R>(f: impl FnOnce() -> R) -> (R, Graph) {
    GRAPH.with(|g| {
        let mut g = g.borrow_mut();
        assert!(g.is_none(), "symbolic::record does not nest");
        *g = Some(Graph::default());
    });
    let guard = Recording;
    let result = f();
    let graph = GRAPH.with(|g| g.borrow_mut().take()).expect("graph");
    drop(guard);
    (result, graph)
}

/// Notes that a value was looked at (see the module notes).
fn branch(what: &'static str) {
    with(|g| {
        if !g.branches.contains(&what) {
            g.branches.push(what);
        }
    })
}

/// A symbolic scalar: a node of the current recording's graph.
#[derive(Clone, Copy)]
pub struct Expr(Id);

impl Expr {
    fn intern(node: Node) -> Expr {
        Expr(with(|g| g.intern(node)))
    }

    /// The constant `c`.
    pub fn constant(c: f64) -> Expr {
        let c = if c == 0.0 { 0.0 } else { c };
        Expr::intern(Node::Const(c.to_bits()))
    }

    /// Element `i` of argument vector `arg`.
    pub fn input(arg: Arg, i: usize) -> Expr {
        Expr::intern(Node::Input(arg, i as u32))
    }

    /// The leaves `arg[0..n]`.
    pub fn inputs(arg: Arg, n: usize) -> Vec<Expr> {
        (0..n).map(|i| Expr::input(arg, i)).collect()
    }

    pub fn id(self) -> Id {
        self.0
    }

    pub fn from_id(id: Id) -> Expr {
        Expr(id)
    }

    pub fn node(self) -> Node {
        with(|g| g.node(self.0))
    }

    /// Its value, if it is a constant.
    pub fn as_const(self) -> Option<f64> {
        match self.node() {
            Node::Const(bits) => Some(f64::from_bits(bits)),
            _ => None,
        }
    }

    /// `a + b`, simplified.
    pub fn plus(a: Expr, b: Expr) -> Expr {
        match (a.as_const(), b.as_const()) {
            (Some(x), Some(y)) => return Expr::constant(x + y),
            (Some(0.0), _) => return b,
            (_, Some(0.0)) => return a,
            (_, Some(y)) if y < 0.0 => return Expr::minus(a, Expr::constant(-y)),
            (Some(x), _) if x < 0.0 => return Expr::minus(b, Expr::constant(-x)),
            _ => {}
        }
        if a.0 == b.0 {
            return Expr::times(a, Expr::constant(2.0));
        }
        match (a.node(), b.node()) {
            (Node::Neg(x), Node::Neg(y)) => -Expr::plus(Expr(x), Expr(y)),
            (_, Node::Neg(y)) => Expr::minus(a, Expr(y)),
            (Node::Neg(x), _) => Expr::minus(b, Expr(x)),
            // Like terms one level apart: a + (a + c) = 2a + c (then ½x + (y + ½x) = x + y).
            (_, Node::Add(x, y)) | (Node::Add(x, y), _) if x == a.0 || x == b.0 => {
                let (twice, other) = if x == a.0 { (a, Expr(y)) } else { (b, Expr(y)) };
                Expr::plus(Expr::times(twice, Expr::constant(2.0)), other)
            }
            (_, Node::Add(x, y)) | (Node::Add(x, y), _) if y == a.0 || y == b.0 => {
                let (twice, other) = if y == a.0 { (a, Expr(x)) } else { (b, Expr(x)) };
                Expr::plus(Expr::times(twice, Expr::constant(2.0)), other)
            }
            _ => {
                let (x, y) = ordered(a, b);
                Expr::intern(Node::Add(x.0, y.0))
            }
        }
    }

    /// `a − b`, simplified.
    pub fn minus(a: Expr, b: Expr) -> Expr {
        match (a.as_const(), b.as_const()) {
            (Some(x), Some(y)) => return Expr::constant(x - y),
            (_, Some(0.0)) => return a,
            (_, Some(y)) if y < 0.0 => return Expr::plus(a, Expr::constant(-y)),
            (Some(0.0), _) => return -b,
            _ => {}
        }
        if a.0 == b.0 {
            return Expr::constant(0.0);
        }
        match (a.node(), b.node()) {
            (_, Node::Neg(y)) => Expr::plus(a, Expr(y)),
            (Node::Neg(x), _) => -Expr::plus(Expr(x), b),
            _ => Expr::intern(Node::Sub(a.0, b.0)),
        }
    }

    /// `a · b`, simplified.
    pub fn times(a: Expr, b: Expr) -> Expr {
        let (a, b) = ordered(a, b);
        if let Some(y) = b.as_const() {
            if let Some(x) = a.as_const() {
                return Expr::constant(x * y);
            }
            if y == 0.0 {
                return b;
            }
            if y == 1.0 {
                return a;
            }
            if y == -1.0 {
                return -a;
            }
            // c · (d · x) = (c d) · x: constants gather in one factor.
            if let Node::Mul(x, d) = a.node() {
                if let Some(d) = Expr(d).as_const() {
                    return Expr::times(Expr(x), Expr::constant(y * d));
                }
            }
        }
        match (a.node(), b.node()) {
            (Node::Neg(x), _) => -Expr::times(Expr(x), b),
            (_, Node::Neg(y)) => -Expr::times(a, Expr(y)),
            // Constant factors move outwards, (x c) · y = (x y) · c, where they meet and
            // fold: the ½ of ½ m v² and the 2 of d(v²) cancel.
            (Node::Mul(x, c), _) if Expr(c).as_const().is_some() => {
                Expr::times(Expr::times(Expr(x), b), Expr(c))
            }
            (_, Node::Mul(y, c)) if Expr(c).as_const().is_some() => {
                Expr::times(Expr::times(a, Expr(y)), Expr(c))
            }
            _ => Expr::intern(Node::Mul(a.0, b.0)),
        }
    }

    /// `a / b`, simplified.
    pub fn over(a: Expr, b: Expr) -> Expr {
        match (a.as_const(), b.as_const()) {
            (Some(x), Some(y)) => return Expr::constant(x / y),
            (Some(0.0), _) => return a,
            (_, Some(1.0)) => return a,
            (_, Some(-1.0)) => return -a,
            // Division by a power of two is an exact multiplication.
            (_, Some(y)) if y.recip() * y == 1.0 && is_power_of_two(y) => {
                return Expr::times(a, Expr::constant(y.recip()))
            }
            _ => {}
        }
        if a.0 == b.0 {
            return Expr::constant(1.0);
        }
        match (a.node(), b.node()) {
            (Node::Mul(x, c), _) if Expr(c).as_const().is_some() => {
                Expr::times(Expr::over(Expr(x), b), Expr(c))
            }
            (Node::Neg(x), _) => -Expr::over(Expr(x), b),
            (_, Node::Neg(y)) => -Expr::over(a, Expr(y)),
            _ => Expr::intern(Node::Div(a.0, b.0)),
        }
    }

    /// `−a`, simplified.
    pub fn negate(a: Expr) -> Expr {
        match a.node() {
            Node::Const(bits) => Expr::constant(-f64::from_bits(bits)),
            Node::Neg(x) => Expr(x),
            Node::Sub(x, y) => Expr::minus(Expr(y), Expr(x)),
            _ => Expr::intern(Node::Neg(a.0)),
        }
    }

    /// `f(a)`, simplified.
    pub fn fun(f: Fun, a: Expr) -> Expr {
        if let Some(x) = a.as_const() {
            return Expr::constant(f.apply(x));
        }
        match (f, a.node()) {
            (Fun::Sin | Fun::Tan | Fun::Asin | Fun::Atan | Fun::Sinh | Fun::Tanh, Node::Neg(x)) => {
                -Expr::fun(f, Expr(x))
            }
            (Fun::Cos | Fun::Cosh | Fun::Abs, Node::Neg(x)) => Expr::fun(f, Expr(x)),
            _ => Expr::intern(Node::Fun(f, a.0)),
        }
    }

    /// `a^n`, simplified.
    pub fn int_power(a: Expr, n: i32) -> Expr {
        match n {
            0 => Expr::constant(1.0),
            1 => a,
            2 => a * a,
            -1 => Expr::fun(Fun::Recip, a),
            _ => match a.as_const() {
                Some(x) => Expr::constant(x.powi(n)),
                None => Expr::intern(Node::Powi(a.0, n)),
            },
        }
    }

    /// `a^n` for a constant n, simplified.
    pub fn real_power(a: Expr, n: f64) -> Expr {
        if n == 0.0 {
            return Expr::constant(1.0);
        }
        if n == 1.0 {
            return a;
        }
        match a.as_const() {
            Some(x) => Expr::constant(x.powf(n)),
            None => Expr::intern(Node::Powf(a.0, n.to_bits())),
        }
    }

    /// `atan2(y, x)`.
    pub fn arctan2(y: Expr, x: Expr) -> Expr {
        match (y.as_const(), x.as_const()) {
            (Some(a), Some(b)) => Expr::constant(a.atan2(b)),
            _ => Expr::intern(Node::Atan2(y.0, x.0)),
        }
    }
}

fn is_power_of_two(y: f64) -> bool {
    y.is_normal() && y.to_bits() & ((1u64 << 52) - 1) == 0
}

/// The canonical operand order of `+` and `·`: a constant last, else by index.
fn ordered(a: Expr, b: Expr) -> (Expr, Expr) {
    let (ca, cb) = (a.as_const().is_some(), b.as_const().is_some());
    if ca && !cb || (ca == cb && a.0 > b.0) {
        (b, a)
    } else {
        (a, b)
    }
}

impl fmt::Debug for Expr {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "Expr#{}", self.0)
    }
}

impl fmt::Display for Expr {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        fmt::Debug::fmt(self, f)
    }
}

// ----- arithmetic: every operator form `DualNum` asks for -----------------------------

macro_rules! binary {
    ($trait:ident, $method:ident, $assign:ident, $assign_method:ident, $build:path) => {
        impl $trait for Expr {
            type Output = Expr;
            fn $method(self, rhs: Expr) -> Expr {
                $build(self, rhs)
            }
        }
        impl<'a> $trait<&'a Expr> for Expr {
            type Output = Expr;
            fn $method(self, rhs: &'a Expr) -> Expr {
                $build(self, *rhs)
            }
        }
        impl $trait<f64> for Expr {
            type Output = Expr;
            fn $method(self, rhs: f64) -> Expr {
                $build(self, Expr::constant(rhs))
            }
        }
        impl $assign for Expr {
            fn $assign_method(&mut self, rhs: Expr) {
                *self = $build(*self, rhs);
            }
        }
        impl $assign<f64> for Expr {
            fn $assign_method(&mut self, rhs: f64) {
                *self = $build(*self, Expr::constant(rhs));
            }
        }
    };
}

binary!(Add, add, AddAssign, add_assign, Expr::plus);
binary!(Sub, sub, SubAssign, sub_assign, Expr::minus);
binary!(Mul, mul, MulAssign, mul_assign, Expr::times);
binary!(Div, div, DivAssign, div_assign, Expr::over);

fn unsupported(what: &str) -> ! {
    panic!("symbolic::Expr does not support {what} (prototype): no code can be generated for this model")
}

fn remainder(_: Expr, _: Expr) -> Expr {
    unsupported("the remainder %")
}

binary!(Rem, rem, RemAssign, rem_assign, remainder);

impl Neg for Expr {
    type Output = Expr;
    fn neg(self) -> Expr {
        Expr::negate(self)
    }
}

impl Inv for Expr {
    type Output = Expr;
    fn inv(self) -> Expr {
        Expr::fun(Fun::Recip, self)
    }
}

impl Sum for Expr {
    fn sum<I: Iterator<Item = Expr>>(iter: I) -> Expr {
        iter.fold(Expr::constant(0.0), |a, b| a + b)
    }
}

impl<'a> Sum<&'a Expr> for Expr {
    fn sum<I: Iterator<Item = &'a Expr>>(iter: I) -> Expr {
        iter.fold(Expr::constant(0.0), |a, b| a + *b)
    }
}

impl Product for Expr {
    fn product<I: Iterator<Item = Expr>>(iter: I) -> Expr {
        iter.fold(Expr::constant(1.0), |a, b| a * b)
    }
}

impl<'a> Product<&'a Expr> for Expr {
    fn product<I: Iterator<Item = &'a Expr>>(iter: I) -> Expr {
        iter.fold(Expr::constant(1.0), |a, b| a * *b)
    }
}

impl From<f64> for Expr {
    fn from(c: f64) -> Expr {
        Expr::constant(c)
    }
}

impl FromPrimitive for Expr {
    fn from_i64(n: i64) -> Option<Expr> {
        Some(Expr::constant(n as f64))
    }
    fn from_u64(n: u64) -> Option<Expr> {
        Some(Expr::constant(n as f64))
    }
    fn from_f64(n: f64) -> Option<Expr> {
        Some(Expr::constant(n))
    }
}

// ----- queries on values: exact for constants, recorded as branches otherwise ---------

impl PartialEq for Expr {
    fn eq(&self, other: &Expr) -> bool {
        match (self.as_const(), other.as_const()) {
            (Some(a), Some(b)) => a == b,
            _ => {
                branch("PartialEq");
                false
            }
        }
    }
}

impl PartialEq<f64> for Expr {
    fn eq(&self, other: &f64) -> bool {
        *self == Expr::constant(*other)
    }
}

impl PartialOrd for Expr {
    fn partial_cmp(&self, other: &Expr) -> Option<std::cmp::Ordering> {
        match (self.as_const(), other.as_const()) {
            (Some(a), Some(b)) => a.partial_cmp(&b),
            _ => {
                branch("PartialOrd");
                None
            }
        }
    }
}

impl PartialOrd<f64> for Expr {
    fn partial_cmp(&self, other: &f64) -> Option<std::cmp::Ordering> {
        self.partial_cmp(&Expr::constant(*other))
    }
}

impl Zero for Expr {
    fn zero() -> Expr {
        Expr::constant(0.0)
    }
    fn is_zero(&self) -> bool {
        match self.as_const() {
            Some(c) => c == 0.0,
            None => {
                branch("is_zero()");
                false
            }
        }
    }
}

impl One for Expr {
    fn one() -> Expr {
        Expr::constant(1.0)
    }
    fn is_one(&self) -> bool {
        match self.as_const() {
            Some(c) => c == 1.0,
            None => {
                branch("is_one()");
                false
            }
        }
    }
}

impl Num for Expr {
    type FromStrRadixErr = <f64 as Num>::FromStrRadixErr;
    fn from_str_radix(s: &str, radix: u32) -> Result<Expr, Self::FromStrRadixErr> {
        f64::from_str_radix(s, radix).map(Expr::constant)
    }
}

impl Signed for Expr {
    fn abs(&self) -> Expr {
        Expr::fun(Fun::Abs, *self)
    }
    fn abs_sub(&self, _other: &Expr) -> Expr {
        unsupported("abs_sub")
    }
    fn signum(&self) -> Expr {
        Expr::fun(Fun::Signum, *self)
    }
    fn is_positive(&self) -> bool {
        match self.as_const() {
            Some(c) => c.is_sign_positive(),
            None => {
                branch("is_positive()");
                false
            }
        }
    }
    fn is_negative(&self) -> bool {
        match self.as_const() {
            Some(c) => c.is_sign_negative(),
            None => {
                branch("is_negative()");
                false
            }
        }
    }
}

impl DualStruct for Expr {
    type Real = f64;
    type Inner = f64;
    /// The value of a constant; for anything else NaN, recorded as a branch.
    fn re(&self) -> f64 {
        self.as_const().unwrap_or_else(|| {
            branch("re()");
            f64::NAN
        })
    }
    fn from_inner(inner: &f64) -> Expr {
        Expr::constant(*inner)
    }
}

impl Mappable<Expr> for Expr {
    type Output<O> = O;
    fn map_dual<M: Fn(Expr) -> O, O>(self, f: M) -> O {
        f(self)
    }
}

impl DualNum for Expr {
    type Primitive = f64;
    const NDERIV: usize = 0;
    type InnerDual = f64;

    fn from_re(re: f64) -> Expr {
        Expr::constant(re)
    }
    fn scale(self, factor: &f64) -> Expr {
        self * *factor
    }
    fn recip(&self) -> Expr {
        Expr::fun(Fun::Recip, *self)
    }
    fn powi(&self, n: i32) -> Expr {
        Expr::int_power(*self, n)
    }
    fn powf(&self, n: f64) -> Expr {
        Expr::real_power(*self, n)
    }
    fn sqrt(&self) -> Expr {
        Expr::fun(Fun::Sqrt, *self)
    }
    fn cbrt(&self) -> Expr {
        Expr::fun(Fun::Cbrt, *self)
    }
    fn exp(&self) -> Expr {
        Expr::fun(Fun::Exp, *self)
    }
    fn exp2(&self) -> Expr {
        Expr::fun(Fun::Exp, *self * std::f64::consts::LN_2)
    }
    fn exp_m1(&self) -> Expr {
        unsupported("exp_m1")
    }
    fn ln(&self) -> Expr {
        Expr::fun(Fun::Ln, *self)
    }
    fn log(&self, base: f64) -> Expr {
        Expr::fun(Fun::Ln, *self) / base.ln()
    }
    fn log2(&self) -> Expr {
        Expr::fun(Fun::Ln, *self) / std::f64::consts::LN_2
    }
    fn log10(&self) -> Expr {
        Expr::fun(Fun::Ln, *self) / std::f64::consts::LN_10
    }
    fn ln_1p(&self) -> Expr {
        unsupported("ln_1p")
    }
    fn sin(&self) -> Expr {
        Expr::fun(Fun::Sin, *self)
    }
    fn cos(&self) -> Expr {
        Expr::fun(Fun::Cos, *self)
    }
    fn tan(&self) -> Expr {
        Expr::fun(Fun::Tan, *self)
    }
    fn sin_cos(&self) -> (Expr, Expr) {
        (self.sin(), self.cos())
    }
    fn asin(&self) -> Expr {
        Expr::fun(Fun::Asin, *self)
    }
    fn acos(&self) -> Expr {
        Expr::fun(Fun::Acos, *self)
    }
    fn atan(&self) -> Expr {
        Expr::fun(Fun::Atan, *self)
    }
    fn atan2(&self, other: Expr) -> Expr {
        Expr::arctan2(*self, other)
    }
    fn sinh(&self) -> Expr {
        Expr::fun(Fun::Sinh, *self)
    }
    fn cosh(&self) -> Expr {
        Expr::fun(Fun::Cosh, *self)
    }
    fn tanh(&self) -> Expr {
        Expr::fun(Fun::Tanh, *self)
    }
    fn asinh(&self) -> Expr {
        unsupported("asinh")
    }
    fn acosh(&self) -> Expr {
        unsupported("acosh")
    }
    fn atanh(&self) -> Expr {
        unsupported("atanh")
    }
    fn sph_j0(&self) -> Expr {
        unsupported("sph_j0")
    }
    fn sph_j1(&self) -> Expr {
        unsupported("sph_j1")
    }
    fn sph_j2(&self) -> Expr {
        unsupported("sph_j2")
    }
    fn mul_add(&self, a: Expr, b: Expr) -> Expr {
        *self * a + b
    }
    fn powd(&self, _exp: Expr) -> Expr {
        unsupported("powd (a symbolic exponent)")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Scalar;

    fn is_scalar<S: Scalar>() {}

    #[test]
    fn expr_is_a_scalar() {
        is_scalar::<Expr>();
        is_scalar::<num_dual::Dual<Expr>>();
        is_scalar::<num_dual::HyperDual<Expr>>();
    }

    #[test]
    fn equal_subexpressions_are_one_node_and_identities_fold() {
        let ((), g) = record(|| {
            let x = Expr::input(Arg::Q, 0);
            let y = Expr::input(Arg::P, 1);
            assert_eq!(
                (x * y).id(),
                (y * x).id(),
                "commutative operands are ordered"
            );
            assert_eq!((x.sin() * y + 0.0).id(), (x.sin() * y).id());
            assert_eq!((x * 1.0).id(), x.id());
            assert_eq!((x - x).as_const(), Some(0.0));
            assert_eq!((x * 0.0).as_const(), Some(0.0));
            assert_eq!((-(-x)).id(), x.id());
            assert_eq!(((x * 2.0) * 0.5).id(), x.id(), "constant factors gather");
            assert_eq!((x + x).id(), (x * 2.0).id());
            assert_eq!((x / 4.0).id(), (x * 0.25).id());
            assert_eq!((x + (-y)).id(), (x - y).id());
            assert_eq!((Expr::constant(2.0) * 3.0).as_const(), Some(6.0));
            assert_eq!((-x).cos().id(), x.cos().id());
            let half = x * 0.5;
            assert_eq!((half + (y + half)).id(), (x + y).id(), "like terms meet");
        });
        assert!(g.branches.is_empty());
        // q0, p1, q0·p1, sin q0, sin q0 · p1, 1, 0, 2, q0·2, 0.5, 4, 0.25, q0·0.25, p1 − …
        assert!(g.len() < 25, "{} nodes", g.len());
    }

    #[test]
    fn looking_at_a_value_is_recorded() {
        let ((), g) = record(|| {
            let x = Expr::input(Arg::Q, 0);
            assert!(Expr::constant(1.0) < Expr::constant(2.0));
            assert!(Expr::constant(0.0).is_zero());
            let _ = x > 0.0;
            let _ = x.re();
        });
        assert_eq!(g.branches, vec!["PartialOrd", "re()"]);
    }

    #[test]
    fn dual_numbers_over_expr_differentiate_symbolically() {
        use num_dual::Dual;
        let (d, g) = record(|| {
            let x = Expr::input(Arg::Q, 0);
            let xd = Dual::new(x, Expr::constant(1.0));
            (xd.sin() * xd).eps.id()
        });
        assert!(g.branches.is_empty());
        let v = g.eval(&[d], [&[0.7], &[], &[], &[], &[]]);
        assert!((v[0] - (0.7f64.cos() * 0.7 + 0.7f64.sin())).abs() < 1e-15);
    }

    #[test]
    fn a_panic_inside_a_recording_leaves_the_thread_clean() {
        let r = std::panic::catch_unwind(|| record(|| Expr::input(Arg::Q, 0) % 2.0));
        assert!(r.is_err());
        let (x, g) = record(|| Expr::input(Arg::Q, 0).id());
        assert_eq!((x, g.len()), (0, 1));
    }
}
