//! The platforms an FMU carries a binary for, and how each is built.
//!
//! The host's binary is built by the toolchain running `mbfmu` (it also answers the
//! packager's `mbfmu_describe`). The others are cross-built from an x86_64 Linux host with
//! Debian 12's own packages, nothing from outside its registry (`scripts/install-cross`):
//! Debian's rustc and cargo (`rustc-web`, `cargo-web`, 1.96); for aarch64 Linux its
//! prebuilt standard library (`libstd-rust-web-dev:arm64`) and `aarch64-linux-gnu-gcc`;
//! for x86_64 Windows, which has no prebuilt standard library in Debian, the standard
//! library built from its source (`rust-web-src`, `-Zbuild-std`, `RUSTC_BOOTSTRAP=1`) and
//! linked by `x86_64-w64-mingw32-gcc`. A cross-built binary carries FMI alone (the FMU
//! crates' default features off: no packager, no documentation).

use std::path::{Path, PathBuf};
use std::process::Command;

/// One platform: its folders in an FMU and its Rust target.
#[derive(Debug, PartialEq, Eq)]
pub struct Platform {
    /// FMI 2.0's folder under `binaries/` (`aarch64-linux` has no name in FMI 2.0: the
    /// FMI 3.0 tuple, as FMPy and the Reference FMUs use).
    pub fmi2: &'static str,
    /// FMI 3.0's platform tuple.
    pub fmi3: &'static str,
    /// Rust's target triple.
    pub triple: &'static str,
    windows: bool,
    /// Needs the standard library built from source (no prebuilt one in Debian).
    build_std: bool,
    /// The C compiler that links it, and its Debian packages.
    linker: &'static str,
    packages: &'static str,
}

/// Every platform an FMU carries, in the order the archive lists them.
pub const ALL: [Platform; 3] = [
    Platform {
        fmi2: "linux64",
        fmi3: "x86_64-linux",
        triple: "x86_64-unknown-linux-gnu",
        windows: false,
        build_std: false,
        linker: "gcc",
        packages: "gcc",
    },
    Platform {
        fmi2: "win64",
        fmi3: "x86_64-windows",
        triple: "x86_64-pc-windows-gnu",
        windows: true,
        build_std: true,
        linker: "x86_64-w64-mingw32-gcc",
        packages: "gcc-mingw-w64-x86-64 rust-web-src",
    },
    Platform {
        fmi2: "aarch64-linux",
        fmi3: "aarch64-linux",
        triple: "aarch64-unknown-linux-gnu",
        windows: false,
        build_std: false,
        linker: "aarch64-linux-gnu-gcc",
        packages: "gcc-aarch64-linux-gnu libc6-dev-arm64-cross libstd-rust-web-dev:arm64",
    },
];

/// The packages every cross build needs: Debian's rustc and cargo.
const RUST_PACKAGES: &str = "rustc-web cargo-web";

/// The platform of the machine running this (the one whose binary also describes the
/// model), if an FMU can carry it.
pub fn host() -> Option<&'static Platform> {
    let triple = match (std::env::consts::OS, std::env::consts::ARCH) {
        ("linux", "x86_64") => "x86_64-unknown-linux-gnu",
        ("linux", "aarch64") => "aarch64-unknown-linux-gnu",
        ("windows", "x86_64") => "x86_64-pc-windows-gnu",
        _ => return None,
    };
    ALL.iter().find(|p| p.triple == triple)
}

