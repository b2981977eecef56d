//! Linearisation for control design: `δẋ = A δx + B δu`, `δy = C δx + D δu` at an
//! operating point, with exact derivatives (forward-mode dual numbers; finite
//! differences are only a test oracle), and an optional trim (Newton with the exact
//! Jacobian) that first finds an equilibrium.
//!
//! The outputs `y` are the FMU's outputs in FMI order: the states, then the extra
//! outputs. So `C = [I; ∂g/∂x]` and `D = [0; ∂g/∂u]`: an output equal to a state has
//! derivative 1 with respect to that state.

mod eigen;
mod format;

pub use eigen::eigenvalues;
pub use format::{to_csv, to_json, to_py};

use crate::model::consistent;
use crate::model::jacobian::{directional, Direction};
use crate::model::{Layout, System, VarKind};
use nalgebra::{DMatrix, DVector};

/// Where to linearise: time, states, inputs, parameters (in declaration order).
#[derive(Clone, Debug, PartialEq)]
pub struct OperatingPoint {
    pub t: f64,
    pub x: Vec<f64>,
    pub u: Vec<f64>,
    pub p: Vec<f64>,
}

impl OperatingPoint {
    /// The start values of the model, then the given `name = value` overrides (any
    /// parameter, state or input, or `time`: a time-varying system linearised at that t,
    /// its dependent states solved there; default 0, the start time).
    pub fn from_start_values<M: System>(overrides: &[(String, f64)]) -> Result<Self, String> {
        let layout = Layout::of::<M>();
        let mut op = OperatingPoint {
            t: 0.0,
            x: M::states().iter().map(|v| v.start).collect(),
            u: M::inputs().iter().map(|v| v.start).collect(),
            p: M::parameters().iter().map(|v| v.start).collect(),
        };
        for (name, value) in overrides {
            if name == "time" {
                if !value.is_finite() {
                    return Err(format!("time = {value}: not a finite time"));
                }
                op.t = *value;
                continue;
            }
            let vr = layout
                .vr_of(name)
                .ok_or_else(|| format!("{} has no variable named {name}", M::name()))?;
            let slot = layout.slot(vr).expect("vr from the layout");
            let target = match slot.kind {
                VarKind::Parameter => &mut op.p,
                VarKind::State => &mut op.x,
                VarKind::Input => &mut op.u,
                _ => {
                    return Err(format!(
                        "{name} is not a parameter, state or input of {}",
                        M::name()
                    ))
                }
            };
            // The FMU's own check and message (fmi2SetReal), so the CLI refuses what the
            // FMU refuses.
            layout.vars[vr as usize]
                .1
                .check(*value)
                .map_err(|e| format!("{e} (value reference {vr})"))?;
            target[slot.index] = *value;
        }
        Ok(op)
    }

    /// [`OperatingPoint::from_start_values`], then the dependent states of a constrained
    /// system solved from the independent ones, as fmi2ExitInitializationMode does
    /// ([`consistent::solve`]). Returns the point and one line per dependent state that an
    /// override set to a value the constraints contradict (the FMU's warning).
    pub fn consistent<M: System>(
        overrides: &[(String, f64)],
    ) -> Result<(Self, Vec<String>), String> {
        let mut op = Self::from_start_values::<M>(overrides)?;
        let set: Vec<bool> = M::states()
            .iter()
            .map(|v| overrides.iter().any(|(name, _)| *name == v.name))
            .collect();
        let before = op.x.clone();
        consistent::solve::<M>(op.t, &op.p, &mut op.x)?;
        let warnings =
            consistent::overridden::<M>(&Layout::of::<M>(), op.t, &op.p, &set, &before, &op.x);
        Ok((op, warnings))
    }
}

/// The linear model at one operating point.
#[derive(Clone, Debug)]
pub struct Linearization {
    pub model: &'static str,
    pub state_names: Vec<String>,
    /// Where each of `state_names` is in the full state `point.x`.
    pub state_index: Vec<usize>,
    /// Dependent states eliminated through the constraints ([`reduced`]); empty when
    /// the model is in all the states.
    pub eliminated: Vec<String>,
    /// Independent states left out ([`reduced`] with `keep`): nothing retained depends on them.
    pub dropped: Vec<String>,
    pub input_names: Vec<String>,
    pub output_names: Vec<String>,
    pub parameter_names: Vec<String>,
    pub point: OperatingPoint,
    /// Outputs at the operating point.
    pub y0: Vec<f64>,
    /// `‖f(x0, u0)‖∞`: zero at an equilibrium.
    pub residual: f64,
    pub a: DMatrix<f64>,
    pub b: DMatrix<f64>,
    pub c: DMatrix<f64>,
    pub d: DMatrix<f64>,
    pub method: &'static str,
    /// What had to give at the operating point (a dependent state set against its
    /// constraints), one line each; empty when everything set was used as set.
    pub warnings: Vec<String>,
}

