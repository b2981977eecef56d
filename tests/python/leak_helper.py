"""Subprocess side of test_concurrency.py's memory test.

usage: python leak_helper.py MODEL ITERATIONS WARMUP

Loads the FMU library once, then ITERATIONS times: instantiate, set start values,
initialize, 10 doSteps, get/serialize/deserialize/free an FMU state, one rejected call
(so the error-logging path runs too), terminate, free.  Prints a JSON line with the
resident set size (from /proc/self/statm) after WARMUP iterations and at the end.
"""

import gc
import json
import os
import sys
from ctypes import c_double, c_uint

import fmu_support as fs

PAGE = os.sysconf("SC_PAGE_SIZE")


def rss_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * PAGE


def one(model, lib, i):
    inst = fs.Instance(model, f"{model.name}_leak_{i}", lib=lib)
    sv = fs.scene_values(model.name, "step" if model.name == "TwoMassChain" else "damped")
    inst.initialize(sv, tol=1e-8)
    for _ in range(10):
        inst.step(0.01)
    s = inst.get_state()
    blob = inst.serialize(s)
    inst.free_state(s)
    st, s2 = inst.deserialize(blob)
    assert st == fs.fmi2OK
    assert inst.set_state(s2) == fs.fmi2OK
    inst.free_state(s2)
    bad = inst.call("fmi2GetReal", (c_uint * 1)(99999), 1, (c_double * 1)())
    assert bad == fs.fmi2Error
    inst.ok("fmi2Terminate")
    inst.free()


def main(model_name, iterations, warmup):
    fs.RECORDER.keep = False  # count only: no Python-side growth from log records
    fs.ensure_logger()
    fs.AUTO_ENSURE_LOGGER = False
    model = fs.Model(model_name)
    lib = model.library()
    rss = {}
    for i in range(iterations):
        one(model, lib, i)
        if i + 1 == warmup:
            gc.collect()
            rss["warmup"] = rss_bytes()
    gc.collect()
    rss["end"] = rss_bytes()
    rss["log_lines"] = fs.RECORDER.count
    lib.freeLibrary()
    print(json.dumps(rss))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3])))
