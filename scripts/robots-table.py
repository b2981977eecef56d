#!/usr/bin/env python3
"""Writes docs/robots.md: every URDF of example-robot-data built with `mbfmu build --urdf`
(the prebuilt runtime, this machine's binary; `--floating-base` for the legged, humanoid and
flying robots, FLOATING in tests/python/test_real_robots.py), with its coordinates, base,
build time, FMU size and q̈ error against Pinocchio (its mimic model, or its free-flyer
model for a floating base) at 10 random states; or the one line it was refused with. Run
with the test virtualenv after `build --all`:

    .venv/bin/python scripts/robots-table.py

It uses the helpers of tests/python/test_real_robots.py (which asserts what this reports).
The operations column is the count of the straight-line q̈ that `--compile` would generate
(read from the crate `mbfmu new --from-urdf` writes, which carries that code; no compiler).
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

import subprocess  # noqa: E402

import fmu_support as fs  # noqa: E402
from test_linearization import cli  # noqa: E402
from test_real_robots import (  # noqa: E402
    FLOATING, REFUSED, base_options, build, every_urdf, identifier_of, worst_against_pinocchio,
)
from test_multibody_pinocchio import robots_dir  # noqa: E402


def qdd_error(model: fs.Model, urdf: pathlib.Path) -> float:
    """The largest relative q̈ error (a floating base's acceleration included) at 10
    random states with no input."""
    inst = model.instance("table")
    try:
        return worst_against_pinocchio(model, urdf, inst, np.random.default_rng(7), 10, torques=False)["qdd"]
    finally:
        inst.free()


def operations(urdf: pathlib.Path, rel: str, scratch: pathlib.Path, identifier: str, joints: str) -> str:
    """The operations of the q̈ `--compile` would generate for this robot (the header of the
    src/dynamics.rs `mbfmu new --from-urdf` writes); past the generator's limit, none is
    written and the interpreted algorithm runs."""
    crate = scratch / f"crate_{identifier}"
    res = subprocess.run([str(cli()), "new", identifier, "--from-urdf", str(urdf), "--dir", str(crate),
                          *base_options(rel)], capture_output=True, text=True)
    if res.returncode != 0:
        return "?"
    dynamics = crate / "src" / "dynamics.rs"
    if not dynamics.exists():
        # None for a robot with no moving joint (a floating body alone: Euler's equations
        # interpreted), else past the generator's limit.
        return "— (no joint)" if joints == "0" else "> 20 000 (none generated)"
    m = re.search(r"`aba`: (\d+) operations", dynamics.read_text())
    return f"{int(m.group(1)):,}".replace(",", " ") if m else "?"


def main() -> None:
    rows, seconds_of = [], {}
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp)
        for rel in every_urdf():
            urdf = robots_dir() / rel
            identifier = identifier_of(rel)
            base = "floating" if rel in FLOATING else "fixed"
            start = time.perf_counter()
            res = build(urdf, out, "--name", identifier, "--platforms", "host", *base_options(rel))
            seconds = time.perf_counter() - start
            if res.returncode != 0:
                line = res.stderr.strip().splitlines()[-1]
                why = re.sub(r"^mbfmu: (\S+?\.urdf(:\d+)?: |mechanism_runtime: )", "", line)
                why = re.sub(r"; integration stopped.*", "", why)
                kind = ("refused: " + REFUSED[rel][1]) if rel in REFUSED else "FAILS"
                rows.append(f"| `{rel}` | | {base} | {kind} | | | | {why.replace('|', '/')} |")
                print(rel, base, kind)
                continue
            joints = re.search(r"\(([^)]*) joints", res.stdout).group(1)
            fmu = out / f"{identifier}.fmu"
            model = fs.Model(identifier, fmu)
            err = qdd_error(model, urdf)
            size = fmu.stat().st_size / 1e6
            ops = operations(urdf, rel, out, identifier, joints)
            rows.append(f"| `{rel}` | {joints} | {base} | builds, runs | {seconds:.1f} s | {size:.1f} MB | {ops} | {err:.1e} |")
            print(rel, joints, base, f"{seconds:.1f} s", ops, f"{err:.1e}")
    (REPO / "docs" / "robots.md").write_text(page(rows))
    print(f"wrote docs/robots.md: {sum('builds, runs' in r for r in rows)} of {len(rows)} build")


def page(rows: list[str]) -> str:
    """docs/robots.md from the table's rows."""
    built = sum("builds, runs" in r for r in rows)
    floating_built = sum("| floating | builds, runs" in r for r in rows)
    refused = sum("| refused: " in r for r in rows)
    times = []
    for r in rows:
        m = re.match(r"\| `([^`]*)` \| [^|]* \| (\w+) \| builds, runs \| ([\d.]+) s \|", r)
        if m and float(m.group(3)) >= 10:
            times.append((float(m.group(3)), pathlib.Path(m.group(1)).stem, m.group(2)))
    slow = ", ".join(f"{stem} ({base}) {t:.0f} s" for t, stem, base in sorted(times, reverse=True))
    return f"""# Every URDF of example-robot-data 6.0

Each of the {len(rows)} files built with `mbfmu build --urdf FILE --platforms host` (the
prebuilt mechanism runtime: no compiler), as `scripts/robots-table.py` measured it on this
project's 2-core machine. **{built} build** and run their default experiment, {refused} are
refused for their own fault; `tests/python/test_real_robots.py` asserts the same for every
file (the FMU's der(J_dot), a floating base's acceleration and E against Pinocchio to 1e-10
at random states, the default experiment run by fmpy to its stop time, or the one refusal
line below).

**Base.** The legged robots, humanoids and flying robots, {len(FLOATING)} files
({floating_built} of them build), are built with `--floating-base`: those
example-robot-data's own loaders put on a free-flyer root joint (the quadrupeds, with or
without an arm, Centauro, the bipeds and humanoids, PR2, Hector's and Iris's quadrotors,
Borinot's and Hextilt's flying arms), and the files without a loader of their own as their
siblings (`iris.urdf`, Romeo's small models, `talos_reduced_corrected.urdf`); the SO-100 and
SO-101, which their loader also floats, are desk arms and stay fixed like every other arm,
hand, pendulum and TIAGo (`FLOATING` in the test names each file). A floating robot has no
ground contact: in its default experiment (at rest, no torques) it falls freely, its shape
kept (the test checks base_z = −½ g t²). A single rigid body (`quadrotor_base.urdf`,
`iris_simple.urdf`) floating is an FMU of its base's 13 states alone.

Columns: joints (coordinates, + mimic joints that follow them); base (fixed, or floating:
six more degrees of freedom); the build's wall time (reading, the reference run,
linearisation, the page); the FMU's size with this machine's binary only (each further
platform adds 1–3 MB); the largest relative difference of q̈ (and of a floating base's
acceleration) from Pinocchio's at 10 random states (a floating base at a random position,
attitude and velocity) with no input, relative to max(1, |q̈ᵢ|): fixed, `crba` and
`nonLinearEffects` of its mimic model; floating, `aba` of its free-flyer model (with mimic
joints, its mass matrix and bias reduced to the independent joints); the URDF's damping
applied, and its Coulomb friction (18 files: TIAGo, Talos, Centauro, the Allegro hands, Z1,
xArm7, Go1, B1-Z1, Hextilt) taken off Pinocchio's as −F sign(q̇), every joint slipping at
these states. A robot with friction starts at rest, so its joints stick until a load beats
their friction (the Allegro hands, which fell onto their stops in 68–71 s of reference run
before friction, now stay held and build in 1 s). A refused file's column says why, in the build's own words. Joint limits are end
stops (`limit_events = stops`, the default): a fixed robot that falls onto its limits in
the default experiment has its reference run go through the impacts. Builds of 10 s or
more: {slow or "none"}. Operations: those of the straight-line q̈ (and base
acceleration) that `--compile` generates for the robot (the runtime interprets the same
algorithm); past 20 000 it generates none (rustc would take minutes) and the compiled
FMU runs the interpreted algorithm too.

| file | joints | base | result | build | FMU | operations | q̈ error / why |
|---|---|---|---|---|---|---|---|
""" + "\n".join(rows) + "\n"


if __name__ == "__main__":
    main()
