"""The hand-written C FMU of `scripts/bench-dostep` (benches/handwritten/fmu.c) is a faithful
comparator of ours: the same states and outputs after the same doSteps, the same refusals of
a bad step, through the same driver (benches/handwritten/driver.c). No timing is asserted.

Tolerance. Both FMUs take the same RK4 steps with the same step plan and stage arithmetic
(rk4.rs); MassSpringDamper, TwoMassChain and RigidBody also evaluate the right-hand side
operation for operation as ours, and agree bit for bit in practice. CompoundPendulum and
DoublePendulum differ in how the accelerations are formed (the floors' division and Cramer's
rule against our generated M and rhs, solved by LDLᵀ with a reciprocal): an ulp or two of
the state per right-hand side, i.e. ~1e-16 · |x| per step, which adds up to ~1e-13 · |x|
after 1000 steps of these non-chaotic motions (the small default swings). 1e-12 · max(1, |x|)
leaves an order of magnitude of room and still catches any difference of equations,
parameters, step plan or projection (those show at 1e-6 or more after one step of 1e-3).

FMUs come from $MBFMU_FMU_DIR or target/fmu; a missing one fails the test (conftest.py).
"""

from __future__ import annotations

import importlib.util
import pathlib
import shutil
import sys
from importlib.machinery import SourceFileLoader

import pytest

import fmu_support as fs

REPO = pathlib.Path(__file__).resolve().parents[2]
STEPS = 1000
RTOL = 1e-12


def _load_script():
    path = REPO / "scripts" / "bench-dostep"
    loader = SourceFileLoader("bench_dostep", str(path))
    spec = importlib.util.spec_from_loader("bench_dostep", loader)
    module = importlib.util.module_from_spec(spec)
    sys.modules["bench_dostep"] = module  # (its dataclasses look their module up)
    loader.exec_module(module)
    return module


bench = _load_script()


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    if not (shutil.which("gcc") or shutil.which("cc")):
        pytest.fail("no C compiler (gcc/cc) for benches/handwritten", pytrace=False)
    build_dir = tmp_path_factory.mktemp("bench-dostep")
    return build_dir, bench.build(build_dir)


def _targets(system, built):
    build_dir, _ = built
    try:
        return bench.targets(system, fs.fmu_dir(), build_dir)
    except FileNotFoundError as e:
        pytest.fail(str(e), pytrace=False)


def _assert_close(ours: dict, c: dict, names, what: str):
    for name in names:
        scale = max(1.0, abs(ours[name]))
        assert abs(ours[name] - c[name]) <= RTOL * scale, (
            f"{what} {name}: ours {ours[name]!r}, C {c[name]!r}"
        )


@pytest.mark.parametrize("system", bench.SYSTEMS)
def test_c_fmu_agrees_with_ours(system, built):
    _, driver = built
    ours, c = _targets(system, built)
    vo = bench.count_run(driver, ours, STEPS)
    vc = bench.count_run(driver, c, STEPS)
    assert vo["t"] == vc["t"]
    # The states moved (the comparison is not of two unchanged start values).
    start = bench.count_run(driver, c, 0)
    assert any(abs(vc[n] - start[n]) > 1e-3 for n in c.states)
    _assert_close(vo, vc, ours.states, f"{system}: state")
    _assert_close(vo, vc, ours.outputs, f"{system}: output")


@pytest.mark.parametrize("system", bench.SYSTEMS)
def test_c_fmu_refuses_a_bad_step_as_ours_does(system, built):
    """h = 0, h < 0, h = NaN or ∞, a current time 1e-6 ahead or a step behind, or NaN: each
    is refused with fmi2Error, the instance keeps its state and time, and the next good
    step is taken: the state equals that of 11 good steps."""
    _, driver = built
    ours, c = _targets(system, built)
    statuses, after = bench.bad_run(driver, c)
    refused = {"h_zero", "h_negative", "h_nan", "h_inf", "time_ahead", "time_behind", "time_nan"}
    assert set(statuses) == refused | {"good"}
    assert all(statuses[k] == "Error" for k in refused), statuses
    assert statuses["good"] == "OK"
    assert after == bench.count_run(driver, c, 11)
    ours_statuses, _ = bench.bad_run(driver, ours)
    assert ours_statuses == statuses


def test_script_quick_writes_the_columns(built, tmp_path):
    """`scripts/bench-dostep --quick` runs both FMUs of every system and writes the CSV of
    the agreed columns (values not asserted but the state differences)."""
    build_dir, _ = built
    out = tmp_path / "dostep_c.csv"
    for system in bench.SYSTEMS:
        _targets(system, built)  # a missing FMU fails here, as the other tests
    assert bench.main(["--quick", "--build-dir", str(build_dir), "--csv", str(out)]) == 0
    rows = list(bench.csv.DictReader(out.open()))
    assert [r["system"] for r in rows] == list(bench.SYSTEMS)
    assert list(rows[0].keys()) == bench.COLUMNS
    for r in rows:
        assert float(r["ours_ns"]) > 0 and float(r["c_ns"]) > 0
        assert float(r["max_state_difference"]) <= 1e-12
