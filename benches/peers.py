#!/usr/bin/env python3
"""Peers of `mbfmu bench`: scipy solve_ivp and SUNDIALS CVODE on every scene of every system.

Run after `mbfmu bench` and `mbfmu build --all` (it reads DIR/reference.csv, DIR/longrun.csv,
DIR/invariant.csv and the FMUs in target/fmu):

    python benches/peers.py [--out docs/bench] [--quick] [--reps 3] [--system M] [--scene S]

No equation is re-typed here. The right-hand side of a scene is the built FMU's own, through
the FMI 2.0 C API (benches/fmu_rhs.py for scipy, via ctypes; benches/cvode_bench.c for CVODE,
which dlopens the FMU's shared library): f(x) is fmi2SetReal of the states then fmi2GetReal of
der(states) on an instance in Initialization Mode, with the scene's parameters and inputs
set; the exact Jacobian of the implicit methods (scipy Radau, BDF, LSODA; CVODE-BDF) is
fmi2GetDirectionalDerivative, one column per call. The initial state is the FMU's after
fmi2ExitInitializationMode (projected onto the constraints where a system has them).

Same tolerances as the adaptive methods of the bench (rtol = tol, atol_i = tol * nominal_i,
as the FMU does), one integration from 0 to the stop time (no communication grid: compare
with the rows of results.csv whose comm_step equals the stop time). Error: max_i |x_i(T) -
ref_i(T)| / scale_i with the reference and scales of reference.csv (the `error_final` of
results.csv). Where the scene is affine and autonomous (checked: the FMU's Jacobian is the
same at two points), the reference is also checked against the closed form e^{MT} (column
ref_vs_closed_form).

Scenes the peers cannot run as one smooth ODE are recorded as `skipped` with the reason
(SphereSlide: its departure event). Systems whose FMU projects its states back onto the
constraints after every doStep (reference.csv column projected: RigidBody's unit quaternion,
RollingHoop, RollingDisk, the surplus-coordinate slider-crank) are integrated by the peers as
the raw ODE, without projection (column note).

Cross-check of our own times (rows with solver `mbfmu-so`): our adaptive methods in one
fmi2DoStep over the scene, through the FMU shared library's C ABI, timed by the CVODE program
(same process layout, same clock), to compare with the in-process times of results.csv.

Long runs: for every scene of longrun.csv (the conservative scenes), the peers integrate over
the same horizon at the same tolerances, and the invariant error |E(t) - E(0)| / |E(0)| is read
from the FMU's output E at the sample times of invariant.csv (scipy: t_eval, i.e. its dense
output; CVODE: CV_NORMAL to each sample time, its interpolation).

Writes DIR/peers.csv, DIR/peers_longrun.csv, DIR/peers_invariant.csv.
"""

import argparse
import csv
import json
import math
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
sys.path.insert(0, HERE)
from fmu_rhs import FmiError, SceneRhs  # noqa: E402

SCIPY = ["RK45", "DOP853", "Radau", "BDF", "LSODA"]
IMPLICIT = ("Radau", "BDF", "LSODA")
CVODE = [("adams", "CVODE-Adams"), ("bdf", "CVODE-BDF")]

# Scenes the peers cannot integrate as one smooth ODE (recorded as skipped, with the reason).
SKIP = {
    ("SphereSlide", "slide"): (
        "event: the particle leaves the sphere (the FMU locates it inside doStep and switches "
        "its mode state); a peer would need the event re-implemented outside the FMU"),
}
# Note on the systems whose FMU projects its states onto the constraints after every doStep
# (reference.csv, column projected).
PROJECTED_NOTE = ("raw ODE: the FMU projects the states onto its constraints after every doStep, "
                  "the peers do not")


