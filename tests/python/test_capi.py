"""The FMI 2.0 C API driven through the raw ctypes function pointers fmpy loads.

Every rejected call must (1) return the documented status, (2) log exactly one line
through the logger callback (loggingOn = false!) with category logStatusError (or
logStatusDiscard for a Discard), and (3) have no effect: the instance keeps its values and,
after the next doStep, is bit-for-bit identical to a twin instance that never saw the call.
No numeric tolerances here: all comparisons are exact.
"""

from __future__ import annotations

import math
from ctypes import byref, c_char_p, c_double, c_int, c_uint

import pytest

import fmu_support as fs
from fmu_support import fmi2Discard, fmi2Error, fmi2OK

NAN = float("nan")
INF = float("inf")


def vrs(*v):
    return (c_uint * len(v))(*v)


def reals(*v):
    return (c_double * len(v))(*v)


def ints(*v):
    return (c_int * len(v))(*v)


def names(model):
    """Model-agnostic names: a state, a parameter (mass)."""
    if model.name == "MassSpringDamper":
        return dict(state="x", mass="m")
    return dict(state="x1", mass="m1")


def start_values(model):
    # a scene with a non-zero input, so the input is part of what must not change
    return fs.scene_values(model.name, "step")


def assert_one_failure_line(logs, mark, inst_name, status=fmi2Error):
    recs = logs.since(mark)
    mine = [r for r in recs if r.instance == inst_name]
    want_cat = {fmi2Error: "logStatusError", fmi2Discard: "logStatusDiscard",
                fs.fmi2Fatal: "logStatusFatal", fs.fmi2Warning: "logStatusWarning"}[status]
    assert len(recs) == 1 and len(mine) == 1, (
        f"expected exactly one log line from {inst_name!r}, got {recs!r}")
    r = mine[0]
    assert r.status == status, r
    assert r.category == want_cat, r
    assert r.message.strip() and "\n" not in r.message.strip(), r
    return r


# ---------------------------------------------------------------------------------------
# Rejected calls in step mode (after initialization), checked against a twin instance
# ---------------------------------------------------------------------------------------


