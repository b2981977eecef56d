//! `mbfmu`: build and package the FMUs, list the systems, keep modelDescription/ current.
//!
//! Subcommands are a stable interface (outside tools script them):
//! - `mbfmu list [--json]`: the systems and their scenes (JSON: with start values and stop times).
//! - `mbfmu build --all | MODEL...`: compile each FMU's cdylib in release mode and
//!   write `target/fmu/<Model>.fmu`.
//! - `mbfmu xml [--check]`: write (or check) `modelDescription/<Model>.xml`.
//! - `mbfmu symbolic [--check]`: write (or check) the generated equations of motion of the
//!   symbolic prototype, `src/model/symbolic/generated/`, with their sizes.
//! - `mbfmu linearize MODEL [--scene S] [--set p=v]... [--at x=v]... [--trim|--trim-inputs]
//!   [--independent | --keep NAME,...] [--format json|py|csv] [--out FILE]`: exact A, B, C, D at an
//!   operating point, in all the states or (constrained systems) the independent ones;
//!   `--at time=T` at time T (time-varying systems; default 0, the start time).
//! - `mbfmu bench [--quick] [--out DIR]`: work–precision of every method on every scene
//!   (`results.csv`, default DIR docs/bench); see `benches/` for the peers and the charts.

use mbfmu::catalogue::{self, Entry};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

const USAGE: &str = "usage:
  mbfmu list [--json]
  mbfmu build (--all | MODEL...) [--out DIR]
  mbfmu xml [--check]
  mbfmu symbolic [--check]
  mbfmu linearize MODEL [--scene S] [--set PARAM=VALUE]... [--at STATE_OR_INPUT=VALUE]... [--at time=T]
                  [--trim | --trim-inputs] [--independent | --keep STATE,...]
                  [--format json|py|csv] [--out FILE]
  mbfmu speed [--system MODEL]... [--reps N] [--out DIR] [--chain | --symbolic]
  mbfmu bench [--quick] [--out DIR] [--system MODEL]... [--scene S]... [--reps N] [--no-energy] [--no-springy]";

fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target"))
}

fn select(names: &[String], all: bool) -> Result<Vec<Entry>, String> {
    let entries = catalogue::all();
    if all {
        return Ok(entries);
    }
    if names.is_empty() {
        return Err(format!("name the models to build, or --all\n{USAGE}"));
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

fn build(args: &[String]) -> Result<(), String> {
    let mut all = false;
    let mut out = target_dir().join("fmu");
    let mut names = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--all" => all = true,
            "--out" => out = PathBuf::from(it.next().ok_or("--out needs a folder")?),
            s if s.starts_with('-') => return Err(format!("unknown option {s}\n{USAGE}")),
            s => names.push(s.to_string()),
        }
    }
    let entries = select(&names, all)?;
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.current_dir(workspace_root())
        .args(["build", "--release", "--lib"]);
    for e in &entries {
        cmd.args(["-p", e.crate_name]);
    }
    let status = cmd.status().map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!("cargo build failed ({status})"));
    }
    for e in &entries {
        let library = target_dir()
            .join("release")
            .join(mbfmu::package::library_file(e.crate_name));
        let fmu = out.join(format!("{}.fmu", e.name));
        // The linearisation at the default operating point (the start values).
        let lin = (e.linearize)(&[], None, &Default::default())?;
        let resources = [
            (
                "linearization.json".to_string(),
                mbfmu::linearize::to_json(&lin),
            ),
            (
                "linearized_model.py".to_string(),
                mbfmu::linearize::to_py(&lin),
            ),
        ];
        mbfmu::package::write_fmu(
            &fmu,
            e.name,
            &(e.model_description)(),
            &(e.documentation)(),
            &library,
            &resources,
        )?;
        println!("wrote {}", fmu.display());
    }
    Ok(())
}

