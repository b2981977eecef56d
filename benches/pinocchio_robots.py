"""Pinocchio's side of `mbfmu speed --robots`, and its chart.

    python benches/pinocchio_robots.py serve        # driven by `mbfmu speed --robots`
    python benches/pinocchio_robots.py plot CSV PNG # the chart of docs/bench/robots.csv

`serve` reads JSON lines on stdin and answers one JSON line each, so that the Rust process
alternates its own timing repetitions with Pinocchio's in one run (the machine's load then
weighs on both alike):

- first `{"models": [{"name", "urdf", "q", "qd", "tau"}, ...]}`: builds each model with
  `pin.buildModelFromUrdf` from the same URDF files the Rust side read, answers `pin.aba`
  at the given state (`{"qdd": {name: [...]}}`) for the Rust side to check that both
  compute the same q̈ (τ there is already τ − d q̇: `pin.aba` has no damping);
- then `"rep"`: one repetition of every timing loop, answering seconds per call,
  `{name: {"aba": s, "aba_world": s, "derivatives": s}}`, and the same calls on a model
  with no joint under `"__empty__"`: the Python-to-C++ binding's cost with (almost) no
  C++ work, which the Rust side takes off (so the figures are Pinocchio's own C++ time per
  call, as benches/pinocchio_chain.py does);
- `{"interpreted": [{"name", "file", "floating"}, ...]}` (the second table: robots the
  runtime interprets, `src/bench/interpreted.rs`): builds each example-robot-data file
  (free-flyer root where floating; its mimic model too where it has mimic joints and a
  fixed base) and answers `{"robots": example-robot-data's robots/ folder}`; then
  `{"time": name}`: `{"aba": s, "mimic": s}` (`crba` + `nonLinearEffects` of the mimic
  model, where built) at a random configuration, the binding's cost taken off here;
- `"quit"`.

Timed: `pin.aba` (forward dynamics, one RHS; in its default LOCAL convention, and in the
WORLD convention: the Rust side keeps the faster of the two, Pinocchio's best) and
`pin.computeABADerivatives` (∂q̈/∂q, ∂q̈/∂q̇ and M⁻¹, returned as references to `data`,
no copy). Each loop runs about 20 ms.
"""

from __future__ import annotations

import json
import sys
import timeit

import numpy as np
import pinocchio as pin

LOOP_SECONDS = 0.02


def calls(model, q, v, tau):
    data = model.createData()
    world = pin.Convention.WORLD
    return {
        "aba": lambda: pin.aba(model, data, q, v, tau),
        "aba_world": lambda: pin.aba(model, data, q, v, tau, world),
        "derivatives": lambda: pin.computeABADerivatives(model, data, q, v, tau),
    }


def number(fn) -> int:
    """Calls per timing loop: about LOOP_SECONDS."""
    t = timeit.timeit(fn, number=50) / 50
    return max(50, int(LOOP_SECONDS / max(t, 1e-9)))


def robots_dir():
    """``<site-packages>/cmeel.prefix/share/example-robot-data/robots``."""
    import pathlib

    for base in map(pathlib.Path, sys.path):
        d = base / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if d.is_dir():
            return d
    raise SystemExit("pinocchio_robots.py: example-robot-data's robots/ is not on sys.path")


_BINDING = []


def binding_cost() -> float:
    """Seconds of one binding call with (almost) no C++ work: `pin.aba` on a model with no
    joint, the best of 5 loops."""
    if not _BINDING:
        z = np.zeros(0)
        fn = calls(pin.Model(), z, z, z)["aba"]
        n = number(fn)
        _BINDING.append(min(timeit.timeit(fn, number=n) / n for _ in range(5)))
    return _BINDING[0]


def interpreted_calls(urdf: str, floating: bool):
    """The timed calls of one robot of the second table: {key: (fn, loop size, binding
    calls per fn)}."""
    np.random.seed(7)
    root = [pin.JointModelFreeFlyer()] if floating else []
    model = pin.buildModelFromUrdf(urdf, *root)
    data = model.createData()
    q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    v, tau = np.random.uniform(-1, 1, model.nv), np.random.uniform(-5, 5, model.nv)
    fn = lambda: pin.aba(model, data, q, v, tau)
    out = {"aba": (fn, number(fn), 1)}
    if not floating:
        mimic = pin.buildModelFromUrdf(urdf, mimic=True)
        if mimic.nv < model.nv:
            md = mimic.createData()
            mq = pin.randomConfiguration(mimic, -np.ones(mimic.nq), np.ones(mimic.nq))
            mv = np.random.uniform(-1, 1, mimic.nv)

            def both():
                pin.crba(mimic, md, mq)
                pin.nonLinearEffects(mimic, md, mq, mv)

            out["mimic"] = (both, number(both), 2)
    return out


