//! The FMU archive: modelDescription.xml, the platform binary, the documentation page and the
//! other files (made by `docs`),
//! filled from what the compiled model itself answers ([`protocol`], [`library`]).

pub mod crosscheck;
pub mod library;
pub mod protocol;

pub use library::ModelLibrary;

use std::io::Write;
use std::path::Path;
use zip::write::SimpleFileOptions;

/// The FMI platform folder of the machine building the FMU.
pub fn platform() -> &'static str {
    match (std::env::consts::OS, std::env::consts::ARCH) {
        ("linux", "x86_64") => "linux64",
        ("linux", "x86") => "linux32",
        ("windows", "x86_64") => "win64",
        ("windows", "x86") => "win32",
        ("macos", _) => "darwin64",
        _ => "linux64",
    }
}

/// The FMI 3.0 platform tuple of the machine building the FMU (`binaries/<tuple>/`).
pub fn platform3() -> &'static str {
    match (std::env::consts::OS, std::env::consts::ARCH) {
        ("linux", "x86") => "x86-linux",
        ("linux", "aarch64") => "aarch64-linux",
        ("windows", "x86_64") => "x86_64-windows",
        ("windows", "x86") => "x86-windows",
        ("macos", "aarch64") => "aarch64-darwin",
        ("macos", _) => "x86_64-darwin",
        _ => "x86_64-linux",
    }
}

/// Where the FMI 3.0 FMUs go beside the FMI 2.0 ones in `out_dir`: the sibling folder
/// named with a 3 (`target/fmu` → `target/fmu3`).
pub fn fmi3_dir(out_dir: &Path) -> std::path::PathBuf {
    let name = out_dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "fmu".into());
    out_dir.with_file_name(format!("{name}3"))
}

/// The shared-library file name cargo gives a cdylib crate named `crate_name`.
pub fn library_file(crate_name: &str) -> String {
    let stem = crate_name.replace('-', "_");
    match std::env::consts::OS {
        "windows" => format!("{stem}.dll"),
        "macos" => format!("lib{stem}.dylib"),
        _ => format!("lib{stem}.so"),
    }
}

/// Writes `<out>`, an FMU with the model's XML, documentation, binary `library`
/// (stored as `binaries/<platform>/<model_identifier>.<ext>`) and `resources`
/// (`(file name, content)` pairs under `resources/`) and `files` (`(path in the archive,
/// content)`: the FMI-LS-REF reference result under `extra/`).
pub fn write_fmu(
    out: &Path,
    model_identifier: &str,
    model_description: &str,
    documentation: &str,
    library: &Path,
    resources: &[(String, String)],
    files: &[(String, String)],
) -> Result<(), String> {
    let contents = Contents {
        model_identifier,
        model_description,
        documentation,
        library,
        resources,
        files,
    };
    write_fmu_in(out, platform(), &contents)
}

/// What an FMU holds (see [`write_fmu`]).
struct Contents<'a> {
    model_identifier: &'a str,
    model_description: &'a str,
    documentation: &'a str,
    library: &'a Path,
    resources: &'a [(String, String)],
    files: &'a [(String, String)],
}

/// [`write_fmu`] with the binary under `binaries/<platform>/` (FMI 2.0's folder names or
/// FMI 3.0's tuples).
fn write_fmu_in(out: &Path, platform: &str, c: &Contents) -> Result<(), String> {
    let Contents {
        model_identifier,
        model_description,
        documentation,
        library,
        resources,
        files,
    } = *c;
    let binary =
        std::fs::read(library).map_err(|e| format!("cannot read {}: {e}", library.display()))?;
    let ext = library.extension().and_then(|e| e.to_str()).unwrap_or("so");
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    let file =
        std::fs::File::create(out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    let mut zip = zip::ZipWriter::new(file);
    // A fixed timestamp keeps the archive reproducible.
    let options = SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .last_modified_time(zip::DateTime::default());
    let mut entries: Vec<(String, &[u8])> = vec![
        ("modelDescription.xml".into(), model_description.as_bytes()),
        (
            format!("binaries/{platform}/{model_identifier}.{ext}"),
            &binary,
        ),
        ("documentation/index.html".into(), documentation.as_bytes()),
    ];
    for (name, text) in resources {
        entries.push((format!("resources/{name}"), text.as_bytes()));
    }
    for (path, text) in files {
        if path.starts_with('/') || path.split('/').any(|p| p == ".." || p.is_empty()) {
            return Err(format!("{path}: not a relative path inside the FMU"));
        }
        entries.push((path.clone(), text.as_bytes()));
    }
    for (name, data) in entries {
        zip.start_file(name.as_str(), options)
            .and_then(|_| zip.write_all(data).map_err(Into::into))
            .map_err(|e| format!("cannot write {name} into {}: {e}", out.display()))?;
    }
    zip.finish()
        .map_err(|e| format!("cannot finish {}: {e}", out.display()))?;
    Ok(())
}

/// Whether `name` can be an FMI modelIdentifier: a C identifier (it names the binary and
/// prefixes nothing, but importers build file names and C code from it).
pub fn is_model_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Writes `<out_dir>/<model identifier>.fmu` (FMI 2.0) and, when the model describes
/// itself in FMI 3.0 too, `<out_dir>3/<model identifier>.fmu` ([`fmi3_dir`]) from the
/// cdylib `library` alone: its `mbfmu_describe` gives the XML, the documentation and the
/// resources. Returns the FMI 2.0 FMU's path.
pub fn package_library(library: &Path, out_dir: &Path) -> Result<std::path::PathBuf, String> {
    let records =
        ModelLibrary::open(library)?.call(&protocol::encode(&[("request", "package")]))?;
    let get = |key: &str| {
        protocol::value(&records, key)
            .ok_or_else(|| format!("{}: the package answer has no {key}", library.display()))
    };
    let identifier = get("model_identifier")?;
    if !is_model_identifier(identifier) {
        return Err(format!(
            "{identifier:?} is not a valid modelIdentifier (letters, digits and _, not starting with a digit): change the model's NAME"
        ));
    }
    let resources: Vec<(String, String)> = records
        .iter()
        .filter_map(|(k, v)| Some((k.strip_prefix("resource:")?.to_string(), v.clone())))
        .collect();
    let files: Vec<(String, String)> = records
        .iter()
        .filter_map(|(k, v)| Some((k.strip_prefix("file:")?.to_string(), v.clone())))
        .collect();
    let fmu = out_dir.join(format!("{identifier}.fmu"));
    let mut contents = Contents {
        model_identifier: identifier,
        model_description: get("model_description")?,
        documentation: get("documentation")?,
        library,
        resources: &resources,
        files: &files,
    };
    write_fmu_in(&fmu, platform(), &contents)?;
    // The FMI 3.0 FMU: the same binary and files, FMI 3.0's description and platform folder.
    if let Some(description3) = protocol::value(&records, "model_description3") {
        contents.model_description = description3;
        let fmu3 = fmi3_dir(out_dir).join(format!("{identifier}.fmu"));
        write_fmu_in(&fmu3, platform3(), &contents)?;
    }
    Ok(fmu)
}
