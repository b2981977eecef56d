//! modelDescription.xml, generated from a [`System`] declaration with quick-xml.
//!
//! Deterministic: the same model gives the same bytes, and the GUID is a UUID v5 of
//! the document's content (with the GUID left out), so any change to the interface
//! changes the GUID and an FMU binary rejects an XML it was not built with.

mod fmi3;
mod structure;
mod units;

pub use fmi3::model_description3;

pub use structure::{dependencies, Dependencies};

use crate::integrators::Method;
use crate::model::{Item, Layout, Probe, Slot, System, Var, VarKind, VarType};
use quick_xml::events::{BytesDecl, BytesEnd, BytesStart, Event};
use quick_xml::Writer;
use std::io::Cursor;

/// Log categories declared in the XML and accepted by fmi2SetDebugLogging.
pub const LOG_CATEGORIES: &[(&str, &str)] = &[
    ("logStatusWarning", "Calls that returned fmi2Warning"),
    (
        "logStatusDiscard",
        "Calls that returned fmi2Discard (a step that could not be completed)",
    ),
    (
        "logStatusError",
        "Calls that returned fmi2Error (bad arguments, illegal call sequence)",
    ),
    ("logStatusFatal", "Calls that returned fmi2Fatal"),
    ("logAll", "Every FMI call, for debugging"),
];

/// Tool name written to `generationTool`.
pub const GENERATION_TOOL: &str = concat!("mbfmu ", env!("CARGO_PKG_VERSION"));

const GUID_PLACEHOLDER: &str = "{00000000-0000-0000-0000-000000000000}";

/// The model description of `M`, with its content GUID.
pub fn model_description<M: System>() -> String {
    let body = render::<M>(GUID_PLACEHOLDER);
    let guid = guid_of(&M::token_text(body.clone()));
    body.replace(GUID_PLACEHOLDER, &guid)
}

/// The content GUID of `M` (what `fmi2Instantiate` checks): of its modelDescription and
/// or of what defines it instead ([`System::token_text`]).
pub fn guid<M: System>() -> String {
    guid_of(&M::token_text(render::<M>(GUID_PLACEHOLDER)))
}

fn guid_of(body: &str) -> String {
    // A fixed namespace for this tool: UUID v5 of the tool's name in the URL namespace.
    let ns = uuid::Uuid::new_v5(&uuid::Uuid::NAMESPACE_URL, b"mbfmu");
    format!("{{{}}}", uuid::Uuid::new_v5(&ns, body.as_bytes()))
}

/// Whether `name` can be an FMI modelIdentifier: a C identifier (it names the binary and
/// prefixes nothing, but importers build file names and C code from it).
pub fn is_model_identifier(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Shortest text that parses back to the same f64 (xs:double syntax).
pub fn fmt_real(v: f64) -> String {
    let plain = format!("{v}");
    let sci = format!("{v:e}");
    if sci.len() < plain.len() {
        sci
    } else {
        plain
    }
}

type W = Writer<Cursor<Vec<u8>>>;

fn empty(w: &mut W, tag: &str, attrs: &[(&str, String)]) {
    let mut e = BytesStart::new(tag);
    for (k, v) in attrs {
        e.push_attribute((*k, v.as_str()));
    }
    w.write_event(Event::Empty(e)).expect("write to memory");
}

fn open(w: &mut W, tag: &str, attrs: &[(&str, String)]) {
    let mut e = BytesStart::new(tag);
    for (k, v) in attrs {
        e.push_attribute((*k, v.as_str()));
    }
    w.write_event(Event::Start(e)).expect("write to memory");
}

fn close(w: &mut W, tag: &str) {
    w.write_event(Event::End(BytesEnd::new(tag)))
        .expect("write to memory");
}

/// Which standard a modelDescription is written for.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Version {
    Fmi2,
    Fmi3,
}

