"""Many instances on many threads, and instantiate/free in a loop without leaking."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import fmu_support as fs

N_INSTANCES = 100
N_THREADS = 8
N_STEPS = 200


def _run_one(model, lib, i):
    """Instance i: its own start value, solver and input change, so a mix-up between
    instances would show.  Returns the bit patterns of every value every 20 steps."""
    inst = fs.Instance(model, f"{model.name}_conc_{i:03d}", lib=lib)
    try:
        sv = fs.scene_values(model.name, "release" if model.name == "TwoMassChain" else "damped")
        state0 = model.state_names[0]
        sv[state0] = 0.05 + 1e-3 * i
        sv["solver"] = fs.SOLVER_RK4 if i % 2 else fs.SOLVER_DOPRI5
        inst.initialize(sv, tol=1e-10)
        out = [inst.snapshot()]
        for k in range(N_STEPS):
            if k == N_STEPS // 2:
                inst.set(F=0.01 * i)
            inst.step(0.01)
            if k % 20 == 19:
                out.append(inst.snapshot())
        return out
    finally:
        inst.free()


def test_threads_give_serial_results(model, logs):
    lib = model.library()
    try:
        mark = logs.mark()
        serial = [_run_one(model, lib, i) for i in range(N_INSTANCES)]
        with ThreadPoolExecutor(max_workers=N_THREADS) as pool:
            parallel = list(pool.map(lambda i: _run_one(model, lib, i), range(N_INSTANCES)))
        for i in range(N_INSTANCES):
            assert parallel[i] == serial[i], f"instance {i} differs when run on {N_THREADS} threads"
        # instances really differ from each other (guards against a shared global state)
        assert len({tuple(r[-1]) for r in serial}) == N_INSTANCES
        assert logs.since(mark) == [], "no call here should have logged anything"
    finally:
        lib.freeLibrary()


def test_instantiate_free_loop_does_not_leak(model):
    # 2000 iterations; the RSS after the first 200 is the baseline (allocator arenas,
    # lazily-initialised statics, Python caches are warm by then).  A leak of even 1 kB per
    # iteration would add 1.8 MB, so the bound is 2 MB.
    proc = subprocess.run(
        [sys.executable, str(fs.HERE / "leak_helper.py"), model.name, "2000", "200"],
        capture_output=True, text=True, timeout=600, cwd=str(fs.HERE),
        env=dict(os.environ, MBFMU_FMU_DIR=str(model.path.parent)),
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-4000:]
    rss = json.loads(proc.stdout.strip().splitlines()[-1])
    growth = rss["end"] - rss["warmup"]
    print(f"METRIC {model.name} RSS after 200: {rss['warmup'] / 2**20:.2f} MiB, after 2000: "
          f"{rss['end'] / 2**20:.2f} MiB, growth {growth / 1024:.1f} KiB, log lines {rss['log_lines']}")
    assert rss["log_lines"] == 2000, "one log line per rejected call"
    assert growth < 2 * 2**20, f"RSS grew by {growth / 2**20:.2f} MiB over 1800 instantiate/free cycles"
