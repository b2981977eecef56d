//! The FMI 3.0 modelDescription.xml of a [`System`]: the same variables, value references,
//! units and dependencies as the FMI 2.0 one ([`super::model_description`]), in FMI 3.0's
//! form, for the same binary (its fmi3 symbols, `fmi::fmi3`).
//!
//! What FMI 3.0 adds: `time`, the independent variable, at the first free value reference,
//! and the event indicator (a model with one) at the next, referenced by `<EventIndicator>`
//! ([`Layout::fmi3_extra_vrs`]). The instantiationToken is the FMI 2.0 GUID: one binary,
//! one model.
//! Enumerations (`solver`, a system's enumeration parameters: each its `EnumerationType`,
//! named as in FMI 2.0) are FMI 3.0's `<Enumeration>` (read with fmi3GetInt64).

use super::{close, default_experiment, empty, integer_attrs, log_categories, open, s, units, W};
use super::{dependencies, real_attrs, solver_items, variable_head, GENERATION_TOOL};
use super::{is_integer, parameter_enumerations, parameter_items};
use super::{state_and_derivatives, Version};
use crate::model::{Layout, Probe, System, VarKind};
use quick_xml::events::{BytesDecl, Event};
use quick_xml::Writer;
use std::io::Cursor;

/// Log categories of the FMI 3.0 description (the names fmi3SetDebugLogging accepts are
/// FMI 2.0's: [`super::LOG_CATEGORIES`]).
const CATEGORIES3: &[(&str, &str)] = &[
    ("logStatusWarning", "Calls that returned fmi3Warning"),
    (
        "logStatusDiscard",
        "Calls that returned fmi3Discard (a step that could not be completed)",
    ),
    (
        "logStatusError",
        "Calls that returned fmi3Error (bad arguments, illegal call sequence)",
    ),
    ("logStatusFatal", "Calls that returned fmi3Fatal"),
    ("logAll", "Every FMI call, for debugging"),
];

/// A description written for FMI 2.0 in FMI 3.0's words: the functions it names are their
/// FMI 3.0 counterparts (fmi2SetupExperiment's tolerance is fmi3EnterInitializationMode's,
/// fmi2NewDiscreteStates is fmi3UpdateDiscreteStates, …; the statuses and the other
/// functions keep their names with a 3).
pub(super) fn fmi3_words(text: &str) -> String {
    const RENAMED: [(&str, &str); 5] = [
        ("fmi2SetupExperiment", "fmi3EnterInitializationMode"),
        ("fmi2NewDiscreteStates", "fmi3UpdateDiscreteStates"),
        ("fmi2GetDerivatives", "fmi3GetContinuousStateDerivatives"),
        ("fmi2GetReal", "fmi3GetFloat64"),
        ("fmi2SetReal", "fmi3SetFloat64"),
    ];
    let mut t = text.to_string();
    for (old, new) in RENAMED {
        t = t.replace(old, new);
    }
    t.replace("fmi2", "fmi3")
}

