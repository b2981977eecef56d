"""Model Exchange runs in fmpy (CVODE), with what the tests and docs/interfaces.md measure:
the constraint residual at the output points and just before each step event's projection.

    python tests/python/me_support.py        # prints the table of docs/interfaces.md
"""

from __future__ import annotations

import math

import numpy as np
from fmpy import simulate_fmu
from fmpy.fmi2 import FMU2Model

import fmu_support as fs


def residual_of(name: str):
    """(t, values, params) -> the largest constraint residual of system `name` (position and
    velocity constraints, in their own units), or None for a system without constraints."""
    def hoop(t, v, p):
        return np.maximum(np.abs(v["residual"]), np.abs(p["r"] * v["theta_dot"] - v["x_dot"]))

    def crank(t, v, p):
        return np.max(np.abs([v[k] for k in ("residual_y", "residual_x", "residual_y_dot",
                                             "residual_x_dot")]), axis=0)

    def disk(t, v, p):
        return np.maximum(np.abs(v["residual_x"]), np.abs(v["residual_y"]))

    def bicycle(t, v, p):
        return np.max(np.abs([v[k] for k in ("residual_contact", "residual_contact_rate",
                                             "slip_rear_x", "slip_rear_y", "slip_front_x",
                                             "slip_front_y")]), axis=0)

    def sphere(t, v, p):
        on = np.asarray(v["on_surface"]) > 0.5
        r = np.hypot(v["x"], v["h"])
        radial = (v["x"] * v["vx"] + v["h"] * v["vh"]) / r
        return np.where(on, np.maximum(np.abs(r - p["R"]), np.abs(radial)), 0.0)

    def hoop_bead(t, v, p):
        return np.maximum(np.abs(v["phi"] - p["Omega"] * t), np.abs(v["phi_dot"] - p["Omega"]))

    def pulled(t, v, p):
        return np.maximum(np.abs(v["r"] - (p["l0"] + p["l_rate"] * t)),
                          np.abs(v["r_dot"] - p["l_rate"]))

    def rigid(t, v, p):
        return np.abs(v["q0"] ** 2 + v["q1"] ** 2 + v["q2"] ** 2 + v["q3"] ** 2 - 1.0)

    return {
        "RollingHoop": (hoop, ["residual", "theta_dot", "x_dot"], ["r"]),
        "SliderCrankSurplus": (crank, ["residual_y", "residual_x", "residual_y_dot",
                                       "residual_x_dot"], []),
        "RollingDisk": (disk, ["residual_x", "residual_y"], []),
        "NonlinearBicycle": (bicycle, ["residual_contact", "residual_contact_rate",
                                       "slip_rear_x", "slip_rear_y", "slip_front_x",
                                       "slip_front_y"], []),
        "SphereSlide": (sphere, ["x", "h", "vx", "vh", "on_surface"], ["R"]),
        "RotatingHoopBead": (hoop_bead, ["phi", "phi_dot"], ["Omega"]),
        "PulledPendulum": (pulled, ["r", "r_dot"], ["l0", "l_rate"]),
        "RigidBody": (rigid, ["q0", "q1", "q2", "q3"], []),
    }.get(name)


CONSTRAINED = ["RollingHoop", "SliderCrankSurplus", "RollingDisk", "NonlinearBicycle",
               "SphereSlide", "RotatingHoopBead", "PulledPendulum", "RigidBody"]


