//! The mechanism runtime: one prebuilt binary per platform that runs any robot, read from
//! its FMU's resources at instantiation, so that a URDF becomes an FMU without a compiler
//! (`mbfmu build --urdf`).
//!
//! An FMU made this way carries the runtime's binaries (renamed to its modelIdentifier)
//! and, under `resources/`, the URDF as given ([`URDF_RESOURCE`]) and its modelIdentifier
//! ([`NAME_RESOURCE`]). Instantiation reads and checks them ([`load_from`]): a file that
//! does not parse, or a mechanism other than the one the modelDescription was made from,
//! is refused with one line: the instantiation token is a hash of the URDF text, the
//! name and the variables ([`Declared::token_text`]), so a changed mass, a removed joint
//! or a truncated file cannot run. (Not of the rendered modelDescription, as other
//! models' tokens are: its start torques come from the platform's sin and cos, whose last
//! bits differ between libms, and every platform must compute the same token.) The packager hands the
//! same two texts to the host's runtime through its describe request ([`load`]).
//!
//! The robot is loaded once per process (a binary file is loaded once per process, and an
//! FMU's binary is its own copy); loading it again is allowed only with the same texts.
//! q̈ by the interpreted articulated-body algorithm ([`Model::aba`](super::Model::aba)),
//! exact Jacobians by dual numbers through it. A model layer: nothing here knows FMI.

use super::fmu::Declared;
use super::mechanism::Mechanism;
use std::path::Path;
use std::sync::OnceLock;

/// The URDF as given to `mbfmu build --urdf`, in the FMU's `resources/`.
pub const URDF_RESOURCE: &str = "mechanism.urdf";
/// The FMU's modelIdentifier, in the FMU's `resources/`.
pub const NAME_RESOURCE: &str = "model_identifier.txt";
/// How the robot's root link is held, in the FMU's `resources/`: `fixed` (bolted to the
/// world) or `floating` (`mbfmu build --urdf FILE --floating-base`). An FMU written before
/// it existed has none: fixed.
pub const BASE_RESOURCE: &str = "base.txt";

/// The [`BASE_RESOURCE`] text of a floating or a fixed base.
pub fn base_text(floating: bool) -> &'static str {
    if floating {
        "floating"
    } else {
        "fixed"
    }
}

/// The robot this process runs.
struct Loaded {
    name: &'static str,
    urdf: String,
    floating: bool,
    mechanism: Mechanism,
    equations: &'static [&'static str],
}

static LOADED: OnceLock<Loaded> = OnceLock::new();

/// Loads the robot named `name` from URDF text `urdf` (checked as `mbfmu build --urdf`
/// checks it), its root link floating or fixed, once per process; again only with the
/// same texts and base.
pub fn load(name: &str, urdf: &str, floating: bool) -> Result<(), String> {
    if let Some(loaded) = LOADED.get() {
        return if loaded.name == name && loaded.urdf == urdf && loaded.floating == floating {
            Ok(())
        } else {
            Err(format!(
                "this binary runs {} already: one robot per loaded binary",
                loaded.name
            ))
        };
    }
    if !crate::xml::is_model_identifier(name) {
        return Err(format!(
            "resources/{NAME_RESOURCE}: {name:?} is no modelIdentifier"
        ));
    }
    let file = format!("resources/{URDF_RESOURCE}");
    let mut mechanism = super::urdf::parse(urdf, &file)
        .map_err(|e| format!("{e} (the FMU's resources were edited or damaged)"))?;
    mechanism.floating_base = floating;
    super::fmu::Built::new(mechanism.clone()).map_err(|e| e.in_file(&file).to_string())?;
    if !mechanism.closures.is_empty() {
        return Err(format!("{file}: loop closures are for compiled mechanisms"));
    }
    let mut lines: Vec<&'static str> = crate::mechanism_equations!().to_vec();
    for note in super::fmu::unmodelled_notes(&mechanism) {
        lines.push(Box::leak(note.into_boxed_str()));
    }
    let loaded = Loaded {
        name: Box::leak(name.to_string().into_boxed_str()),
        urdf: urdf.to_string(),
        floating,
        mechanism,
        equations: Box::leak(lines.into_boxed_slice()),
    };
    // Two threads instantiating at once: the second finds the first's, and compares.
    if LOADED.set(loaded).is_err() {
        return load(name, urdf, floating);
    }
    Ok(())
}

