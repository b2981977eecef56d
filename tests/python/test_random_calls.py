"""Random call sequences through the C API of every FMU in the FMU folder, on
Co-Simulation and Model Exchange instances (about a third are Model Exchange ones).

random_calls.py makes the calls and states the oracles (O1 crash or hang, O2 invalid
arguments refused and valid ones accepted, O3 finite values after success, O4 returned
status agrees with the logged lines, O5 FMU states freed with their instance). Each FMU's
batch runs in a subprocess (two at a time), with fixed seeds: a failure names its seed and
the command that replays it. MBFMU_RANDOM_SEQUENCES / MBFMU_RANDOM_CALLS change how many
sequences of how many calls each FMU gets.
"""

from __future__ import annotations

import os
import struct
import time
import zlib
from ctypes import c_double, c_int, c_uint

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


# -- Issue 24: a doStep after extreme accepted values, restored blobs with a refused solver --

WORK_BOUND = 5_000_000  # mbfmu::fmi::DOSTEP_WORK, state-component evaluations per doStep
EXTREME_SEEDS = int(os.environ.get("MBFMU_EXTREME_SEEDS", "6"))


def _extreme(v, rng):
    """An accepted value far from the start: an end of [min, max], or the start (or nominal)
    times 10^±6 where the range is open."""
    s = v.start if v.start not in (None, 0.0) else v.nominal
    x = s * 10 ** rng.choice((-6, -3, 3, 6)) * rng.choice((1, 1, -1))
    if v.min is not None and (rng.random() < 0.3 or x < v.min):
        x = v.min if v.min != 0.0 else (v.max if v.max is not None else 1e-6)
    if v.max is not None and (rng.random() < 0.3 or x > v.max):
        x = v.max
    return x


def _work_lines(mark):
    return [int(r.message.split("work ")[1].split()[0]) for r in fs.RECORDER.since(mark)
            if "fmi2DoStep: work " in r.message]


@pytest.mark.parametrize("name", FMUS)
def test_a_do_step_after_extreme_values_stays_within_the_work_bound(name):
    """Every FMU, seeds 0..EXTREME_SEEDS: parameters and inputs set to extreme accepted values,
    a random solver it accepts, a tight or loose tolerance and a small solver_step, then
    doSteps of 0.5 s with logAll on. Each doStep reports its work (counted, not timed); it
    must not pass the bound by more than one step's work (the bound is checked before each
    step). RK4 takes the fixed-step path, whose plan solver_max_steps bounds before any
    work: it logs no work line, and its plan is checked instead."""
    import random

    model = fs.Model.get(name)
    spec = rc.Spec(model)
    n = len(spec.states)
    one_step = n * (6 * n + 3 * 50 + 12)
    worst = 0
    for seed in range(EXTREME_SEEDS):
        rng = random.Random(f"{name}-extreme-{seed}")
        inst = model.instance(f"{name}_extreme_{seed}", logging_on=True)
        try:
            inst.ok("fmi2SetDebugLogging", 1, 0, None)
            inst.setup(tol=10 ** rng.uniform(-13, -3))
            values = [v for v in spec.reals if v.causality in ("parameter", "input")
                      and v.name != "solver_step" and v.variability != "constant"]
            for v in rng.sample(values, k=min(len(values), rng.randint(1, 3))):
                inst.call("fmi2SetReal", (c_uint * 1)(v.vr), 1, (c_double * 1)(_extreme(v, rng)))
            inst.set(solver_step=10 ** rng.uniform(-5, -3))
            solver = rng.randint(1, 12)
            inst.call("fmi2SetInteger", (c_uint * 1)(model.vr["solver"]), 1, (c_int * 1)(solver))
            if inst.call("fmi2EnterInitializationMode") != 0:
                continue
            if inst.call("fmi2ExitInitializationMode") not in (0, 1):
                continue  # an infeasible combination, refused with its line
            solver = inst.get("solver")
            for _ in range(2):
                mark = fs.RECORDER.mark()
                st = inst.do_step(0.5)
                work = _work_lines(mark)
                if solver == 1:
                    assert not work or work[0] <= 4 * n * int(inst.get("solver_max_steps"))
                else:
                    assert len(work) == 1, f"{name} seed {seed}: no work line ({solver=})"
                    worst = max(worst, work[0])
                    assert work[0] <= WORK_BOUND + one_step, (
                        f"{name} seed {seed} solver {solver}: a doStep did {work[0]} "
                        f"state-component evaluations, more than the bound {WORK_BOUND}")
                if st != 0:
                    break
        finally:
            inst.free()
    print(f"METRIC {name}: most work in one doStep after extreme values: {worst} "
          f"state-component evaluations (bound {WORK_BOUND})")


def _blob_fields(blob: bytes, method: int, solver_step: float):
    """Offsets of the method code (found before solver_step) and the machine state (the
    last u32 before the CRC-32) in a serialized FMU state."""
    at = blob.find(struct.pack("<Id", method, solver_step))
    assert at > 0 and blob.find(struct.pack("<Id", method, solver_step), at + 1) < 0
    return at, len(blob) - 8


