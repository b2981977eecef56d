"""fmi2GetDirectionalDerivative, consistent with what the FMU declares.

- providesDirectionalDerivative = false: the call returns fmi2Error, logs one line, and
  has no effect (the contract these tests were first written against).
- providesDirectionalDerivative = true: the Jacobian of (state derivatives, outputs) with
  respect to (states, input F), seeded one known at a time, equals the analytic one:
  d der(x)/d(x, F) = (A, B) of the linear model, dE/dx = gradient of the energy, d x/d x = I.
  The models are linear (E quadratic) and the FMU claims exact derivatives, so the
  comparison is to rounding: 1e-12 relative to the largest entry of each row.
"""

from __future__ import annotations

from ctypes import c_double, c_uint

import numpy as np
import pytest

import fmu_support as fs
from closed_form import tmc_matrices
from fmu_support import fmi2Error, fmi2OK


def vrs(*v):
    return (c_uint * len(v))(*v)


def reals(*v):
    return (c_double * len(v))(*v)


def _point(model, instances, tag):
    sv = fs.scene_values(model.name, "resonance" if model.name == "MassSpringDamper" else "step")
    inst = instances(model, f"{model.name}_{tag}").initialize(sv, tol=1e-10)
    for _ in range(37):
        inst.step(0.01)
    return inst, sv


def _analytic(model, sv, vals):
    """rows: der(states)..., E, states... ; columns: states..., F"""
    states = model.state_names
    n = len(states)
    if model.name == "MassSpringDamper":
        m, k, c = sv["m"], sv["k"], sv["c"]
        A = np.array([[0.0, 1.0], [-k / m, -c / m]])
        B = np.array([0.0, 1.0 / m])
        x, v = vals["x"], vals["v"]
        dE = np.array([k * x, m * v])
    else:
        A, B = tmc_matrices(**sv)
        x1, x2, v1, v2 = (vals[s] for s in states)
        k1, k2, m1, m2 = sv["k1"], sv["k2"], sv["m1"], sv["m2"]
        dE = np.array([k1 * x1 - k2 * (x2 - x1), k2 * (x2 - x1), m1 * v1, m2 * v2])
    J = np.zeros((2 * n + 1, n + 1))
    J[:n, :n] = A
    J[:n, n] = B
    J[n, :n] = dE
    J[n + 1:, :n] = np.eye(n)
    return J


def test_directional_derivative_matches_declaration(model, instances, logs):
    inst, sv = _point(model, instances, "dd")
    states = model.state_names
    unknowns = [f"der({s})" for s in states] + ["E"] + states
    knowns = states + ["F"]
    uvr = vrs(*[model.vr[u] for u in unknowns])
    declared = model.md.coSimulation.providesDirectionalDerivative

    if not declared:
        before = inst.snapshot()
        mark = logs.mark()
        out = reals(*([0.0] * len(unknowns)))
        st = inst.call("fmi2GetDirectionalDerivative", uvr, len(unknowns),
                       vrs(model.vr["F"]), 1, reals(1.0), out)
        assert st == fmi2Error
        recs = logs.since(mark)
        assert len(recs) == 1 and recs[0].category == "logStatusError", recs
        assert inst.snapshot() == before
        assert inst.do_step(0.01) == fmi2OK
        return

    vals = dict(zip(states, inst.get_reals(states)))
    J = np.zeros((len(unknowns), len(knowns)))
    for j, kname in enumerate(knowns):
        out = reals(*([0.0] * len(unknowns)))
        st = inst.call("fmi2GetDirectionalDerivative", uvr, len(unknowns),
                       vrs(model.vr[kname]), 1, reals(1.0), out)
        assert st == fmi2OK, kname
        J[:, j] = list(out)
    want = _analytic(model, sv, vals)
    scale = np.maximum(np.max(np.abs(want), axis=1, keepdims=True), 1e-300)
    err = float(np.max(np.abs(J - want) / scale))
    print(f"METRIC {model.name} directional derivative max rel err {err:.3e}")
    assert err < 1e-12, f"Jacobian differs:\n{J}\nwant\n{want}"

    # linearity in the seed: seed 2*e_F + 3*e_state0 in one call
    out = reals(*([0.0] * len(unknowns)))
    st = inst.call("fmi2GetDirectionalDerivative", uvr, len(unknowns),
                   vrs(model.vr["F"], model.vr[states[0]]), 2, reals(2.0, 3.0), out)
    assert st == fmi2OK
    combo = 2.0 * want[:, -1] + 3.0 * want[:, 0]
    assert np.allclose(list(out), combo, rtol=1e-12, atol=1e-12 * np.max(np.abs(combo)))


@pytest.mark.parametrize("bad", ["unknown vr 99999", "parameter as known", "parameter as unknown",
                                 "NaN seed", "null seed array"])
def test_directional_derivative_bad_arguments(model, instances, logs, bad):
    """Bad arguments -> fmi2Error, one log line, no effect (whatever the declaration)."""
    inst, _ = _point(model, instances, "ddbad")
    states = model.state_names
    mass = "m" if model.name == "MassSpringDamper" else "m1"
    unknown = [model.vr[f"der({states[1]})"]]
    known, seed = [model.vr["F"]], reals(1.0)
    if bad == "unknown vr 99999":
        known = [99999]
    elif bad == "parameter as known":
        known = [model.vr[mass]]
    elif bad == "parameter as unknown":
        unknown = [model.vr[mass]]
    elif bad == "NaN seed":
        seed = reals(float("nan"))
    elif bad == "null seed array":
        seed = None
    before = inst.snapshot()
    mark = logs.mark()
    st = inst.call("fmi2GetDirectionalDerivative", vrs(*unknown), 1, vrs(*known), 1, seed, reals(0.0))
    assert st == fmi2Error
    recs = logs.since(mark)
    assert len(recs) == 1 and recs[0].category == "logStatusError", recs
    assert inst.snapshot() == before
    assert inst.do_step(0.01) == fmi2OK
