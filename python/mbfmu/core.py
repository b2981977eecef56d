"""The client side of a sweep: the grid, the batches, the dask tasks and the table.

dask.distributed does the scheduling, so the same study runs on a laptop (a LocalCluster)
or on a cluster (``scheduler="tcp://HOST:PORT"``) without a process pool of our own.
"""

from __future__ import annotations

import hashlib
import math
import os
import pathlib
from typing import Callable, Mapping, Sequence

import cloudpickle
import numpy as np
import pandas as pd
from fmpy import read_model_description

from .instance import run_batch

Run = Callable[[object, dict], Mapping[str, float]]


def linspace(spec: str) -> tuple[str, np.ndarray]:
    """``"NAME=LO:HI:N"`` -> (NAME, N linearly spaced values including both ends)."""
    name, _, rng = spec.partition("=")
    parts = rng.split(":")
    if not name or len(parts) != 3:
        raise ValueError(f"grid {spec!r}: expected NAME=LO:HI:N")
    lo, hi, n = float(parts[0]), float(parts[1]), int(parts[2])
    if n < 1:
        raise ValueError(f"grid {spec!r}: N must be at least 1")
    return name.strip(), np.linspace(lo, hi, n)


def points(grid: Mapping[str, Sequence[float]] | pd.DataFrame) -> np.ndarray:
    """The cartesian product of the grids, one row per run, a column per name (in the
    order of ``grid``), the last name varying fastest. A DataFrame is taken as the runs
    themselves, one per row (Monte Carlo samples, a hand-made design)."""
    if isinstance(grid, pd.DataFrame):
        return grid.to_numpy(dtype=float).reshape(len(grid), grid.shape[1])
    axes = [np.asarray(grid[n], dtype=float).ravel() for n in grid]
    mesh = np.meshgrid(*axes, indexing="ij")
    return np.stack([m.ravel() for m in mesh], axis=1).reshape(-1, len(axes))


def _check_names(md, names: Sequence[str], what: str) -> None:
    known = {v.name for v in md.modelVariables}
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f"{what}: no variable {', '.join(unknown)} in {md.modelName}")


def _batches(n_runs: int, n_threads: int, batch_size: int | None) -> list[range]:
    """Batches of run indices. By default about 8 batches per worker thread (so a slow
    batch or a lost worker holds back little) and at most 2000 runs each (a few tenths of a second
    of ~0.1 ms runs, against the ~ms a dask task costs)."""
    if batch_size is None:
        batch_size = max(1, min(2000, math.ceil(n_runs / (8 * max(1, n_threads)))))
    return [range(i, min(i + batch_size, n_runs)) for i in range(0, n_runs, batch_size)]


