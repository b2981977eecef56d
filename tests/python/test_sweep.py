"""mbfmu.sweep (python/mbfmu) on a real dask cluster and on the default LocalCluster.

Each sweep is MassSpringDamper's free, undamped oscillation (c = 0, F_amp = 0, v0 = 0),
checked row by row against x(T) = x0 cos(√(k/m) T) and E = ½ k x0².

Tolerance: the runs use DOPRI5 at rtol 1e-10 (fmi2SetupExperiment tolerance). Its local
error per step is held to ~1e-10 of |x| ≤ x0; over T = 2 s (≤ 3.2 periods of ω ≤ √200)
the controller takes a few hundred steps, so the global error stays orders below
1e-7·x0 (measured ~1e-10·x0). 1e-7·x0 still fails any wrong k, m, T or start value: a
relative error of 1e-7 in ω moves x(T) by up to ωT·1e-7·x0 ≈ 3e-6·x0.
"""

from __future__ import annotations

import functools
import json
import os
import pathlib
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

import fmu_support as fs

X0, T = 0.1, 2.0
FREE = ["--set", "c=0", "--set", "F_amp=0", "--set", f"x={X0}", "--set", "v=0"]
TOL = 1e-7 * X0


def cli(*args, timeout=300):
    cmd = [sys.executable, "-m", "mbfmu.sweep", "--fmu", str(fs.fmu_file("MassSpringDamper")),
           "--stop-time", str(T), "--outputs", "x,E", "--tolerance", "1e-10", "--no-progress",
           *FREE, *args]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    assert done.returncode == 0, done.stderr
    return done


def check_rows(df: pd.DataFrame, grid: dict[str, np.ndarray], m_fixed: float = 1.0):
    """Every run is a row, in grid order; a point outside [min, max] is a failed row with
    the FMU's message; every other row matches the closed form."""
    names = list(grid)
    mesh = np.meshgrid(*(grid[n] for n in names), indexing="ij")
    assert len(df) == mesh[0].size
    for n, values in zip(names, mesh):
        np.testing.assert_array_equal(df[n].to_numpy(), values.ravel())
    k = df["k"].to_numpy()
    m = df["m"].to_numpy() if "m" in df else np.full(len(df), m_fixed)
    bad = (k < 0) | (m < 1e-12)  # below the min of k (0) or m (1e-12) in the XML
    assert set(df["status"][bad]) <= {"error"} and set(df["status"][~bad]) == {"ok"}
    for _, row in df[bad].iterrows():
        name = "k" if row["k"] < 0 else "m"
        assert f"for {name} is outside" in row["message"], row["message"]
        assert np.isnan(row["x"]) and np.isnan(row["E"])
    ok = df[~bad]
    assert (ok["message"] == "").all()
    want = X0 * np.cos(np.sqrt(ok["k"] / m[~bad]) * T)
    err = np.abs(ok["x"] - want).max()
    print(f"METRIC sweep max |x(T) - x0 cos(sqrt(k/m) T)| = {err:.2e}")
    assert err <= TOL
    # Undamped: the energy stays ½ k x0² (same DOPRI5 error budget, scaled by k x0).
    np.testing.assert_allclose(ok["E"], 0.5 * ok["k"] * X0**2, rtol=0, atol=1e-6 * ok["k"].max() * X0)


