//! The crate `mbfmu build --urdf` (and `mbfmu new --from-urdf`) writes for a robot, compiled
//! here as a module: UR5's `src/lib.rs` and `src/dynamics.rs` as the writer writes them now
//! (committed under `tests/generated/ur5_fmu/`; `MBFMU_BLESS=1 cargo test --release --test
//! urdf_crate` rewrites them). Its declaration runs the straight-line q̈ generated for it,
//! which equals the interpreted articulated-body algorithm (`Model::aba`) to 1e-12; a
//! mechanism edited after its code was generated runs the interpreted algorithm instead,
//! and its describe answer carries the code generated again (which `mbfmu build` writes).

use mbfmu::model::lagrangian::Lagrangian;
use mbfmu::multibody::fmu::{Declared, Robot};
use mbfmu::multibody::{codegen, urdf, Mechanism};
use mbfmu::package::protocol;
use std::path::{Path, PathBuf};

#[rustfmt::skip]
#[allow(clippy::all)]
#[path = "generated/ur5_fmu/lib.rs"]
mod ur5_fmu;

#[rustfmt::skip]
#[allow(dead_code, clippy::all, clippy::approx_constant, clippy::excessive_precision, clippy::unreadable_literal)]
#[path = "generated/ur5_fmu/dynamics.rs"]
mod ur5_dynamics;

use ur5_fmu::Ur5;

fn ur5_urdf() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src/multibody/generated/urdf/ur5.urdf")
}

fn ur5() -> Mechanism {
    urdf::load(&ur5_urdf()).unwrap()
}

/// UR5 with its forearm 10 % heavier: not the mechanism the committed code was generated
/// from.
fn edited_ur5() -> Mechanism {
    let mut m = ur5();
    let forearm = m
        .bodies
        .iter_mut()
        .find(|b| b.name == "forearm_link")
        .unwrap();
    forearm.mass *= 1.1;
    m
}

// The committed code declared with the edited mechanism, as a crate whose lib.rs was
// edited after `mbfmu build` wrote its dynamics.
mbfmu::mechanism_fmu!(pub EditedUr5, "EditedUr5", edited_ur5, {
    const GENERATED_FROM: Option<u64> = Some(ur5_dynamics::FINGERPRINT);
    fn generated_aba<S: mbfmu::model::Scalar>(q: &[S], qd: &[S], tau: &[S], qdd: &mut [S]) -> bool {
        ur5_dynamics::aba(q, qd, tau, qdd);
        true
    }
});

