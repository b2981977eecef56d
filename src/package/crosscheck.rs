//! `mbfmu crosscheck`: the FMI Cross-Check vendor tree of FMUs already built,
//! `fmus/2.0/cs/<platform>/mbfmu/<version>/<Model>/` with `<Model>.fmu`, `<Model>_ref.csv`,
//! `<Model>_ref.opt`, `<Model>_in.csv` (models with inputs) and `ReadMe.txt`, all from what
//! the FMU itself holds: its DefaultExperiment and its FMI-LS-REF reference result.
//!
//! fmpy compares a run with a tube around each reference signal, 10 % of the signal's
//! range wide (after a min/max over 21 of 1000 resampled points). So the `_ref.csv` keeps a
//! column only where that tube is at least [`TUBE_FLOOR`] × rtol of its scale, the tolerance
//! the test suite holds an FMU run to; a quantity that only varies by rounding (a conserved
//! energy, |H|, a constraint residual) would make a tube of rounding width that any other
//! correct run leaves. An exactly constant column is kept (fmpy then allows 10 % of its value,
//! or 0.5 around 0). The rows are the reference's, one per communication step, the grid the
//! importer's run is sampled on, so a fast signal is not cut between samples. A model of
//! many states (the N four-bar's 162) would pass the repository's 1 MB per file: then its
//! own outputs are kept first and its states only as far as the size allows.

use std::io::Read;
use std::path::{Path, PathBuf};

/// Where the reference result lives in an FMU (FMI-LS-REF).
pub const REFERENCE_IN_FMU: &str = "extra/org.fmi-standard.fmi-ls-ref/reference.csv";
/// A `_ref.csv` column's fmpy tube (10 % of its range) must be at least this × rtol × its
/// scale: the tolerance (1e4 × rtol × scale) tests/python/test_reference_result.py holds a
/// run of the default experiment to.
pub const TUBE_FLOOR: f64 = 1e4;
/// The FMI Cross-Check repository takes no file above 1 MB (fmpy's validator says so):
/// the `_ref.csv`, and the `_out.csv` an importer writes with the same columns.
pub const MAX_FILE_BYTES: usize = 1_000_000;
/// A value in an importer's `_out.csv`, at most: 17 significant digits, sign, point,
/// exponent and comma.
pub const IMPORTER_BYTES_PER_VALUE: usize = 25;

/// What the cross-check needs of an FMU's modelDescription.xml.
#[derive(Debug, Default)]
struct Description {
    start: f64,
    stop: f64,
    tolerance: f64,
    step: f64,
    /// (name, start) of every input.
    inputs: Vec<(String, f64)>,
    /// (name, nominal) of every output.
    outputs: Vec<(String, f64)>,
    /// The names of the continuous states (the variables a `derivative` attribute names).
    states: Vec<String>,
}

fn read_description(xml: &str) -> Result<Description, String> {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_str(xml);
    let mut d = Description {
        stop: f64::NAN,
        tolerance: f64::NAN,
        step: f64::NAN,
        ..Default::default()
    };
    let mut current: Option<(String, String)> = None;
    // Every ScalarVariable's name, and the (1-based) indices `derivative` attributes name.
    let (mut names, mut derivative_of) = (Vec::new(), Vec::new());
    loop {
        let event = reader
            .read_event()
            .map_err(|e| format!("modelDescription.xml: {e}"))?;
        let e = match &event {
            Event::Start(e) | Event::Empty(e) => e,
            Event::Eof => break,
            _ => continue,
        };
        let mut attr = std::collections::HashMap::new();
        for a in e.attributes().flatten() {
            let key: &str = a.key.as_ref();
            let key = key.to_string();
            let value = quick_xml::escape::unescape(&a.value)
                .map_err(|e| format!("modelDescription.xml: {e}"))?
                .into_owned();
            attr.insert(key, value);
        }
        let num = |k: &str, default: f64| -> Result<f64, String> {
            attr.get(k).map_or(Ok(default), |v| {
                v.parse()
                    .map_err(|_| format!("modelDescription.xml: {k}={v} is not a number"))
            })
        };
        let name = e.name();
        let name: &str = name.as_ref();
        match name {
            "DefaultExperiment" => {
                d.start = num("startTime", 0.0)?;
                d.stop = num("stopTime", f64::NAN)?;
                d.tolerance = num("tolerance", f64::NAN)?;
                d.step = num("stepSize", f64::NAN)?;
            }
            "ScalarVariable" => {
                names.push(attr.get("name").cloned().unwrap_or_default());
                current = Some((
                    attr.get("name").cloned().unwrap_or_default(),
                    attr.get("causality").cloned().unwrap_or_default(),
                ));
            }
            "Real" => {
                if let Some(k) = attr.get("derivative") {
                    derivative_of.push(k.parse::<usize>().map_err(|_| {
                        format!("modelDescription.xml: derivative={k} is not an index")
                    })?);
                }
                if let Some((name, causality)) = current.take() {
                    match causality.as_str() {
                        "input" => d.inputs.push((name, num("start", 0.0)?)),
                        "output" => d.outputs.push((name, num("nominal", 1.0)?.abs())),
                        _ => {}
                    }
                }
            }
            _ => {}
        }
    }
    if !(d.stop.is_finite() && d.tolerance.is_finite() && d.step.is_finite()) {
        return Err("modelDescription.xml: a DefaultExperiment with stopTime, tolerance and stepSize is needed".into());
    }
    d.states = derivative_of
        .iter()
        .filter_map(|&k| names.get(k.wrapping_sub(1)).cloned())
        .collect();
    Ok(d)
}

