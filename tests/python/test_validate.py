"""modelDescription.xml and FMU archive structure (exact checks: no numeric tolerance,
except that start values are compared as parsed floats, exactly)."""

from __future__ import annotations

import uuid
import zipfile

from fmpy.validation import validate_fmu

import fmu_support as fs


PARAMS = {
    "MassSpringDamper": {"m": (1.0, "kg"), "k": (100.0, "N/m"), "c": (2.0, None), "F_amp": (0.0, "N"),
                         "F_omega": (10.0, "rad/s")},
    "TwoMassChain": {"m1": (1.0, "kg"), "m2": (1.0, "kg"), "k1": (100.0, "N/m"), "k2": (100.0, "N/m"),
                     "c2": (2.0, None)},
}
STATES = {
    "MassSpringDamper": {"x": (0.1, "m"), "v": (0.0, "m/s")},
    "TwoMassChain": {"x1": (0.1, "m"), "x2": (0.0, "m"), "v1": (0.0, "m/s"), "v2": (0.0, "m/s")},
}
LOG_CATEGORIES = {"logStatusWarning", "logStatusDiscard", "logStatusError", "logStatusFatal", "logAll"}


def test_validate_fmu_reports_no_problems(model):
    problems = validate_fmu(str(model.path))
    assert problems == [], "\n".join(problems)


def test_fmi2_cosimulation_and_model_exchange(model):
    md = model.md
    assert md.fmiVersion == "2.0"
    assert md.coSimulation is not None
    me = md.modelExchange
    assert me is not None, "the FMU declares ModelExchange beside CoSimulation"
    assert me.modelIdentifier == md.coSimulation.modelIdentifier == model.identifier
    assert me.providesDirectionalDerivative and me.canGetAndSetFMUstate
    assert me.canSerializeFMUstate
    assert md.modelName == model.name
    # GUID is a braced UUID string
    uuid.UUID(md.guid.strip("{}"))


def test_binaries_of_every_platform(model):
    """x86_64 Linux, x86_64 Windows and aarch64 Linux (test_platforms.py runs each)."""
    with zipfile.ZipFile(model.path) as zf:
        names = zf.namelist()
    binaries = [n for n in names if n.startswith("binaries/") and not n.endswith("/")]
    assert binaries == [f"binaries/linux64/{model.identifier}.so",
                        f"binaries/win64/{model.identifier}.dll",
                        f"binaries/aarch64-linux/{model.identifier}.so"], binaries
    assert "modelDescription.xml" in names
    assert not any("\\" in n for n in names)


def test_capabilities(model):
    cs = model.md.coSimulation
    assert cs.canGetAndSetFMUstate is True
    assert cs.canSerializeFMUstate is True
    assert cs.canHandleVariableCommunicationStepSize is True
    # Input derivatives (orders 1-2) are followed inside doStep; both models' f and outputs
    # do not read t at their defaults, so outputs have exact derivatives of orders 1-2.
    assert cs.canInterpolateInputs is True
    assert int(cs.maxOutputDerivativeOrder) == 2
    # The contract given for these tests says false; flip
    # fmu_support.CONTRACT_PROVIDES_DIRECTIONAL_DERIVATIVE if the contract changed.
    assert cs.providesDirectionalDerivative is fs.CONTRACT_PROVIDES_DIRECTIONAL_DERIVATIVE


def test_log_categories(model):
    assert {c.name for c in model.md.logCategories} == LOG_CATEGORIES


def test_default_experiment(model):
    de = model.md.defaultExperiment
    assert de is not None
    assert float(de.startTime) == 0.0
    assert float(de.stopTime) == 10.0
    assert float(de.tolerance) == 1e-8
    assert float(de.stepSize) == 0.01


def _var(model, name):
    assert name in model.vars, f"{model.name}: variable {name!r} missing; have {sorted(model.vars)}"
    return model.vars[name]


def test_parameters(model):
    for name, (start, unit) in PARAMS[model.name].items():
        v = _var(model, name)
        assert v.type == "Real", name
        assert v.causality == "parameter", name
        assert v.variability == "fixed", name
        assert v.initial in ("exact", None), name
        assert float(v.start) == start, name
        if unit is not None:
            assert (v.unit or (v.declaredType.unit if v.declaredType else None)) == unit, name


def test_solver_parameters(model):
    solver = _var(model, "solver")
    assert solver.type == "Enumeration"
    assert solver.causality == "parameter" and solver.variability == "fixed"
    # DOPRI5 (2), but RADAU5 (10) for the stiff flyball governor (its dampers).
    assert int(solver.start) == (10 if model.name == "FlyballGovernor" else 2)
    assert solver.declaredType is not None
    items = {int(i.value) for i in solver.declaredType.items}
    assert {1, 2} <= items, items

    step = _var(model, "solver_step")
    assert step.type == "Real"
    assert step.causality == "parameter" and step.variability == "fixed"
    assert float(step.start) == 1e-3
    assert (step.unit or (step.declaredType.unit if step.declaredType else None)) == "s"


def test_states_derivatives_inputs_outputs(model):
    for name, (start, unit) in STATES[model.name].items():
        v = _var(model, name)
        assert v.type == "Real"
        assert v.causality == "output", name
        assert v.variability == "continuous", name
        assert v.initial == "exact", name
        assert float(v.start) == start, name
        assert (v.unit or (v.declaredType.unit if v.declaredType else None)) == unit, name
        d = _var(model, f"der({name})")
        assert d.causality == "local", d.name
        assert d.derivative is v, f"{d.name} must be declared the derivative of {name}"
    f = _var(model, "F")
    assert f.causality == "input" and f.type == "Real"
    assert float(f.start) == 0.0
    e = _var(model, "E")
    assert e.causality == "output" and e.type == "Real"
    assert e.initial in ("calculated", None)


def test_model_structure(model):
    md = model.md
    states = list(STATES[model.name])
    outputs = {u.variable.name for u in md.outputs}
    assert outputs == set(states) | {"E"}
    derivs = [u.variable.name for u in md.derivatives]
    assert derivs == [f"der({s})" for s in states]
    # FMI 2.0 3.3.2: InitialUnknowns = outputs with initial approx/calculated, all state
    # derivatives, (states with initial approx/calculated: none here).
    assert md.initialUnknowns, "InitialUnknowns must be present"
    assert {u.variable.name for u in md.initialUnknowns} == {"E"} | {f"der({s})" for s in states}


def test_value_references_unique_per_type(model):
    seen = {}
    for v in model.md.modelVariables:
        t = "Integer" if v.type == "Enumeration" else v.type
        key = (t, v.valueReference)
        assert key not in seen, f"{v.name} and {seen[key]} share value reference {key}"
        seen[key] = v.name


def test_fmu_start_values_match_xml(model, instances):
    """After initialization with no start values set, GetReal/GetInteger return the XML starts."""
    inst = instances(model, f"{model.name}_defaults").initialize(None, tol=None)
    for v in model.md.modelVariables:
        if v.start is None or v.causality not in ("parameter", "input", "output"):
            continue
        if v.name == "E":
            continue
        got = inst.get(v.name)
        want = int(v.start) if v.type in ("Integer", "Enumeration") else float(v.start)
        assert got == want, f"{v.name}: FMU has {got}, XML start {want}"
