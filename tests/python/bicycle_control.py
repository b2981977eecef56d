"""Gain-scheduled LQR steering of the NonlinearBicycle FMU, shared by
test_bicycle_control.py and docs/bicycle/control.py (the plot).

Design: at each speed v of a small grid, ``mbfmu linearize NonlinearBicycle --at
rear_wheel_dot=-v/rR --keep y,yaw,roll,steer,roll_dot,steer_dot`` gives A(v), B(v) in
the independent states that matter for steering (x and the wheel angles are ignorable,
the speed is held by the operating point); LQR on the steer torque T_delta alone (the
column of B for T_phi is not used, T_phi stays 0) gives K(v), a 1x6 row.

Co-simulation: fmpy's low-level FMI 2.0 calls (fmu_support.Instance: fmi2Instantiate,
fmi2SetupExperiment, start values, fmi2Enter/ExitInitializationMode, then per
communication step fmi2GetReal of the outputs -> T_delta = -K(speed) (x - x_ref(t)) ->
fmi2SetReal(T_delta) -> fmi2DoStep). K(speed) interpolates the grid's gains entry by
entry at the FMU's measured ``speed`` output (clamped at the grid's ends).
"""

from __future__ import annotations

import json
import os
import pathlib
import subprocess
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.linalg

import fmu_support as fs

MODEL = "NonlinearBicycle"
RR = 0.3  # rear wheel radius of the benchmark (v = -rR * rear_wheel_dot)
STATES = ("y", "yaw", "roll", "steer", "roll_dot", "steer_dot")
# The speed grid of the schedule: around the operating speeds (2 m/s, below the weave
# speed 4.29 m/s where the uncontrolled bicycle falls).
SPEED_GRID = (1.5, 2.0, 2.5, 3.0)
# Bryson's rule: the acceptable excursion of each state and of the steer torque. The cost
# is mostly the lateral offset against the torque; lean and steer are weighted lightly
# (chosen on the linear model for: |T_delta| < 10 N.m from a lean of 0.1 rad, the lean
# below 1e-3 rad within ~5.5 s, a 1.5 m lane change settled ~4 s after it ends).
STATE_SCALE = dict(y=0.1, yaw=1.0, roll=1.0, steer=1.0, roll_dot=1.0, steer_dot=10.0)
TORQUE_SCALE = 0.3  # N.m
STEP = 0.01  # s, communication step
# The scenario of the test and the plot: 2 m/s, lean 0.1 rad at t = 0 (recovery over
# 0 … 6 s), then y_ref from 0 to 1.5 m over 6 … 10 s, then 5 s to settle.
V = 2.0  # m/s
ROLL0 = 0.1  # rad
SHIFT, LANE_START, LANE_TIME, STOP = 1.5, 6.0, 4.0, 15.0
TOL = 1e-8  # DOPRI5 tolerance inside doStep


def cli() -> pathlib.Path:
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", fs.REPO / "target"))
    exe = target / "release" / "mbfmu"
    assert exe.is_file(), f"{exe} missing: build with `cargo run --release --bin mbfmu -- build --all`"
    return exe


def linearize(v: float) -> tuple[np.ndarray, np.ndarray]:
    """A (6x6) and the T_delta column of B (6x1) at upright straight running at v m/s."""
    out = subprocess.run(
        [str(cli()), "linearize", MODEL, "--at", f"rear_wheel_dot={-float(v) / RR!r}", "--at", "roll=0",
         "--keep", ",".join(STATES), "--format", "json"],
        capture_output=True, text=True, check=True,
    )
    lin = json.loads(out.stdout)
    assert lin["states"] == list(STATES), lin["states"]
    assert lin["inputs"] == ["T_phi", "T_delta"], lin["inputs"]
    a = np.array(lin["A"], dtype=float)
    b = np.array(lin["B"], dtype=float)[:, [1]]
    return a, b


