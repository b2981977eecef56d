//! A mechanism declared as a user's crate declares it (`mechanism_fmu!`), run through the
//! FMU's own Instance: with `limit_events = 1` (discard) a joint reaching its position limit
//! ends the doStep at that instant with fmi2Discard and a line naming the joint, the limit
//! and the time (`limit_events = 0`: through it; the default, end stops, in
//! tests/end_stops.rs); and `mbfmu build --urdf` refuses every bad URDF with one line and writes
//! no file.

#[path = "common/instance.rs"]
mod instance;

use mbfmu::fmi::{Instance, Logger, ModelInfo, StepOutcome};
use mbfmu::multibody::fmu::Robot;
use mbfmu::multibody::{Body, Joint, JointKind, Limit, Mechanism, Origin};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A 1 kg block on a vertical prismatic joint `lift` limited to (−0.1, 0.2) m, effort 50 N.
fn lift() -> Mechanism {
    Mechanism::new("lift")
        .body(Body::massless("base"))
        .body(Body::new("block", 1.0).inertia_diag([0.01, 0.01, 0.01]))
        .joint(
            Joint::new(
                "lift",
                JointKind::Prismatic,
                "base",
                "block",
                Origin::IDENTITY,
            )
            .axis([0.0, 0.0, 1.0])
            .limit(Limit {
                lower: Some(-0.1),
                upper: Some(0.2),
                effort: Some(50.0),
                velocity: None,
            }),
        )
}

mbfmu::mechanism_fmu!(pub Lift, "Lift", lift);

// The FMU's symbols, as a user's crate exports them (compiled here, not called).
mbfmu::export_fmu!(mechanism Lift);

type R = Robot<Lift>;

/// The describe answer of a mechanism: what it runs, and the mechanism it was built from
/// (which `mbfmu build --urdf` compares with the URDF's).
#[test]
fn a_mechanism_describes_what_it_runs_and_what_it_is() {
    use mbfmu::package::protocol;
    let ask = |what: &str| {
        let answer =
            mbfmu::describe::respond_mechanism::<R>(&protocol::encode(&[("request", what)]));
        protocol::parse_response(&answer).unwrap()
    };
    let runs = ask("symbolic");
    assert_eq!(
        protocol::value(&runs, "runs"),
        Some("runs the articulated-body algorithm (Featherstone) on its model: 1 moving joint, q̈ in O(n)")
    );
    let debug = ask("mechanism");
    assert_eq!(
        protocol::value(&debug, "debug"),
        Some(format!("{:?}", lift()).as_str())
    );
    // Everything else as any model: the package answer names it.
    let package = ask("package");
    assert_eq!(protocol::value(&package, "model_identifier"), Some("Lift"));
    // Its page draws it: the picture in its own section, one view (a lift along z is
    // planar: every point on one line) with a square for the prismatic joint, and a picture
    // of every scene; the plain `respond` (the in-tree
    // systems' answer) draws nothing.
    let page = protocol::value(&package, "documentation").unwrap();
    assert!(page.contains("<h2 id=\"mechanism\">"), "{page}");
    assert!(page.contains("<img src=\"mechanism.svg\""), "{page}");
    let svg = protocol::value(&package, "file:documentation/mechanism.svg").unwrap();
    assert_eq!(svg.matches("<g class=\"view\"").count(), 1, "{svg}");
    assert_eq!(
        svg.matches("<rect class=\"joint prismatic\" data-joint=\"lift\"")
            .count(),
        1,
        "{svg}"
    );
    for scene in ["released", "step"] {
        let file = format!("file:documentation/scene_{scene}_mechanism.svg");
        assert!(protocol::value(&package, &file).is_some(), "{file}");
        assert!(page.contains(&format!("<img src=\"scene_{scene}_mechanism.svg\"")));
    }
    let plain = mbfmu::describe::respond::<R>(&protocol::encode(&[("request", "package")]));
    let plain = protocol::parse_response(&plain).unwrap();
    assert!(protocol::value(&plain, "file:documentation/mechanism.svg").is_none());
}

fn instance(values: &[(&str, f64)]) -> (Instance<R>, &'static ModelInfo) {
    instance::started::<R>("lift", values)
}

