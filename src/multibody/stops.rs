//! End stops: a joint's position limits as the physical stops they are.
//!
//! A joint that reaches a stop moving into it is an impact (located as an event by the
//! FMU): its velocity becomes −e times what it was (restitution e), the other joints'
//! velocities change by the same impulse through the mass matrix, and its position is put
//! on the stop exactly. A joint resting on a stop (exactly on it, velocity exactly 0) is
//! held there while the load pushes into it: its q̈ is 0 and the stop's reaction is the
//! generalised force that makes it so; where the reaction would have to pull, the joint
//! leaves. Both are the same small solve: with `w_c = M⁻¹ e_c` the columns of the inverse
//! mass matrix for the constrained joints C (taken from the forward dynamics itself: q̈ at
//! zero velocity with a unit force on c, less q̈ with none), the reactions λ solve
//! `W λ = target − value` on C with `W = [w_c]_C`, and every velocity (or acceleration)
//! changes by `Σ w_c λ_c`. A constrained joint whose λ comes out pulling is released and
//! the rest solved again (an active set: one joint at a time, the worst first).
//!
//! A rebound that would rise less than [`REST_HEIGHT`] is taken as resting (the joint
//! stays on the stop): otherwise a joint bouncing under a load with 0 < e < 1 would make
//! infinitely many impacts in finite time.
//!
//! No state of its own: whether a joint rests is read from (q, q̇), so the FMU's state,
//! its saved states and Model Exchange's importer hold all there is. A model layer: it
//! knows no FMI.

use super::fmu::PositionLimit;
use crate::model::Scalar;

/// A rebound that would rise less than this (rad, or m) above its stop under the load at
/// the impact, `(e v)² / (2 |q̈|)`, rests instead: far below any tolerance a user sets.
pub const REST_HEIGHT: f64 = 1e-9;

/// Which of its two stops a joint is on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    Lower,
    Upper,
}

impl Side {
    /// +1 for a velocity or force into the upper stop, −1 into the lower.
    fn into(self) -> f64 {
        match self {
            Side::Lower => -1.0,
            Side::Upper => 1.0,
        }
    }
}

impl PositionLimit {
    /// The stop `q` is on or beyond, if any.
    pub fn on(&self, q: f64) -> Option<Side> {
        if q <= self.lower {
            Some(Side::Lower)
        } else if q >= self.upper {
            Some(Side::Upper)
        } else {
            None
        }
    }

    /// The position of the stop on `side`.
    pub fn stop(&self, side: Side) -> f64 {
        match side {
            Side::Lower => self.lower,
            Side::Upper => self.upper,
        }
    }

    /// The signed distance to the nearer stop: positive between them.
    pub fn distance(&self, q: f64) -> f64 {
        (q - self.lower).min(self.upper - q)
    }
}

/// The joints resting on a stop: on it (or beyond) with velocity exactly 0, as an impact
/// or the start leaves them.
fn resting(limits: &[PositionLimit], q: &[f64], qd: &[f64]) -> Vec<(usize, Side)> {
    limits
        .iter()
        .enumerate()
        .filter_map(|(k, l)| {
            let i = l.coordinate;
            l.on(q[i]).filter(|_| qd[i] == 0.0).map(|side| (k, side))
        })
        .collect()
}

/// Whether some joint rests on a stop (cheap: no allocation, the common answer is no).
pub fn any_resting<S: Scalar>(limits: &[PositionLimit], q: &[S], qd: &[S]) -> bool {
    limits.iter().any(|l| {
        let i = l.coordinate;
        qd[i].re() == 0.0 && l.on(q[i].re()).is_some()
    })
}

/// The event indicator with end stops: the smallest signed distance to a stop, over the
/// joints not exactly on one (a joint on its stop gives 0 only while moving into it: the
/// impact to apply; resting or leaving, no event until it has left); `Some(1.0)` when
/// every limited joint is on its stop that way; `None` without limits.
pub fn indicator(limits: &[PositionLimit], q: &[f64], qd: &[f64]) -> Option<f64> {
    if limits.is_empty() {
        return None;
    }
    let nearest = limits
        .iter()
        .filter(|l| {
            let i = l.coordinate;
            match l.on(q[i]) {
                Some(side) if q[i] == l.stop(side) => qd[i] * side.into() > 0.0,
                _ => true,
            }
        })
        .map(|l| l.distance(q[l.coordinate]))
        .fold(f64::INFINITY, f64::min);
    Some(if nearest.is_finite() { nearest } else { 1.0 })
}

/// `w_c = M⁻¹ e_c` for each coordinate c in `at`, from the forward dynamics `free(q̇, τ,
/// q̈)` at zero velocity: q̈ with a unit force on c less q̈ with none (gravity and springs
/// cancel; damping is 0 at rest).
fn inverse_mass_columns<S: Scalar>(
    n: usize,
    at: &[usize],
    free: &impl Fn(&[S], &[S], &mut [S]),
) -> Vec<Vec<S>> {
    let zero = vec![S::zero(); n];
    let mut base = vec![S::zero(); n];
    free(&zero, &zero, &mut base);
    at.iter()
        .map(|&c| {
            let mut unit = zero.clone();
            unit[c] = S::one();
            let mut w = vec![S::zero(); n];
            free(&zero, &unit, &mut w);
            w.iter_mut().zip(&base).for_each(|(w, b)| *w -= *b);
            w
        })
        .collect()
}

