"""The adaptive methods' dense output, seen from fmpy: the communication grid does not
steer the integration.

DOPRI5 (2), DOP853 (9) and RADAU5 (10) run ahead of the communication points and read
each point from their continuous extension, so two grids give the same steps: where the
grids meet (1/8 s and 1/64 s are exact in binary, so they meet exactly) the outputs are
the same bits. Had a method landed on every point, its steps, and so the bits, would
differ between the grids. Both grids are also checked against the closed form.
"""

from __future__ import annotations

import numpy as np
import pytest

import fmu_support as fs
from closed_form import msd_exact

SOLVER_DOP853 = 9
SOLVER_RADAU5 = 10

# Bounds on the worst error relative to the amplitude (0.1 m), MassSpringDamper/damped
# over 10 s at tol 1e-10. DOPRI5 and DOP853: their interpolants (orders 4 and 7) are as
# accurate as the steps, whose global error is a few hundred local errors; measured
# 2.6e-10 and 2.7e-10, bound 2e-9. RADAU5's points between steps come from its order-3
# collocation polynomial, held to radau5.f's local tolerance 0.1 tol^(2/3) = 2.2e-8
# rather than to the global error; measured 6.2e-9, bound 5e-8.
CASES = [
    (fs.SOLVER_DOPRI5, 2e-9),
    (SOLVER_DOP853, 2e-9),
    (SOLVER_RADAU5, 5e-8),
]


def rel_err(got, want):
    return float(np.max(np.abs(np.asarray(got) - want)) / np.max(np.abs(want)))


@pytest.mark.parametrize("solver,bound", CASES, ids=["DOPRI5", "DOP853", "RADAU5"])
def test_points_do_not_depend_on_the_grid(msd, solver, bound):
    sv = fs.scene_values(msd.name, "damped")
    coarse = fs.simulate(msd, sv, solver=solver, tol=1e-10, output_interval=1 / 8)
    fine = fs.simulate(msd, sv, solver=solver, tol=1e-10, output_interval=1 / 64)
    assert len(coarse["time"]) == 81 and len(fine["time"]) == 641
    met = fine[::8]
    assert np.array_equal(met["time"], coarse["time"])
    for name in ("x", "v"):
        same = np.array_equal(met[name].view(np.uint64), coarse[name].view(np.uint64))
        assert same, f"solver {solver}: {name} differs where the grids meet"
    for res in (coarse, fine):
        x, v = msd_exact(res["time"], **sv)
        ex, ev = rel_err(res["x"], x), rel_err(res["v"], v)
        print(f"METRIC dense solver {solver} grid {len(res['time'])}: x {ex:.2e} v {ev:.2e}")
        assert ex < bound and ev < bound, f"solver {solver}: {ex:.2e} {ev:.2e}"
