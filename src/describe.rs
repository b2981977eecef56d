//! What a compiled model answers about itself (the model's side of
//! [`package::protocol`](crate::package::protocol), behind its cdylib's `mbfmu_describe`):
//! the FMU's contents and its linearisation. So the CLI packages and linearises a model it
//! was not compiled with (a user's crate), and the in-tree systems take the same path.
//! Above `xml`, `package` and `linearize`, which it ties together for one system.

use crate::linearize::{self, to_csv, to_json, to_py, Linearization, OperatingPoint, States, Trim};
use crate::model::lagrangian::Lagrangian;
use crate::model::{symbolic, System};
use crate::package::protocol::{self, Records, ABI};

/// Linearise `M` at its start values with these `name = value` overrides, after an
/// optional trim, in these states; an error when the result is not finite.
pub fn linearize_at<M: System>(
    overrides: &[(String, f64)],
    trim: Option<Trim>,
    states: &States,
) -> Result<Linearization, String> {
    let (mut op, warnings) = OperatingPoint::consistent::<M>(overrides)?;
    if let Some(what) = trim {
        linearize::trim::<M>(&mut op, what)?;
    }
    let mut lin = linearize::linearize::<M>(&op);
    lin = match states {
        States::All => lin,
        States::Independent => linearize::reduced::<M>(&lin, None)?,
        States::Only(keep) => linearize::reduced::<M>(&lin, Some(keep))?,
    };
    lin.warnings = warnings;
    let finite = |m: &nalgebra::DMatrix<f64>| m.iter().all(|v| v.is_finite());
    let all_finite = finite(&lin.a)
        && finite(&lin.b)
        && finite(&lin.c)
        && finite(&lin.d)
        && lin.y0.iter().all(|v| v.is_finite());
    if !all_finite {
        return Err(format!(
            "{}: the linearisation at this point is not finite (a derivative is singular there)",
            M::name()
        ));
    }
    Ok(lin)
}

/// `mbfmu linearize`'s options, as sent to the model.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LinearizeRequest {
    /// Scenes whose start values apply first, in order.
    pub scenes: Vec<String>,
    /// Parameter values (`--set`).
    pub sets: Vec<(String, f64)>,
    /// State or input values (`--at`).
    pub ats: Vec<(String, f64)>,
    pub trim: Option<Trim>,
    /// All the states, the independent ones, or some of those (`--independent`, `--keep`).
    pub states: States,
    /// `json`, `py` or `csv`.
    pub format: String,
}

/// What a linearize request answers: the text, and one line per value that had to give.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearizeAnswer {
    pub text: String,
    pub warnings: Vec<String>,
}

impl LinearizeRequest {
    /// The request in the protocol's framing.
    pub fn encode(&self) -> String {
        let mut r: Vec<(&str, String)> = vec![("request", "linearize".into())];
        r.extend(self.scenes.iter().map(|s| ("scene", s.clone())));
        r.extend(self.sets.iter().map(|(n, v)| ("set", format!("{n}={v:?}"))));
        r.extend(self.ats.iter().map(|(n, v)| ("at", format!("{n}={v:?}"))));
        match self.trim {
            Some(Trim::States) => r.push(("trim", "states".into())),
            Some(Trim::Inputs) => r.push(("trim", "inputs".into())),
            None => {}
        }
        match &self.states {
            States::All => {}
            States::Independent => r.push(("states", "independent".into())),
            States::Only(keep) => r.push(("states", format!("keep:{}", keep.join(",")))),
        }
        r.push(("format", self.format.clone()));
        protocol::encode(&r)
    }

