//! `mbfmu`: build and package the FMUs, list the systems, keep modelDescription/ current,
//! and start and package a model of your own (`mbfmu new`, `build --manifest-path`).
//!
//! Subcommand names and flags are a stable interface (outside tools and tests/ script
//! them); `mbfmu help SUBCOMMAND` or `--help` documents each. Errors go to stderr as one
//! `mbfmu: ...` line with exit status 1 (a bad command line: status 2).

use clap::{Args, Parser, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use mbfmu::catalogue::{self, Entry};
use mbfmu::describe::{LinearizeAnswer, LinearizeRequest};
use mbfmu::linearize::{States, Trim};
use mbfmu::package::{self, platforms, protocol, ModelLibrary, Platform};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::Duration;

#[derive(Parser)]
#[command(
    name = "mbfmu",
    version,
    about = "Multibody mechanics models as FMUs (FMI 2.0 and 3.0, Co-Simulation and Model Exchange)",
    arg_required_else_help = true
)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// The systems and their scenes
    List {
        /// As JSON, with start values and stop times
        #[arg(long)]
        json: bool,
    },
    /// Compile FMUs (release) and package them: in-tree models, a crate of your own, or a URDF
    Build(BuildArgs),
    /// Write modelDescription/<Model>.xml of every in-tree model (committed, reviewed)
    Xml {
        /// Only check that the committed files are current
        #[arg(long)]
        check: bool,
    },
    /// PROTOTYPE: write the equations generated from the Lagrangians (src/model/symbolic/generated/)
    Symbolic {
        /// Only check that the committed files are current
        #[arg(long)]
        check: bool,
    },
    /// Exact A, B, C, D of a model at an operating point
    Linearize(LinearizeArgs),
    /// ns per doStep, RHS and Jacobian of every system beside hand-written floors
    Speed(SpeedArgs),
    /// Work-precision runs of every scene and method into docs/bench/*.csv
    Bench(BenchArgs),
    /// Start a model of your own: a crate with a commented Lagrangian template (a pendulum), or a URDF's bodies and joints (--from-urdf)
    New(NewArgs),
    /// Write the FMI Cross-Check vendor tree (fmus/2.0/cs/<platform>/mbfmu/<version>/) of built FMUs
    Crosscheck(CrosscheckArgs),
}

#[derive(Args)]
struct CrosscheckArgs {
    /// Where to write the tree (its fmus/ folder goes there)
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Where the built .fmu files are [default: target/fmu of this tree]
    #[arg(long, value_name = "DIR")]
    fmus: Option<PathBuf>,
}

/// The cross-check tree from the FMUs as built: their DefaultExperiment and FMI-LS-REF
/// reference result (`package::crosscheck`).
fn crosscheck(args: CrosscheckArgs) -> Result<(), String> {
    let fmus = args.fmus.unwrap_or_else(|| target_dir().join("fmu"));
    let written = package::crosscheck::write_tree(
        &fmus,
        &args.out,
        platforms::host().map_or("linux64", |p| p.fmi2),
        env!("CARGO_PKG_VERSION"),
    )?;
    for w in &written {
        let dropped: Vec<&str> = w.dropped.iter().map(|(n, _)| n.as_str()).collect();
        println!(
            "wrote {} ({} reference columns{})",
            w.dir.display(),
            w.kept.len(),
            if dropped.is_empty() {
                String::new()
            } else {
                format!("; dropped {}", dropped.join(", "))
            }
        );
    }
    Ok(())
}

#[derive(Args)]
struct BuildArgs {
    /// Every in-tree model
    #[arg(long)]
    all: bool,
    /// In-tree models by name (`mbfmu list`)
    #[arg(value_name = "MODEL")]
    models: Vec<String>,
    /// A model crate of your own (`mbfmu new`): its Cargo.toml or its folder
    #[arg(long, value_name = "PATH", conflicts_with_all = ["all", "models"])]
    manifest_path: Option<PathBuf>,
    /// A robot's URDF: its links and joints become an FMU (NAME.fmu). The file is read and
    /// checked first (a bad one: one line, no file written); a crate declaring the same
    /// bodies and joints is written under target/urdf/NAME and compiled (all such crates
    /// share target/urdf-target, so mbfmu compiles once for every robot)
    #[arg(long, value_name = "FILE", conflicts_with_all = ["all", "models", "manifest_path"])]
    urdf: Option<PathBuf>,
    /// With --urdf: the FMU's modelIdentifier [default: the robot's name, other characters
    /// than letters, digits and _ made _]
    #[arg(long, value_name = "NAME", requires = "urdf")]
    name: Option<String>,
    /// With --urdf: write a crate declaring the robot, with its q̈ generated as
    /// straight-line code, and compile it (faster FMUs; needs cargo, 10-90 s a robot). By
    /// default the FMU runs the prebuilt mechanism runtime, which reads the robot from the
    /// FMU's resources: no compiler, about a second
    #[arg(long, requires = "urdf")]
    compile: bool,
    /// With --urdf: the robot's root link floats (legged robots, humanoids, flying arms):
    /// six more degrees of freedom, states base_x base_y base_z, base_q0 … base_q3 (unit
    /// quaternion world ← base), base_vx … base_wz (its velocity in the base frame). No
    /// ground: it falls, flies or floats in space
    #[arg(long, requires = "urdf")]
    floating_base: bool,
    /// Where to write the .fmu files [default: target/fmu, of this tree (in-tree models,
    /// --urdf) or of the crate (--manifest-path)]
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// The platforms the FMUs carry a binary for: all (x86_64-linux, x86_64-windows,
    /// aarch64-linux: the others cross-built with Debian's toolchains, installed when
    /// missing and run as root), host (this machine's alone: the quick edit-build loop), or
    /// a comma-separated list
    #[arg(long, value_name = "LIST", default_value = "all")]
    platforms: String,
}

