//! The FMU archive: modelDescription.xml, a binary per platform ([`platforms`]), the
//! documentation page and the other files (made by `docs`),
//! filled from what the compiled model itself answers ([`protocol`], [`library`]).

pub mod crosscheck;
pub mod library;
pub mod platforms;
pub mod protocol;

pub use library::ModelLibrary;
pub use platforms::Platform;

use std::io::Write;
use std::path::{Path, PathBuf};
use zip::write::SimpleFileOptions;

/// Where the FMI 3.0 FMUs go beside the FMI 2.0 ones in `out_dir`: the sibling folder
/// named with a 3 (`target/fmu` → `target/fmu3`).
pub fn fmi3_dir(out_dir: &Path) -> std::path::PathBuf {
    let name = out_dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "fmu".into());
    out_dir.with_file_name(format!("{name}3"))
}

/// What an FMU holds beside its binaries.
struct Contents<'a> {
    model_identifier: &'a str,
    model_description: &'a str,
    documentation: &'a str,
    /// Each platform's binary (read), the host's first.
    binaries: &'a [(&'static Platform, Vec<u8>)],
    /// `(file name, content)` pairs under `resources/`.
    resources: &'a [(String, String)],
    /// `(path in the archive, content)`: the FMI-LS-REF reference result under `extra/`.
    files: &'a [(String, String)],
}

/// Writes the FMU `out`: each binary under `binaries/<folder>/<model_identifier>.<ext>`,
/// the folder FMI 3.0's platform tuple (`fmi3`) or FMI 2.0's name.
fn write_fmu_in(out: &Path, fmi3: bool, c: &Contents) -> Result<(), String> {
    let Contents {
        model_identifier,
        model_description,
        documentation,
        binaries,
        resources,
        files,
    } = *c;
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
    let mut entries: Vec<(String, &[u8])> =
        vec![("modelDescription.xml".into(), model_description.as_bytes())];
    for (platform, binary) in binaries {
        let folder = if fmi3 { platform.fmi3 } else { platform.fmi2 };
        let ext = platform.extension();
        entries.push((
            format!("binaries/{folder}/{model_identifier}.{ext}"),
            binary,
        ));
    }
    entries.push(("documentation/index.html".into(), documentation.as_bytes()));
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

pub use crate::xml::is_model_identifier;

/// Writes `<out_dir>/<model identifier>.fmu` (FMI 2.0) and, when the model describes
/// itself in FMI 3.0 too, `<out_dir>3/<model identifier>.fmu` ([`fmi3_dir`]) from the
/// model's binaries alone, one per platform, the host's first: its `mbfmu_describe` gives
/// the XML, the documentation and the resources (one modelDescription for every
/// platform). Returns the FMI 2.0 FMU's path.
pub fn package_library(
    binaries: &[(&'static Platform, PathBuf)],
    out_dir: &Path,
) -> Result<PathBuf, String> {
    package_library_with(binaries, out_dir, &[])
}

/// [`package_library`] with `request` records added to the `package` request (the
/// mechanism runtime's robot: its `model_identifier` and `urdf`).
pub fn package_library_with(
    binaries: &[(&'static Platform, PathBuf)],
    out_dir: &Path,
    request: &[(&str, &str)],
) -> Result<PathBuf, String> {
    let (host, library) = binaries
        .first()
        .ok_or("no binary to package: the host's describes the model")?;
    if !host.is_host() {
        return Err(format!(
            "{}: the first binary must be this machine's, to describe the model",
            library.display()
        ));
    }
    let mut asked = vec![("request", "package")];
    asked.extend_from_slice(request);
    let records = ModelLibrary::open(library)?.call(&protocol::encode(&asked))?;
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
    let read: Vec<(&'static Platform, Vec<u8>)> = binaries
        .iter()
        .map(|(p, path)| {
            std::fs::read(path)
                .map(|bytes| (*p, bytes))
                .map_err(|e| format!("cannot read {}: {e}", path.display()))
        })
        .collect::<Result<_, _>>()?;
    let fmu = out_dir.join(format!("{identifier}.fmu"));
    let mut contents = Contents {
        model_identifier: identifier,
        model_description: get("model_description")?,
        documentation: get("documentation")?,
        binaries: &read,
        resources: &resources,
        files: &files,
    };
    write_fmu_in(&fmu, false, &contents)?;
    // The FMI 3.0 FMU: the same binaries and files, FMI 3.0's description and folders.
    if let Some(description3) = protocol::value(&records, "model_description3") {
        contents.model_description = description3;
        let fmu3 = fmi3_dir(out_dir).join(format!("{identifier}.fmu"));
        write_fmu_in(&fmu3, true, &contents)?;
    }
    Ok(fmu)
}
