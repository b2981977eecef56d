"""`mbfmu crosscheck --out DIR` writes the FMI Cross-Check vendor tree of the built FMUs;
fmpy's vendor-repository validator finds no problem in it, and fmpy's cross-check run of
every model (its `_ref.opt` and `_in.csv`) passes against its `_ref.csv`.

The run is fmpy's own (`python -m fmpy.cross_check --simulate`'s `simulate`: simulate_fmu
with the `.opt` step and stop time, the `_in.csv` as input, the `_ref.csv` columns as
outputs), written as a cross-check result (`results/2.0/cs/<platform>/FMPy/<version>/
mbfmu/<version>/<Model>/` with `<Model>_out.csv` and `passed`) that the same validator then
compares with the reference (fmpy.cross_check.validate_result: fewer than 10 % of the
samples outside the tube).  fmpy 0.3.32's `cross_check()` itself calls validate_result
without t_start/t_stop (a TypeError it counts as a failure), so its loop is not used.
"""

from __future__ import annotations

import os
import pathlib
import subprocess

import numpy as np
import pytest
import fmpy
from fmpy.cross_check import validate_result
from fmpy.cross_check.validate_vendor_repo import read_csv, validate_repo
from fmpy.util import read_ref_opt_file

import fmu_support as fs

FMUS = sorted(p.stem for p in fs.fmu_dir().glob("*.fmu"))


def cli() -> pathlib.Path:
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", fs.REPO / "target"))
    return target / "release" / "mbfmu"


@pytest.fixture(scope="module")
def tree(tmp_path_factory):
    out = tmp_path_factory.mktemp("xc")
    subprocess.run([str(cli()), "crosscheck", "--out", str(out), "--fmus", str(fs.fmu_dir())],
                   check=True, capture_output=True, text=True)
    return out


def model_dirs(tree):
    return {d.name: d for d in tree.glob("fmus/2.0/cs/*/mbfmu/*/*") if d.is_dir()}


def test_the_tree_holds_every_fmu_and_the_validator_finds_no_problem(tree):
    dirs = model_dirs(tree)
    assert sorted(dirs) == FMUS
    for name, d in dirs.items():
        for suffix in (".fmu", "_ref.csv", "_ref.opt"):
            assert (d / f"{name}{suffix}").is_file()
        assert (d / "ReadMe.txt").is_file()
    fmu_count, result_count, problems = validate_repo(str(tree))
    assert (fmu_count, problems) == (len(FMUS), [])


@pytest.mark.parametrize("name", FMUS)
def test_fmpys_cross_check_run_passes(tree, name):
    d = model_dirs(tree)[name]
    opt = read_ref_opt_file(str(d / f"{name}_ref.opt"))
    reference = read_csv(str(d / f"{name}_ref.csv"))
    in_csv = d / f"{name}_in.csv"
    md = fmpy.read_model_description(str(d / f"{name}.fmu"))
    has_inputs = any(v.causality == "input" for v in md.modelVariables)
    assert in_csv.is_file() == has_inputs
    # fmpy.cross_check.__main__.simulate
    result = fmpy.simulate_fmu(
        filename=str(d / f"{name}.fmu"), validate=False,
        step_size=opt["StepSize"] or None, stop_time=opt["StopTime"],
        input=fmpy.util.read_csv(str(in_csv)) if has_inputs else None,
        output=reference.dtype.names[1:])
    assert validate_result(result=result, reference=reference,
                           t_start=opt["StartTime"], t_stop=opt["StopTime"]) is None
    # As a cross-check result, for the repository validator.
    res_dir = (tree / "results/2.0/cs" / d.parts[-4] / "FMPy" / fmpy.__version__
               / "mbfmu" / d.parts[-2] / name)
    res_dir.mkdir(parents=True)
    header = ",".join(f'"{n}"' for n in result.dtype.names)
    np.savetxt(res_dir / f"{name}_out.csv", result, delimiter=",", header=header,
               comments="", fmt="%.17g")
    (res_dir / "passed").touch()
    fmu_count, result_count, problems = validate_repo(str(tree))
    assert problems == []
    assert result_count >= 1