def sweep(fmu: str | os.PathLike, grid: Mapping[str, Sequence[float]] | pd.DataFrame, *,
          outputs: Sequence[str] = (), stop_time: float | None = None,
          fixed: Mapping[str, float] | None = None, run: Run | None = None,
          scheduler: str | None = None, client=None, n_workers: int | None = None,
          batch_size: int | None = None, tolerance: float | None = None,
          step: float | None = None, progress: bool = True, retries: int = 3) -> pd.DataFrame:
    """Run the FMU at every point of the cartesian product of ``grid`` (or at every row
    of ``grid`` if it is a DataFrame); one row per run.

    Each run starts a fresh (reset) instance, sets ``fixed`` then the point's values as
    start values, and by default simulates to ``stop_time`` recording the final value of
    each of ``outputs``. With ``run=f``, ``f(inst, point)`` does the run instead and
    returns a dict of named results (e.g. eigenvalues from :meth:`Instance.state_matrix`);
    ``inst`` is a :class:`mbfmu.instance.Instance` in the Instantiated state. ``run`` is
    shipped with cloudpickle: a function of a module the workers cannot import needs
    ``cloudpickle.register_pickle_by_value(module)`` first.

    Where: ``client`` (a dask Client), else ``scheduler`` (address of a running dask
    scheduler), else a LocalCluster of ``n_workers`` single-threaded processes (default:
    one per CPU), shut down at the end.

    Returns a DataFrame: the grid columns, the outputs (NaN where a run failed; an
    output with the name of a grid column is called NAME_out),
    ``status`` ('ok', 'discard', 'error', 'fatal', or 'lost' when a batch's task failed
    even after ``retries``) and ``message`` (the exception and the FMU's log lines).
    """
    path = pathlib.Path(fmu)
    data = path.read_bytes()
    digest = hashlib.sha256(data).hexdigest()
    md = read_model_description(str(path))
    fixed = dict(fixed or {})
    _check_names(md, list(grid) + list(fixed), "start values")
    if run is None:
        if stop_time is None or not outputs:
            raise ValueError("a simulation sweep needs stop_time and outputs")
        _check_names(md, outputs, "outputs")
    pts = points(grid)
    # cloudpickle here, not dask's pickle-first serialisation of the graph: that pickles a
    # function by reference, and a module registered with
    # cloudpickle.register_pickle_by_value (one the workers cannot import) then fails.
    spec = dict(run=None if run is None else cloudpickle.dumps(run), fixed=fixed,
                names=list(grid), stop_time=stop_time,
                outputs=list(outputs) if run is None else [], step=step, tolerance=tolerance)

    from distributed import Client, LocalCluster

    owned = []
    try:
        if client is None:
            if scheduler is not None:
                client = Client(scheduler)
            else:
                cluster = LocalCluster(n_workers=n_workers or os.cpu_count() or 1,
                                       threads_per_worker=1, processes=True,
                                       dashboard_address="127.0.0.1:0")
                owned.append(cluster)
                client = Client(cluster)
            owned.insert(0, client)
        client.wait_for_workers(1, timeout=120)  # scatter needs a worker to send to
        threads = sum(client.nthreads().values())  # every thread runs a batch at a time
        results = _run(client, data, digest, spec, pts, _batches(len(pts), threads, batch_size),
                       progress, retries)
    finally:
        for obj in owned:
            obj.close()
    return _table(grid, pts, results, spec["outputs"])


def _run(client, data, digest, spec, pts, batches, progress, retries):
    """Submit the batches; collect per run (results, status, message)."""
    from distributed import as_completed
    from tqdm.auto import tqdm

    # The FMU goes to every worker once; each task gets the worker's local copy (and the
    # worker unzips it once: mbfmu.instance caches by digest). hash=False: a key of its
    # own per sweep. With hash=True a second sweep of the same FMU on one client reused
    # the first one's key, and the first one's late release cancelled its tasks ("lost
    # dependencies").
    shipped = client.scatter(data, broadcast=True, hash=False)
    futures = {client.submit(run_batch, shipped, digest, spec, b.start, pts[b.start:b.stop],
                             pure=False, retries=retries): b for b in batches}
    n = len(pts)
    results, statuses, messages = [None] * n, ["lost"] * n, [""] * n
    with tqdm(total=n, unit="run", disable=not progress, smoothing=0.1) as bar:
        for fut in as_completed(futures):
            b = futures[fut]
            try:
                start, res, st, msg = fut.result()
                results[b.start:b.stop] = list(res)
                statuses[b.start:b.stop] = st
                for i, m in msg.items():
                    messages[start + i] = m
            except Exception as exc:  # e.g. KilledWorker after the retries: rows say so
                messages[b.start:b.stop] = [f"{type(exc).__name__}: {exc}"] * len(b)
            bar.update(len(b))
            fut.release()
    shipped.release()
    return results, statuses, messages


def _table(grid, pts, run_results, outputs) -> pd.DataFrame:
    results, statuses, messages = run_results
    cols = {n: pts[:, j] for j, n in enumerate(grid)}
    if outputs:  # a simulation: each result is a row of output values
        names = list(outputs)
        vals = np.array([np.full(len(names), np.nan) if r is None else r for r in results],
                        dtype=float).reshape(len(results), len(names))
        named = dict(zip(names, vals.T))
    else:  # a custom run names its own results
        names = list(dict.fromkeys(k for r in results if r for k in r))
        named = {k: np.array([np.nan if not r else float(r.get(k, np.nan)) for r in results])
                 for k in names}
    for n in names:  # an output named like a grid column (x0 swept, x read) gets "_out"
        cols[n + "_out" if n in cols else n] = named[n]
    cols["status"] = statuses
    cols["message"] = messages
    return pd.DataFrame(cols)
