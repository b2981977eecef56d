//! The equations of motion of a [`Lagrangian`], assembled once on the graph.
//!
//! The system's own `kinetic`, `potential`, `forces` and `constraints` are called with
//! `S = Expr` on symbolic leaves q, q̇, u, p and t, and the same equations
//! [`lagrangian`](crate::model::lagrangian) forms numerically at every evaluation are
//! formed here symbolically:
//!
//! ```text
//! (∂L/∂q, ∂L/∂q̇)   one reverse sweep of L = T − V (∂L/∂q̇ = ∂T/∂q̇ = p, the momenta)
//! M[·][j] = ∂p/∂q̇ⱼ  one forward sweep of p per column (upper triangle: M is symmetric)
//! (∂²L/∂q̇∂q) q̇      one forward sweep of p with the tangent q̇ on q (and 1 on t:
//!                   + ∂²L/∂q̇∂t, for T with t in it)
//! rhs = Q + ∂L/∂q − (∂²L/∂q̇∂q) q̇
//! G[k] = ∂Φₖ/∂q     one reverse sweep per constraint
//! γ = q̇ᵀ ∇²Φ q̇      two forward sweeps of Φ along (q̇, 1): + 2 Φ_qt q̇ + Φ_tt
//! A[k] = ∂(A q̇)ₖ/∂q̇  one reverse sweep per velocity constraint (A q̇ is linear in q̇)
//! Ȧ q̇ + ḃ           one forward sweep of A q̇ + b along (q̇, 1)
//! ```
//!
//! The velocity constraints' rows follow the holonomic ones in G and γ, as
//! [`accelerations_and_multipliers`](crate::model::lagrangian::accelerations_and_multipliers)
//! orders them.
//!
//! What cannot be traced is refused ([`TraceError`]) rather than traced wrong.

use super::diff::{forward, gradient};
use super::expr::{record, Arg, Expr, Graph, Id};
use crate::model::lagrangian::Lagrangian;
use std::fmt;

/// The symbolic equations of motion `M q̈ + Gᵀ λ = rhs`, `G q̈ = −γ`, as roots in `graph`.
pub struct Equations {
    pub name: &'static str,
    pub graph: Graph,
    /// Coordinates n, constraint rows k (holonomic and velocity), inputs, parameters.
    pub n: usize,
    pub k: usize,
    /// Of the k rows, the holonomic ones (the first).
    pub holonomic: usize,
    pub inputs: usize,
    pub parameters: usize,
    /// `m[i][j]` for j ≥ i (the upper triangle; `m[j][i]` is the same node).
    pub m: Vec<Vec<Id>>,
    pub rhs: Vec<Id>,
    /// `g[k][j] = ∂Φₖ/∂qⱼ`, then `A[k][j]`.
    pub g: Vec<Vec<Id>>,
    pub gamma: Vec<Id>,
}

impl Equations {
    /// Every root, M's upper triangle first (the order the emitted code assigns them).
    pub fn roots(&self) -> Vec<Id> {
        let upper = (0..self.n).flat_map(|i| self.m[i][i..].iter().copied());
        upper
            .chain(self.rhs.iter().copied())
            .chain(self.g.iter().flatten().copied())
            .chain(self.gamma.iter().copied())
            .collect()
    }

    /// The nodes the equations need (shared subexpressions once), and how many of them
    /// are operations (neither leaves nor constants).
    pub fn size(&self) -> (usize, usize) {
        let seen = self.graph.reachable(&self.roots());
        let mut nodes = 0;
        let mut ops = 0;
        for (i, &s) in seen.iter().enumerate() {
            if s {
                nodes += 1;
                if !matches!(
                    self.graph.node(i as Id),
                    super::Node::Const(_) | super::Node::Input(..)
                ) {
                    ops += 1;
                }
            }
        }
        (nodes, ops)
    }

    /// `(M, rhs, G, γ)` at a point, by interpreting the graph in `f64`.
    #[allow(clippy::type_complexity)]
    pub fn eval(
        &self,
        q: &[f64],
        qd: &[f64],
        u: &[f64],
        p: &[f64],
    ) -> (Vec<Vec<f64>>, Vec<f64>, Vec<Vec<f64>>, Vec<f64>) {
        self.eval_at(0.0, q, qd, u, p)
    }

    /// [`Equations::eval`] at time t (rheonomic systems).
    #[allow(clippy::type_complexity)]
    pub fn eval_at(
        &self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        u: &[f64],
        p: &[f64],
    ) -> (Vec<Vec<f64>>, Vec<f64>, Vec<Vec<f64>>, Vec<f64>) {
        let v = |ids: &[Id]| self.graph.eval(ids, [q, qd, u, p, &[t]]);
        let m = (0..self.n)
            .map(|i| {
                (0..self.n)
                    .map(|j| v(&[self.m[i.min(j)][i.max(j)]])[0])
                    .collect()
            })
            .collect();
        let g = self.g.iter().map(|row| v(row)).collect();
        (m, v(&self.rhs), g, v(&self.gamma))
    }
}

