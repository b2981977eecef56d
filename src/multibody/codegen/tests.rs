use super::*;
use crate::multibody::generated;

/// A small deterministic generator (xorshift), uniform in [lo, hi): also the closed-loop
/// tests'.
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    pub(crate) fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
    fn vec(&mut self, n: usize, lo: f64, hi: f64) -> Vec<f64> {
        (0..n).map(|_| self.uniform(lo, hi)).collect()
    }
}

/// `|a − b| ≤ tol · max(|b|, scale)` elementwise, `scale` the largest |b|.
fn assert_close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    let scale = b.iter().fold(1.0f64, |m, x| m.max(x.abs()));
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= tol * scale,
            "{what}[{i}]: {x} vs {y} (scale {scale})"
        );
    }
}

fn state(rng: &mut Rng, n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    (
        rng.vec(n, -3.0, 3.0),
        rng.vec(n, -3.0, 3.0),
        rng.vec(n, -20.0, 20.0),
    )
}

#[test]
fn every_algorithm_equals_model_aba() {
    let mut rng = Rng(0x5eed);
    for module in ["ur5", "panda", "chain_1", "chain_2", "chain_8", "chain_64"] {
        let model = benchmark_model(module);
        let n = model.nq();
        for _ in 0..5 {
            let (q, qd, tau) = state(&mut rng, n);
            let want = snapped(&model).aba(&q, &qd, &tau);
            assert_close(&want, &model.aba(&q, &qd, &tau), 1e-10, "snapped");
            for alg in [Algorithm::AbaFolded, Algorithm::CrbaLdl] {
                if alg == Algorithm::CrbaLdl && n > 9 {
                    continue; // the long chain's M is too ill-conditioned for 1e-12
                }
                let got = forward_dynamics(&snapped(&model), alg, &q, &qd, &tau);
                assert_close(&got, &want, 1e-12, &format!("{module} {alg:?}"));
            }
        }
    }
}

/// How many operations each algorithm leaves after folding (run with --ignored
/// --nocapture: it traces every model three times).
#[test]
#[ignore]
fn operation_counts() {
    let mut names: Vec<String> = vec!["ur5".into(), "panda".into()];
    names.extend(CHAIN_SIZES.iter().map(|n| format!("chain_{n}")));
    for module in names {
        let model = benchmark_model(&module);
        let mut line = format!("{module:9} n = {:2}:", model.nq());
        for alg in [Algorithm::Aba, Algorithm::AbaFolded, Algorithm::CrbaLdl] {
            let t = trace(&model, alg, None);
            let st = straight_line(&t.graph, &t.qdd, &leaf_name);
            line += &format!("  {alg:?} {} ops", st.operations);
        }
        let alg = fewest_operations(&model);
        for how in [
            Jacobian::ForwardOfForwardDynamics,
            Jacobian::InverseDynamics,
        ] {
            if model.nq() > 16 || (how == Jacobian::ForwardOfForwardDynamics && model.nq() > 9) {
                continue;
            }
            let t = trace(&model, alg, Some(how));
            let roots: Vec<Id> = t.qdd.iter().chain(&t.dq).chain(&t.dqd).copied().collect();
            let st = straight_line(&t.graph, &roots, &leaf_name);
            line += &format!("  | {alg:?} + {how:?} {} ops", st.operations);
        }
        eprintln!("{line}");
    }
}

/// The committed generated code is what the generator writes now
/// (`MBFMU_REGENERATE=1` rewrites it).
#[test]
fn generated_code_is_current() {
    let (_, files) = generate_all();
    let dir = generated_dir();
    let rewrite = std::env::var_os("MBFMU_REGENERATE").is_some();
    let mut stale = Vec::new();
    for (name, source) in &files {
        let path = dir.join(name);
        if rewrite {
            std::fs::write(&path, source).unwrap();
        } else if std::fs::read_to_string(&path).ok().as_deref() != Some(source.as_str()) {
            stale.push(name.clone());
        }
    }
    assert!(
        stale.is_empty(),
        "stale generated code in {}: {stale:?}; rerun with MBFMU_REGENERATE=1",
        dir.display()
    );
}

/// The committed modules' `aba` and `aba_derivatives` (where emitted), by module name.
type AbaFn<S> = fn(&[S], &[S], &[S], &mut [S]);
type DerFn = fn(&[f64], &[f64], &[f64], &mut [f64], &mut [f64], &mut [f64]);

macro_rules! committed {
    ($S:ty; $($m:ident)*) => {
        vec![$((stringify!($m), generated::$m::aba::<$S> as AbaFn<$S>)),*]
    };
}

fn committed_f64() -> Vec<(&'static str, AbaFn<f64>)> {
    committed!(f64; ur5 panda chain_1 chain_2 chain_4 chain_8 chain_16 chain_32 chain_64)
}

fn committed_dual() -> Vec<(&'static str, AbaFn<num_dual::Dual64>)> {
    committed!(num_dual::Dual64; ur5 panda chain_1 chain_2 chain_4 chain_8 chain_16 chain_32 chain_64)
}

