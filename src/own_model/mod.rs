//! A user's model in its own crate: the template `mbfmu new` writes, and building such a
//! crate's cdylib with cargo so that `package` can load it.

use crate::package::is_model_identifier;
use std::path::{Path, PathBuf};

const LIB_RS: &str = include_str!("template/lib.rs.template");
const CARGO_TOML: &str = include_str!("template/Cargo.toml.template");
const README: &str = include_str!("template/README.md.template");
const BUILD_RS: &str = include_str!("template/build.rs.template");
const MECHANISM_LIB_RS: &str = include_str!("template/mechanism_lib.rs.template");
const MECHANISM_README: &str = include_str!("template/mechanism_README.md.template");

/// Where a crate of one's own keeps the equations of motion generated from its Lagrangian
/// (written by [`build_generated`]; run by the `generated_eom!` line of its template).
pub const EOM_FILE: &str = "src/eom.rs";

/// FNV-1a (64 bits) over the relative path and the bytes of every file under `src` but
/// `eom.rs`, in path order. The template's build.rs computes the same: the generated
/// equations run only while the model's source is the one they were generated from, so a
/// model edited and rebuilt with plain cargo falls back to automatic differentiation
/// (exact, slower) instead of running stale equations.
pub fn source_hash(src: &Path) -> Result<u64, String> {
    fn files(dir: &Path, rel: &str, out: &mut Vec<(String, PathBuf)>) -> Result<(), String> {
        let entries = std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for entry in entries {
            let entry = entry.map_err(|e| format!("{}: {e}", dir.display()))?;
            let name = entry.file_name().to_string_lossy().into_owned();
            let rel = if rel.is_empty() {
                name
            } else {
                format!("{rel}/{name}")
            };
            let path = entry.path();
            if path.is_dir() {
                files(&path, &rel, out)?;
            } else if rel != "eom.rs" {
                out.push((rel, path));
            }
        }
        Ok(())
    }
    let mut all = Vec::new();
    files(src, "", &mut all)?;
    all.sort();
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes.iter().chain(&[0u8]) {
            hash = (hash ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    };
    for (rel, path) in all {
        eat(rel.as_bytes());
        eat(&std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?);
    }
    Ok(hash)
}

/// The first line of [`EOM_FILE`]: what it was generated from.
pub fn eom_header(hash: u64) -> String {
    format!("// mbfmu: generated from src/ with fnv1a64={hash:016x}; `mbfmu build` rewrites it\n")
}

/// `MyPendulum` → `my_pendulum` (the crate name cargo recommends).
fn snake_case(name: &str) -> String {
    let mut s = String::new();
    let mut prev_lower = false;
    for c in name.chars() {
        if c.is_ascii_uppercase() && prev_lower {
            s.push('_');
        }
        prev_lower = c.is_ascii_lowercase() || c.is_ascii_digit();
        s.push(c.to_ascii_lowercase());
    }
    s
}

/// `my_pendulum` → `MyPendulum` (the Rust type name).
fn camel_case(name: &str) -> String {
    name.split('_')
        .filter(|w| !w.is_empty())
        .map(|w| {
            let mut c = w.chars();
            let first = c.next().expect("non-empty").to_ascii_uppercase();
            std::iter::once(first).chain(c).collect::<String>()
        })
        .collect()
}

/// A TOML basic string's content.
fn toml_escape(s: &str) -> String {
    s.replace('\\', "\\\\").replace('"', "\\\"")
}

/// Writes a new crate for model `name` into `dir` (which must not exist or be empty),
/// depending on the mbfmu library at `mbfmu_source` by path. Its `Cargo.lock` is a copy of
/// mbfmu's, so it builds with the versions mbfmu was tested with, offline when they are
/// in cargo's cache. Returns the files written.
pub fn write_template(name: &str, dir: &Path, mbfmu_source: &Path) -> Result<Vec<PathBuf>, String> {
    if !is_model_identifier(name) {
        return Err(format!(
            "{name:?} cannot name a model: use letters, digits and _, starting with a letter (it becomes the FMU's modelIdentifier)"
        ));
    }
    let crate_name = snake_case(name);
    let type_name = camel_case(name);
    if crate_name == "mbfmu" || type_name.is_empty() {
        return Err(format!("{name:?} cannot name a model: choose another name"));
    }
    if dir.exists()
        && std::fs::read_dir(dir)
            .map_err(|e| format!("{}: {e}", dir.display()))?
            .next()
            .is_some()
    {
        return Err(format!(
            "{} exists and is not empty: choose another --dir",
            dir.display()
        ));
    }
    let fill = |t: &str| {
        t.replace("{{NAME}}", name)
            .replace("{{TYPE}}", &type_name)
            .replace("{{CRATE}}", &crate_name)
            .replace(
                "{{MBFMU_PATH}}",
                &toml_escape(&mbfmu_source.to_string_lossy()),
            )
    };
    let mut files = vec![
        (dir.join("Cargo.toml"), fill(CARGO_TOML)),
        (dir.join("src/lib.rs"), fill(LIB_RS)),
        (dir.join("README.md"), fill(README)),
        (dir.join("build.rs"), BUILD_RS.to_string()),
        (dir.join(".gitignore"), "/target\n".to_string()),
    ];
    if let Ok(lock) = std::fs::read_to_string(mbfmu_source.join("Cargo.lock")) {
        files.push((dir.join("Cargo.lock"), lock));
    }
    write_files(files)
}

/// A modelIdentifier from a robot's name: characters other than letters, digits and `_`
/// become `_`, and a name that does not start with a letter gets `robot_` in front.
pub fn identifier_from(robot: &str) -> String {
    let s: String = robot
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if s.starts_with(|c: char| c.is_ascii_alphabetic()) {
        s
    } else {
        format!("robot_{s}")
    }
}

/// Where a mechanism's crate came from and which command wrote it (its doc comments).
pub struct MechanismSource<'a> {
    /// e.g. the URDF file's path.
    pub source: &'a str,
    /// e.g. `build --urdf ur5.urdf`.
    pub command: &'a str,
}

