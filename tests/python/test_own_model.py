"""A model of one's own, as a new user makes it, outside the repository: `mbfmu new`, then
`mbfmu build --manifest-path` and `mbfmu linearize --manifest-path`; the CLI's help,
version and errors; and the in-tree FMUs carrying the committed modelDescription/ texts.

The user's crate builds into target/urdf-target (CARGO_TARGET_DIR), where `build --urdf`
builds the robots of test_urdf_fmu.py: both depend on mbfmu without its `cli` feature, so
it compiles once for all of them (about 2.5 min on 2 cores; a change of the model's file
about 15 s).
"""

from __future__ import annotations

import os
import pathlib
import subprocess
import zipfile

import fmpy
import numpy as np
import pytest
from fmpy.validation import validate_fmu
from scipy.special import ellipj, ellipk

import fmu_support as fs
from test_linearization import cli

NAME = "MyPendulum"


def run(*args, cwd=None, check=True, env=None):
    out = subprocess.run([str(cli()), *map(str, args)], cwd=cwd, capture_output=True,
                         text=True, env=env)
    if check and out.returncode != 0:
        pytest.fail(f"mbfmu {' '.join(map(str, args))} failed:\n{out.stderr}", pytrace=False)
    return out


def build_env():
    target = cli().parent.parent / "urdf-target"
    return {**os.environ, "CARGO_TARGET_DIR": str(target)}


@pytest.fixture(scope="module")
def crate(tmp_path_factory) -> pathlib.Path:
    """`mbfmu new MyPendulum` in an empty folder outside the repository."""
    home = tmp_path_factory.mktemp("user")
    out = run("new", NAME, cwd=home)
    assert "mbfmu build --manifest-path" in out.stdout
    root = home / NAME
    for f in ["Cargo.toml", "src/lib.rs", "README.md"]:
        assert (root / f).is_file(), f
    assert "[workspace]" in (root / "Cargo.toml").read_text()
    return root


GENERATED = "runs the equations generated from its Lagrangian (src/eom.rs"


def build(crate: pathlib.Path, runs: str | None = None) -> pathlib.Path:
    """`mbfmu build` of the crate; `runs`: what it must say the FMU runs."""
    out = run("build", "--manifest-path", crate / "Cargo.toml", "--platforms", "host", env=build_env())
    if runs is not None:
        assert runs in out.stdout, out.stdout
    fmu = crate / "target" / "fmu" / f"{NAME}.fmu"
    assert fmu.is_file()
    return fmu


def assert_exact_pendulum(fmu, g: float, theta0: float = 1.0):
    """θ against the exact solution θ = 2 asin(k sn(K − ω t, k)), k = sin(θ0/2), ω = √(g/l),
    l = 1, to 1e-7 rad over 10 s at rtol 1e-10 (DOPRI5's global error there is ~1e-9)."""
    res = simulate(fmu, {"theta": theta0}, 10.0, ["theta", "E"])
    t, theta = res["time"], res["theta"]
    omega, m = np.sqrt(g), np.sin(theta0 / 2) ** 2
    sn = ellipj(ellipk(m) - omega * t, m)[0]
    assert np.max(np.abs(theta - 2 * np.arcsin(np.sqrt(m) * sn))) < 1e-7
    return res


def simulate(fmu, start, stop, outputs):
    return fmpy.simulate_fmu(str(fmu), start_values=start, stop_time=stop,
                             output_interval=0.01, relative_tolerance=1e-10, output=outputs)


def test_the_template_builds_validates_and_swings_as_the_exact_pendulum(crate):
    """The template (m = l = 1, g = 9.81, no damping) from θ0 = 1 rad: θ against the exact solution
    θ = 2 asin(k sn(K − ω t, k)), k = sin(θ0/2), to 1e-7 rad over 10 s at rtol 1e-10
    (DOPRI5's global error there is ~1e-9); its energy output conserved to 1e-8 relative
    (measured 1.7e-9: DOPRI5 is not symplectic, its energy error grows with the steps)."""
    fmu = build(crate, runs=GENERATED)
    assert (crate / "src" / "eom.rs").read_text().startswith("// mbfmu: generated from src/")
    assert validate_fmu(str(fmu)) == []
    assert fmpy.read_model_description(str(fmu)).coSimulation.maxOutputDerivativeOrder == 2
    with zipfile.ZipFile(fmu) as z:
        names = set(z.namelist())
    assert {"modelDescription.xml", f"binaries/linux64/{NAME}.so", "documentation/index.html",
            "resources/linearization.json", "resources/linearized_model.py"} <= names
    theta0 = 1.0
    energy = assert_exact_pendulum(fmu, 9.81, theta0)["E"]
    e0 = -9.81 * np.cos(theta0)
    assert abs(energy[0] - e0) < 1e-12
    assert np.max(np.abs(energy - e0)) < 1e-8 * abs(e0)


