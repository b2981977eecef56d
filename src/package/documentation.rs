//! `documentation/index.html`: what the system is, its equations, its variables.

use crate::integrators::Method;
use crate::model::{Layout, System};
use crate::xml::fmi_attributes;

fn escape(s: &str) -> String {
    quick_xml::escape::escape(s).into_owned()
}

/// The documentation page of `M`.
pub fn index_html<M: System>() -> String {
    let layout = Layout::of::<M>();
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
    h.push_str(&format!("<title>{}</title>\n", escape(M::NAME)));
    h.push_str("<style>body{font-family:sans-serif;max-width:60em;margin:2em auto}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:.2em .5em;text-align:left}code{background:#f4f4f4}</style>\n");
    h.push_str("</head>\n<body>\n");
    h.push_str(&format!(
        "<h1>{}</h1>\n<p>{}</p>\n",
        escape(M::NAME),
        escape(M::DESCRIPTION)
    ));
    h.push_str("<h2>Equations</h2>\n<ul>\n");
    for line in M::EQUATIONS {
        h.push_str(&format!("<li><code>{}</code></li>\n", escape(line)));
    }
    h.push_str("</ul>\n<h2>Variables</h2>\n<table>\n<tr><th>name</th><th>causality</th><th>unit</th><th>start</th><th>description</th></tr>\n");
    for (slot, var) in &layout.vars {
        let (causality, _, initial) = fmi_attributes(*slot);
        let start = if initial == Some("calculated") {
            "calculated".to_string()
        } else {
            format!("{}", var.start)
        };
        h.push_str(&format!(
            "<tr><td><code>{}</code></td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
            escape(&var.name),
            causality,
            escape(var.unit.as_deref().unwrap_or("")),
            start,
            escape(&var.description)
        ));
    }
    h.push_str("</table>\n<h2>Scenes</h2>\n<table>\n<tr><th>scene</th><th>start values</th><th>stop time</th><th>description</th></tr>\n");
    for scene in M::scenes() {
        let sets: Vec<String> = scene
            .start_values
            .iter()
            .map(|(n, v)| format!("{n} = {v}"))
            .collect();
        h.push_str(&format!(
            "<tr><td>{}</td><td><code>{}</code></td><td>{} s</td><td>{}</td></tr>\n",
            escape(scene.name),
            escape(&sets.join(", ")),
            scene.stop_time,
            escape(scene.description)
        ));
    }
    h.push_str(&format!(
        "</table>\n<h2>Simulation</h2>\n<p>The state is advanced inside <code>fmi2DoStep</code> by the method chosen with the <code>solver</code> parameter ({}; the adaptive ones, {}, with the tolerance of <code>fmi2SetupExperiment</code>, else the DefaultExperiment's; the others with fixed step <code>solver_step</code>), in at most <code>solver_max_steps</code> internal steps. Every step ends exactly on the communication point. States are set through the start values of their outputs before initialisation. FMU state get/set and serialisation are supported.</p>\n",
        escape(&Method::codes()),
        Method::names_where_adaptive(true)
    ));
    h.push_str("</body>\n</html>\n");
    h
}
