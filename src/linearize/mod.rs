//! Linearisation for control design: `δẋ = A δx + B δu`, `δy = C δx + D δu` at an
//! operating point, with exact derivatives (forward-mode dual numbers; finite
//! differences are only a test oracle), and an optional trim (Newton with the exact
//! Jacobian) that first finds an equilibrium.
//!
//! The outputs `y` are the FMU's outputs in FMI order: the states, then the extra
//! outputs. So `C = [I; ∂g/∂x]` and `D = [0; ∂g/∂u]`: an output equal to a state has
//! derivative 1 with respect to that state.

mod format;

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
    /// parameter, state or input).
    pub fn from_start_values<M: System>(overrides: &[(String, f64)]) -> Result<Self, String> {
        let layout = Layout::of::<M>();
        let mut op = OperatingPoint {
            t: 0.0,
            x: M::states().iter().map(|v| v.start).collect(),
            u: M::inputs().iter().map(|v| v.start).collect(),
            p: M::parameters().iter().map(|v| v.start).collect(),
        };
        for (name, value) in overrides {
            let vr = layout
                .vr_of(name)
                .ok_or_else(|| format!("{} has no variable named {name}", M::NAME))?;
            let slot = layout.slot(vr).expect("vr from the layout");
            let target = match slot.kind {
                VarKind::Parameter => &mut op.p,
                VarKind::State => &mut op.x,
                VarKind::Input => &mut op.u,
                _ => {
                    return Err(format!(
                        "{name} is not a parameter, state or input of {}",
                        M::NAME
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
        model: M::NAME,
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