/// Writes a crate declaring `mechanism` as the model `name` (`mbfmu new NAME --from-urdf`,
/// and the crate `mbfmu build --urdf` compiles) into `dir`, depending on the mbfmu library
/// at `mbfmu_source`. `replace`: `dir` may hold an earlier such crate, whose files are
/// rewritten where they differ (unchanged files keep their time, so cargo does not rebuild
/// them); else `dir` must be empty or absent. Returns the files written.
pub fn write_mechanism_crate(
    name: &str,
    dir: &Path,
    mbfmu_source: &Path,
    mechanism: &crate::multibody::Mechanism,
    from: &MechanismSource,
    replace: bool,
) -> Result<Vec<PathBuf>, String> {
    use crate::multibody::{fmu, source};
    if !is_model_identifier(name) {
        return Err(format!(
            "{name:?} cannot name a model: use letters, digits and _, starting with a letter (it becomes the FMU's modelIdentifier)"
        ));
    }
    // `_fmu`: a library named like a crate of the prelude (`core`, `std`) would not build.
    let crate_name = format!("{}_fmu", snake_case(name));
    let mut type_name = camel_case(name);
    // Not one of the names the template imports or the export macro declares.
    const TAKEN: [&str; 8] = [
        "Body",
        "Joint",
        "JointKind",
        "Limit",
        "Mechanism",
        "Origin",
        "ExportedModel",
        "Robot",
    ];
    if TAKEN.contains(&type_name.as_str()) || type_name.is_empty() {
        type_name.push_str("Robot");
    }
    if !replace
        && dir.exists()
        && std::fs::read_dir(dir)
            .map_err(|e| format!("{}: {e}", dir.display()))?
            .next()
            .is_some()
    {
        return Err(format!(
            "{} exists and is not empty: choose another --dir",
            dir.display()
        ));
    }
    let notes: Vec<String> = fmu::unmodelled_notes(mechanism)
        .iter()
        .map(|line| format!("{line:?}"))
        .collect();
    let dynamics =
        crate::multibody::codegen::robot_dynamics(mechanism, "mbfmu").map_err(|e| e.to_string())?;
    let (dynamics_mod, dynamics_hook) = if dynamics.is_some() {
        (DYNAMICS_MOD, DYNAMICS_HOOK)
    } else {
        ("", "")
    };
    let fill = |t: &str| {
        t.replace("{{DYNAMICS_MOD}}", dynamics_mod)
            .replace("{{DYNAMICS_HOOK}}", dynamics_hook)
            .replace("{{NAME}}", name)
            .replace("{{TYPE}}", &type_name)
            .replace("{{CRATE}}", &crate_name)
            .replace("{{SOURCE}}", from.source)
            .replace("{{COMMAND}}", from.command)
            .replace("{{NOTES}}", &notes.join(", "))
            .replace(
                "{{MBFMU_PATH}}",
                &toml_escape(&mbfmu_source.to_string_lossy()),
            )
            .replace("{{BUILDER}}", &source::builder(mechanism))
    };
    let mut files = vec![
        (dir.join("Cargo.toml"), fill(CARGO_TOML)),
        (dir.join("src/lib.rs"), fill(MECHANISM_LIB_RS)),
        (dir.join("README.md"), fill(MECHANISM_README)),
        (dir.join(".gitignore"), "/target\n".to_string()),
    ];
    if let Some(g) = dynamics {
        files.push((dir.join(DYNAMICS_FILE), g.source));
    }
    if let Ok(lock) = std::fs::read_to_string(mbfmu_source.join("Cargo.lock")) {
        files.push((dir.join("Cargo.lock"), lock));
    }
    write_files(files)
}