/// `--platforms`: `all` (the default), `host`, or a comma-separated list of FMI 3.0 tuples
/// or FMI 2.0 folder names (`x86_64-linux,win64`). The host's platform is always first:
/// its binary describes the model.
pub fn parse(spec: &str) -> Result<Vec<&'static Platform>, String> {
    let host = host().ok_or_else(|| {
        format!(
            "this machine ({} {}) is no platform an FMU of mbfmu carries (x86_64 Linux or Windows, aarch64 Linux)",
            std::env::consts::OS,
            std::env::consts::ARCH
        )
    })?;
    let mut chosen = vec![host];
    let names = match spec {
        "host" => Vec::new(),
        "all" => ALL.iter().map(|p| p.fmi3).collect(),
        list => list.split(',').map(str::trim).collect(),
    };
    for name in names {
        let platform = ALL
            .iter()
            .find(|p| p.fmi3 == name || p.fmi2 == name)
            .ok_or_else(|| {
                let known: Vec<&str> = ALL.iter().map(|p| p.fmi3).collect();
                format!(
                    "unknown platform {name:?}: all, host, or some of {}",
                    known.join(", ")
                )
            })?;
        if !chosen.contains(&platform) {
            chosen.push(platform);
        }
    }
    Ok(chosen)
}

impl Platform {
    /// The shared-library file name cargo gives a cdylib crate named `crate_name` here.
    pub fn library_file(&self, crate_name: &str) -> String {
        let stem = crate_name.replace('-', "_");
        if self.windows {
            format!("{stem}.dll")
        } else {
            format!("lib{stem}.so")
        }
    }

    /// The binary's extension in the FMU (`binaries/<folder>/<modelIdentifier>.<ext>`).
    pub fn extension(&self) -> &'static str {
        if self.windows {
            "dll"
        } else {
            "so"
        }
    }

    /// Whether this is the machine's own platform (built by the toolchain running `mbfmu`).
    pub fn is_host(&self) -> bool {
        host() == Some(self)
    }
}

/// Debian's rustc and cargo (`MBFMU_CROSS_RUSTC`, `MBFMU_CROSS_CARGO` to use others).
fn cross_tools() -> (PathBuf, PathBuf) {
    let var = |name: &str, default: &str| {
        std::env::var_os(name)
            .map(PathBuf::from)
            .unwrap_or_else(|| PathBuf::from(default))
    };
    (
        var("MBFMU_CROSS_RUSTC", "/usr/bin/rustc"),
        var("MBFMU_CROSS_CARGO", "/usr/bin/cargo"),
    )
}

fn on_path(program: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|dir| dir.join(program).is_file()))
}

/// The script that installs the cross toolchains (Debian, as root), in the checkout the
/// `mbfmu` binary was built from.
fn install_script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scripts/install-cross")
}

