//! RATTLE, fixed step: the constrained Störmer–Verlet method for mechanical systems with
//! holonomic constraints `g(q) = 0` and a mass matrix that may depend on q. Second order,
//! symplectic on the constraint manifold, symmetric (time-reversible); the positions satisfy
//! `g(q) = 0` and the velocities the hidden constraint `G(q) q̇ = 0` after every step to the
//! Newton tolerance, with no projection. Without constraints it is the generalised
//! Störmer–Verlet (leapfrog) method, symplectic for any `T = ½ q̇ᵀ M(q) q̇` — which velocity
//! Verlet on `(q, q̇)` is not when M depends on q (angle or polar coordinates).
//!
//! Source: E. Hairer, C. Lubich, G. Wanner, *Geometric Numerical Integration*, 2nd ed.,
//! Springer 2006, Sect. VII.1.4, eq. (1.26) (RATTLE for general Hamiltonians), Theorems
//! VII.1.3–1.4 (symplectic, order 2); H. C. Andersen, J. Comput. Phys. 52 (1983) 24–34.
//!
//! In the momenta `p = ∂L/∂q̇ = M(q) q̇ + b(q)`, with `F(t, q, q̇) = ∂L/∂q + Q` (the Legendre
//! identity `∂H/∂q = −∂L/∂q` turns GNI's `−H_q` into `F`) and `v(q, p) = M(q)⁻¹ (p − b(q))`,
//! one step from `(q₀, p₀)` at t₀ to t₁ = t₀ + h is
//!
//! ```text
//! p½ = p₀ + h/2 (F(t₀, q₀, v(q₀, p½)) − G(q₀)ᵀ λ)
//! q₁ = q₀ + h/2 (v(q₀, p½) + v(q₁, p½))              } one Newton solve for (p½, q₁, λ)
//! 0  = g(q₁)
//! p₁ = p½ + h/2 (F(t₁, q₁, v(q₁, p½)) − G(q₁)ᵀ μ)
//! 0  = G(q₁) v(q₁, p₁)                               } linear in μ
//! ```
//!
//! The first solve is a simplified Newton iteration on all 2n + m unknowns with a
//! forward-difference Jacobian, formed once per step at the explicit predictor; it is
//! iterated to rounding (as Gauss is), so the constraint holds to rounding, not to a
//! tolerance. The sign convention of λ is that of [`crate::model::lagrangian`]:
//! `M q̈ + Gᵀ λ = F − (∂²L/∂q̇∂q) q̇`.

use super::problem::Mechanics;
use super::problem::{fixed_steps, ImplicitFailure, NEWTON_MAX_ITER, NEWTON_TOL};
use super::workspace::Workspace;
use super::{Failure, Stats};
use nalgebra::{DMatrix, DVector};

/// Everything about `q` that the step uses more than once.
struct AtQ {
    mass: DMatrix<f64>,
    lu: nalgebra::LU<f64, nalgebra::Dyn, nalgebra::Dyn>,
    b: DVector<f64>,
    g: DVector<f64>,
    jac: DMatrix<f64>,
}

impl AtQ {
    /// `None` if M(q) is singular or anything is not finite.
    fn new(mech: &mut dyn Mechanics, q: &[f64]) -> Option<AtQ> {
        let (n, m) = mech.dims();
        let mut mm = vec![0.0; n * n];
        mech.mass_matrix(q, &mut mm);
        let mut b = DVector::zeros(n);
        mech.momentum_offset(q, b.as_mut_slice());
        let mut g = DVector::zeros(m);
        let mut jac = vec![0.0; m * n];
        mech.constraints(q, g.as_mut_slice(), &mut jac);
        let finite = mm
            .iter()
            .chain(&jac)
            .chain(b.iter())
            .chain(g.iter())
            .all(|v| v.is_finite());
        let mass = DMatrix::from_row_slice(n, n, &mm);
        let lu = mass.clone().lu();
        (finite && lu.is_invertible()).then(|| AtQ {
            mass,
            lu,
            b,
            g,
            jac: DMatrix::from_row_slice(m, n, &jac),
        })
    }

    /// `v(q, p) = M⁻¹ (p − b)`.
    fn velocity(&self, p: &DVector<f64>) -> DVector<f64> {
        self.lu.solve(&(p - &self.b)).expect("invertible")
    }

