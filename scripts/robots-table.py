#!/usr/bin/env python3
"""Writes docs/robots.md: every URDF of example-robot-data built with `mbfmu build --urdf`
(the prebuilt runtime, this machine's binary), with its coordinates, build time, FMU size
and q̈ error against Pinocchio (its mimic model) at 10 random states; or the one line it was
refused with. Run with the test virtualenv after `build --all`:

    .venv/bin/python scripts/robots-table.py

It uses the helpers of tests/python/test_real_robots.py (which asserts what this reports).
"""

from __future__ import annotations

import pathlib
import re
import sys
import tempfile
import time

import numpy as np

REPO = pathlib.Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests" / "python"))

import fmu_support as fs  # noqa: E402
from test_real_robots import (  # noqa: E402
    REFUSED, PinocchioMimic, build, coordinate_damping, every_urdf, initialised_at,
    urdf_joints,
)
from test_multibody_pinocchio import robots_dir  # noqa: E402


def qdd_error(model: fs.Model, urdf: pathlib.Path) -> float:
    n = len(model.state_names) // 2
    ours = model.state_names[:n]
    ref = PinocchioMimic(urdf, ours)
    d = coordinate_damping(urdf_joints(urdf), ours)
    prismatic = np.array([model.vars[j].unit == "m" for j in ours])
    inst = model.instance("table")
    rng = np.random.default_rng(7)
    worst = 0.0
    try:
        for k in range(10):
            q = rng.uniform(-np.pi, np.pi, n)
            q[prismatic] = rng.uniform(-0.05, 0.05, prismatic.sum())
            qd = rng.uniform(-2, 2, n)
            initialised_at(inst, ours, q, qd, np.zeros(n), reset=k > 0)
            want = ref.qdd(q, qd, -d * qd)
            got = np.array(inst.get_reals([f"der({j}_dot)" for j in ours]))
            worst = max(worst, (np.abs(got - want) / np.maximum(1.0, np.abs(want))).max())
    finally:
        inst.free()
    return worst


def main() -> None:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp)
        for rel in every_urdf():
            urdf = robots_dir() / rel
            identifier = "R_" + "".join(c if c.isalnum() else "_" for c in rel.removesuffix(".urdf"))
            start = time.perf_counter()
            res = build(urdf, out, "--name", identifier, "--platforms", "host")
            seconds = time.perf_counter() - start
            if res.returncode != 0:
                line = res.stderr.strip().splitlines()[-1]
                why = re.sub(r"^mbfmu: (\S+?\.urdf(:\d+)?: |mechanism_runtime: )", "", line)
                why = re.sub(r"; integration stopped.*", "", why)
                kind = ("refused: " + REFUSED[rel][1]) if rel in REFUSED else "FAILS"
                rows.append(f"| `{rel}` | | {kind} | | | {why.replace('|', '/')} |")
                print(rel, kind)
                continue
            joints = re.search(r"\(([^)]*) joints", res.stdout).group(1)
            fmu = out / f"{identifier}.fmu"
            model = fs.Model(identifier, fmu)
            err = qdd_error(model, urdf)
            size = fmu.stat().st_size / 1e6
            rows.append(f"| `{rel}` | {joints} | builds, runs | {seconds:.1f} s | {size:.1f} MB | {err:.1e} |")
            print(rel, joints, f"{seconds:.1f} s", f"{err:.1e}")
    built = sum("builds, runs" in r for r in rows)
    text = f"""# Every URDF of example-robot-data 6.0

Each of the {len(rows)} files built with `mbfmu build --urdf FILE --platforms host` (the
prebuilt mechanism runtime: no compiler), as `scripts/robots-table.py` measured it on this
project's 2-core machine. **{built} build** and run their default experiment;
`tests/python/test_real_robots.py` asserts the same for every file (the FMU's der(J_dot) and
E against Pinocchio to 1e-10 at random states, the default experiment run by fmpy to its
stop time, or the one refusal line below).

Columns: joints (coordinates, + mimic joints that follow them); the build's wall time
(reading, the reference run, linearisation, the page: most of it is the reference run of
the default experiment); the FMU's size with this machine's binary only (each further
platform adds 1–3 MB); the largest relative difference of q̈ from Pinocchio's (`crba` and
`nonLinearEffects` of its mimic model, the URDF's damping applied) at 10 random states with
no input, relative to max(1, |q̈ᵢ|). A refused file's column says why, in the build's own
words. Joint limits are end stops (`limit_events = stops`, the default): the robots that fall
onto their limits in the default experiment (the humanoids, Baxter, PR2, Centauro, TIAGo)
build in 12–31 s, most of it their reference run through the impacts.

| file | joints | result | build | FMU | q̈ error / why |
|---|---|---|---|---|---|
""" + "\n".join(rows) + "\n"
    (REPO / "docs" / "robots.md").write_text(text)
    print(f"wrote docs/robots.md: {built} of {len(rows)} build")


if __name__ == "__main__":
    main()