def _cases_step_mode(model):
    n = names(model)
    vr = model.vr
    F, X, M, SOLVER, STEP = vr["F"], vr[n["state"]], vr[n["mass"]], vr["solver"], vr["solver_step"]
    c = {}
    # null pointers with nvr > 0
    c["SetReal null vr"] = lambda i: i.call("fmi2SetReal", None, 1, reals(1.0))
    c["SetReal null value"] = lambda i: i.call("fmi2SetReal", vrs(F), 1, None)
    c["GetReal null vr"] = lambda i: i.call("fmi2GetReal", None, 1, reals(0.0))
    c["GetReal null value"] = lambda i: i.call("fmi2GetReal", vrs(X), 1, None)
    c["SetInteger null vr"] = lambda i: i.call("fmi2SetInteger", None, 1, ints(1))
    c["GetInteger null value"] = lambda i: i.call("fmi2GetInteger", vrs(SOLVER), 1, None)
    # unknown value references
    c["GetReal vr 99999"] = lambda i: i.call("fmi2GetReal", vrs(99999), 1, reals(0.0))
    c["SetReal vr 99999"] = lambda i: i.call("fmi2SetReal", vrs(99999), 1, reals(1.0))
    c["SetReal F ok + vr 99999 (atomic)"] = lambda i: i.call("fmi2SetReal", vrs(F, 99999), 2, reals(5.0, 1.0))
    c["GetInteger vr 99999"] = lambda i: i.call("fmi2GetInteger", vrs(99999), 1, ints(0))
    c["SetInteger vr 99999"] = lambda i: i.call("fmi2SetInteger", vrs(99999), 1, ints(1))
    c["GetBoolean vr 99999"] = lambda i: i.call("fmi2GetBoolean", vrs(99999), 1, ints(0))
    c["GetString vr 99999"] = lambda i: i.call("fmi2GetString", vrs(99999), 1, (c_char_p * 1)())
    # non-finite values
    c["SetReal F NaN"] = lambda i: i.call("fmi2SetReal", vrs(F), 1, reals(NAN))
    c["SetReal F +Inf"] = lambda i: i.call("fmi2SetReal", vrs(F), 1, reals(INF))
    c["SetReal F -Inf"] = lambda i: i.call("fmi2SetReal", vrs(F), 1, reals(-INF))
    c["SetReal F=5 then NaN (atomic)"] = lambda i: i.call("fmi2SetReal", vrs(F, F), 2, reals(5.0, NAN))
    # wrong state: parameters / solver / states after initialization
    c["SetReal mass after init"] = lambda i: i.call("fmi2SetReal", vrs(M), 1, reals(2.0))
    c["SetReal solver_step after init"] = lambda i: i.call("fmi2SetReal", vrs(STEP), 1, reals(1e-2))
    c["SetInteger solver after init"] = lambda i: i.call("fmi2SetInteger", vrs(SOLVER), 1, ints(1))
    c["SetReal state after init"] = lambda i: i.call("fmi2SetReal", vrs(X), 1, reals(0.5))
    c["EnterInitializationMode after init"] = lambda i: i.call("fmi2EnterInitializationMode")
    c["ExitInitializationMode after init"] = lambda i: i.call("fmi2ExitInitializationMode")
    c["SetupExperiment after init"] = lambda i: i.call("fmi2SetupExperiment", 1, 1e-6, 0.0, 0, 0.0)
    # doStep arguments
    c["DoStep h=0"] = lambda i: i.call("fmi2DoStep", c_double(i.t), c_double(0.0), 1)
    c["DoStep h<0"] = lambda i: i.call("fmi2DoStep", c_double(i.t), c_double(-0.01), 1)
    c["DoStep h=-0.0"] = lambda i: i.call("fmi2DoStep", c_double(i.t), c_double(-0.0), 1)
    c["DoStep h=NaN"] = lambda i: i.call("fmi2DoStep", c_double(i.t), c_double(NAN), 1)
    c["DoStep h=+Inf"] = lambda i: i.call("fmi2DoStep", c_double(i.t), c_double(INF), 1)
    c["DoStep t=current+0.5"] = lambda i: i.call("fmi2DoStep", c_double(i.t + 0.5), c_double(0.01), 1)
    c["DoStep t=current-0.01"] = lambda i: i.call("fmi2DoStep", c_double(i.t - 0.01), c_double(0.01), 1)
    c["DoStep t=current+1e-6"] = lambda i: i.call("fmi2DoStep", c_double(i.t + 1e-6), c_double(0.01), 1)
    c["DoStep t=NaN"] = lambda i: i.call("fmi2DoStep", c_double(NAN), c_double(0.01), 1)
    # input and output derivatives: wrong variable, order out of range, non-finite value
    c["SetRealInputDerivatives of a state"] = lambda i: i.call("fmi2SetRealInputDerivatives", vrs(X), 1, ints(1), reals(1.0))
    c["SetRealInputDerivatives order 0"] = lambda i: i.call("fmi2SetRealInputDerivatives", vrs(F), 1, ints(0), reals(1.0))
    c["SetRealInputDerivatives order 3"] = lambda i: i.call("fmi2SetRealInputDerivatives", vrs(F), 1, ints(3), reals(1.0))
    c["SetRealInputDerivatives NaN"] = lambda i: i.call("fmi2SetRealInputDerivatives", vrs(F), 1, ints(1), reals(NAN))
    c["SetRealInputDerivatives unknown vr"] = lambda i: i.call("fmi2SetRealInputDerivatives", vrs(99999), 1, ints(1), reals(1.0))
    c["GetRealOutputDerivatives of an input"] = lambda i: i.call("fmi2GetRealOutputDerivatives", vrs(F), 1, ints(1), reals(0.0))
    c["GetRealOutputDerivatives of a parameter"] = lambda i: i.call("fmi2GetRealOutputDerivatives", vrs(M), 1, ints(1), reals(0.0))
    c["GetRealOutputDerivatives order 0"] = lambda i: i.call("fmi2GetRealOutputDerivatives", vrs(X), 1, ints(0), reals(0.0))
    c["GetRealOutputDerivatives order 3"] = lambda i: i.call("fmi2GetRealOutputDerivatives", vrs(X), 1, ints(3), reals(0.0))
    # status queries with null value pointers
    c["GetRealStatus null value"] = lambda i: i.call("fmi2GetRealStatus", fs.fmi2LastSuccessfulTime, None)
    c["GetStatus null value"] = lambda i: i.call("fmi2GetStatus", fs.fmi2DoStepStatus, None)
    c["GetBooleanStatus null value"] = lambda i: i.call("fmi2GetBooleanStatus", fs.fmi2Terminated, None)
    # logging
    c["SetDebugLogging unknown category"] = lambda i: i.call(
        "fmi2SetDebugLogging", 1, 1, (c_char_p * 1)(b"noSuchCategory"))
    return c


