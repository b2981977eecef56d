"""Random call sequences through the C API of every FMU in the FMU folder.

random_calls.py makes the calls and states the oracles (O1 crash or hang, O2 invalid
arguments refused and valid ones accepted, O3 finite values after success, O4 returned
status agrees with the logged lines, O5 FMU states freed with their instance). Each FMU's
batch runs in a subprocess (two at a time), with fixed seeds: a failure names its seed and
the command that replays it. MBFMU_RANDOM_SEQUENCES / MBFMU_RANDOM_CALLS change how many
sequences of how many calls each FMU gets.
"""

from __future__ import annotations

import os
import time

import pytest

import fmu_support as fs
import random_calls as rc

FMUS = sorted(p.stem for p in fs.fmu_dir().glob("*.fmu"))
SEQUENCES = int(os.environ.get("MBFMU_RANDOM_SEQUENCES", "150"))
CALLS = int(os.environ.get("MBFMU_RANDOM_CALLS", "250"))


@pytest.fixture(scope="module")
def outcomes(request):
    """The batches of the FMUs this session's selected tests ask for, run once."""
    wanted = sorted({item.callspec.params["name"] for item in request.session.items
                     if item.module is request.module and hasattr(item, "callspec")})
    t0 = time.monotonic()
    out = rc.run_batches(wanted, SEQUENCES, CALLS)
    calls = sum(r["calls"] for o in out.values() for r in o["results"])
    print(f"METRIC random calls: {len(wanted)} FMUs x {SEQUENCES} sequences of up to {CALLS} "
          f"calls, {calls} calls in {time.monotonic() - t0:.1f} s")
    return out


def test_the_fmu_folder_has_fmus():
    assert FMUS, f"no FMU in {fs.fmu_dir()}"


@pytest.mark.parametrize("name", FMUS)
def test_random_call_sequences(name, outcomes):
    failures, report = rc.describe(name, outcomes[name], CALLS)
    print(f"METRIC {report.splitlines()[0]} ({outcomes[name]['seconds']:.1f} s)")
    if failures:
        pytest.fail(report, pytrace=False)


@pytest.mark.parametrize("name", FMUS)
def test_free_instance_frees_outstanding_states(name, outcomes):
    leak = outcomes[name]["leak"]
    if leak is None:
        pytest.fail(f"{name}: the leak check did not run: {outcomes[name]['crashes']}",
                    pytrace=False)
    print(f"METRIC {name} heap growth over {leak['cycles']} instances freed with 3 FMU states "
          f"outstanding: {leak['growth_states_left']} bytes (states freed first: "
          f"{leak['growth_states_freed']}; bound {leak['bound']})")
    assert leak["growth_states_freed"] < leak["bound"], (
        f"{name}: the heap grows even when every FMU state is freed ({leak}): the "
        f"measurement is not usable")
    assert leak["growth_states_left"] < leak["bound"], (
        f"{name}: fmi2FreeInstance leaves the FMU states outstanding allocated: the heap grew "
        f"by {leak['growth_states_left']} bytes over {leak['cycles']} instances, "
        f"{leak['growth_states_left'] / (3 * leak['cycles']):.0f} bytes per state "
        f"(serialized size {leak['state_bytes']})")
