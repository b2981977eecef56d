//! Consistent initialisation of constrained systems: the user sets the independent
//! states, the constraints give the dependent ones.
//!
//! A system with constraints on its state (position constraints Φ(t, q) = 0, velocity
//! constraints G q̇ = 0 and A(q) q̇ = 0) declares, once, which of its states are
//! *dependent* ([`Var::dependent`](super::Var::dependent)) and how many residuals
//! [`System::state_constraints`] returns; there must be as many residuals as dependent
//! states, or more where some are redundant (Bricard's loop: Gauss-Newton then). [`solve`] then keeps every independent state exactly as set and solves the
//! residuals for the dependent ones by Newton's method with the exact Jacobian (dual
//! numbers): the position constraints are nonlinear (the slider-crank's rod angle from
//! its crank angle), the velocity constraints linear in the velocities, and one Newton
//! iteration on both together solves the velocities exactly once the positions have
//! converged. The dependent states' current values are the starting guess, so where
//! the constraints have several roots (the rod above or below the axis) the start value
//! picks one — FMI's `initial="approx"`.

use super::{System, VarKind};
use crate::model::lagrangian::solve_full_rank;
use crate::model::Layout;
use num_dual::Dual64;

/// Newton iterations allowed (quadratic convergence needs ~5 from a guess within the
/// basin; more means no consistent state is near the guess).
const MAX_ITERATIONS: usize = 50;

/// Relative size of a Newton step below which the iteration has converged to rounding.
const STEP_TOLERANCE: f64 = 1e-13;

/// Largest constraint residual accepted at convergence, relative to the state's size:
/// Newton ends at rounding (~1e-15); a least-squares point of constraints that cannot all
/// hold ends far above.
const RESIDUAL_TOLERANCE: f64 = 1e-9;

/// The indices (into the state vector) of the states declared dependent.
pub fn dependent_states<M: System>() -> Vec<usize> {
    M::states()
        .iter()
        .enumerate()
        .filter(|(_, v)| v.dependent)
        .map(|(i, _)| i)
        .collect()
}

/// The constraint residuals at `x` (empty where the system holds no constraint there).
pub fn residuals<M: System>(t: f64, x: &[f64], p: &[f64]) -> Vec<f64> {
    let mut r = vec![0.0; M::STATE_CONSTRAINTS];
    if M::state_constraints(t, x, p, &mut r) {
        r
    } else {
        Vec::new()
    }
}

/// Solves the state constraints for the dependent states of `x`, keeping the independent
/// ones bit for bit. Does nothing for a system without constraints (or where they do not
/// hold at this state: a mode variable). On failure (no consistent state near the
/// current values, a singular constraint Jacobian) `x` is left unchanged and the error
/// says which constraint could not be met.
pub fn solve<M: System>(t: f64, p: &[f64], x: &mut [f64]) -> Result<(), String> {
    if M::STATE_CONSTRAINTS == 0 || residuals::<M>(t, x, p).is_empty() {
        return Ok(());
    }
    let dependent = dependent_states::<M>();
    if dependent.len() > M::STATE_CONSTRAINTS {
        return Err(format!(
            "{} declares {} state constraints but {} dependent states: initialisation needs at most as many dependent states as constraints",
            M::name(),
            M::STATE_CONSTRAINTS,
            dependent.len()
        ));
    }
    let mut trial = x.to_vec();
    let mut converged = false;
    for _ in 0..MAX_ITERATIONS {
        let (r, jac) = residuals_and_jacobian::<M>(t, &trial, p, &dependent);
        if r.iter().any(|v| !v.is_finite()) {
            break;
        }
        // Redundant constraints (more than the dependent states): Gauss-Newton, whose step
        // is Newton's on the independent equations among them.
        let Some(step) = solve_full_rank(jac, r) else {
            return Err(format!(
                "{}: the constraints cannot be solved for the dependent states ({}) here: their Jacobian is singular",
                M::name(),
                names::<M>(&dependent)
            ));
        };
        let mut small = true;
        for (&i, s) in dependent.iter().zip(&step) {
            small &= s.abs() <= STEP_TOLERANCE * trial[i].abs().max(1.0);
            trial[i] -= s;
        }
        if small {
            converged = true;
            break;
        }
    }
    let r = residuals::<M>(t, &trial, p);
    let worst = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // Redundant constraints that cannot all hold (their geometry inconsistent) converge to
    // a least-squares point: the residual left says so.
    let scale = trial.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    if !converged || !worst.is_finite() || worst > RESIDUAL_TOLERANCE * scale {
        return Err(format!(
            "{}: no consistent state near the values set: Newton on the constraints for {} did not converge (residual {worst:e}); check the independent values and the start values of the dependent ones",
            M::name(),
            names::<M>(&dependent)
        ));
    }
    x.copy_from_slice(&trial);
    Ok(())
}

