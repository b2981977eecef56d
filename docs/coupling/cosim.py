"""The split two-mass oscillator study (issue 16): global error at t = 2 s against the
communication step H, for a zero-order hold of the coupling force and its extrapolation
from the FMUs' exact output derivatives, Jacobi and Gauss–Seidel.

    MBFMU_FMU_DIR=$PWD/target/fmu /work/venv-rc/bin/python docs/coupling/cosim.py

writes docs/coupling/cosim.csv and docs/coupling/cosim.png. The master is
tests/python/cosim.py (the one tests/python/test_cosimulation.py asserts on).
"""

from __future__ import annotations

import csv
import pathlib
import sys

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "tests" / "python"))

import cosim  # noqa: E402
import fmu_support as fs  # noqa: E402

HS = [0.04, 0.02, 0.01, 0.005, 0.0025, 0.00125]
RUNS = [
    ("jacobi", 0, "Jacobi, hold"),
    ("gauss_seidel", 0, "Gauss–Seidel, hold"),
    ("jacobi", 1, "Jacobi, 1st-order extrapolation"),
    ("gauss_seidel", 1, "Gauss–Seidel, 1st-order extrapolation"),
    ("jacobi", 2, "Jacobi, 2nd-order extrapolation"),
]


def main() -> None:
    model = fs.Model.get("MassSpringDamper")
    errors = {(s, o): [cosim.run(model, h, o, s) for h in HS] for s, o, _ in RUNS}
    with open(HERE / "cosim.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["H"] + [f"{s}_order{o}" for s, o, _ in RUNS])
        for i, h in enumerate(HS):
            w.writerow([h] + [f"{errors[(s, o)][i]:.4e}" for s, o, _ in RUNS])
        # Orders fitted on H <= 0.02 (the asymptotic range; see docs/coupling.md).
        w.writerow(["order"] + [f"{cosim.observed_order(HS[1:], errors[(s, o)][1:]):.2f}"
                                for s, o, _ in RUNS])
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    for (s, o, label), marker in zip(RUNS, "os^vD"):
        p = cosim.observed_order(HS[1:], errors[(s, o)][1:])
        ax.loglog(HS, errors[(s, o)], marker=marker, label=f"{label} (order {p:.2f})")
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("communication step H [s]")
    ax.set_ylabel("max(|x1 − x1,ref|, |x2 − x2,ref|) at t = 2 s [m]")
    ax.set_title("Split two-mass oscillator: two MassSpringDamper FMUs")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(HERE / "cosim.png", dpi=120)
    for s, o, label in RUNS:
        print(label, " ".join(f"{e:.3e}" for e in errors[(s, o)]))


if __name__ == "__main__":
    main()