def test_linearize_a_users_crate(crate):
    """At θ = 0 the pendulum's A is [[0, 1], [−g/l, 0]] and B = [[0], [1/(m l²)]]."""
    import json

    out = run("linearize", "--manifest-path", crate, "--at", "theta=0", env=build_env())
    lin = json.loads(out.stdout)
    assert lin["model"] == NAME and lin["states"] == ["theta", "theta_dot"]
    assert np.allclose(lin["A"], [[0, 1], [-9.81, 0]], rtol=0, atol=1e-15)
    assert np.allclose(lin["B"], [[0], [1]], rtol=0, atol=1e-15)
    bad = run("linearize", "--manifest-path", crate, "--scene", "nope", check=False,
              env=build_env())
    assert bad.returncode == 1 and bad.stderr.strip() == f"mbfmu: {NAME} has no scene nope"


def test_an_edited_model_never_runs_stale_generated_equations(crate):
    """V edited to 4 m g l (1 − cos θ) after the equations were generated: a plain cargo
    build (`mbfmu linearize` builds so) runs the edited model by automatic differentiation
    (A = [[0, 1], [−4g, 0]] exactly, not the old −g: build.rs turned the stale src/eom.rs
    off, its hash no longer the source's); `mbfmu build` generates them anew and the FMU
    swings as the exact pendulum of 4g."""
    import json

    lib = crate / "src" / "lib.rs"
    source = lib.read_text()
    potential = "-(p[M] * p[G] * p[L] * q[0].cos())"
    assert potential in source
    lib.write_text(source.replace(potential, "-(p[M] * (p[G] * 4.0) * p[L] * q[0].cos())"))
    header = (crate / "src" / "eom.rs").read_text().splitlines()[0]
    out = run("linearize", "--manifest-path", crate, "--at", "theta=0", env=build_env())
    assert np.allclose(json.loads(out.stdout)["A"], [[0, 1], [-4 * 9.81, 0]], rtol=0, atol=1e-14)
    fmu = build(crate, runs=GENERATED)
    assert (crate / "src" / "eom.rs").read_text().splitlines()[0] != header
    assert_exact_pendulum(fmu, 4 * 9.81)


def test_a_copied_system_agrees_with_the_in_tree_fmu(crate):
    """CompoundPendulum's file copied into the crate as a user would (renamed, its imports
    from mbfmu): the same trajectory as the in-tree FMU, to rounding (measured: bit for bit,
    as it is the same code; also under RADAU5 and RATTLE). The in-tree system runs its
    generated equations (`generated_eom!`), which a user's crate does not have: the copy
    drops that line and runs on automatic differentiation: two evaluation orders, whose
    last-bit differences the swing from θ = 3 rad (near inverted) amplifies over 10 s to
    1.0e-12 in θ̇ (measured); the bound leaves 100× for that."""
    source = (fs.REPO / "src" / "systems" / "compound_pendulum.rs").read_text()
    source = "\n".join(line for line in source.splitlines() if "generated_eom!" not in line)
    source = source.replace("crate::", "mbfmu::").replace("CompoundPendulum", NAME)
    (crate / "src" / "lib.rs").write_text(source + f"\nmbfmu::export_fmu!({NAME});\n")
    mine = build(crate, runs="runs on automatic differentiation: it is exported with")
    theirs = fs.fmu_file("CompoundPendulum")
    assert theirs.is_file(), f"{theirs} missing: run `mbfmu build --all`"
    outputs = ["theta", "theta_dot", "E"]
    start = {"theta": 3.0, "theta_dot": 0.0}
    a = simulate(mine, start, 10.0, outputs)
    b = simulate(theirs, start, 10.0, outputs)
    for name in outputs:
        assert np.max(np.abs(a[name] - b[name])) <= 1e-10, name


def test_help_version_and_errors():
    """`--version` and every `--help` exit 0; a bad flag, an unknown model or subcommand, a
    missing crate, a bad name: non-zero, nothing on stdout, one `mbfmu: ...` line on stderr."""
    out = run("--version")
    assert out.stdout.startswith("mbfmu ")
    for sub in ["list", "build", "xml", "symbolic", "linearize", "speed", "bench", "new"]:
        assert "Usage: mbfmu" in run(sub, "--help").stdout
    assert "--manifest-path" in run("build", "--help").stdout
    for args, needle in [
        (["build", "--bogus"], "--bogus"),
        (["build", "NoSuchModel"], "mbfmu: unknown model NoSuchModel"),
        (["build", "--manifest-path", "/nonexistent/Cargo.toml"], "mbfmu: no crate at"),
        (["linearize", "NoSuchModel"], "mbfmu: unknown model NoSuchModel"),
        (["new", "1bad"], "mbfmu: \"1bad\" cannot name a model"),
        (["frobnicate"], "frobnicate"),
    ]:
        bad = run(*args, check=False)
        assert bad.returncode != 0 and bad.stdout == "", args
        assert needle in bad.stderr and bad.stderr.count("\n") == 1, (args, bad.stderr)
        assert bad.stderr.startswith("mbfmu: "), (args, bad.stderr)


@pytest.mark.parametrize("path", sorted((fs.REPO / "modelDescription").glob("*.xml")),
                         ids=lambda p: p.stem)
def test_packaged_model_descriptions_are_the_committed_ones(path):
    """The XML an FMU carries now comes from its binary (`mbfmu_describe`): byte for byte
    the committed modelDescription/ text."""
    fmu = fs.fmu_file(path.stem)
    assert fmu.is_file(), f"{fmu} missing: run `mbfmu build --all`"
    with zipfile.ZipFile(fmu) as z:
        assert z.read("modelDescription.xml").decode() == path.read_text()
