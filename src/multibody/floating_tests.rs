//! The floating base's dynamics against what must hold whatever the tree: Euler's
//! equations for one free body, energy kept along the flow under gravity, the spatial
//! momentum kept without it (and changed by exactly M g with it). The rates are taken by
//! dual numbers along `(q̇, q̈)` and the base's kinematics (`Ṙ = R [ω]×`, `ṗ = R v`), so
//! a wrong term anywhere in the floating ABA shows.

use super::dynamics::Data;
use super::mechanism::Mechanism;
use super::spatial::{mat_mul, mat_vec, quat_to_matrix, skew, Motion, M3, V3};
use super::{urdf, Model};
use crate::model::Scalar;
use num_dual::{Dual64, HyperDual64};

/// A three-link floating arm: offsets on every axis, a prismatic joint, inertias with
/// products, a root with its own mass and an off-origin centre of mass.
pub(crate) const ARM: &str = r#"<robot name="arm">
  <link name="torso"><inertial><origin xyz="0.05 -0.02 0.1"/><mass value="4"/>
    <inertia ixx="0.3" ixy="0.01" ixz="-0.02" iyy="0.25" iyz="0.015" izz="0.2"/></inertial></link>
  <link name="upper"><inertial><origin xyz="0.1 0.02 -0.15"/><mass value="1.5"/>
    <inertia ixx="0.025" ixy="0.001" ixz="0.002" iyy="0.03" iyz="-0.001" izz="0.015"/></inertial></link>
  <link name="slider"><inertial><origin xyz="0 0.03 0.05"/><mass value="0.8"/>
    <inertia ixx="0.004" ixy="0" ixz="0.0005" iyy="0.005" iyz="0" izz="0.003"/></inertial></link>
  <link name="hand"><inertial><origin xyz="0.02 0 -0.04"/><mass value="0.5"/>
    <inertia ixx="0.002" ixy="0.0001" ixz="0" iyy="0.0015" iyz="0.0002" izz="0.001"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="torso"/><child link="upper"/>
    <origin xyz="0.1 0.2 0.3" rpy="0.3 -0.2 0.5"/><axis xyz="0 0.6 0.8"/>
    <limit lower="-3" upper="3" effort="50" velocity="5"/></joint>
  <joint name="slide" type="prismatic"><parent link="upper"/><child link="slider"/>
    <origin xyz="0.2 0 -0.3" rpy="0 0.4 0"/><axis xyz="1 0 0"/>
    <limit lower="-0.5" upper="0.5" effort="50" velocity="1"/></joint>
  <joint name="wrist" type="continuous"><parent link="slider"/><child link="hand"/>
    <origin xyz="0 0.1 0" rpy="-0.3 0 0.2"/><axis xyz="1 0 0"/></joint>
</robot>"#;

fn floating(urdf_text: &str, gravity: [f64; 3]) -> Model {
    let mechanism = urdf::parse(urdf_text, "arm.urdf")
        .expect("parses")
        .gravity(gravity)
        .floating_base();
    Model::new(&mechanism).expect("builds")
}

/// A state: base quaternion (not unit: the rotation is homogeneous), position, velocity;
/// joint positions, velocities, torques.
struct State {
    quat: [f64; 4],
    position: V3<f64>,
    velocity: Motion<f64>,
    q: Vec<f64>,
    qd: Vec<f64>,
    tau: Vec<f64>,
}

fn state(n: usize) -> State {
    State {
        quat: [0.8, -0.3, 0.4, 0.2],
        position: [0.3, -1.2, 2.0],
        velocity: Motion {
            ang: [0.7, -1.1, 0.4],
            lin: [0.5, 0.2, -0.9],
        },
        q: [0.4, 0.12, -0.8][..n].to_vec(),
        qd: [1.3, -0.4, 2.1][..n].to_vec(),
        tau: vec![0.0; n],
    }
}

/// The state moved along the flow to first order in ε: `(R, p, v₀, q, q̇)` as dual
/// numbers, their ε parts the rates the floating ABA gives.
#[allow(clippy::type_complexity)]
fn along_flow<D: Scalar>(
    model: &Model,
    s: &State,
    lift: impl Fn(f64, f64) -> D,
) -> (M3<D>, V3<D>, Motion<D>, Vec<D>, Vec<D>) {
    let r = quat_to_matrix(&s.quat);
    let n = model.nq();
    let mut qdd = vec![0.0; n];
    let a0 = model.aba_free_in(
        &mut Data::new(model),
        &r,
        &s.velocity,
        &s.q,
        &s.qd,
        &s.tau,
        &mut qdd,
    );
    let r_dot = mat_mul(&r, &skew(&s.velocity.ang));
    let p_dot = mat_vec(&r, &s.velocity.lin);
    let rd: M3<D> = std::array::from_fn(|i| std::array::from_fn(|k| lift(r[i][k], r_dot[i][k])));
    let pd: V3<D> = std::array::from_fn(|i| lift(s.position[i], p_dot[i]));
    let vd = Motion {
        ang: std::array::from_fn(|i| lift(s.velocity.ang[i], a0.ang[i])),
        lin: std::array::from_fn(|i| lift(s.velocity.lin[i], a0.lin[i])),
    };
    let qd: Vec<D> = (0..n).map(|i| lift(s.q[i], s.qd[i])).collect();
    let qdd: Vec<D> = (0..n).map(|i| lift(s.qd[i], qdd[i])).collect();
    (rd, pd, vd, qd, qdd)
}

