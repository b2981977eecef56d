"""Command line: ``python -m mbfmu.sweep --fmu PATH --grid NAME=LO:HI:N ... --out FILE.parquet``."""

from __future__ import annotations

import argparse
import sys
import time

from mbfmu.core import linspace, sweep


def _assignment(text: str) -> tuple[str, float]:
    name, eq, value = text.partition("=")
    if not eq or not name:
        raise argparse.ArgumentTypeError(f"{text!r}: expected NAME=VALUE")
    return name.strip(), float(value)


def _grid(text: str):
    try:
        return linspace(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m mbfmu.sweep",
        description="Simulate an FMI 2.0 Co-Simulation FMU at every point of a grid of start "
                    "values on dask.distributed and write one row per run (grid values, the "
                    "final value of each output, status, message) to a Parquet file. A run "
                    "that fails (fmi2Error, fmi2Discard, a value outside [min, max]) is a row "
                    "with its status and message, not a failed sweep.")
    p.add_argument("--fmu", required=True, help="the .fmu file")
    p.add_argument("--grid", action="append", type=_grid, required=True, metavar="NAME=LO:HI:N",
                   help="N linearly spaced values from LO to HI, both included; repeat for a "
                        "cartesian product")
    p.add_argument("--set", action="append", type=_assignment, default=[], metavar="NAME=V",
                   help="a start value fixed for every run; repeatable")
    p.add_argument("--stop-time", type=float, required=True, metavar="T",
                   help="simulated time of each run (start 0)")
    p.add_argument("--outputs", required=True, metavar="a,b",
                   help="comma-separated variables whose final value is recorded")
    p.add_argument("--out", required=True, metavar="FILE.parquet",
                   help="the table, one row per run (pandas + pyarrow)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="a running dask scheduler, e.g. tcp://HOST:8786 (default: a "
                        "LocalCluster on this machine)")
    p.add_argument("--workers", type=int, help="LocalCluster worker processes (default: one per CPU)")
    p.add_argument("--batch-size", type=int, help="runs per dask task (default: about 8 tasks "
                                                  "per worker thread, at most 2000 runs each)")
    p.add_argument("--tolerance", type=float, help="fmi2SetupExperiment tolerance "
                                                   "(default: the DefaultExperiment's)")
    p.add_argument("--step", type=float, help="communication step (default: one fmi2DoStep "
                                              "to T; the FMU's solver steps inside it)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    grid = dict(args.grid)
    t0 = time.perf_counter()
    try:
        df = sweep(args.fmu, grid, fixed=dict(args.set), stop_time=args.stop_time,
                   outputs=[o.strip() for o in args.outputs.split(",") if o.strip()],
                   scheduler=args.scheduler, n_workers=args.workers,
                   batch_size=args.batch_size, tolerance=args.tolerance, step=args.step,
                   progress=not args.no_progress)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    df.to_parquet(args.out, index=False)
    failed = int((df["status"] != "ok").sum())
    print(f"{len(df)} runs ({failed} failed) in {time.perf_counter() - t0:.1f} s -> {args.out}",
          file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
