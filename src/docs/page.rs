//! `documentation/index.html` of an FMU, offline and without script: what the system is (a
//! mechanism's picture too, [`Pictures`]), its equations typeset in MathML
//! ([`mathml`](super::mathml)), its variables, a plot of every scene drawn at package time
//! ([`svg`](super::svg)) with its invariants (and the mechanism at instants of the run),
//! the linearisation
//! at the default operating point read as natural frequencies and damping ratios, every
//! solver and what the FMU does with bad input and failed steps, and the reference result.

use super::mathml::line_html;
use super::reference::{Reference, LS_REF_DIR, REFERENCE_CSV};
use super::run::{simulate, RunSettings, Trajectory};
use super::svg::{chart, Series};
use super::{rough, written};
use crate::integrators::Method;
use crate::linearize::{eigenvalues, Linearization};
use crate::model::{Layout, Scene, System, VarKind};
use crate::xml::fmi_attributes;
use nalgebra::DMatrix;

fn escape(s: &str) -> String {
    quick_xml::escape::escape(s).into_owned()
}

/// Points per scene plot: smooth at 720 px without bloating the FMU.
const PLOT_POINTS: f64 = 400.0;
/// At most this many states in one plot (the rest are in the reference CSV).
const PLOT_SERIES: usize = 8;
/// An output whose range over a scene is below this fraction of its scale is an invariant
/// of that scene (an energy, |H|, a constraint residual) and gets its own drift plot.
const INVARIANT_SPREAD: f64 = 1e-6;

/// When to choose each method (the modelDescription's `solver` enumeration says what it is).
fn when(m: Method) -> &'static str {
    match m {
        Method::Dopri5 => "The usual default: accuracy by tolerance at moderate cost; the first choice for smooth, non-stiff motion.",
        Method::Dop853 => "Tight tolerances (1e-9 and below): fewer, costlier steps than DOPRI5 for the same accuracy.",
        Method::Radau5 => "Stiff systems (a stiff spring, a fast damper beside slow motion), where explicit methods need tiny steps.",
        Method::Rk4 => "A fixed, predictable cost per doStep (real time); accuracy set by solver_step.",
        Method::ExplicitEuler => "Teaching and baselines only: first order, and its energy grows.",
        Method::SymplecticEuler => "Long conservative runs at low cost: energy bounded (first order); second-order systems only.",
        Method::Verlet => "Long conservative runs: second order, symplectic, energy bounded; second-order systems only.",
        Method::ImplicitMidpoint => "Quadratic invariants (|H| of a free rigid body) kept exactly; fixed step.",
        Method::Gauss4 => "Long conservative runs at higher accuracy: symplectic, order 4; fixed step.",
        Method::Gauss6 => "Long conservative runs at high accuracy: symplectic, order 6; fixed step.",
        Method::ExactLinear => "Linear time-invariant systems only: exact for inputs held over a step, at any step.",
        Method::Rattle => "Lagrangian systems with holonomic constraints: symplectic, constraints kept to rounding without projection.",
    }
}

fn table_row(cells: &[String]) -> String {
    let mut s = String::from("<tr>");
    for c in cells {
        s.push_str(&format!("<td>{c}</td>"));
    }
    s.push_str("</tr>\n");
    s
}

fn number(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-3 {
        format!("{v:.4e}")
    } else {
        format!("{v:.5}")
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_string()
    }
}

/// A matrix in MathML, rows and columns labelled in the caption instead.
fn matrix(m: &DMatrix<f64>) -> String {
    let mut s = String::from("<math display=\"block\"><mrow><mo>[</mo><mtable>");
    for i in 0..m.nrows() {
        s.push_str("<mtr>");
        for j in 0..m.ncols() {
            let v = m[(i, j)];
            let text = number(v).replace('-', "−");
            s.push_str(&format!("<mtd><mn>{text}</mn></mtd>"));
        }
        s.push_str("</mtr>");
    }
    s.push_str("</mtable><mo>]</mo></mrow></math>");
    s
}

/// Variable names as code: (x1, x2, …).
fn names_math(names: &[String]) -> String {
    let inner: Vec<String> = names
        .iter()
        .map(|n| format!("<code>{}</code>", escape(n)))
        .collect();
    inner.join(", ")
}