    fn decode(records: &Records) -> Result<Self, String> {
        let assignment = |text: &str| -> Result<(String, f64), String> {
            let (n, v) = text
                .split_once('=')
                .ok_or_else(|| format!("expected NAME=VALUE, got {text}"))?;
            let v = v.parse().map_err(|_| format!("{n}: {v} is not a number"))?;
            Ok((n.to_string(), v))
        };
        let mut req = LinearizeRequest {
            format: "json".into(),
            ..Default::default()
        };
        for (k, v) in records {
            match k.as_str() {
                "request" => {}
                "scene" => req.scenes.push(v.clone()),
                "set" => req.sets.push(assignment(v)?),
                "at" => req.ats.push(assignment(v)?),
                "trim" if v == "states" => req.trim = Some(Trim::States),
                "trim" if v == "inputs" => req.trim = Some(Trim::Inputs),
                "states" if v == "independent" => req.states = States::Independent,
                "states" if v.starts_with("keep:") => {
                    let names = v["keep:".len()..].split(',').map(str::to_string).collect();
                    req.states = States::Only(names);
                }
                "format" => req.format = v.clone(),
                other => return Err(format!("linearize request: unknown record {other}")),
            }
        }
        Ok(req)
    }

    /// The answer of `M` (what its cdylib would send).
    pub fn answer<M: System>(&self) -> Result<LinearizeAnswer, String> {
        let model = M::name();
        // A scene's start values replace the system's operating point, else --at goes on it.
        let mut overrides: Vec<(String, f64)> = if self.scenes.is_empty() {
            M::linearization_point()
        } else {
            Vec::new()
        };
        for name in &self.scenes {
            let scene = M::scenes()
                .into_iter()
                .find(|s| s.name == name.as_str())
                .ok_or_else(|| format!("{model} has no scene {name}"))?;
            overrides.extend(scene.start_values.iter().map(|(n, v)| (n.to_string(), *v)));
        }
        let params: Vec<String> = M::parameters()
            .into_iter()
            .map(|v| v.name.into_owned())
            .collect();
        for (name, _) in &self.sets {
            if !params.contains(name) {
                return Err(format!(
                    "--set {name}: not a parameter of {model} (parameters: {})",
                    params.join(", ")
                ));
            }
        }
        for (name, _) in &self.ats {
            if params.contains(name) {
                return Err(format!("--at {name}: a parameter; use --set"));
            }
        }
        overrides.extend(self.sets.iter().cloned());
        overrides.extend(self.ats.iter().cloned());
        let lin = linearize_at::<M>(&overrides, self.trim, &self.states)?;
        let text = match self.format.as_str() {
            "json" => to_json(&lin),
            "py" => to_py(&lin),
            "csv" => to_csv(&lin),
            other => return Err(format!("unknown format {other} (json, py, csv)")),
        };
        Ok(LinearizeAnswer {
            text,
            warnings: lin.warnings,
        })
    }

    /// Reads an answer from response records.
    pub fn parse_answer(records: &Records) -> Result<LinearizeAnswer, String> {
        Ok(LinearizeAnswer {
            text: protocol::value(records, "text")
                .ok_or("linearize answer without text")?
                .to_string(),
            warnings: records
                .iter()
                .filter(|(k, _)| k == "warning")
                .map(|(_, v)| v.clone())
                .collect(),
        })
    }
}

/// What goes into `M`'s FMU beside the binary (the `package` request); `traced` and
/// `pictures` go on the page (see [`crate::docs::page::page`]).
fn package<M: System>(
    traced: Option<String>,
    pictures: Option<&dyn crate::docs::page::Pictures>,
) -> Result<Records, String> {
    // The linearisation at the system's operating point (the start values where it names
    // none).
    let lin = linearize_at::<M>(&M::linearization_point(), None, &States::All)?;
    let reference = crate::docs::reference::reference::<M>()?;
    // The page reads the model in its independent states where the constraints allow.
    let page_lin = linearize::reduced::<M>(&lin, None).unwrap_or_else(|_| lin.clone());
    let (documentation, page_files) =
        crate::docs::page::page::<M>(Some(&page_lin), &reference, traced.as_deref(), pictures);
    let mut records: Records = vec![
        ("model_identifier".into(), M::name().into()),
        (
            "model_description".into(),
            crate::xml::model_description::<M>(),
        ),
        (
            "model_description3".into(),
            crate::xml::model_description3::<M>(),
        ),
        ("documentation".into(), documentation),
        ("resource:linearization.json".into(), to_json(&lin)),
        ("resource:linearized_model.py".into(), to_py(&lin)),
    ];
    records.extend(
        reference
            .files(M::name())
            .into_iter()
            .chain(page_files)
            .map(|(path, text)| (format!("file:{path}"), text)),
    );
    Ok(records)
}