/// The files `write_mechanism_crate` writes for UR5 now are the committed ones.
#[test]
fn the_committed_crate_is_what_the_writer_writes() {
    let dir = std::env::temp_dir().join(format!("mbfmu-urdf-crate-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let source = "src/multibody/generated/urdf/ur5.urdf";
    let command = format!("build --urdf {source}");
    let from = mbfmu::own_model::MechanismSource {
        source,
        command: &command,
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    mbfmu::own_model::write_mechanism_crate("ur5", &dir, root, &ur5(), &from, false).unwrap();
    let committed = root.join("tests/generated/ur5_fmu");
    let mut stale = Vec::new();
    for file in ["lib.rs", "dynamics.rs"] {
        let text = std::fs::read_to_string(dir.join("src").join(file)).unwrap();
        if std::env::var_os("MBFMU_BLESS").is_some() {
            std::fs::create_dir_all(&committed).unwrap();
            std::fs::write(committed.join(file), &text).unwrap();
        }
        if std::fs::read_to_string(committed.join(file)).unwrap_or_default() != text {
            stale.push(file);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        stale.is_empty(),
        "{stale:?} out of date: rerun with MBFMU_BLESS=1"
    );
    // The wiring: the module, the hook, the fingerprint of this mechanism.
    let lib = std::fs::read_to_string(committed.join("lib.rs")).unwrap();
    for needle in [
        "mod dynamics;",
        "const GENERATED_FROM: Option<u64> = Some(dynamics::FINGERPRINT);",
        "dynamics::aba(q, qd, tau, qdd);",
        "mbfmu::export_fmu!(mechanism Ur5);",
    ] {
        assert!(lib.contains(needle), "lib.rs lacks {needle}");
    }
    let model = mbfmu::multibody::Model::new(&ur5()).unwrap();
    assert_eq!(ur5_dynamics::FINGERPRINT, codegen::fingerprint(&model));
    assert_eq!(Ur5::built().fingerprint, ur5_dynamics::FINGERPRINT);
}

/// A small deterministic generator (xorshift).
struct Rng(u64);

impl Rng {
    fn vec(&mut self, n: usize, lo: f64, hi: f64) -> Vec<f64> {
        (0..n)
            .map(|_| {
                self.0 ^= self.0 << 13;
                self.0 ^= self.0 >> 7;
                self.0 ^= self.0 << 17;
                lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
            })
            .collect()
    }
}

/// The largest |a − b| / max(1, |b|).
fn relative(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / y.abs().max(1.0))
        .fold(0.0, f64::max)
}

fn runs<D: Declared>() -> protocol::Records {
    type R<D> = Robot<D>;
    let answer =
        mbfmu::describe::respond_mechanism::<R<D>>(&protocol::encode(&[("request", "symbolic")]));
    protocol::parse_response(&answer).unwrap()
}

/// The crate's declaration runs its generated dynamics (the describe answer says so, and
/// its q̈ is the generated function's, bit for bit), equal to `Model::aba` to 1e-12
/// relative at 100 random states and torques; with its mechanism edited it runs
/// `Model::aba` of the edited mechanism and answers the code generated for it.
#[test]
fn the_crate_runs_its_generated_dynamics_and_an_edited_one_does_not() {
    let answer = runs::<Ur5>();
    assert_eq!(
        protocol::value(&answer, "runs"),
        Some("runs straight-line code generated for this mechanism: 6 moving joints, q̈ in O(n)")
    );
    assert!(protocol::value(&answer, "dynamics").is_none());
    // The generated code is the model with rotation entries within 1e-14 of 0 or ±1
    // snapped (codegen::EXACT_SNAP: `cos(π/2)`, not UR5's 1.57079632679): equal to that
    // model's `Model::aba` and to the literal URDF's to rounding.
    let model = Ur5::model();
    let exact = codegen::snapped_within(model, codegen::EXACT_SNAP);
    let edited = EditedUr5::model();
    let mut rng = Rng(0x0005_eed5);
    let (mut worst, mut worst_literal, mut worst_edited) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..100 {
        let q = rng.vec(6, -3.2, 3.2);
        let qd = rng.vec(6, -2.0, 2.0);
        let tau = rng.vec(6, -20.0, 20.0);
        let mut qdd = [0.0; 6];
        assert!(Robot::<Ur5>::generated_eom(
            0.0,
            &q,
            &qd,
            &tau,
            &[1.0],
            &mut qdd,
            &mut []
        ));
        let mut direct = [0.0; 6];
        ur5_dynamics::aba(&q, &qd, &tau, &mut direct);
        assert_eq!(qdd, direct, "not the generated code");
        worst = worst.max(relative(&qdd, &exact.aba(&q, &qd, &tau)));
        worst_literal = worst_literal.max(relative(&qdd, &model.aba(&q, &qd, &tau)));
        let mut qdd = [0.0; 6];
        assert!(Robot::<EditedUr5>::generated_eom(
            0.0,
            &q,
            &qd,
            &tau,
            &[1.0],
            &mut qdd,
            &mut []
        ));
        assert_eq!(
            qdd.to_vec(),
            edited.aba(&q, &qd, &tau),
            "the stale code ran"
        );
        worst_edited = worst_edited.max(relative(&direct, &edited.aba(&q, &qd, &tau)));
    }
    println!(
        "generated vs Model::aba: {worst:.1e} (of the literal URDF: {worst_literal:.1e}); the edit changes q̈ by {worst_edited:.1e}"
    );
    assert!(worst < 1e-12, "{worst}");
    assert!(worst_literal < 1e-12, "{worst_literal}");
    assert!(worst_edited > 1e-6, "the edit does not show");
    let answer = runs::<EditedUr5>();
    assert_eq!(
        protocol::value(&answer, "runs"),
        Some("runs the articulated-body algorithm (Featherstone) on its model: 6 moving joints, q̈ in O(n) (its generated code is of another mechanism: not run)")
    );
    let regenerated = protocol::value(&answer, "dynamics").expect("the code generated again");
    let fingerprint = codegen::fingerprint(edited);
    assert_ne!(fingerprint, ur5_dynamics::FINGERPRINT);
    assert!(regenerated.contains(&format!(
        "pub const FINGERPRINT: u64 = {fingerprint:#018x};"
    )));
}

// ----- what the generated dynamics buy the FMU (run with --ignored --nocapture) ---------

fn panda() -> Mechanism {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("src/multibody/generated/urdf/panda.urdf");
    urdf::load(&path).unwrap()
}

// The interpreted path: what a URDF FMU ran before its crate got src/dynamics.rs.
mbfmu::mechanism_fmu!(pub Ur5Interpreted, "Ur5Interpreted", ur5);
mbfmu::mechanism_fmu!(pub PandaInterpreted, "PandaInterpreted", panda);
// The Panda's crate runs the committed module's `aba` (a_robot_crate_gets_the_committed_aba
// in src/multibody/codegen/tests.rs: the same function).
mbfmu::mechanism_fmu!(pub PandaGenerated, "PandaGenerated", panda, {
    fn generated_aba<S: mbfmu::model::Scalar>(q: &[S], qd: &[S], tau: &[S], qdd: &mut [S]) -> bool {
        mbfmu::multibody::generated::panda::aba(q, qd, tau, qdd);
        true
    }
});

/// Best ns per call of `f` over `reps` loops of ~20 ms.
fn best_ns(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut calls = 1usize;
    loop {
        let t = std::time::Instant::now();
        for _ in 0..calls {
            f();
        }
        if t.elapsed().as_secs_f64() > 0.02 {
            break;
        }
        calls *= 2;
    }
    (0..reps)
        .map(|_| {
            let t = std::time::Instant::now();
            for _ in 0..calls {
                f();
            }
            t.elapsed().as_secs_f64() * 1e9 / calls as f64
        })
        .fold(f64::INFINITY, f64::min)
}

/// doStep (RK4, 1 ms), RHS and state Jacobian (2n dual-number columns, as the implicit
/// methods and fmi2GetDirectionalDerivative evaluate it) of the URDF FMU's model on the
/// interpreted ABA and on its generated code; and the symbolic `aba_derivatives` (one call
/// for ∂q̈/∂(q, q̇)) beside the dual-number columns.
#[test]
#[ignore]
fn speed_of_the_generated_dynamics() {
    use mbfmu::bench::speed::measure;
    use std::hint::black_box;
    let reps = 7;
    println!(
        "| robot | path | doStep ns | RHS ns | Jacobian ns (2n dual columns) | per direction ns |"
    );
    println!("|---|---|---|---|---|---|");
    let rows = [
        (
            "UR5",
            "interpreted",
            measure::<Robot<Ur5Interpreted>>(reps, None),
        ),
        ("UR5", "generated", measure::<Robot<Ur5>>(reps, None)),
        (
            "Panda",
            "interpreted",
            measure::<Robot<PandaInterpreted>>(reps, None),
        ),
        (
            "Panda",
            "generated",
            measure::<Robot<PandaGenerated>>(reps, None),
        ),
    ];
    for (robot, path, r) in &rows {
        println!(
            "| {robot} | {path} | {:.0} | {:.0} | {:.0} | {:.0} |",
            r.dostep_ns,
            r.rhs_ns,
            r.jacobian_ns,
            r.jacobian_ns / r.states as f64
        );
    }
    type Der = fn(&[f64], &[f64], &[f64], &mut [f64], &mut [f64], &mut [f64]);
    let symbolic: [(&str, usize, Der); 2] = [
        (
            "UR5",
            6,
            mbfmu::multibody::generated::ur5::aba_derivatives::<f64>,
        ),
        (
            "Panda",
            9,
            mbfmu::multibody::generated::panda::aba_derivatives::<f64>,
        ),
    ];
    for (robot, n, der) in symbolic {
        let mut rng = Rng(0xbe4c);
        let (q, qd, tau) = (
            rng.vec(n, -1.0, 1.0),
            rng.vec(n, -1.0, 1.0),
            rng.vec(n, -5.0, 5.0),
        );
        let (mut qdd, mut dq, mut dqd) = (vec![0.0; n], vec![0.0; n * n], vec![0.0; n * n]);
        let ns = best_ns(reps, || {
            der(black_box(&q), &qd, &tau, &mut qdd, &mut dq, &mut dqd);
            black_box((&qdd, &dq, &dqd));
        });
        println!("{robot}: symbolic aba_derivatives (q̈, ∂q̈/∂q, ∂q̈/∂q̇ in one call): {ns:.0} ns");
    }
}
