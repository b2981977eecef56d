//! Unit tests of the multibody layer: closed forms, the algorithms against each other,
//! energy conservation, the fixed-joint merge, and every refusal of a bad URDF.

use super::mechanism::{Body, Joint, JointKind, Mechanism, Origin};
use super::urdf;
use super::Model;
use nalgebra::{DMatrix, DVector};
use num_dual::Dual64;

/// A small deterministic generator (xorshift64*), uniform in [lo, hi).
struct Rng(u64);

impl Rng {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let u = (self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * u
    }

    fn vec(&mut self, n: usize, lo: f64, hi: f64) -> Vec<f64> {
        (0..n).map(|_| self.uniform(lo, hi)).collect()
    }
}

const M1: f64 = 1.3;
const M2: f64 = 0.7;
const L1: f64 = 0.9;
const L2: f64 = 0.6;
/// The bobs' own (small) moment of inertia about y: "point-ish" masses, but a positive
/// definite inertia as validation requires.
const EPS: f64 = 1e-4;

fn double_pendulum_urdf() -> String {
    format!(
        r#"<?xml version="1.0"?>
<robot name="double_pendulum">
  <link name="base"/>
  <link name="upper">
    <inertial>
      <origin xyz="0 0 -{L1}" rpy="0 0 0"/>
      <mass value="{M1}"/>
      <inertia ixx="{EPS}" ixy="0" ixz="0" iyy="{EPS}" iyz="0" izz="{EPS}"/>
    </inertial>
    <visual><geometry><sphere radius="0.05"/></geometry></visual>
  </link>
  <link name="lower">
    <inertial>
      <origin xyz="0 0 -{L2}"/>
      <mass value="{M2}"/>
      <inertia ixx="{EPS}" ixy="0" ixz="0" iyy="{EPS}" iyz="0" izz="{EPS}"/>
    </inertial>
  </link>
  <joint name="shoulder" type="revolute">
    <parent link="base"/>
    <child link="upper"/>
    <axis xyz="0 2 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="5"/>
  </joint>
  <joint name="elbow" type="continuous">
    <parent link="upper"/>
    <child link="lower"/>
    <origin xyz="0 0 -{L1}"/>
    <axis xyz="0 1 0"/>
  </joint>
  <transmission name="t"><joint name="shoulder"/></transmission>
</robot>
"#
    )
}

/// The double pendulum's closed form: `M q̈ + h + G = τ` with angles about y from hanging
/// down (the bobs at `(−l sin θ, 0, −l cos θ)`).
fn double_pendulum_closed_form(q: &[f64], qd: &[f64]) -> ([[f64; 2]; 2], [f64; 2]) {
    let g = 9.81;
    let (s2, c2) = q[1].sin_cos();
    let m11 = M1 * L1 * L1 + EPS + M2 * (L1 * L1 + L2 * L2 + 2.0 * L1 * L2 * c2) + EPS;
    let m12 = M2 * (L2 * L2 + L1 * L2 * c2) + EPS;
    let m22 = M2 * L2 * L2 + EPS;
    let h1 = -M2 * L1 * L2 * s2 * (2.0 * qd[0] * qd[1] + qd[1] * qd[1]);
    let h2 = M2 * L1 * L2 * s2 * qd[0] * qd[0];
    let s1 = q[0].sin();
    let s12 = (q[0] + q[1]).sin();
    let g1 = g * (M1 * L1 * s1 + M2 * (L1 * s1 + L2 * s12));
    let g2 = g * M2 * L2 * s12;
    ([[m11, m12], [m12, m22]], [h1 + g1, h2 + g2])
}

#[test]
fn double_pendulum_matches_its_closed_form() {
    let mech = urdf::parse(&double_pendulum_urdf(), "double_pendulum.urdf").unwrap();
    assert_eq!(mech.name, "double_pendulum");
    assert_eq!(
        mech.joints[0].axis,
        [0.0, 1.0, 0.0],
        "the axis is normalised"
    );
    assert_eq!(mech.joints[0].limit.upper, Some(3.0));
    let model = Model::new(&mech).unwrap();
    assert_eq!(model.joints, ["shoulder", "elbow"]);
    let mut rng = Rng(7);
    for _ in 0..50 {
        let q = rng.vec(2, -3.0, 3.0);
        let qd = rng.vec(2, -2.0, 2.0);
        let tau = rng.vec(2, -5.0, 5.0);
        let (m, bias) = double_pendulum_closed_form(&q, &qd);
        let mm = model.crba(&q);
        for r in 0..2 {
            for c in 0..2 {
                assert!((mm[r][c] - m[r][c]).abs() < 1e-13, "M[{r}][{c}]");
            }
        }
        // q̈ = M⁻¹ (τ − h − G), 2×2 by Cramer's rule.
        let (b1, b2) = (tau[0] - bias[0], tau[1] - bias[1]);
        let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
        let expect = [
            (m[1][1] * b1 - m[0][1] * b2) / det,
            (m[0][0] * b2 - m[1][0] * b1) / det,
        ];
        let qdd = model.aba(&q, &qd, &tau);
        for k in 0..2 {
            assert!(
                (qdd[k] - expect[k]).abs() < 1e-10 * expect[k].abs().max(1.0),
                "q̈[{k}] {} vs {}",
                qdd[k],
                expect[k]
            );
        }
        let rnea = model.rnea(&q, &qd, &[0.0, 0.0]);
        for k in 0..2 {
            assert!((rnea[k] - bias[k]).abs() < 1e-12, "bias[{k}]");
        }
        // Energies and the tip.
        let t = model.kinetic_energy(&q, &qd);
        let t_expect = 0.5
            * (m[0][0] * qd[0] * qd[0] + 2.0 * m[0][1] * qd[0] * qd[1] + m[1][1] * qd[1] * qd[1]);
        assert!((t - t_expect).abs() < 1e-12);
        let v_expect =
            -9.81 * (M1 * L1 * q[0].cos() + M2 * (L1 * q[0].cos() + L2 * (q[0] + q[1]).cos()));
        assert!((model.potential_energy(&q) - v_expect).abs() < 1e-12);
    }
    let tips = model.tip_poses(&[0.3, -0.4]);
    assert_eq!(model.tips.len(), 1);
    assert_eq!(model.tips[0].name, "lower");
    let (p, quat) = tips[0];
    assert!((p[0] - (-L1 * 0.3f64.sin())).abs() < 1e-15 && p[1].abs() < 1e-15);
    // Rotation by −0.1 about y.
    let half = -0.05f64;
    let expect = [half.cos(), 0.0, half.sin(), 0.0];
    for k in 0..4 {
        assert!((quat[k] - expect[k]).abs() < 1e-15);
    }
}