def forcing_of(system, start):
    """(start values for the peers, forcing) of a scene.

    MassSpringDamper computes its built-in forcing F_amp sin(F_omega t) from the FMU's own
    time, which an importer cannot set while it evaluates der(x) in Initialization Mode; the
    peers drive the input F with the same function instead (F_amp := 0), the same ODE."""
    if system == "MassSpringDamper" and start.get("F_amp", 0.0) != 0.0:
        if start.get("F", 0.0) != 0.0:
            return None, None
        sv = dict(start, F_amp=0.0)
        return sv, ("F", start["F_amp"], start.get("F_omega", 10.0))
    return dict(start), None


def mbfmu_exe(arg):
    if arg:
        return [arg]
    exe = os.path.join(ROOT, "target", "release", "mbfmu")
    if os.path.exists(exe):
        return [exe]
    return ["cargo", "run", "--quiet", "--release", "--bin", "mbfmu", "--"]


def read_csv(path):
    if not os.path.exists(path):
        return []
    with open(path) as f:
        return list(csv.DictReader(f))


def load_reference(path):
    ref = {}
    for row in read_csv(path):
        key = (row["system"], row["scene"])
        r = ref.setdefault(key, dict(states=[], value=[], scale=[], nominal=[], start=[],
                                     ref_error=float(row.get("ref_error") or "nan"),
                                     invariant=row.get("invariant") == "1",
                                     projected=row.get("projected") == "1",
                                     reference=row.get("reference", "DOP853"),
                                     stop_time=float(row["stop_time"])))
        r["states"].append(row["state"])
        for k in ("value", "scale", "nominal", "start"):
            r[k].append(float(row[k]) if row.get(k) not in (None, "") else float("nan"))
    for r in ref.values():
        for k in ("value", "scale", "nominal", "start"):
            r[k] = np.array(r[k])
    return ref


def scaled_error(x, ref, scale):
    return float(np.max(np.abs(np.asarray(x) - ref) / scale))


def closed_form(rhs, x0, T, scale):
    """e^{MT} [x0; 1] when der(x) = A x + b (A, b constant: the Jacobian is the same at x0
    and at a perturbed point, and the forcing is not time-dependent), else None."""
    if rhs.forcing:
        return None
    A = rhs.jac(0.0, x0)
    rng = np.random.default_rng(1)
    x1 = x0 + 0.1 * scale * rng.standard_normal(len(x0))
    try:
        A1 = rhs.jac(0.0, x1)
    except FmiError:
        return None
    if not np.allclose(A, A1, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(A).max())):
        return None
    b = rhs(0.0, x0) - A @ x0
    n = len(x0)
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n] = A, b
    return (expm(M * T) @ np.append(x0, 1.0))[:n]


class OverBudget(Exception):
    pass


def run_scipy(rhs, method, x0, T, tol, nominal, reps, max_nfev, t_eval=None):
    """(sol, best time, nfev, njev) or raises FmiError / OverBudget."""
    kwargs = dict(rtol=tol, atol=tol * np.asarray(nominal))
    if method in IMPLICIT:
        kwargs["jac"] = rhs.jac
    if t_eval is not None:
        kwargs["t_eval"] = t_eval

    def fun(t, x):
        if rhs.nfev >= max_nfev:
            raise OverBudget(f"over {max_nfev} RHS evaluations")
        return rhs(t, x)

    best, sol = math.inf, None
    for _ in range(reps):
        rhs.nfev = rhs.njev = 0
        t0 = time.perf_counter()
        sol = solve_ivp(fun, (0.0, T), np.asarray(x0, float), method=method, **kwargs)
        dt = time.perf_counter() - t0
        best = min(best, dt)
        if not sol.success or dt > 0.3:
            break  # failed or long runs are timed once
    return sol, best, rhs.nfev, rhs.njev


def build_cvode():
    if not os.path.exists("/usr/include/cvode/cvode.h") or shutil.which("gcc") is None:
        return None, "SUNDIALS headers (libsundials-dev) or gcc not found"
    exe = os.path.join(os.environ.get("TMPDIR", "/tmp"), "mbfmu_cvode_bench")
    cmd = [
        "gcc", "-O2", "-o", exe, os.path.join(HERE, "cvode_bench.c"),
        "-lsundials_cvode", "-lsundials_nvecserial", "-lsundials_sunlinsoldense",
        "-lsundials_sunmatrixdense", "-lsundials_sunnonlinsolfixedpoint", "-ldl", "-lm",
    ]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        return None, "gcc failed: " + r.stderr.strip().splitlines()[0]
    return exe, ""