#[derive(Clone, Copy, ValueEnum)]
enum Format {
    Json,
    Py,
    Csv,
}

#[derive(Args)]
struct LinearizeArgs {
    /// An in-tree model (`mbfmu list`)
    #[arg(
        value_name = "MODEL",
        required_unless_present = "manifest_path",
        conflicts_with = "manifest_path"
    )]
    model: Option<String>,
    /// A model crate of your own (`mbfmu new`): its Cargo.toml or its folder
    #[arg(long, value_name = "PATH")]
    manifest_path: Option<PathBuf>,
    /// Start from a scene's start values
    #[arg(long, value_name = "S")]
    scene: Vec<String>,
    /// A parameter value
    #[arg(long, value_name = "PARAM=VALUE", value_parser = parse_assignment)]
    set: Vec<(String, f64)>,
    /// A state or input value; `time=T` linearises at time T (default 0)
    #[arg(long, value_name = "STATE_OR_INPUT=VALUE", value_parser = parse_assignment)]
    at: Vec<(String, f64)>,
    /// First solve for the states with zero derivatives (Newton)
    #[arg(long, conflicts_with = "trim_inputs")]
    trim: bool,
    /// First solve for the inputs that hold the state (least squares)
    #[arg(long)]
    trim_inputs: bool,
    /// Write the model in the independent states only (dependent ones eliminated through the constraints)
    #[arg(long, conflicts_with = "keep")]
    independent: bool,
    /// Keep only these independent states, in this order (comma-separated); refused if a kept state depends on a dropped one
    #[arg(long, value_name = "STATE,...", value_delimiter = ',')]
    keep: Vec<String>,
    /// json (canonical), py (OpenModelica's linearized_model.py) or csv
    #[arg(long, value_enum, default_value_t = Format::Json)]
    format: Format,
    /// Write to FILE instead of stdout
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
}

#[derive(Args)]
struct SpeedArgs {
    /// Only this system (repeatable)
    #[arg(long, value_name = "MODEL")]
    system: Vec<String>,
    /// Best of N repetitions
    #[arg(long, value_name = "N", default_value_t = 5, value_parser = positive)]
    reps: usize,
    /// Where speed.csv (chain.csv, symbolic.csv) goes [default: docs/bench]
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// The planar chain of N links instead (chain.csv)
    #[arg(long, conflicts_with = "symbolic")]
    chain: bool,
    /// The symbolic prototype's generated equations instead (symbolic.csv)
    #[arg(long)]
    symbolic: bool,
    /// The generated robot dynamics (UR5, Panda, spatial chain N = 1…64) against Pinocchio
    /// in the same run instead (robots.csv, robots.png), then the runtime's interpreted
    /// dynamics on mimic and floating robots (robots_interpreted.csv; Python with `pin` and
    /// example-robot-data: $MBFMU_PYTHON, else .venv/bin/python3, else python3)
    #[arg(long, conflicts_with_all = ["chain", "symbolic"])]
    robots: bool,
    /// The IVP test set's Fortran F for andrews, built as a shared object exporting `f_`
    /// (e.g. gfortran -O2 -fPIC -shared), timed beside AndrewsSqueezer's RHS in the same
    /// run (columns peer_rhs_ns, rhs_over_peer; docs/benchmarks.md)
    #[arg(long, value_name = "PATH.so", conflicts_with_all = ["chain", "symbolic", "robots"])]
    fortran_andrews: Option<PathBuf>,
}

#[derive(Args)]
struct BenchArgs {
    /// Two settings per method, MassSpringDamper and TwoMassChain unless --system
    #[arg(long)]
    quick: bool,
    /// Where the CSVs go [default: docs/bench]
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Only this system (repeatable)
    #[arg(long, value_name = "MODEL")]
    system: Vec<String>,
    /// Only this scene (repeatable)
    #[arg(long, value_name = "S")]
    scene: Vec<String>,
    /// Timing repetitions per run
    #[arg(long, value_name = "N")]
    reps: Option<usize>,
    /// Skip the long runs of the conservative scenes
    #[arg(long)]
    no_energy: bool,
    /// Skip the springy-vs-rigid comparison
    #[arg(long)]
    no_springy: bool,
}

#[derive(Args)]
struct NewArgs {
    /// The model's name: its FMU's modelIdentifier (letters, digits, _), e.g. MyPendulum
    name: String,
    /// The crate's folder [default: ./NAME]
    #[arg(long, value_name = "DIR")]
    dir: Option<PathBuf>,
    /// Instead of the pendulum template: the bodies and joints of this URDF, as Rust
    /// builder calls in src/lib.rs for you to edit
    #[arg(long, value_name = "FILE")]
    from_urdf: Option<PathBuf>,
    /// With --from-urdf: the robot's root link floats (as `build --urdf --floating-base`)
    #[arg(long, requires = "from_urdf")]
    floating_base: bool,
}

fn positive(text: &str) -> Result<usize, String> {
    text.parse::<usize>()
        .ok()
        .filter(|&r| r > 0)
        .ok_or_else(|| "needs a positive integer".into())
}

/// This source tree: the in-tree FMU crates, modelDescription/, docs/bench, and the mbfmu
/// library a new crate depends on (where this binary was built from, also when installed).
fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target"))
}

