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

/// A joint held at q̈ = 0 (or brought to a velocity, at an impact) by a reaction λ bounded
/// to `[lo, hi]`: a stop pushes only (one bound 0, or the joint's friction where it has
/// some: friction holds it where the load pulls it off), a stuck joint's friction holds
/// it within ±F (Coulomb).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Held {
    coordinate: usize,
    lo: f64,
    hi: f64,
    /// The stop it is on (the limit's index, the side), if any.
    stop: Option<(usize, Side)>,
}

impl Held {
    /// On the stop of `limit` (index `k`) on `side`, with friction `f` (0: none).
    fn on_stop(k: usize, limit: &PositionLimit, side: Side, f: f64) -> Held {
        let (lo, hi) = match side {
            Side::Lower => (-f, f64::INFINITY),
            Side::Upper => (f64::NEG_INFINITY, f),
        };
        Held {
            coordinate: limit.coordinate,
            lo,
            hi,
            stop: Some((k, side)),
        }
    }
}

/// Reactions λ on the joints `set` that make each one's velocity or acceleration change
/// by `change` (through `w`, the columns of `M⁻¹` for `set`), each within its bounds: where
/// one comes out beyond, the worst (by the acceleration its excess makes, `(M⁻¹)_kk ·
/// excess`) is let go at its bound, that force applied, and the rest solved again. Returns
/// the joints kept with their λ, and those let go with the force they keep (a joint
/// slipping at its friction; 0 for a stop let go). Not the exact complementarity solution
/// where several coupled joints are let go at once, but each one let go is one whose bound
/// could not hold it.
fn reactions<S: Scalar>(
    mut set: Vec<Held>,
    mut w: Vec<Vec<S>>,
    mut change: Vec<S>,
) -> (Vec<Held>, Vec<S>, Vec<(usize, f64)>) {
    let mut let_go = Vec::new();
    loop {
        let mut a: Vec<Vec<S>> = set
            .iter()
            .map(|h| w.iter().map(|col| col[h.coordinate]).collect())
            .collect();
        let mut lambda = change.clone();
        crate::model::lagrangian::solve(&mut a, &mut lambda);
        // An excess is judged by the acceleration (or velocity change) it makes: one below
        // RELEASE is rounding of a reaction at its bound (a limb resting on its stop
        // unloaded), and letting go on rounding would make the joint chatter.
        let worst = set
            .iter()
            .zip(&lambda)
            .enumerate()
            .map(|(k, (h, l))| {
                let l = l.re();
                let excess = (l - h.hi).max(h.lo - l).max(0.0);
                (k, excess * w[k][h.coordinate].re())
            })
            .filter(|&(_, excess)| excess > RELEASE)
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let Some((k, _)) = worst else {
            return (set, lambda, let_go);
        };
        let h = set.remove(k);
        let col = w.remove(k);
        let bound = lambda[k].re().clamp(h.lo, h.hi);
        change.remove(k);
        for (c, other) in change.iter_mut().zip(&set) {
            *c -= col[other.coordinate] * bound;
        }
        let_go.push((h.coordinate, bound));
    }
}

