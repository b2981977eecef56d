"""Charts of the two rheonomic FMUs (issue 14): the bead's bifurcation and the pulled
pendulum's power balance.

- bifurcation.png: the bead's equilibrium angle against Ω, the closed form (θ = 0 below
  √(g/R), θ* = arccos(g/(R Ω²)) above) and simulated points: the time average of θ over
  20 s of a small oscillation (0.02 rad) started beside the closed-form equilibrium.
- pulled.png: the pulled pendulum (l from 1 m at −0.05 m/s, θ0 = 0.3): θ and l against t,
  and E − E0 beside −∫ tension · l̇ dt.

    cargo run --release --bin mbfmu -- build RotatingHoopBead PulledPendulum
    python docs/rheonomic/charts.py        # bifurcation.csv, pulled.csv and the PNGs

Needs fmpy and numpy (tests/requirements.txt), matplotlib for the PNGs; the FMUs are
found like the tests find them ($MBFMU_FMU_DIR, default target/fmu).
"""

from __future__ import annotations

import pathlib
import sys

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "tests" / "python"))

import fmu_support as fs  # noqa: E402

G, R = 9.81, 0.5


def closed_form(omega: np.ndarray) -> np.ndarray:
    c = G / (R * omega**2)
    return np.where(c < 1.0, np.arccos(np.minimum(c, 1.0)), 0.0)


def bifurcation() -> np.ndarray:
    model = fs.Model.get("RotatingHoopBead")
    rows = []
    for omega in np.arange(1.0, 10.01, 0.25):
        eq = float(closed_form(np.array(omega)))
        res = fs.simulate(model, {"Omega": omega, "phi_dot": omega, "theta": eq + 0.02},
                          tol=1e-10, stop_time=20.0, output_interval=1e-3, outputs=["theta"])
        rows.append((omega, eq, float(np.mean(res["theta"]))))
    return np.array(rows)


def pulled() -> np.ndarray:
    model = fs.Model.get("PulledPendulum")
    res = fs.simulate(model, {"theta": 0.3}, tol=1e-12, stop_time=15.0, output_interval=1e-3,
                      outputs=["theta", "l", "E", "tension"])
    t = res["time"]
    power = -res["tension"] * -0.05
    work = np.concatenate([[0.0], np.cumsum(np.diff(t) * 0.5 * (power[1:] + power[:-1]))])
    return np.column_stack([t, res["theta"], res["l"], res["E"] - res["E"][0], work])


def main() -> None:
    b = bifurcation()
    np.savetxt(HERE / "bifurcation.csv", b, delimiter=",", header="Omega,theta_closed_form,theta_mean_simulated", comments="")
    p = pulled()
    np.savetxt(HERE / "pulled.csv", p[::10], delimiter=",", header="t,theta,l,E_minus_E0,work_of_pull", comments="")
    worst = np.max(np.abs(b[:, 1] - b[:, 2]))
    print(f"bifurcation: worst |mean θ − closed form| {worst:.2e} rad over {len(b)} rates")
    print(f"pulled: worst |ΔE − work| {np.max(np.abs(p[:, 3] - p[:, 4])):.2e} J")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    w = np.linspace(1.0, 10.0, 400)
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(w, closed_form(w), label="closed form: 0, then arccos(g/(R Ω²))")
    ax.plot(w, np.zeros_like(w), "--", color="gray", lw=0.8, label="θ = 0 (unstable above √(g/R))")
    ax.plot(b[:, 0], b[:, 2], "o", ms=4, label="FMU: mean θ of a small oscillation, 20 s")
    ax.axvline(np.sqrt(G / R), color="gray", lw=0.5)
    ax.set_xlabel("Ω (rad/s)")
    ax.set_ylabel("equilibrium θ (rad)")
    ax.set_title("RotatingHoopBead: R = 0.5 m, g = 9.81")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(HERE / "bifurcation.png", dpi=120)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(6, 6), sharex=True)
    a1.plot(p[:, 0], p[:, 1], label="θ (rad)")
    a1.plot(p[:, 0], p[:, 2], label="l (m)")
    a1.legend(fontsize=8)
    a1.set_title("PulledPendulum: l = 1 − 0.05 t, θ0 = 0.3")
    a2.plot(p[:, 0], p[:, 3], label="E − E0")
    a2.plot(p[:, 0], p[:, 4], "--", label="−∫ tension · (dl/dt) dt")
    a2.set_xlabel("t (s)")
    a2.set_ylabel("J")
    a2.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(HERE / "pulled.png", dpi=120)


if __name__ == "__main__":
    main()
