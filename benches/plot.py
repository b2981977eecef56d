#!/usr/bin/env python3
"""Charts of `mbfmu bench` (results.csv, energy.csv) and benches/peers.py (peers.csv).

    python benches/plot.py [--out docs/bench]

For MassSpringDamper/damped, TwoMassChain/release and TwoMassChain/stiff: error at the stop
time vs CPU time and vs RHS evaluations (log-log, one line per method). Our adaptive methods
are drawn twice: solid with one doStep over the whole scene (the integrator alone, as the
peers run) and dotted with the 0.01 s communication grid (the FMU as a co-simulation master
drives it); fixed-step methods always run on the grid. Failed runs are not drawn (they are
in results.csv). Also the energy error of MassSpringDamper/free over a long horizon.
"""

import argparse
import csv
import os
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES = [("MassSpringDamper", "damped"), ("TwoMassChain", "release"), ("TwoMassChain", "stiff")]


def read(path):
    if not os.path.exists(path):
        return []
    with open(path) as f:
        return list(csv.DictReader(f))


def curves(results, peers, system, scene):
    """{label: (style, [(cpu, rhs, err)])}"""
    out = defaultdict(lambda: [None, []])
    for r in results:
        if r["system"] != system or r["scene"] != scene or r["status"] != "ok":
            continue
        err = float(r["error_final"])
        free = r["setting_kind"] == "tol" and float(r["comm_step"]) > 0.011
        label = r["method"] + ("" if free or r["setting_kind"] == "step" else " (grid 0.01)")
        style = dict(ls="-" if free else (":" if r["setting_kind"] == "tol" else "--"), marker="o", ms=3)
        out[label][0] = style
        out[label][1].append((float(r["cpu_s"]), float(r["rhs_evals"]), err))
    for r in peers:
        if r["system"] != system or r["scene"] != scene or r["status"] != "ok":
            continue
        label = ("scipy " if r["solver"] == "scipy" else "") + r["method"]
        out[label][0] = dict(ls="-.", marker="s", ms=3)
        out[label][1].append((float(r["cpu_s"]), float(r["rhs_evals"]), float(r["error_final"])))
    return out


def work_precision(results, peers, outdir):
    written = []
    for system, scene in SCENES:
        data = curves(results, peers, system, scene)
        if not data:
            continue
        fig, axes = plt.subplots(1, 2, figsize=(13, 5.5))
        for ax, k, xlabel in ((axes[0], 0, "CPU time [s] (min of repeats)"), (axes[1], 1, "RHS evaluations")):
            for i, (label, (style, pts)) in enumerate(sorted(data.items())):
                pts = sorted(p for p in pts if p[2] > 0)
                if not pts:
                    continue
                ax.loglog([p[k] for p in pts], [p[2] for p in pts], label=label,
                          color=plt.cm.tab20(i % 20), **style)
            ax.set_xlabel(xlabel)
            ax.set_ylabel("scaled error at stop time")
            ax.grid(True, which="both", alpha=0.3)
        axes[1].legend(fontsize=7, ncol=2, loc="best")
        fig.suptitle(f"{system}/{scene}: work vs precision")
        fig.tight_layout()
        path = os.path.join(outdir, f"wp_{system}_{scene}.png")
        fig.savefig(path, dpi=100)
        plt.close(fig)
        written.append(path)
    return written


def energy(rows, outdir):
    if not rows:
        return []
    by = defaultdict(list)
    for r in rows:
        by[f"{r['method']} ({'tol' if r['method'] == 'DOPRI5' else 'h'} {float(r['setting']):g})"].append(
            (float(r["t"]), float(r["energy_error"])))
    fig, ax = plt.subplots(figsize=(8, 5))
    for label, pts in sorted(by.items()):
        pts = [p for p in pts if p[0] > 0]
        ax.loglog([p[0] for p in pts], [max(p[1], 1e-17) for p in pts], label=label)
    ax.set_xlabel("simulated time [s]")
    ax.set_ylabel("|E(t) - E(0)| / E(0)")
    ax.set_title("MassSpringDamper/free: energy error (communication step 0.01 s)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    path = os.path.join(outdir, "energy_MassSpringDamper_free.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return [path]


def cost_at(pts, target):
    """(cpu, rhs) at error `target`, interpolated log-log between the two runs around it."""
    import math
    pts = sorted((p for p in pts if p[2] > 0), key=lambda p: -p[2])
    for a, b in zip(pts, pts[1:]):
        if a[2] >= target >= b[2] and a[2] > b[2]:
            w = (math.log(a[2]) - math.log(target)) / (math.log(a[2]) - math.log(b[2]))
            return tuple(math.exp((1 - w) * math.log(a[k]) + w * math.log(b[k])) for k in (0, 1))
    return None


def headline(results, peers, target=1e-8):
    """Prints, per scene, the cost of each method at error `target` (interpolated)."""
    for system, scene in SCENES:
        rows = []
        for label, (_, pts) in curves(results, peers, system, scene).items():
            c = cost_at(pts, target)
            if c:
                rows.append((c[1], c[0], label))
        print(f"{system}/{scene} at error {target:g}: RHS evaluations, CPU s")
        for rhs, cpu, label in sorted(rows):
            print(f"  {label:<28} {rhs:9.0f} {cpu:10.3e}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "bench"))
    args = ap.parse_args()
    results = read(os.path.join(args.out, "results.csv"))
    peers = read(os.path.join(args.out, "peers.csv"))
    written = work_precision(results, peers, args.out) + energy(read(os.path.join(args.out, "energy.csv")), args.out)
    for p in written:
        print("wrote", p)
    headline(results, peers)


if __name__ == "__main__":
    main()