fn energy<S: Scalar>(model: &Model, r: &M3<S>, p: &V3<S>, v: &Motion<S>, q: &[S], qd: &[S]) -> S {
    model.kinetic_energy_free(v, q, qd) + model.potential_energy_free(r, p, q)
}

/// One free body (no joint): the floating ABA is Euler's equations, `I ω̇ = −ω × I ω`
/// about the centre of mass at the origin, and `v̇ = Rᵀ g − ω × v` for the body-frame
/// components of the origin's velocity.
#[test]
fn a_free_body_follows_eulers_equations() {
    let text = r#"<robot name="brick"><link name="brick"><inertial><mass value="2"/>
        <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.3"/></inertial></link></robot>"#;
    let g = [0.0, 0.0, -9.81];
    let model = floating(text, g);
    assert_eq!(model.nq(), 0);
    let s = state(0);
    let r = quat_to_matrix(&s.quat);
    let a0 = model.aba_free_in(
        &mut Data::new(&model),
        &r,
        &s.velocity,
        &[],
        &[],
        &[],
        &mut [],
    );
    let (w, v) = (s.velocity.ang, s.velocity.lin);
    let moments = [0.1, 0.2, 0.3];
    let iw = [moments[0] * w[0], moments[1] * w[1], moments[2] * w[2]];
    let gyro = super::spatial::cross(&w, &iw);
    let rt_g = super::spatial::mat_t_vec(&r, &g);
    let wxv = super::spatial::cross(&w, &v);
    for k in 0..3 {
        let euler = -gyro[k] / moments[k];
        assert!(
            (a0.ang[k] - euler).abs() < 1e-14,
            "ω̇[{k}] {} vs {euler}",
            a0.ang[k]
        );
        let linear = rt_g[k] - wxv[k];
        assert!(
            (a0.lin[k] - linear).abs() < 1e-13,
            "v̇[{k}] {} vs {linear}",
            a0.lin[k]
        );
    }
}

/// Under gravity, no torque, no damping: dE/dt = 0 along the flow (to rounding of E).
#[test]
fn a_floating_arm_keeps_its_energy() {
    let model = floating(ARM, [0.0, 0.0, -9.81]);
    let s = state(model.nq());
    let (r, p, v, q, qd) = along_flow(&model, &s, Dual64::new);
    let e = energy(&model, &r, &p, &v, &q, &qd);
    assert!(e.re.abs() > 1.0, "{}", e.re);
    assert!(
        e.eps.abs() < 1e-12 * e.re.abs(),
        "dE/dt = {} (E = {})",
        e.eps,
        e.re
    );
}

/// The spatial momentum of `model` in the world, `(linear, angular about the world origin)`,
/// as dual numbers in time along the flow from `s`: `X*(∂T/∂v₀)` (T's gradient in the base
/// velocity is the momentum of the whole tree in base coordinates).
fn world_momentum(model: &Model, s: &State) -> (V3<Dual64>, V3<Dual64>) {
    // h_b[k] = ∂T/∂v₀ₖ as a dual number in time: ε₁ time, ε₂ the gradient.
    let lift = |x: f64, rate: f64| HyperDual64::new(x, rate, 0.0, 0.0);
    let (r, p, v, q, qd) = along_flow(model, s, lift);
    let mut h = [Dual64::from(0.0); 6];
    for (k, hk) in h.iter_mut().enumerate() {
        let mut vk = v;
        let slot = if k < 3 {
            &mut vk.ang[k]
        } else {
            &mut vk.lin[k - 3]
        };
        slot.eps2 = 1.0;
        let t = model.kinetic_energy_free(&vk, &q, &qd);
        *hk = Dual64::new(t.eps2, t.eps1eps2);
    }
    let time = |x: &HyperDual64| Dual64::new(x.re, x.eps1);
    let rt: M3<Dual64> = std::array::from_fn(|i| std::array::from_fn(|k| time(&r[i][k])));
    let pt: V3<Dual64> = std::array::from_fn(|i| time(&p[i]));
    let f_w = mat_vec(&rt, &[h[3], h[4], h[5]]);
    let n_w = super::spatial::add(
        &mat_vec(&rt, &[h[0], h[1], h[2]]),
        &super::spatial::cross(&pt, &f_w),
    );
    (f_w, n_w)
}

