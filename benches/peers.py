#!/usr/bin/env python3
"""Peers of `mbfmu bench`: scipy solve_ivp and SUNDIALS CVODE on the same scenes.

Run after `mbfmu bench` (it reads DIR/reference.csv, the Rust reference at the stop time):

    python benches/peers.py [--out docs/bench] [--quick] [--reps 3]

Scenes (linear, x' = A x, A from ../shared/systems.md with the scene's parameters):
MassSpringDamper/damped, TwoMassChain/release, TwoMassChain/stiff. Same tolerances as the
adaptive methods of the bench (rtol = tol, atol_i = tol * nominal_i, as the FMU does), one
integration from 0 to the stop time (no communication grid: compare with the Rust rows
whose comm_step equals the stop time). Error: max_i |x_i(T) - ref_i(T)| / scale_i with the
reference and scales of reference.csv (the `error_final` of results.csv). The reference is
also checked against the closed form e^{AT} x0 (column ref_vs_expm).

CVODE (Adams with fixed-point iteration; BDF with Newton, dense, exact Jacobian) runs through
benches/cvode_bench.c, compiled here with gcc if SUNDIALS is installed
(`apt-get install libsundials-dev`); otherwise it is skipped and said so.
Writes DIR/peers.csv.
"""

import argparse
import csv
import os
import shutil
import subprocess
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp
from scipy.linalg import expm

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def msd(m=1.0, k=100.0, c=2.0):
    return np.array([[0.0, 1.0], [-k / m, -c / m]])


def chain(m1=1.0, m2=1.0, k1=100.0, k2=100.0, c2=2.0):
    # states x1, x2, v1, v2
    return np.array(
        [
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
            [(-k1 - k2) / m1, k2 / m1, -c2 / m1, c2 / m1],
            [k2 / m2, -k2 / m2, c2 / m2, -c2 / m2],
        ]
    )


# (system, scene, A, x0, nominal, stop time): the scenes of src/systems/*.rs.
SCENES = [
    ("MassSpringDamper", "damped", msd(c=2.0), [0.1, 0.0], [0.1, 1.0], 10.0),
    ("TwoMassChain", "release", chain(), [0.1, 0.0, 0.0, 0.0], [0.1, 0.1, 1.0, 1.0], 10.0),
    (
        "TwoMassChain",
        "stiff",
        chain(k2=1e6, c2=10.0),
        [0.1, 0.0, 0.0, 0.0],
        [0.1, 0.1, 1.0, 1.0],
        2.0,
    ),
]

SCIPY = ["RK45", "DOP853", "Radau", "BDF", "LSODA"]


def load_reference(path):
    ref = {}
    with open(path) as f:
        for row in csv.DictReader(f):
            key = (row["system"], row["scene"])
            ref.setdefault(key, ([], []))
            ref[key][0].append(float(row["value"]))
            ref[key][1].append(float(row["scale"]))
    return {k: (np.array(v), np.array(s)) for k, (v, s) in ref.items()}


def scaled_error(x, ref, scale):
    return float(np.max(np.abs(np.asarray(x) - ref) / scale))


def run_scipy(method, A, x0, T, tol, nominal, reps):
    fun = lambda t, x: A @ x  # noqa: E731  (the numpy RHS of the linear system)
    jac = (lambda t, x: A) if method in ("Radau", "BDF", "LSODA") else None
    kwargs = dict(rtol=tol, atol=tol * np.asarray(nominal))
    if jac is not None:
        kwargs["jac"] = jac
    best, sol = np.inf, None
    for _ in range(reps):
        t0 = time.perf_counter()
        sol = solve_ivp(fun, (0.0, T), np.asarray(x0, float), method=method, **kwargs)
        best = min(best, time.perf_counter() - t0)
        if not sol.success:
            break
    return sol, best


def build_cvode():
    if not os.path.exists("/usr/include/cvode/cvode.h") or shutil.which("gcc") is None:
        return None, "SUNDIALS headers (libsundials-dev) or gcc not found"
    exe = os.path.join(os.environ.get("TMPDIR", "/tmp"), "mbfmu_cvode_bench")
    cmd = [
        "gcc", "-O2", "-o", exe, os.path.join(HERE, "cvode_bench.c"),
        "-lsundials_cvode", "-lsundials_nvecserial", "-lsundials_sunlinsoldense",
        "-lsundials_sunmatrixdense", "-lsundials_sunnonlinsolfixedpoint", "-lm",
    ]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        return None, "gcc failed: " + r.stderr.strip().splitlines()[0]
    return exe, ""