/// A progress bar on stderr, hidden unless stdout and stderr are both terminals (so logs
/// and pipes stay clean).
fn progress(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    if !(std::io::stdout().is_terminal() && std::io::stderr().is_terminal()) {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{what} {{bar:30}} {{pos}}/{{len}} {{elapsed}} {{msg}}"
        ))
        .expect("a valid template"),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

fn select(names: &[String], all: bool) -> Result<Vec<Entry>, String> {
    let entries = catalogue::all();
    if all {
        return Ok(entries);
    }
    if names.is_empty() {
        return Err("name the models to build, or --all, or --manifest-path".into());
    }
    let known: Vec<&str> = entries.iter().map(|e| e.name).collect();
    for n in names {
        if !known.contains(&n.as_str()) {
            return Err(format!("unknown model {n}; known: {}", known.join(", ")));
        }
    }
    Ok(entries
        .into_iter()
        .filter(|e| names.iter().any(|n| n == e.name))
        .collect())
}

/// Packages from the compiled cdylibs alone (their `mbfmu_describe`): the in-tree models
/// and a user's crate take the same path.
fn build(args: BuildArgs) -> Result<(), String> {
    // Each path checks the toolchains after its own input (a bad file is its own error).
    let chosen = platforms::parse(&args.platforms)?;
    if let Some(urdf) = &args.urdf {
        let robot = (urdf.as_path(), args.name.as_deref(), args.floating_base);
        return if args.compile {
            build_urdf(robot, args.out, &chosen)
        } else {
            build_urdf_runtime(robot, args.out, &chosen)
        };
    }
    if let Some(path) = args.manifest_path {
        let manifest = mbfmu::own_model::manifest(&path)?;
        platforms::ensure_toolchains(&chosen)?;
        let (library, runs) = mbfmu::own_model::build_generated(&manifest, false)?;
        println!("{}", runs);
        let binaries = mbfmu::own_model::with_cross_builds(&manifest, library, &chosen, None)?;
        let out = args.out.unwrap_or_else(|| {
            manifest
                .parent()
                .expect("a manifest has a folder")
                .join("target/fmu")
        });
        let fmu = package::package_library(&binaries, &out)?;
        println!(
            "wrote {} (FMI 3.0: {})",
            fmu.display(),
            fmi3_path(&fmu).display()
        );
        return Ok(());
    }
    let entries = select(&args.models, args.all)?;
    platforms::ensure_toolchains(&chosen)?;
    let out = args.out.unwrap_or_else(|| target_dir().join("fmu"));
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(workspace_root())
        .args(["build", "--release", "--lib"]);
    let mut crates: Vec<&str> = entries.iter().map(|e| e.crate_name).collect();
    if args.all {
        // The mechanism runtime `build --urdf` packages robots with: built, not packaged.
        crates.push(RUNTIME_CRATE);
    }
    for c in &crates {
        cmd.args(["-p", c]);
    }
    let status = cmd.status().map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!("cargo build failed ({status})"));
    }
    // The other platforms: the library once per target, the FMU crates on it.
    for platform in chosen.iter().filter(|p| !p.is_host()) {
        let mut cmd = platforms::cross_cargo(platform, &target_dir());
        cmd.current_dir(workspace_root());
        for c in &crates {
            cmd.args(["-p", c]);
        }
        let status = cmd
            .status()
            .map_err(|e| format!("cannot run {:?}: {e}", cmd.get_program()))?;
        if !status.success() {
            return Err(format!(
                "cargo build for {} failed ({status})",
                platform.fmi3
            ));
        }
    }
    let bar = progress(entries.len() as u64, "packaging");
    for e in &entries {
        bar.set_message(e.name);
        let binaries: Vec<(&'static Platform, PathBuf)> = chosen
            .iter()
            .map(|&p| {
                let dir = if p.is_host() {
                    target_dir().join("release")
                } else {
                    platforms::release_dir(p, &target_dir())
                };
                (p, dir.join(p.library_file(e.crate_name)))
            })
            .collect();
        let fmu = package::package_library(&binaries, &out)?;
        if fmu.file_stem().and_then(|s| s.to_str()) != Some(e.name) {
            return Err(format!(
                "{} describes itself as {}, not {}",
                binaries[0].1.display(),
                fmu.display(),
                e.name
            ));
        }
        bar.suspend(|| {
            println!(
                "wrote {} (FMI 3.0: {})",
                fmu.display(),
                fmi3_path(&fmu).display()
            )
        });
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(())
}

/// A URDF read and checked into a mechanism, and the modelIdentifier it will have; any
/// error is one line naming the file and the element. Once both are good, the build
/// warnings (what the model does not hold, inertias used with a warning) go to stderr.
fn read_urdf(
    urdf: &Path,
    name: Option<&str>,
    floating: bool,
) -> Result<(mbfmu::multibody::Mechanism, String), String> {
    use mbfmu::multibody::{fmu::Built, urdf as reader};
    let file = urdf.display().to_string();
    let mut mechanism = reader::load(urdf).map_err(|e| e.to_string())?;
    mechanism.floating_base = floating;
    // What the FMU needs beyond a valid tree: variable names that do not clash.
    Built::new(mechanism.clone()).map_err(|e| e.in_file(&file).to_string())?;
    let name = match name {
        Some(n) => n.to_string(),
        None => mbfmu::own_model::identifier_from(&mechanism.name),
    };
    if !package::is_model_identifier(&name) {
        return Err(format!(
            "{file}: {name:?} cannot name the FMU: use letters, digits and _, starting with a letter (--name)"
        ));
    }
    // What the model does not hold, and the inertias used with a warning: one line each.
    for line in mbfmu::multibody::fmu::unmodelled(&mechanism) {
        eprintln!("warning: {file}: {line}");
    }
    Ok((mechanism, name))
}

/// The file's absolute path, as the crates written from it name it.
fn absolute(path: &Path) -> String {
    std::path::absolute(path)
        .unwrap_or_else(|_| path.to_path_buf())
        .display()
        .to_string()
}

/// `mbfmu build --urdf FILE [--name NAME] [--out DIR]`: reads and checks the URDF, writes the
/// crate declaring its bodies and joints under target/urdf/NAME, compiles it into the
/// shared target/urdf-target, checks that the compiled mechanism is the URDF's, and
/// packages NAME.fmu (written under a temporary name, then renamed: never a partial file).
/// A URDF to build: its file, the FMU's name if given, whether its root link floats.
type Robot<'a> = (&'a Path, Option<&'a str>, bool);

fn build_urdf(
    (urdf, name, floating): Robot,
    out: Option<PathBuf>,
    chosen: &[&'static Platform],
) -> Result<(), String> {
    use mbfmu::own_model::{self, MechanismSource};
    let started = std::time::Instant::now();
    let file = urdf.display().to_string();
    let (mechanism, name) = read_urdf(urdf, name, floating)?;
    platforms::ensure_toolchains(chosen)?;
    let dir = target_dir().join("urdf").join(&name);
    let absolute = absolute(urdf);
    let command = format!(
        "build --urdf {absolute}{}",
        if floating { " --floating-base" } else { "" }
    );
    let from = MechanismSource {
        source: &absolute,
        command: &command,
    };
    own_model::write_mechanism_crate(&name, &dir, &workspace_root(), &mechanism, &from, true)?;
    let manifest = own_model::manifest(&dir)?;
    let shared = target_dir().join("urdf-target");
    let library = own_model::build_cdylib_in(&manifest, false, Some(&shared))?;
    let opened = ModelLibrary::open(&library)?;
    let compiled = opened.call(&protocol::encode(&[("request", "mechanism")]))?;
    if protocol::value(&compiled, "debug") != Some(format!("{mechanism:?}").as_str()) {
        return Err(format!(
            "{file}: the compiled mechanism ({}) differs from the URDF's: a bug of mbfmu's source printer",
            dir.display()
        ));
    }
    // A tree (with a moving joint) runs the straight-line dynamics generated for it
    // (src/dynamics.rs, whose fingerprint must be the compiled mechanism's: stale or
    // unwired code is caught here).
    let runs = opened.call(&protocol::encode(&[("request", "symbolic")]))?;
    let runs = protocol::value(&runs, "runs")
        .unwrap_or_default()
        .to_string();
    let generated = runs.starts_with("runs straight-line code generated");
    let planned = mbfmu::multibody::codegen::robot_dynamics(&mechanism, "mbfmu")
        .map_err(|e| format!("{file}: {e}"))?
        .is_some();
    if planned && !generated {
        return Err(format!(
            "{file}: the compiled crate ({}) does not run its generated dynamics ({runs}): a bug of mbfmu's code generator",
            dir.display()
        ));
    }
    let binaries = own_model::with_cross_builds(&manifest, library, chosen, Some(&shared))?;
    let fmu = package_robot(&binaries, &[], out, &name)?;
    let tree = mechanism.closures.is_empty()
        && mbfmu::multibody::Model::new(&mechanism).is_ok_and(|m| m.nq() > 0);
    let runs = if tree && !planned {
        format!(
            "{runs} (no straight-line code: its q̈ would take more than {} operations, which rustc compiles in minutes)",
            mbfmu::multibody::codegen::MAX_OPERATIONS
        )
    } else {
        runs
    };
    report_robot(&fmu, &mechanism, started, &runs);
    Ok(())
}

/// The mechanism runtime's crate (fmu/mechanism_runtime), built by `build --all`.
const RUNTIME_CRATE: &str = "mechanism_runtime";

/// `mbfmu build --urdf FILE [--name NAME] [--out DIR]` (without --compile): reads and checks
/// the URDF and packages NAME.fmu from the prebuilt mechanism runtime (a binary per
/// platform, built by `build --all`), the URDF and NAME as its resources: no compiler.
fn build_urdf_runtime(
    (urdf, name, floating): Robot,
    out: Option<PathBuf>,
    chosen: &[&'static Platform],
) -> Result<(), String> {
    let started = std::time::Instant::now();
    let file = urdf.display().to_string();
    let (mechanism, name) = read_urdf(urdf, name, floating)?;
    if !mechanism.closures.is_empty() {
        return Err(format!("{file}: loop closures need --compile"));
    }
    let text = std::fs::read_to_string(urdf).map_err(|e| format!("{file}: {e}"))?;
    let mut binaries = Vec::with_capacity(chosen.len());
    for &p in chosen {
        let dir = if p.is_host() {
            target_dir().join("release")
        } else {
            platforms::release_dir(p, &target_dir())
        };
        let binary = dir.join(p.library_file(RUNTIME_CRATE));
        if !binary.is_file() {
            return Err(format!(
                "the mechanism runtime for {} is not built ({}): run `cargo run --release --bin mbfmu -- build --all` once in {}, or build with --compile (needs cargo)",
                p.fmi3,
                binary.display(),
                workspace_root().display()
            ));
        }
        binaries.push((p, binary));
    }
    // The host's runtime answers for one robot per process: a fresh copy of it is loaded.
    let copy = std::env::temp_dir().join(format!(
        "mbfmu-runtime-{}-{}",
        std::process::id(),
        binaries[0].1.file_name().expect("a file").to_string_lossy()
    ));
    std::fs::copy(&binaries[0].1, &copy).map_err(|e| format!("{}: {e}", copy.display()))?;
    binaries[0].1 = copy.clone();
    let base = mbfmu::multibody::runtime::base_text(floating);
    let request = [
        ("model_identifier", name.as_str()),
        ("urdf", text.as_str()),
        ("base", base),
    ];
    let packaged = package_robot(&binaries, &request, out, &name);
    let _ = std::fs::remove_file(&copy);
    let fmu = packaged?;
    report_robot(
        &fmu,
        &mechanism,
        started,
        if floating {
            "runs the articulated-body algorithm with a floating base (the base solved from its articulated inertia), interpreted by the prebuilt mechanism runtime, which reads the robot from the FMU's resources (no compiler; --compile generates straight-line code for this robot: faster, needs cargo)"
        } else if mbfmu::multibody::Model::new(&mechanism).is_ok_and(|m| m.has_mimics()) {
            "runs the mass matrix reduced to the independent joints (mimic joints follow them), interpreted by the prebuilt mechanism runtime, which reads the robot from the FMU's resources (no compiler; --compile generates straight-line code for this robot: faster, needs cargo)"
        } else {
            "runs the articulated-body algorithm interpreted by the prebuilt mechanism runtime, which reads the robot from the FMU's resources (no compiler; --compile generates straight-line code for this robot: faster, needs cargo)"
        },
    );
    Ok(())
}

/// Packages a robot's NAME.fmu into `out` (default target/fmu), its FMI 3.0 twin into
/// `out`3: written under a temporary name, then renamed (never a partial file).
fn package_robot(
    binaries: &[(&'static Platform, PathBuf)],
    request: &[(&str, &str)],
    out: Option<PathBuf>,
    name: &str,
) -> Result<PathBuf, String> {
    let out = out.unwrap_or_else(|| target_dir().join("fmu"));
    let partial = out.join(format!(".{name}.fmu.partial-{}", std::process::id()));
    let packaged = package::package_library_with(binaries, &partial, request).and_then(|fmu| {
        let fmu_path = out.join(format!("{name}.fmu"));
        std::fs::rename(&fmu, &fmu_path).map_err(|e| format!("{}: {e}", fmu_path.display()))?;
        // The FMI 3.0 FMU, beside in <out>3.
        let fmu3 = package::fmi3_dir(&partial).join(format!("{name}.fmu"));
        if fmu3.exists() {
            let dir3 = package::fmi3_dir(&out);
            std::fs::create_dir_all(&dir3).map_err(|e| format!("{}: {e}", dir3.display()))?;
            let fmu3_path = dir3.join(format!("{name}.fmu"));
            std::fs::rename(&fmu3, &fmu3_path)
                .map_err(|e| format!("{}: {e}", fmu3_path.display()))?;
        }
        Ok(fmu_path)
    });
    let _ = std::fs::remove_dir_all(&partial);
    let _ = std::fs::remove_dir_all(package::fmi3_dir(&partial));
    packaged
}

/// The line a robot's build ends with.
fn report_robot(
    fmu: &Path,
    mechanism: &mbfmu::multibody::Mechanism,
    started: std::time::Instant,
    runs: &str,
) {
    let size = std::fs::metadata(fmu).map(|m| m.len()).unwrap_or(0);
    println!(
        "wrote {} ({} joints, {:.1} MB, {:.1} s; FMI 3.0: {}): {runs}",
        fmu.display(),
        mbfmu::multibody::Model::new(mechanism)
            .map(|m| match m.nq() - m.ndof() {
                0 => m.nq().to_string(),
                mimics => format!("{} + {mimics} mimic", m.ndof()),
            })
            .unwrap_or_default(),
        size as f64 / 1e6,
        started.elapsed().as_secs_f64(),
        fmi3_path(fmu).display()
    );
}

/// The FMI 3.0 FMU written beside the FMI 2.0 one at `fmu` ([`package::fmi3_dir`]).
fn fmi3_path(fmu: &Path) -> PathBuf {
    let dir = fmu.parent().unwrap_or(Path::new("."));
    package::fmi3_dir(dir).join(fmu.file_name().unwrap_or_default())
}

fn xml(check: bool) -> Result<(), String> {
    let dir = workspace_root().join("modelDescription");
    let mut stale = Vec::new();
    for e in catalogue::all() {
        let path = dir.join(format!("{}.xml", e.name));
        let text = (e.model_description)();
        if check {
            if std::fs::read_to_string(&path).ok().as_deref() != Some(text.as_str()) {
                stale.push(path.display().to_string());
            }
        } else {
            write(&path, &text)?;
            println!("wrote {}", path.display());
        }
    }
    if stale.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "out of date (run `cargo run --bin mbfmu -- xml`): {}",
            stale.join(", ")
        ))
    }
}

/// `mbfmu symbolic [--check]`: trace, differentiate and emit the equations of motion of the
/// symbolic prototype into `src/model/symbolic/generated/` (or check they are current), and
/// print each module's size and generation time.
fn symbolic(check: bool) -> Result<(), String> {
    use mbfmu::bench::symbolic;
    let (generated, files) = symbolic::generate_all().map_err(|e| e.to_string())?;
    println!("| module | n | nodes | operations | lets | lines | generation ms |");
    println!("|---|---|---|---|---|---|---|");
    for g in &generated {
        let e = &g.emitted;
        println!(
            "| {} | {} | {} | {} | {} | {} | {:.1} |",
            g.module,
            g.coordinates,
            e.nodes,
            e.operations,
            e.lets,
            e.lines,
            g.seconds * 1e3
        );
    }
    if !check {
        println!("\n| chain N | nodes | operations | lets | lines | generation ms |");
        println!("|---|---|---|---|---|---|");
        for g in symbolic::chain_sizes() {
            let e = &g.emitted;
            println!(
                "| {} | {} | {} | {} | {} | {:.1} |",
                g.coordinates,
                e.nodes,
                e.operations,
                e.lets,
                e.lines,
                g.seconds * 1e3
            );
        }
    }
    let dir = symbolic::generated_dir();
    let mut stale = Vec::new();
    for (name, text) in files {
        let path = dir.join(name);
        if check {
            if std::fs::read_to_string(&path).ok().as_deref() != Some(text.as_str()) {
                stale.push(path.display().to_string());
            }
        } else {
            write(&path, &text)?;
        }
    }
    if stale.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "out of date (run `cargo run --bin mbfmu -- symbolic`): {}",
            stale.join(", ")
        ))
    }
}