fn committed_derivatives() -> Vec<(&'static str, DerFn)> {
    use generated::*;
    vec![
        ("ur5", ur5::aba_derivatives::<f64> as DerFn),
        ("panda", panda::aba_derivatives::<f64>),
        ("chain_1", chain_1::aba_derivatives::<f64>),
        ("chain_2", chain_2::aba_derivatives::<f64>),
        ("chain_4", chain_4::aba_derivatives::<f64>),
        ("chain_8", chain_8::aba_derivatives::<f64>),
    ]
}

#[test]
fn generated_aba_equals_model_aba() {
    let mut rng = Rng(0xaba);
    for (module, aba) in committed_f64() {
        let model = benchmark_model(module);
        let exact = snapped(&model);
        let n = model.nq();
        let mut qdd = vec![0.0; n];
        for _ in 0..20 {
            let (q, qd, tau) = state(&mut rng, n);
            aba(&q, &qd, &tau, &mut qdd);
            assert_close(&qdd, &exact.aba(&q, &qd, &tau), 1e-12, module);
            assert_close(&qdd, &model.aba(&q, &qd, &tau), 1e-10, module);
        }
    }
}

/// ∂q̈/∂(q, q̇) by dual numbers through the generated code and through `Model::aba`, and
/// the symbolic `aba_derivatives` where emitted.
#[test]
fn generated_jacobians_equal_model_aba_jacobians() {
    use num_dual::Dual64;
    let mut rng = Rng(0xd1a1);
    let derivatives = committed_derivatives();
    for (module, aba) in committed_dual() {
        let model = snapped(&benchmark_model(module));
        let n = model.nq();
        let (q, qd, tau) = state(&mut rng, n);
        let lift = |v: &[f64]| v.iter().map(|&x| Dual64::from(x)).collect::<Vec<_>>();
        let (mut dq, mut dqd) = (vec![0.0; n * n], vec![0.0; n * n]);
        let (mut want_q, mut want_qd) = (vec![0.0; n * n], vec![0.0; n * n]);
        let mut out = vec![Dual64::from(0.0); n];
        for j in 0..n {
            for wrt_q in [true, false] {
                let (mut xq, mut xqd) = (lift(&q), lift(&qd));
                if wrt_q {
                    xq[j].eps = 1.0;
                } else {
                    xqd[j].eps = 1.0;
                }
                aba(&xq, &xqd, &lift(&tau), &mut out);
                let want = model.aba(&xq, &xqd, &lift(&tau));
                let (got, exp) = if wrt_q {
                    (&mut dq, &mut want_q)
                } else {
                    (&mut dqd, &mut want_qd)
                };
                for i in 0..n {
                    got[i * n + j] = out[i].eps;
                    exp[i * n + j] = want[i].eps;
                }
            }
        }
        assert_close(&dq, &want_q, 1e-11, &format!("{module} ∂q̈/∂q"));
        assert_close(&dqd, &want_qd, 1e-11, &format!("{module} ∂q̈/∂q̇"));
        if let Some((_, der)) = derivatives.iter().find(|(m, _)| *m == module) {
            let (mut qdd, mut sq, mut sqd) = (vec![0.0; n], vec![0.0; n * n], vec![0.0; n * n]);
            der(&q, &qd, &tau, &mut qdd, &mut sq, &mut sqd);
            assert_close(&qdd, &model.aba(&q, &qd, &tau), 1e-12, module);
            assert_close(&sq, &want_q, 1e-11, &format!("{module} symbolic ∂q̈/∂q"));
            assert_close(&sqd, &want_qd, 1e-11, &format!("{module} symbolic ∂q̈/∂q̇"));
        }
    }
}

/// The `aba` a robot's crate gets ([`robot_dynamics`]) is the committed, tested one of the
/// same model where snapping within [`EXACT_SNAP`] and [`SNAP`] agree (Panda: its angles
/// are exact doubles), but for the path it names the library by; not where they do not
/// (UR5's 1.57079632679, which [`SNAP`] takes: tests/urdf_crate.rs compiles UR5's crate
/// and compares its q̈ with `Model::aba`); its `FINGERPRINT` is the model's; a mechanism
/// with loop closures gets none.
#[test]
fn a_robot_crate_gets_the_committed_aba() {
    let function = |source: &str| {
        let at = source.find("pub fn aba<").expect("an aba");
        let end = at + source[at..].find("\n}\n").expect("its end");
        source[at..end].to_string()
    };
    for module in ["ur5", "panda"] {
        let path = generated_dir().join(format!("urdf/{module}.urdf"));
        let mechanism = super::super::urdf::load(&path).unwrap();
        let g = robot_dynamics(&mechanism, "mbfmu")
            .unwrap()
            .expect("a tree");
        let committed = std::fs::read_to_string(generated_dir().join(format!("{module}.rs")));
        let same = function(&g.source) == function(&committed.unwrap());
        assert_eq!(same, module == "panda", "{module}");
        assert!(g.source.contains("use mbfmu::model::Scalar;"));
        assert!(!g.source.contains("crate::"));
        assert!(!g.source.contains("aba_derivatives"));
        let model = Model::new(&mechanism).unwrap();
        let line = format!(
            "pub const FINGERPRINT: u64 = {:#018x};",
            fingerprint(&model)
        );
        assert!(g.source.contains(&line), "{module}");
    }
    let looped = crate::systems::four_bar::mechanism();
    assert!(robot_dynamics(&looped, "mbfmu").unwrap().is_none());
}