def _step_case_ids():
    class _Fake:
        name = "MassSpringDamper"
        vr = {k: 0 for k in ["F", "x", "m", "solver", "solver_step"]}
    return list(_cases_step_mode(_Fake))


STEP_CASE_NAMES = _step_case_ids()


def _twins(model, instances, tag):
    a = instances(model, f"{model.name}_{tag}_A")
    b = instances(model, f"{model.name}_{tag}_B")
    for inst in (a, b):
        inst.initialize(start_values(model), tol=1e-10)
        for _ in range(5):
            inst.step(0.01)
    return a, b


def _assert_twin_after_step(a, b):
    assert a.t == b.t
    sa, sb = a.real_status(), b.real_status()
    assert sa == sb == (fmi2OK, a.t)
    assert a.do_step(0.01) == fmi2OK, "instance unusable after a rejected call"
    assert b.do_step(0.01) == fmi2OK
    assert a.snapshot() == b.snapshot(), "the rejected call changed the instance"


@pytest.mark.parametrize("case", STEP_CASE_NAMES)
def test_rejected_call_in_step_mode(model, instances, logs, case):
    a, b = _twins(model, instances, "rej")
    call = _cases_step_mode(model)[case]
    before = a.snapshot()
    mark = logs.mark()
    status = call(a)
    assert status == fmi2Error, f"{case}: returned {fs.STATUS_NAMES.get(status, status)}"
    assert_one_failure_line(logs, mark, a.name)
    assert a.snapshot() == before, f"{case}: values changed by a rejected call"
    _assert_twin_after_step(a, b)


# ---------------------------------------------------------------------------------------
# Rejected calls before initialization / in initialization mode
# ---------------------------------------------------------------------------------------


def _pre_init_cases(model):
    n = names(model)
    X, M = model.vr[n["state"]], model.vr[n["mass"]]
    return {
        "DoStep before init": ("instantiated", lambda i: i.call("fmi2DoStep", c_double(0.0), c_double(0.01), 1)),
        "ExitInitializationMode before Enter": ("instantiated", lambda i: i.call("fmi2ExitInitializationMode")),
        "SetReal state NaN before init": ("instantiated", lambda i: i.call("fmi2SetReal", vrs(X), 1, reals(NAN))),
        "SetReal mass +Inf before init": ("instantiated", lambda i: i.call("fmi2SetReal", vrs(M), 1, reals(INF))),
        "SetReal vr 99999 before init": ("instantiated", lambda i: i.call("fmi2SetReal", vrs(99999), 1, reals(1.0))),
        "DoStep in initialization mode": ("init", lambda i: i.call("fmi2DoStep", c_double(0.0), c_double(0.01), 1)),
        "EnterInitializationMode twice": ("init", lambda i: i.call("fmi2EnterInitializationMode")),
        "SetupExperiment in initialization mode": ("init", lambda i: i.call("fmi2SetupExperiment", 0, 0.0, 0.0, 0, 0.0)),
        "SetReal state NaN in initialization mode": ("init", lambda i: i.call("fmi2SetReal", vrs(X), 1, reals(NAN))),
    }


PRE_INIT_CASES = list(_pre_init_cases(type("F", (), {"name": "MassSpringDamper",
                                                      "vr": {"x": 0, "m": 0}})))


@pytest.mark.parametrize("case", PRE_INIT_CASES)
def test_rejected_call_before_step_mode(model, instances, logs, case):
    phase, call = _pre_init_cases(model)[case]
    a = instances(model, f"{model.name}_pre_A")
    b = instances(model, f"{model.name}_pre_B")
    for inst in (a, b):
        inst.setup(tol=1e-10)
        inst.set(**start_values(model))
    if phase == "init":
        a.ok("fmi2EnterInitializationMode")
    mark = logs.mark()
    status = call(a)
    assert status == fmi2Error, f"{case}: returned {fs.STATUS_NAMES.get(status, status)}"
    assert_one_failure_line(logs, mark, a.name)
    # the instance is still usable and the call had no effect
    if phase == "instantiated":
        a.ok("fmi2EnterInitializationMode")
    a.ok("fmi2ExitInitializationMode")
    b.ok("fmi2EnterInitializationMode")
    b.ok("fmi2ExitInitializationMode")
    assert a.snapshot() == b.snapshot()
    for _ in range(3):
        assert a.do_step(0.01) == fmi2OK
        assert b.do_step(0.01) == fmi2OK
    assert a.snapshot() == b.snapshot()