fn write(path: &Path, text: &str) -> Result<(), String> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

fn parse_assignment(text: &str) -> Result<(String, f64), String> {
    let (name, value) = text
        .split_once('=')
        .ok_or_else(|| format!("expected NAME=VALUE, got {text}"))?;
    let value: f64 = value
        .trim()
        .parse()
        .map_err(|_| format!("{name}: {value} is not a number"))?;
    Ok((name.trim().to_string(), value))
}

/// Asks the model, in-tree (in process) or a user's crate (its compiled cdylib), the same
/// linearize request.
fn linearize(args: LinearizeArgs) -> Result<(), String> {
    let request = LinearizeRequest {
        scenes: args.scene,
        sets: args.set,
        ats: args.at,
        trim: if args.trim {
            Some(Trim::States)
        } else if args.trim_inputs {
            Some(Trim::Inputs)
        } else {
            None
        },
        states: if !args.keep.is_empty() {
            States::Only(args.keep)
        } else if args.independent {
            States::Independent
        } else {
            States::All
        },
        format: match args.format {
            Format::Json => "json",
            Format::Py => "py",
            Format::Csv => "csv",
        }
        .into(),
    };
    let records = match (&args.model, &args.manifest_path) {
        (_, Some(path)) => {
            let manifest = mbfmu::own_model::manifest(path)?;
            let library = mbfmu::own_model::build_cdylib(&manifest, true)?;
            ModelLibrary::open(&library)?.call(&request.encode())?
        }
        (Some(model), None) => {
            let entry = catalogue::all()
                .into_iter()
                .find(|e| e.name == model)
                .ok_or_else(|| format!("unknown model {model}"))?;
            protocol::parse_response(&(entry.describe)(&request.encode()))?
        }
        (None, None) => return Err("name a model, or --manifest-path".into()),
    };
    let LinearizeAnswer { text, warnings } = LinearizeRequest::parse_answer(&records)?;
    for line in &warnings {
        eprintln!("warning: {line}");
    }
    match args.out {
        Some(path) => write(&path, &text),
        None => {
            print!("{text}");
            Ok(())
        }
    }
}