fn answer<M: System>(request: &Records) -> Result<Records, String> {
    match protocol::value(request, "request") {
        Some("package") => package::<M>(None, None),
        Some("linearize") => {
            let a = LinearizeRequest::decode(request)?.answer::<M>()?;
            let mut r: Records = a
                .warnings
                .into_iter()
                .map(|w| ("warning".to_string(), w))
                .collect();
            r.push(("text".into(), a.text));
            Ok(r)
        }
        other => Err(format!("unknown describe request {other:?}")),
    }
}

/// [`respond`] for a Lagrangian (`export_fmu!(lagrangian …)`): its page also shows T and V
/// typeset from their trace, and it also answers `symbolic`
/// with `source`, the Rust source of its equations of motion traced from T, V and the
/// constraints (`type_name` its type, `nodes` its size), and `in_use`, whether this binary
/// already runs generated equations; or with `error` when the model cannot be traced (it
/// then runs on automatic differentiation, exact and slower).
pub fn respond_lagrangian<L: Lagrangian>(request: &str) -> String {
    let asked = protocol::decode(request)
        .ok()
        .and_then(|r| protocol::value(&r, "request").map(str::to_string));
    let mut records = vec![("abi".to_string(), ABI.to_string())];
    match asked.as_deref() {
        Some("symbolic") => {}
        // The page with T and V typeset from the code besides the equation lines.
        Some("package") => {
            match package::<L>(Some(traced_energies::<L>()), None) {
                Ok(r) => records.extend(r),
                Err(e) => records.push(("error".into(), e)),
            }
            return protocol::encode(&records);
        }
        _ => return respond::<L>(request),
    }
    // One name whatever the model's: the crate's `generated_eom!` line names it.
    let type_name = "GeneratedEom".to_string();
    match generated_source::<L>(&type_name) {
        Ok((source, nodes)) => records.extend([
            ("type_name".to_string(), type_name),
            ("nodes".to_string(), nodes.to_string()),
            ("in_use".to_string(), runs_generated::<L>().to_string()),
            ("source".to_string(), source),
        ]),
        Err(e) => records.push(("error".into(), e)),
    }
    protocol::encode(&records)
}

/// The page's section of `L`'s T and V typeset from their trace (see
/// [`crate::docs::traced`]); a model whose code looks at values (a branch the trace cannot
/// follow) or has an operation with no symbolic form gets a line saying so instead.
fn traced_energies<L: Lagrangian>() -> String {
    use symbolic::{Arg, Expr};
    let (n, np) = (L::coordinates().len(), L::parameters().len());
    let traced = std::panic::catch_unwind(|| {
        symbolic::record(|| {
            let q = Expr::inputs(Arg::Q, n);
            let qd = Expr::inputs(Arg::Qd, n);
            let p = Expr::inputs(Arg::P, np);
            let t = Expr::input(Arg::T, 0);
            (
                L::kinetic(t, &q, &qd, &p).id(),
                L::potential(t, &q, &p).id(),
            )
        })
    });
    let ((kinetic, potential), graph) = match traced {
        Ok(r) if r.1.branches.is_empty() => r,
        _ => return "<p id=\"traced\">T and V are not typeset from the code: it does something the tracer cannot follow.</p>\n".into(),
    };
    let names = |vars: Vec<crate::model::Var>| -> Vec<String> {
        vars.iter()
            .map(|v| crate::docs::traced::greek(&v.name))
            .collect()
    };
    let (coordinates, parameters) = (names(L::coordinates()), names(L::parameters()));
    let inputs = names(L::inputs());
    let name = |arg: Arg, i: u32| -> String {
        let i = i as usize;
        match arg {
            Arg::Q => coordinates[i].clone(),
            Arg::Qd => crate::docs::traced::dotted(&coordinates[i]),
            Arg::P => parameters[i].clone(),
            Arg::U => inputs[i].clone(),
            Arg::T => "t".into(),
        }
    };
    let math = |lhs: &str, root| crate::docs::traced::equation(lhs, &graph, root, &name);
    crate::docs::page::traced_section(&[("T", math("T", kinetic)), ("V", math("V", potential))])
}