/// q̈ (`qdd`, from `free`, the forward dynamics at this q, the slipping joints' friction
/// included) of the joints held: those resting on a stop (`limits`) and, with `friction`
/// (per coordinate, 0: none; empty: none anywhere), those at rest
/// ([`friction::at_rest`](super::friction::at_rest)). Each is
/// made 0 where its bounded reaction can hold it (a stop pushes; friction holds within ±F),
/// the others' changed by the reactions; a joint the bound cannot hold moves, its friction
/// at the bound. Each limit's reaction into `stop_out` and each coordinate's friction force
/// into `friction_out` when given (0 where none acts; a stuck joint on its stop: the stop's
/// reaction where it pushes into the stop, else friction's). `free(q̇, τ, q̈)`: the
/// unconstrained q̈ at this q.
pub fn hold<S: Scalar>(
    (limits, friction): (&[PositionLimit], &[f64]),
    (q, qd): (&[S], &[S]),
    qdd: &mut [S],
    (mut stop_out, mut friction_out): (Option<&mut [S]>, Option<&mut [S]>),
    free: impl Fn(&[S], &[S], &mut [S]),
) {
    for out in [stop_out.as_deref_mut(), friction_out.as_deref_mut()]
        .into_iter()
        .flatten()
    {
        out.fill(S::zero());
    }
    let stuck = |c: usize| {
        friction
            .get(c)
            .is_some_and(|&f| super::friction::at_rest(f, qd[c].re()))
    };
    if !any_resting(limits, q, qd) && !(0..qd.len()).any(stuck) {
        return;
    }
    let f_of = |c: usize| friction.get(c).copied().unwrap_or(0.0);
    let re = |v: &[S]| v.iter().map(|x| x.re()).collect::<Vec<f64>>();
    let mut set: Vec<Held> = resting(limits, &re(q), &re(qd))
        .into_iter()
        .map(|(k, side)| Held::on_stop(k, &limits[k], side, f_of(limits[k].coordinate)))
        .collect();
    for c in (0..qd.len()).filter(|&c| stuck(c)) {
        if !set.iter().any(|h| h.coordinate == c) {
            let f = f_of(c);
            set.push(Held {
                coordinate: c,
                lo: -f,
                hi: f,
                stop: None,
            });
        }
    }
    // Unloaded (every held joint's free q̈ is rounding, a robot at rest under its holding
    // torques or falling freely): the reactions are ~0, within any bound; no solve (it
    // costs a forward dynamics per held joint, a floating robot's with mimics O(n²) each).
    if set.iter().all(|h| qdd[h.coordinate].re().abs() <= RELEASE) {
        for h in &set {
            qdd[h.coordinate] = S::zero();
        }
        return;
    }
    let at: Vec<usize> = set.iter().map(|h| h.coordinate).collect();
    let w = inverse_mass_columns(qd.len(), &at, &free);
    let column = |c: usize| &w[at.iter().position(|&a| a == c).expect("held")];
    let change = at.iter().map(|&c| -qdd[c]).collect();
    let (kept, lambda, let_go) = reactions(set.clone(), w.clone(), change);
    for &(c, force) in &let_go {
        qdd.iter_mut()
            .zip(column(c))
            .for_each(|(a, &wc)| *a += wc * force);
        if let Some(out) = friction_out.as_deref_mut() {
            out[c] = S::from(force);
        }
    }
    for (h, &l) in kept.iter().zip(&lambda) {
        qdd.iter_mut()
            .zip(column(h.coordinate))
            .for_each(|(a, &wc)| *a += wc * l);
        let pushes = |side: Side| l.re() * side.into() <= 0.0;
        match h.stop {
            Some((k, side)) if pushes(side) => {
                if let Some(out) = stop_out.as_deref_mut() {
                    out[k] = l;
                }
            }
            _ => {
                if let Some(out) = friction_out.as_deref_mut() {
                    out[h.coordinate] = l;
                }
            }
        }
    }
    // Exactly at rest: no rounding left to move it.
    for h in &kept {
        qdd[h.coordinate] = S::zero();
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
        // An impact's impulses: the stops' only (friction is a bounded force, no impulse).
        let held: Vec<Held> = set
            .iter()
            .map(|&(c, side)| {
                let k = limits
                    .iter()
                    .position(|l| l.coordinate == c)
                    .expect("a limit");
                Held::on_stop(k, &limits[k], side, 0.0)
            })
            .collect();
        let change = at.iter().map(|&c| goal(c) - before[c]).collect();
        let (kept, lambda, _) = reactions(held, w.clone(), change);
        qd.copy_from_slice(&before);
        for (h, &l) in kept.iter().zip(&lambda) {
            let col = &w[at
                .iter()
                .position(|&a| a == h.coordinate)
                .expect("kept from at")];
            qd.iter_mut().zip(col).for_each(|(v, &wc)| *v += wc * l);
        }
        for h in &kept {
            qd[h.coordinate] = goal(h.coordinate);
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
