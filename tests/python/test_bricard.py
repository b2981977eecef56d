"""The Bricard FMU (IFToMM A04) run by fmpy against the independent oracle (bricard_oracle.py:
Pinocchio's tree, the null-space method, DOP853 at 1e-12 with projection; checked by two other
routes in test_bricard_oracle.py). The library publishes no A04 reference file (docs/
iftomm-sources.md): the oracle is the reference here.

The FMU's default experiment (DOPRI5, rtol 1e-10, doSteps of 0.05 s, 10 s) must give P3 within
1e-6 m of the oracle at every communication point, the energy to 1e-9 relative and the five loop
residuals at 1e-12 m; the FMU's redundancy (five residuals, rank four) is declared, and RATTLE,
whose Newton matrix it makes singular, is refused with one line.
"""

from __future__ import annotations

from ctypes import c_int, c_uint

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu

import bricard_oracle as bo
import fmu_support as fs

RESIDUALS = ["residual_J6_x", "residual_J6_y", "residual_J6_z",
             "residual_J6_axis_y", "residual_J6_axis_z"]


@pytest.fixture(scope="module")
def run():
    path = str(fs.fmu_file("Bricard"))
    md = read_model_description(path)
    de = md.defaultExperiment
    result = simulate_fmu(path, stop_time=float(de.stopTime), output_interval=float(de.stepSize),
                          output=["P3_x", "P3_y", "P3_z", "E"] + RESIDUALS)
    return md, result


def test_the_default_experiment_is_the_benchmarks(run):
    md, result = run
    de = md.defaultExperiment
    assert (float(de.stopTime), float(de.tolerance), float(de.stepSize)) == (10.0, 1e-10, 0.05)
    outputs = [v.name for v in md.modelVariables if v.causality == "output"]
    for name in ["P3_x", "P3_y", "P3_z", "E"] + RESIDUALS:
        assert name in outputs


def test_p3_follows_the_oracle_within_1e_6(run):
    _, result = run
    oracle = bo.reference(result["time"])
    p3 = np.column_stack([result["P3_x"], result["P3_y"], result["P3_z"]])
    error = np.abs(p3 - oracle["P3"]).max()
    print(f"METRIC Bricard (A04) default experiment: P3 within {error:.1e} m of the oracle over 10 s")
    assert error < 1e-6
    # It moved: P3 reaches the mirrored cube (x = −1) half a period in.
    assert p3[:, 0].min() < -0.999


def test_the_energy_and_the_loop_are_kept(run):
    _, result = run
    e = result["E"]
    drift = np.abs(e - e[0]).max() / abs(e[0])
    residual = max(np.abs(result[n]).max() for n in RESIDUALS)
    print(f"METRIC Bricard (A04): |E - E0|/|E0| <= {drift:.1e}, loop residuals <= {residual:.1e} m")
    assert e[0] == pytest.approx(bo.E_0, abs=1e-12)
    assert drift < 1e-9
    assert residual < 1e-12


def test_rattle_is_refused_with_one_line():
    model = fs.Model.get("Bricard")
    inst = model.instance("bricard_rattle")
    try:
        inst.setup(tol=1e-10)
        mark = fs.RECORDER.mark()
        st = inst.call("fmi2SetInteger", (c_uint * 1)(model.vr["solver"]), 1, (c_int * 1)(12))
        assert st == 3  # fmi2Error
        lines = [r.message for r in fs.RECORDER.since(mark, "bricard_rattle")]
        assert len(lines) == 1 and "non-redundant holonomic constraints" in lines[0], lines
    finally:
        inst.free()