def serve():
    setups, interpreted = {}, {}
    for line in sys.stdin:
        msg = json.loads(line)
        if msg == "quit":
            return
        if isinstance(msg, dict) and "models" in msg:
            qdd = {}
            for m in msg["models"]:
                model = pin.buildModelFromUrdf(m["urdf"])
                q, v, tau = (np.array(m[k], dtype=float) for k in ("q", "qd", "tau"))
                assert model.nq == model.nv == len(q), (m["name"], model.nq, len(q))
                qdd[m["name"]] = pin.aba(model, model.createData(), q, v, tau).tolist()
                fns = calls(model, q, v, tau)
                setups[m["name"]] = {k: (fn, number(fn)) for k, fn in fns.items()}
            empty = pin.Model()
            z = np.zeros(0)
            fns = calls(empty, z, z, z)
            setups["__empty__"] = {k: (fn, number(fn)) for k, fn in fns.items()}
            print(json.dumps({"qdd": qdd, "version": pin.__version__}), flush=True)
        elif isinstance(msg, dict) and "interpreted" in msg:
            robots = robots_dir()
            for m in msg["interpreted"]:
                interpreted[m["name"]] = interpreted_calls(str(robots / m["file"]), m["floating"])
            print(json.dumps({"robots": str(robots)}), flush=True)
        elif isinstance(msg, dict) and "time" in msg:
            out = {}
            for k, (fn, n, calls_made) in interpreted[msg["time"]].items():
                out[k] = timeit.timeit(fn, number=n) / n - calls_made * binding_cost()
            print(json.dumps(out), flush=True)
        elif msg == "rep":
            out = {}
            for name, fns in setups.items():
                out[name] = {k: timeit.timeit(fn, number=n) / n for k, (fn, n) in fns.items()}
            print(json.dumps(out), flush=True)
        else:
            raise SystemExit(f"pinocchio_robots.py: unknown message {msg!r}")


def plot(csv_path: str, png_path: str):
    import csv

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = list(csv.DictReader(open(csv_path)))
    chain = [r for r in rows if r["model"].startswith("chain_")]
    arms = [r for r in rows if not r["model"].startswith("chain_")]
    f = lambda rs, k: [float(r[k]) for r in rs]
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 4.8), gridspec_kw={"width_ratios": [3, 2]})
    n = [int(r["nq"]) for r in chain]
    ax.loglog(n, f(chain, "generated_rhs_ns"), "o-", color="C0", label="mbfmu generated: one RHS (q̈)")
    ax.loglog(n, f(chain, "interpretive_rhs_ns"), "o:", color="C0", alpha=0.6,
              label="mbfmu Model::aba (interpretive): one RHS")
    ax.loglog(n, f(chain, "jacobian_ns"), "s--", color="C0",
              label="mbfmu Jacobian ∂q̈/∂(q, q̇): symbolic (N ≤ 8), else analytical")
    ax.loglog(n, f(chain, "dual_jacobian_ns"), "s:", color="C0", alpha=0.5,
              label="mbfmu Jacobian by dual numbers through the generated code")
    ax.loglog(n, f(chain, "pinocchio_aba_ns"), "o-", color="C3", label="Pinocchio aba")
    ax.loglog(n, f(chain, "pinocchio_derivatives_ns"), "s--", color="C3",
              label="Pinocchio computeABADerivatives")
    ax.set_xlabel("links N (spatial chain, axes z, y, x, …)")
    ax.set_ylabel("ns per call")
    ax.set_title("Spatial chain: cost against size (same run)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    names = [r["model"] for r in arms]
    x = np.arange(len(names))
    w = 0.2
    for k, (key, label, color, hatch) in enumerate([
        ("generated_rhs_ns", "mbfmu RHS", "C0", None),
        ("pinocchio_aba_ns", "Pinocchio aba", "C3", None),
        ("jacobian_ns", "mbfmu Jacobian", "C0", "//"),
        ("pinocchio_derivatives_ns", "Pinocchio ABA derivatives", "C3", "//"),
    ]):
        bx.bar(x + (k - 1.5) * w, f(arms, key), w, label=label, color=color,
               hatch=hatch, alpha=0.9 if hatch is None else 0.5)
    bx.set_xticks(x, [f"{a['model']} (n = {a['nq']})" for a in arms])
    bx.set_yscale("log")
    bx.set_ylabel("ns per call")
    bx.set_title("Robot arms")
    bx.grid(True, axis="y", which="both", alpha=0.3)
    bx.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)
    print(f"wrote {png_path}")


if __name__ == "__main__":
    if sys.argv[1:2] == ["serve"]:
        serve()
    elif sys.argv[1:2] == ["plot"] and len(sys.argv) == 4:
        plot(sys.argv[2], sys.argv[3])
    else:
        raise SystemExit(__doc__)
