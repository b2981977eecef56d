"""Every FMU in the FMU folder: fmpy finds no problem in it, every system of
`mbfmu list --json` has an FMU, and each scene simulates in fmpy (DOPRI5 at rtol 1e-8,
output every 0.01 s) to its stop time with finite outputs."""

from __future__ import annotations

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

import fmu_support as fs

FMUS = sorted(p.stem for p in fs.fmu_dir().glob("*.fmu"))


def cli() -> pathlib.Path:
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", fs.REPO / "target"))
    return target / "release" / "mbfmu"


def catalogue() -> list[dict]:
    out = subprocess.run([str(cli()), "list", "--json"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


SCENES = [(m["name"], s) for m in catalogue() for s in m["scenes"]]


@pytest.mark.parametrize("name", FMUS)
def test_fmpy_validation_finds_no_problem(name, load_model):
    model = load_model(name)
    assert validate_fmu(str(model.path)) == []


def test_every_system_has_an_fmu():
    assert {m["name"] for m in catalogue()} == set(FMUS)


@pytest.mark.parametrize("name, scene", SCENES, ids=[f"{m}-{s['name']}" for m, s in SCENES])
def test_each_scene_runs_to_its_stop_time(name, scene, load_model):
    model = load_model(name)
    result = simulate_fmu(str(model.path), start_values=scene["start_values"],
                          stop_time=scene["stop_time"], output_interval=0.01,
                          relative_tolerance=1e-8)
    assert abs(result["time"][-1] - scene["stop_time"]) < 1e-9
    for field in result.dtype.names:
        assert np.all(np.isfinite(result[field])), f"{name}/{scene['name']}: {field} not finite"
