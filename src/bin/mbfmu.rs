//! `mbfmu`: build and package the FMUs, list the systems, keep modelDescription/ current.
//!
//! Subcommands are a stable interface (outside tools script them):
//! - `mbfmu list`: the systems and their scenes.
//! - `mbfmu build --all | MODEL...`: compile each FMU's cdylib in release mode and
//!   write `target/fmu/<Model>.fmu`.
//! - `mbfmu xml [--check]`: write (or check) `modelDescription/<Model>.xml`.

use mbfmu::systems::{self, Entry};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

const USAGE: &str = "usage:
  mbfmu list
  mbfmu build (--all | MODEL...) [--out DIR]
  mbfmu xml [--check]";

fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target"))
}

fn select(names: &[String], all: bool) -> Result<Vec<Entry>, String> {
    let entries = systems::all();
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
        mbfmu::package::write_fmu(
            &fmu,
            e.name,
            &(e.model_description)(),
            &(e.documentation)(),
            &library,
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
    for e in systems::all() {
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

fn write(path: &Path, text: &str) -> Result<(), String> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

fn list() {
    for e in systems::all() {
        println!("{}: {}", e.name, e.description);
        for s in (e.scenes)() {
            println!("  {:<12} {}", s.name, s.description);
        }
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("list") => {
            list();
            Ok(())
        }
        Some("build") => build(&args[1..]),
        Some("xml") => xml(&args[1..]),
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