def lqr(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """K minimising ∫ xᵀQx + uᵀRu for ẋ = Ax + Bu, u = -Kx (Bryson weights)."""
    q = np.diag([1.0 / STATE_SCALE[s] ** 2 for s in STATES])
    r = np.array([[1.0 / TORQUE_SCALE**2]])
    p = scipy.linalg.solve_continuous_are(a, b, q, r)
    return np.linalg.solve(r, b.T @ p)


@dataclass
class Schedule:
    speeds: np.ndarray  # grid, increasing
    a: list[np.ndarray]
    b: list[np.ndarray]
    k: np.ndarray  # len(speeds) x 6

    @classmethod
    def design(cls, speeds=SPEED_GRID) -> "Schedule":
        a, b, k = [], [], []
        for v in speeds:
            av, bv = linearize(v)
            a.append(av)
            b.append(bv)
            k.append(lqr(av, bv)[0])
        return cls(np.asarray(speeds, dtype=float), a, b, np.array(k))

    def gain(self, v: float) -> np.ndarray:
        """K(v): each entry interpolated linearly over the grid, held beyond its ends."""
        return np.array([np.interp(v, self.speeds, self.k[:, j]) for j in range(self.k.shape[1])])


def lane_change(shift: float, t0: float, duration: float) -> Callable[[float], float]:
    """y_ref(t): 0 before t0, `shift` after t0 + duration, a smooth (C²) quintic between."""

    def y_ref(t: float) -> float:
        s = min(max((t - t0) / duration, 0.0), 1.0)
        return shift * s**3 * (10.0 - 15.0 * s + 6.0 * s * s)

    return y_ref


@dataclass
class Run:
    t: np.ndarray
    x: dict[str, np.ndarray]  # the STATES plus speed, T_delta, y_ref
    status: int  # of the last fmi2DoStep (fmi2OK, or fmi2Discard when it fell)
    messages: list[str] = field(default_factory=list)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.x[name]


def simulate(model: fs.Model, v: float, roll0: float, stop: float, schedule: Schedule | None,
             y_ref: Callable[[float], float] | None = None, roll_abort: float = np.inf,
             h: float = STEP) -> Run:
    """Co-simulate from upright straight running at v m/s with lean roll0.

    With ``schedule`` None, T_delta stays 0 (the uncontrolled bicycle). The run ends at
    `stop`, at a doStep that does not return OK (the FMU's fmi2Discard when |roll| reaches
    roll_max), or once |roll| > roll_abort."""
    names = list(STATES) + ["speed"]
    inst = model.instance(f"bicycle_control_{id(schedule) if schedule else 'open'}")
    mark = fs.RECORDER.mark()
    try:
        inst.setup(tol=TOL, start=0.0, stop=stop)
        inst.set(rear_wheel_dot=-v / RR, roll=roll0, solver=fs.SOLVER_DOPRI5)
        inst.ok("fmi2EnterInitializationMode")
        inst.ok("fmi2ExitInitializationMode")
        ts, rows = [], []
        status = fs.fmi2OK
        n = int(round(stop / h))
        for i in range(n + 1):
            t = i * h
            vals = inst.get_reals(names)
            state = np.array(vals[:6])
            ref = y_ref(t) if y_ref else 0.0
            if schedule is None:
                torque = 0.0
            else:
                err = state.copy()
                err[0] -= ref
                torque = float(-schedule.gain(vals[6]) @ err)
            ts.append(t)
            rows.append(vals + [torque, ref])
            if i == n or abs(state[2]) > roll_abort:
                break
            inst.set(T_delta=torque)
            status = inst.do_step(h, t)
            if status != fs.fmi2OK:
                break
        data = np.array(rows)
        cols = names + ["T_delta", "y_ref"]
        msgs = [r.message for r in fs.RECORDER.since(mark, inst.name)]
        return Run(np.array(ts), {c: data[:, j] for j, c in enumerate(cols)}, status, msgs)
    finally:
        inst.free()


def closed_loop_eigenvalues(schedule: Schedule) -> list[np.ndarray]:
    """Eigenvalues of A(v) - B(v) K(v) at each grid speed."""
    return [np.linalg.eigvals(a - b @ schedule.gain(v)[None, :])
            for v, a, b in zip(schedule.speeds, schedule.a, schedule.b)]


def sampled_closed_loop_radius(schedule: Schedule, h: float = STEP) -> list[float]:
    """Spectral radius of the sampled loop (T_delta held over each doStep, zero-order hold)
    at each grid speed: < 1 means the discrete-time loop the co-simulation runs is stable."""
    radii = []
    for v, a, b in zip(schedule.speeds, schedule.a, schedule.b):
        n = a.shape[0]
        m = np.zeros((n + 1, n + 1))
        m[:n, :n], m[:n, n:] = a, b
        e = scipy.linalg.expm(m * h)
        ad, bd = e[:n, :n], e[:n, n:]
        radii.append(float(max(abs(np.linalg.eigvals(ad - bd @ schedule.gain(v)[None, :])))))
    return radii