fn list(json: bool) {
    if json {
        print!("{}", list_json());
        return;
    }
    for e in catalogue::all() {
        println!("{}: {}", e.name, e.description);
        for s in (e.scenes)() {
            println!("  {:<18} {}", s.name, s.description);
        }
    }
}

/// `mbfmu list --json`: every system and its scenes (start values, stop time), for scripts.
fn list_json() -> String {
    let q = |s: &str| format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""));
    let models: Vec<String> = catalogue::all()
        .iter()
        .map(|e| {
            let scenes: Vec<String> = (e.scenes)()
                .iter()
                .map(|s| {
                    let values: Vec<String> = s
                        .start_values
                        .iter()
                        .map(|(n, v)| format!("{}: {v:?}", q(n)))
                        .collect();
                    format!(
                        "{{\"name\": {}, \"description\": {}, \"stop_time\": {:?}, \"start_values\": {{{}}}}}",
                        q(s.name),
                        q(s.description),
                        s.stop_time,
                        values.join(", ")
                    )
                })
                .collect();
            format!(
                "  {{\"name\": {}, \"description\": {}, \"scenes\": [{}]}}",
                q(e.name),
                q(e.description),
                scenes.join(", ")
            )
        })
        .collect();
    format!("[\n{}\n]\n", models.join(",\n"))
}