/// The generated equations of `L` as a file of a crate that depends on mbfmu.
fn generated_source<L: Lagrangian>(type_name: &str) -> Result<(String, usize), String> {
    let eq = symbolic::equations::<L>().map_err(|e| e.to_string())?;
    let doc = format!(
        "Generated by `mbfmu build` from the Lagrangian of `{}`: do not edit (rebuilt from\n\
         T, V and the constraints whenever they change). M = ∂²T/∂q̇², rhs = Q + ∂L/∂q −\n\
         (∂²L/∂q̇∂q) q̇, G = ∂Φ/∂q, γ = q̇ᵀ∇²Φq̇.",
        eq.name
    );
    let emitted = symbolic::emit::emit(&eq, type_name, &doc, "mbfmu");
    Ok((emitted.source, emitted.nodes))
}

/// Whether `L` answers through generated equations (its `generated_eom!` line is compiled in).
fn runs_generated<L: Lagrangian>() -> bool {
    let (n, k) = (
        L::coordinates().len(),
        L::CONSTRAINTS + L::VELOCITY_CONSTRAINTS,
    );
    let start =
        |vars: Vec<crate::model::Var>| -> Vec<f64> { vars.iter().map(|v| v.start).collect() };
    let (q, qd) = (start(L::coordinates()), start(L::velocities()));
    let (u, p) = (start(L::inputs()), start(L::parameters()));
    let (mut qdd, mut lambda) = (vec![0.0; n], vec![0.0; k]);
    L::generated_eom(0.0, &q, &qd, &u, &p, &mut qdd, &mut lambda)
}