def test_parameter_settable_in_initialization_mode(model, instances):
    """Parameters are settable 'before/at initialization' (fixed): in init mode -> OK."""
    n = names(model)
    inst = instances(model, f"{model.name}_initmode")
    inst.setup(tol=1e-10)
    inst.ok("fmi2EnterInitializationMode")
    inst.set(**{n["mass"]: 2.0, "solver": 1, "solver_step": 5e-4})
    inst.ok("fmi2ExitInitializationMode")
    assert inst.get(n["mass"]) == 2.0
    assert inst.get("solver") == 1
    assert inst.get("solver_step") == 5e-4


# ---------------------------------------------------------------------------------------
# fmi2Instantiate failures
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("what", ["wrong GUID", "other model's GUID", "fmuType 7"])
def test_instantiate_rejected(model, load_model, logs, what):
    lib = model.library()
    try:
        fn = lib._functions["fmi2Instantiate"]
        guid = model.guid.encode()
        kind = fs.fmi2CoSimulation
        if what == "wrong GUID":
            guid = b"{00000000-1111-2222-3333-444444444444}"
        elif what == "other model's GUID":
            other = "TwoMassChain" if model.name == "MassSpringDamper" else "MassSpringDamper"
            guid = load_model(other).guid.encode()
            assert guid != model.guid.encode()
        else:
            kind = 7  # neither fmi2ModelExchange (0) nor fmi2CoSimulation (1)
        name = f"{model.name}_bad_{what.replace(' ', '_')}"
        fs.ensure_logger()
        mark = logs.mark()
        comp = fn(name.encode(), kind, guid, model.resource_uri(), byref(fs.CALLBACKS), 0, 0)
        assert not comp, f"fmi2Instantiate must return NULL for {what}"
        assert_one_failure_line(logs, mark, name)
        # the library is still usable: a correct instantiation succeeds
        good = fs.Instance(model, f"{model.name}_after_bad", lib=lib)
        good.initialize(None)
        assert good.do_step(0.01) == fmi2OK
        good.free()
    finally:
        lib.freeLibrary()


# ---------------------------------------------------------------------------------------
# Status queries
# ---------------------------------------------------------------------------------------


def test_status_queries_after_steps(model, instances, logs):
    inst = instances(model, f"{model.name}_status").initialize(start_values(model))
    for _ in range(7):
        inst.step(0.01)
    mark = logs.mark()
    st, t = inst.real_status(fs.fmi2LastSuccessfulTime)
    assert st == fmi2OK and t == inst.t
    term = c_int(7)
    assert inst.call("fmi2GetBooleanStatus", fs.fmi2Terminated, byref(term)) == fmi2OK
    assert term.value == 0
    assert logs.since(mark) == [], "successful calls must not log with loggingOn=false"


STATUS_QUERIES = {
    # (function, kind, ctype of the value, statuses accepted)
    "GetStatus(DoStepStatus)": ("fmi2GetStatus", fs.fmi2DoStepStatus, c_int, {fmi2OK, fmi2Discard, fmi2Error}),
    "GetStatus(PendingStatus)": ("fmi2GetStatus", fs.fmi2PendingStatus, c_int, {fmi2Discard, fmi2Error}),
    "GetStatus(kind 42)": ("fmi2GetStatus", 42, c_int, {fmi2Discard, fmi2Error}),
    "GetRealStatus(DoStepStatus)": ("fmi2GetRealStatus", fs.fmi2DoStepStatus, c_double, {fmi2Discard, fmi2Error}),
    "GetRealStatus(kind 42)": ("fmi2GetRealStatus", 42, c_double, {fmi2Discard, fmi2Error}),
    "GetIntegerStatus(LastSuccessfulTime)": ("fmi2GetIntegerStatus", fs.fmi2LastSuccessfulTime, c_int, {fmi2Discard, fmi2Error}),
    "GetBooleanStatus(LastSuccessfulTime)": ("fmi2GetBooleanStatus", fs.fmi2LastSuccessfulTime, c_int, {fmi2Discard, fmi2Error}),
    "GetStringStatus(PendingStatus)": ("fmi2GetStringStatus", fs.fmi2PendingStatus, c_char_p, {fmi2OK, fmi2Discard, fmi2Error}),
    "GetStringStatus(kind 42)": ("fmi2GetStringStatus", 42, c_char_p, {fmi2Discard, fmi2Error}),
}