MACHINE_CODES = {"Instantiated": 1, "InitializationMode": 2, "StepComplete": 4,
                 "StepFailed": 8, "Terminated": 16, "Error": 32}


@pytest.mark.parametrize("name", FMUS)
def test_a_restored_blob_with_a_refused_solver_is_refused_in_every_machine_state(name):
    """The solvers the FMU refuses with its start values (fmi2SetInteger before
    initialisation), written into blobs of a fresh, an initialising, a stepping and a
    terminated instance with a valid CRC-32 and each machine state: fmi2DeSerializeFMUstate
    refuses every one with fmi2Error and a line."""
    model = fs.Model.get(name)
    probe = model.instance(f"{name}_probe")
    refused = []
    try:
        for code in range(1, 13):
            st = probe.call("fmi2SetInteger", (c_uint * 1)(model.vr["solver"]), 1,
                            (c_int * 1)(code))
            if st != 0:
                refused.append(code)
    finally:
        probe.free()
    if not refused:
        pytest.skip(f"{name} accepts every solver")
    inst = model.instance(f"{name}_blobs")
    blobs = []
    try:
        inst.setup(tol=1e-8)
        blobs.append(inst.serialize(inst.get_state()))
        inst.ok("fmi2EnterInitializationMode")
        blobs.append(inst.serialize(inst.get_state()))
        inst.ok("fmi2ExitInitializationMode")
        inst.step(0.01)
        blobs.append(inst.serialize(inst.get_state()))
        inst.ok("fmi2Terminate")
        blobs.append(inst.serialize(inst.get_state()))
        method, step = inst.get("solver"), inst.get("solver_step")
        tried = 0
        for blob in blobs:
            at_method, at_machine = _blob_fields(blob, method, step)
            for code in refused:
                for machine, mcode in MACHINE_CODES.items():
                    b = bytearray(blob)
                    b[at_method:at_method + 4] = struct.pack("<I", code)
                    b[at_machine:at_machine + 4] = struct.pack("<I", mcode)
                    b[-4:] = struct.pack("<I", zlib.crc32(bytes(b[:-4])))
                    mark = fs.RECORDER.mark()
                    st, ptr = inst.deserialize(bytes(b))
                    lines = fs.RECORDER.since(mark)
                    assert st == 3 and not ptr.value, (
                        f"{name}: a blob with solver {code} (refused) in machine state "
                        f"{machine} was accepted")
                    assert len(lines) == 1, lines
                    tried += 1
    finally:
        inst.free()
    print(f"METRIC {name}: {tried} blobs with a refused solver ({refused}) refused")


# -- FMI 3.0: the same oracles through the fmi3 functions (random_calls3.py) --

FMU3_DIR = fs.fmu_dir().with_name(fs.fmu_dir().name + "3")
FMUS3 = sorted(p.stem for p in FMU3_DIR.glob("*.fmu"))
SEQUENCES3 = int(os.environ.get("MBFMU_RANDOM_SEQUENCES3", "40"))
CALLS3 = int(os.environ.get("MBFMU_RANDOM_CALLS3", "150"))


@pytest.mark.parametrize("name", FMUS3)
def test_random_fmi3_call_sequences(name):
    """O1 (a crash or a hang of the subprocess), O2, O3, O4 of random_calls3.py, on
    SEQUENCES3 sequences of up to CALLS3 calls of the FMI 3.0 twin of each FMU (at most
    MBFMU_RANDOM_BUDGET3 = 20 s of them per FMU after the first 10: the stiff
    AndrewsSqueezer's doSteps are slow)."""
    import json
    import subprocess
    import sys

    cmd = [sys.executable, str(fs.HERE / "random_calls3.py"), name, str(FMU3_DIR), "0",
           str(SEQUENCES3), str(CALLS3)]
    t0 = time.monotonic()
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    except subprocess.TimeoutExpired:
        pytest.fail(f"{name}: FMI 3.0 random calls hung (O1): {' '.join(cmd)}", pytrace=False)
    if done.returncode != 0:
        pytest.fail(f"{name}: FMI 3.0 random calls crashed (O1, exit {done.returncode}): "
                    f"{done.stderr[-3000:]}\nreplay: {' '.join(cmd)}", pytrace=False)
    out = json.loads(done.stdout.strip().splitlines()[-1])
    print(f"METRIC FMI3 random calls {name}: {out['sequences']} sequences, {out['calls']} calls, "
          f"{len(out['failures'])} failures ({time.monotonic() - t0:.1f} s)")
    if out["failures"]:
        shown = "\n".join(f"seed {f['seed']} {f['message']}" for f in out["failures"][:3])
        pytest.fail(f"{name}: {len(out['failures'])} of {out['sequences']} FMI 3.0 sequences "
                    f"failed:\n{shown}\nreplay: {' '.join(cmd[:3])} <seed> 1 {CALLS3}",
                    pytrace=False)
