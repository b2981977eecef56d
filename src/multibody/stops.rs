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

use crate::model::Scalar;

/// A joint position limit on one coordinate.
#[derive(Clone, Debug, PartialEq)]
pub struct PositionLimit {
    pub coordinate: usize,
    pub lower: f64,
    pub upper: f64,
}

/// A rebound that would rise less than this (rad, or m) above its stop under the load at
/// the impact, `(e v)² / (2 |q̈|)`, rests instead: far below any tolerance a user sets.
pub const REST_HEIGHT: f64 = 1e-9;

/// A stop lets go only where holding the joint would take a pull that accelerates it by
/// more than this (rad/s², or m/s²; at an impact, rad/s or m/s): far above the rounding of
/// a reaction that is ~0, far below anything a tolerance would resolve.
pub const RELEASE: f64 = 1e-9;

/// A joint this close to its stop (rad, or m) when an impulse drives it in takes part in
/// the impact ([`impact`]) instead of hitting the stop a moment later on its own.
pub const CONTACT: f64 = 1e-9;

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
        // A stop pushes: λ against the side it is on (λ · into ≤ 0). A pull is judged by
        // the acceleration (or velocity change) it makes, (M⁻¹)_kk λ: one below RELEASE is
        // rounding of a reaction that is ~0 (a limb resting on its stop unloaded), and
        // letting go on rounding would make the joint chatter on and off its stop.
        let pulling = set
            .iter()
            .zip(&lambda)
            .enumerate()
            .map(|(k, (&(c, side), l))| (k, l.re() * side.into() * w[k][c].re()))
            .filter(|&(_, pull)| pull > RELEASE)
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
    let w = inverse_mass_columns(qd.len(), &at, &free);
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
/// rests, when the rebound would rise less than [`REST_HEIGHT`] under the load there), the
/// joints already resting stay at rest, and every other velocity changes by the impulses.
/// A joint within [`CONTACT`] of its stop that the impulse drives into it joins the same
/// impact (put on its stop, coming to rest): impacts through the mass matrix are
/// simultaneous, else two coupled joints would knock each other into their stops in turn,
/// a geometric series of events. Returns whether anything changed. `free(q, q̇, τ, q̈)`:
/// the unconstrained q̈; `u` the inputs.
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
    let n = qd.len();
    let before = qd.to_vec();
    let mut loaded = vec![0.0; n];
    free(q, qd, u, &mut loaded);
    let target = |c: usize, side: Side| -> f64 {
        let rebound = -restitution * before[c];
        let push = loaded[c] * side.into();
        if before[c] * side.into() <= 0.0
            || push > 0.0 && rebound * rebound < 2.0 * push * REST_HEIGHT
        {
            0.0
        } else {
            rebound
        }
    };
    let resting_set: Vec<(usize, Side)> = resting(limits, q, &before)
        .into_iter()
        .map(|(k, side)| (limits[k].coordinate, side))
        .collect();
    for _ in 0..=limits.len() {
        let mut set: Vec<(usize, Side)> = hits.clone();
        set.extend(
            resting_set
                .iter()
                .filter(|&&(c, _)| !hits.iter().any(|&(h, _)| h == c)),
        );
        let goals: Vec<f64> = set
            .iter()
            .map(|&(c, side)| {
                if hits.iter().any(|&(h, _)| h == c) {
                    target(c, side)
                } else {
                    0.0
                }
            })
            .collect();
        let at: Vec<usize> = set.iter().map(|&(c, _)| c).collect();
        let qf = q.to_vec();
        let w = inverse_mass_columns(n, &at, &|v: &[f64], tau: &[f64], out: &mut [f64]| {
            free(&qf, v, tau, out)
        });
        let goal = |c: usize| goals[at.iter().position(|&a| a == c).expect("in the set")];
        let (kept, lambda) = reactions(set, w.clone(), |c| goal(c) - before[c]);
        qd.copy_from_slice(&before);
        for (&(c, _), &l) in kept.iter().zip(&lambda) {
            let col = &w[at.iter().position(|&a| a == c).expect("kept from at")];
            qd.iter_mut().zip(col).for_each(|(v, &wc)| *v += wc * l);
        }
        for &(c, _) in &kept {
            qd[c] = goal(c);
        }
        // Joints at their stop that the impulse drives into it: part of this impact.
        let mut more = false;
        for l in limits {
            let i = l.coordinate;
            if at.contains(&i) {
                continue;
            }
            let side = if q[i] - l.lower <= l.upper - q[i] {
                Side::Lower
            } else {
                Side::Upper
            };
            if (q[i] - l.stop(side)).abs() <= CONTACT && qd[i] * side.into() > 0.0 {
                q[i] = l.stop(side);
                hits.push((i, side));
                more = true;
            }
        }
        if !more {
            break;
        }
    }
    true
}