def me_run(model: fs.Model, start_values: dict, stop_time: float, output_interval: float,
           rtol: float = 1e-8, projection: bool = True, record_events: bool = False,
           output=None):
    """fmpy's Model Exchange run (CVODE, fmi2CompletedIntegratorStep once per output
    interval). Returns (result, before) where `before` lists, for each step event, the time
    and the constraint residual of the state the importer integrated to, just before
    fmi2NewDiscreteStates projected it (empty for an unconstrained system)."""
    md = model.md
    fmu = FMU2Model(guid=md.guid, unzipDirectory=model.unzipdir,
                    modelIdentifier=md.modelExchange.modelIdentifier,
                    instanceName=f"{model.name}_me")
    fmu.instantiate()
    spec = residual_of(model.name)
    sv = dict(start_values)
    if not projection:
        sv["me_projection"] = 0
    params = {}
    if spec:
        for n in spec[2]:
            params[n] = float(sv.get(n, model.vars[n].start))
    before = []
    clock = {"t": 0.0}
    set_time, completed = fmu.setTime, fmu.completedIntegratorStep

    def tracked_set_time(t):
        clock["t"] = t
        return set_time(t)

    def tracked_completed(*args, **kw):
        step_event, terminate = completed(*args, **kw)
        if spec and step_event:
            vrs = [model.vars[n].valueReference for n in spec[1]]
            vals = dict(zip(spec[1], fmu.getReal(vrs)))
            before.append((clock["t"], float(spec[0](clock["t"], vals, params))))
        return step_event, terminate

    fmu.setTime = tracked_set_time
    fmu.completedIntegratorStep = tracked_completed
    names = output
    if names is None:
        names = [v.name for v in md.modelVariables
                 if v.causality == "output" and v.type == "Real"]
    try:
        result = simulate_fmu(model.unzipdir, model_description=md, fmu_instance=fmu,
                              fmi_type="ModelExchange", solver="CVode",
                              relative_tolerance=rtol, start_values=sv, stop_time=stop_time,
                              output_interval=output_interval, record_events=record_events,
                              output=names)
    finally:
        fmu.freeInstance()
    return result, before


def cs_run(model: fs.Model, start_values: dict, stop_time: float, output_interval: float,
           rtol: float = 1e-10, output=None):
    md = model.md
    names = output
    if names is None:
        names = [v.name for v in md.modelVariables
                 if v.causality == "output" and v.type == "Real"]
    return simulate_fmu(model.unzipdir, model_description=md, fmi_type="CoSimulation",
                        relative_tolerance=rtol, start_values=dict(start_values),
                        stop_time=stop_time, output_interval=output_interval, output=names)


def residuals(model: fs.Model, result, start_values: dict) -> np.ndarray:
    fn, names, pnames = residual_of(model.name)
    params = {n: float(start_values.get(n, model.vars[n].start)) for n in pnames}
    vals = {n: result[n] for n in names}
    return np.asarray(fn(result["time"], vals, params), dtype=float)


def measure(name: str, scene: str | None = None, intervals=(1e-2, 1e-3), rtol: float = 1e-8):
    """Rows of docs/interfaces.md for one constrained system: per output interval and
    projection on/off, the largest residual at the output points and just before a
    projection (CVODE at `rtol`)."""
    model = fs.Model.get(name)
    sv, stop = scene_start(name, scene)
    rows = []
    for dt in intervals:
        for projection in (True, False):
            result, before = me_run(model, sv, stop, dt, rtol=rtol, projection=projection)
            at_outputs = float(np.max(residuals(model, result, sv)))
            pre = max((r for _, r in before), default=float("nan"))
            rows.append({"system": name, "interval": dt, "projection": projection,
                         "at_outputs": at_outputs, "before_projection": pre,
                         "events": len(before), "stop_time": stop})
    return rows


def scene_start(name: str, scene: str | None = None):
    """(start values, stop time) of a scene of `mbfmu list --json` (the first by default)."""
    import json
    import os
    import subprocess
    target = os.environ.get("CARGO_TARGET_DIR", str(fs.REPO / "target"))
    out = subprocess.run([os.path.join(target, "release", "mbfmu"), "list", "--json"],
                         check=True, capture_output=True, text=True).stdout
    entry = next(m for m in json.loads(out) if m["name"] == name)
    s = entry["scenes"][0] if scene is None else next(
        s for s in entry["scenes"] if s["name"] == scene)
    return dict(s["start_values"]), float(s["stop_time"])


if __name__ == "__main__":
    for name in CONSTRAINED:
        for row in measure(name):
            print(f"{row['system']:20s} dt={row['interval']:.0e} "
                  f"proj={'on ' if row['projection'] else 'off'} "
                  f"outputs {row['at_outputs']:.1e} before {row['before_projection']:.1e} "
                  f"events {row['events']} (T = {row['stop_time']:.3g} s)", flush=True)
