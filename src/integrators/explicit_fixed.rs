//! The explicit fixed-step methods besides RK4 (explicit and symplectic Euler, velocity
//! Verlet): one entry, one loop and one pair of buffers for all three. Each step evaluates f
//! at its start and hands it to the method's own update ([`super::euler`], [`super::verlet`]).

use super::buffers::sized;
use super::problem::{fixed_steps, FixedCall, Problem};
use super::{euler, verlet, Failure, Method};

/// `method` (explicit Euler, symplectic Euler or velocity Verlet) for one [`FixedCall`], in
/// the buffers `work` (the new state and f): no allocation once they have held this size.
/// Same conventions as [`super::advance`]. Explicit Euler needs only `problem.rhs`; the other
/// two need `problem.second_order = Some(nq)` with `x.len() == 2·nq`.
pub fn advance_in(
    method: Method,
    problem: &mut Problem,
    call: FixedCall,
    work: &mut [Vec<f64>; 2],
) -> Result<(), Failure> {
    let name = match method {
        Method::ExplicitEuler => "explicit Euler",
        Method::SymplecticEuler => "symplectic Euler",
        Method::Verlet => "Störmer–Verlet",
        other => panic!("{} is not an explicit fixed-step method", other.name()),
    };
    let nq = if method.needs_second_order() {
        problem.positions(name, call.x.len())
    } else {
        0
    };
    let [y, k] = work;
    let k = sized(k, call.x.len());
    fixed_steps(name, call, y, |stats, ta, tb, x, y| {
        let hs = tb - ta;
        if !problem.eval(ta, x, k, stats) {
            return Err(Failure::NonFinite { t: ta });
        }
        match method {
            Method::ExplicitEuler => euler::explicit(hs, x, k, y),
            Method::SymplecticEuler => euler::symplectic(nq, hs, x, k, y),
            _ => verlet::kick_drift_kick(problem, stats, nq, (ta, tb), x, k, y)?,
        }
        Ok(())
    })
}