/// Columns of `[∂f/∂x ∂f/∂u]` and `[∂g/∂x ∂g/∂u]`, one dual-number pass per column.
fn jacobians<M: System>(op: &OperatingPoint) -> (DMatrix<f64>, DMatrix<f64>) {
    let (n, m, ny) = (op.x.len(), op.u.len(), M::outputs().len());
    let mut fj = DMatrix::zeros(n, n + m);
    let mut gj = DMatrix::zeros(ny, n + m);
    let zeros_p = vec![0.0; op.p.len()];
    for j in 0..n + m {
        let mut e = vec![0.0; n + m];
        e[j] = 1.0;
        let (df, dg) = directional::<M>(
            &Direction {
                t: op.t,
                x: (&op.x, &e[..n]),
                u: (&op.u, &e[n..]),
                p: (&op.p, &zeros_p),
            },
            ny,
        );
        fj.set_column(j, &DVector::from_vec(df));
        gj.set_column(j, &DVector::from_vec(dg));
    }
    (fj, gj)
}

fn derivatives<M: System>(op: &OperatingPoint) -> Vec<f64> {
    let mut f = vec![0.0; op.x.len()];
    M::derivatives(op.t, &op.x, &op.u, &op.p, &mut f);
    f
}

fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// A, B, C, D of `M` at `op`.
pub fn linearize<M: System>(op: &OperatingPoint) -> Linearization {
    let (n, m) = (op.x.len(), op.u.len());
    let ny = M::outputs().len();
    let (fj, gj) = jacobians::<M>(op);
    let mut c = DMatrix::zeros(n + ny, n);
    let mut d = DMatrix::zeros(n + ny, m);
    c.view_mut((0, 0), (n, n)).fill_with_identity();
    c.view_mut((n, 0), (ny, n)).copy_from(&gj.columns(0, n));
    d.view_mut((n, 0), (ny, m)).copy_from(&gj.columns(n, m));
    let mut extra = vec![0.0; ny];
    M::extra_outputs(op.t, &op.x, &op.u, &op.p, &mut extra);
    let names = |vars: Vec<crate::model::Var>| {
        vars.into_iter()
            .map(|v| v.name.into_owned())
            .collect::<Vec<_>>()
    };
    let state_names = names(M::states());
    let mut output_names = state_names.clone();
    output_names.extend(names(M::outputs()));
    Linearization {
        model: M::name(),
        state_index: (0..n).collect(),
        eliminated: Vec::new(),
        dropped: Vec::new(),
        state_names,
        input_names: names(M::inputs()),
        output_names,
        parameter_names: names(M::parameters()),
        y0: op.x.iter().copied().chain(extra).collect(),
        residual: inf_norm(&derivatives::<M>(op)),
        a: fj.columns(0, n).into_owned(),
        b: fj.columns(n, m).into_owned(),
        c,
        d,
        point: op.clone(),
        method: "exact: forward-mode dual numbers (num-dual)",
        warnings: Vec::new(),
    }
}

impl Linearization {
    /// The operating point's values of the states the model is written in.
    pub fn x0(&self) -> Vec<f64> {
        self.state_index.iter().map(|&i| self.point.x[i]).collect()
    }
}

/// Which states a linear model is written in.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum States {
    /// All of them (dependent ones included), as the FMU integrates them.
    #[default]
    All,
    /// The independent ones: the dependent states eliminated through the constraints.
    Independent,
    /// These independent ones, in this order.
    Only(Vec<String>),
}

/// What `--trim` solves for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Trim {
    /// The states with zero derivatives for the given inputs (Newton on f(x) = 0).
    States,
    /// The inputs that hold the given state (Gauss–Newton on f(u) = 0, least squares).
    Inputs,
}

/// Newton iterations allowed before trim gives up.
const TRIM_MAX_ITERATIONS: usize = 50;

