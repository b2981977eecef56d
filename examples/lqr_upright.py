"""LQR from the exported linearisation keeps a pendulum upright in an fmpy co-simulation.

1. `mbfmu linearize MODEL --at <upright> --format json` gives the exact A, B at the top.
2. python-control designs u = -K (x - x_top) with `lqr(A, B, Q, R)`.
3. The *nonlinear* FMU runs in a co-simulation loop driven from Python (fmpy's FMU2Slave):
   at every communication point the controller reads the states and sets the torques,
   starting from an offset from the upright.

Usage: python examples/lqr_upright.py [CompoundPendulum|DoublePendulum] [--offset RAD]
Prints the final deviation; exits non-zero if the pendulum did not stay up.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import pathlib
import subprocess
import sys

import control
import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

REPO = pathlib.Path(__file__).resolve().parent.parent
TARGET = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))

# The upright operating point of each system (angles from the downward vertical).
UPRIGHT = {
    "CompoundPendulum": {"theta": math.pi, "theta_dot": 0.0},
    "DoublePendulum": {"theta1": math.pi, "phi": math.pi, "theta1_dot": 0.0, "phi_dot": 0.0},
}


def linearization(model: str, point: dict) -> dict:
    args = [str(TARGET / "release" / "mbfmu"), "linearize", model, "--format", "json"]
    for name, value in point.items():
        args += ["--at", f"{name}={value!r}"]
    return json.loads(subprocess.run(args, check=True, capture_output=True, text=True).stdout)


def design(lin: dict) -> np.ndarray:
    n, m = lin["n"], lin["m"]
    A = np.array(lin["A"]).reshape(n, n)
    B = np.array(lin["B"]).reshape(n, m)
    assert np.max(np.linalg.eigvals(A).real) > 0, "the upright should be unstable"
    K, _, poles = control.lqr(A, B, np.eye(n), 0.1 * np.eye(m))
    assert np.all(np.real(poles) < 0)
    return np.asarray(K)


def run(model: str, offset: float, stop: float = 8.0, h: float = 1e-2) -> float:
    """Co-simulate the nonlinear FMU under LQR; returns max |x - x_top| over the last second."""
    point = UPRIGHT[model]
    lin = linearization(model, point)
    K = design(lin)
    states, inputs = lin["states"], lin["inputs"]
    x_top = np.array([point[s] for s in states])

    fmu = TARGET / "fmu" / f"{model}.fmu"
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="lqr")
    slave.instantiate()
    slave.setupExperiment(tolerance=1e-8, startTime=0.0)
    start = dict(point)
    start[states[0]] += offset
    slave.setReal([vr[s] for s in start], list(start.values()))
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    t, tail = 0.0, []
    state_vrs = [vr[s] for s in states]
    for i in range(int(round(stop / h))):
        x = np.array(slave.getReal(state_vrs))
        u = -K @ (x - x_top)
        slave.setReal([vr[n] for n in inputs], list(u))
        slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t = (i + 1) * h
        if t > stop - 1.0:
            tail.append(np.max(np.abs(np.array(slave.getReal(state_vrs)) - x_top)))
    slave.terminate()
    slave.freeInstance()
    return float(max(tail))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("model", nargs="?", default="CompoundPendulum", choices=sorted(UPRIGHT))
    ap.add_argument("--offset", type=float, default=0.1)
    args = ap.parse_args()
    dev = run(args.model, args.offset)
    print(f"{args.model}: offset {args.offset} rad, max deviation over the last second {dev:.3e}")
    return 0 if dev < 1e-3 else 1


if __name__ == "__main__":
    sys.exit(main())