/// The FMU-state and derivative capabilities every interface of every FMU declares, in
/// each version's words (FMI 2.0's "FMUstate" and "DirectionalDerivative", FMI 3.0's
/// "FMUState", "DirectionalDerivatives" and its adjoint derivatives).
pub(crate) fn state_and_derivatives(version: Version) -> Vec<(&'static str, String)> {
    let (get_set, serialize, directional) = match version {
        Version::Fmi2 => (
            "canGetAndSetFMUstate",
            "canSerializeFMUstate",
            "providesDirectionalDerivative",
        ),
        Version::Fmi3 => (
            "canGetAndSetFMUState",
            "canSerializeFMUState",
            "providesDirectionalDerivatives",
        ),
    };
    let mut capabilities = vec![
        (get_set, s(true)),
        (serialize, s(true)),
        (directional, s(true)),
    ];
    if version == Version::Fmi3 {
        capabilities.push(("providesAdjointDerivatives", s(true)));
    }
    capabilities
}

fn s(v: impl ToString) -> String {
    v.to_string()
}

/// How a version words the descriptions, which are written for FMI 2.0 (FMI 3.0 renames the
/// functions they name: [`fmi3::fmi3_words`]).
type Words = fn(&str) -> String;

fn fmi2_words(text: &str) -> String {
    text.to_string()
}

/// The `Item`s of the `Solver` enumeration, one per integration method.
fn solver_items(w: &mut W, words: Words) {
    for m in Method::ALL {
        empty(
            w,
            "Item",
            &[
                ("name", s(m.name())),
                ("value", s(m.code())),
                ("description", words(m.description())),
            ],
        );
    }
}

/// The enumeration types of a system's parameters, in value-reference order: (type name,
/// items). Declared after `Solver`, one per enumeration parameter
/// ([`Var::type_name`]).
fn parameter_enumerations(layout: &Layout) -> Vec<(String, &'static [Item])> {
    layout
        .vars
        .iter()
        .filter_map(|(_, var)| match var.ty {
            VarType::Enumeration(items) => Some((var.type_name().expect("an enumeration"), items)),
            _ => None,
        })
        .collect()
}

/// The `Item`s of an enumeration parameter: values 0, 1, 2, … in order (a description only
/// when the item has one).
fn parameter_items(w: &mut W, items: &[Item], words: Words) {
    for (code, (name, description)) in items.iter().enumerate() {
        let mut attrs = vec![("name", s(name)), ("value", s(code))];
        if !description.is_empty() {
            attrs.push(("description", words(description)));
        }
        empty(w, "Item", &attrs);
    }
}

fn log_categories(w: &mut W, categories: &[(&str, &str)]) {
    open(w, "LogCategories", &[]);
    for (name, description) in categories {
        empty(
            w,
            "Category",
            &[("name", s(name)), ("description", s(description))],
        );
    }
    close(w, "LogCategories");
}

fn default_experiment<M: System>(w: &mut W) {
    let (stop, tol, step) = M::default_experiment();
    empty(
        w,
        "DefaultExperiment",
        &[
            ("startTime", s("0")),
            ("stopTime", fmt_real(stop)),
            ("tolerance", fmt_real(tol)),
            ("stepSize", fmt_real(step)),
        ],
    );
}

/// What every variable's element starts with, in both versions: name, value reference,
/// description, causality, variability, initial.
fn variable_head(vr: usize, slot: Slot, var: &Var, words: Words) -> Vec<(&'static str, String)> {
    let mut attrs = vec![
        ("name", s(&var.name)),
        ("valueReference", s(vr)),
        ("description", words(&var.description)),
    ];
    let (causality, variability, mut initial) = fmi_attributes(slot);
    if var.dependent {
        // Computed from the constraints; the start value is the guess that picks the root.
        initial = Some("approx");
    }
    attrs.push(("causality", s(causality)));
    attrs.push(("variability", s(variability)));
    if let Some(initial) = initial {
        attrs.push(("initial", s(initial)));
    }
    attrs
}