def run_cvode(exe, kind, A, x0, T, tol, nominal, reps):
    n = len(x0)
    text = f"{n} {T!r} {reps} {tol!r}\n"
    text += " ".join(repr(tol * v) for v in nominal) + "\n"
    text += " ".join(repr(float(v)) for v in x0) + "\n"
    text += " ".join(repr(float(v)) for v in np.asarray(A).ravel()) + "\n"
    out = subprocess.run([exe, kind], input=text, capture_output=True, text=True).stdout.split()
    if not out or out[0] != "ok":
        return None, " ".join(out)
    nfev, nsteps, netf, njev = map(int, out[1:5])
    return (nfev, nsteps, netf, njev, float(out[5]), np.array(list(map(float, out[6:])))), ""


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "bench"))
    ap.add_argument("--quick", action="store_true", help="tolerances 1e-4 and 1e-8 only")
    ap.add_argument("--reps", type=int, default=3)
    args = ap.parse_args()
    tols = [1e-4, 1e-8] if args.quick else [10.0 ** -k for k in range(3, 13)]
    ref_path = os.path.join(args.out, "reference.csv")
    if not os.path.exists(ref_path):
        sys.exit(f"{ref_path} is missing: run `mbfmu bench` first")
    reference = load_reference(ref_path)
    exe, why = build_cvode()
    if exe is None:
        print(f"peers: CVODE skipped ({why})", file=sys.stderr)
    rows = []
    for system, scene, A, x0, nominal, T in SCENES:
        if (system, scene) not in reference:
            print(f"peers: no reference for {system}/{scene}, skipped", file=sys.stderr)
            continue
        ref, scale = reference[(system, scene)]
        exact = expm(A * T) @ np.asarray(x0)
        ref_vs_expm = scaled_error(exact, ref, scale)
        print(f"peers: {system}/{scene}: reference vs e^(AT) x0: {ref_vs_expm:.2e}", file=sys.stderr)
        base = dict(system=system, scene=scene, ref_vs_expm=f"{ref_vs_expm:e}")
        for tol in tols:
            for method in SCIPY:
                sol, cpu = run_scipy(method, A, x0, T, tol, nominal, args.reps)
                row = dict(base, solver="scipy", method=method, tol=f"{tol:e}", cpu_s=f"{cpu:e}",
                           rhs_evals=sol.nfev, jac_evals=sol.njev, steps="", rejected="")
                if sol.success:
                    row.update(status="ok", error_final=f"{scaled_error(sol.y[:, -1], ref, scale):e}",
                               error_vs_expm=f"{scaled_error(sol.y[:, -1], exact, scale):e}")
                else:
                    row.update(status="failed", error_final="", error_vs_expm="", message=sol.message)
                rows.append(row)
            if exe is None:
                continue
            for kind, name in (("adams", "CVODE-Adams"), ("bdf", "CVODE-BDF")):
                res, msg = run_cvode(exe, kind, A, x0, T, tol, nominal, args.reps)
                row = dict(base, solver="cvode", method=name, tol=f"{tol:e}")
                if res is None:
                    row.update(status="failed", message=msg)
                else:
                    nfev, nsteps, netf, njev, cpu, xT = res
                    row.update(status="ok", cpu_s=f"{cpu:e}", rhs_evals=nfev, jac_evals=njev,
                               steps=nsteps, rejected=netf,
                               error_final=f"{scaled_error(xT, ref, scale):e}",
                               error_vs_expm=f"{scaled_error(xT, exact, scale):e}")
                rows.append(row)
        print(f"peers: {system}/{scene} done", file=sys.stderr)
    fields = ["system", "scene", "solver", "method", "tol", "status", "error_final", "error_vs_expm",
              "cpu_s", "rhs_evals", "jac_evals", "steps", "rejected", "ref_vs_expm", "message"]
    path = os.path.join(args.out, "peers.csv")
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, restval="")
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {path}", file=sys.stderr)


if __name__ == "__main__":
    main()