/// The spatial momentum in the world ([`world_momentum`]) as dual numbers along the flow:
/// without gravity it is kept whatever the joints' torques; with gravity its linear part
/// changes by M g.
#[test]
fn a_floating_arm_keeps_its_momentum() {
    for (g, torques) in [([0.0; 3], [0.8, -3.0, 0.4]), ([0.0, 0.0, -9.81], [0.0; 3])] {
        let model = floating(ARM, g);
        let mut s = state(model.nq());
        s.tau = torques.to_vec();
        let mass: f64 = model.inertia.iter().map(|i| i.m).sum::<f64>()
            + model.free_base.as_ref().unwrap().inertia.m;
        let (f_w, n_w) = world_momentum(&model, &s);
        let scale = f_w
            .iter()
            .chain(&n_w)
            .map(|x| x.re.abs())
            .fold(1.0, f64::max);
        for k in 0..3 {
            let expected = mass * g[k];
            assert!(
                (f_w[k].eps - expected).abs() < 1e-12 * scale,
                "g = {g:?}: dp/dt[{k}] = {} vs M g = {expected}",
                f_w[k].eps
            );
            if g == [0.0; 3] {
                assert!(
                    n_w[k].eps.abs() < 1e-12 * scale,
                    "dL/dt[{k}] = {}",
                    n_w[k].eps
                );
            }
        }
    }
}

/// The floating mechanism's builder flag survives the fixed-joint merge.
#[test]
fn the_floating_flag_is_kept_by_the_merge() {
    let m = Mechanism::new("m").floating_base();
    assert!(m.floating_base);
    let model = floating(ARM, [0.0; 3]);
    assert_eq!(
        model.free_base.as_ref().map(|b| b.body.as_str()),
        Some("torso")
    );
}

/// [`ARM`] with a pointer on the hand following the shoulder at half its angle.
pub(crate) fn with_mimic() -> String {
    ARM.replace(
        "</robot>",
        r#"<link name="pointer"><inertial><origin xyz="0.05 0.02 0.1"/><mass value="0.3"/>
            <inertia ixx="0.002" ixy="0.0001" ixz="0" iyy="0.003" iyz="0" izz="0.0025"/></inertial></link>
          <joint name="follower" type="revolute"><parent link="hand"/><child link="pointer"/>
            <origin xyz="0.05 0 -0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/>
            <mimic joint="shoulder" multiplier="0.5" offset="0.1"/></joint></robot>"#,
    )
}

/// With a mimic joint (a pointer on the hand following the shoulder at half its angle),
/// the floating dynamics reduced to the base and the independent joints (inverse-dynamics
/// columns, LDLᵀ) keep the energy under gravity and the momentum without it, as the
/// articulated path does: the mimic's state and rates follow (`q = r q_J + o`).
#[test]
fn the_reduced_floating_dynamics_keep_energy_and_momentum() {
    let mimic = floating(&with_mimic(), [0.0, 0.0, -9.81]);
    assert!(mimic.has_mimics() && mimic.nq() == 4);
    let consistent = |s: &mut State| {
        s.q.push(0.5 * s.q[0] + 0.1);
        s.qd.push(0.5 * s.qd[0]);
        s.tau.push(0.0);
    };
    let mut s = state(3);
    consistent(&mut s);
    let (r, p, v, q, qd) = along_flow(&mimic, &s, Dual64::new);
    assert!(
        (qd[3].eps - 0.5 * qd[0].eps).abs() < 1e-15,
        "the mimic follows: {} vs {}",
        qd[3].eps,
        0.5 * qd[0].eps
    );
    let e = energy(&mimic, &r, &p, &v, &q, &qd);
    assert!(
        e.eps.abs() < 1e-12 * e.re.abs(),
        "dE/dt = {} (E = {})",
        e.eps,
        e.re
    );
    // Without gravity, under joint torques (the mimic's acting through its multiplier):
    // dE/dt is the torques' power, and the momentum is kept.
    let free = floating(&with_mimic(), [0.0; 3]);
    let mut s = state(3);
    s.tau = vec![0.8, -3.0, 0.4];
    consistent(&mut s);
    s.tau[3] = 0.6;
    let (r, p, v, q, qd) = along_flow(&free, &s, Dual64::new);
    let power: f64 = s.tau.iter().zip(&s.qd).map(|(t, w)| t * w).sum();
    let e = energy(&free, &r, &p, &v, &q, &qd);
    assert!(
        (e.eps - power).abs() < 1e-12 * e.re.abs().max(1.0),
        "dE/dt = {} vs power {power}",
        e.eps
    );
    let (f_w, n_w) = world_momentum(&free, &s);
    for k in 0..3 {
        assert!(
            f_w[k].eps.abs() < 1e-12 && n_w[k].eps.abs() < 1e-12,
            "{k}: {} {}",
            f_w[k].eps,
            n_w[k].eps
        );
    }
}