/// `mbfmu speed [--system MODEL]... [--reps N] [--out DIR] [--chain | --symbolic]`: ns per
/// doStep (RK4, 1 ms), per RHS and per Jacobian of every system beside the hand-written
/// floors, into `DIR/speed.csv` (default docs/bench) and as a markdown table on stdout;
/// `--chain`: the planar chain of N = 1 … 16 links instead, into `DIR/chain.csv`;
/// `--symbolic`: the symbolic prototype's generated equations against today's path and the
/// floors, into `DIR/symbolic.csv`; `--robots`: the generated robot dynamics against
/// Pinocchio, into `DIR/robots.csv` and `DIR/robots.png`.
fn speed(args: SpeedArgs) -> Result<(), String> {
    use mbfmu::bench::speed;
    let SpeedArgs {
        system: only,
        reps,
        out,
        chain,
        symbolic,
        robots,
        fortran_andrews,
    } = args;
    let out = out.unwrap_or_else(|| workspace_root().join("docs/bench"));
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    if robots {
        return speed_robots(reps, &out);
    }
    if symbolic {
        use mbfmu::bench::{chain::growth_exponent, symbolic};
        let rows = symbolic::sweep(reps);
        println!("| system | n | nodes | generated RHS ns (of which eom) | AD RHS ns (ratio) | floor RHS ns (generated / floor) | generated Jacobian ns | AD Jacobian ns (ratio) |");
        println!("|---|---|---|---|---|---|---|---|");
        let mut csv = String::from(symbolic::CSV_HEADER);
        for r in &rows {
            println!("{}", symbolic::markdown_line(r));
            csv.push_str(&symbolic::csv_line(r));
        }
        let fit = |pick: fn(&symbolic::SymbolicRow) -> f64| {
            let pts: Vec<(usize, f64)> = rows
                .iter()
                .filter(|r| r.system == "Chain" && (2..=16).contains(&r.coordinates))
                .map(|r| (r.coordinates, pick(r)))
                .collect();
            growth_exponent(&pts)
        };
        println!(
            "chain growth exponent (N = 2 … 16): generated RHS {:.2}, Jacobian {:.2}, nodes {:.2}; AD RHS {:.2}",
            fit(|r| r.generated_rhs_ns),
            fit(|r| r.generated_jacobian_ns),
            fit(|r| r.nodes as f64),
            fit(|r| r.ad_rhs_ns),
        );
        return write(&out.join("symbolic.csv"), &csv);
    }
    if chain {
        use mbfmu::bench::chain;
        let rows = chain::sweep(reps);
        let mut csv = String::from("links,states,rhs_ns,jacobian_ns\n");
        println!("| links N | RHS ns | Jacobian ns |");
        println!("|---|---|---|");
        for (n, rhs, jac) in &rows {
            println!("| {n} | {rhs:.0} | {jac:.0} |");
            csv.push_str(&format!("{n},{},{rhs:.1},{jac:.1}\n", 2 * n));
        }
        let fit = |pick: fn(&(usize, f64, f64)) -> f64| {
            let pts: Vec<(usize, f64)> = rows
                .iter()
                .filter(|r| r.0 >= 2)
                .map(|r| (r.0, pick(r)))
                .collect();
            chain::growth_exponent(&pts)
        };
        println!(
            "growth exponent (N = 2 … 16): RHS {:.2}, Jacobian {:.2}",
            fit(|r| r.1),
            fit(|r| r.2)
        );
        return write(&out.join("chain.csv"), &csv);
    }
    let entries = select(&only, only.is_empty())?;
    println!("| system | states | doStep ns | floor doStep ns (ratio) | RHS ns | floor RHS ns (ratio) | Jacobian ns | Jacobian / (n RHS) |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut csv = String::from(speed::CSV_HEADER);
    let mut peer_lines = Vec::new();
    for e in &entries {
        let mut row = (e.speed)(reps);
        if let (Some(path), "AndrewsSqueezer") = (&fortran_andrews, row.system) {
            let (ns, residual) = speed::fortran_andrews(path, reps)?;
            row.peer_rhs_ns = Some(ns);
            peer_lines.push(format!(
                "AndrewsSqueezer: RHS {:.0} ns, the test set's Fortran F {ns:.0} ns at the same state ({:.2}×); its residual M w − f + Gᵀλ at our q̈ and λ: {residual:.1e} of the forces' scale",
                row.rhs_ns,
                row.rhs_ns / ns
            ));
        }
        println!("{}", speed::markdown_line(&row));
        csv.push_str(&speed::csv_line(&row));
    }
    for line in &peer_lines {
        println!("{line}");
    }
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    write(&out.join("speed.csv"), &csv)
}

/// `mbfmu speed --robots`: see `mbfmu::bench::robots`.
fn speed_robots(reps: usize, out: &Path) -> Result<(), String> {
    use mbfmu::bench::{chain::growth_exponent, robots};
    let scratch = std::env::temp_dir().join(format!("mbfmu-robots-{}", std::process::id()));
    let rows = robots::sweep(reps, &scratch);
    let _ = std::fs::remove_dir_all(&scratch);
    let rows = rows?;
    println!("{}", robots::MARKDOWN_HEADER);
    let mut csv = String::from(robots::CSV_HEADER);
    for r in &rows {
        println!("{}", robots::markdown_line(r));
        csv.push_str(&robots::csv_line(r));
    }
    let chain: Vec<&robots::RobotRow> = rows
        .iter()
        .filter(|r| r.model.starts_with("chain_"))
        .collect();
    let fit = |pick: fn(&robots::RobotRow) -> f64| {
        let pts: Vec<(usize, f64)> = chain
            .iter()
            .filter(|r| r.nq >= 8)
            .map(|r| (r.nq, pick(r)))
            .collect();
        growth_exponent(&pts)
    };
    println!(
        "chain growth exponent (N = 8 … 64): generated RHS {:.2}, Pinocchio aba {:.2}; Jacobian {:.2}, Pinocchio derivatives {:.2}",
        fit(|r| r.generated_rhs_ns),
        fit(|r| r.pinocchio_aba_ns),
        fit(|r| r.jacobian_ns),
        fit(|r| r.pinocchio_derivatives_ns),
    );
    let slower: Vec<usize> = chain
        .iter()
        .filter(|r| r.generated_rhs_ns >= r.pinocchio_aba_ns)
        .map(|r| r.nq)
        .collect();
    println!("chain sizes where Pinocchio's aba is as fast or faster: {slower:?}");
    let slower: Vec<&str> = rows
        .iter()
        .filter(|r| r.jacobian_ns >= r.pinocchio_derivatives_ns)
        .map(|r| r.model.as_str())
        .collect();
    println!("models where Pinocchio's computeABADerivatives is as fast or faster: {slower:?}");
    let worst = rows.iter().map(|r| r.max_difference).fold(0.0, f64::max);
    println!("largest relative q̈ difference from pin.aba at the timed states: {worst:.1e}");
    let csv_path = out.join("robots.csv");
    write(&csv_path, &csv)?;
    robots::plot(&csv_path, &out.join("robots.png"))?;
    speed_interpreted(reps, out)
}

/// The second table of `mbfmu speed --robots`: the runtime's interpreted dynamics on mimic
/// and floating robots against Pinocchio (`mbfmu::bench::interpreted`), into
/// `DIR/robots_interpreted.csv`.
fn speed_interpreted(reps: usize, out: &Path) -> Result<(), String> {
    use mbfmu::bench::interpreted;
    let rows = interpreted::sweep(reps)?;
    println!("{}", interpreted::MARKDOWN_HEADER);
    let mut csv = String::from(interpreted::CSV_HEADER);
    for r in &rows {
        println!("{}", interpreted::markdown_line(r));
        csv.push_str(&interpreted::csv_line(r));
    }
    write(&out.join("robots_interpreted.csv"), &csv)
}

fn bench(args: BenchArgs) -> Result<(), String> {
    use mbfmu::bench::{BenchEvent, BenchOptions};
    let options = BenchOptions {
        quick: args.quick,
        out: args
            .out
            .unwrap_or_else(|| workspace_root().join("docs/bench")),
        systems: args.system,
        scenes: args.scene,
        reps: args.reps,
        energy: !args.no_energy,
        springy: !args.no_springy,
    };
    let systems: Vec<_> = catalogue::all().iter().map(|e| (e.name, e.bench)).collect();
    let bar = progress(0, "bench");
    let report = |event: BenchEvent| match event {
        BenchEvent::Start(n) => bar.set_length(n as u64),
        BenchEvent::System(name) => bar.set_message(name.to_string()),
        BenchEvent::Done(line) => {
            bar.suspend(|| eprintln!("{line}"));
            bar.inc(1);
        }
        BenchEvent::Note(line) => bar.suspend(|| eprintln!("{line}")),
    };
    let result = mbfmu::bench::cli(&options, &systems, &report);
    bar.finish_and_clear();
    result
}

fn new(args: NewArgs) -> Result<(), String> {
    let dir = args.dir.unwrap_or_else(|| PathBuf::from(&args.name));
    match &args.from_urdf {
        Some(urdf) => {
            let (mechanism, name) = read_urdf(urdf, Some(&args.name), args.floating_base)?;
            let source = absolute(urdf);
            let command = format!(
                "new {name} --from-urdf {source}{}",
                if args.floating_base {
                    " --floating-base"
                } else {
                    ""
                }
            );
            let from = mbfmu::own_model::MechanismSource {
                source: &source,
                command: &command,
            };
            mbfmu::own_model::write_mechanism_crate(
                &name,
                &dir,
                &workspace_root(),
                &mechanism,
                &from,
                false,
            )?;
        }
        None => {
            mbfmu::own_model::write_template(&args.name, &dir, &workspace_root())?;
        }
    }
    let manifest = dir.join("Cargo.toml");
    println!(
        "created {}: edit {}, then\n  mbfmu build --manifest-path {}",
        dir.display(),
        dir.join("src/lib.rs").display(),
        manifest.display()
    );
    Ok(())
}

/// Parses the command line; a usage error is one `mbfmu: ...` line with the usage and
/// status 2 (help and version print as clap prints them).
fn parse() -> Result<Cli, ExitCode> {
    use clap::error::ErrorKind;
    match Cli::try_parse() {
        Ok(cli) => Ok(cli),
        Err(e)
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) =>
        {
            e.exit()
        }
        Err(e) => {
            let text = e.to_string();
            let lines: Vec<&str> = text.lines().map(str::trim).collect();
            let what: Vec<&str> = lines
                .iter()
                .copied()
                .filter(|l| {
                    !l.is_empty()
                        && !l.starts_with("Usage: ")
                        && !l.starts_with("tip: ")
                        && !l.starts_with("For more information")
                })
                .collect();
            let what = what.join(" ");
            let what = what.strip_prefix("error: ").unwrap_or(&what);
            match lines.iter().find(|l| l.starts_with("Usage: ")) {
                Some(usage) => eprintln!("mbfmu: {what}; {usage} (see --help)"),
                None => eprintln!("mbfmu: {what} (see --help)"),
            }
            Err(ExitCode::from(2))
        }
    }
}

fn main() -> ExitCode {
    let cli = match parse() {
        Ok(cli) => cli,
        Err(code) => return code,
    };
    let result = match cli.command {
        Cmd::List { json } => {
            list(json);
            Ok(())
        }
        Cmd::Build(args) => build(args),
        Cmd::Xml { check } => xml(check),
        Cmd::Symbolic { check } => symbolic(check),
        Cmd::Linearize(args) => linearize(args),
        Cmd::Speed(args) => speed(args),
        Cmd::Bench(args) => bench(args),
        Cmd::New(args) => new(args),
        Cmd::Crosscheck(args) => crosscheck(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("mbfmu: {e}");
            ExitCode::FAILURE
        }
    }
}