/// The residuals and their Jacobian with respect to the states `columns` (a row per
/// residual, a column per listed state), one dual-number evaluation per column: square
/// for the dependent states (Newton here), all states for [`linearize::reduced`](crate::linearize::reduced).
pub fn residuals_and_jacobian<M: System>(
    t: f64,
    x: &[f64],
    p: &[f64],
    columns: &[usize],
) -> (Vec<f64>, Vec<Vec<f64>>) {
    let k = M::STATE_CONSTRAINTS;
    let pd: Vec<Dual64> = p.iter().map(|&v| Dual64::from(v)).collect();
    let mut jac = vec![vec![0.0; columns.len()]; k];
    let mut r = vec![0.0; k];
    let mut out = vec![Dual64::from(0.0); k];
    for (col, &j) in columns.iter().enumerate() {
        let mut xd: Vec<Dual64> = x.iter().map(|&v| Dual64::from(v)).collect();
        xd[j].eps = 1.0;
        M::state_constraints(t, &xd, &pd, &mut out);
        for (row, v) in out.iter().enumerate() {
            jac[row][col] = v.eps;
            r[row] = v.re;
        }
    }
    (r, jac)
}

fn names<M: System>(indices: &[usize]) -> String {
    let states = M::states();
    indices
        .iter()
        .map(|&i| states[i].name.as_ref())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Two values agree when they differ by at most this, relative to the larger of their
/// magnitude and the variable's nominal: a value computed by hand in double precision
/// from the closed form (a scene's) passes; a different value does not.
const AGREEMENT: f64 = 1e-10;

/// The dependent states the user set (`set[i]`) to a value the constraints changed:
/// one line each, naming the variable, the value set and the value used.
pub fn overridden<M: System>(
    layout: &Layout,
    t: f64,
    p: &[f64],
    set: &[bool],
    before: &[f64],
    after: &[f64],
) -> Vec<String> {
    let states = M::states();
    let mut lines = Vec::new();
    for (i, v) in states.iter().enumerate() {
        if !(v.dependent && set.get(i).copied().unwrap_or(false)) {
            continue;
        }
        let scale = before[i]
            .abs()
            .max(after[i].abs())
            .max(v.nominal.unwrap_or(1.0));
        if (before[i] - after[i]).abs() > AGREEMENT * scale {
            let vr = layout.vr_of_slot(VarKind::State, i);
            lines.push(format!(
                "{} (value reference {vr}) was set to {} but the constraints give {} from the values of {}: {} is used",
                v.name,
                before[i],
                after[i],
                solved_from::<M>(t, p, after),
                after[i],
            ));
        }
    }
    lines
}

/// The independent states the constraints involve at `x`: what the dependent ones are
/// computed from.
fn solved_from<M: System>(t: f64, p: &[f64], x: &[f64]) -> String {
    let pd: Vec<Dual64> = p.iter().map(|&v| Dual64::from(v)).collect();
    let mut out = vec![Dual64::from(0.0); M::STATE_CONSTRAINTS];
    let states = M::states();
    let involved = (0..x.len()).filter(|&j| {
        let mut xd: Vec<Dual64> = x.iter().map(|&v| Dual64::from(v)).collect();
        xd[j].eps = 1.0;
        M::state_constraints(t, &xd, &pd, &mut out);
        !states[j].dependent && out.iter().any(|v| v.eps != 0.0)
    });
    involved
        .map(|j| states[j].name.as_ref())
        .collect::<Vec<_>>()
        .join(", ")
}