/// [`respond`] for a declared mechanism (`export_fmu!(mechanism …)`): its page also draws
/// the mechanism ([`crate::docs::stick`]: in its reference configuration, and in each
/// scene at three instants of the run); it also answers
/// `symbolic` with `runs`, the one line `mbfmu build` prints about what the FMU runs (a
/// mechanism is not traced from its Lagrangian: its q̈ is the articulated-body algorithm,
/// or the straight-line code generated for it), and with `dynamics`, that code generated
/// again, when the crate's is of another mechanism (an edited one) and so not run,
/// and `mechanism` with `debug`, the `{:?}` of the mechanism it was built from (every
/// number in its shortest exact form), which `mbfmu build --urdf` compares with the URDF's.
pub fn respond_mechanism<R: crate::multibody::fmu::OfMechanism>(request: &str) -> String {
    use crate::multibody::fmu::Declared;
    type D<R> = <R as crate::multibody::fmu::OfMechanism>::Declared;
    let asked = protocol::decode(request)
        .ok()
        .and_then(|r| protocol::value(&r, "request").map(str::to_string));
    let mut records = vec![("abi".to_string(), ABI.to_string())];
    match asked.as_deref() {
        Some("symbolic") => {
            let model = D::<R>::model();
            let n = model.nq();
            let z = vec![0.0; n];
            let mut joints = if n == 1 {
                "1 moving joint".to_string()
            } else {
                format!("{n} moving joints")
            };
            let mimics = n - model.ndof();
            if mimics > 0 {
                joints += &format!(
                    " ({mimics} of them mimic joints: q̈ from the mass matrix reduced to the {} independent ones, O(n³))",
                    model.ndof()
                );
            }
            let m = D::<R>::CONSTRAINTS;
            let floating = model.free_base.is_some();
            if floating {
                joints += " and 6 of the floating base";
            }
            let runs = if m > 0 && !floating && mimics == 0 {
                format!(
                    "runs its tree's dynamics (CRBA, RNEA) with its loop closures by Gauss's principle (G M⁻¹ Gᵀ factored with diagonal pivoting: redundant or singular closures included): {joints}, {m} loop-closure residuals by forward kinematics, projected after every step"
                )
            } else if m > 0 {
                format!(
                    "runs the λ-method on automatic differentiation of its energies: {joints}, {m} loop-closure residuals by forward kinematics, projected after every step"
                )
            } else {
                // The generated code's slices (longer with a floating base).
                let [nq, nqd, _] = crate::multibody::codegen::leaf_lengths(model);
                let (zq, zqd) = (vec![0.0; nq], vec![0.0; nqd]);
                let mut qdd = vec![0.0; nqd];
                let has = D::<R>::generated_aba(&zq, &zqd, &z, &mut qdd);
                let current = crate::multibody::fmu::generated_is_current::<D<R>>();
                let how = if has && current {
                    "straight-line code generated for this mechanism"
                } else if floating {
                    "the articulated-body algorithm with a floating base (the base solved from its articulated inertia) on its model"
                } else {
                    "the articulated-body algorithm (Featherstone) on its model"
                };
                let stale = if has && !current {
                    " (its generated code is of another mechanism: not run)"
                } else {
                    ""
                };
                if has && !current {
                    // Its crate's src/dynamics.rs, regenerated for the mechanism it declares
                    // now: `mbfmu build` writes it and builds again.
                    if let Ok(Some(g)) = crate::multibody::codegen::robot_dynamics(
                        &D::<R>::built().mechanism,
                        "mbfmu",
                    ) {
                        records.push(("dynamics".into(), g.source));
                    }
                }
                let order = if mimics > 0 { "" } else { ", q̈ in O(n)" };
                format!("runs {how}: {joints}{order}{stale}")
            };
            records.push(("runs".into(), runs));
        }
        Some("mechanism") => {
            records.push(("debug".into(), format!("{:?}", D::<R>::mechanism())));
        }
        Some("package") => {
            let built = D::<R>::built();
            let skeleton = crate::docs::stick::Skeleton::new(&built.mechanism, &built.model);
            // The pictures take every model joint's q (mimic joints' from those they follow).
            let start = built.positions_to_model(&built.start);
            let pictures = skeleton.map(|skeleton| crate::docs::stick::MechanismPictures {
                name: D::<R>::name(),
                skeleton,
                start: &start,
            });
            match package::<R>(
                None,
                pictures
                    .as_ref()
                    .map(|p| p as &dyn crate::docs::page::Pictures),
            ) {
                Ok(r) => records.extend(r),
                Err(e) => records.push(("error".into(), e)),
            }
        }
        _ => return respond::<R>(request),
    }
    protocol::encode(&records)
}

/// [`respond_mechanism`] for the mechanism runtime
/// ([`multibody::runtime`](crate::multibody::runtime)): a request carrying
/// `model_identifier` and `urdf` loads that robot first (the packager's `mbfmu build
/// --urdf`); the package answer then carries both texts as the FMU's resources, which
/// the runtime reads at instantiation.
pub fn respond_runtime<R: crate::multibody::fmu::OfMechanism>(request: &str) -> String {
    use crate::multibody::runtime;
    let refuse = |e: &str| protocol::encode(&[("abi", ABI), ("error", e)]);
    let records = match protocol::decode(request) {
        Ok(r) => r,
        Err(e) => return refuse(&e),
    };
    let (Some(name), Some(urdf)) = (
        protocol::value(&records, "model_identifier"),
        protocol::value(&records, "urdf"),
    ) else {
        return refuse("the mechanism runtime answers for a robot given with the request (model_identifier, urdf)");
    };
    let floating = match protocol::value(&records, "base") {
        None | Some("fixed") => false,
        Some("floating") => true,
        Some(other) => return refuse(&format!("base {other:?} is neither fixed nor floating")),
    };
    if let Err(e) = runtime::load(name, urdf, floating) {
        return refuse(&e);
    }
    let answer = respond_mechanism::<R>(request);
    match protocol::decode(&answer) {
        Ok(mut out) if protocol::value(&records, "request") == Some("package") => {
            out.push((
                format!("resource:{}", runtime::NAME_RESOURCE),
                name.to_string(),
            ));
            out.push((
                format!("resource:{}", runtime::URDF_RESOURCE),
                urdf.to_string(),
            ));
            if floating {
                out.push((
                    format!("resource:{}", runtime::BASE_RESOURCE),
                    runtime::base_text(true).to_string(),
                ));
            }
            protocol::encode(&out)
        }
        _ => answer,
    }
}