/// Whether fmpy's tube around `column` (10 % of its range) is at least [`TUBE_FLOOR`] ×
/// `rtol` × its scale (the largest of its range, largest magnitude and `nominal`), or the
/// column is exactly constant (then fmpy's tube is 10 % of its value, or 0.5 around 0).
fn fits_fmpys_tube(column: &[f64], nominal: f64, rtol: f64) -> Result<(), String> {
    let max = column.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let min = column.iter().cloned().fold(f64::INFINITY, f64::min);
    let magnitude = column.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let scale = (max - min).max(magnitude).max(nominal);
    let needed = TUBE_FLOOR * rtol * scale;
    if max == min || 0.1 * (max - min) >= needed {
        Ok(())
    } else {
        Err(format!(
            "varies by {:.1e} only: fmpy's tube (10 % of that) is narrower than {TUBE_FLOOR:e} x rtol x scale = {needed:.1e}",
            max - min
        ))
    }
}

/// A CSV as (header, rows).
fn parse_csv(text: &str) -> Result<(Vec<String>, Vec<Vec<f64>>), String> {
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .ok_or("empty reference CSV")?
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .filter(|l| !l.is_empty())
        .map(|l| {
            l.split(',')
                .map(|v| {
                    v.parse()
                        .map_err(|_| format!("reference CSV: {v} is not a number"))
                })
                .collect::<Result<Vec<f64>, String>>()
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((header, rows))
}

/// What one model contributes to the tree: the kept and the dropped columns.
#[derive(Debug)]
pub struct Written {
    pub model: String,
    pub dir: PathBuf,
    pub kept: Vec<String>,
    /// (column, why)
    pub dropped: Vec<(String, String)>,
}

/// Writes the vendor tree of every `*.fmu` in `fmus` under `out` for tool `mbfmu`
/// `version` on `platform`.
pub fn write_tree(
    fmus: &Path,
    out: &Path,
    platform: &str,
    version: &str,
) -> Result<Vec<Written>, String> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(fmus)
        .map_err(|e| format!("cannot read {}: {e}", fmus.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "fmu"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(format!(
            "no .fmu in {} (run mbfmu build --all first)",
            fmus.display()
        ));
    }
    files
        .iter()
        .map(|fmu| write_model(fmu, out, platform, version))
        .collect()
}

fn write_model(fmu: &Path, out: &Path, platform: &str, version: &str) -> Result<Written, String> {
    let model = fmu
        .file_stem()
        .and_then(|s| s.to_str())
        .ok_or_else(|| format!("{}: no model name", fmu.display()))?
        .to_string();
    let file = std::fs::File::open(fmu).map_err(|e| format!("{}: {e}", fmu.display()))?;
    let mut zip = zip::ZipArchive::new(file).map_err(|e| format!("{}: {e}", fmu.display()))?;
    let mut read = |name: &str| -> Result<String, String> {
        let mut s = String::new();
        zip.by_name(name)
            .map_err(|e| format!("{}: {name}: {e} (built by an older mbfmu?)", fmu.display()))?
            .read_to_string(&mut s)
            .map_err(|e| format!("{}: {name}: {e}", fmu.display()))?;
        Ok(s)
    };
    let d = read_description(&read("modelDescription.xml")?)?;
    let (header, rows) = parse_csv(&read(REFERENCE_IN_FMU)?)?;
    let dir = out
        .join("fmus/2.0/cs")
        .join(platform)
        .join("mbfmu")
        .join(version)
        .join(&model);
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let write = |name: String, text: &str| {
        let path = dir.join(name);
        std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
    };
    std::fs::copy(fmu, dir.join(format!("{model}.fmu")))
        .map_err(|e| format!("cannot copy {}: {e}", fmu.display()))?;

    // Columns whose fmpy tube is wide enough (module doc).
    let mut keep = vec![0];
    let mut written = Written {
        model: model.clone(),
        dir: dir.clone(),
        kept: Vec::new(),
        dropped: Vec::new(),
    };
    for (j, name) in header.iter().enumerate().skip(1) {
        let column: Vec<f64> = rows.iter().map(|r| r[j]).collect();
        let nominal = d
            .outputs
            .iter()
            .find(|(n, _)| n == name)
            .map_or(1.0, |(_, n)| *n);
        match fits_fmpys_tube(&column, nominal, d.tolerance) {
            Ok(()) => {
                keep.push(j);
                written.kept.push(name.clone());
            }
            Err(why) => written.dropped.push((name.clone(), why)),
        }
    }
    // Within the repository's file size: the model's own outputs first, then its states.
    let budget = MAX_FILE_BYTES / (rows.len().max(1) * IMPORTER_BYTES_PER_VALUE) - 1;
    if keep.len() - 1 > budget {
        let is_state = |j: &usize| d.states.contains(&header[*j]);
        let (states, own): (Vec<usize>, Vec<usize>) = keep[1..].iter().copied().partition(is_state);
        let over: Vec<usize> = own.into_iter().chain(states).skip(budget).collect();
        for &j in &over {
            written.kept.retain(|n| n != &header[j]);
            written.dropped.push((
                header[j].clone(),
                format!("past the {budget} columns whose file stays within the cross-check repository's {MAX_FILE_BYTES} bytes (an importer writes up to {IMPORTER_BYTES_PER_VALUE} bytes a value)"),
            ));
        }
        keep.retain(|j| !over.contains(j));
    }
    let mut csv = String::new();
    let quoted: Vec<String> = keep.iter().map(|&j| format!("\"{}\"", header[j])).collect();
    csv.push_str(&quoted.join(","));
    csv.push('\n');
    for r in &rows {
        // 12 significant digits: the reference's rounding stays far inside any tube.
        let values: Vec<String> = keep.iter().map(|&j| format!("{:.11e}", r[j])).collect();
        csv.push_str(&values.join(","));
        csv.push('\n');
    }
    write(format!("{model}_ref.csv"), &csv)?;
    write(
        format!("{model}_ref.opt"),
        &format!(
            "StartTime,{:?}\nStopTime,{:?}\nStepSize,{:?}\nRelTol,{:?}\n",
            d.start, d.stop, d.step, d.tolerance
        ),
    )?;
    if !d.inputs.is_empty() {
        // The default experiment holds every input at its start value.
        let mut csv = String::from("\"time\"");
        for (n, _) in &d.inputs {
            csv.push_str(&format!(",\"{n}\""));
        }
        csv.push('\n');
        for t in [d.start, d.stop] {
            csv.push_str(&format!("{t:?}"));
            for (_, v) in &d.inputs {
                csv.push_str(&format!(",{v:?}"));
            }
            csv.push('\n');
        }
        write(format!("{model}_in.csv"), &csv)?;
    }
    write("ReadMe.txt".into(), &readme(&model, version, &d, &written))?;
    Ok(written)
}

fn readme(model: &str, version: &str, d: &Description, w: &Written) -> String {
    let mut s = format!(
        "{model}: an FMI 2.0 Co-Simulation FMU exported by mbfmu {version}\n\
         (multibody mechanics models as FMUs; the integration method is the FMU's `solver`\n\
         parameter, DOPRI5 by default, with the tolerance of fmi2SetupExperiment).\n\n\
         Experiment ({model}_ref.opt): the FMU's DefaultExperiment, start {} s, stop {} s,\n\
         communication step {} s, relative tolerance {}, every variable at its start value{}.\n\n\
         Reference ({model}_ref.csv): the FMU's own reference result, shipped inside it under\n\
         FMI-LS-REF (extra/org.fmi-standard.fmi-ls-ref/reference.csv, whose fmi-ls-manifest.xml\n\
         states how it was computed, independently of DOPRI5, and its estimated error),\n\
         at every communication point (one row per step: the grid the importer's run is sampled\n\
         on, so no fast signal is cut between samples), 12 significant digits.\n\n\
         Columns: an output is kept when fmpy's comparison tube around it (10 % of its range)\n\
         is at least {TUBE_FLOOR:e} x rtol x its scale (the largest of its range, its largest\n\
         magnitude and its nominal): a quantity that is conserved, or zero, up to rounding\n\
         would give a tube of rounding width that every other correct run leaves; and, for a\n\
         model of many variables, as far as the files stay within the repository's 1 MB\n\
         (its own outputs first, then its states).\n",
        d.start,
        d.stop,
        d.step,
        d.tolerance,
        if d.inputs.is_empty() {
            String::new()
        } else {
            format!("; the inputs held at their start values ({model}_in.csv)")
        }
    );
    s.push_str(&format!("Kept: {}\n", w.kept.join(", ")));
    if w.dropped.is_empty() {
        s.push_str("Dropped: none\n");
    } else {
        s.push_str("Dropped:\n");
        for (n, why) in &w.dropped {
            s.push_str(&format!("  {n}: {why}\n"));
        }
    }
    s.push_str(
        "\nCompliance checker: no FMU Compliance Checker log is included (the checker is not\n\
         part of mbfmu's toolchain); the FMU passes fmpy's validation (fmpy.validation) and\n\
         fmpy's cross-check in mbfmu's test suite.\n",
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_description_gives_the_experiment_inputs_and_outputs() {
        let xml = r#"<fmiModelDescription><DefaultExperiment startTime="0" stopTime="2.5" tolerance="1e-8" stepSize="0.01"/>
<ModelVariables>
<ScalarVariable name="F" causality="input"><Real start="1.5"/></ScalarVariable>
<ScalarVariable name="x" causality="output"><Real nominal="-0.1"/></ScalarVariable>
<ScalarVariable name="m" causality="parameter"><Real start="2"/></ScalarVariable>
<ScalarVariable name="E" causality="output" initial="calculated"><Real/></ScalarVariable>
</ModelVariables></fmiModelDescription>"#;
        let d = read_description(xml).unwrap();
        assert_eq!(
            (d.start, d.stop, d.tolerance, d.step),
            (0.0, 2.5, 1e-8, 0.01)
        );
        assert_eq!(d.inputs, vec![("F".to_string(), 1.5)]);
        assert_eq!(
            d.outputs,
            vec![("x".to_string(), 0.1), ("E".to_string(), 1.0)]
        );
        let no_experiment = xml.replace("stepSize=\"0.01\"", "");
        assert!(read_description(&no_experiment).is_err());
        let (header, rows) = parse_csv("time,x\n0.0,1\n0.5,2e-3\n").unwrap();
        assert_eq!(header, vec!["time", "x"]);
        assert_eq!(rows, vec![vec![0.0, 1.0], vec![0.5, 2e-3]]);
        assert!(parse_csv("time,x\n0.0,abc\n").is_err());
    }

    #[test]
    fn a_column_conserved_to_rounding_is_left_out_of_the_reference() {
        let t: Vec<f64> = (0..1001).map(|k| k as f64 * 0.01).collect();
        let swing: Vec<f64> = t.iter().map(|t| 0.1 * t.sin()).collect();
        let energy: Vec<f64> = t.iter().map(|t| -4.9 + 1e-14 * t.cos()).collect();
        assert!(fits_fmpys_tube(&swing, 1.0, 1e-8).is_ok());
        assert!(fits_fmpys_tube(&energy, 1.0, 1e-8).is_err());
        assert!(fits_fmpys_tube(&[0.0; 5], 1.0, 1e-8).is_ok());
        assert!(fits_fmpys_tube(&[-4.9; 5], 1.0, 1e-8).is_ok());
    }
}