/// Whether a variable is an FMI 2.0 Integer (FMI 3.0: Int32): `solver_max_steps`,
/// `me_projection`, or a parameter declared [`Var::integer`].
fn is_integer(slot: Slot, var: &Var) -> bool {
    matches!(slot.kind, VarKind::SolverMaxSteps | VarKind::MeProjection)
        || var.ty == VarType::Integer
}

/// An Integer variable's (FMI 3.0: Int32) min, max and start.
fn integer_attrs(var: &Var) -> Vec<(&'static str, String)> {
    let mut attrs = Vec::new();
    for (name, bound) in [("min", var.min), ("max", var.max)] {
        if let Some(bound) = bound {
            attrs.push((name, s(bound as i32)));
        }
    }
    attrs.push(("start", s(var.start as i32)));
    attrs
}

/// A Real variable's (FMI 3.0: Float64) attributes. `derivative`: how this version names
/// the state a derivative is of (FMI 2.0 by index, vr + 1; FMI 3.0 by value reference).
fn real_attrs(
    layout: &Layout,
    probe: &Probe,
    slot: Slot,
    var: &Var,
    derivative: fn(u32) -> u32,
) -> Vec<(&'static str, String)> {
    let mut real = Vec::new();
    if slot.kind == VarKind::Derivative {
        real.push((
            "derivative",
            s(derivative(layout.vr_of_slot(VarKind::State, slot.index))),
        ));
    }
    if let Some(unit) = &var.unit {
        real.push(("unit", s(unit)));
        if let Some(display) = units::display_unit(unit) {
            real.push(("displayUnit", s(display)));
        }
    }
    if let Some(min) = var.min {
        real.push(("min", fmt_real(min)));
    }
    if let Some(max) = var.max {
        real.push(("max", fmt_real(max)));
    }
    if let Some(nominal) = var.nominal {
        real.push(("nominal", fmt_real(nominal)));
    }
    if has_start(slot.kind) {
        real.push(("start", fmt_real(var.start)));
    }
    // A state the FMU changes at events (projection, on_event): Model Exchange's importer
    // must re-read it after the event.
    if slot.kind == VarKind::State && probe.reinit[slot.index] {
        real.push(("reinit", s(true)));
    }
    real
}