/// The held solve evaluates the dynamics again at the same q with other velocities and
/// forces, reusing the factored reduced mass matrix (`Data::mass_is_current`): what it
/// gives is, to the bit, what a fresh evaluation gives, with a floating base and without.
#[test]
fn the_reused_mass_matrix_gives_a_fresh_evaluations_accelerations() {
    for model in [
        floating(&with_mimic(), [0.0, 0.0, -9.81]),
        Model::new(&urdf::parse(&with_mimic(), "arm.urdf").expect("parses")).expect("builds"),
    ] {
        assert!(model.has_mimics());
        let s = state(3);
        let r = quat_to_matrix(&s.quat);
        let q = [s.q.clone(), vec![0.5 * s.q[0] + 0.1]].concat();
        let run_at = |d: &mut Data<f64>, q: &[f64], qd: &[f64], tau: &[f64]| {
            let mut qdd = vec![0.0; 4];
            let base = if model.free_base.is_some() {
                let still = Motion::zero();
                let v = if qd[0] == 0.0 { &still } else { &s.velocity };
                model.aba_free_in(d, &r, v, q, qd, tau, &mut qdd)
            } else {
                model.aba_in(d, q, qd, tau, &mut qdd);
                Motion::zero()
            };
            (qdd, base)
        };
        let run = |d: &mut Data<f64>, qd: &[f64], tau: &[f64]| run_at(d, &q, qd, tau);
        let (qd, still) = ([1.3, -0.4, 2.1, 0.65], [0.0; 4]);
        let (tau, unit) = ([0.8, -3.0, 0.4, 0.6], [0.0, 1.0, 0.0, 0.0]);
        let mut reused = Data::new(&model);
        run(&mut reused, &qd, &tau);
        reused.mass_is_current = true;
        for (qd, tau) in [(&still, &unit), (&qd, &unit), (&still, &tau)] {
            let again = run(&mut reused, qd, tau);
            let fresh = run(&mut Data::new(&model), qd, tau);
            assert_eq!(again.0, fresh.0);
            assert_eq!(again.1.ang, fresh.1.ang);
            assert_eq!(again.1.lin, fresh.1.lin);
        }
        // And it is reused: marked current at another q, the answer differs.
        let mut moved = Data::new(&model);
        let mut q2 = q.clone();
        // (Not the root joint's angle: a fixed base's M does not depend on it.)
        q2[1] += 0.3;
        run_at(&mut moved, &q2, &qd, &tau);
        moved.mass_is_current = true;
        assert_ne!(
            run(&mut moved, &qd, &tau).0,
            run(&mut Data::new(&model), &qd, &tau).0
        );
    }
}

/// The floating mass matrix by CRBA with the base ([`Model::crba_free_in`]) is, column by
/// column, the inverse dynamics without gravity or velocity at a unit acceleration of the
/// base or of one joint ([`Model::rnea_free_in`]: the definition), with and without a
/// mimic joint (here every joint its own column, the reduction is the caller's).
#[test]
fn the_floating_crba_is_the_inverse_dynamics_column_by_column() {
    for model in [
        floating(ARM, [0.0, 0.0, -9.81]),
        floating(&with_mimic(), [0.0; 3]),
    ] {
        let n = model.nq();
        let size = 6 + n;
        let s = state(3);
        let q = [s.q.clone(), vec![0.3; n - 3]].concat();
        let r = quat_to_matrix(&s.quat);
        let mut d = Data::new(&model);
        let mut m = vec![0.0; size * size];
        model.crba_free_in(&mut d, &q, &mut m);
        let still = Motion::zero();
        let mut worst = 0.0f64;
        for c in 0..size {
            let mut a0 = Motion::zero();
            let mut qdd = vec![0.0; n];
            match c {
                0..=2 => a0.ang[c] = 1.0,
                3..=5 => a0.lin[c - 3] = 1.0,
                _ => qdd[c - 6] = 1.0,
            }
            let mut tau = vec![0.0; n];
            let f0 = model.rnea_free_in(
                &mut d,
                (&r, &still, &a0),
                &q,
                &vec![0.0; n],
                &qdd,
                false,
                &mut tau,
            );
            let column = [f0.ang.to_vec(), f0.lin.to_vec(), tau].concat();
            for (row, want) in column.iter().enumerate() {
                worst = worst.max((m[row * size + c] - want).abs());
                assert_eq!(m[row * size + c], m[c * size + row], "symmetric");
            }
        }
        assert!(worst < 1e-12, "{worst:e}");
    }
}