/// A branched mechanism with every joint kind, offsets, tilted origins and full inertias.
fn branched() -> Mechanism {
    let inertia = |a: f64, b: f64, c: f64, d: f64| [[a, d, 0.0], [d, b, -d], [0.0, -d, c]];
    Mechanism::new("tree")
        .body(Body::new("base", 5.0).inertia_diag([1.0, 1.0, 1.0]))
        .body(
            Body::new("torso", 2.0)
                .com([0.0, 0.05, 0.3])
                .inertia(inertia(0.2, 0.25, 0.1, 0.01)),
        )
        .body(
            Body::new("arm", 1.0)
                .com([0.2, 0.0, 0.0])
                .inertia(inertia(0.01, 0.05, 0.05, 0.002)),
        )
        .body(Body::new("slider", 0.5).inertia_diag([0.01, 0.01, 0.01]))
        .body(Body::massless("flange"))
        .body(
            Body::new("hand", 0.3)
                .com([0.0, 0.0, 0.05])
                .inertia_diag([0.002, 0.002, 0.001]),
        )
        .body(
            Body::new("leg", 1.5)
                .com([0.0, 0.0, -0.4])
                .inertia(inertia(0.1, 0.1, 0.02, -0.003)),
        )
        .revolute(
            "waist",
            "base",
            "torso",
            Origin::new([0.0, 0.0, 0.5], [0.1, -0.2, 0.3]),
            [0.0, 0.0, 1.0],
        )
        .revolute(
            "shoulder",
            "torso",
            "arm",
            Origin::new([0.1, 0.2, 0.6], [0.5, 0.0, -0.4]),
            [1.0, 1.0, 0.0],
        )
        .prismatic(
            "slide",
            "arm",
            "slider",
            Origin::new([0.4, 0.0, 0.0], [0.0, 0.3, 0.0]),
            [0.3, 0.0, 1.0],
        )
        .fixed(
            "mount",
            "slider",
            "flange",
            Origin::new([0.0, 0.1, 0.05], [0.2, 0.3, -0.1]),
        )
        .continuous(
            "wrist",
            "flange",
            "hand",
            Origin::new([0.05, 0.0, 0.0], [0.0, 0.0, 0.7]),
            [0.0, 1.0, 0.0],
        )
        .joint(
            Joint::new(
                "hip",
                JointKind::Revolute,
                "torso",
                "leg",
                Origin::new([0.0, -0.1, 0.0], [-0.3, 0.2, 0.1]),
            )
            .axis([0.2, 1.0, 0.1])
            .damping(0.4),
        )
}

#[test]
fn aba_equals_crba_solve_of_rnea() {
    let model = Model::new(&branched()).unwrap();
    assert_eq!(model.joints, ["waist", "shoulder", "slide", "wrist", "hip"]);
    assert_eq!(model.parent, [None, Some(0), Some(1), Some(2), Some(0)]);
    let n = model.nq();
    let mut rng = Rng(42);
    for _ in 0..100 {
        let q = rng.vec(n, -3.0, 3.0);
        let qd = rng.vec(n, -3.0, 3.0);
        let tau = rng.vec(n, -10.0, 10.0);
        let m = model.crba(&q);
        let mm = DMatrix::from_fn(n, n, |r, c| m[r][c]);
        assert_eq!(mm, mm.transpose(), "M is symmetric");
        assert!(mm.clone().cholesky().is_some(), "M is positive definite");
        let bias = model.rnea(&q, &qd, &vec![0.0; n]);
        let rhs = DVector::from_fn(n, |k, _| tau[k] - model.damping[k] * qd[k] - bias[k]);
        let expect = mm.lu().solve(&rhs).unwrap();
        let qdd = model.aba(&q, &qd, &tau);
        for k in 0..n {
            assert!(
                (qdd[k] - expect[k]).abs() < 1e-11 * expect[k].abs().max(1.0),
                "q̈[{k}] {} vs {}",
                qdd[k],
                expect[k]
            );
        }
        // And RNEA inverts ABA.
        let back = model.rnea(&q, &qd, &qdd);
        for k in 0..n {
            let want = tau[k] - model.damping[k] * qd[k];
            assert!((back[k] - want).abs() < 1e-10 * want.abs().max(1.0));
        }
    }
}

fn energy(model: &Model, x: &[f64]) -> f64 {
    let n = model.nq();
    model.kinetic_energy(&x[..n], &x[n..]) + model.potential_energy(&x[..n])
}

