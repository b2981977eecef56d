"""The gain-scheduled LQR steering of the NonlinearBicycle FMU: recovery from a lean of
0.1 rad at 2 m/s, then a 1.5 m lane change; beside it the same start without control.

The controller and the co-simulation loop are tests/python/bicycle_control.py, the same
code and the same scenario as tests/python/test_bicycle_control.py.

    cargo run --release --bin mbfmu -- build NonlinearBicycle     # target/fmu, target/release/mbfmu
    python docs/bicycle/control.py                 # control.csv, and control.png if matplotlib imports
    python docs/bicycle/control.py --from-csv      # control.png from control.csv (matplotlib only)

The first needs fmpy, numpy and scipy (tests/requirements.txt); the FMU is found like the
tests find it ($MBFMU_FMU_DIR, default target/fmu).
"""

from __future__ import annotations

import argparse
import pathlib
import sys

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
CSV = HERE / "control.csv"
PNG = HERE / "control.png"
COLUMNS = ("t", "roll", "steer", "T_delta", "y", "y_ref", "yaw", "speed", "roll_open")


def simulate() -> np.ndarray:
    sys.path.insert(0, str(HERE.parents[1] / "tests" / "python"))
    import bicycle_control as bc
    import fmu_support as fs
    scenario = bc

    model = fs.Model.get(bc.MODEL)
    schedule = bc.Schedule.design()
    run = bc.simulate(model, scenario.V, scenario.ROLL0, scenario.STOP, schedule,
                      y_ref=bc.lane_change(scenario.SHIFT, scenario.LANE_START, scenario.LANE_TIME))
    open_loop = bc.simulate(model, scenario.V, scenario.ROLL0, scenario.STOP, None)
    roll_open = np.full(run.t.shape, np.nan)
    roll_open[: len(open_loop.t)] = open_loop["roll"]
    print(f"controlled: max |T_delta| = {np.abs(run['T_delta']).max():.2f} N.m, "
          f"final |y - {scenario.SHIFT}| = {abs(run['y'][-1] - scenario.SHIFT):.4f} m; "
          f"uncontrolled: stopped at t = {open_loop.t[-1]:.2f} s ({open_loop.messages[-1:]})")
    data = np.column_stack([run.t] + [run[c] for c in COLUMNS[1:-1]] + [roll_open])
    np.savetxt(CSV, data, delimiter=",", header=",".join(COLUMNS), comments="", fmt="%.6g")
    print(f"wrote {CSV}")
    return data


def plot(data: np.ndarray) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = {c: data[:, j] for j, c in enumerate(COLUMNS)}
    t = d["t"]
    lane = t[np.nonzero(np.diff(d["y_ref"]) > 0)[0][[0, -1]]]
    fig, ax = plt.subplots(4, 1, sharex=True, figsize=(8, 9))
    ax[0].plot(t, d["roll"], label="controlled")
    ax[0].plot(t, d["roll_open"], "--", color="tab:red", label="T_delta = 0 (falls: fmi2Discard)")
    ax[0].set_ylim(-0.3, 0.3)
    ax[0].set_ylabel("roll [rad]")
    ax[0].legend(loc="lower right")
    ax[1].plot(t, d["steer"])
    ax[1].set_ylabel("steer [rad]")
    ax[2].plot(t, d["T_delta"])
    ax[2].set_ylabel("T_delta [N m]")
    ax[3].plot(t, d["y_ref"], "--", color="gray", label="y_ref")
    ax[3].plot(t, d["y"], label="y")
    ax[3].set_ylabel("y [m]")
    ax[3].set_xlabel("t [s]")
    ax[3].legend(loc="lower right")
    for a in ax:
        a.axvspan(*lane, color="0.92", zorder=0)
        a.grid(alpha=0.3)
    ax[0].set_title("NonlinearBicycle at 2 m/s, gain-scheduled LQR on T_delta:\n"
                    "lean 0.1 rad at t = 0, then a 1.5 m lane change (shaded)", fontsize=10)
    fig.tight_layout()
    fig.savefig(PNG, dpi=110)
    print(f"wrote {PNG}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--from-csv", action="store_true", help="plot control.csv, no simulation")
    args = ap.parse_args()
    if args.from_csv:
        data = np.loadtxt(CSV, delimiter=",", skiprows=1)
    else:
        data = simulate()
    try:
        plot(data)
    except ImportError:
        print("matplotlib not importable: run again with --from-csv where it is")


if __name__ == "__main__":
    main()