/// Pushed up by 20 N against its weight from rest at 0: q = ½ a t², a = 20 − 9.81, so the
/// upper limit 0.2 m is reached at t* = √(0.4 / a) = 0.198127… s, where the doStep of 1 s
/// ends: fmi2Discard, the time and the state there (to the integration's accuracy, and
/// the bisection's resolution of the crossing).
#[test]
fn a_joint_reaching_its_limit_ends_the_do_step_there() {
    let a = 20.0 - 9.81;
    let t_star = (0.4f64 / a).sqrt();
    let (mut inst, info) = instance(&[("tau_lift", 20.0), ("limit_events", 1.0)]);
    let why = match inst.do_step(0.0, 1.0).unwrap() {
        StepOutcome::Discarded(why) => why,
        other => panic!("not stopped at the limit: {other:?}"),
    };
    println!("{why}");
    assert!(
        why.contains("joint lift reached its upper limit 0.2 m at t = 0.1981"),
        "{why}"
    );
    assert!(why.contains("limit_events = 1, discard"), "{why}");
    assert!(
        (inst.time() - t_star).abs() < 1e-9,
        "{} vs {t_star}",
        inst.time()
    );
    let mut q = [0.0];
    inst.get_real(&[info.layout.vr_of("lift").unwrap()], &mut q)
        .unwrap();
    assert!((q[0] - 0.2).abs() < 1e-9, "{}", q[0]);
    assert!((inst.last_successful_time() - t_star).abs() < 1e-9);

    // Off: through the limit, to the end of the step.
    let (mut inst, info) = instance(&[("tau_lift", 20.0), ("limit_events", 0.0)]);
    assert_eq!(inst.do_step(0.0, 1.0).unwrap(), StepOutcome::Completed);
    inst.get_real(&[info.layout.vr_of("lift").unwrap()], &mut q)
        .unwrap();
    assert!((q[0] - 0.5 * a).abs() < 1e-8, "{}", q[0]);
}

/// Effort limits are the inputs' range: 60 N is refused.
#[test]
fn an_input_beyond_the_effort_limit_is_refused() {
    let info: &'static ModelInfo = Box::leak(Box::new(ModelInfo::of::<R>()));
    let mut inst = Instance::<R>::new(info, Logger::silent("lift"));
    let vr = info.layout.vr_of("tau_lift").unwrap();
    let err = inst.set_real(&[vr], &[60.0]).unwrap_err();
    assert!(err.contains("tau_lift") && err.contains("50"), "{err}");
    // Its start value holds the block against gravity: 9.81 N.
    assert_eq!(info.layout.vars[vr as usize].1.start, 9.81);
}

const GOOD: &str = r#"<robot name="two">
  <link name="base"/>
  <link name="a"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <link name="b"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="5" velocity="1"/></joint>
  <joint name="j2" type="continuous"><parent link="a"/><child link="b"/><origin xyz="0 0 -1"/><axis xyz="0 1 0"/></joint>
</robot>"#;

fn cli() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_mbfmu"))
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("mbfmu-urdf-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    if let Ok(entries) = std::fs::read_dir(dir) {
        for e in entries.flatten() {
            out.push(e.path());
        }
    }
    out
}

