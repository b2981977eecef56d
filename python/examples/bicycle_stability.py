"""The Whipple bicycle's self-stable speed range as a map over trail and head angle.

Each run is a linearisation, not a simulation: mbfmu.spectrum reads A = ∂der(x)/∂x from
the WhippleBicycle FMU's fmi2GetDirectionalDerivative at one (trail c, steer axis tilt
lambda, speed v) and returns its eigenvalues. Per (c, lambda), the bicycle is self-stable
where every eigenvalue has a negative real part: from the weave speed (the weave pair's
real part crosses zero) to the capsize speed (the capsize eigenvalue crosses zero). Both
are found by linear interpolation of max Re(λ) between grid speeds.

    python python/examples/bicycle_stability.py [--fmu target/fmu/WhippleBicycle.fmu]
        [--scheduler tcp://HOST:PORT] [--out docs/sweeps/bicycle_stability.png]

Check: at the benchmark's c = 0.08 m, lambda = π/10 (head angle 72°) it prints the weave
and capsize speeds beside those of Meijaard et al. (2007), 4.2924 and 6.0243 m/s.
"""

from __future__ import annotations

import argparse

import numpy as np

import mbfmu

BENCHMARK = dict(c=0.08, head=72.0, weave=4.292383208, capsize=6.024262937)


def crossings(v: np.ndarray, margin: np.ndarray) -> tuple[float, float]:
    """(weave speed, capsize speed): where max Re(λ) first turns negative, then where it
    turns non-negative again (NaN when there is no such crossing on the grid)."""
    stable = margin < 0
    weave = capsize = np.nan
    for i in range(1, len(v)):
        if np.isnan(weave) and stable[i] and not stable[i - 1]:
            weave = np.interp(0.0, [margin[i], margin[i - 1]], [v[i], v[i - 1]])
        elif not np.isnan(weave) and not stable[i] and stable[i - 1]:
            capsize = np.interp(0.0, [margin[i - 1], margin[i]], [v[i - 1], v[i]])
            break
    return weave, capsize


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fmu", default="target/fmu/WhippleBicycle.fmu")
    ap.add_argument("--scheduler", help="a running dask scheduler (default: a LocalCluster)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default="docs/sweeps/bicycle_stability.png")
    args = ap.parse_args()

    trail = np.linspace(0.0, 0.16, 17)                   # m (benchmark 0.08)
    head = np.linspace(60.0, 84.0, 17)                   # degrees (benchmark 72)
    speed = np.linspace(0.0, 10.0, 201)                  # m/s
    grid = {"c": trail, "lambda": np.radians(90.0 - head), "v": speed}
    df = mbfmu.sweep(args.fmu, grid, run=mbfmu.spectrum, scheduler=args.scheduler,
                     n_workers=args.workers)
    failed = df[df["status"] != "ok"]
    print(f"{len(df)} linearisations, {len(failed)} failed")
    margin = df["max_re"].to_numpy().reshape(len(trail), len(head), len(speed))
    weave = np.full((len(trail), len(head)), np.nan)
    capsize = np.full_like(weave, np.nan)
    for i in range(len(trail)):
        for j in range(len(head)):
            weave[i, j], capsize[i, j] = crossings(speed, margin[i, j])

    i, j = np.argmin(abs(trail - BENCHMARK["c"])), np.argmin(abs(head - BENCHMARK["head"]))
    print(f"benchmark c = {trail[i]} m, head angle {head[j]}°: weave {weave[i, j]:.4f} m/s "
          f"(published {BENCHMARK['weave']:.4f}), capsize {capsize[i, j]:.4f} m/s "
          f"(published {BENCHMARK['capsize']:.4f})")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), sharey=True, constrained_layout=True)
    for ax, field, title in ((axes[0], weave, "weave speed (stable above) [m/s]"),
                             (axes[1], capsize, "capsize speed (stable below) [m/s]")):
        cs = ax.contourf(head, trail, field, levels=np.arange(0, 10.5, 0.5), cmap="viridis")
        ax.contour(head, trail, field, levels=np.arange(1, 10, 1), colors="k", linewidths=0.5)
        ax.plot(BENCHMARK["head"], BENCHMARK["c"], "r*", ms=12, label="benchmark bicycle")
        ax.set_title(title)
        ax.set_xlabel("head angle [°] (= 90° − λ)")
        fig.colorbar(cs, ax=ax)
    axes[0].set_ylabel("trail c [m]")
    axes[0].legend(loc="lower right")
    fig.suptitle("Whipple bicycle (benchmark parameters otherwise): self-stable between the two "
                 "speeds; blank = no self-stable range below 10 m/s", fontsize=10)
    fig.savefig(args.out, dpi=100)
    print(f"plot -> {args.out}")


if __name__ == "__main__":
    main()