@pytest.mark.parametrize("query", list(STATUS_QUERIES))
def test_status_query_variants(model, instances, logs, query):
    """Kinds that a non-asynchronous CS FMU cannot answer: FMI 2.0 4.2.3 says 'If a status
    is required which cannot be retrieved by the slave it returns fmi2Discard'; fmi2Error is
    accepted too (an illegal argument).  DoStepStatus / PendingStatus may also be answered."""
    fname, kind, ctype, accepted = STATUS_QUERIES[query]
    a, b = _twins(model, instances, "sq")
    before = a.snapshot()
    value = ctype()
    mark = logs.mark()
    st = a.call(fname, kind, byref(value))
    print(f"METRIC {model.name} {query} -> {fs.STATUS_NAMES.get(st, st)}")
    assert st in accepted, f"{query} returned {fs.STATUS_NAMES.get(st, st)}"
    if st == fmi2OK:
        assert logs.since(mark) == []
        if fname == "fmi2GetStatus":
            assert value.value == fmi2OK  # the last doStep's status
    else:
        assert_one_failure_line(logs, mark, a.name, status=st)
    assert a.snapshot() == before
    _assert_twin_after_step(a, b)


def test_set_debug_logging_known_categories(model, instances, logs):
    inst = instances(model, f"{model.name}_dbg").initialize(start_values(model))
    cats = [b"logStatusWarning", b"logStatusDiscard", b"logStatusError", b"logStatusFatal", b"logAll"]
    arr = (c_char_p * len(cats))(*cats)
    assert inst.call("fmi2SetDebugLogging", 1, len(cats), arr) == fmi2OK
    assert inst.call("fmi2SetDebugLogging", 0, 0, None) == fmi2OK
    # errors are still logged with logging switched off
    mark = logs.mark()
    assert inst.call("fmi2GetReal", vrs(99999), 1, reals(0.0)) == fmi2Error
    assert_one_failure_line(logs, mark, inst.name)


def test_do_step_after_terminate_is_rejected(model, instances, logs):
    inst = instances(model, f"{model.name}_term").initialize(start_values(model))
    inst.step(0.01)
    values = inst.get_reals(model.state_names)
    inst.ok("fmi2Terminate")
    mark = logs.mark()
    assert inst.do_step(0.01) == fmi2Error
    assert_one_failure_line(logs, mark, inst.name)
    # values can still be inquired after terminate (FMI 2.0 state machine) and are unchanged
    assert inst.get_reals(model.state_names) == values


def test_zero_length_calls_with_null_pointers_are_ok(model, instances, logs):
    """nvr = 0: nothing to read or write, null arrays are fine (the contract only rejects
    null pointers with nvr > 0)."""
    inst = instances(model, f"{model.name}_nvr0").initialize(start_values(model))
    mark = logs.mark()
    for f in ("fmi2GetReal", "fmi2SetReal", "fmi2GetInteger", "fmi2GetBoolean"):
        assert inst.call(f, None, 0, None) == fmi2OK, f
    assert logs.since(mark) == []


# ---------------------------------------------------------------------------------------
# Divergence
# ---------------------------------------------------------------------------------------


def _diverging(model, instances, tag):
    """RK4 with h = 1e-2 on k = 1e6 (w h = 10, far outside RK4's stability interval
    |w h| < 2.83): the amplification is ~400 per step, overflow after ~1.2 s."""
    if model.name == "MassSpringDamper":
        sv = dict(fs.scene_values(model.name, "free"), k=1e6)
    else:
        sv = dict(fs.scene_values(model.name, "release"), k1=1e6, c2=0.0)
    sv.update(solver=fs.SOLVER_RK4, solver_step=1e-2)
    return instances(model, f"{model.name}_{tag}").initialize(sv, tol=1e-6)