/// Why the equations of a system cannot be generated.
#[derive(Debug, Clone, PartialEq)]
pub enum TraceError {
    /// The traced functions looked at a symbolic value (compared it, took `re()`): a branch
    /// of theirs would have been baked into the code for one side only.
    Branches {
        system: &'static str,
        what: Vec<&'static str>,
    },
    /// `forces` gave different graphs for different t: time is an `f64` there (not a
    /// leaf, as in T, V and the constraints), so its value would be baked in.
    TimeDependent { system: &'static str },
}

impl fmt::Display for TraceError {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match self {
            TraceError::Branches { system, what } => write!(
                f,
                "{system}: the traced code looked at a symbolic value ({}), so a branch would be baked in; no code generated",
                what.join(", ")
            ),
            TraceError::TimeDependent { system } => write!(
                f,
                "{system}: the generalised forces depend on t, which the Lagrangian trait passes to them as f64; no code generated"
            ),
        }
    }
}

impl std::error::Error for TraceError {}

fn ids(v: &[Expr]) -> Vec<Id> {
    v.iter().map(|e| e.id()).collect()
}

/// Traces `L` and assembles its equations of motion (see the module notes).
pub fn equations<L: Lagrangian>() -> Result<Equations, TraceError> {
    let system = L::NAME;
    let n = L::coordinates().len();
    let holonomic = L::CONSTRAINTS;
    let k = holonomic + L::VELOCITY_CONSTRAINTS;
    let (inputs, parameters) = (L::inputs().len(), L::parameters().len());
    let (result, graph) = record(|| {
        let q = Expr::inputs(Arg::Q, n);
        let qd = Expr::inputs(Arg::Qd, n);
        let u = Expr::inputs(Arg::U, inputs);
        let p = Expr::inputs(Arg::P, parameters);
        // The time is a leaf too, so rheonomic T, V and constraints trace exactly.
        let t = Expr::input(Arg::T, 0);

        let forces_at = |t: f64| {
            let mut f = vec![Expr::constant(0.0); n];
            L::forces(t, &q, &qd, &u, &p, &mut f);
            ids(&f)
        };
        let forces = forces_at(0.0);
        let time_independent = [1.0, f64::NAN].iter().all(|&t| forces_at(t) == forces);

        let lagrangian = L::kinetic(t, &q, &qd, &p) - L::potential(t, &q, &p);
        let leaves: Vec<Expr> = q.iter().chain(&qd).copied().collect();
        let dl = gradient(lagrangian, &leaves);
        let (dl_dq, momenta) = dl.split_at(n);

        let mut m = vec![Vec::new(); n];
        for j in 0..n {
            let column = forward(&momenta[..=j], |arg, i| {
                (arg == Arg::Qd && i == j).then(|| Expr::constant(1.0))
            });
            for (i, mij) in column.into_iter().enumerate() {
                m[i].push(mij.id());
            }
        }
        // m[i] now holds M[i][i..]: pad the lower part so m[i][j] is M[i][j] for j ≥ i.
        for (i, row) in m.iter_mut().enumerate() {
            let mut full = vec![0; i];
            full.append(row);
            *row = full;
        }

        // Along the motion: q + ε q̇, t + ε (the time derivative of a rheonomic term).
        let along_qd = |arg: Arg, i: usize| match arg {
            Arg::Q => Some(qd[i]),
            Arg::T => Some(Expr::constant(1.0)),
            _ => None,
        };
        let mixed = forward(momenta, along_qd);
        let rhs: Vec<Id> = (0..n)
            .map(|i| (Expr::from_id(forces[i]) + dl_dq[i] - mixed[i]).id())
            .collect();

        let mut phi = vec![Expr::constant(0.0); holonomic];
        L::constraints(t, &q, &p, &mut phi);
        let mut g: Vec<Vec<Id>> = phi.iter().map(|&c| ids(&gradient(c, &q))).collect();
        let mut gamma = ids(&forward(&forward(&phi, along_qd), along_qd));
        let mut aqd = vec![Expr::constant(0.0); k - holonomic];
        L::velocity_constraints(t, &q, &qd, &p, &mut aqd);
        g.extend(aqd.iter().map(|&c| ids(&gradient(c, &qd))));
        gamma.extend(ids(&forward(&aqd, along_qd)));
        (time_independent, m, rhs, g, gamma)
    });
    let (time_independent, m, rhs, g, gamma) = result;
    if !graph.branches.is_empty() {
        return Err(TraceError::Branches {
            system,
            what: graph.branches.clone(),
        });
    }
    if !time_independent {
        return Err(TraceError::TimeDependent { system });
    }
    Ok(Equations {
        name: system,
        graph,
        n,
        k,
        holonomic,
        inputs,
        parameters,
        m,
        rhs,
        g,
        gamma,
    })
}