@pytest.fixture(scope="module")
def dask_scheduler(tmp_path_factory):
    """A dask scheduler and two single-threaded workers started with dask's own command
    line on the loopback address; torn down by process group whatever the test did."""
    tmp = tmp_path_factory.mktemp("dask")
    dask = str(pathlib.Path(sys.executable).with_name("dask"))
    sfile = tmp / "scheduler.json"
    procs = []

    def start(args, log):
        out = open(tmp / log, "w")
        procs.append(subprocess.Popen([dask, *args], stdout=out, stderr=subprocess.STDOUT,
                                      cwd=tmp, start_new_session=True))

    try:
        # --port 0: the scheduler picks a free port and writes its address to the file.
        start(["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
               "--scheduler-file", str(sfile)], "scheduler.log")
        deadline = time.monotonic() + 60
        while not sfile.exists() or not sfile.read_text().strip():
            assert procs[0].poll() is None, (tmp / "scheduler.log").read_text()
            assert time.monotonic() < deadline, "dask scheduler did not start"
            time.sleep(0.2)
        address = json.loads(sfile.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        start(["worker", address, "--host", "127.0.0.1", "--nworkers", "2", "--nthreads", "1",
               "--no-dashboard", "--local-directory", str(tmp)], "workers.log")
        from distributed import Client
        with Client(address, timeout=60) as client:
            client.wait_for_workers(2, timeout=120)
            assert len(client.scheduler_info()["workers"]) == 2
        yield address
    finally:
        for p in reversed(procs):
            try:
                os.killpg(p.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        for p in reversed(procs):
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(timeout=30)


def test_sweep_on_a_running_scheduler_with_two_workers(dask_scheduler, tmp_path):
    """--scheduler: a 2-D grid (k crosses its min of 0) on two dask workers."""
    out = tmp_path / "msd.parquet"
    cli("--grid", "k=-20:100:25", "--grid", "m=0.5:2:4", "--scheduler", dask_scheduler,
        "--batch-size", "7", "--out", str(out))
    df = pd.read_parquet(out)
    check_rows(df, {"k": np.linspace(-20, 100, 25), "m": np.linspace(0.5, 2, 4)})
    assert (df["status"] == "error").sum() == 4 * 4  # k = -20, -15, -10, -5


def _die_once_then_simulate(marker: str, k_dies: float, inst, point):
    """A run that kills its own worker process the first time it meets k = k_dies (the
    marker file remembers), as a lost machine would; otherwise the usual simulation."""
    import os
    import pathlib

    if point["k"] == k_dies and not pathlib.Path(marker).exists():
        pathlib.Path(marker).write_text(str(os.getpid()))
        os._exit(1)  # no cleanup, no reply: the scheduler sees the worker vanish
    return inst.simulate(T, ["x", "E"], tolerance=1e-10)


def test_a_lost_worker_costs_only_a_retry(dask_scheduler, tmp_path):
    """A worker dies mid-sweep: its batch is run again elsewhere (task retries, the
    nanny restarts the worker) and every row is still there and right."""
    import cloudpickle

    import mbfmu

    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers lack tests/python
    marker = tmp_path / "died"
    k = np.linspace(1, 100, 12)
    run = functools.partial(_die_once_then_simulate, str(marker), float(k[7]))
    df = mbfmu.sweep(fs.fmu_file("MassSpringDamper"), {"k": k}, run=run, batch_size=3,
                     fixed={"c": 0.0, "F_amp": 0.0, "x": X0, "v": 0.0},
                     scheduler=dask_scheduler, progress=False)
    assert marker.exists(), df[["k", "status", "message"]].to_string()  # a worker died
    check_rows(df, {"k": k})


def test_sweep_on_the_default_local_cluster(tmp_path):
    """No --scheduler: a LocalCluster; m crosses its min of 1e-12 (m = -1 and 0 fail)."""
    out = tmp_path / "msd.parquet"
    cli("--grid", "m=-1:2:4", "--grid", "k=0:100:21", "--workers", "2", "--out", str(out))
    df = pd.read_parquet(out)
    check_rows(df, {"m": np.linspace(-1, 2, 4), "k": np.linspace(0, 100, 21)})
    assert (df["status"] == "error").sum() == 2 * 21


def test_sweep_api_linearisation_run_and_samples():
    """On one running client: a DataFrame of Monte Carlo samples against the closed form;
    a run refused with fmi2Discard is a 'discard' row; run=mbfmu.spectrum: eigenvalues from the FMU's directional
    derivatives against -c/2m ± i√(k/m - (c/2m)²) (exact derivatives and a 2x2
    eigenproblem: agreement to rounding, 1e-12 relative to |λ|)."""
    import mbfmu
    from distributed import Client, LocalCluster

    fmu = fs.fmu_file("MassSpringDamper")
    grid = {"k": np.linspace(5, 100, 12), "c": [0.0, 0.5, 3.0], "m": [-1.0, 2.0]}
    with LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address="127.0.0.1:0") \
            as cluster, Client(cluster) as client:
        df = mbfmu.sweep(fmu, grid, run=mbfmu.spectrum, client=client, progress=False)
        # A DataFrame is the runs themselves (Monte Carlo samples), not a product.
        rng = np.random.default_rng(18)
        samples = pd.DataFrame({"k": rng.uniform(1, 100, 40), "m": rng.uniform(0.5, 2, 40)})
        mc = mbfmu.sweep(fmu, samples, fixed={"c": 0.0, "F_amp": 0.0, "x": X0, "v": 0.0},
                         stop_time=T, outputs=["x", "E"], tolerance=1e-10, client=client,
                         progress=False)
        # fmi2Discard: RK4 at 1e-3 s needs 2000 steps to T; solver_max_steps 1000 refuses.
        disc = mbfmu.sweep(fmu, {"solver_max_steps": [1000, 3000]}, stop_time=T,
                           fixed={"solver": 1, "solver_step": 1e-3}, outputs=["x"],
                           client=client, progress=False)
    assert list(disc["status"]) == ["discard", "ok"], disc["message"].tolist()
    assert "fmi2DoStep" in disc["message"][0] and np.isnan(disc["x"][0])
    assert len(mc) == 40 and (mc[["k", "m"]].to_numpy() == samples.to_numpy()).all()
    assert (mc["status"] == "ok").all()
    assert np.abs(mc["x"] - X0 * np.cos(np.sqrt(mc["k"] / mc["m"]) * T)).max() <= TOL
    assert len(df) == 12 * 3 * 2
    assert set(df["status"][df["m"] < 0]) == {"error"}
    ok = df[df["m"] > 0]
    assert set(ok["status"]) == {"ok"}
    sigma = -ok["c"] / (2 * ok["m"])
    disc = ok["k"] / ok["m"] - sigma**2
    assert (disc > 0).all()  # every point here is underdamped: a complex pair
    scale = np.sqrt(ok["k"] / ok["m"])
    np.testing.assert_allclose(ok["re0"], sigma, rtol=0, atol=1e-12 * scale.max())
    np.testing.assert_allclose(ok["re1"], sigma, rtol=0, atol=1e-12 * scale.max())
    np.testing.assert_allclose(ok["im0"], np.sqrt(disc), rtol=1e-12)
    np.testing.assert_allclose(ok["im1"], -np.sqrt(disc), rtol=1e-12)
    np.testing.assert_allclose(ok["max_re"], sigma, rtol=0, atol=1e-12 * scale.max())