/// One scene's trajectory with the default method at the default tolerance.
fn scene_run<M: System>(scene: &Scene) -> Result<Trajectory, String> {
    let (_, tol, _) = M::default_experiment();
    simulate::<M>(
        &scene.start_values,
        RunSettings {
            method: super::reference::default_method::<M>(),
            tol,
            step: 0.0,
            comm_step: scene.stop_time / PLOT_POINTS,
            stop: scene.stop_time,
        },
    )
}

/// What a page draws of its system beside the plots: a mechanism's stick figures
/// ([`super::stick`]). Each answers its HTML and the files it refers to (`(path in the FMU,
/// content)`).
pub trait Pictures {
    /// The id of the section [`Pictures::reference`] writes, and its name in the page's
    /// navigation.
    fn anchor(&self) -> (&'static str, &'static str);
    /// The section after the description (the system in its reference configuration).
    fn reference(&self) -> (String, Vec<(String, String)>);
    /// A figure after a scene's plot, from that scene's run.
    fn scene(&self, scene: &Scene, run: &Trajectory) -> (String, Vec<(String, String)>);
}

/// The scene's section: plot of its states, the pictures' figure of the run where there
/// are pictures, and of its invariants' drift where it has any.
fn scene_section<M: System>(
    scene: &Scene,
    pictures: Option<&dyn Pictures>,
    files: &mut Vec<(String, String)>,
) -> String {
    let mut h = format!(
        "<h3 id=\"scene-{0}\">{0}</h3>\n<p>{1}. Stop time {2} s; start values: <code>{3}</code>.</p>\n",
        escape(scene.name),
        escape(scene.description.trim_end_matches('.')),
        scene.stop_time,
        escape(
            &scene
                .start_values
                .iter()
                .map(|(n, v)| format!("{n} = {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        )
    );
    let traj = match scene_run::<M>(scene) {
        Ok(t) => t,
        Err(e) => {
            return h + &format!(
                "<p>No plot: the run could not start ({}).</p>\n",
                escape(&e)
            );
        }
    };
    let states: Vec<usize> = (0..traj.names.len())
        .filter(|&j| traj.is_state[j])
        .take(PLOT_SERIES)
        .collect();
    let series: Vec<Series> = states
        .iter()
        .map(|&j| Series {
            label: if traj.units[j].is_empty() {
                traj.names[j].clone()
            } else {
                format!("{} ({})", traj.names[j], traj.units[j])
            },
            y: &traj.columns[j],
        })
        .collect();
    let file = format!("scene_{}.svg", scene.name);
    files.push((
        format!("documentation/{file}"),
        chart(
            &format!("{} — {}: states", M::name(), scene.name),
            "t (s)",
            &traj.t,
            &series,
        ),
    ));
    h.push_str(&format!(
        "<figure><img src=\"{file}\" width=\"720\" height=\"300\" alt=\"{} scene {}: the states against time\"><figcaption>The states{} with {} at the default tolerance, {} points.</figcaption></figure>\n",
        M::name(),
        escape(scene.name),
        if traj.names.iter().zip(&traj.is_state).filter(|(_, s)| **s).count() > PLOT_SERIES {
            format!(" (the first {PLOT_SERIES})")
        } else {
            String::new()
        },
        super::reference::default_method::<M>().name(),
        traj.t.len()
    ));
    if let Some(pictures) = pictures {
        let (figure, drawn) = pictures.scene(scene, &traj);
        h.push_str(&figure);
        files.extend(drawn);
    }
    if let Some(why) = &traj.failure {
        h.push_str(&format!(
            "<p>The run ends early: {} (doStep answers fmi2Discard there).</p>\n",
            escape(why)
        ));
    }
    // Invariants of this scene: outputs (not states) that stay put to a small fraction of
    // their scale.
    let invariants: Vec<usize> = (0..traj.names.len())
        .filter(|&j| !traj.is_state[j] && traj.t.len() > 1)
        .filter(|&j| traj.range(j) <= INVARIANT_SPREAD * traj.scale(j))
        .collect();
    if !invariants.is_empty() {
        let drift: Vec<Vec<f64>> = invariants
            .iter()
            .map(|&j| {
                let c = &traj.columns[j];
                c.iter().map(|v| v - c[0]).collect()
            })
            .collect();
        let series: Vec<Series> = invariants
            .iter()
            .zip(&drift)
            .map(|(&j, d)| Series {
                label: format!("{} − {}(0)", traj.names[j], traj.names[j]),
                y: d,
            })
            .collect();
        let file = format!("scene_{}_invariants.svg", scene.name);
        files.push((
            format!("documentation/{file}"),
            chart(
                &format!("{} — {}: invariants", M::name(), scene.name),
                "t (s)",
                &traj.t,
                &series,
            ),
        ));
        let spreads: Vec<String> = invariants
            .iter()
            .map(|&j| {
                format!(
                    "{} within {} of its scale",
                    escape(&traj.names[j]),
                    rough(traj.range(j) / traj.scale(j))
                )
            })
            .collect();
        h.push_str(&format!(
            "<figure><img src=\"{file}\" width=\"720\" height=\"300\" alt=\"{} scene {}: drift of its invariants\"><figcaption>Invariants of this scene (outputs that stay within {INVARIANT_SPREAD:e} of their scale): {}.</figcaption></figure>\n",
            M::name(),
            escape(scene.name),
            spreads.join(", ")
        ));
    }
    h
}

/// The linearisation's section; `own_point`: taken at the system's own operating point
/// ([`System::linearization_point`](crate::model::System::linearization_point)), not at
/// the start values.
fn linearisation_section(lin: &Linearization, own_point: bool) -> String {
    let mut h = String::from(
        "<h2 id=\"linearisation\">Linearisation at the default operating point</h2>\n",
    );
    let about = if own_point {
        let values: Vec<String> = (lin.state_names.iter().zip(lin.x0()))
            .chain(lin.input_names.iter().zip(lin.point.u.iter().copied()))
            .map(|(n, v)| format!("{} = {}", escape(n), number(v)))
            .collect();
        format!(
            "the system's operating point, a stable equilibrium ({}), not the start values, where it is not at rest",
            values.join(", ")
        )
    } else {
        "the start values".to_string()
    };
    h.push_str(&format!(
        "<p>ẋ = A x + B u about {about} (exact derivatives, {}; also in <code>resources/linearization.json</code> and <code>resources/linearized_model.py</code>, and from <code>mbfmu linearize</code>). States x = ({}); inputs u = ({}).{}{}</p>\n",
        escape(lin.method),
        names_math(&lin.state_names),
        names_math(&lin.input_names),
        if lin.eliminated.is_empty() {
            String::new()
        } else {
            format!(
                " The dependent states ({}) are eliminated through the constraints.",
                escape(&lin.eliminated.join(", "))
            )
        },
        if lin.residual > 1e-9 {
            format!(
                " Not an equilibrium: ‖f(x0, u0)‖∞ = {}, so the eigenvalues describe the motion only near the start.",
                number(lin.residual)
            )
        } else {
            String::new()
        }
    ));
    h.push_str(&format!("<p>A =</p>{}\n", matrix(&lin.a)));
    if lin.b.ncols() > 0 {
        h.push_str(&format!("<p>B =</p>{}\n", matrix(&lin.b)));
    }
    let eig = match eigenvalues(&lin.a) {
        Ok(eig) => eig,
        Err(why) => {
            h.push_str(&format!(
                "<p>The eigenvalues of A are not listed: {}.</p>\n",
                escape(&why)
            ));
            return h;
        }
    };
    let mut rows = String::new();
    let mut eigs: Vec<_> = eig.iter().collect();
    eigs.sort_by(|a, b| a.norm().total_cmp(&b.norm()).then(b.im.total_cmp(&a.im)));
    for l in eigs {
        // A complex pair is listed once (im > 0); its partner is the conjugate.
        if l.im < 0.0 {
            continue;
        }
        let wn = l.norm();
        let (pair, kind) = if l.im > 0.0 {
            let zeta = -l.re / wn;
            (
                format!("{} ± {}i", number(l.re), number(l.im)),
                format!(
                    "oscillation: ωn = {} rad/s ({} Hz), ζ = {}",
                    number(wn),
                    number(wn / (2.0 * std::f64::consts::PI)),
                    number(zeta)
                ),
            )
        } else if l.re == 0.0 || wn < 1e-12 {
            (number(l.re), "rigid-body mode (neutral)".to_string())
        } else if l.re < 0.0 {
            (
                number(l.re),
                format!("decay, time constant {} s", number(-1.0 / l.re)),
            )
        } else {
            (
                number(l.re),
                format!("unstable, growth time {} s", number(1.0 / l.re)),
            )
        };
        rows.push_str(&table_row(&[pair, kind]));
    }
    h.push_str(&format!(
        "<table>\n<tr><th>eigenvalue λ of A (1/s)</th><th>read as</th></tr>\n{rows}</table>\n"
    ));
    h
}

/// The page's section of T and V as the FMU computes them: each `Some` a `<math>` typeset
/// from the traced code, `None` one too long to read.
pub fn traced_section(energies: &[(&str, Option<String>)]) -> String {
    let mut h = String::from("<h3 id=\"traced\">T and V as the FMU computes them</h3>\n<p>Typeset from the traced code of <code>kinetic</code> and <code>potential</code> when the FMU was built (the equations of motion are generated from the same trace), so they cannot differ from what runs.</p>\n<ul class=\"eq\">\n");
    for (what, math) in energies {
        match math {
            Some(m) => h.push_str(&format!("<li>{m}</li>\n")),
            None => h.push_str(&format!(
                "<li>{what}: too long to typeset readably (see the lines above)</li>\n"
            )),
        }
    }
    h.push_str("</ul>\n");
    h
}

const BAD_INPUT: &str = "<h3>Bad input and failed steps</h3>\n<ul>\n<li>A value outside a variable's [min, max], or not finite, is refused: <code>fmi2SetReal</code> returns fmi2Error and logs the variable and the range; the instance keeps its previous value.</li>\n<li>A <code>solver</code> the system cannot use (a symplectic method without (q, q̇) states, ExactLinear on a nonlinear system, RATTLE without a Lagrangian) is refused at <code>fmi2ExitInitializationMode</code> with a message naming the reason.</li>\n<li>A doStep whose integration fails (step size underflow, Newton failure, more than <code>solver_max_steps</code> internal steps, a model that stops holding such as a bicycle that has fallen) returns fmi2Discard; the state is the last good one and <code>fmi2GetRealStatus(fmi2LastSuccessfulTime)</code> says where it is. The importer can retry with a shorter communication step, another solver or a larger <code>solver_max_steps</code>.</li>\n<li>Events (a particle leaving a surface) are located inside doStep to the integration's time resolution and never stepped over.</li>\n</ul>\n";

/// The page and the files it refers to (`(path in the FMU, content)`: the scene plots).
/// `traced`: the section of T and V typeset from the code (a Lagrangian's, see
/// [`traced_section`]), after the equation lines; `pictures`: drawings of the system (a
/// mechanism's), a section after the description and a figure in each scene.
pub fn page<M: System>(
    lin: Option<&Linearization>,
    reference: &Reference,
    traced: Option<&str>,
    pictures: Option<&dyn Pictures>,
) -> (String, Vec<(String, String)>) {
    let layout = Layout::of::<M>();
    let mut files = Vec::new();
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    h.push_str(&format!("<title>{}</title>\n", escape(M::name())));
    // (`mover>mo`: a gap under each dot, so it never touches a tall letter's top, Ω's say.)
    h.push_str("<style>body{font-family:sans-serif;max-width:64em;margin:2em auto;padding:0 1em;line-height:1.45}table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:.2em .5em;text-align:left;vertical-align:top}code{background:#f4f4f4}ul.eq li{margin:.35em 0}math{font-size:1.1em}mover>mo{padding-bottom:.15em}figure{margin:1em 0}figcaption{font-size:.9em;color:#444}img{max-width:100%;height:auto}nav a{margin-right:1em}</style>\n");
    h.push_str("</head>\n<body>\n");
    h.push_str(&format!(
        "<h1>{}</h1>\n<p>{}</p>\n<nav>{}<a href=\"#equations\">Equations</a><a href=\"#variables\">Variables</a><a href=\"#scenes\">Scenes</a><a href=\"#linearisation\">Linearisation</a><a href=\"#solvers\">Solvers</a><a href=\"#reference\">Reference result</a></nav>\n",
        escape(M::name()),
        escape(M::DESCRIPTION),
        pictures.map_or(String::new(), |p| {
            let (id, name) = p.anchor();
            format!("<a href=\"#{id}\">{name}</a>")
        })
    ));
    if let Some(pictures) = pictures {
        let (section, drawn) = pictures.reference();
        h.push_str(&section);
        files.extend(drawn);
    }
    h.push_str(
        "<h2 id=\"equations\">Coordinates, conventions and equations</h2>\n<ul class=\"eq\">\n",
    );
    for line in M::equations() {
        h.push_str(&format!("<li>{}</li>\n", line_html(line)));
    }
    h.push_str("</ul>\n");
    if let Some(traced) = traced {
        h.push_str(traced);
    }

    h.push_str("<h2 id=\"variables\">Variables</h2>\n<p><em>Set</em>: a value the importer chooses (a parameter, an input, the start value of a state); <em>computed</em>: the FMU's result. A dependent state's start value is only a guess: initialisation solves the constraints for it.</p>\n<table>\n<tr><th>name</th><th>causality</th><th>set or computed</th><th>unit</th><th>start</th><th>range</th><th>description</th></tr>\n");
    for (slot, var) in &layout.vars {
        let (causality, _, initial) = fmi_attributes(*slot);
        let role = match slot.kind {
            VarKind::State if var.dependent => "computed (dependent state; start = guess)",
            VarKind::State => "set (start value), then computed",
            VarKind::Output | VarKind::Derivative => "computed",
            _ => "set",
        };
        let start = if initial == Some("calculated") {
            "—".to_string()
        } else {
            written(var.start)
        };
        // An enumeration's range is its items (code = name).
        let range = match (var.items_text(), var.min, var.max) {
            (Some(items), ..) => escape(&items),
            (None, None, None) => String::new(),
            (None, min, max) => format!(
                "[{}, {}]",
                min.map_or("−∞".into(), written),
                max.map_or("∞".into(), written)
            ),
        };
        h.push_str(&table_row(&[
            format!("<code>{}</code>", escape(&var.name)),
            causality.into(),
            role.into(),
            escape(var.unit.as_deref().unwrap_or("")),
            start,
            range,
            escape(&var.description),
        ]));
    }
    h.push_str("</table>\n");

    h.push_str("<h2 id=\"scenes\">Scenes</h2>\n<p>Each scene is a set of start values and a stop time (<code>mbfmu list --json</code>), simulated here when the FMU was built, through the FMU's own code.</p>\n");
    for scene in M::scenes() {
        h.push_str(&scene_section::<M>(&scene, pictures, &mut files));
    }

    match lin {
        Some(lin) => h.push_str(&linearisation_section(
            lin,
            !M::linearization_point().is_empty(),
        )),
        None => h.push_str("<h2 id=\"linearisation\">Linearisation</h2>\n<p>Not available at the start values (a derivative is singular there).</p>\n"),
    }

    h.push_str("<h2 id=\"solvers\">Solvers</h2>\n<p>The state is advanced inside <code>fmi2DoStep</code> by the method of the <code>solver</code> parameter; the adaptive ones with the tolerance of <code>fmi2SetupExperiment</code> (else the DefaultExperiment's), the others with the fixed step <code>solver_step</code>, in at most <code>solver_max_steps</code> internal steps. Every doStep ends exactly on the communication point. FMU state get/set and serialisation are supported.</p>\n<table>\n<tr><th>solver</th><th>method</th><th>step</th><th>what it is</th><th>when to choose it</th></tr>\n");
    for m in Method::ALL {
        h.push_str(&table_row(&[
            m.code().to_string(),
            m.name().into(),
            if m.is_adaptive() {
                "adaptive (tolerance)".into()
            } else {
                "fixed (solver_step)".into()
            },
            escape(m.description()),
            escape(when(m)),
        ]));
    }
    h.push_str("</table>\n");
    h.push_str(BAD_INPUT);

    h.push_str(&format!(
        "<h2 id=\"reference\">Reference result</h2>\n<p>{} The file is <a href=\"../{LS_REF_DIR}/{REFERENCE_CSV}\"><code>{LS_REF_DIR}/{REFERENCE_CSV}</code></a>, described in <a href=\"../{LS_REF_DIR}/fmi-ls-manifest.xml\"><code>fmi-ls-manifest.xml</code></a> (FMI-LS-REF): compare your importer's run of the default experiment with it.</p>\n",
        escape(&reference.description(M::name()))
    ));
    h.push_str("</body>\n</html>\n");
    (h, files)
}