fn render<M: System>(guid: &str) -> String {
    let layout = Layout::of::<M>();
    let deps = dependencies::<M>(&layout);
    let probe = Probe::of::<M>(&layout);
    let mut w = Writer::new_with_indent(Cursor::new(Vec::new()), b' ', 2);
    w.write_event(Event::Decl(BytesDecl::new("1.0", Some("UTF-8"), None)))
        .expect("write to memory");

    open(
        &mut w,
        "fmiModelDescription",
        &[
            ("fmiVersion", s("2.0")),
            ("modelName", s(M::name())),
            ("guid", s(guid)),
            ("description", s(M::DESCRIPTION)),
            ("generationTool", s(GENERATION_TOOL)),
            ("numberOfEventIndicators", s(probe.event_indicators)),
        ],
    );
    // Model Exchange first (the schema's order). A constrained system needs
    // fmi2CompletedIntegratorStep: it asks for the step events that project.
    empty(
        &mut w,
        "ModelExchange",
        &[
            ("modelIdentifier", s(M::name())),
            ("needsExecutionTool", s(false)),
            ("completedIntegratorStepNotNeeded", s(!probe.projects)),
            ("canBeInstantiatedOnlyOncePerProcess", s(false)),
            ("canNotUseMemoryManagementFunctions", s(true)),
        ]
        .into_iter()
        .chain(state_and_derivatives(Version::Fmi2))
        .collect::<Vec<_>>(),
    );
    empty(
        &mut w,
        "CoSimulation",
        &[
            ("modelIdentifier", s(M::name())),
            ("needsExecutionTool", s(false)),
            ("canHandleVariableCommunicationStepSize", s(true)),
            ("canInterpolateInputs", s(true)),
            (
                "maxOutputDerivativeOrder",
                s(crate::model::jacobian::output_derivative_order::<M>()),
            ),
            ("canRunAsynchronuously", s(false)),
            ("canBeInstantiatedOnlyOncePerProcess", s(false)),
            ("canNotUseMemoryManagementFunctions", s(true)),
        ]
        .into_iter()
        .chain(state_and_derivatives(Version::Fmi2))
        .collect::<Vec<_>>(),
    );

    units::write_unit_definitions(&mut w, &layout);

    open(&mut w, "TypeDefinitions", &[]);
    open(&mut w, "SimpleType", &[("name", s("Solver"))]);
    open(&mut w, "Enumeration", &[]);
    solver_items(&mut w, fmi2_words);
    close(&mut w, "Enumeration");
    close(&mut w, "SimpleType");
    for (name, items) in parameter_enumerations(&layout) {
        open(&mut w, "SimpleType", &[("name", name)]);
        open(&mut w, "Enumeration", &[]);
        parameter_items(&mut w, items, fmi2_words);
        close(&mut w, "Enumeration");
        close(&mut w, "SimpleType");
    }
    close(&mut w, "TypeDefinitions");

    log_categories(&mut w, LOG_CATEGORIES);
    default_experiment::<M>(&mut w);

    open(&mut w, "ModelVariables", &[]);
    for (vr, (slot, var)) in layout.vars.iter().enumerate() {
        open(
            &mut w,
            "ScalarVariable",
            &variable_head(vr, *slot, var, fmi2_words),
        );
        if slot.kind == VarKind::SolverMethod {
            empty(
                &mut w,
                "Enumeration",
                &[
                    ("declaredType", s("Solver")),
                    ("start", s(var.start as i32)),
                ],
            );
        } else if let Some(type_name) = var.type_name() {
            empty(
                &mut w,
                "Enumeration",
                &[("declaredType", type_name), ("start", s(var.start as i32))],
            );
        } else if is_integer(*slot, var) {
            empty(&mut w, "Integer", &integer_attrs(var));
        } else {
            let real = real_attrs(&layout, &probe, *slot, var, |vr| vr + 1);
            empty(&mut w, "Real", &real);
        }
        close(&mut w, "ScalarVariable");
    }
    close(&mut w, "ModelVariables");

    open(&mut w, "ModelStructure", &[]);
    for (tag, list) in [
        ("Outputs", &deps.outputs),
        ("Derivatives", &deps.derivatives),
        ("InitialUnknowns", &deps.initial_unknowns),
    ] {
        open(&mut w, tag, &[]);
        for (index, on) in list {
            let on: Vec<String> = on.iter().map(|i| i.to_string()).collect();
            empty(
                &mut w,
                "Unknown",
                &[("index", s(index)), ("dependencies", on.join(" "))],
            );
        }
        close(&mut w, tag);
    }
    close(&mut w, "ModelStructure");
    close(&mut w, "fmiModelDescription");

    let mut text = String::from_utf8(w.into_inner().into_inner()).expect("utf-8");
    text.push('\n');
    text
}

/// Causality, variability and initial of each kind of variable: the legal FMI 2.0
/// combinations (standard, section 2.2.7).
pub fn fmi_attributes(slot: Slot) -> (&'static str, &'static str, Option<&'static str>) {
    match slot.kind {
        VarKind::Parameter
        | VarKind::SolverMethod
        | VarKind::SolverStep
        | VarKind::SolverMaxSteps
        | VarKind::MeProjection => ("parameter", "fixed", Some("exact")),
        // States are outputs whose start value is the initial state.
        VarKind::State => ("output", "continuous", Some("exact")),
        VarKind::Derivative => ("local", "continuous", Some("calculated")),
        VarKind::Input => ("input", "continuous", None),
        VarKind::Output => ("output", "continuous", Some("calculated")),
    }
}

/// Only variables with initial = exact/approx, and inputs, may carry a start value.
fn has_start(kind: VarKind) -> bool {
    !matches!(kind, VarKind::Derivative | VarKind::Output)
}