/// Where a mechanism's crate keeps its generated forward dynamics
/// ([`codegen::robot_dynamics`](crate::multibody::codegen::robot_dynamics)).
pub const DYNAMICS_FILE: &str = "src/dynamics.rs";

/// The module declaration of [`DYNAMICS_FILE`] in a mechanism crate's lib.rs.
const DYNAMICS_MOD: &str = "
/// q̈ generated for `mechanism()` below (straight-line code; `mbfmu build` rewrites it when
/// the mechanism changes, and until then the articulated-body algorithm runs instead).
#[rustfmt::skip]
#[allow(dead_code, clippy::all, clippy::approx_constant, clippy::excessive_precision, clippy::unreadable_literal)]
mod dynamics;
";

/// The `Declared` items that run [`DYNAMICS_FILE`] (while its fingerprint is the
/// mechanism's).
const DYNAMICS_HOOK: &str = ",
    {
        const GENERATED_FROM: Option<u64> = Some(dynamics::FINGERPRINT);
        fn generated_aba<S: mbfmu::model::Scalar>(q: &[S], qd: &[S], tau: &[S], qdd: &mut [S]) -> bool {
            dynamics::aba(q, qd, tau, qdd);
            true
        }
    }";

/// Writes each file whose content differs, creating folders; returns those written.
fn write_files(files: Vec<(PathBuf, String)>) -> Result<Vec<PathBuf>, String> {
    let mut written = Vec::new();
    for (path, text) in files {
        if std::fs::read_to_string(&path).is_ok_and(|old| old == text) {
            continue;
        }
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(|e| format!("{}: {e}", parent.display()))?;
        }
        std::fs::write(&path, text).map_err(|e| format!("{}: {e}", path.display()))?;
        written.push(path);
    }
    Ok(written)
}

