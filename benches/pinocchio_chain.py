"""The planar chain of `mbfmu speed --chain` in Pinocchio, timed per call, and the chart
of both against N.

    pip install pin numpy matplotlib
    cargo run --release --bin mbfmu -- speed --chain      # docs/bench/chain.csv (ours)
    python benches/pinocchio_chain.py                     # chain_pinocchio.csv, chain.png

The chain: N revolute joints about the same horizontal axis, a point mass m = 1 kg at
the end of each rigid massless link of l = 1 m, gravity 9.81 (Pinocchio's relative joint
angles; the dynamics and the cost are those of our absolute-angle chain). Timed: the
articulated-body algorithm `aba` (forward dynamics, one RHS) and
`computeABADerivatives` (∂q̈/∂q, ∂q̈/∂v: the Jacobian of the RHS). Each is timed in a
Python loop, best of several repetitions; the Python-to-C++ call overhead is measured on
the same calls with a model of no joint, interleaved with them, and taken off, so the
numbers are Pinocchio's own C++ time per call.
"""

from __future__ import annotations

import argparse
import csv
import pathlib
import timeit

import numpy as np
import pinocchio as pin

REPO = pathlib.Path(__file__).resolve().parent.parent
LINKS = [1, 2, 4, 8, 16]


def chain(n: int, m: float = 1.0, l: float = 1.0) -> pin.Model:
    model = pin.Model()
    parent = 0
    for i in range(n):
        placement = pin.SE3(np.eye(3), np.array([0.0, 0.0, -l if i > 0 else 0.0]))
        parent = model.addJoint(parent, pin.JointModelRY(), placement, f"j{i}")
        inertia = pin.Inertia(m, np.array([0.0, 0.0, -l]), np.zeros((3, 3)))
        model.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
    model.gravity = pin.Motion(np.array([0.0, 0.0, -9.81, 0.0, 0.0, 0.0]))
    return model


def calls(n: int):
    """The two timed calls on the n-link chain (n = 0: no joint, the binding's cost alone),
    and how many of each make one timing loop."""
    model = chain(n)
    data = model.createData()
    rng = np.random.default_rng(n)
    q, v, tau = rng.normal(size=n), rng.normal(size=n), np.zeros(n)
    aba = lambda: pin.aba(model, data, q, v, tau)
    der = lambda: pin.computeABADerivatives(model, data, q, v, tau)
    return (aba, der), max(2000, 100_000 // max(1, n * n))


def best_times(links: list[int], repeat: int) -> dict[int, tuple[float, float]]:
    """Best seconds per call of (aba, derivatives) for each N. The loops of every N,
    the joint-less model's included, are interleaved repetition by repetition, so that
    the overhead taken off and the times it is taken from see the same machine."""
    setups = {n: calls(n) for n in links}
    best = {n: [np.inf, np.inf] for n in links}
    for _ in range(repeat):
        for n, (fns, number) in setups.items():
            for k, fn in enumerate(fns):
                best[n][k] = min(best[n][k], timeit.timeit(fn, number=number) / number)
    return {n: (a, d) for n, (a, d) in best.items()}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(REPO / "docs" / "bench"))
    ap.add_argument("--repeat", type=int, default=15)
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    # Check the model: for N = 1 the pendulum, q̈ = −(g/l) sin q (Pinocchio's sign
    # convention for RY: a positive angle swings the mass towards +x... any sign: |q̈|).
    m1 = chain(1)
    qdd = pin.aba(m1, m1.createData(), np.array([0.7]), np.zeros(1), np.zeros(1))
    assert abs(abs(qdd[0]) - 9.81 * np.sin(0.7)) < 1e-12, qdd
    times = best_times([0] + LINKS, args.repeat)
    o_aba, o_der = times[0]
    rows = []
    for n in LINKS:
        aba, der = times[n]
        rows.append((n, (aba - o_aba) * 1e9, (der - o_der) * 1e9))
        print(f"N = {n:2d}: aba {rows[-1][1]:8.0f} ns, ABA derivatives {rows[-1][2]:8.0f} ns")
    print(f"(binding overhead taken off: aba {o_aba * 1e9:.0f} ns, derivatives {o_der * 1e9:.0f} ns)")
    with open(out / "chain_pinocchio.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["links", "aba_ns", "aba_derivatives_ns"])
        for n, a, d in rows:
            w.writerow([n, f"{a:.1f}", f"{d:.1f}"])
    ours = list(csv.DictReader(open(out / "chain.csv")))
    plot(ours, rows, out / "chain.png")


def plot(ours, pinocchio, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n_ours = [int(r["links"]) for r in ours]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.loglog(n_ours, [float(r["rhs_ns"]) for r in ours], "o-", color="C0",
              label="mbfmu Lagrangian (AD of T, V): one RHS")
    ax.loglog(n_ours, [float(r["jacobian_ns"]) for r in ours], "s--", color="C0",
              label="mbfmu: Jacobian ∂f/∂x (dual numbers)")
    n_pin = [r[0] for r in pinocchio]
    ax.loglog(n_pin, [r[1] for r in pinocchio], "o-", color="C3", label="Pinocchio aba: one RHS")
    ax.loglog(n_pin, [r[2] for r in pinocchio], "s--", color="C3",
              label="Pinocchio computeABADerivatives")
    ax.set_xlabel("links N (2N states)")
    ax.set_ylabel("ns per call")
    ax.set_title("Planar chain: cost against size (same machine, same run)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
