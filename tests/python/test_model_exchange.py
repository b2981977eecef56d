"""FMI 2.0 Model Exchange in fmpy, for every FMU of the FMU folder.

- fmpy validates the FMU with both interfaces declared;
- every scene: fmpy's Model Exchange run (CVODE, fmi_type='ModelExchange') agrees with its
  Co-Simulation run, and the closed forms of the mass-spring-damper scenes;
- events land where the Co-Simulation runs put them (SphereSlide's departure at the
  closed-form angle, the bicycle's fall at roll_max, PulledPendulum's shortest string);
- a constrained system under Model Exchange keeps its constraints through the step events
  at the level docs/interfaces.md gives, and drifts measurably more with me_projection = 0.

Tolerances: CVODE at rtol 1e-11 against DOPRI5 at 1e-11 (their global errors on these
runs are below 1e-4 of the states' scale, measured: docs/interfaces.md); the two scenes that
are unstable by design (DoublePendulum "chaotic", CompoundPendulum "inverted") are compared
over their first 5 s, before the exponential growth amplifies the solvers' differences.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
from ctypes import c_double

import numpy as np
import pytest
from fmpy.validation import validate_fmu

import fmu_support as fs
from closed_form import msd_exact
from me_support import CONSTRAINED, cs_run, me_run, residuals

# A call refused inside CVODE's callbacks (fmpy raises in a ctypes callback, which Python
# only reports as an unraisable exception and CVODE goes on with) fails the test.
pytestmark = pytest.mark.filterwarnings("error::pytest.PytestUnraisableExceptionWarning")

FMUS = sorted(p.stem for p in fs.fmu_dir().glob("*.fmu"))
RTOL = 1e-11
AGREE = 1e-4  # relative to max(1, the state's largest magnitude)
UNSTABLE = {("DoublePendulum", "chaotic"): 5.0, ("CompoundPendulum", "inverted"): 5.0}


def catalogue() -> list[dict]:
    target = os.environ.get("CARGO_TARGET_DIR", str(fs.REPO / "target"))
    out = subprocess.run([os.path.join(target, "release", "mbfmu"), "list", "--json"],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out)


SCENES = [(m["name"], s) for m in catalogue() for s in m["scenes"] if m["name"] in FMUS]

# Output intervals finer than 0.01 s where CVODE needs more than its 500 internal steps
# (CVODE's default mxstep, which fmpy does not expose) per interval at rtol 1e-11: FourBar
# "step" spins its crank up to 190 rad/s by t = 0.9 s (1.9 rad per 0.01 s), AndrewsSqueezer's
# "test_set" turns at up to 1.4e3 rad/s. With 0.01 s both stopped on "mxstep steps taken
# before reaching tout" (at t = 0.84 s and 0.013 s); with 1e-3 s they agree with
# Co-Simulation to 1.7e-6 and 1.7e-9 of the scale.
INTERVAL = {("FourBar", "step"): 1e-3, ("AndrewsSqueezer", "test_set"): 1e-3}


@pytest.mark.parametrize("name", FMUS)
def test_fmpy_validates_both_interfaces(name, load_model):
    model = load_model(name)
    assert validate_fmu(str(model.path)) == []
    md = model.md
    assert md.modelExchange is not None and md.coSimulation is not None
    assert md.modelExchange.modelIdentifier == md.coSimulation.modelIdentifier
    # The closed-loop mechanisms project onto their closures too (their residuals are
    # checked in their own tests, tests/four_bar.rs and tests/andrews_squeezer.rs).
    constrained = name in CONSTRAINED or name in ("FourBar", "AndrewsSqueezer", "NFourBar", "Bricard")
    assert md.modelExchange.needsCompletedIntegratorStep == constrained


def _id(p):
    m, s = p.values if hasattr(p, "values") else p
    return f"{m}-{s['name']}"


@pytest.mark.parametrize("name, scene", SCENES, ids=[_id(p) for p in SCENES])
def test_model_exchange_agrees_with_co_simulation(name, scene, load_model):
    model = load_model(name)
    stop = min(scene["stop_time"], UNSTABLE.get((name, scene["name"]), math.inf))
    states = model.state_names
    dt = INTERVAL.get((name, scene["name"]), 0.01)
    me, _ = me_run(model, scene["start_values"], stop, dt, rtol=RTOL, output=states)
    cs = cs_run(model, scene["start_values"], stop, dt, rtol=RTOL, output=states)
    # (fmpy's ME loop samples the output grid only: a stop time off it is not recorded)
    assert 0 <= stop - me["time"][-1] < dt + 1e-9
    n = min(len(me), len(cs))
    assert n >= len(cs) - 1  # (a stop time off the grid: CS samples it, ME may not)
    assert np.allclose(me["time"][:n], cs["time"][:n], rtol=0, atol=1e-9)
    worst = 0.0
    for s in states:
        scale = max(1.0, float(np.max(np.abs(cs[s]))))
        err = float(np.max(np.abs(me[s][:n] - cs[s][:n])))
        worst = max(worst, err / scale)
        assert err <= AGREE * scale, f"{name}/{scene['name']}: {s} differs by {err:.2e}"
    print(f"METRIC ME vs CS {name}/{scene['name']}: {worst:.1e} of the scale (T = {stop:g} s)")


@pytest.mark.parametrize("scene", ["free", "damped", "critical", "overdamped", "step",
                                   "resonance"])
def test_mass_spring_damper_model_exchange_matches_the_closed_form(scene, load_model):
    model = load_model("MassSpringDamper")
    entry = next(m for m in catalogue() if m["name"] == "MassSpringDamper")
    s = next(x for x in entry["scenes"] if x["name"] == scene)
    sv = {n: float(model.vars[n].start) for n in ("m", "k", "c", "F_amp", "F_omega", "x", "v")}
    sv["F"] = 0.0
    sv.update(s["start_values"])
    me, _ = me_run(model, s["start_values"], s["stop_time"], 0.01, rtol=RTOL,
                   output=["x", "v"])
    x, v = msd_exact(me["time"], **sv)
    err = max(float(np.max(np.abs(me["x"] - x))), float(np.max(np.abs(me["v"] - v))))
    print(f"METRIC ME vs closed form MassSpringDamper/{scene}: {err:.1e}")
    assert err < 1e-6 * max(1.0, float(np.max(np.abs(v))))


def test_sphere_slide_departs_where_co_simulation_does(load_model):
    """The departure event: located by CVODE's root finding on the normal force, at the
    closed-form angle cos θ = (2/3) cos θ0, within the bracket of the Co-Simulation run's
    on_surface flip (communication steps of 1 ms)."""
    model = load_model("SphereSlide")
    theta0 = math.atan2(float(model.vars["x"].start), float(model.vars["h"].start))
    out = ["x", "h", "vx", "vh", "on_surface"]
    me, _ = me_run(model, {}, 3.0, 0.01, rtol=RTOL, record_events=True, output=out)
    flip = int(np.argmax(me["on_surface"] < 0.5))
    assert flip > 0
    t_me = me["time"][flip]
    assert me["time"][flip - 1] == t_me, "the event is recorded before and after"
    cos_theta = me["h"][flip] / math.hypot(me["x"][flip], me["h"][flip])
    assert abs(cos_theta - 2.0 / 3.0 * math.cos(theta0)) < 1e-6
    cs = cs_run(model, {}, 3.0, 1e-3, rtol=RTOL, output=["on_surface"])
    k = int(np.argmax(cs["on_surface"] < 0.5))
    assert cs["time"][k - 1] <= t_me <= cs["time"][k] + 1e-12, (t_me, cs["time"][k])
    print(f"METRIC SphereSlide departure: ME t = {t_me:.6f} s, CS in "
          f"({cs['time'][k - 1]:.3f}, {cs['time'][k]:.3f}]")


def test_sphere_slide_projection_costs_no_accuracy(load_model):
    """SphereSlide under CVODE at rtol 1e-9: θ with the step events' projection is at least
    as close to an independent reference as without it, while the particle is on the
    sphere. The reference: θ'' = (g/R) sin θ from rest at θ0 (the motion on the sphere in
    its one coordinate), scipy's DOP853 at rtol 1e-13.

    The step events cost accuracy through the restarts they force on the importer (fmpy
    re-initialises CVODE after every event), not through the projection: asked at rounding
    level (238 events) θ was ten times further off than without projection. They are now
    asked only beyond 10 × the tolerance (2 events here)."""
    from scipy.integrate import solve_ivp

    model = load_model("SphereSlide")
    start = {n: float(model.vars[n].start) for n in ("x", "h", "R", "g")}
    theta0 = math.atan2(start["x"], start["h"])
    leaves = math.acos(2.0 / 3.0 * math.cos(theta0))
    stop = 2.75  # the particle leaves the sphere at about 2.5 s
    reference = solve_ivp(lambda t, y: [y[1], start["g"] / start["R"] * math.sin(y[0])],
                          (0.0, stop), [theta0, 0.0], method="DOP853", rtol=1e-13,
                          atol=1e-15, dense_output=True)
    errors, events = {}, {}
    for projection in (True, False):
        me, before = me_run(model, {}, stop, 1e-2, rtol=1e-9, projection=projection,
                            output=["theta"])
        ref = reference.sol(me["time"])[0]
        on = ref < leaves - 0.05  # on the sphere, away from the departure event
        errors[projection] = float(np.max(np.abs(me["theta"][on] - ref[on])))
        events[projection] = len(before)
    print(f"METRIC SphereSlide ME rtol 1e-9, max |θ − θ_ref| on the sphere: "
          f"{errors[True]:.2e} with projection ({events[True]} step events), "
          f"{errors[False]:.2e} without")
    assert events[False] == 0
    assert 0 < events[True] <= 10
    # "At least as accurate", within 10 %: the two runs differ by their few restarts, and
    # the error at the end has been amplified ~1600 times by the unstable equilibrium at the
    # top (e^(2.35 √(g/R))), so which last bits start it moves the ratio by a few percent.
    assert errors[True] <= 1.1 * errors[False], errors
    assert errors[False] < 1e-4


def _cs_event_time(model, start_values: dict, stop: float, h: float) -> float:
    """The time a Co-Simulation run stops at its event: doStep answers fmi2Discard there and
    lastSuccessfulTime is the event."""
    inst = model.instance(f"{model.name}_event")
    try:
        inst.initialize(start_values, tol=RTOL)
        t = 0.0
        while t < stop - 1e-12:
            st = inst.call("fmi2DoStep", c_double(t), c_double(h), 1)
            if st == fs.fmi2Discard:
                return inst.real_status(fs.fmi2LastSuccessfulTime)[1]
            assert st == fs.fmi2OK
            t += h
        raise AssertionError("no event")
    finally:
        inst.free()


@pytest.mark.parametrize("name, start_values, stop", [
    ("NonlinearBicycle", None, 3.0),  # the "weave" scene, run on until it falls (1.89 s)
    ("PulledPendulum", {"l_rate": -0.2}, 6.0),
], ids=["bicycle-fall", "string-shortest"])
def test_terminating_events_land_where_co_simulation_stops(name, start_values, stop,
                                                          load_model):
    """An event the model cannot pass: Co-Simulation answers fmi2Discard at it, Model
    Exchange returns terminateSimulation there (fmpy stops)."""
    model = load_model(name)
    if name == "NonlinearBicycle":
        entry = next(m for m in catalogue() if m["name"] == name)
        start_values = next(s for s in entry["scenes"] if s["name"] == "weave")["start_values"]
    t_cs = _cs_event_time(model, start_values, stop, 0.01)
    me, _ = me_run(model, start_values, stop, 0.01, rtol=RTOL, record_events=True,
                   output=model.state_names[:1])
    t_me = float(me["time"][-1])
    print(f"METRIC {name} terminating event: CS t = {t_cs:.9f} s, ME t = {t_me:.9f} s")
    assert t_me < stop - 0.1
    assert abs(t_me - t_cs) < 1e-6
    if name == "PulledPendulum":
        assert abs(t_me - 0.99 / 0.2) < 1e-6


# Constraint residual with and without the step events' projection (CVODE at rtol 1e-8,
# fmi2CompletedIntegratorStep once per output interval of 1e-2 s), measured in
# docs/interfaces.md. A step event is asked for when the projection would move a state by
# more than 10 × the experiment's tolerance of its scale (fmpy sets no tolerance in Model
# Exchange: the DefaultExperiment's, 1e-8 here). The residual at the outputs stays below
# KEPT × that tolerance: measured 3.4e-7 at the most (SliderCrankSurplus) where the rule's
# 1e-7 per state becomes a residual in its own units (lengths and rates together, |q|² − 1
# twice the move) and the drift grows for one output interval before it is checked.
# Without the projection these systems drift to 1.5e-7 … 9e-5.
DRIFTING = ["SliderCrankSurplus", "RollingDisk", "NonlinearBicycle", "SphereSlide", "RigidBody"]
KEPT = 50.0


@pytest.mark.parametrize("name", [n for n in CONSTRAINED if n in FMUS])
def test_constrained_systems_keep_their_constraints_through_step_events(name, load_model):
    model = load_model(name)
    entry = next(m for m in catalogue() if m["name"] == name)
    sv, stop = entry["scenes"][0]["start_values"], entry["scenes"][0]["stop_time"]
    tolerance = float(model.md.defaultExperiment.tolerance)
    on, before = me_run(model, sv, stop, 1e-2, rtol=1e-8, projection=True)
    off, none = me_run(model, sv, stop, 1e-2, rtol=1e-8, projection=False)
    kept = float(np.max(residuals(model, on, sv)))
    drift = float(np.max(residuals(model, off, sv)))
    pre = max((r for _, r in before), default=0.0)
    print(f"METRIC {name} ME residual at outputs: {kept:.1e} with projection "
          f"({len(before)} step events, {pre:.1e} before them), {drift:.1e} without")
    assert none == [], "no step events with me_projection = 0"
    assert kept < KEPT * tolerance, (kept, tolerance)
    if name in DRIFTING:
        assert len(before) > 0
        assert drift > kept, (kept, drift)
    else:  # linear constraints: CVODE keeps them itself, the projection has nothing to do
        assert before == []
        assert drift < 1e-11