/// Every bad URDF of issue 25 (and a name clash): `mbfmu build --urdf` exits 1 with one
/// `mbfmu: FILE…` line naming the element and why, and writes nothing (neither an FMU in
/// --out nor a crate under target/urdf); `mbfmu new --from-urdf` writes no crate.
#[test]
fn every_bad_urdf_gives_one_line_and_no_file() {
    let dir = scratch("bad");
    let target = dir.join("target");
    let replace = |from: &str, to: &str| {
        assert!(GOOD.contains(from), "{from}");
        GOOD.replacen(from, to, 1)
    };
    let cases: Vec<(&str, String, &str)> = vec![
        ("malformed", GOOD.replace("</robot>", ""), "malformed XML"),
        (
            "unknown_type",
            replace("type=\"continuous\"", "type=\"ball\""),
            "joint \"j2\": unknown type \"ball\"",
        ),
        (
            "missing_link",
            replace("<child link=\"b\"/>", "<child link=\"c\"/>"),
            "joint \"j2\": child link \"c\" does not exist",
        ),
        (
            "two_parents",
            replace("<parent link=\"a\"/>", "<parent link=\"base\"/><child link=\"a\"/>")
                .replacen("<child link=\"b\"/>", "", 1),
            "link \"a\": has two parents",
        ),
        (
            "cycle",
            replace("<parent link=\"base\"/>", "<parent link=\"b\"/>")
                .replace("<link name=\"base\"/>", ""),
            "cycle",
        ),
        (
            "negative_mass",
            replace("<mass value=\"1\"/>", "<mass value=\"-1\"/>"),
            "link \"a\": mass -1 is not a finite number ≥ 0",
        ),
        (
            "not_positive_definite",
            replace("ixx=\"0.1\"", "ixx=\"-0.1\""),
            "link \"a\": inertia is not positive definite",
        ),
        (
            "massless_end",
            GOOD.replace(
                "<link name=\"b\"><inertial><mass value=\"1\"/><inertia ixx=\"0.1\" ixy=\"0\" ixz=\"0\" iyy=\"0.1\" iyz=\"0\" izz=\"0.1\"/></inertial></link>",
                "<link name=\"b\"/>",
            ),
            "joint \"j2\": moves only massless links (\"b\")",
        ),
        (
            "xacro",
            replace("value=\"1\"", "value=\"${mass}\""),
            "unexpanded xacro",
        ),
        (
            "mimic_of_a_missing_joint",
            replace("<axis xyz=\"0 1 0\"/></joint>\n</robot>", "<axis xyz=\"0 1 0\"/><mimic joint=\"j3\"/></joint>\n</robot>"),
            "joint \"j2\": mimics joint \"j3\", which does not exist",
        ),
        (
            "floating",
            replace("type=\"revolute\"", "type=\"floating\""),
            "joint \"j1\": type \"floating\" is not supported",
        ),
        (
            "name_clash",
            replace("name=\"j2\"", "name=\"j1_dot\""),
            "joint \"j1\": its velocity variable \"j1_dot\" would also be the position of joint \"j1_dot\"",
        ),
    ];
    for (name, text, needle) in &cases {
        let file = dir.join(format!("{name}.urdf"));
        std::fs::write(&file, text).unwrap();
        let out_dir = dir.join(format!("out-{name}"));
        let run = Command::new(cli())
            .args(["build", "--urdf"])
            .arg(&file)
            .arg("--out")
            .arg(&out_dir)
            .env("CARGO_TARGET_DIR", &target)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        println!("{name}: {stderr}");
        assert_eq!(run.status.code(), Some(1), "{name}: {stderr}");
        assert!(run.stdout.is_empty(), "{name}");
        assert_eq!(stderr.lines().count(), 1, "{name}: {stderr}");
        let prefix = format!("mbfmu: {}", file.display());
        assert!(stderr.starts_with(&prefix), "{name}: {stderr}");
        assert!(stderr.contains(needle), "{name}: {stderr} lacks {needle}");
        assert!(files_under(&out_dir).is_empty(), "{name}: wrote into --out");
        assert!(files_under(&target).is_empty(), "{name}: wrote a crate");
        let crate_dir = dir.join(format!("crate-{name}"));
        let new = Command::new(cli())
            .args(["new", "Robot1", "--from-urdf"])
            .arg(&file)
            .arg("--dir")
            .arg(&crate_dir)
            .output()
            .unwrap();
        assert_eq!(new.status.code(), Some(1), "{name}");
        assert_eq!(String::from_utf8_lossy(&new.stderr).lines().count(), 1);
        assert!(!crate_dir.exists(), "{name}: mbfmu new wrote a crate");
    }
    // A bad --name, and a missing file, the same way.
    let good = dir.join("good.urdf");
    std::fs::write(&good, GOOD).unwrap();
    for (args, needle) in [
        (vec!["--name", "1x"], "\"1x\" cannot name the FMU"),
        (vec![], ""),
    ] {
        let file = if args.is_empty() {
            dir.join("nonexistent.urdf")
        } else {
            good.clone()
        };
        let run = Command::new(cli())
            .args(["build", "--urdf"])
            .arg(&file)
            .args(&args)
            .arg("--out")
            .arg(dir.join("out-misc"))
            .env("CARGO_TARGET_DIR", &target)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(1), "{stderr}");
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(
            stderr.starts_with(&format!("mbfmu: {}", file.display())),
            "{stderr}"
        );
        assert!(stderr.contains(needle), "{stderr}");
    }
    assert!(files_under(&dir.join("out-misc")).is_empty());
    // `new --from-urdf` of a good file writes the editable crate, builder calls and all.
    let crate_dir = dir.join("crate-good");
    let new = Command::new(cli())
        .args(["new", "Two", "--from-urdf"])
        .arg(&good)
        .arg("--dir")
        .arg(&crate_dir)
        .output()
        .unwrap();
    assert!(
        new.status.success(),
        "{}",
        String::from_utf8_lossy(&new.stderr)
    );
    let lib = std::fs::read_to_string(crate_dir.join("src/lib.rs")).unwrap();
    assert!(lib.contains("mbfmu::mechanism_fmu!("), "{lib}");
    assert!(lib.contains(".joint(Joint::new(\"j2\", JointKind::Continuous, \"a\", \"b\", Origin::new([0.0, 0.0, -1.0], [0.0, 0.0, 0.0]))"), "{lib}");
    assert!(lib.contains("mbfmu::export_fmu!(mechanism Two);"), "{lib}");
    // and its q̈ generated as straight-line code, run while it is of this mechanism.
    assert!(lib.contains("\nmod dynamics;\n"), "{lib}");
    assert!(
        lib.contains("const GENERATED_FROM: Option<u64> = Some(dynamics::FINGERPRINT);"),
        "{lib}"
    );
    assert!(lib.contains("dynamics::aba(q, qd, tau, qdd);"), "{lib}");
    let dynamics = std::fs::read_to_string(crate_dir.join("src/dynamics.rs")).unwrap();
    let model = mbfmu::multibody::Model::new(&mbfmu::multibody::urdf::parse(GOOD, "good").unwrap())
        .unwrap();
    assert!(dynamics.contains(&format!(
        "pub const FINGERPRINT: u64 = {:#018x};",
        mbfmu::multibody::codegen::fingerprint(&model)
    )));
    assert!(dynamics.contains("pub fn aba<S: Scalar>(q: &[S], qd: &[S], tau: &[S], qdd: &mut [S])"));
    let _ = std::fs::remove_dir_all(&dir);
}
