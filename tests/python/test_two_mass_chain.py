"""TwoMassChain against the matrix exponential.

Error measure: for each state (x1, x2, v1, v2) max |FMU - exact| over the output grid,
divided by max |exact| of that state (error relative to its amplitude).
"""

from __future__ import annotations

import numpy as np
import pytest

import fmu_support as fs
from closed_form import tmc_energy, tmc_exact

STATES = ["x1", "x2", "v1", "v2"]

# Same reasoning as for MassSpringDamper: rtol 1e-10, <= 1e4 steps of <= 1e-3 s, global
# error at most a few hundred local errors -> 1e-7 of the amplitude.
DOPRI_TOL = 1e-10
DOPRI_BOUND = 1e-7

# Stiff scene (k2 = 1e6, c2 = 10): the relative mode rings at sqrt(2e6) = 1414 rad/s,
# ~225 periods before it decays (rate c2/(2 mu) = 10 1/s).  DOPRI5 is explicit, so it
# must resolve every one of those periods: with rtol 1e-6 each of the ~1e4 steps of the
# first second commits an error ~tol in phase and they accumulate (scipy's Dormand-Prince
# RK45 with the same rtol and max_step 1e-3 is off by 2.2e-5 of the amplitude).  The bound
# 5e-4 = 500 x tol allows for a different error norm/step controller but still catches a
# wrong stiffness or damping term (which gives O(1) errors).
STIFF_TOL = 1e-6
STIFF_BOUND = 5e-4

# RK4 at h = 1e-3: the faster mode is w = 10*sqrt((3+sqrt5)/2) = 16.2 rad/s,
# phase error ~ N (w h)^5 / 120 = 1e4 * 1.1e-9 / 120 = 9.3e-8 -> bound 5e-7.
RK4_BOUND = 5e-7


def errors(res, sv):
    t = res["time"]
    ex = tmc_exact(t, **sv)
    return {s: float(np.max(np.abs(res[s] - ex[:, i])) / np.max(np.abs(ex[:, i])))
            for i, s in enumerate(STATES)}


def _fmt(errs):
    return " ".join(f"{k}={v:.3e}" for k, v in errs.items())


@pytest.mark.parametrize("scene", ["release", "step"])
def test_dopri5_matches_expm(tmc, scene):
    sv = fs.scene_values(tmc.name, scene)
    res = fs.simulate(tmc, sv, tol=DOPRI_TOL, output_interval=1e-2)
    assert len(res) == 1001
    errs = errors(res, sv)
    print(f"METRIC tmc dopri5 {scene}: {_fmt(errs)}")
    for s, e in errs.items():
        assert e < DOPRI_BOUND, f"{scene} {s}: {e:.3e}"


def test_stiff_dopri5_matches_expm(tmc):
    sv = fs.scene_values(tmc.name, "stiff")
    res = fs.simulate(tmc, sv, tol=STIFF_TOL, output_interval=1e-2)
    for s in STATES:
        assert np.all(np.isfinite(res[s])), s
    errs = errors(res, sv)
    print(f"METRIC tmc dopri5 stiff (tol 1e-6): {_fmt(errs)}")
    for s, e in errs.items():
        assert e < STIFF_BOUND, f"stiff {s}: {e:.3e}"


def test_release_rk4_matches_expm(tmc):
    sv = fs.scene_values(tmc.name, "release")
    res = fs.simulate(tmc, sv, solver=fs.SOLVER_RK4, solver_step=1e-3, output_interval=1e-2)
    errs = errors(res, sv)
    print(f"METRIC tmc rk4 release: {_fmt(errs)}")
    for s, e in errs.items():
        assert e < RK4_BOUND, f"rk4 release {s}: {e:.3e}"


def test_energy_non_increasing_with_damping(tmc):
    sv = fs.scene_values(tmc.name, "release")
    res = fs.simulate(tmc, sv, tol=DOPRI_TOL, output_interval=1e-2)
    E = np.asarray(res["E"])
    E0 = tmc_energy(**sv)
    assert E[0] == pytest.approx(E0, rel=1e-15)
    # dE/dt = -c2 (v1 - v2)^2 <= 0 exactly.  Numerically E may wiggle by the integration
    # error (~rtol * E0 = 1e-10 E0 per sample); allow 1e-9 E0 per step.
    rises = np.diff(E)
    worst = float(np.max(rises) / E0)
    print(f"METRIC tmc release energy: E(10)/E0 = {E[-1] / E0:.4f}, largest rise {worst:.3e} E0")
    assert worst < 1e-9, f"energy rose by {worst:.3e} E0 in one output interval"
    # and it is really dissipated (exact value of E(10)/E0 computed from expm)
    ex = tmc_exact(np.array([10.0]), **sv)[0]
    E10 = tmc_energy(**{**sv, **dict(zip(STATES, ex))})
    assert E[-1] == pytest.approx(E10, rel=1e-6)
    assert E[-1] < 0.5 * E0


@pytest.mark.parametrize("scene", list(fs.TMC_SCENES))
def test_energy_output_formula(tmc, scene):
    """E = 1/2 m1 v1^2 + 1/2 m2 v2^2 + 1/2 k1 x1^2 + 1/2 k2 (x2 - x1)^2 (rounding only)."""
    sv = fs.scene_values(tmc.name, scene)
    res = fs.simulate(tmc, sv, tol=STIFF_TOL, output_interval=0.1)
    E = tmc_energy(**{**sv, **{s: res[s] for s in STATES}})
    assert float(np.max(np.abs(res["E"] - E)) / np.max(np.abs(E))) < 1e-12


def test_input_on_first_mass_only(tmc, instances):
    """F pushes m1: right after a short step from rest, v1 > 0 and v2 is still tiny."""
    sv = fs.scene_values(tmc.name, "step")
    inst = instances(tmc, "tmc_input").initialize(sv, tol=DOPRI_TOL)
    inst.step(1e-3)
    x1, x2, v1, v2 = inst.get_reals(STATES)
    ex = tmc_exact(np.array([inst.t]), **sv)[0]
    # v1 ~ F/m1 t = 1e-3; v2 only through the damper/spring: ~ c2/m2 t^2/2 ~ 1e-6
    assert v1 == pytest.approx(ex[2], rel=1e-8)
    assert v2 == pytest.approx(ex[3], rel=1e-6)
    assert 0 < v2 < 0.01 * v1