def cvode_input(rhs, T, reps, tol, x0, trace=(), start=None, own=None):
    F = rhs.fmu
    n = rhs.n
    sets = [(F.vr(k), float(v)) for k, v in (start or rhs.start_values).items()
            if F.vars[k]["real"] and k not in F.states]
    lines = [F.so, F.guid, f"{n} {T!r} {reps} {tol!r} {len(trace)}",
             " ".join(map(str, F.state_vr)), " ".join(map(str, F.der_vr)),
             " ".join(repr(float(tol * v)) for v in F.nominal),
             " ".join(repr(float(v)) for v in x0),
             f"{len(sets)} " + " ".join(f"{vr} {v!r}" for vr, v in sets)]
    if rhs.forcing:
        name, amp, omega = rhs.forcing
        lines.append(f"1 {F.vr(name)} {float(amp)!r} {float(omega)!r}")
    else:
        lines.append("0")
    lines.append(" ".join(repr(float(t)) for t in trace))
    if own:
        code, step, comm = own
        lines.append(f"{F.vr('solver')} {code} {F.vr('solver_step')} {float(step)!r} {float(comm)!r}")
    return "\n".join(lines) + "\n"


def run_cvode(exe, kind, rhs, x0, T, tol, reps, trace=(), timeout=600):
    """dict(nfev, nsteps, netf, njev, nnlcf, cpu, xT, trace) or (None, why)."""
    try:
        p = subprocess.run([exe, kind], input=cvode_input(rhs, T, reps, tol, x0, trace),
                           capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, f"over {timeout} s"
    lines = p.stdout.splitlines()
    if not lines or not lines[0].startswith("ok"):
        return None, (lines[0] if lines else f"no output (exit {p.returncode}) {p.stderr[-200:]}")
    head = lines[0].split()
    if kind == "rhscost":
        return dict(rhs_s=float(head[1]), jac_s=float(head[2])), ""
    nfev, nsteps, netf, njev, nnlcf = map(int, head[1:6])
    res = dict(nfev=nfev, nsteps=nsteps, netf=netf, njev=njev, nnlcf=nnlcf, cpu=float(head[6]),
               xT=np.array(list(map(float, head[7:]))))
    res["trace"] = [np.array(list(map(float, ln.split()[2:]))) for ln in lines[1:]
                    if ln.startswith("trace")]
    return res, ""


# Our adaptive methods (name, `solver` code), run through the FMU's C ABI as a cross-check.
OURS_ADAPTIVE = [("DOPRI5", 2), ("DOP853", 9), ("RADAU5", 10)]


def run_ours_so(exe, rhs, start, x0, T, tol, code, reps):
    """Our method `code` in one fmi2DoStep over the scene, through the shared library's C ABI,
    timed by the same program and clock as CVODE. (cpu, x(T)) or (None, why)."""
    text = cvode_input(rhs, T, reps, tol, x0, start=start, own=(code, 0.0, T))
    p = subprocess.run([exe, "fmu"], input=text, capture_output=True, text=True, timeout=600)
    head = p.stdout.split()
    if not head or head[0] != "ok":
        return None, " ".join(head) or p.stderr[-200:]
    return (float(head[1]), np.array(list(map(float, head[2:])))), ""


def python_call_cost(rhs, x0):
    """Seconds per f(x) and per J(x) through ctypes (min of 3 batches)."""
    best_f = best_j = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        for _ in range(2000):
            rhs(0.0, x0)
        best_f = min(best_f, (time.perf_counter() - t0) / 2000)
        t0 = time.perf_counter()
        for _ in range(200):
            rhs.jac(0.0, x0)
        best_j = min(best_j, (time.perf_counter() - t0) / 200)
    return best_f, best_j


def sweep(rhs, ref, x0, T, tols, args, exe, base, rows, scene_start):
    """The scene sweep: every peer at every tolerance, loose to tight; once a run of a method
    takes longer than --budget seconds, its tighter tolerances are skipped (and said so)."""
    nominal = ref["nominal"]
    for method in SCIPY:
        stop_why = None
        for tol in tols:
            row = dict(base, solver="scipy", method=method, tol=f"{tol:e}")
            if stop_why:
                rows.append(dict(row, status="skipped", message=stop_why))
                continue
            try:
                sol, cpu, nfev, njev = run_scipy(rhs, method, x0, T, tol, nominal, args.reps,
                                                 args.max_nfev)
            except (FmiError, OverBudget) as e:
                rows.append(dict(row, status="failed", rhs_evals=rhs.nfev, message=str(e)))
                stop_why = f"not run: tolerance {tol:g} failed ({e})"
                continue
            row.update(cpu_s=f"{cpu:e}", rhs_evals=nfev, jac_evals=njev, steps=len(sol.t) - 1)
            if sol.success:
                row.update(status="ok", error_final=f"{scaled_error(sol.y[:, -1], ref['value'], ref['scale']):.12e}")
            else:
                row.update(status="failed", message=sol.message)
            rows.append(row)
            if cpu > args.budget:
                stop_why = f"not run: tolerance {tol:g} took {cpu:.1f} s (budget {args.budget:g} s)"
    if exe is None:
        return
    for name, code in OURS_ADAPTIVE:
        for tol in tols:
            row = dict(base, solver="mbfmu-so", method=name, tol=f"{tol:e}")
            res, msg = run_ours_so(exe, rhs, scene_start, x0, T, tol, code, args.reps)
            if res is None:
                rows.append(dict(row, status="failed", message=msg))
                continue
            rows.append(dict(row, status="ok", cpu_s=f"{res[0]:e}",
                             error_final=f"{scaled_error(res[1], ref['value'], ref['scale']):.12e}"))
    for kind, name in CVODE:
        stop_why = None
        for tol in tols:
            row = dict(base, solver="cvode", method=name, tol=f"{tol:e}")
            if stop_why:
                rows.append(dict(row, status="skipped", message=stop_why))
                continue
            res, msg = run_cvode(exe, kind, rhs, x0, T, tol, args.reps)
            if res is None:
                rows.append(dict(row, status="failed", message=msg))
                continue
            row.update(status="ok", cpu_s=f"{res['cpu']:e}", rhs_evals=res["nfev"],
                       jac_evals=res["njev"], steps=res["nsteps"], rejected=res["netf"],
                       error_final=f"{scaled_error(res['xT'], ref['value'], ref['scale']):.12e}")
            rows.append(row)
            if res["cpu"] > args.budget:
                stop_why = f"not run: tolerance {tol:g} took {res['cpu']:.1f} s (budget {args.budget:g} s)"


def long_runs(rhs, ref, x0, times, horizon, tols, args, exe, base, summary, history):
    """Every peer over the long horizon: invariant error at the sample times."""
    nominal = ref["nominal"]
    e0 = rhs.energy(x0)

    def record(row, states, cpu, nfev, extra):
        errs = [abs(rhs.energy(x) - e0) / abs(e0) for x in states]
        row.update(status="ok", max_invariant_error=f"{max(errs):e}",
                   final_invariant_error=f"{errs[-1]:e}", cpu_s=f"{cpu:e}", rhs_evals=nfev, **extra)
        summary.append(row)
        for t, e in zip(times, errs):
            history.append(dict(system=base["system"], scene=base["scene"], solver=row["solver"],
                                method=row["method"], tol=row["tol"], t=repr(float(t)),
                                invariant_error=f"{e:.3e}"))

    peers = [("scipy", m) for m in SCIPY] + ([("cvode", c) for c in CVODE] if exe else [])
    for solver, method in peers:
        name = method if solver == "scipy" else method[1]
        stop_why = None
        for tol in tols:
            row = dict(base, solver=solver, method=name, tol=f"{tol:e}", horizon=repr(horizon))
            if stop_why:
                summary.append(dict(row, status="skipped", message=stop_why))
                continue
            if solver == "scipy":
                try:
                    sol, cpu, nfev, njev = run_scipy(rhs, method, x0, horizon, tol, nominal, 1,
                                                     args.long_max_nfev, t_eval=times)
                except (FmiError, OverBudget) as e:
                    summary.append(dict(row, status="failed", rhs_evals=rhs.nfev, message=str(e)))
                    stop_why = f"not run: tolerance {tol:g} failed ({e})"
                    continue
                if not sol.success or sol.y.shape[1] != len(times):
                    summary.append(dict(row, status="failed", rhs_evals=nfev, message=sol.message))
                    continue
                record(row, sol.y.T, cpu, nfev, dict(jac_evals=njev))
            else:
                res, msg = run_cvode(exe, method[0], rhs, x0, horizon, tol, 1, trace=times)
                if res is None:
                    summary.append(dict(row, status="failed", message=msg))
                    continue
                cpu = res["cpu"]
                record(row, res["trace"], cpu, res["nfev"],
                       dict(jac_evals=res["njev"], steps=res["nsteps"], rejected=res["netf"]))
            if cpu > args.budget:
                stop_why = f"not run: tolerance {tol:g} took {cpu:.1f} s (budget {args.budget:g} s)"


def write(path, fields, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, restval="", extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {path}", file=sys.stderr)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "docs", "bench"))
    ap.add_argument("--quick", action="store_true", help="tolerances 1e-4 and 1e-8 only")
    ap.add_argument("--reps", type=int, default=3, help="repetitions (min time) of short runs")
    ap.add_argument("--system", action="append", default=[])
    ap.add_argument("--scene", action="append", default=[])
    ap.add_argument("--no-long", action="store_true", help="skip the long runs")
    ap.add_argument("--budget", type=float, default=3.0,
                    help="seconds: a run longer than this ends its method's sweep")
    ap.add_argument("--max-nfev", type=int, default=1_000_000,
                    help="RHS evaluations after which a scipy run is abandoned")
    ap.add_argument("--long-max-nfev", type=int, default=300_000,
                    help="the same, for the long runs")
    ap.add_argument("--mbfmu", default=None, help="the mbfmu executable (default target/release)")
    args = ap.parse_args()
    clock = time.perf_counter()
    tols = [1e-4, 1e-8] if args.quick else [10.0 ** -k for k in range(3, 13)]
    reference = load_reference(os.path.join(args.out, "reference.csv"))
    if not reference:
        sys.exit(f"{args.out}/reference.csv is missing or empty: run `mbfmu bench` first")
    listing = json.loads(subprocess.run(mbfmu_exe(args.mbfmu) + ["list", "--json"], check=True,
                                        capture_output=True, text=True).stdout)
    exe, why = build_cvode()
    if exe is None:
        print(f"peers: CVODE skipped ({why})", file=sys.stderr)
    longrun = read_csv(os.path.join(args.out, "longrun.csv"))
    invariant = read_csv(os.path.join(args.out, "invariant.csv"))
    long_tols = sorted({float(r["setting"]) for r in longrun if r["setting_kind"] == "tol"},
                       reverse=True)
    horizons = {(r["system"], r["scene"]): float(r["horizon"]) for r in longrun}
    times = {}
    for r in invariant:
        times.setdefault((r["system"], r["scene"]), set()).add(float(r["t"]))

    rows, summary, history = [], [], []
    for system in listing:
        if args.system and system["name"] not in args.system:
            continue
        for scene in system["scenes"]:
            if args.scene and scene["name"] not in args.scene:
                continue
            key = (system["name"], scene["name"])
            base = dict(system=key[0], scene=key[1],
                        note=PROJECTED_NOTE if reference.get(key, {}).get("projected") else "")
            if key in SKIP:
                rows.append(dict(base, solver="-", method="-", status="skipped", message=SKIP[key]))
                print(f"peers: {key[0]}/{key[1]}: skipped ({SKIP[key]})", file=sys.stderr)
                continue
            if key not in reference:
                print(f"peers: no reference for {key[0]}/{key[1]}, skipped", file=sys.stderr)
                continue
            ref = reference[key]
            start, forcing = forcing_of(key[0], scene["start_values"])
            if start is None:
                rows.append(dict(base, solver="-", method="-", status="skipped",
                                 message="forcing on top of a set input: not supported"))
                continue
            if forcing:
                base["note"] = ("the FMU's built-in forcing F_amp sin(F_omega t) is driven through "
                                "the input F (F_amp := 0): the same ODE")
            T = scene["stop_time"]
            rhs = SceneRhs(key[0], start, forcing=forcing, stop_time=T)
            if rhs.fmu.states != ref["states"]:
                sys.exit(f"{key}: states {rhs.fmu.states} != reference.csv {ref['states']}")
            x0 = rhs.x0
            if not np.allclose(x0, ref["start"], rtol=0, atol=1e-15 * np.maximum(1, np.abs(x0)).max()):
                print(f"peers: {key}: start {x0} differs from reference.csv {ref['start']}", file=sys.stderr)
            exact = closed_form(rhs, x0, T, ref["scale"])
            if exact is not None:
                base["ref_vs_closed_form"] = f"{scaled_error(exact, ref['value'], ref['scale']):e}"
            base["ref_error"] = f"{ref['ref_error']:e}"
            py_f, py_j = python_call_cost(rhs, x0)
            c_cost = run_cvode(exe, "rhscost", rhs, x0, T, 1e-6, 1)[0] if exe else None
            t0 = time.perf_counter()
            n_before = len(rows)
            sweep(rhs, ref, x0, T, tols, args, exe, base, rows, scene["start_values"])
            for r in rows[n_before:]:
                if r["solver"] == "scipy":
                    r.update(rhs_call_s=f"{py_f:e}", jac_call_s=f"{py_j:e}")
                elif r["solver"] == "cvode" and c_cost:
                    r.update(rhs_call_s=f"{c_cost['rhs_s']:e}", jac_call_s=f"{c_cost['jac_s']:e}")
            msg = f"peers: {key[0]}/{key[1]}: sweep {time.perf_counter() - t0:.1f} s"
            if key in horizons and not args.no_long:
                t0 = time.perf_counter()
                ts = np.array(sorted(times[key]))
                long_runs(rhs, ref, x0, ts, horizons[key], long_tols, args, exe,
                          dict(system=key[0], scene=key[1], note=base["note"]), summary, history)
                msg += f", long runs ({horizons[key]:g} s) {time.perf_counter() - t0:.1f} s"
            print(msg, file=sys.stderr)
            rhs.close()

    fields = ["system", "scene", "solver", "method", "tol", "status", "error_final", "cpu_s",
              "rhs_evals", "jac_evals", "steps", "rejected", "rhs_call_s", "jac_call_s",
              "ref_error", "ref_vs_closed_form", "note", "message"]
    write(os.path.join(args.out, "peers.csv"), fields, rows)
    if not args.no_long:
        write(os.path.join(args.out, "peers_longrun.csv"),
              ["system", "scene", "solver", "method", "tol", "horizon", "status",
               "max_invariant_error", "final_invariant_error", "cpu_s", "rhs_evals", "jac_evals",
               "steps", "rejected", "note", "message"], summary)
        write(os.path.join(args.out, "peers_invariant.csv"),
              ["system", "scene", "solver", "method", "tol", "t", "invariant_error"], history)
    print(f"peers: done in {time.perf_counter() - clock:.0f} s", file=sys.stderr)


if __name__ == "__main__":
    main()
