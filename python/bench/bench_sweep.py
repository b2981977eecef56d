"""Runs per second of a sweep: serial loops in one process against mbfmu.sweep on 1 and 2
LocalCluster workers. Prints the Markdown table of docs/sweeps.md.

    python python/bench/bench_sweep.py [--fmu-dir target/fmu] [--scale 1.0]

Two workloads: MassSpringDamper to T = 2 s (a run of ~0.1 ms: the per-run overhead
shows) and DoublePendulum to T = 30 s (chaotic, runs of ~1 ms: the scaling shows).
Columns:
- fmpy.simulate_fmu loop: what one writes first (extracts and instantiates every run);
- serial loop: one process, one instance reused with fmi2Reset (mbfmu's own run code,
  no dask) -- the baseline;
- 1 worker / 2 workers: mbfmu.sweep on a LocalCluster already started (its ~2 s start is
  reported apart), FMU shipping, batching and the result table included.
Overhead per run = (time with 1 worker - serial loop time) / runs; it includes the fixed
cost of a sweep (shown apart: a sweep of one run) spread over the runs.
Wall-clock times on a shared machine: take the best of --repeat.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import pathlib
import time

import fmpy
import numpy as np

import mbfmu
from mbfmu.instance import run_batch

WORKLOADS = {
    "MassSpringDamper": dict(grid={"k": (1.0, 100.0), "c": (0.0, 1.0)}, n=20000,
                             fixed={"x": 0.1}, stop_time=2.0, outputs=["x", "E"], n_simulate=200),
    "DoublePendulum": dict(grid={"theta1": (0.5, 2.5), "phi": (-1.0, 1.0)}, n=2000,
                           fixed={}, stop_time=30.0, outputs=["theta1", "phi", "E"], n_simulate=100),
}


def grid_of(w, scale):
    side = max(2, int(round(np.sqrt(w["n"] * scale))))
    return {k: np.linspace(lo, hi, side) for k, (lo, hi) in w["grid"].items()}


def best(f, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return min(times)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fmu-dir", default=os.environ.get("MBFMU_FMU_DIR", "target/fmu"))
    ap.add_argument("--scale", type=float, default=1.0, help="multiply the run counts")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    from distributed import Client, LocalCluster

    rows = []
    for name, w in WORKLOADS.items():
        fmu = pathlib.Path(args.fmu_dir) / f"{name}.fmu"
        grid = grid_of(w, args.scale)
        pts = mbfmu.points(grid)
        n = len(pts)
        data = fmu.read_bytes()
        digest = hashlib.sha256(data).hexdigest()
        spec = dict(run=None, fixed=w["fixed"], names=list(grid), stop_time=w["stop_time"],
                    outputs=w["outputs"], step=None, tolerance=None)

        k = min(w["n_simulate"], n)
        t_sim = best(lambda: [fmpy.simulate_fmu(str(fmu), stop_time=w["stop_time"],
                                                start_values={**w["fixed"], **dict(zip(grid, p))},
                                                output=w["outputs"]) for p in pts[:k]], 1) / k
        run_batch(data, digest, spec, 0, pts[:10])  # extract + load once
        row = dict(model=name, runs=n, simulate=1 / t_sim)
        clusters = {}
        try:
            for workers in (1, 2):
                t0 = time.perf_counter()
                cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                       dashboard_address="127.0.0.1:0")
                clusters[workers] = (cluster, Client(cluster))
                row[f"start{workers}"] = time.perf_counter() - t0

            def swept(workers):
                df = mbfmu.sweep(fmu, grid, fixed=w["fixed"], stop_time=w["stop_time"],
                                 outputs=w["outputs"], client=clusters[workers][1], progress=False)
                assert (df["status"] == "ok").all(), df[df["status"] != "ok"].head()

            # Interleaved repeats, best of each: the load of a shared machine drifts.
            times = {"serial": [], 1: [], 2: [], "one": []}
            one = {k: v[:1] for k, v in grid.items()}
            for _ in range(args.repeat):
                times["serial"].append(best(lambda: run_batch(data, digest, spec, 0, pts), 1))
                for workers in (1, 2):
                    times[workers].append(best(lambda: swept(workers), 1))
                times["one"].append(best(lambda: mbfmu.sweep(
                    fmu, one, fixed=w["fixed"], stop_time=w["stop_time"], outputs=w["outputs"],
                    client=clusters[1][1], progress=False), 1))
        finally:
            for cluster, client in clusters.values():
                client.close()
                cluster.close()
        t_serial = min(times["serial"])
        row["serial"] = n / t_serial
        row["w1"], row["w2"] = n / min(times[1]), n / min(times[2])
        row["overhead_us"] = (min(times[1]) - t_serial) / n * 1e6
        row["fixed_s"] = min(times["one"])  # a 1-run sweep: scatter, XML, task, table
        rows.append(row)
        print(row, flush=True)

    print(f"\nload average {os.getloadavg()}, {os.cpu_count()} CPUs\n")
    print("| model, T | runs | fmpy.simulate_fmu loop | serial loop (reset) | 1 worker | 2 workers "
          "| overhead per run (1 worker − serial) | fixed cost of a sweep (1 run) | run (serial) |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        T = WORKLOADS[r["model"]]["stop_time"]
        print(f"| {r['model']}, {T:g} s | {r['runs']} | {r['simulate']:.0f}/s | {r['serial']:.0f}/s "
              f"| {r['w1']:.0f}/s | {r['w2']:.0f}/s | {r['overhead_us']:.0f} µs "
              f"| {r['fixed_s'] * 1e3:.0f} ms | {1e3 / r['serial']:.3f} ms |")
    print(f"\nLocalCluster start: {rows[0]['start1']:.1f} s (1 worker), {rows[0]['start2']:.1f} s (2 workers)")


if __name__ == "__main__":
    main()