def _assert_no_nan(inst):
    vals = inst.get_reals(inst.model.real_names)
    bad = [n for n, v in zip(inst.model.real_names, vals) if math.isnan(v)]
    assert not bad, f"NaN outputs after divergence: {bad}"
    states = inst.get_reals(inst.model.state_names)
    assert all(math.isfinite(v) for v in states), f"non-finite states {states}"
    return dict(zip(inst.model.real_names, vals))


def test_divergence_is_reported_small_steps(model, instances, logs):
    inst = _diverging(model, instances, "div")
    h = 0.1
    status = fmi2OK
    t_before = 0.0
    mark = logs.mark()
    for _ in range(100):  # up to t = 10
        t_before = inst.t
        status = inst.do_step(h)
        if status != fmi2OK:
            break
    assert status in (fmi2Discard, fmi2Error), "a diverging RK4 integration was not reported"
    st, last = inst.real_status()
    vals = _assert_no_nan(inst)
    print(f"METRIC {model.name} divergence: status {fs.STATUS_NAMES[status]} in step from "
          f"{t_before:.3f}, lastSuccessfulTime {last!r}, states "
          f"{[vals[s] for s in model.state_names]}")
    assert st == fmi2OK
    assert math.isfinite(last) and t_before <= last < t_before + h
    assert_one_failure_line(logs, mark, inst.name, status=status)


def test_divergence_is_reported_one_big_step(model, instances, logs):
    inst = _diverging(model, instances, "div1")
    mark = logs.mark()
    status = inst.do_step(10.0)
    assert status in (fmi2Discard, fmi2Error)
    st, last = inst.real_status()
    _assert_no_nan(inst)
    assert st == fmi2OK
    print(f"METRIC {model.name} divergence (one 10 s step): {fs.STATUS_NAMES[status]}, "
          f"lastSuccessfulTime {last!r}")
    assert math.isfinite(last) and 0.0 <= last < 10.0
    assert_one_failure_line(logs, mark, inst.name, status=status)


# ---------------------------------------------------------------------------------------
# The same through fmpy's high-level FMU2Slave API (FMICallException carries the status)
# ---------------------------------------------------------------------------------------


def test_fmpy_high_level_api_raises_with_status(model, logs):
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave

    fs.ensure_logger()
    fmu = FMU2Slave(guid=model.guid, modelIdentifier=model.identifier,
                    unzipDirectory=model.unzipdir, instanceName=f"{model.name}_fmpy")
    fmu.instantiate(callbacks=fs.CALLBACKS, loggingOn=False)
    try:
        fmu.setupExperiment(tolerance=1e-10, startTime=0.0)
        with pytest.raises(FMICallException) as e:
            fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
        assert e.value.status == fmi2Error  # doStep before initialization
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.01)
        for bad in [(0.5, 0.01), (0.01, 0.0), (0.01, -1.0), (0.01, NAN)]:
            mark = logs.mark()
            with pytest.raises(FMICallException) as e:
                fmu.doStep(currentCommunicationPoint=bad[0], communicationStepSize=bad[1])
            assert e.value.status == fmi2Error, bad
            assert len(logs.since(mark, fmu.instanceName)) == 1
        with pytest.raises(FMICallException) as e:
            fmu.getReal([99999])
        assert e.value.status == fmi2Error
        with pytest.raises(FMICallException) as e:
            fmu.setReal([model.vr["F"]], [NAN])
        assert e.value.status == fmi2Error
        fmu.doStep(currentCommunicationPoint=0.01, communicationStepSize=0.01)
        assert fmu.getRealStatus(fs.fmi2LastSuccessfulTime) == 0.01 + 0.01
        fmu.terminate()
    finally:
        fmu.freeInstance()


def test_fmpy_runs_model_exchange(model):
    """The same binary serves Model Exchange (tests/python/test_model_exchange.py compares
    the runs)."""
    import fmpy
    import numpy as np

    result = fmpy.simulate_fmu(model.unzipdir, model_description=model.md,
                               fmi_type="ModelExchange", stop_time=0.5, output_interval=0.01)
    assert abs(result["time"][-1] - 0.5) < 1e-9
    for field in result.dtype.names:
        assert np.all(np.isfinite(result[field])), field