/// Loads the robot from the FMU's `resources/` folder `folder` ([`load`]).
pub fn load_from(folder: &Path) -> Result<(), String> {
    let read = |file: &str| {
        std::fs::read_to_string(folder.join(file))
            .map_err(|e| format!("cannot read resources/{file} ({}): {e}", folder.display()))
    };
    let name = read(NAME_RESOURCE)?;
    let floating = match folder.join(BASE_RESOURCE).exists() {
        false => false,
        true => match read(BASE_RESOURCE)?.trim() {
            "floating" => true,
            "fixed" => false,
            other => {
                return Err(format!(
                    "resources/{BASE_RESOURCE}: {other:?} is neither \"fixed\" nor \"floating\""
                ))
            }
        },
    };
    load(name.trim(), &read(URDF_RESOURCE)?, floating)
}

fn loaded() -> &'static Loaded {
    LOADED
        .get()
        .expect("the mechanism runtime ran before its robot was loaded (at instantiation)")
}

/// The runtime's declaration: its robot is [`load`]ed, not compiled in.
pub struct Runtime;

impl Declared for Runtime {
    /// Never an FMU's: [`Declared::name`] is the loaded robot's.
    const NAME: &'static str = "mechanism_runtime";

    fn name() -> &'static str {
        loaded().name
    }

    fn equations() -> &'static [&'static str] {
        loaded().equations
    }

    /// The tool, the robot's name and URDF text as read, and each variable's name, unit,
    /// causality and variability in order: the same on every platform.
    fn token_text(_model_description: String) -> String {
        use crate::model::System;
        type R = super::fmu::Robot<Runtime>;
        let loaded = loaded();
        let mut text = format!(
            "{}\nmechanism runtime\n{}\n{}\n",
            crate::xml::GENERATION_TOOL,
            loaded.name,
            loaded.urdf
        );
        // (Only a floating base adds a line: a fixed robot's token stays what it was.)
        if loaded.floating {
            text += "base floating\n";
        }
        let groups = [
            ("parameter", R::parameters()),
            ("input", R::inputs()),
            ("state", R::states()),
            ("output", R::outputs()),
        ];
        for (what, vars) in groups {
            for v in vars {
                text += &format!("{what} {} {:?} {}\n", v.name, v.unit, v.dependent);
            }
        }
        text
    }

    fn mechanism() -> Mechanism {
        loaded().mechanism.clone()
    }

    fn built() -> &'static super::fmu::Built {
        static BUILT: OnceLock<super::fmu::Built> = OnceLock::new();
        BUILT.get_or_init(super::fmu::Built::of::<Runtime>)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ONE: &str = r#"<robot name="one"><link name="base"/>
      <link name="arm"><inertial><origin xyz="0 0 -0.5"/><mass value="1"/>
        <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
      <joint name="hinge" type="continuous"><parent link="base"/><child link="arm"/>
        <axis xyz="0 1 0"/></joint></robot>"#;

    /// One robot per process: loading it again is allowed with the same texts only; a
    /// damaged file or a bad identifier is one line naming the resource.
    #[test]
    fn a_robot_loads_once_and_bad_resources_are_one_line() {
        let truncated = load("one", &ONE[..ONE.len() / 2], false).unwrap_err();
        assert!(
            truncated.starts_with("resources/mechanism.urdf"),
            "{truncated}"
        );
        assert!(!truncated.contains('\n'), "{truncated}");
        let named = load("1one", ONE, false).unwrap_err();
        assert!(named.contains("no modelIdentifier"), "{named}");
        load("one", ONE, false).unwrap();
        load("one", ONE, false).unwrap();
        assert!(load("one", ONE, true)
            .unwrap_err()
            .contains("runs one already"));
        assert_eq!(Runtime::name(), "one");
        assert!(load("two", ONE, false)
            .unwrap_err()
            .contains("runs one already"));
        let heavier = ONE.replace("mass value=\"1\"", "mass value=\"2\"");
        assert!(load("one", &heavier, false).is_err());
    }
}
