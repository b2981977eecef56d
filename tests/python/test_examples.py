"""The examples/ scripts run in the test suite and do what they claim."""

from __future__ import annotations

import importlib.util
import math

import pytest

import fmu_support as fs

spec = importlib.util.spec_from_file_location("lqr_upright", fs.REPO / "examples" / "lqr_upright.py")
lqr_upright = importlib.util.module_from_spec(spec)
spec.loader.exec_module(lqr_upright)


@pytest.mark.parametrize("model, offset", [("CompoundPendulum", 0.3), ("DoublePendulum", 0.05)])
def test_lqr_keeps_the_pendulum_upright(model, offset, load_model):
    load_model(model)  # fails clearly when the FMU is missing
    deviation = lqr_upright.run(model, offset)
    print(f"METRIC {model} LQR from offset {offset} rad: max deviation over the last second {deviation:.3e}")
    # The closed loop is exponentially stable; after 7 s the state is back at the top
    # to well below a milliradian (a controller that fails lets it fall by ~π).
    assert math.isfinite(deviation) and deviation < 1e-3