/// Moves `op` to an equilibrium by Newton's method with the exact Jacobian. Returns the
/// final residual `‖f‖∞`, or an error when the Jacobian is singular or Newton does not
/// converge (the operating point is then left unchanged).
pub fn trim<M: System>(op: &mut OperatingPoint, what: Trim) -> Result<f64, String> {
    let n = op.x.len();
    let mut trial = op.clone();
    let scale = 1.0 + inf_norm(&trial.x).max(inf_norm(&trial.u));
    for _ in 0..TRIM_MAX_ITERATIONS {
        let f = DVector::from_vec(derivatives::<M>(&trial));
        let r = f.amax();
        if r <= 1e-13 * scale {
            *op = trial;
            return Ok(r);
        }
        let (fj, _) = jacobians::<M>(&trial);
        let step = match what {
            Trim::States => fj
                .columns(0, n)
                .into_owned()
                .lu()
                .solve(&f)
                .ok_or("trim: ∂f/∂x is singular at this point; give a nearer start (--at)")?,
            Trim::Inputs => {
                let b = fj.columns(n, op.u.len()).into_owned();
                b.svd(true, true)
                    .solve(&f, 1e-12)
                    .map_err(|e| format!("trim: cannot solve for the inputs: {e}"))?
            }
        };
        let target = match what {
            Trim::States => &mut trial.x,
            Trim::Inputs => &mut trial.u,
        };
        for (v, s) in target.iter_mut().zip(step.iter()) {
            *v -= s;
        }
        if target.iter().any(|v| !v.is_finite()) {
            return Err("trim: Newton diverged".into());
        }
    }
    let r = inf_norm(&derivatives::<M>(&trial));
    // Inputs may not be able to cancel every derivative: report the least-squares residual.
    if what == Trim::Inputs {
        *op = trial;
        return Ok(r);
    }
    Err(format!(
        "trim: Newton did not converge in {TRIM_MAX_ITERATIONS} iterations (residual {r:e})"
    ))
}

/// Relative size (to the largest entry of A) below which a coupling counts as zero when
/// a state is dropped: ~100 ulp of sums of terms of the size of A's entries.
const DROP_TOLERANCE: f64 = 1e-13;

/// The linearisation on the constraint manifold, in the independent states only.
///
/// A constrained system's state `x = (x_i, x_d)` satisfies `c(x) = 0`
/// ([`System::state_constraints`]), which gives the dependent states as functions of the
/// independent ones, `x_d = h(x_i)`, with `∂h/∂x_i = −(∂c/∂x_d)⁻¹ ∂c/∂x_i` (implicit
/// functions; ∂c exact by dual numbers). The motion on the manifold is
/// `ẋ_i = f_i(x_i, h(x_i))`, so
///
/// ```text
/// A_r = A_ii + A_id ∂h/∂x_i,   B_r = B_i,   C_r = C_·i + C_·d ∂h/∂x_i,   D_r = D
/// ```
///
/// The full A also has eigenvalues of the motion off the manifold (the constraint drift
/// the λ-method leaves undamped: zeros); A_r has only those of the mechanics. Then
/// `keep`, if given, names the independent states to retain (rows and columns of A,
/// rows of B, columns of C, in that order): dropping a state is exact where no retained
/// state depends on it (an ignorable coordinate), which this checks and refuses
/// otherwise. A system without dependent states is returned as it is (then only `keep`).
pub fn reduced<M: System>(
    lin: &Linearization,
    keep: Option<&[String]>,
) -> Result<Linearization, String> {
    reduced_on::<M>(lin, &consistent::dependent_states::<M>(), keep)
}

