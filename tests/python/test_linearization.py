"""Linearisation through the FMU itself, for every FMU in the FMU folder.

A, B, C, D are built column by column from fmi2GetDirectionalDerivative at the exported
operating point (the start values, or the system's own point where they are not an
equilibrium: FourBar's held linkage; set before initialisation, read in Initialization
Mode) and compared with
- the JSON of `mbfmu linearize MODEL` and the copy packed in the FMU's resources/: the
  same exact derivatives, so they must agree to 1e-14 relative;
- central finite differences of der(x) and the outputs, read through fmi2GetReal after
  fmi2SetReal of the states/inputs in Initialization Mode: their own accuracy, O(δ²)
  truncation plus O(ε/δ) rounding, ~1e-8 relative for δ = 1e-5.
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
import zipfile
from ctypes import c_double, c_uint

import numpy as np
import pytest

import fmu_support as fs

FMUS = sorted(p.stem for p in fs.fmu_dir().glob("*.fmu"))


def cli() -> pathlib.Path:
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", fs.REPO / "target"))
    exe = target / "release" / "mbfmu"
    assert exe.is_file(), f"{exe} missing: build with `cargo run --release --bin mbfmu -- build --all`"
    return exe


def structure(model: fs.Model):
    md = model.md
    states = model.state_names
    ders = [u.variable.name for u in md.derivatives]
    inputs = [v.name for v in md.modelVariables if v.causality == "input"]
    outputs = [u.variable.name for u in md.outputs]
    return states, ders, inputs, outputs


def fmu_jacobian(inst: fs.Instance, unknowns, knowns):
    vr = inst.model.vr
    unk = (c_uint * len(unknowns))(*(vr[n] for n in unknowns))
    kn = (c_uint * len(knowns))(*(vr[n] for n in knowns))
    J = np.zeros((len(unknowns), len(knowns)))
    for j in range(len(knowns)):
        seed = (c_double * len(knowns))(*(1.0 if i == j else 0.0 for i in range(len(knowns))))
        out = (c_double * len(unknowns))()
        inst.ok("fmi2GetDirectionalDerivative", unk, len(unknowns), kn, len(knowns), seed, out)
        J[:, j] = list(out)
    return J


def bounds(model: fs.Model, name: str) -> tuple[float, float]:
    var = next(v for v in model.md.modelVariables if v.name == name)
    lo = float(var.min) if var.min is not None else -np.inf
    hi = float(var.max) if var.max is not None else np.inf
    return lo, hi


def central_differences(inst: fs.Instance, unknowns, knowns, delta=1e-5):
    """Central differences, one-sided at a min/max bound (the FMU rightly rejects a
    value outside [min, max], e.g. a mode state sitting at its max of 1). Where both sides
    are free, Richardson's extrapolation of the steps h and h/2, (4 D(h/2) - D(h)) / 3: its
    truncation error is O(h^4) instead of h^2/6 times the third derivative. The flyball
    governor's springs (K = 8e5 N/m) make that derivative of E about 4e6 along s, so that
    plain central differences at h = 1e-5 miss dE/ds by 6e-5 (4e-7 of the scale), where
    the FMU's value is exact."""
    base = dict(zip(knowns, inst.get_reals(knowns)))
    J = np.zeros((len(unknowns), len(knowns)))

    def difference(name, h):
        lo, hi = bounds(inst.model, name)
        plus = min(base[name] + h, hi)
        minus = max(base[name] - h, lo)
        inst.set(**{name: plus})
        up = np.array(inst.get_reals(unknowns))
        inst.set(**{name: minus})
        down = np.array(inst.get_reals(unknowns))
        inst.set(**{name: base[name]})
        return (up - down) / (plus - minus), lo < base[name] - h and base[name] + h < hi

    for j, name in enumerate(knowns):
        h = delta * max(1.0, abs(base[name]))
        wide, symmetric = difference(name, h)
        narrow, narrow_symmetric = difference(name, h / 2)
        J[:, j] = (4 * narrow - wide) / 3 if symmetric and narrow_symmetric else wide
    return J