/// The manifest a `--manifest-path` names: the file, or `Cargo.toml` in a folder.
pub fn manifest(path: &Path) -> Result<PathBuf, String> {
    let manifest = if path.is_dir() {
        path.join("Cargo.toml")
    } else {
        path.to_path_buf()
    };
    if !manifest.is_file() {
        return Err(format!(
            "no crate at {}: no such manifest (make one with `mbfmu new NAME`)",
            manifest.display()
        ));
    }
    std::path::absolute(&manifest).map_err(|e| format!("{}: {e}", manifest.display()))
}

#[cfg(feature = "cli")]
/// The shared libraries among the `filenames` of one line of cargo's JSON messages, when
/// it is the artifact of a cdylib of the package at `manifest`.
fn cdylib_of(line: &str, manifest: &Path) -> Vec<PathBuf> {
    let Ok(msg) = serde_json::from_str::<serde_json::Value>(line) else {
        return Vec::new();
    };
    let is_cdylib = msg["target"]["kind"]
        .as_array()
        .is_some_and(|k| k.iter().any(|k| k == "cdylib"));
    if msg["reason"] != "compiler-artifact" || !is_cdylib {
        return Vec::new();
    }
    // Compared as real paths: cargo may print a path through other links than ours.
    let real = |p: &Path| p.canonicalize().unwrap_or_else(|_| p.to_path_buf());
    let same_manifest = msg["manifest_path"]
        .as_str()
        .is_some_and(|m| real(Path::new(m)) == real(manifest));
    if !same_manifest {
        return Vec::new();
    }
    msg["filenames"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|f| f.as_str())
        .map(PathBuf::from)
        .filter(|p| {
            matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("so" | "dylib" | "dll")
            )
        })
        .collect()
}

#[cfg(feature = "cli")]
/// `cargo build --release --lib` of the crate at `manifest` (absolute, from [`manifest`]);
/// returns its cdylib, wherever the crate's target folder is. Cargo's progress and
/// diagnostics go to stderr (`quiet`: only errors).
pub fn build_cdylib(manifest: &Path, quiet: bool) -> Result<PathBuf, String> {
    build_cdylib_in(manifest, quiet, None)
}

#[cfg(feature = "cli")]
/// [`build_cdylib`] into the cargo target folder `target` (`None`: the crate's own, or
/// `CARGO_TARGET_DIR`'s).
pub fn build_cdylib_in(
    manifest: &Path,
    quiet: bool,
    target: Option<&Path>,
) -> Result<PathBuf, String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = std::process::Command::new(&cargo);
    if let Some(target) = target {
        cmd.env("CARGO_TARGET_DIR", target);
    }
    // The packager's questions: on by the template's default features, and asked here
    // for crates made before the feature existed.
    cmd.args([
        "build",
        "--release",
        "--lib",
        "--features",
        "mbfmu/describe",
    ])
    .arg("--manifest-path")
    .arg(manifest);
    run_cargo_for_cdylib(cmd, manifest, quiet)
}

#[cfg(feature = "cli")]
/// Runs the cargo build `cmd` (its output as JSON messages, diagnostics rendered to
/// stderr; `quiet`: only errors) and returns the cdylib of the crate at `manifest`.
fn run_cargo_for_cdylib(
    mut cmd: std::process::Command,
    manifest: &Path,
    quiet: bool,
) -> Result<PathBuf, String> {
    use std::process::Stdio;
    cmd.arg("--message-format=json-render-diagnostics")
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit());
    if quiet {
        cmd.arg("--quiet");
    }
    let program = cmd.get_program().to_string_lossy().into_owned();
    let out = cmd
        .output()
        .map_err(|e| format!("cannot run {program}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "cargo build of {} failed ({})",
            manifest.display(),
            out.status
        ));
    }
    let stdout = String::from_utf8_lossy(&out.stdout);
    stdout
        .lines()
        .flat_map(|l| cdylib_of(l, manifest))
        .last()
        .ok_or_else(|| {
            format!(
                "{} builds no shared library: its [lib] needs crate-type = [\"cdylib\"]",
                manifest.display()
            )
        })
}