fn xml(args: &[String]) -> Result<(), String> {
    let check = match args {
        [] => false,
        [flag] if flag == "--check" => true,
        _ => return Err(USAGE.into()),
    };
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
fn symbolic(args: &[String]) -> Result<(), String> {
    use mbfmu::bench::symbolic;
    let check = match args {
        [] => false,
        [flag] if flag == "--check" => true,
        _ => return Err(USAGE.into()),
    };
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

fn linearize(args: &[String]) -> Result<(), String> {
    use mbfmu::linearize::{to_csv, to_json, to_py, States, Trim};
    let (model, rest) = args.split_first().ok_or(USAGE)?;
    let entry = catalogue::all()
        .into_iter()
        .find(|e| e.name == model)
        .ok_or_else(|| format!("unknown model {model}"))?;
    let mut overrides: Vec<(String, f64)> = Vec::new();
    let mut sets = Vec::new();
    let mut ats = Vec::new();
    let mut trim = None;
    let mut states = States::All;
    let mut format = "json".to_string();
    let mut out = None;
    let mut it = rest.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{a} needs a value"));
        match a.as_str() {
            "--scene" => {
                let name = value()?;
                let scene = (entry.scenes)()
                    .into_iter()
                    .find(|s| s.name == name.as_str())
                    .ok_or_else(|| format!("{model} has no scene {name}"))?;
                overrides.extend(scene.start_values.iter().map(|(n, v)| (n.to_string(), *v)));
            }
            "--set" => sets.push(parse_assignment(value()?)?),
            "--at" => ats.push(parse_assignment(value()?)?),
            "--trim" => trim = Some(Trim::States),
            "--trim-inputs" => trim = Some(Trim::Inputs),
            "--independent" => states = States::Independent,
            "--keep" => {
                let names = value()?.split(',').map(|s| s.trim().to_string()).collect();
                states = States::Only(names);
            }
            "--format" => format = value()?.clone(),
            "--out" => out = Some(PathBuf::from(value()?)),
            other => return Err(format!("unknown option {other}\n{USAGE}")),
        }
    }
    let params: Vec<String> = (entry.linearize)(&[], None, &Default::default())?.parameter_names;
    for (name, _) in &sets {
        if !params.contains(name) {
            return Err(format!(
                "--set {name}: not a parameter of {model} (parameters: {})",
                params.join(", ")
            ));
        }
    }
    for (name, _) in &ats {
        if params.contains(name) {
            return Err(format!("--at {name}: a parameter; use --set"));
        }
    }
    overrides.extend(sets);
    overrides.extend(ats);
    let lin = (entry.linearize)(&overrides, trim, &states)?;
    for line in &lin.warnings {
        eprintln!("warning: {line}");
    }
    let text = match format.as_str() {
        "json" => to_json(&lin),
        "py" => to_py(&lin),
        "csv" => to_csv(&lin),
        other => return Err(format!("unknown format {other} (json, py, csv)")),
    };
    match out {
        Some(path) => write(&path, &text),
        None => {
            print!("{text}");
            Ok(())
        }
    }
}

fn list(args: &[String]) -> Result<(), String> {
    match args {
        [] => {
            for e in catalogue::all() {
                println!("{}: {}", e.name, e.description);
                for s in (e.scenes)() {
                    println!("  {:<18} {}", s.name, s.description);
                }
            }
        }
        [flag] if flag == "--json" => print!("{}", list_json()),
        _ => return Err(USAGE.into()),
    }
    Ok(())
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
/// floors, into `DIR/symbolic.csv`.
fn speed(args: &[String]) -> Result<(), String> {
    use mbfmu::bench::speed;
    let mut only = Vec::new();
    let mut reps = 5;
    let mut out = workspace_root().join("docs/bench");
    let mut chain = false;
    let mut symbolic = false;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{a} needs a value"));
        match a.as_str() {
            "--chain" => chain = true,
            "--symbolic" => symbolic = true,
            "--system" => only.push(value()?.clone()),
            "--reps" => {
                reps = value()?
                    .parse::<usize>()
                    .ok()
                    .filter(|&r| r > 0)
                    .ok_or("--reps needs a positive integer")?
            }
            "--out" => out = PathBuf::from(value()?),
            other => return Err(format!("unknown option {other}\n{USAGE}")),
        }
    }
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
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
    for e in &entries {
        let row = (e.speed)(reps);
        println!("{}", speed::markdown_line(&row));
        csv.push_str(&speed::csv_line(&row));
    }
    std::fs::create_dir_all(&out).map_err(|e| format!("{}: {e}", out.display()))?;
    write(&out.join("speed.csv"), &csv)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("list") => list(&args[1..]),
        Some("build") => build(&args[1..]),
        Some("xml") => xml(&args[1..]),
        Some("symbolic") => symbolic(&args[1..]),
        Some("linearize") => linearize(&args[1..]),
        Some("bench") => {
            let systems: Vec<_> = catalogue::all().iter().map(|e| (e.name, e.bench)).collect();
            mbfmu::bench::cli(&args[1..], &workspace_root().join("docs/bench"), &systems)
        }
        Some("speed") => speed(&args[1..]),
        Some("-h" | "--help" | "help") => {
            println!("{USAGE}");
            Ok(())
        }
        _ => Err(USAGE.to_string()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("mbfmu: {e}");
            ExitCode::FAILURE
        }
    }
}