fn rk4_step(model: &Model, x: &[f64], h: f64) -> Vec<f64> {
    let n = model.nq();
    let zero = vec![0.0; n];
    let f = |x: &[f64]| -> Vec<f64> {
        let mut dx = x[n..].to_vec();
        dx.extend(model.aba(&x[..n], &x[n..], &zero));
        dx
    };
    let axpy =
        |a: f64, k: &[f64]| -> Vec<f64> { x.iter().zip(k).map(|(x, k)| x + a * k).collect() };
    let k1 = f(x);
    let k2 = f(&axpy(h / 2.0, &k1));
    let k3 = f(&axpy(h / 2.0, &k2));
    let k4 = f(&axpy(h, &k3));
    (0..2 * n)
        .map(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
        .collect()
}

#[test]
fn energy_is_conserved_without_damping() {
    let mut mech = branched();
    for j in &mut mech.joints {
        j.damping = 0.0;
    }
    let model = Model::new(&mech).unwrap();
    let n = model.nq();
    let mut x: Vec<f64> = Rng(3).vec(2 * n, -1.0, 1.0);
    let e0 = energy(&model, &x);
    let mut drift: f64 = 0.0;
    for _ in 0..1000 {
        x = rk4_step(&model, &x, 1e-3);
        drift = drift.max((energy(&model, &x) - e0).abs());
    }
    // RK4 at h = 1 ms over 1 s: the energy error is O(h⁴), far below this.
    assert!(drift < 1e-7 * e0.abs().max(1.0), "drift {drift:e} of {e0}");
    // With damping, energy only decreases (no input).
    let damped = Model::new(&branched()).unwrap();
    let mut x: Vec<f64> = Rng(3).vec(2 * n, -1.0, 1.0);
    let mut e = energy(&damped, &x);
    for _ in 0..200 {
        x = rk4_step(&damped, &x, 1e-3);
        let e1 = energy(&damped, &x);
        assert!(e1 <= e + 1e-9);
        e = e1;
    }
}

#[test]
fn fixed_joint_merge_equals_one_combined_body() {
    // link1 with a bob fixed below it (offset, turned 90° about z, com off its origin).
    let bob = Body::new("bob", 2.0)
        .com([0.1, 0.0, 0.0])
        .inertia_diag([0.1, 0.2, 0.3]);
    let link = Body::new("link1", 1.0)
        .com([0.0, 0.0, -0.5])
        .inertia_diag([0.01, 0.02, 0.03]);
    let o = Origin::new([0.0, 0.0, -1.0], [0.0, 0.0, std::f64::consts::FRAC_PI_2]);
    let pendulum = |m: Mechanism| {
        m.body(Body::massless("base"))
            .revolute(
                "j1",
                "base",
                "link1",
                Origin::new([0.0, 0.0, 1.0], [0.3, 0.0, 0.0]),
                [0.0, 1.0, 0.0],
            )
            .body(
                Body::new("link2", 0.5)
                    .com([0.0, 0.0, -0.3])
                    .inertia_diag([0.01, 0.01, 0.001]),
            )
    };
    let split = pendulum(Mechanism::new("split"))
        .body(link.clone())
        .body(bob)
        .fixed("weld", "link1", "bob", o)
        .revolute(
            "j2",
            "bob",
            "link2",
            Origin::xyz([0.0, 0.2, 0.0]),
            [1.0, 0.0, 0.0],
        );
    // By hand: the bob's com in link1 is (0, 0.1, −1), its inertia diag(0.2, 0.1, 0.3) in
    // link1 axes; the total com is (1·(0,0,−0.5) + 2·(0,0.1,−1))/3.
    let com = [0.0, 0.2 / 3.0, -2.5 / 3.0];
    let parts = [
        (1.0, [0.0, 0.0, -0.5], [0.01, 0.02, 0.03]),
        (2.0, [0.0, 0.1, -1.0], [0.2, 0.1, 0.3]),
    ];
    let mut inertia = [[0.0; 3]; 3];
    for (m, c, d) in parts {
        let r: Vec<f64> = (0..3).map(|k| c[k] - com[k]).collect();
        let rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
        for a in 0..3 {
            for b in 0..3 {
                let diag = if a == b { d[a] + m * rr } else { 0.0 };
                inertia[a][b] += diag - m * r[a] * r[b];
            }
        }
    }
    // The child joint's origin composed with the weld by hand: Rz(90°)·(0, 0.2, 0) = (−0.2, 0, 0).
    let combined = pendulum(Mechanism::new("combined"))
        .body(Body::new("link1", 3.0).com(com).inertia(inertia))
        .revolute(
            "j2",
            "link1",
            "link2",
            Origin::new([-0.2, 0.0, -1.0], [0.0, 0.0, std::f64::consts::FRAC_PI_2]),
            [1.0, 0.0, 0.0],
        );
    let merged = split.merge_fixed().unwrap();
    assert_eq!(merged.mechanism.bodies.len(), 3);
    let b = &merged.mechanism.bodies[1];
    assert_eq!(b.name, "link1");
    assert!((b.mass - 3.0).abs() < 1e-15);
    let bob_frame = merged.frames.iter().find(|f| f.name == "bob").unwrap();
    assert_eq!((bob_frame.body.as_str(), bob_frame.leaf), ("link1", false));
    let (a, b) = (Model::new(&split).unwrap(), Model::new(&combined).unwrap());
    let mut rng = Rng(11);
    for _ in 0..20 {
        let q = rng.vec(2, -3.0, 3.0);
        let qd = rng.vec(2, -3.0, 3.0);
        let tau = rng.vec(2, -3.0, 3.0);
        let (qa, qb) = (a.aba(&q, &qd, &tau), b.aba(&q, &qd, &tau));
        let (ma, mb) = (a.crba(&q), b.crba(&q));
        for r in 0..2 {
            assert!((qa[r] - qb[r]).abs() < 1e-12 * qa[r].abs().max(1.0));
            for c in 0..2 {
                assert!((ma[r][c] - mb[r][c]).abs() < 1e-13);
            }
        }
        let (ea, eb) = (
            energy(&a, &[q.clone(), qd.clone()].concat()),
            energy(&b, &[q, qd].concat()),
        );
        assert!((ea - eb).abs() < 1e-12);
    }
}

#[test]
fn a_merged_leaf_keeps_its_frame() {
    // The tool is welded to the arm: its pose is still reported.
    let m = Mechanism::new("arm")
        .body(Body::massless("base"))
        .body(
            Body::new("link", 1.0)
                .com([0.5, 0.0, 0.0])
                .inertia_diag([0.01, 0.1, 0.1]),
        )
        .body(Body::massless("tool"))
        .revolute("j", "base", "link", Origin::IDENTITY, [0.0, 0.0, 1.0])
        .fixed(
            "tcp",
            "link",
            "tool",
            Origin::new([1.0, 0.0, 0.0], [0.0, 0.0, 0.5]),
        );
    let model = Model::new(&m).unwrap();
    assert_eq!(model.nq(), 1);
    assert_eq!(model.tips[0].name, "tool");
    let (p, quat) = model.tip_poses(&[0.25])[0];
    assert!((p[0] - 0.25f64.cos()).abs() < 1e-15 && (p[1] - 0.25f64.sin()).abs() < 1e-15);
    let expect = [0.375f64.cos(), 0.0, 0.0, 0.375f64.sin()];
    for k in 0..4 {
        assert!((quat[k] - expect[k]).abs() < 1e-15);
    }
}

#[test]
fn dual_numbers_give_the_exact_derivative_of_aba() {
    let model = Model::new(&branched()).unwrap();
    let n = model.nq();
    let mut rng = Rng(5);
    let (q, qd, tau) = (
        rng.vec(n, -2.0, 2.0),
        rng.vec(n, -2.0, 2.0),
        rng.vec(n, -2.0, 2.0),
    );
    for k in 0..n {
        let qk: Vec<Dual64> = (0..n)
            .map(|i| {
                let d = Dual64::from(q[i]);
                if i == k {
                    d.derivative()
                } else {
                    d
                }
            })
            .collect();
        let lift = |v: &[f64]| v.iter().map(|&x| Dual64::from(x)).collect::<Vec<_>>();
        let exact = model.aba(&qk, &lift(&qd), &lift(&tau));
        let h = 1e-6;
        let mut plus = q.clone();
        plus[k] += h;
        let mut minus = q.clone();
        minus[k] -= h;
        let (a, b) = (model.aba(&plus, &qd, &tau), model.aba(&minus, &qd, &tau));
        for i in 0..n {
            let fd = (a[i] - b[i]) / (2.0 * h);
            assert!(
                (exact[i].eps - fd).abs() < 1e-6 * fd.abs().max(1.0),
                "∂q̈{i}/∂q{k}"
            );
            assert_eq!(exact[i].re, model.aba(&q, &qd, &tau)[i]);
        }
    }
}

// --- refusals -------------------------------------------------------------------------

/// A URDF with two links, `a` (massive) and `b`, and `body` in between.
fn urdf_with(body: &str) -> String {
    format!(
        r#"<robot name="r">
  <link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  {body}
</robot>"#
    )
}

const LINK_B: &str = r#"<link name="b"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>"#;

fn refusal(text: &str) -> String {
    match urdf::parse(text, "bad.urdf") {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => {
            let line = e.to_string();
            assert!(!line.contains('\n'), "one line: {line}");
            assert!(line.starts_with("bad.urdf"), "names the file: {line}");
            line
        }
    }
}

fn assert_says(message: &str, parts: &[&str]) {
    for p in parts {
        assert!(message.contains(p), "{message:?} should contain {p:?}");
    }
}

#[test]
fn missing_link_is_named() {
    let m = refusal(&urdf_with(
        r#"<joint name="elbow" type="revolute"><parent link="a"/><child link="forearm"/></joint>"#,
    ));
    assert_eq!(
        m,
        r#"bad.urdf:3: joint "elbow": child link "forearm" does not exist"#
    );
}

#[test]
fn malformed_xml_is_refused() {
    let m = refusal(r#"<robot name="r"><link name="a"></robot>"#);
    assert_says(&m, &["malformed XML"]);
    let m = refusal(r#"<robot name="r"><link name="a">"#);
    assert_says(&m, &["malformed XML"]);
    let m = refusal(r#"<robot name="r"><link name="a" mass=1/></robot>"#);
    assert_says(&m, &["malformed XML"]);
}

#[test]
fn a_file_that_is_not_a_robot_is_refused() {
    assert_says(
        &refusal(r#"<sdf version="1.6"><model/></sdf>"#),
        &["not a URDF robot", "<sdf>"],
    );
    assert_says(&refusal("<!-- nothing -->"), &["not a URDF robot"]);
}

#[test]
fn joint_types_are_checked() {
    let joint = |t: &str| {
        urdf_with(&format!(
            r#"{LINK_B}<joint name="j" type="{t}"><parent link="a"/><child link="b"/></joint>"#
        ))
    };
    assert_says(
        &refusal(&joint("spherical")),
        &[r#"joint "j""#, "unknown type \"spherical\""],
    );
    assert_says(
        &refusal(&joint("floating")),
        &[r#"joint "j""#, "\"floating\" is not supported"],
    );
    assert_says(
        &refusal(&joint("planar")),
        &[r#"joint "j""#, "\"planar\" is not supported"],
    );
    for ok in ["revolute", "continuous", "prismatic", "fixed"] {
        urdf::parse(&joint(ok), "ok.urdf").unwrap();
    }
}

#[test]
fn a_joint_without_parent_or_child_is_refused() {
    let m = refusal(&urdf_with(&format!(
        r#"{LINK_B}<joint name="j" type="revolute"><child link="b"/></joint>"#
    )));
    assert_says(&m, &[r#"joint "j""#, "has no <parent"]);
    let m = refusal(&urdf_with(
        r#"<joint name="k" type="fixed"><parent link="a"/></joint>"#,
    ));
    assert_says(&m, &["bad.urdf:3:", r#"joint "k""#, "has no <child"]);
}

#[test]
fn two_parents_are_refused() {
    let m = refusal(&urdf_with(&format!(
        r#"{LINK_B}<link name="c"/>
  <joint name="j1" type="fixed"><parent link="a"/><child link="b"/></joint>
  <joint name="j2" type="fixed"><parent link="c"/><child link="b"/></joint>"#
    )));
    assert_says(&m, &[r#"link "b""#, r#"two parents: joints "j1" and "j2""#]);
}

#[test]
fn cycles_are_refused() {
    let m = refusal(&urdf_with(&format!(
        r#"{LINK_B}<link name="c"/><link name="root"/>
  <joint name="j0" type="fixed"><parent link="root"/><child link="a"/></joint>
  <joint name="j1" type="revolute"><parent link="c"/><child link="b"/></joint>
  <joint name="j2" type="fixed"><parent link="b"/><child link="c"/></joint>"#
    )));
    assert_says(&m, &["cycle", r#""j1""#, r#""j2""#]);
}

#[test]
fn several_roots_are_refused() {
    let m = refusal(&urdf_with(LINK_B));
    assert_says(&m, &[r#"robot "r""#, "2 root links", r#""a""#, r#""b""#]);
}

#[test]
fn bad_masses_and_inertias_are_refused() {
    let link = |inertial: &str| {
        urdf_with(&format!(
            r#"<link name="bad"><inertial>{inertial}</inertial></link><joint name="j" type="revolute"><parent link="a"/><child link="bad"/></joint>"#
        ))
    };
    let m = refusal(&link(
        r#"<mass value="-1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>"#,
    ));
    assert_says(&m, &[r#"link "bad""#, "mass -1"]);
    let m = refusal(&link(
        r#"<mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="-1" iyz="0" izz="1"/>"#,
    ));
    assert_says(&m, &[r#"link "bad""#, "not positive definite"]);
    let m = refusal(&link(
        r#"<mass value="1"/><inertia ixx="1" ixy="2" ixz="0" iyy="1" iyz="0" izz="1"/>"#,
    ));
    assert_says(&m, &[r#"link "bad""#, "not positive definite"]);
    // A point mass on a moving joint: read with a warning; on the joint's axis it moves no
    // inertia, and the FMU is refused for its singular mass matrix.
    let point = urdf::parse(&link(r#"<mass value="1"/>"#), "ok.urdf").unwrap();
    let w = point.inertia_warnings();
    assert_eq!(w.len(), 1, "{w:?}");
    assert_says(&w[0], &[r#"link "bad""#, "a point mass"]);
    let e = Built::new(point).unwrap_err().to_string();
    assert_says(&e, &[r#"joint "j""#, "mass matrix is singular"]);
    // Off the axis it is a pendulum's bob: fine.
    let bob = urdf::parse(
        &link(r#"<origin xyz="0 0 -1"/><mass value="1"/>"#),
        "ok.urdf",
    )
    .unwrap();
    Built::new(bob).unwrap();
    // On a fixed joint a point mass is folded into its parent (a sensor's mass, as in
    // Talos's URDF): allowed, and the merged body is checked instead.
    let folded = |b_inertial: &str| {
        urdf_with(&format!(
            r#"<link name="b">{b_inertial}</link>
            <link name="sensor"><inertial><origin xyz="0.1 0 0"/><mass value="0.1"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
            <joint name="j" type="revolute"><parent link="a"/><child link="b"/></joint>
            <joint name="f" type="fixed"><parent link="b"/><child link="sensor"/></joint>"#
        ))
    };
    let ok = urdf::parse(
        &folded(r#"<inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>"#),
        "ok.urdf",
    )
    .unwrap();
    let merged = Model::new(&ok).unwrap();
    assert_eq!(merged.inertia[0].m, 1.1);
    // Folded into a massless link, it is still a point mass on a moving joint, here on the
    // joint's axis: the FMU is refused for its singular mass matrix, naming the joint.
    let bare = urdf::parse(&folded(""), "bare.urdf").unwrap();
    let e = Built::new(bare).unwrap_err().to_string();
    assert_says(&e, &[r#"joint "j""#, "mass matrix is singular"]);
    // The triangle inequality broken beyond rounding (allegro's link_11.0: by 20 %): no
    // rigid body, but the mass matrix stays positive definite; used as given, with a
    // warning naming the link. A zero moment (a thin rod) likewise; a negative one beyond
    // rounding is refused.
    let warned = |inertia: &str| {
        let m = urdf::parse(
            &link(&format!(r#"<mass value="1"/><inertia {inertia}/>"#)),
            "ok.urdf",
        )
        .unwrap();
        let w = m.inertia_warnings();
        assert_eq!(w.len(), 1, "{w:?}");
        w[0].clone()
    };
    let w = warned(r#"ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="3""#);
    assert_says(&w, &[r#"link "bad""#, "triangle inequality", "by 33.3%"]);
    let w = warned(r#"ixx="0" ixy="0" ixz="0" iyy="1.2e-4" iyz="0" izz="1.2e-4""#);
    assert_says(&w, &[r#"link "bad""#, "zero principal moment"]);
    let w = warned(r#"ixx="-2.2e-22" ixy="0" ixz="0" iyy="1" iyz="0" izz="1""#);
    assert_says(&w, &[r#"link "bad""#, "zero principal moment"]);
    let m = refusal(&link(
        r#"<mass value="1"/><inertia ixx="-1e-6" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>"#,
    ));
    assert_says(
        &m,
        &[r#"link "bad""#, "not positive definite", "beyond rounding"],
    );
    // A flat plate (I₁ + I₂ = I₃) printed with 5 digits is within the tolerance; a thin
    // rotated inertial frame is fine too.
    urdf::parse(
        &link(r#"<mass value="1"/><inertia ixx="0.33333" ixy="0" ixz="0" iyy="0.66666" iyz="0" izz="1.0"/>"#),
        "ok.urdf",
    )
    .unwrap();
    urdf::parse(&link(r#"<origin rpy="0.3 0.2 0.1"/><mass value="1"/><inertia ixx="0.3" ixy="0" ixz="0" iyy="0.6" iyz="0" izz="0.8"/>"#), "ok.urdf").unwrap();
    let m = refusal(&link(r#"<mass value="abc"/>"#));
    assert_says(&m, &[r#"link "bad""#, "not a finite number"]);
    let m = refusal(&link(r#"<mass value="1"/><inertia ixx="1" izz="1"/>"#));
    assert_says(&m, &[r#"link "bad""#, "<inertia> has no ixy"]);
    // The fixed base's inertia plays no part (go1, b1, anymal: principal moments of
    // −2.2e-22, 0 and 3e-6), nor does that of a link welded to it: not checked. A negative
    // mass is still refused.
    let base = |inertia: &str, mass: &str| {
        format!(
            r#"<robot name="r">
  <link name="a"><inertial><mass value="{mass}"/><inertia {inertia}/></inertial></link>
  <link name="trunk"><inertial><mass value="2"/><inertia {inertia}/></inertial></link>
  <joint name="weld" type="fixed"><parent link="a"/><child link="trunk"/></joint>
  {LINK_B}<joint name="j" type="revolute"><parent link="trunk"/><child link="b"/></joint>
</robot>"#
        )
    };
    let rough = r#"ixx="-2.2e-22" ixy="0" ixz="0" iyy="0" iyz="0" izz="3e-6""#;
    urdf::parse(&base(rough, "1"), "ok.urdf").unwrap();
    let m = refusal(&base(rough, "-1"));
    assert_says(&m, &[r#"link "a""#, "mass -1"]);
}

#[test]
fn a_robot_with_no_moving_joint_is_refused_with_a_line() {
    let m = urdf::parse(
        &urdf_with(&format!(
            r#"{LINK_B}<joint name="weld" type="fixed"><parent link="a"/><child link="b"/></joint>"#
        )),
        "ok.urdf",
    )
    .unwrap();
    let e = Built::new(m).unwrap_err().to_string();
    assert!(!e.contains('\n'), "{e}");
    assert_says(&e, &[r#"robot "r""#, "has no moving joint"]);
}

#[test]
fn massless_end_on_a_moving_joint_is_refused() {
    let m = refusal(&urdf_with(
        r#"<link name="tip"/><joint name="wrist" type="revolute"><parent link="a"/><child link="tip"/></joint>"#,
    ));
    assert_says(&m, &[r#"joint "wrist""#, r#""tip""#, "singular"]);
    // The same link welded on is fine.
    urdf::parse(
        &urdf_with(r#"<link name="tip"/><joint name="wrist" type="fixed"><parent link="a"/><child link="tip"/></joint>"#),
        "ok.urdf",
    )
    .unwrap();
}

#[test]
fn unexpanded_xacro_is_refused() {
    let m = refusal(&urdf_with(r#"<xacro:property name="l" value="1"/>"#));
    assert_says(&m, &["unexpanded xacro", "<xacro:property>"]);
    let m = refusal(&urdf_with(&format!(
        r#"{LINK_B}<joint name="j" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 ${{l}}"/></joint>"#
    )));
    assert_says(&m, &[r#"joint "j""#, "unexpanded xacro", "${l}"]);
}

const TWO_LINKS: &str = r#"<link name="b"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="c"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>"#;

#[test]
fn mimic_joints_are_read() {
    let text = urdf_with(&format!(
        r#"{TWO_LINKS}
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/></joint>
  <joint name="j2" type="revolute"><parent link="b"/><child link="c"/><mimic joint="j1" multiplier="-2" offset="0.5"/></joint>"#
    ));
    let m = urdf::parse(&text, "ok.urdf").unwrap();
    let mimic = m.joints[1].mimic.as_ref().unwrap();
    assert_eq!(
        (mimic.joint.as_str(), mimic.multiplier, mimic.offset),
        ("j1", -2.0, 0.5)
    );
    let model = Model::new(&m).unwrap();
    assert_eq!((model.nq(), model.ndof()), (2, 1));
    assert_eq!(model.driver(1), (0, -2.0));
    // Defaults 1 and 0, as URDF's.
    let text = text.replace(r#" multiplier="-2" offset="0.5""#, "");
    let m = urdf::parse(&text, "ok.urdf").unwrap();
    let mimic = m.joints[1].mimic.as_ref().unwrap();
    assert_eq!((mimic.multiplier, mimic.offset), (1.0, 0.0));
}

#[test]
fn bad_mimics_are_refused() {
    let joints = |j1: &str, j2: &str| {
        urdf_with(&format!(
            r#"{TWO_LINKS}
  <joint name="j1" type="{j1}"><parent link="a"/><child link="b"/><mimic joint="j2"/></joint>
  <joint name="j2" type="revolute"><parent link="b"/><child link="c"/><mimic joint="{j2}"/></joint>"#
        ))
    };
    let m = refusal(&joints("revolute", "j1"));
    assert_says(&m, &["cycle of mimic joints", r#""j1""#, r#""j2""#]);
    let m = refusal(&joints("revolute", "nowhere"));
    assert_says(
        &m,
        &[
            r#"joint "j2""#,
            r#"mimics joint "nowhere", which does not exist"#,
        ],
    );
    let m = refusal(&joints("fixed", "j1"));
    assert_says(
        &m,
        &[r#"joint "j2""#, r#"mimics joint "j1", which is fixed"#],
    );
    // A mimic on a fixed joint means nothing: read, then ignored.
    let text = urdf_with(&format!(
        r#"{TWO_LINKS}
  <joint name="j1" type="fixed"><parent link="a"/><child link="b"/><mimic joint="j2"/></joint>
  <joint name="j2" type="revolute"><parent link="b"/><child link="c"/></joint>"#
    ));
    let ignored = urdf::parse(&text, "ok.urdf").unwrap();
    let model = Model::new(&ignored).unwrap();
    assert_eq!((model.nq(), model.ndof()), (1, 1));
    let warned = super::fmu::unmodelled(&ignored);
    assert!(
        warned
            .iter()
            .any(|w| w.contains("ignored on a fixed joint") && w.contains(r#""j1""#)),
        "{warned:?}"
    );
    let notes = super::fmu::unmodelled_notes(&ignored);
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("A mimic element of 1 joint is ignored on a fixed joint")),
        "{notes:?}"
    );
    let m = refusal(&urdf_with(&format!(
        r#"{TWO_LINKS}
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/></joint>
  <joint name="j2" type="revolute"><parent link="b"/><child link="c"/><mimic joint="j1" multiplier="x"/></joint>"#
    )));
    assert_says(&m, &[r#"joint "j2""#, "multiplier", "not a finite number"]);
}

#[test]
fn builder_errors_name_the_element() {
    let m = Mechanism::new("arm")
        .body(Body::new("base", 1.0).inertia_diag([1.0; 3]))
        .body(Body::new("link", 1.0).inertia_diag([1.0; 3]))
        .revolute("j", "base", "link", Origin::IDENTITY, [0.0, 0.0, 0.0]);
    assert_says(
        &m.validate().unwrap_err().to_string(),
        &[r#"joint "j""#, "axis"],
    );
    let m = Mechanism::new("arm").body(Body::new("base", 1.0).inertia_diag([1.0; 3]));
    let m = m.revolute(
        "elbow",
        "base",
        "forearm",
        Origin::IDENTITY,
        [0.0, 0.0, 1.0],
    );
    assert_eq!(
        m.validate().unwrap_err().to_string(),
        r#"joint "elbow": child link "forearm" does not exist"#
    );
}

#[test]
fn origin_rpy_round_trips() {
    let o = Origin::new([1.0, 2.0, 3.0], [0.3, -0.7, 2.5]);
    let rpy = o.rpy();
    for (a, b) in rpy.iter().zip([0.3, -0.7, 2.5]) {
        assert!((a - b).abs() < 1e-14);
    }
    // URDF: R = Rz(y) Ry(p) Rx(r), so a pure yaw of 90° takes x to y.
    let yaw = Origin::new([0.0; 3], [0.0, 0.0, std::f64::consts::FRAC_PI_2]);
    assert!((yaw.rotation[1][0] - 1.0).abs() < 1e-15);
}

#[test]
fn articulated_and_rigid_inertia_transform_alike() {
    use super::spatial::{ArticulatedInertia, RigidInertia, Transform};
    let r = RigidInertia::from_com(
        1.7,
        &[0.1, -0.2, 0.3],
        &[[0.3, 0.01, 0.02], [0.01, 0.4, -0.03], [0.02, -0.03, 0.5]],
    );
    let o = Origin::new([0.4, -0.5, 0.6], [0.3, 0.2, -0.1]);
    let x = Transform {
        e: super::spatial::transpose(&o.rotation),
        r: o.xyz,
    };
    let a = ArticulatedInertia::from_rigid(&r).back(&x);
    let b = ArticulatedInertia::from_rigid(&r.back(&x));
    for (p, q) in [(a.a, b.a), (a.b, b.b), (a.c, b.c)] {
        for i in 0..3 {
            for j in 0..3 {
                assert!((p[i][j] - q[i][j]).abs() < 1e-14);
            }
        }
    }
}

#[test]
fn aba_traces_into_a_branch_free_graph() {
    use crate::model::symbolic::{record, Arg, Expr};
    // A tree, and the same with mimic joints (q̈ by the reduced mass matrix and LDLᵀ).
    for mechanism in [branched(), geared()] {
        let model = Model::new(&mechanism).unwrap();
        let n = model.nq();
        let (roots, graph) = record(|| {
            let q = Expr::inputs(Arg::Q, n);
            let qd = Expr::inputs(Arg::Qd, n);
            let tau = Expr::inputs(Arg::U, n);
            let qdd = model.aba(&q, &qd, &tau);
            let mut roots: Vec<u32> = qdd.iter().map(|e| e.id()).collect();
            roots.push(model.kinetic_energy(&q, &qd).id());
            roots.push(model.potential_energy(&q).id());
            roots
        });
        assert!(
            graph.branches.is_empty(),
            "looked at values: {:?}",
            graph.branches
        );
        let mut rng = Rng(9);
        for _ in 0..10 {
            let (q, qd, tau) = (
                rng.vec(n, -3.0, 3.0),
                rng.vec(n, -3.0, 3.0),
                rng.vec(n, -9.0, 9.0),
            );
            let traced = graph.eval(&roots, [&q, &qd, &tau, &[], &[]]);
            let mut direct = model.aba(&q, &qd, &tau);
            direct.push(model.kinetic_energy(&q, &qd));
            direct.push(model.potential_energy(&q));
            for (a, b) in traced.iter().zip(&direct) {
                assert!((a - b).abs() < 1e-11 * b.abs().max(1.0), "{a} vs {b}");
            }
        }
        eprintln!(
            "q̈ + energies of {} ({} joints, mimics: {}): {} nodes",
            mechanism.name,
            n,
            model.has_mimics(),
            graph.len()
        );
    }
}

// ---- The FMU adapter (fmu.rs) and the builder printer (source.rs) ----

use super::fmu::{Built, Declared, Robot};
use super::mechanism::Limit;
use crate::model::lagrangian::{self, Lagrangian};
use crate::model::System;

/// `branched()` with limits and efforts: the hip limited to (−0.5, 0.8) rad with effort
/// 40 N.m, the slide to (−0.1, 0.2) m with 50 N, the wrist (continuous) unlimited.
fn limited() -> Mechanism {
    let mut m = branched();
    for j in &mut m.joints {
        j.limit = match j.name.as_str() {
            "hip" => Limit {
                lower: Some(-0.5),
                upper: Some(0.8),
                effort: Some(40.0),
                velocity: Some(2.0),
            },
            "slide" => Limit {
                lower: Some(-0.1),
                upper: Some(0.2),
                effort: Some(50.0),
                velocity: None,
            },
            _ => Limit::default(),
        };
    }
    m.joints[0].friction = 0.2;
    m
}

crate::mechanism_fmu!(Tree, "Tree", limited, notes = ["a test mechanism"]);

/// `Robot<Tree>` on automatic differentiation only, whatever its generated path.
type TreeAd = lagrangian::AutoDiff<Robot<Tree>>;

#[test]
fn the_adapters_accelerations_are_aba_and_the_euler_lagrange_equations() {
    let model = Tree::model();
    let n = model.nq();
    assert_eq!(n, 5);
    let mut rng = Rng(0x5eed_f7ee);
    let p = [1.0];
    let mut worst: f64 = 0.0;
    for _ in 0..50 {
        let q = rng.vec(n, -1.0, 1.0);
        let qd = rng.vec(n, -2.0, 2.0);
        let u = rng.vec(n, -3.0, 3.0);
        let x: Vec<f64> = q.iter().chain(&qd).copied().collect();
        let mut dx = vec![0.0; 2 * n];
        <Robot<Tree> as System>::derivatives(0.0, &x, &u, &p, &mut dx);
        assert_eq!(&dx[..n], &qd[..]);
        // The generated path is exactly Model::aba (damping inside), the waist's Coulomb
        // friction 0.2 against its motion.
        let mut slipping = u.clone();
        slipping[0] -= 0.2 * qd[0].signum();
        assert_eq!(dx[n..].to_vec(), model.aba(&q, &qd, &slipping));
        // The Euler–Lagrange equations of T, V and Q = τ − d q̇ by automatic
        // differentiation: the same q̈ to rounding.
        let ad = lagrangian::accelerations::<TreeAd, f64>(0.0, &q, &qd, &u, &p);
        for (a, b) in ad.iter().zip(&dx[n..]) {
            worst = worst.max((a - b).abs() / b.abs().max(1.0));
        }
    }
    println!("worst relative difference ABA vs automatic differentiation: {worst:e}");
    assert!(worst < 1e-10, "{worst:e}");
}

/// `branched()` geared: the slide follows the shoulder (0.3 m/rad, offset 0.05 m) and the
/// damped hip follows the slide (−1.5 rad/m, offset 0.2 rad), a chain of mimics; waist,
/// shoulder and wrist keep coordinates of their own.
fn geared() -> Mechanism {
    let mut m = limited();
    for j in &mut m.joints {
        match j.name.as_str() {
            "slide" => *j = j.clone().mimic("shoulder", 0.3, 0.05),
            "hip" => *j = j.clone().mimic("slide", -1.5, 0.2),
            _ => {}
        }
    }
    m
}

crate::mechanism_fmu!(
    Geared,
    "Geared",
    geared,
    notes = ["a test mechanism with mimic joints"]
);

#[test]
fn mimic_joints_follow_and_their_dynamics_are_the_euler_lagrange_equations() {
    let b = Geared::built();
    let names: Vec<String> = b.coordinates.iter().map(|v| v.name.to_string()).collect();
    assert_eq!(names, ["waist", "shoulder", "wrist"]);
    let outputs: Vec<String> = b.outputs.iter().map(|v| v.name.to_string()).collect();
    assert_eq!(
        outputs[outputs.len() - 5..],
        ["slide", "slide_dot", "hip", "hip_dot", "tau_friction_waist"]
    );
    // The chain composed: hip = −1.5 (0.3 shoulder + 0.05) + 0.2.
    let hip = b.model.joints.iter().position(|j| j == "hip").unwrap();
    let f = b.model.follows[hip].unwrap();
    assert_eq!(b.model.joints[f.joint], "shoulder");
    assert!((f.multiplier + 0.45).abs() < 1e-15 && (f.offset - 0.125).abs() < 1e-15);
    // The hip's damping 0.4 acts on the shoulder through the multiplier: r² d.
    assert!(
        (b.damping[1] - 0.45 * 0.45 * 0.4).abs() < 1e-15,
        "{:?}",
        b.damping
    );
    let n = 3;
    let mut rng = Rng(0x006e_a2ed);
    let p = [1.0];
    let mut worst: f64 = 0.0;
    for _ in 0..50 {
        let q = rng.vec(n, -1.0, 1.0);
        let qd = rng.vec(n, -2.0, 2.0);
        let u = rng.vec(n, -3.0, 3.0);
        let x: Vec<f64> = q.iter().chain(&qd).copied().collect();
        let mut dx = vec![0.0; 2 * n];
        <Robot<Geared> as System>::derivatives(0.0, &x, &u, &p, &mut dx);
        // The Euler–Lagrange equations of T(q) and V(q) with the mimics expanded, by
        // automatic differentiation: an independent derivation of the reduced q̈.
        let ad = lagrangian::accelerations::<lagrangian::AutoDiff<Robot<Geared>>, f64>(
            0.0, &q, &qd, &u, &p,
        );
        for (a, b) in ad.iter().zip(&dx[n..]) {
            worst = worst.max((a - b).abs() / b.abs().max(1.0));
        }
        // The outputs: the mimics' positions and velocities follow.
        let mut y = vec![0.0; b.outputs.len()];
        <Robot<Geared> as Lagrangian>::extra_outputs(0.0, &q, &qd, &u, &p, &mut y);
        let at = y.len() - 5;
        assert!((y[at] - (0.3 * q[1] + 0.05)).abs() < 1e-15);
        assert!((y[at + 1] - 0.3 * qd[1]).abs() < 1e-15);
        assert!((y[at + 2] - (-1.5 * (0.3 * q[1] + 0.05) + 0.2)).abs() < 1e-15);
        assert!((y[at + 3] + 0.45 * qd[1]).abs() < 1e-15);
    }
    println!("worst relative difference reduced CRBA vs automatic differentiation: {worst:e}");
    assert!(worst < 1e-10, "{worst:e}");
}

/// example-robot-data's double pendulum (its SolidWorks export's numbers): two light links
/// balanced upright, damped.
fn upright_pendulum() -> Mechanism {
    let text = r#"<robot name="upright">
  <link name="base_link"/>
  <link name="link1"><inertial><origin xyz="0.0086107 2.1727E-06 0.036012"/><mass value="0.26703"/>
    <inertia ixx="0.00040827" ixy="1.2675E-09" ixz="1.8738E-05" iyy="0.00038791" iyz="3.5443E-08" izz="3.6421E-05"/></inertial></link>
  <joint name="joint1" type="revolute"><origin xyz="0.0060872 0 0.035"/><parent link="base_link"/><child link="link1"/>
    <axis xyz="1 0 0"/><dynamics damping="0.05"/></joint>
  <link name="link2"><inertial><origin xyz="-0.0050107 1.9371E-10 0.10088"/><mass value="0.33238"/>
    <inertia ixx="0.0011753" ixy="-3.854E-13" ixz="-2.9304E-08" iyy="0.0011666" iyz="-5.2365E-12" izz="1.4553E-05"/></inertial></link>
  <joint name="joint2" type="revolute"><origin xyz="0.023 0 0.1"/><parent link="link1"/><child link="link2"/>
    <axis xyz="1 0 0"/><dynamics damping="0.05"/></joint>
</robot>"#;
    urdf::parse(text, "upright.urdf").unwrap()
}

crate::mechanism_fmu!(Upright, "Upright", upright_pendulum);

/// The default experiment holds the mechanism at rest by its gravity torques: its states
/// stay within rounding of 0 (1e-21 rad here), and Gauss6's Newton iteration must accept
/// increments at the rounding of f there (it judged them against the states' own size, and
/// failed: the build's reference check of example-robot-data's double pendulum).
#[test]
fn gauss6_runs_a_mechanism_held_at_rest() {
    use crate::docs::run::{simulate, RunSettings};
    use crate::integrators::Method;
    let run = simulate::<Robot<Upright>>(
        &[],
        RunSettings {
            method: Method::Gauss6,
            tol: 1e-8,
            step: 1.25e-3,
            comm_step: 1e-2,
            stop: 2.0,
        },
    )
    .unwrap();
    assert!(run.failure.is_none(), "{:?}", run.failure);
}

#[test]
fn the_adapters_variables_are_named_after_joints_and_links() {
    let names = |v: Vec<crate::model::Var>| -> Vec<String> {
        v.iter().map(|v| v.name.to_string()).collect()
    };
    let units = |v: Vec<crate::model::Var>| -> Vec<String> {
        v.iter()
            .map(|v| v.unit.as_deref().unwrap_or("-").to_string())
            .collect()
    };
    type R = Robot<Tree>;
    // Depth first from the root, children in declaration order.
    let joints = ["waist", "shoulder", "slide", "wrist", "hip"];
    assert_eq!(names(R::coordinates()), joints);
    assert_eq!(units(R::coordinates()), ["rad", "rad", "m", "rad", "rad"]);
    assert_eq!(
        names(R::velocities()),
        joints.map(|j| format!("{j}_dot")).to_vec()
    );
    assert_eq!(
        units(R::velocities()),
        ["rad/s", "rad/s", "m/s", "rad/s", "rad/s"]
    );
    assert_eq!(
        names(<R as Lagrangian>::inputs()),
        joints.map(|j| format!("tau_{j}")).to_vec()
    );
    let inputs = <R as Lagrangian>::inputs();
    assert_eq!(units(inputs.clone()), ["N.m", "N.m", "N", "N.m", "N.m"]);
    assert_eq!((inputs[4].min, inputs[4].max), (Some(-40.0), Some(40.0)));
    assert_eq!((inputs[2].min, inputs[2].max), (Some(-50.0), Some(50.0)));
    assert_eq!((inputs[0].min, inputs[0].max), (None, None));
    assert!(inputs[4].description.contains("±40.0 N.m"));
    // The ends of branches: "hand" (behind the fixed "mount") and "leg".
    let mut outputs = vec!["E".to_string()];
    for link in ["hand", "leg"] {
        for s in ["x", "y", "z", "q0", "q1", "q2", "q3"] {
            outputs.push(format!("{link}_{s}"));
        }
    }
    // The end stops' reactions, in coordinate order: the slide, then the hip; then the
    // waist's friction force.
    outputs.extend([
        "tau_stop_slide".into(),
        "tau_stop_hip".into(),
        "tau_friction_waist".into(),
    ]);
    assert_eq!(names(<R as Lagrangian>::outputs()), outputs);
    assert_eq!(
        names(<R as Lagrangian>::parameters()),
        ["limit_events", "restitution"]
    );
    assert!(!<R as System>::explicit_time(&[1.0]).0);
    assert_eq!(
        <R as Lagrangian>::EQUATIONS.last(),
        Some(&"a test mechanism")
    );
    // The start: 0 inside the limits; the inputs hold it against gravity.
    let built = Tree::built();
    let x0: Vec<f64> = built.start.iter().chain(&[0.0; 5]).copied().collect();
    let mut dx = vec![0.0; 10];
    <R as System>::derivatives(0.0, &x0, &built.hold, &[1.0], &mut dx);
    assert!(dx.iter().all(|v| v.abs() < 1e-12), "{dx:?}");
    // Outputs: E = T + V and the tips' poses as Model::tip_poses.
    let mut rng = Rng(42);
    let (q, qd) = (rng.vec(5, -1.0, 1.0), rng.vec(5, -1.0, 1.0));
    let mut y = vec![0.0; 17];
    <R as Lagrangian>::extra_outputs(0.0, &q, &qd, &[0.0; 5], &[2.0, 0.0], &mut y);
    let model = Tree::model();
    assert_eq!(
        y[0],
        model.kinetic_energy(&q, &qd) + model.potential_energy(&q)
    );
    let tips = model.tip_poses(&q);
    assert_eq!(&y[1..4], &tips[0].0);
    assert_eq!(&y[4..8], &tips[0].1);
    assert_eq!(&y[8..11], &tips[1].0);
}

#[test]
fn the_unmodelled_is_named() {
    // Friction is modelled in a tree, not in a mechanism with loop closures.
    let lines = super::fmu::unmodelled(&limited());
    assert_eq!(lines.len(), 1, "{lines:?}");
    assert!(lines[0].contains("velocity limits") && lines[0].contains("\"hip\" (2.0)"));
    let notes = super::fmu::unmodelled_notes(&limited());
    assert_eq!(
        notes,
        ["Velocity limits of 1 joint are not enforced (the build warning names them)"]
    );
    let mut looped = limited();
    looped.closures.push(crate::multibody::Closure {
        name: "c".into(),
        body_a: "a".into(),
        point_a: [0.0; 3],
        body_b: "b".into(),
        point_b: [0.0; 3],
        axes: "xz".into(),
    });
    let lines = super::fmu::unmodelled(&looped);
    assert!(
        lines[0].contains("Coulomb friction is not modelled in a mechanism with loop closures")
            && lines[0].contains("\"waist\" (0.2)"),
        "{lines:?}"
    );
}

#[test]
fn names_that_clash_are_refused() {
    let m = limited();
    let mut clash = m.clone();
    clash.joints[0].name = "solver".into();
    let e = Built::new(clash).unwrap_err().to_string();
    assert!(e.starts_with("joint \"solver\": its position variable \"solver\" would also be a variable of the FMU itself"), "{e}");
    let mut clash = m.clone();
    clash.joints[1].name = "waist_dot".into();
    let e = Built::new(clash).unwrap_err().to_string();
    assert!(e.starts_with("joint \"waist\": its velocity variable \"waist_dot\" would also be the position of joint \"waist_dot\""), "{e}");
    let mut clash = m;
    let hip = clash.joints.iter().position(|j| j.name == "hip").unwrap();
    clash.joints[hip].name = "hand_x".into();
    let e = Built::new(clash).unwrap_err().to_string();
    assert!(
        e.starts_with(
            "link \"hand\": its output \"hand_x\" would also be the position of joint \"hand_x\""
        ),
        "{e}"
    );
}

#[test]
fn the_builder_source_spells_every_value_exactly() {
    let text = double_pendulum_urdf();
    let m = urdf::parse(&text, "dp.urdf").unwrap();
    let src = super::source::builder(&m);
    println!("{src}");
    assert!(src.starts_with("Mechanism::new(\"double_pendulum\")"));
    assert!(src.contains(".body(Body::massless(\"base\"))"));
    assert!(src.contains(&format!("Body::new(\"upper\", {M1:?})")));
    assert!(src.contains(".limit(Limit { lower: Some(-3.0), upper: Some(3.0), effort: Some(10.0), velocity: Some(5.0) })"));
    // An axis "0 2 0" was normalised on reading: printed as the unit vector.
    assert!(src.contains(".axis([0.0, 1.0, 0.0])"));
    let tree = super::source::builder(&branched());
    println!("{tree}");
    assert!(
        tree.contains("Origin::new([0.0, 0.0, 0.5], [0.1, -0.2, 0.3])")
            || tree.contains("Origin { xyz: [0.0, 0.0, 0.5]")
    );
    assert!(tree.contains(".damping(0.4)"));
    let geared = super::source::builder(&geared());
    assert!(
        geared.contains(".mimic(\"shoulder\", 0.3, 0.05)"),
        "{geared}"
    );
}

/// A quarter turn as exporters write it (1.570796325, not π/2): the pitch next to ±π/2 is
/// recovered by atan2 and printed as written, not as the matrix.
#[test]
#[allow(clippy::approx_constant)] // rounded on purpose: as exporters write π/2 and π
fn the_builder_source_keeps_rpy_next_to_a_quarter_turn() {
    for rpy in [
        [0.0, 1.570796325, 0.0],
        [0.3, -1.5707963, 0.2],
        [3.14159265, 0.0, -1.5707963],
    ] {
        let m = Mechanism::new("q")
            .body(Body::massless("a"))
            .body(Body::new("b", 1.0).inertia_diag([1.0, 1.0, 1.0]))
            .revolute("j", "a", "b", Origin::new([0.0; 3], rpy), [0.0, 0.0, 1.0]);
        let src = super::source::builder(&m);
        assert!(
            src.contains(&format!(
                "Origin::new([0.0, 0.0, 0.0], [{:?}, {:?}, {:?}])",
                rpy[0], rpy[1], rpy[2]
            )),
            "{src}"
        );
    }
}
