"""Consistent initialisation through fmpy, as a user runs it: `simulate_fmu` with
`start_values` on the independent states of a constrained FMU gives exactly those values
at t = 0, the dependent ones solved from the constraints; a dependent value set against
them is used as the constraints say and reported as a warning. The CLI's `linearize`
takes the same values the same way and refuses what the FMU refuses.
"""

from __future__ import annotations

import subprocess
from ctypes import c_double, c_uint

import numpy as np

import fmu_support as fs
from test_linearization import cli


def first_row(result, names):
    return {n: float(result[n][0]) for n in names}


def test_the_disk_keeps_its_rates_and_runs_on_the_closed_form_circle(load_model):
    """systems.md §10: θ̇ = ω, φ̇ = s alone; contact point on x = ρ sin ωt,
    y = ρ (1 − cos ωt), ρ = a s / ω. Before: φ̇ read 1.667 at t = 0 and the circle was
    2.9 m off."""
    model = load_model("RollingDisk")
    w, s, a = 0.7, 5.0, 0.3
    res = fs.simulate(model, {"theta_dot": w, "phi_dot": s}, tol=1e-10, stop_time=10.0,
                      outputs=["x", "y", "x_dot", "theta_dot", "phi_dot"])
    t0 = first_row(res, ["theta_dot", "phi_dot", "x_dot"])
    assert t0["theta_dot"] == w and t0["phi_dot"] == s
    assert abs(t0["x_dot"] - a * s) <= 4 * np.finfo(float).eps * a * s
    rho = a * s / w
    t = res["time"]
    off = np.max(np.hypot(res["x"] - rho * np.sin(w * t), res["y"] - rho * (1 - np.cos(w * t))))
    # DOPRI5 at rtol 1e-10 over 10 s on a 2.1 m circle: global error ~1e-9 m.
    assert off <= 1e-7, off


def test_the_surplus_slider_crank_keeps_theta(load_model):
    """θ = 1.0 alone: it reads 1.0 at t = 0 (before: 0.909) and β, x, ẋ equal the reduced
    SliderCrank's to rounding."""
    surplus, reduced = load_model("SliderCrankSurplus"), load_model("SliderCrank")
    names = ["theta", "beta", "x", "x_dot", "theta_dot"]
    a = first_row(fs.simulate(surplus, {"theta": 1.0}, stop_time=0.01, outputs=names), names)
    b = first_row(fs.simulate(reduced, {"theta": 1.0}, stop_time=0.01, outputs=names), names)
    assert a["theta"] == 1.0
    for n in names:
        assert abs(a[n] - b[n]) <= 8 * np.finfo(float).eps * max(1.0, abs(b[n])), (n, a[n], b[n])


def test_the_hoop_keeps_its_speed_and_warns_about_a_contradicting_rate(load_model, logs):
    """ẋ = 1 m/s alone reads 1 (before: 0.5). With θ̇ = 7 rad/s set too (r = 0.5 m, so
    the rolling constraint gives 2 rad/s) the FMU uses 2 and says so, once."""
    model = load_model("RollingHoop")
    names = ["x_dot", "theta_dot"]
    res = fs.simulate(model, {"x_dot": 1.0}, stop_time=0.01, outputs=names)
    assert first_row(res, names) == {"x_dot": 1.0, "theta_dot": 2.0}
    mark = logs.mark()
    res = fs.simulate(model, {"x_dot": 1.0, "theta_dot": 7.0}, stop_time=0.01, outputs=names)
    assert first_row(res, names) == {"x_dot": 1.0, "theta_dot": 2.0}
    warnings = [r for r in logs.since(mark) if r.status == 1]
    assert len(warnings) == 1, warnings
    assert "theta_dot" in warnings[0].message and "set to 7" in warnings[0].message


def test_the_cli_refuses_what_the_fmu_refuses(load_model, logs):
    """`--set m=-1` gives the FMU's own message for fmi2SetReal, and a non-zero exit."""
    cli_run = subprocess.run([cli(), "linearize", "MassSpringDamper", "--set", "m=-1"],
                             capture_output=True, text=True)
    assert cli_run.returncode != 0 and cli_run.stdout == ""
    inst = load_model("MassSpringDamper").instance("refuse-m")
    try:
        mark = logs.mark()
        vr = (c_uint * 1)(inst.model.vr["m"])
        assert inst.call("fmi2SetReal", vr, 1, (c_double * 1)(-1.0)) == 3
        (line,) = [r.message for r in logs.since(mark, "refuse-m")]
    finally:
        inst.free()
    assert line.startswith("fmi2SetReal: ")
    assert cli_run.stderr.strip() == "mbfmu: " + line.removeprefix("fmi2SetReal: ")


def test_linearize_solves_the_dependent_states_like_the_fmu():
    """`--at theta=1` on the surplus slider-crank: x0 holds θ = 1 and the solved β, x;
    a contradicting `--at beta=0` is reported on stderr."""
    import json

    run = subprocess.run([cli(), "linearize", "SliderCrankSurplus", "--at", "theta=1"],
                         capture_output=True, text=True, check=True)
    lin = json.loads(run.stdout)
    x0 = dict(zip(lin["states"], lin["x0"]))
    assert x0["theta"] == 1.0
    l1, l2 = 0.1, 0.3
    assert abs(x0["beta"] - np.arcsin(l1 * np.sin(1.0) / l2)) < 1e-15
    assert run.stderr == ""
    run = subprocess.run([cli(), "linearize", "SliderCrankSurplus", "--at", "theta=1",
                          "--at", "beta=0"], capture_output=True, text=True, check=True)
    assert run.stderr.startswith("warning: beta") and "set to 0" in run.stderr