/// The FMI 3.0 model description of `M`.
pub fn model_description3<M: System>() -> String {
    let layout = Layout::of::<M>();
    let deps = dependencies::<M>(&layout);
    let probe = Probe::of::<M>(&layout);
    let guid = super::guid::<M>();
    let mut w = Writer::new_with_indent(Cursor::new(Vec::new()), b' ', 2);
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))
        .expect("write to memory");
    assert_eq!(
        super::LOG_CATEGORIES.len(),
        CATEGORIES3.len(),
        "the same categories"
    );

    open(
        &mut w,
        "fmiModelDescription",
        &[
            ("fmiVersion", s("3.0")),
            ("modelName", s(M::name())),
            ("instantiationToken", guid),
            ("description", fmi3_words(M::DESCRIPTION)),
            ("generationTool", s(GENERATION_TOOL)),
        ],
    );
    let common = |w: &mut W, tag: &str, extra: Vec<(&str, String)>| {
        let mut attrs = vec![
            ("modelIdentifier", s(M::name())),
            ("needsExecutionTool", s(false)),
            ("canBeInstantiatedOnlyOncePerProcess", s(false)),
        ];
        attrs.extend(state_and_derivatives(Version::Fmi3));
        attrs.extend(extra);
        empty(w, tag, &attrs);
    };
    // A constrained system needs fmi3CompletedIntegratorStep: it asks for the step events
    // that project.
    common(
        &mut w,
        "ModelExchange",
        vec![("needsCompletedIntegratorStep", s(probe.projects))],
    );
    common(
        &mut w,
        "CoSimulation",
        vec![
            ("canHandleVariableCommunicationStepSize", s(true)),
            (
                "maxOutputDerivativeOrder",
                s(crate::model::jacobian::output_derivative_order::<M>()),
            ),
            ("providesIntermediateUpdate", s(true)),
            ("mightReturnEarlyFromDoStep", s(probe.event_indicators > 0)),
            ("canReturnEarlyAfterIntermediateUpdate", s(true)),
            ("hasEventMode", s(true)),
        ],
    );

    units::write_unit_definitions(&mut w, &layout);

    open(&mut w, "TypeDefinitions", &[]);
    open(&mut w, "EnumerationType", &[("name", s("Solver"))]);
    solver_items(&mut w, fmi3_words);
    close(&mut w, "EnumerationType");
    for (name, items) in parameter_enumerations(&layout) {
        open(&mut w, "EnumerationType", &[("name", name)]);
        parameter_items(&mut w, items, fmi3_words);
        close(&mut w, "EnumerationType");
    }
    close(&mut w, "TypeDefinitions");

    log_categories(&mut w, CATEGORIES3);
    default_experiment::<M>(&mut w);

    let (time_vr, indicator_vr) = layout.fmi3_extra_vrs(probe.event_indicators);
    open(&mut w, "ModelVariables", &[]);
    empty(
        &mut w,
        "Float64",
        &[
            ("name", s("time")),
            ("valueReference", s(time_vr)),
            ("description", s("Simulation time")),
            ("causality", s("independent")),
            ("variability", s("continuous")),
            ("unit", s("s")),
        ],
    );
    for (vr, (slot, var)) in layout.vars.iter().enumerate() {
        let mut attrs = variable_head(vr, *slot, var, fmi3_words);
        if slot.kind == VarKind::SolverMethod {
            attrs.push(("declaredType", s("Solver")));
            attrs.push(("start", s(var.start as i32)));
            empty(&mut w, "Enumeration", &attrs);
        } else if let Some(type_name) = var.type_name() {
            attrs.push(("declaredType", type_name));
            attrs.push(("start", s(var.start as i32)));
            empty(&mut w, "Enumeration", &attrs);
        } else if is_integer(*slot, var) {
            attrs.extend(integer_attrs(var));
            empty(&mut w, "Int32", &attrs);
        } else {
            attrs.extend(real_attrs(&layout, &probe, *slot, var, |vr| vr));
            empty(&mut w, "Float64", &attrs);
        }
    }
    if let Some(vr) = indicator_vr {
        empty(
            &mut w,
            "Float64",
            &[
                ("name", s("event_indicator")),
                ("valueReference", s(vr)),
                (
                    "description",
                    s("The model's event indicator: an event where it changes sign"),
                ),
                ("causality", s("local")),
                ("variability", s("continuous")),
                ("initial", s("calculated")),
            ],
        );
    }
    close(&mut w, "ModelVariables");

    // FMI 2.0's dependency lists name variables by index (value reference + 1); FMI 3.0's
    // by value reference.
    let vrs = |on: &[usize]| -> String {
        on.iter()
            .map(|i| (i - 1).to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    open(&mut w, "ModelStructure", &[]);
    for (tag, list) in [
        ("Output", &deps.outputs),
        ("ContinuousStateDerivative", &deps.derivatives),
        ("InitialUnknown", &deps.initial_unknowns),
    ] {
        for (index, on) in list {
            empty(
                &mut w,
                tag,
                &[("valueReference", s(index - 1)), ("dependencies", vrs(on))],
            );
        }
    }
    if let Some(vr) = indicator_vr {
        empty(&mut w, "EventIndicator", &[("valueReference", s(vr))]);
    }
    close(&mut w, "ModelStructure");
    close(&mut w, "fmiModelDescription");

    let mut text = String::from_utf8(w.into_inner().into_inner()).expect("utf-8");
    text.push('\n');
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The FMI 3.0 description speaks of FMI 3.0's functions and statuses only.
    #[test]
    fn the_fmi3_description_names_no_fmi2_function() {
        for xml in [
            model_description3::<crate::systems::MassSpringDamper>(),
            model_description3::<crate::systems::SphereSlide>(),
            model_description3::<crate::systems::AndrewsSqueezer>(),
        ] {
            assert!(xml.contains("fmi3EnterInitializationMode"), "{xml}");
            assert!(!xml.contains("fmi2"), "{xml}");
        }
        assert_eq!(
            fmi3_words("fmi2SetupExperiment, then fmi2DoStep answers fmi2Discard"),
            "fmi3EnterInitializationMode, then fmi3DoStep answers fmi3Discard"
        );
    }
}