    /// `p(q, q̇) = M q̇ + b`.
    fn momentum(&self, qd: &DVector<f64>) -> DVector<f64> {
        &self.mass * qd + &self.b
    }
}

/// RATTLE from `*t` to `t_end` with step `h` (the last step shortened; `h` not positive and
/// finite: one step), on the state `x = (q, q̇)` of the FMU: converted to `p` at the start and
/// back at the end of the call. `stats.rhs_evals` counts evaluations of `F`.
pub fn advance(
    mech: &mut dyn Mechanics,
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    h: f64,
    stats: &mut Stats,
) -> Result<(), ImplicitFailure> {
    advance_in(mech, t, x, t_end, h, stats, &mut Workspace::default())
}

/// [`advance`] in the scratch of `work`.
pub fn advance_in(
    mech: &mut dyn Mechanics,
    t: &mut f64,
    x: &mut [f64],
    t_end: f64,
    h: f64,
    stats: &mut Stats,
    work: &mut Workspace,
) -> Result<(), ImplicitFailure> {
    let (n, _) = mech.dims();
    assert_eq!(x.len(), 2 * n, "RATTLE: the state is (q, q̇)");
    if x.iter().all(|v| v.is_finite()) {
        let at = AtQ::new(mech, &x[..n]).ok_or(Failure::NonFinite { t: *t })?;
        let p = at.momentum(&DVector::from_column_slice(&x[n..]));
        x[n..].copy_from_slice(p.as_slice());
    }
    // The loop runs on (q, p); on failure the last good (q, p) is converted back.
    let y = &mut work.fixed[0];
    let result = fixed_steps("RATTLE", t, x, t_end, h, stats, y, |stats, ta, tb, x, y| {
        step(mech, stats, ta, tb, x, y)
    });
    if x.iter().all(|v| v.is_finite()) {
        if let Some(at) = AtQ::new(mech, &x[..n]) {
            let v = at.velocity(&DVector::from_column_slice(&x[n..]));
            x[n..].copy_from_slice(v.as_slice());
        }
    }
    result
}

/// An increment that stops shrinking while below this size is rounding noise and the iterate
/// is accepted (above it, divergence). Looser than Gauss's 1e-12: the momentum residual
/// carries the rounding of `F`, whose terms (∂T/∂q of a fast mechanism) can exceed its
/// value by orders of magnitude; measured noise on the slider-crank ~4e-12 of the momenta,
/// while the positions — and so `g(q₁)` — converge to ~1e-16.
const STALL: f64 = 1e-10;

/// The size of a Newton increment `dz` of `z = (p½, q₁, λ)`, max norm, each block against
/// the size of the terms of its equation: q₁ against `max(‖q₀‖, ‖q₁‖)`; p½ against
/// `max(‖p₀‖, ‖p½‖, h/2 ‖F‖, h/2 ‖Gᵀλ‖)` (at a turning point p is ~0 while the forces are
/// not, and the forces' rounding is what the iteration can resolve); λ by what it moves,
/// `h/2 ‖G₀ᵀ Δλ‖`, against the same momentum scale. (λ itself is determined only to the
/// rounding of `g(q₁)` divided by `h²/2 G M⁻¹ Gᵀ`, far coarser than ε|λ| at small h.)
fn increment_size(
    dz: &DVector<f64>,
    z: &DVector<f64>,
    (q0, p0): (&DVector<f64>, &DVector<f64>),
    g0: &DMatrix<f64>,
    hh_force: f64,
    hh: f64,
) -> f64 {
    let n = q0.len();
    let max = |v: &[f64]| v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let zs = z.as_slice();
    let lambda = z.rows(2 * n, z.len() - 2 * n);
    let dlambda = dz.rows(2 * n, z.len() - 2 * n);
    let constraint_force = hh * max((g0.transpose() * lambda).as_slice());
    let scale_p = max(p0.as_slice())
        .max(max(&zs[..n]))
        .max(hh_force)
        .max(constraint_force)
        .max(f64::MIN_POSITIVE);
    let scale_q = max(q0.as_slice())
        .max(max(&zs[n..2 * n]))
        .max(f64::MIN_POSITIVE);
    let dp = max(&dz.as_slice()[..n]) / scale_p;
    let dq = max(&dz.as_slice()[n..2 * n]) / scale_q;
    let dl = hh * max((g0.transpose() * dlambda).as_slice()) / scale_p;
    dp.max(dq).max(dl)
}

