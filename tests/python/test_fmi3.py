"""FMI 3.0 in fmpy, for every FMU of the FMI 3.0 folder (``<MBFMU_FMU_DIR>3``, beside the
FMI 2.0 one: `mbfmu build` writes both from the same binary).

- fmpy validates every FMI 3.0 FMU (its FMI 3.0 schema and rules); the value references of
  FMI 2.0's variables are unchanged, ``time`` is the independent variable at the next one;
- every system and scene: fmpy's FMI 3.0 Co-Simulation and Model Exchange runs equal the
  FMI 2.0 runs of the same FMU (same solver and tolerance: the same core computes both);
- events land where Co-Simulation puts them: SphereSlide's departure, through FMI 3.0's
  early return (eventModeUsed, earlyReturnAllowed), at the closed-form angle and at the
  time Model Exchange's root finding gives.
"""

from __future__ import annotations

import math
import pathlib
import xml.etree.ElementTree as ET
import zipfile

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.validation import validate_fmu

import fmu_support as fs
from fmpy.fmi1 import FMICallException
from fmpy.fmi3 import FMU3Slave

from test_model_exchange import UNSTABLE, _cs_event_time, catalogue

pytestmark = pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")


def fmu3_dir() -> pathlib.Path:
    d = fs.fmu_dir()
    return d.with_name(d.name + "3")


FMUS = sorted(p.stem for p in fs.fmu_dir().glob("*.fmu"))
FMUS3 = sorted(p.stem for p in fmu3_dir().glob("*.fmu"))
# Agreement of FMI 3.0 with FMI 2.0, relative to max(1, the state's largest magnitude).
AGREE = 1e-9
RTOL = 1e-8
# The scenes are compared over their first STOP_CAP seconds at most (run time).
STOP_CAP = 5.0

_CACHE: dict = {}


def pair(name: str):
    """(FMI 2.0 path, FMI 3.0 path, unzipped FMI 2.0, unzipped FMI 3.0, md2, md3)."""
    if name not in _CACHE:
        p2, p3 = fs.fmu_file(name), fmu3_dir() / f"{name}.fmu"
        if not p3.is_file():
            pytest.fail(f"no FMI 3.0 FMU {p3} beside {p2}")
        _CACHE[name] = (p2, p3, extract(str(p2)), extract(str(p3)),
                        read_model_description(str(p2)), read_model_description(str(p3)))
    return _CACHE[name]


def test_every_fmu_has_its_fmi3_twin():
    assert FMUS, f"no FMU in {fs.fmu_dir()}"
    assert FMUS3 == FMUS


@pytest.mark.parametrize("name", FMUS)
def test_fmpy_validates_the_fmi3_fmu(name):
    p2, p3, _, _, md2, md3 = pair(name)
    assert validate_fmu(str(p3)) == []
    assert md3.fmiVersion == "3.0"
    assert md3.guid == md2.guid  # instantiationToken: one binary, one model
    assert md3.modelExchange is not None and md3.coSimulation is not None
    with zipfile.ZipFile(p3) as z:
        root = ET.fromstring(z.read("modelDescription.xml"))
    me, cs = root.find("ModelExchange").attrib, root.find("CoSimulation").attrib
    for interface in (me, cs):
        for flag in ("providesDirectionalDerivatives", "providesAdjointDerivatives",
                     "canGetAndSetFMUState", "canSerializeFMUState"):
            assert interface[flag] == "true", flag
    for flag in ("providesIntermediateUpdate", "canReturnEarlyAfterIntermediateUpdate",
                 "hasEventMode", "canHandleVariableCommunicationStepSize"):
        assert cs[flag] == "true", flag
    with zipfile.ZipFile(p2) as z:
        me2 = ET.fromstring(z.read("modelDescription.xml")).find("ModelExchange").attrib
    needs = me["needsCompletedIntegratorStep"] == "true"
    assert needs == (me2["completedIntegratorStepNotNeeded"] == "false")
    vr2 = {v.name: v.valueReference for v in md2.modelVariables}
    vr3 = {v.name: v.valueReference for v in md3.modelVariables}
    assert {n: vr3[n] for n in vr2} == vr2, "FMI 2.0's value references unchanged"
    time = next(v for v in md3.modelVariables if v.causality == "independent")
    assert (time.name, time.valueReference) == ("time", len(vr2))
    assert len(md3.eventIndicators) == md2.numberOfEventIndicators
    assert len(md3.derivatives) == len(md2.derivatives)
    assert len(md3.outputs) == len(md2.outputs)


def _scenes():
    out = []
    for m in catalogue():
        if m["name"] not in FMUS:
            continue
        for s in m["scenes"]:
            # (test_model_exchange's fast scenes, compared there on a finer grid for
            # CVODE's 500 steps per interval, run here within them: RTOL and STOP_CAP)
            out.append((m["name"], s))
    return out


SCENES = _scenes()


def _id(p):
    m, s = p
    return f"{m}-{s['name']}"


def _run(name, version, fmi_type, scene, stop, states):
    p2, p3, u2, u3, md2, md3 = pair(name)
    unzip, md = (u2, md2) if version == 2 else (u3, md3)
    kw = dict(solver="CVode") if fmi_type == "ModelExchange" else {}
    return simulate_fmu(unzip, model_description=md, fmi_type=fmi_type,
                        relative_tolerance=RTOL, start_values=dict(scene["start_values"]),
                        stop_time=stop, output_interval=0.01, output=states, **kw)