/// The response of `M` to one request: what `mbfmu_describe` returns.
pub fn respond<M: System>(request: &str) -> String {
    let mut records = vec![("abi".to_string(), ABI.to_string())];
    match protocol::decode(request).and_then(|r| answer::<M>(&r)) {
        Ok(r) => records.extend(r),
        Err(e) => records.push(("error".into(), e)),
    }
    protocol::encode(&records)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::systems::CompoundPendulum;

    /// A Lagrangian's page shows T and V typeset from its traced code: CompoundPendulum's
    /// T = ½ I_O θ̇² and V = −m g l cos θ, with the dot a glyph of its own.
    #[test]
    fn a_lagrangians_page_typesets_t_and_v_from_its_code() {
        let request = protocol::encode(&[("request", "package")]);
        let records =
            protocol::parse_response(&respond_lagrangian::<CompoundPendulum>(&request)).unwrap();
        let page = protocol::value(&records, "documentation").unwrap();
        let start = page.find("id=\"traced\"").expect("the traced section");
        let section = &page[start..start + page[start..].find("</ul>").unwrap()];
        println!("{section}");
        assert_eq!(section.matches("<math>").count(), 2, "{section}");
        assert!(
            section.contains("<mover><mi>θ</mi><mo>˙</mo></mover>"),
            "{section}"
        );
        assert!(section.contains("<mi>cos</mi>"), "{section}");
        assert!(
            section.contains("<mfrac><mn>1</mn><mn>2</mn></mfrac>"),
            "{section}"
        );
        // The plain `respond` (no Lagrangian bound) has no such section.
        let plain = protocol::parse_response(&respond::<CompoundPendulum>(&request)).unwrap();
        assert!(!protocol::value(&plain, "documentation")
            .unwrap()
            .contains("id=\"traced\""));
    }

    #[test]
    fn a_linearize_request_round_trips() {
        let req = LinearizeRequest {
            scenes: vec!["large".into()],
            sets: vec![("m".into(), 0.1 + 0.2)],
            ats: vec![("theta".into(), -1e-300)],
            trim: Some(Trim::Inputs),
            states: States::Only(vec!["theta".into(), "theta_dot".into()]),
            format: "py".into(),
        };
        let records = protocol::decode(&req.encode()).unwrap();
        assert_eq!(LinearizeRequest::decode(&records).unwrap(), req);
    }

    #[test]
    fn the_package_answer_is_what_the_catalogue_generates() {
        let request = protocol::encode(&[("request", "package")]);
        let records = protocol::parse_response(&respond::<CompoundPendulum>(&request)).unwrap();
        let get = |k| protocol::value(&records, k).unwrap();
        assert_eq!(get("model_identifier"), "CompoundPendulum");
        assert_eq!(
            get("model_description"),
            crate::xml::model_description::<CompoundPendulum>()
        );
        assert!(get("resource:linearization.json").contains("\"A\""));
        let csv = get("file:extra/org.fmi-standard.fmi-ls-ref/reference.csv");
        assert!(csv.starts_with("time,theta,"), "{}", &csv[..40]);
        assert!(
            get("file:extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml")
                .contains("role=\"result\"")
        );
        let bad = respond::<CompoundPendulum>(&protocol::encode(&[("request", "fly")]));
        assert!(protocol::parse_response(&bad)
            .unwrap_err()
            .contains("unknown describe request"));
    }
}