/// `F(t, q, q̇)`, counted.
fn force(
    mech: &mut dyn Mechanics,
    stats: &mut Stats,
    t: f64,
    q: &DVector<f64>,
    v: &DVector<f64>,
) -> DVector<f64> {
    stats.rhs_evals += 1;
    let mut f = DVector::zeros(q.len());
    mech.force(t, q.as_slice(), v.as_slice(), f.as_mut_slice());
    f
}

/// One RATTLE step from `(q₀, p₀) = x` at `ta` to `y` at `tb`.
fn step(
    mech: &mut dyn Mechanics,
    stats: &mut Stats,
    ta: f64,
    tb: f64,
    x: &[f64],
    y: &mut [f64],
) -> Result<(), ImplicitFailure> {
    let (n, m) = mech.dims();
    let h = tb - ta;
    let hh = 0.5 * h;
    let q0 = DVector::from_column_slice(&x[..n]);
    let p0 = DVector::from_column_slice(&x[n..]);
    let fail = |iterations| ImplicitFailure::NewtonFailed {
        t: ta,
        h,
        iterations,
    };
    let non_finite = || ImplicitFailure::Integration(Failure::NonFinite { t: ta });
    let at0 = AtQ::new(mech, q0.as_slice()).ok_or_else(non_finite)?;

    // Explicit predictor: the unconstrained leapfrog half step, λ = 0.
    let v0 = at0.velocity(&p0);
    let f_pred = force(mech, stats, ta, &q0, &v0);
    let hh_force = hh * f_pred.amax();
    let ph = &p0 + f_pred * hh;
    let q1 = &q0 + at0.velocity(&ph) * h;
    let mut z = DVector::zeros(2 * n + m);
    z.rows_mut(0, n).copy_from(&ph);
    z.rows_mut(n, n).copy_from(&q1);

    // Residual of the first half: (p½, q₁, λ) ↦ R, 2n + m equations.
    // `None`: not finite, or M(q₁) singular (either way no step from here). F(t₀, q₀, v₀)
    // depends on p½ alone: the last value is kept, so the Jacobian's q₁ and λ columns and
    // a repeated p½ cost no evaluation of F.
    let mut last_force: Option<(DVector<f64>, DVector<f64>)> = None;
    let mut residual = |mech: &mut dyn Mechanics, z: &DVector<f64>| -> Option<DVector<f64>> {
        let ph = z.rows(0, n).into_owned();
        let q1 = z.rows(n, n).into_owned();
        let lambda = z.rows(2 * n, m).into_owned();
        let at1 = AtQ::new(mech, q1.as_slice())?;
        let v0 = at0.velocity(&ph);
        let v1 = at1.velocity(&ph);
        let f0 = match &last_force {
            Some((p, f)) if *p == ph => f.clone(),
            _ => {
                let f = force(mech, stats, ta, &q0, &v0);
                last_force = Some((ph.clone(), f.clone()));
                f
            }
        };
        let mut r = DVector::zeros(2 * n + m);
        let rp = &ph - &p0 - (f0 - at0.jac.transpose() * &lambda) * hh;
        let rq = &q1 - &q0 - (v0 + v1) * hh;
        r.rows_mut(0, n).copy_from(&rp);
        r.rows_mut(n, n).copy_from(&rq);
        r.rows_mut(2 * n, m).copy_from(&at1.g);
        r.iter().all(|v| v.is_finite()).then_some(r)
    };

    // Forward-difference Jacobian at the predictor, factorized once. The residual is
    // linear in λ, so any increment gives λ's columns exactly: 1 (a force of 1 N).
    let r0 = residual(mech, &z).ok_or_else(non_finite)?;
    let scale_p = p0.amax().max(z.rows(0, n).amax()).max(hh_force);
    let scale_q = q0.amax().max(z.rows(n, n).amax());
    let mut jac = DMatrix::zeros(2 * n + m, 2 * n + m);
    for j in 0..2 * n + m {
        let scale = [scale_p, scale_q, 1.0][(j / n).min(2)];
        let delta = f64::EPSILON.sqrt() * z[j].abs().max(scale).max(f64::MIN_POSITIVE);
        let mut zj = z.clone();
        zj[j] += delta;
        let rj = residual(mech, &zj).ok_or_else(non_finite)?;
        jac.set_column(j, &((rj - &r0) / delta));
    }
    let lu = jac.lu();
    if !lu.is_invertible() {
        return Err(fail(0));
    }

    let mut r = r0;
    let mut previous = f64::INFINITY;
    let mut converged = false;
    for iteration in 1..=NEWTON_MAX_ITER {
        let dz = lu.solve(&r).ok_or(fail(0))?;
        z -= &dz;
        let size = increment_size(&dz, &z, (&q0, &p0), &at0.jac, hh_force, hh);
        if !size.is_finite() {
            return Err(fail(iteration));
        }
        if size <= NEWTON_TOL {
            converged = true;
            break;
        }
        if size >= previous {
            if size <= STALL {
                converged = true;
                break;
            }
            return Err(fail(iteration));
        }
        previous = size;
        r = residual(mech, &z).ok_or_else(non_finite)?;
    }
    if !converged {
        return Err(fail(NEWTON_MAX_ITER));
    }

    // Second half: p₁ = a − h/2 Gᵀμ with G M⁻¹ (p₁ − b) = 0, linear in μ.
    let ph = z.rows(0, n).into_owned();
    let q1 = z.rows(n, n).into_owned();
    let at1 = AtQ::new(mech, q1.as_slice()).ok_or_else(non_finite)?;
    let v1 = at1.velocity(&ph);
    let a = &ph + force(mech, stats, tb, &q1, &v1) * hh;
    let p1 = if m > 0 {
        let gt = at1.jac.transpose();
        // M⁻¹ Gᵀ, column by column.
        let mut minv_gt = DMatrix::zeros(n, m);
        for k in 0..m {
            let col = at1
                .lu
                .solve(&gt.column(k).into_owned())
                .expect("invertible");
            minv_gt.set_column(k, &col);
        }
        let schur = &at1.jac * &minv_gt * hh;
        let rhs = &at1.jac * at1.velocity(&a);
        let mu = schur.lu().solve(&rhs).ok_or(fail(0))?;
        a - gt * mu * hh
    } else {
        a
    };
    y[..n].copy_from_slice(q1.as_slice());
    y[n..].copy_from_slice(p1.as_slice());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A pendulum in Cartesian coordinates: mass `M` at (x, z), z down, on a rod of length
    /// `L` from the origin: `T = ½ M (ẋ² + ż²)`, `V = −M g z`, `g(q) = (x² + z² − L²)/2`.
    /// Constant mass matrix: RATTLE is Andersen's original method here.
    struct CartesianPendulum;
    const MASS: f64 = 2.0;
    const LEN: f64 = 1.5;
    const GRAV: f64 = 9.81;

    impl Mechanics for CartesianPendulum {
        fn dims(&self) -> (usize, usize) {
            (2, 1)
        }
        fn mass_matrix(&mut self, _q: &[f64], m: &mut [f64]) {
            m.copy_from_slice(&[MASS, 0.0, 0.0, MASS]);
        }
        fn momentum_offset(&mut self, _q: &[f64], b: &mut [f64]) {
            b.fill(0.0);
        }
        fn force(&mut self, _t: f64, _q: &[f64], _qd: &[f64], f: &mut [f64]) {
            f.copy_from_slice(&[0.0, MASS * GRAV]);
        }
        fn constraints(&mut self, q: &[f64], g: &mut [f64], jac: &mut [f64]) {
            g[0] = 0.5 * (q[0] * q[0] + q[1] * q[1] - LEN * LEN);
            jac.copy_from_slice(&[q[0], q[1]]);
        }
    }

    /// The same pendulum in its angle θ (from the downward vertical): `T = ½ M L² θ̇²`, no
    /// constraint. Constant mass matrix too, a check of the unconstrained path.
    struct AnglePendulum;

    impl Mechanics for AnglePendulum {
        fn dims(&self) -> (usize, usize) {
            (1, 0)
        }
        fn mass_matrix(&mut self, _q: &[f64], m: &mut [f64]) {
            m[0] = MASS * LEN * LEN;
        }
        fn momentum_offset(&mut self, _q: &[f64], b: &mut [f64]) {
            b.fill(0.0);
        }
        fn force(&mut self, _t: f64, q: &[f64], _qd: &[f64], f: &mut [f64]) {
            f[0] = -MASS * GRAV * LEN * q[0].sin();
        }
        fn constraints(&mut self, _q: &[f64], _g: &mut [f64], _jac: &mut [f64]) {}
    }

    fn cartesian_energy(x: &[f64]) -> f64 {
        0.5 * MASS * (x[2] * x[2] + x[3] * x[3]) - MASS * GRAV * x[1]
    }

    fn cartesian_start(theta: f64, omega: f64) -> [f64; 4] {
        let (s, c) = theta.sin_cos();
        [LEN * s, LEN * c, LEN * omega * c, -LEN * omega * s]
    }

    /// `windows` windows of `per_window` steps of 0.01 s (one call each): the largest
    /// |g|, |G q̇| and, per window, the largest relative energy error.
    fn long_run(windows: usize, per_window: usize) -> (f64, f64, Vec<f64>) {
        let mut x = cartesian_start(1.0, 0.0);
        let e0 = cartesian_energy(&x);
        let (mut t, h) = (0.0, 0.01);
        let mut stats = Stats::default();
        let (mut worst_g, mut worst_gv) = (0.0f64, 0.0f64);
        let mut energy = Vec::new();
        for _ in 0..windows {
            let mut window = 0.0f64;
            for _ in 0..per_window / 100 {
                let t_end = t + 1.0;
                advance(&mut CartesianPendulum, &mut t, &mut x, t_end, h, &mut stats).unwrap();
                let g = 0.5 * (x[0] * x[0] + x[1] * x[1] - LEN * LEN);
                let gv = x[0] * x[2] + x[1] * x[3];
                worst_g = worst_g.max(g.abs());
                worst_gv = worst_gv.max(gv.abs());
                window = window.max(((cartesian_energy(&x) - e0) / e0).abs());
            }
            energy.push(window);
        }
        (worst_g, worst_gv, energy)
    }

    fn check_long_run(windows: usize, per_window: usize) {
        let (worst_g, worst_gv, energy) = long_run(windows, per_window);
        let (first, last) = (energy[0], *energy.last().unwrap());
        println!(
            "METRIC RATTLE Cartesian pendulum, h = 0.01, {} steps: |g| ≤ {worst_g:.1e} m², \
             |G q̇| ≤ {worst_gv:.1e} m²/s, max |ΔE/E| first window {first:.3e}, last {last:.3e}",
            windows * per_window
        );
        // g is solved to rounding every step, never integrated: no growth with t.
        assert!(
            worst_g < 1e-13 && worst_gv < 1e-12,
            "{worst_g:e} {worst_gv:e}"
        );
        // Symplectic: the energy error is O(h²) and bounded, the same in the last window
        // as in the first (a drifting method would grow it with the number of windows).
        assert!(first < 1e-3 && last < 1.2 * first, "{first:e} {last:e}");
    }

    #[test]
    fn constraints_hold_to_rounding_and_energy_does_not_drift() {
        check_long_run(10, 10_000);
    }

    /// The same over 10⁷ steps (~80 s in release: run by scripts/test-all).
    #[test]
    #[ignore]
    fn constraints_hold_to_rounding_and_energy_does_not_drift_1e7() {
        check_long_run(100, 100_000);
    }

    #[test]
    fn cartesian_and_angle_forms_agree_at_second_order() {
        // The exact answer: the angle pendulum with a tiny step (both forms are second
        // order, the angle form's error at h/64 is 4096× below the compared ones).
        let reference = {
            let (mut t, mut x) = (0.0, [1.0, 0.0]);
            advance(
                &mut AnglePendulum,
                &mut t,
                &mut x,
                2.0,
                1e-4,
                &mut Stats::default(),
            )
            .unwrap();
            x
        };
        let error = |h: f64| {
            let (mut t, mut x) = (0.0, cartesian_start(1.0, 0.0));
            advance(
                &mut CartesianPendulum,
                &mut t,
                &mut x,
                2.0,
                h,
                &mut Stats::default(),
            )
            .unwrap();
            let theta = x[0].atan2(x[1]);
            (theta - reference[0]).abs()
        };
        let (e1, e2, e3) = (error(0.02), error(0.01), error(0.005));
        println!(
            "METRIC RATTLE order: θ errors {e1:.3e} {e2:.3e} {e3:.3e}, ratios {:.3} {:.3}",
            e1 / e2,
            e2 / e3
        );
        assert!((3.8..4.2).contains(&(e1 / e2)) && (3.8..4.2).contains(&(e2 / e3)));
    }

    #[test]
    fn time_reversal_returns_to_the_start() {
        // Symmetric: stepping forward, flipping the momenta and stepping forward again
        // returns to the start, to Newton's rounding.
        let x0 = cartesian_start(0.7, 1.3);
        let (mut t, mut x) = (0.0, x0);
        advance(
            &mut CartesianPendulum,
            &mut t,
            &mut x,
            1.0,
            0.05,
            &mut Stats::default(),
        )
        .unwrap();
        x[2] = -x[2];
        x[3] = -x[3];
        let (mut t, mut back) = (0.0, x);
        advance(
            &mut CartesianPendulum,
            &mut t,
            &mut back,
            1.0,
            0.05,
            &mut Stats::default(),
        )
        .unwrap();
        let worst = (0..4).fold(0.0f64, |a, i| {
            let target = if i < 2 { x0[i] } else { -x0[i] };
            a.max((back[i] - target).abs())
        });
        println!("METRIC RATTLE reversibility after 20 steps there and back: {worst:.1e}");
        assert!(worst < 1e-12, "{worst:e}");
    }

    /// The Cartesian pendulum whose force is not finite after t = 0.5 s.
    struct BrokenPendulum;

    impl Mechanics for BrokenPendulum {
        fn dims(&self) -> (usize, usize) {
            (2, 1)
        }
        fn mass_matrix(&mut self, q: &[f64], m: &mut [f64]) {
            CartesianPendulum.mass_matrix(q, m)
        }
        fn momentum_offset(&mut self, q: &[f64], b: &mut [f64]) {
            CartesianPendulum.momentum_offset(q, b)
        }
        fn force(&mut self, t: f64, q: &[f64], qd: &[f64], f: &mut [f64]) {
            CartesianPendulum.force(t, q, qd, f);
            if t > 0.5 {
                f[0] = f64::NAN;
            }
        }
        fn constraints(&mut self, q: &[f64], g: &mut [f64], jac: &mut [f64]) {
            CartesianPendulum.constraints(q, g, jac)
        }
    }

    #[test]
    fn a_failing_step_leaves_the_last_good_state_in_q_and_q_dot() {
        let (mut t, mut x) = (0.0, cartesian_start(1.0, 0.0));
        let mut good = x;
        advance(
            &mut CartesianPendulum,
            &mut 0.0,
            &mut good,
            0.5,
            0.1,
            &mut Stats::default(),
        )
        .unwrap();
        let err = advance(
            &mut BrokenPendulum,
            &mut t,
            &mut x,
            1.0,
            0.1,
            &mut Stats::default(),
        )
        .unwrap_err();
        assert!(err.to_string().contains("non-finite"), "{err}");
        assert_eq!(t, 0.5);
        // The same (q, q̇) as the run that stopped there by itself.
        for i in 0..4 {
            assert!((x[i] - good[i]).abs() < 1e-14, "{x:?} {good:?}");
        }
    }

    #[test]
    fn a_step_too_large_for_newton_is_refused() {
        // h = 2 s on a 1.5 m pendulum (small-angle period 2.46 s) released at 3 rad: the
        // predictor lands far off the circle and the simplified Newton iteration, with its
        // Jacobian frozen there, does not converge. The state stays at t = 0.
        let x0 = cartesian_start(3.0, 4.0);
        let (mut t, mut x) = (0.0, x0);
        let err = advance(
            &mut CartesianPendulum,
            &mut t,
            &mut x,
            2.0,
            2.0,
            &mut Stats::default(),
        )
        .unwrap_err();
        assert!(matches!(err, ImplicitFailure::NewtonFailed { .. }), "{err}");
        assert_eq!((t, x), (0.0, x0));
    }
}
