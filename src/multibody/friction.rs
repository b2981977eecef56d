//! Coulomb friction at the joints (URDF `<dynamics friction>`): a generalised force of
//! magnitude F opposing a joint's motion, which holds a joint at rest as long as the load
//! on it needs no more than F.
//!
//! The model is the set-valued law, not a smooth approximation of it: a joint that slips
//! feels `−F sign(q̇)`; a joint at rest is stuck, held at q̈ = 0 by a friction force
//! within ±F ([`stops::hold`](super::stops::hold), the same bounded solve as a joint
//! resting on its end stop), and breaks away, at the bound, where the load needs more.
//!
//! Coming to rest is an event, and what it must not be is a sign flip inside a step: an
//! integrator stepping over q̇ = 0 would meet a force that turns with q̇ and, under a load
//! below F, chatter around 0 in ever smaller steps. So a joint whose speed is within
//! [`STICK`] of 0 counts as at rest (held while its bound holds it: nothing pushes it back
//! out), entering that band is the event (a factor of the event indicator, `sign(q̇) (|q̇| −
//! STICK)`), and at the event the joint is put exactly at rest ([`stick`]); the held solve
//! then decides whether it stays or slips back the other way. A joint breaking away
//! crosses the band speeding up, which is no event.
//!
//! No state of its own: whether a joint sticks is read from q̇, as whether a joint rests on
//! a stop is. A mimic joint's friction acts on the joint it follows through the
//! multiplier: `|r| F`. A model layer: it knows no FMI.

use crate::model::Scalar;

/// A joint with friction whose speed is at most this (rad/s, or m/s) is at rest (see the
/// module's text): far below what a tolerance resolves, far above what locating the
/// event leaves (~1e-13: the bisection in time times q̈).
pub const STICK: f64 = 1e-9;

/// Whether any joint has friction.
pub fn any(friction: &[f64]) -> bool {
    friction.iter().any(|&f| f > 0.0)
}

/// Whether a joint with friction `f` moving at `v` is at rest: held by its friction, or
/// breaking away (see the module's text).
pub fn at_rest(f: f64, v: f64) -> bool {
    f > 0.0 && v.abs() <= STICK
}

/// `u` less the slipping joints' friction, `F sign(q̇)` (a joint at rest gets its friction
/// from the held solve, [`stops::hold`](super::stops::hold)).
pub fn slip<S: Scalar>(friction: &[f64], qd: &[S], u: &mut [S]) {
    for ((u, &f), v) in u.iter_mut().zip(friction).zip(qd) {
        if f > 0.0 && !at_rest(f, v.re()) {
            *u -= S::from(f * v.re().signum());
        }
    }
}

/// Whether some joint is in the band at rest without being exactly at rest (the event
/// indicator then needs q̈: [`factors`]).
pub fn any_in_band(friction: &[f64], qd: &[f64]) -> bool {
    friction
        .iter()
        .zip(qd)
        .any(|(&f, &v)| at_rest(f, v) && v != 0.0)
}

/// Whether a joint in the band, with acceleration `a`, is coming to rest (held there, or
/// slowing down) rather than breaking away.
fn settling(v: f64, a: f64) -> bool {
    a == 0.0 || v * a < 0.0
}

/// The event indicator's factors friction adds: `sign(q̇) (|q̇| − STICK)` for every joint
/// with friction not exactly at rest, except one in the band breaking away (`qdd`, the
/// accelerations, needed only where [`any_in_band`]). Each changes sign where its joint
/// enters the band from either side, and where a step takes it over the band (a fixed
/// step, or an adaptive one that straddles it).
pub fn factors<'a>(
    friction: &'a [f64],
    qd: &'a [f64],
    qdd: Option<&'a [f64]>,
) -> impl Iterator<Item = f64> + 'a {
    friction
        .iter()
        .zip(qd)
        .enumerate()
        .filter(move |&(k, (&f, &v))| {
            f > 0.0 && v != 0.0 && (!at_rest(f, v) || qdd.is_some_and(|a| settling(v, a[k])))
        })
        .map(|(_, (_, &v))| v.signum() * (v.abs() - STICK))
}

/// One event indicator from several that each cross 0 at an event: the product of their
/// signs times the smallest magnitude. Continuous (it goes to 0 as any factor does) and it
/// changes sign where one factor does. `None` without factors.
pub fn one_indicator(factors: impl Iterator<Item = f64>) -> Option<f64> {
    factors.fold(None, |acc: Option<f64>, f| {
        Some(match acc {
            None => f,
            Some(g) => g.signum() * f.signum() * g.abs().min(f.abs()),
        })
    })
}

/// At an event: every joint in the band coming to rest (held, or slowing down: `qdd` the
/// accelerations at this state) is put exactly at rest. A joint breaking away is left
/// moving. Returns whether anything changed.
pub fn stick(friction: &[f64], qd: &mut [f64], qdd: &[f64]) -> bool {
    let mut changed = false;
    for ((v, &f), &a) in qd.iter_mut().zip(friction).zip(qdd) {
        if at_rest(f, *v) && *v != 0.0 && settling(*v, a) {
            *v = 0.0;
            changed = true;
        }
    }
    changed
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_indicator_changes_sign_where_a_factor_does_and_is_continuous() {
        assert_eq!(one_indicator(std::iter::empty()), None);
        assert_eq!(one_indicator([0.5].into_iter()), Some(0.5));
        assert_eq!(one_indicator([0.5, -0.25, 2.0].into_iter()), Some(-0.25));
        assert_eq!(one_indicator([-0.5, -0.25].into_iter()), Some(0.25));
        // A factor going through 0 takes the indicator through 0 with it.
        let g = |x: f64| one_indicator([1.0, x, -3.0].into_iter()).unwrap();
        assert!(g(1e-12) < 0.0 && g(-1e-12) > 0.0 && g(1e-12).abs() <= 1e-12);
    }

    #[test]
    fn only_a_joint_slowing_to_rest_is_stuck() {
        let friction = [1.0, 1.0, 0.0, 1.0, 1.0];
        let mut qd = [1e-12, -1e-12, 1e-12, 0.5, 1e-12];
        // Slowing down; speeding up (a breakaway); no friction; not near rest; held.
        let qdd = [-1.0, -1.0, -1.0, -1.0, 0.0];
        let factors: Vec<f64> = factors(&friction, &qd, Some(&qdd)).collect();
        assert_eq!(factors, [1e-12 - STICK, 0.5 - STICK, 1e-12 - STICK]);
        // Over the band: the factor changes sign.
        let over: Vec<f64> = super::factors(&[1.0], &[-1e-3], None).collect();
        assert!(over[0] < 0.0 && (0.5 - STICK) > 0.0);
        assert!(stick(&friction, &mut qd, &qdd));
        assert_eq!(qd, [0.0, -1e-12, 1e-12, 0.5, 0.0]);
        assert!(!stick(&friction, &mut qd, &qdd));
    }

    #[test]
    fn slip_opposes_the_motion_and_leaves_a_stuck_joint_to_the_hold() {
        let mut u = [1.0, 1.0, 1.0, 1.0];
        slip(&[0.5, 0.5, 0.5, 0.0], &[2.0, -2.0, 1e-10, 2.0], &mut u);
        assert_eq!(u, [0.5, 1.5, 1.0, 1.0]);
    }
}
