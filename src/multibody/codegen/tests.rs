use super::*;
use crate::multibody::generated;

/// A small deterministic generator (xorshift), as in the multibody tests.
struct Rng(u64);

impl Rng {
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
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