/// What is missing to cross-build for `platform`: `None` when nothing is, else the
/// Debian packages that hold it and one line saying what.
fn missing(platform: &Platform) -> Option<(String, String)> {
    let (rustc, cargo) = cross_tools();
    if !rustc.is_file() || !cargo.is_file() {
        return Some((
            format!("{RUST_PACKAGES} {}", platform.packages),
            format!(
                "Debian's Rust toolchain ({} and {})",
                rustc.display(),
                cargo.display()
            ),
        ));
    }
    let sysroot = Command::new(&rustc)
        .args(["--print", "sysroot"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| PathBuf::from(String::from_utf8_lossy(&o.stdout).trim()))?;
    let rustlib = sysroot.join("lib/rustlib");
    let std_there = if platform.build_std {
        rustlib.join("src/rust/library/std").is_dir()
    } else {
        rustlib.join(platform.triple).join("lib").is_dir()
    };
    if !on_path(platform.linker) || !std_there {
        return Some((
            platform.packages.to_string(),
            format!(
                "the {} linker {} and the Rust standard library {}",
                platform.fmi3,
                platform.linker,
                if platform.build_std {
                    "source"
                } else {
                    "for it"
                }
            ),
        ));
    }
    None
}

/// Checks the toolchain of every platform in `platforms` that is not the host's. What is
/// missing is installed by `scripts/install-cross` when this runs as root on Debian
/// (unless `MBFMU_NO_INSTALL` is set), as `scripts/test-all` installs what the tests need;
/// otherwise it is one line naming the command that installs it, never a thinner FMU.
pub fn ensure_toolchains(platforms: &[&'static Platform]) -> Result<(), String> {
    let lacking: Vec<(String, String, &str)> = platforms
        .iter()
        .filter(|p| !p.is_host())
        .filter_map(|p| missing(p).map(|(packages, what)| (packages, what, p.fmi3)))
        .collect();
    if lacking.is_empty() {
        return Ok(());
    }
    let names: Vec<&str> = lacking.iter().map(|l| l.2).collect();
    let script = install_script();
    // SAFETY: geteuid has no preconditions.
    let root = cfg!(unix) && unsafe { libc_geteuid() } == 0;
    let can_install = root
        && on_path("apt-get")
        && script.is_file()
        && std::env::var_os("MBFMU_NO_INSTALL").is_none();
    if can_install {
        eprintln!(
            "mbfmu: installing the toolchains for {} ({}: Debian's packages, about 400 MB)",
            names.join(", "),
            script.display()
        );
        let status = Command::new("sh")
            .arg(&script)
            .status()
            .map_err(|e| format!("cannot run {}: {e}", script.display()))?;
        if status.success()
            && platforms
                .iter()
                .all(|p| p.is_host() || missing(p).is_none())
        {
            return Ok(());
        }
    }
    let (_, what, name) = &lacking[0];
    Err(format!(
        "building the {} binaries needs {what}, which this machine lacks: install them with `sudo sh {}` (Debian 12), or build for this machine alone with --platforms host",
        if names.len() > 1 { names.join(" and ") } else { name.to_string() },
        script.display()
    ))
}

#[cfg(unix)]
unsafe fn libc_geteuid() -> u32 {
    libc::geteuid()
}

#[cfg(not(unix))]
unsafe fn libc_geteuid() -> u32 {
    1
}

/// `cargo build --release --lib` for `platform` (not the host's) with Debian's toolchain
/// and without the crates' default features (FMI alone), into `target_dir`; the caller
/// adds what to build (`-p …` or `--manifest-path …`). Its binaries land in
/// [`release_dir`].
pub fn cross_cargo(platform: &Platform, target_dir: &Path) -> Command {
    let (rustc, cargo) = cross_tools();
    let mut cmd = Command::new(cargo);
    let linker_var = format!(
        "CARGO_TARGET_{}_LINKER",
        platform.triple.to_uppercase().replace('-', "_")
    );
    cmd.env("RUSTC", rustc)
        .env_remove("RUSTC_WRAPPER")
        .env_remove("RUSTFLAGS")
        .env(linker_var, platform.linker)
        .env("CARGO_TARGET_DIR", target_dir)
        // A cross-built binary keeps no symbol table of its own (its exports stay): the
        // MassSpringDamper.dll from 3.7 to 2.7 MB.
        .env("CARGO_PROFILE_RELEASE_STRIP", "symbols")
        .args(["build", "--release", "--lib", "--no-default-features"])
        .args(["--target", platform.triple]);
    if platform.build_std {
        // No prebuilt standard library for this target in Debian: built from its source
        // (an unstable cargo flag, allowed on this stable compiler by RUSTC_BOOTSTRAP).
        cmd.env("RUSTC_BOOTSTRAP", "1")
            .arg("-Zbuild-std=std,panic_unwind");
    }
    cmd
}

/// Where [`cross_cargo`] puts `platform`'s binaries.
pub fn release_dir(platform: &Platform, target_dir: &Path) -> PathBuf {
    target_dir.join(platform.triple).join("release")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn platforms_parse_with_the_host_first() {
        let host = host().expect("the tests run on a platform an FMU carries");
        assert_eq!(parse("host").unwrap(), vec![host]);
        let all = parse("all").unwrap();
        assert_eq!(all.len(), 3);
        assert_eq!(all[0], host);
        assert_eq!(parse("win64,aarch64-linux").unwrap().len(), 3);
        assert!(parse("win32")
            .unwrap_err()
            .contains("unknown platform \"win32\""));
        assert_eq!(ALL[1].library_file("my-model"), "my_model.dll");
        assert_eq!(ALL[2].library_file("my_model"), "libmy_model.so");
    }
}
