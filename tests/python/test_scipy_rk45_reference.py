"""The reference for DOPRI5's scipy-RK45 conformance mode (`tests/scipy_rk45.rs`).

scipy's `solve_ivp(method="RK45")` on two problems at three tolerances: its `nfev` and the
accepted step times, stored in tests/data/scipy_rk45.csv. This test recomputes them with
the installed scipy and fails if the file no longer matches (so the Rust test never
compares against stale numbers). Regenerate with

    python tests/python/test_scipy_rk45_reference.py
"""

from __future__ import annotations

import csv
import pathlib

import numpy as np
from scipy.integrate import solve_ivp

DATA = pathlib.Path(__file__).resolve().parents[1] / "data" / "scipy_rk45.csv"


def oscillator(_t, y):
    return [y[1], -100.0 * y[0]]


def van_der_pol(_t, y):
    mu = 5.0
    return [y[1], mu * (1.0 - y[0] ** 2) * y[1] - y[0]]


# name, f, y0, t_end (the Rust test defines the same right-hand sides)
PROBLEMS = [
    ("oscillator", oscillator, [1.0, 0.0], 10.0),
    ("van_der_pol", van_der_pol, [2.0, 0.0], 20.0),
]
RTOLS = [1e-3, 1e-6, 1e-9]


def runs():
    for name, f, y0, t_end in PROBLEMS:
        for rtol in RTOLS:
            atol = 1e-2 * rtol
            sol = solve_ivp(f, (0.0, t_end), y0, method="RK45", rtol=rtol, atol=atol)
            assert sol.success, sol.message
            yield name, rtol, atol, t_end, sol.nfev, list(sol.t[1:]), list(sol.y[:, -1])


def write() -> None:
    with DATA.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["problem", "rtol", "atol", "t_end", "nfev", "y_end", "times"])
        for name, rtol, atol, t_end, nfev, times, y_end in runs():
            w.writerow([name, repr(rtol), repr(atol), repr(t_end), nfev,
                        " ".join(repr(float(v)) for v in y_end),
                        " ".join(repr(float(t)) for t in times)])


def read():
    with DATA.open() as fh:
        return list(csv.DictReader(fh))


def test_stored_reference_matches_the_installed_scipy():
    stored = read()
    live = list(runs())
    assert len(stored) == len(live)
    for row, (name, rtol, atol, t_end, nfev, times, y_end) in zip(stored, live):
        assert row["problem"] == name and float(row["rtol"]) == rtol
        assert int(row["nfev"]) == nfev, f"{name} rtol {rtol}: nfev {nfev} vs stored {row['nfev']}"
        st = np.array([float(v) for v in row["times"].split()])
        assert st.shape == (len(times),)
        assert np.allclose(st, times, rtol=1e-12, atol=0.0)


if __name__ == "__main__":
    write()
    print(f"wrote {DATA}")