@pytest.mark.parametrize("name, scene", SCENES, ids=[_id(p) for p in SCENES])
def test_fmi3_runs_equal_fmi2_runs(name, scene):
    md2 = pair(name)[4]
    states = [u.variable.derivative.name for u in md2.derivatives]
    stop = min(scene["stop_time"], UNSTABLE.get((name, scene["name"]), math.inf), STOP_CAP)
    worst = {}
    for fmi_type in ("CoSimulation", "ModelExchange"):
        r2 = _run(name, 2, fmi_type, scene, stop, states)
        r3 = _run(name, 3, fmi_type, scene, stop, states)
        assert len(r2) == len(r3), (fmi_type, len(r2), len(r3))
        assert np.array_equal(r2["time"], r3["time"])
        w = 0.0
        for s in states:
            scale = max(1.0, float(np.max(np.abs(r2[s]))))
            err = float(np.max(np.abs(r3[s] - r2[s])))
            w = max(w, err / scale)
            assert err <= AGREE * scale, f"{name}/{scene['name']} {fmi_type}: {s} differs by {err:.2e}"
        worst[fmi_type] = w
    print(f"METRIC FMI3 vs FMI2 {name}/{scene['name']}: CS {worst['CoSimulation']:.1e}, "
          f"ME {worst['ModelExchange']:.1e} of the scale (T = {stop:g} s)")


def test_sphere_slide_returns_early_at_its_departure():
    """FMI 3.0 Co-Simulation with eventModeUsed and earlyReturnAllowed (fmpy's loop: early
    return, Event Mode, Step Mode): the step holding the departure returns at it; the
    recorded flip of on_surface is at the closed-form angle cos θ = (2/3) cos θ0 and at the
    time FMI 3.0 Model Exchange (CVODE's root finding) finds."""
    name = "SphereSlide"
    if name not in FMUS3:
        pytest.skip("no SphereSlide FMU")
    _, _, _, u3, md2, md3 = pair(name)
    vars3 = {v.name: v for v in md3.modelVariables}
    theta0 = math.atan2(float(vars3["x"].start), float(vars3["h"].start))
    out = ["x", "h", "vx", "vh", "on_surface"]
    cs = simulate_fmu(u3, model_description=md3, fmi_type="CoSimulation",
                      relative_tolerance=1e-11, stop_time=3.0, output_interval=0.1,
                      output=out, early_return_allowed=True, use_event_mode=True)
    k = int(np.argmax(cs["on_surface"] < 0.5))
    assert k > 0
    t_cs = float(cs["time"][k])
    grid = np.round(cs["time"] / 0.1) * 0.1
    assert abs(t_cs - grid[k]) > 1e-6, "the departure is recorded off the 0.1 s grid"
    cos_theta = cs["h"][k] / math.hypot(cs["x"][k], cs["h"][k])
    assert abs(cos_theta - 2.0 / 3.0 * math.cos(theta0)) < 1e-6
    me = simulate_fmu(u3, model_description=md3, fmi_type="ModelExchange", solver="CVode",
                      relative_tolerance=1e-11, stop_time=3.0, output_interval=0.01,
                      output=out, record_events=True)
    j = int(np.argmax(me["on_surface"] < 0.5))
    t_me = float(me["time"][j])
    print(f"METRIC SphereSlide FMI3 departure: CS early return at t = {t_cs:.9f} s, "
          f"ME event at t = {t_me:.9f} s")
    assert abs(t_cs - t_me) < 1e-6


@pytest.mark.parametrize("name, start_values, stop", [
    ("NonlinearBicycle", None, 3.0),  # the "weave" scene, run on until it falls (1.89 s)
    ("PulledPendulum", {"l_rate": -0.2}, 6.0),
], ids=["bicycle-fall", "string-shortest"])
def test_terminating_events_end_fmi3_steps_where_fmi2_ends_them(name, start_values, stop):
    """An event the model cannot pass: FMI 3.0's doStep answers fmi3Discard there (with
    early return allowed and Event Mode used), at the time FMI 2.0's doStep gives as
    lastSuccessfulTime, bit for bit."""
    if name not in FMUS3:
        pytest.skip(f"no {name} FMU")
    if start_values is None:
        entry = next(m for m in catalogue() if m["name"] == name)
        start_values = next(s for s in entry["scenes"] if s["name"] == "weave")["start_values"]
    t2 = _cs_event_time(fs.Model.get(name), start_values, stop, 0.01)
    _, _, _, u3, md2, md3 = pair(name)
    vrs = {v.name: v.valueReference for v in md3.modelVariables}
    fmu = FMU3Slave(guid=md3.guid, unzipDirectory=u3,
                    modelIdentifier=md3.coSimulation.modelIdentifier, instanceName="t3")
    fmu.instantiate(eventModeUsed=True, earlyReturnAllowed=True)
    try:
        for n, v in start_values.items():
            fmu.setFloat64([vrs[n]], [float(v)])
        fmu.enterInitializationMode(tolerance=1e-11, startTime=0.0)
        fmu.exitInitializationMode()
        fmu.enterStepMode()
        t, t3 = 0.0, None
        while t < stop - 1e-12:
            try:
                _, terminate, early, last = fmu.doStep(t, 0.01)
            except FMICallException as e:
                assert e.status == 2, e
                t3 = fmu.getFloat64([vrs["time"]])[0]
                break
            assert not terminate
            t = last
        assert t3 is not None, "no discarded step"
    finally:
        fmu.freeInstance()
    print(f"METRIC {name} terminating event: FMI 2 t = {t2:.12f} s, FMI 3 t = {t3:.12f} s")
    assert t3 == t2