/// Reactions λ on the joints `set` (coordinates, with the side of their stop) that take
/// `value` to `target` through `w` (the columns of `M⁻¹` for `set`), released one at a
/// time (the most pulling first) while one pulls: returns the joints kept and their λ.
fn reactions<S: Scalar>(
    mut set: Vec<(usize, Side)>,
    mut w: Vec<Vec<S>>,
    change: impl Fn(usize) -> S,
) -> (Vec<(usize, Side)>, Vec<S>) {
    loop {
        let mut a: Vec<Vec<S>> = set
            .iter()
            .map(|&(r, _)| w.iter().map(|col| col[r]).collect())
            .collect();
        let mut lambda: Vec<S> = set.iter().map(|&(c, _)| change(c)).collect();
        crate::model::lagrangian::solve(&mut a, &mut lambda);
        // A stop pushes: λ against the side it is on (λ · into ≤ 0).
        let pulling = set
            .iter()
            .zip(&lambda)
            .enumerate()
            .map(|(k, (&(_, side), l))| (k, l.re() * side.into()))
            .filter(|&(_, pull)| pull > 0.0)
            .max_by(|a, b| a.1.total_cmp(&b.1));
        match pulling {
            Some((k, _)) => {
                set.remove(k);
                w.remove(k);
            }
            None => return (set, lambda),
        }
    }
}

/// With end stops: q̈ (`qdd`, from `free`, the forward dynamics at this q) of the joints
/// resting on a stop made 0 where the load pushes them into it, the others' changed by the
/// reactions; each limit's reaction (generalised force, 0 where none acts) into
/// `reaction` when given. `free(q̇, τ, q̈)`: the unconstrained q̈ at this q.
pub fn hold<S: Scalar>(
    limits: &[PositionLimit],
    (q, qd): (&[S], &[S]),
    qdd: &mut [S],
    mut reaction: Option<&mut [S]>,
    free: impl Fn(&[S], &[S], &mut [S]),
) {
    if let Some(r) = reaction.as_deref_mut() {
        r.fill(S::zero());
    }
    if !any_resting(limits, q, qd) {
        return;
    }
    let re = |v: &[S]| v.iter().map(|x| x.re()).collect::<Vec<f64>>();
    let set: Vec<(usize, Side)> = resting(limits, &re(q), &re(qd))
        .into_iter()
        .map(|(k, side)| (limits[k].coordinate, side))
        .collect();
    let at: Vec<usize> = set.iter().map(|&(c, _)| c).collect();
    let w = inverse_mass_columns(q.len(), &at, &free);
    let (kept, lambda) = reactions(set, w.clone(), |c| -qdd[c]);
    for (&(c, _), &l) in kept.iter().zip(&lambda) {
        let col = &w[at.iter().position(|&a| a == c).expect("kept from at")];
        qdd.iter_mut().zip(col).for_each(|(a, &wc)| *a += wc * l);
        if let Some(r) = reaction.as_deref_mut() {
            let k = limits
                .iter()
                .position(|l| l.coordinate == c)
                .expect("a limit");
            r[k] = l;
        }
    }
    // Exactly at rest: no rounding left to move it off the stop.
    for &(c, _) in &kept {
        qdd[c] = S::zero();
    }
}

/// At an event with end stops: every joint on or beyond a stop and moving into it (or
/// resting beyond it) is put on the stop and rebounds with `−e` times its velocity (or
/// rests, when the rebound would rise less than [`REST_HEIGHT`] under `qdd_free`, the
/// unconstrained q̈ there), the joints already resting stay at rest, and every other
/// velocity changes by the impulses. Returns whether anything changed. `free(q, q̇, τ,
/// q̈)`: the unconstrained q̈; `u` the inputs.
pub fn impact(
    limits: &[PositionLimit],
    (q, qd, u): (&mut [f64], &mut [f64], &[f64]),
    restitution: f64,
    free: impl Fn(&[f64], &[f64], &[f64], &mut [f64]),
) -> bool {
    let mut hits: Vec<(usize, Side)> = Vec::new();
    for l in limits {
        let i = l.coordinate;
        let Some(side) = l.on(q[i]) else { continue };
        if qd[i] * side.into() > 0.0 || (qd[i] == 0.0 && q[i] != l.stop(side)) {
            q[i] = l.stop(side);
            hits.push((i, side));
        }
    }
    if hits.is_empty() {
        return false;
    }
    let n = q.len();
    let mut loaded = vec![0.0; n];
    free(q, qd, u, &mut loaded);
    let target = |c: usize, side: Side| -> f64 {
        let rebound = -restitution * qd[c];
        let push = loaded[c] * side.into();
        if push > 0.0 && rebound * rebound < 2.0 * push * REST_HEIGHT {
            0.0
        } else {
            rebound
        }
    };
    let mut set: Vec<(usize, Side)> = resting(limits, q, qd)
        .into_iter()
        .map(|(k, side)| (limits[k].coordinate, side))
        .filter(|&(c, _)| !hits.iter().any(|&(h, _)| h == c))
        .collect();
    let targets: Vec<(usize, f64)> = hits
        .iter()
        .map(|&(c, side)| (c, target(c, side)))
        .chain(set.iter().map(|&(c, _)| (c, 0.0)))
        .collect();
    set.splice(0..0, hits.iter().copied());
    let at: Vec<usize> = set.iter().map(|&(c, _)| c).collect();
    let qf = q.to_vec();
    let w = inverse_mass_columns(n, &at, &|v: &[f64], tau: &[f64], out: &mut [f64]| {
        free(&qf, v, tau, out)
    });
    let goal = |c: usize| targets.iter().find(|t| t.0 == c).expect("a target").1;
    let (kept, lambda) = reactions(set, w.clone(), |c| goal(c) - qd[c]);
    for (&(c, _), &l) in kept.iter().zip(&lambda) {
        let col = &w[at.iter().position(|&a| a == c).expect("kept from at")];
        qd.iter_mut().zip(col).for_each(|(v, &wc)| *v += wc * l);
    }
    for &(c, _) in &kept {
        qd[c] = goal(c);
    }
    true
}