/// [`reduced`] with another choice of the dependent states (as many as the system has
/// constraints on its state): the same motion in other independent coordinates.
pub fn reduced_on<M: System>(
    lin: &Linearization,
    dependent: &[usize],
    keep: Option<&[String]>,
) -> Result<Linearization, String> {
    let n = lin.state_names.len();
    let independent: Vec<usize> = (0..n).filter(|i| !dependent.contains(i)).collect();
    let op = &lin.point;
    // ∂c/∂x, one dual pass per state.
    let k = dependent.len();
    // Redundant constraints: more rows than dependent states (of the same rank).
    let rows = M::STATE_CONSTRAINTS;
    if k > rows {
        return Err(format!(
            "{}: {k} dependent states named for {rows} constraints on the state",
            M::name()
        ));
    }
    let mut cx = DMatrix::zeros(rows, n);
    if k > 0 {
        if consistent::residuals::<M>(op.t, &op.x, &op.p).is_empty() {
            return Err(format!(
                "{}: the constraints do not hold at this state, nothing to reduce",
                M::name()
            ));
        }
        let all: Vec<usize> = (0..n).collect();
        let (_, jac) = consistent::residuals_and_jacobian::<M>(op.t, &op.x, &op.p, &all);
        for (i, row) in jac.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                cx[(i, j)] = *v;
            }
        }
    }
    let pick = |m: &DMatrix<f64>, rows: &[usize], cols: &[usize]| {
        DMatrix::from_fn(rows.len(), cols.len(), |i, j| m[(rows[i], cols[j])])
    };
    // Columns of x (all states) for a change of the independent ones: [I; ∂h/∂x_i].
    let mut lift = DMatrix::zeros(n, independent.len());
    for (col, &i) in independent.iter().enumerate() {
        lift[(i, col)] = 1.0;
    }
    if k > 0 {
        let all_rows: Vec<usize> = (0..rows).collect();
        let cd = pick(&cx, &all_rows, dependent);
        let ci = pick(&cx, &all_rows, &independent);
        let singular = || {
            format!(
                "{}: the constraints cannot be solved for the dependent states here (singular)",
                M::name()
            )
        };
        let dh = if rows == k {
            cd.lu().solve(&(-ci)).ok_or_else(singular)?
        } else {
            // Least squares: exact, the redundant rows being combinations of the others.
            let svd = cd.svd(true, true);
            let eps = crate::model::lagrangian::LEAST_SQUARES_RANK_RTOL * svd.singular_values.max();
            if svd.rank(eps) < k {
                return Err(singular());
            }
            svd.solve(&(-ci), eps).map_err(|_| singular())?
        };
        for (row, &d) in dependent.iter().enumerate() {
            lift.row_mut(d).copy_from(&dh.row(row));
        }
    }
    let a_full = &lin.a * &lift;
    let mut a = pick(
        &a_full,
        &independent,
        &(0..independent.len()).collect::<Vec<_>>(),
    );
    let mut b = pick(
        &lin.b,
        &independent,
        &(0..lin.b.ncols()).collect::<Vec<_>>(),
    );
    let mut c = &lin.c * &lift;
    let mut names: Vec<String> = independent
        .iter()
        .map(|&i| lin.state_names[i].clone())
        .collect();
    let mut index = independent.clone();
    let mut dropped_names = Vec::new();
    if let Some(keep) = keep {
        let mut chosen = Vec::new();
        for name in keep {
            let at = names.iter().position(|s| s == name).ok_or_else(|| {
                let why = if lin.state_names.contains(name) {
                    "is a dependent state (computed from the constraints)"
                } else {
                    "is not a state"
                };
                format!("{}: cannot keep {name}: it {why}", M::name())
            })?;
            chosen.push(at);
        }
        let dropped: Vec<usize> = (0..names.len()).filter(|i| !chosen.contains(i)).collect();
        for &j in &dropped {
            for &i in &chosen {
                // Zero to rounding: the entries of A are sums of O(‖A‖) terms.
                if a[(i, j)].abs() > DROP_TOLERANCE * a.amax() {
                    return Err(format!(
                        "{}: cannot drop {}: the derivative of {} depends on it (∂/∂ = {:e}); keep it too",
                        M::name(),
                        names[j],
                        names[i],
                        a[(i, j)]
                    ));
                }
            }
        }
        let all_inputs: Vec<usize> = (0..b.ncols()).collect();
        let all_outputs: Vec<usize> = (0..c.nrows()).collect();
        a = pick(&a, &chosen, &chosen);
        b = pick(&b, &chosen, &all_inputs);
        c = pick(&c, &all_outputs, &chosen);
        dropped_names = dropped.iter().map(|&i| names[i].clone()).collect();
        index = chosen.iter().map(|&i| index[i]).collect();
        names = chosen.iter().map(|&i| names[i].clone()).collect();
    }
    let mut out = lin.clone();
    out.state_index = index;
    out.eliminated = dependent
        .iter()
        .map(|&i| lin.state_names[i].clone())
        .collect();
    out.dropped = dropped_names;
    out.state_names = names;
    out.a = a;
    out.b = b;
    out.c = c;
    Ok(out)
}