#[cfg(feature = "cli")]
/// The host's cdylib `host` (built, and its equations generated, by [`build_generated`] or
/// [`build_cdylib_in`]) and the crate at `manifest` cross-built for every other platform
/// of `platforms` ([`platforms::cross_cargo`](crate::package::platforms::cross_cargo):
/// FMI alone), into the cargo target folder `target` (`None`: the crate's own), the
/// host's first, as [`package_library`](crate::package::package_library) takes them.
pub fn with_cross_builds(
    manifest: &Path,
    host: PathBuf,
    platforms: &[&'static crate::package::Platform],
    target: Option<&Path>,
) -> Result<Vec<(&'static crate::package::Platform, PathBuf)>, String> {
    use crate::package::platforms;
    let mut binaries = Vec::with_capacity(platforms.len());
    for &platform in platforms {
        if platform.is_host() {
            binaries.insert(0, (platform, host.clone()));
            continue;
        }
        let default_target = manifest
            .parent()
            .expect("a manifest has a folder")
            .join("target");
        let target = target.map_or(default_target, Path::to_path_buf);
        let mut cmd = platforms::cross_cargo(platform, &target);
        cmd.arg("--manifest-path").arg(manifest);
        let library = run_cargo_for_cdylib(cmd, manifest, true)
            .map_err(|e| format!("{e} (for {})", platform.fmi3))?;
        binaries.push((platform, library));
    }
    Ok(binaries)
}

#[cfg(feature = "cli")]
/// [`build_cdylib`], then the model's own equations of motion: the cdylib is asked for them
/// (`export_fmu!(lagrangian …)`), [`EOM_FILE`] is written when it does not hold them for
/// this source, and the crate is built again to run them. Returns the cdylib and one line
/// saying what it runs (generated equations, or automatic differentiation and why).
pub fn build_generated(manifest: &Path, quiet: bool) -> Result<(PathBuf, String), String> {
    use crate::package::protocol;
    let dir = manifest.parent().expect("a manifest has a folder");
    let mut library = build_cdylib(manifest, quiet)?;
    let records = match ask_symbolic(&library)? {
        Ok(records) => records,
        Err(why) => return Ok((library, format!("runs on automatic differentiation: {why}"))),
    };
    // A mechanism (`export_fmu!(mechanism …)`) says what it runs; its generated dynamics,
    // when those of its crate are of another mechanism (it was edited), are written and
    // the crate built again.
    if let Some(runs) = protocol::value(&records, "runs") {
        let Some(dynamics) = protocol::value(&records, "dynamics") else {
            return Ok((library, runs.to_string()));
        };
        let path = dir.join(DYNAMICS_FILE);
        std::fs::write(&path, dynamics).map_err(|e| format!("{}: {e}", path.display()))?;
        library = build_cdylib(manifest, quiet)?;
        let records = ask_symbolic(&library)??;
        let runs = protocol::value(&records, "runs").unwrap_or_default();
        return Ok((
            library,
            format!("{runs} ({DYNAMICS_FILE} rewritten for the edited mechanism)"),
        ));
    }
    let get = |key: &str| {
        protocol::value(&records, key)
            .unwrap_or_default()
            .to_string()
    };
    let hash = source_hash(&dir.join("src"))?;
    let text = format!("{}{}", eom_header(hash), get("source"));
    let path = dir.join(EOM_FILE);
    let current = std::fs::read_to_string(&path).is_ok_and(|t| t == text);
    let mut in_use = get("in_use") == "true";
    if !current || !in_use {
        if !current {
            std::fs::write(&path, &text).map_err(|e| format!("{}: {e}", path.display()))?;
        }
        library = build_cdylib(manifest, quiet)?;
        in_use =
            ask_symbolic(&library)?.is_ok_and(|r| protocol::value(&r, "in_use") == Some("true"));
    }
    let nodes = get("nodes");
    let what = if in_use {
        format!("runs the equations generated from its Lagrangian ({EOM_FILE}, {nodes} nodes)")
    } else {
        format!(
            "runs on automatic differentiation: {EOM_FILE} is written ({nodes} nodes), but src/lib.rs does not run it (the template's `generated_eom!` line)"
        )
    };
    Ok((library, what))
}

#[cfg(feature = "cli")]
/// The cdylib's answer to `symbolic`: its records, or why it has none (not a Lagrangian
/// exported with `export_fmu!(lagrangian …)`, or one the tracer cannot take). Asked of a
/// copy: a loaded library is never unloaded ([`ModelLibrary`](crate::package::ModelLibrary)),
/// and the crate is rebuilt and loaded again after this.
fn ask_symbolic(
    library: &Path,
) -> Result<Result<crate::package::protocol::Records, String>, String> {
    use crate::package::{protocol, ModelLibrary};
    use std::sync::atomic::{AtomicUsize, Ordering};
    static PROBES: AtomicUsize = AtomicUsize::new(0);
    let n = PROBES.fetch_add(1, Ordering::Relaxed);
    let name = library
        .file_name()
        .expect("a library file")
        .to_string_lossy();
    let copy = std::env::temp_dir().join(format!("mbfmu-probe-{}-{n}-{name}", std::process::id()));
    std::fs::copy(library, &copy).map_err(|e| format!("{}: {e}", copy.display()))?;
    let answer = ModelLibrary::open(&copy)?.call(&protocol::encode(&[("request", "symbolic")]));
    let _ = std::fs::remove_file(&copy);
    Ok(answer.map_err(|e| {
        if e.contains("unknown describe request") {
            "it is exported with `export_fmu!(T)`; `export_fmu!(lagrangian T)` generates its equations".into()
        } else {
            e
        }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hash the template's build.rs compares: the source files, not eom.rs itself.
    #[test]
    fn source_hash_sees_the_model_not_its_generated_equations() {
        let dir = std::env::temp_dir().join(format!("mbfmu-hash-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let write = |f: &str, t: &str| std::fs::write(dir.join(f), t).unwrap();
        write("lib.rs", "mod sub;");
        write("sub/mod.rs", "// T");
        let h0 = source_hash(&dir).unwrap();
        write("eom.rs", "// generated");
        assert_eq!(source_hash(&dir).unwrap(), h0);
        write("sub/mod.rs", "// T edited");
        assert_ne!(source_hash(&dir).unwrap(), h0);
        std::fs::remove_dir_all(&dir).unwrap();
        assert!(eom_header(h0).contains(&format!("fnv1a64={h0:016x};")));
    }

    #[test]
    fn names() {
        assert_eq!(snake_case("MyPendulum"), "my_pendulum");
        assert_eq!(snake_case("my_pendulum"), "my_pendulum");
        assert_eq!(snake_case("Pendulum2D"), "pendulum2_d");
        assert_eq!(camel_case("my_pendulum"), "MyPendulum");
        assert_eq!(camel_case("MyPendulum"), "MyPendulum");
    }

    #[cfg(feature = "cli")]
    #[test]
    fn a_cdylib_artifact_is_found_only_for_its_manifest() {
        let line = r#"{"reason":"compiler-artifact","manifest_path":"/x/Cargo.toml","target":{"kind":["cdylib"]},"filenames":["/x/target/release/libp.so"]}"#;
        let here = Path::new("/x/Cargo.toml");
        assert_eq!(
            cdylib_of(line, here),
            vec![PathBuf::from("/x/target/release/libp.so")]
        );
        assert!(cdylib_of(line, Path::new("/y/Cargo.toml")).is_empty());
        assert!(cdylib_of("not json", here).is_empty());
    }
}