/// A state of a floating model in the generated code's layout
/// ([`floating_dynamics`]): joints, then the base's position and a random quaternion (not
/// unit: the rotation is homogeneous); joints' rates, then the base's v, ω; torques. A mimic
/// joint's position and rate follow the joint it names.
fn floating_state(rng: &mut Rng, model: &Model) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = model.nq();
    let (mut q, mut qd, tau) = state(rng, n);
    for i in 0..n {
        if let Some(f) = &model.follows[i] {
            q[i] = f.multiplier * q[f.joint] + f.offset;
            qd[i] = f.multiplier * qd[f.joint];
        }
    }
    if model.free_base.is_some() {
        q.extend(rng.vec(3, -2.0, 2.0));
        q.extend(rng.vec(4, -1.0, 1.0));
        qd.extend(rng.vec(6, -2.0, 2.0));
    }
    (q, qd, tau)
}

/// The interpreted floating dynamics in the generated layout: [`Model::aba_free_in`] with
/// the rotation of a quaternion normalised first (the interpreted path's input).
fn interpreted_floating(model: &Model, q: &[f64], qd: &[f64], tau: &[f64]) -> Vec<f64> {
    use crate::multibody::spatial::{quat_to_matrix, Motion};
    let n = model.nq();
    let quat = [q[n + 3], q[n + 4], q[n + 5], q[n + 6]];
    let norm = quat.iter().map(|x| x * x).sum::<f64>().sqrt();
    let velocity = Motion {
        ang: [qd[n + 3], qd[n + 4], qd[n + 5]],
        lin: [qd[n], qd[n + 1], qd[n + 2]],
    };
    let mut out = vec![0.0; n + 6];
    let a0 = model.aba_free_in(
        &mut crate::multibody::Data::new(model),
        &quat_to_matrix(&quat.map(|x| x / norm)),
        &velocity,
        &q[..n],
        &qd[..n],
        tau,
        &mut out[..n],
    );
    out[n..n + 3].copy_from_slice(&a0.lin);
    out[n + 3..].copy_from_slice(&a0.ang);
    out
}

/// The floating base's and mimic joints' generated code: the traced graph (evaluated) and
/// the committed modules equal the interpreted dynamics ([`Model::aba_free_in`],
/// [`Model::aba`]'s reduced path) at random states, 1e-12 relative; the floating arm with
/// and without a mimic joint (prismatic joint, products of inertia, an off-origin root).
#[test]
fn floating_and_mimic_code_equals_the_interpreted_dynamics() {
    use crate::multibody::floating_tests::{with_mimic, ARM};
    let mut rng = Rng(0xf10a7);
    let arm = |text: &str| {
        let mut m = super::super::urdf::parse(text, "arm.urdf").unwrap();
        m.floating_base = true;
        Model::new(&m).unwrap()
    };
    for (what, model) in [("arm", arm(ARM)), ("arm with a mimic", arm(&with_mimic()))] {
        let t = trace(&model, Algorithm::Aba, None);
        let exact = snapped(&model);
        for _ in 0..10 {
            let (q, qd, tau) = floating_state(&mut rng, &model);
            let got = t.graph.eval(&t.qdd, [&q, &qd, &tau, &[], &[]]);
            assert_close(
                &got,
                &interpreted_floating(&exact, &q, &qd, &tau),
                1e-12,
                what,
            );
        }
    }
    let go2 = benchmark_model("go2_floating");
    let panda = benchmark_model("panda_mimic");
    assert!(go2.free_base.is_some() && panda.has_mimics());
    let mut out = vec![0.0; go2.nq() + 6];
    for _ in 0..20 {
        let (q, qd, tau) = floating_state(&mut rng, &go2);
        generated::go2_floating::aba(&q, &qd, &tau, &mut out);
        let want = interpreted_floating(&snapped(&go2), &q, &qd, &tau);
        assert_close(&out, &want, 1e-12, "go2_floating");
        let literal = interpreted_floating(&go2, &q, &qd, &tau);
        assert_close(&out, &literal, 1e-10, "go2_floating (literal)");
        let (q, qd, tau) = floating_state(&mut rng, &panda);
        let mut qdd = vec![0.0; panda.nq()];
        generated::panda_mimic::aba(&q, &qd, &tau, &mut qdd);
        assert_close(
            &qdd,
            &snapped(&panda).aba(&q, &qd, &tau),
            1e-12,
            "panda_mimic",
        );
    }
}