def assert_close(got, want, rel, what):
    scale = max(1.0, float(np.max(np.abs(want)))) if want.size else 1.0
    err = float(np.max(np.abs(got - want))) if want.size else 0.0
    print(f"METRIC {what}: max abs error {err:.3e} (scale {scale:.3e})")
    assert got.shape == want.shape, f"{what}: shape {got.shape} != {want.shape}"
    assert err <= rel * scale, f"{what}: error {err:.3e} > {rel:.0e} x {scale:.3e}"


@pytest.mark.parametrize("name", FMUS)
def test_directional_derivatives_match_export_and_finite_differences(name, load_model):
    model = load_model(name)
    states, ders, inputs, outputs = structure(model)
    out = subprocess.run([str(cli()), "linearize", name, "--format", "json"],
                         check=True, capture_output=True, text=True).stdout
    exported = json.loads(out)
    with zipfile.ZipFile(model.path) as z:
        packed = json.loads(z.read("resources/linearization.json"))
    assert packed == exported
    n, m, p = exported["n"], exported["m"], exported["p"]
    assert (n, m, p) == (len(states), len(inputs), len(outputs))
    assert exported["states"] == states and exported["inputs"] == inputs
    assert exported["outputs"] == outputs

    # The export's operating point, where it is not the start values (FourBar: the held
    # linkage, a stable equilibrium; it starts turning), set before initialisation, when
    # FMI 2.0 lets every state and input be set.
    start = {v.name: float(v.start) for v in model.md.modelVariables if v.start is not None}
    point = {k: v for k, v in zip(states + inputs, exported["x0"] + exported["u0"])
             if start.get(k) != v}

    inst = model.instance(f"{name}_lin")
    try:
        inst.setup(tol=1e-10)
        inst.set(**point)
        inst.ok("fmi2EnterInitializationMode")
        knowns = states + inputs
        F = fmu_jacobian(inst, ders, knowns)
        G = fmu_jacobian(inst, outputs, knowns)
        shape = lambda key, r, c: np.array(exported[key], dtype=float).reshape(r, c)
        A, B = shape("A", n, n), shape("B", n, m)
        C, D = shape("C", p, n), shape("D", p, m)
        assert_close(F, np.hstack([A, B]), 1e-14, f"{name} [A B] vs export")
        assert_close(G, np.hstack([C, D]), 1e-14, f"{name} [C D] vs export")
        # A Model Exchange instance of the same binary gives the same derivatives, bit
        # for bit (one core, the same dual numbers).
        me = fs.Instance(model, f"{name}_lin_me", lib=inst.lib, kind=fs.fmi2ModelExchange)
        try:
            me.setup(tol=1e-10)
            me.set(**point)
            me.ok("fmi2EnterInitializationMode")
            assert np.array_equal(fmu_jacobian(me, ders, knowns), F), f"{name}: ME [A B]"
            assert np.array_equal(fmu_jacobian(me, outputs, knowns), G), f"{name}: ME [C D]"
        finally:
            me.free()
        # An output equal to a state has derivative exactly 1 with respect to it.
        for i, o in enumerate(outputs):
            if o in states:
                assert G[i, states.index(o)] == 1.0
        # Differences need fmi2SetReal in Initialization Mode, which FMI 2.0 allows for
        # initial="exact" states and inputs only: a dependent state (initial="approx",
        # solved from the constraints) has its column checked against the export above.
        initial = {v.name: v.initial for v in model.md.modelVariables}
        settable = [k for k in knowns if initial.get(k) != "approx"]
        cols = [knowns.index(k) for k in settable]
        Ffd = central_differences(inst, ders, settable)
        Gfd = central_differences(inst, outputs, settable)
        assert_close(F[:, cols], Ffd, 1e-7, f"{name} [A B] vs central differences")
        assert_close(G[:, cols], Gfd, 1e-7, f"{name} [C D] vs central differences")
    finally:
        inst.free()


def test_every_built_fmu_is_checked():
    assert {"MassSpringDamper", "TwoMassChain"} <= set(FMUS)
