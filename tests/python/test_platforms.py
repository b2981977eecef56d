"""Every FMU carries a binary for each platform, and each platform's binary runs.

- Every FMU of ``target/fmu`` and its FMI 3.0 twin carry ``binaries/linux64``, ``win64`` and
  ``aarch64-linux`` (FMI 3.0: ``x86_64-linux``, ``x86_64-windows``, ``aarch64-linux``), each
  under 5 MB, each of its machine (the ELF or PE header says which), each exporting the
  FMI symbols.
- Each platform's binary of MassSpringDamper, NonlinearBicycle, AndrewsSqueezer and a URDF
  robot (UR5 of example-robot-data, built here with ``mbfmu build --urdf``: the prebuilt
  mechanism runtime, reading the robot from the FMU's resources, given as Windows paths
  under Wine) runs its default
  experiment through a small C driver compiled for that platform (``tests/c/fmu_run.c``:
  gcc natively, aarch64-linux-gnu-gcc under qemu-aarch64, x86_64-w64-mingw32-gcc under
  wine), FMI 2.0 and FMI 3.0 Co-Simulation, and every value at every communication point
  equals the Linux x86_64 run within 1e-12 of its column's largest magnitude (at least 1
  for an output that is not a state: a constraint residual or a slip is rounding noise of
  the states, some 1e-15 m, with no relative digits to compare). aarch64
  Linux has the same glibc libm and gives the same bits; Windows' msvcrt libm (sin, cos,
  pow, exp) differs in the last bits (the test prints how many values differ and by how
  much).

Wine 8.0 lacks ``bcryptprimitives.dll`` (``ProcessPrng``, which Rust's standard library
imports since 1.78; Windows 10 has it): the test puts a stand-in (``tests/c/
bcryptprimitives.c``, forwarding to RtlGenRandom) beside the driver. No FMU ships it.
"""
from __future__ import annotations

import os
import pathlib
import shutil
import struct
import subprocess
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description

import fmu_support as fs
from test_fmi3 import fmu3_dir
from test_linearization import cli
from test_multibody_pinocchio import robots_dir

C = fs.REPO / "tests" / "c"
MAX_BINARY = 5_000_000
# FMI 2.0 folder -> (FMI 3.0 tuple, extension, machine: ELF e_machine or PE Machine).
PLATFORMS = {
    "linux64": ("x86_64-linux", "so", ("ELF", 62)),
    "win64": ("x86_64-windows", "dll", ("PE", 0x8664)),
    "aarch64-linux": ("aarch64-linux", "so", ("ELF", 183)),
}
WINE = "/usr/lib/wine/wine64"
QEMU = "qemu-aarch64"
# Every value at every point within this of its column's scale: the platforms' libms may
# differ in the last bit of sin, cos, exp, pow; over these runs that moves the results by
# a few 1e-15 relative (printed), far below it.
RELATIVE = 1e-12
# AndrewsSqueezer's q̈ comes out of M's and the closures' Schur complement S = G M⁻¹ Gᵀ
# solves, cond(M) ≈ 1e2 and cond(S) ≈ 3e2 along its run (the test set's formulas, at t = 0
# and 0.03 s): a last-bit difference of sin or cos is amplified up to ~3e4 in each q̈
# before the integration carries it. Measured on its generated closed terms: Windows
# 1.23e-12 of the column's scale (aarch64 bit-identical).
RELATIVE_OF = {"AndrewsSqueezer": 1e-11}


def machine(binary: bytes) -> tuple[str, int]:
    if binary[:4] == b"\x7fELF":
        return "ELF", struct.unpack_from("<H", binary, 18)[0]
    if binary[:2] == b"MZ":
        pe = struct.unpack_from("<I", binary, 0x3C)[0]
        assert binary[pe:pe + 4] == b"PE\0\0"
        return "PE", struct.unpack_from("<H", binary, pe + 4)[0]
    return "?", 0


def fmus() -> list[pathlib.Path]:
    return sorted(fs.fmu_dir().glob("*.fmu")) + sorted(fmu3_dir().glob("*.fmu"))


def test_every_fmu_carries_every_platform():
    found = fmus()
    assert len(found) >= 2 * 19, [f.name for f in found]
    for fmu in found:
        fmi3 = fmu.parent == fmu3_dir()
        with zipfile.ZipFile(fmu) as z:
            md = read_model_description(str(fmu))
            identifier = md.coSimulation.modelIdentifier
            expected = {f"binaries/{tuple3 if fmi3 else folder}/{identifier}.{ext}": kind
                        for folder, (tuple3, ext, kind) in PLATFORMS.items()}
            binaries = sorted(n for n in z.namelist() if n.startswith("binaries/"))
            assert binaries == sorted(expected), fmu
            for name, kind in expected.items():
                data = z.read(name)
                assert len(data) < MAX_BINARY, f"{fmu.name}: {name} is {len(data)} bytes"
                assert machine(data) == kind, f"{fmu.name}: {name}"
                for symbol in [b"fmi2DoStep", b"fmi3DoStep", b"fmi2GetDirectionalDerivative"]:
                    assert symbol in data, f"{fmu.name}: {name} lacks {symbol!r}"


# ---------------------------------------------------------------- running each binary


def missing_tools() -> list[str]:
    tools = ["gcc", "aarch64-linux-gnu-gcc", "x86_64-w64-mingw32-gcc", QEMU]
    lacking = [t for t in tools if shutil.which(t) is None]
    return lacking + ([WINE] if not os.path.exists(WINE) else [])


class Drivers:
    """The C driver compiled for each platform, and how to run it there."""

    def __init__(self, tmp: pathlib.Path):
        lacking = missing_tools()
        if lacking:
            pytest.fail(f"missing {', '.join(lacking)}: run `sh scripts/install-cross --run-tools` as root",
                        pytrace=False)
        self.tmp = tmp
        source = str(C / "fmu_run.c")
        flags = ["-std=c99", "-O1", "-Wall", "-Wextra", "-Werror"]
        self.exe = {
            "linux64": tmp / "fmu_run",
            "aarch64-linux": tmp / "fmu_run_aarch64",
            "win64": tmp / "win" / "fmu_run.exe",
        }
        (tmp / "win").mkdir()
        compilers = {"linux64": "gcc", "aarch64-linux": "aarch64-linux-gnu-gcc",
                     "win64": "x86_64-w64-mingw32-gcc"}
        for platform, compiler in compilers.items():
            libs = [] if platform == "win64" else ["-ldl"]
            subprocess.run([compiler, *flags, "-o", str(self.exe[platform]), source, *libs], check=True)
        subprocess.run(["x86_64-w64-mingw32-gcc", "-shared", "-O1", "-o", str(tmp / "win" / "bcryptprimitives.dll"),
                        str(C / "bcryptprimitives.c"), "-ladvapi32"], check=True)
        self.env = {**os.environ, "WINEPREFIX": str(tmp / "wineprefix"), "WINEDEBUG": "-all"}

    def run(self, platform: str, library: pathlib.Path, args: list[str]) -> np.ndarray:
        exe = self.exe[platform]
        if platform == "win64":
            # Wine finds a DLL beside the program: the FMU's binary goes there by name.
            local = exe.parent / library.name
            shutil.copyfile(library, local)
            cmd = [WINE, str(exe), args[0], local.name, *args[1:]]
            cwd = exe.parent
        elif platform == "aarch64-linux":
            cmd = [QEMU, "-L", "/usr/aarch64-linux-gnu", str(exe), args[0], str(library), *args[1:]]
            cwd = self.tmp
        else:
            cmd = [str(exe), args[0], str(library), *args[1:]]
            cwd = self.tmp
        res = subprocess.run(cmd, capture_output=True, text=True, env=self.env, cwd=cwd, timeout=600)
        assert res.returncode == 0, f"{platform}: {' '.join(cmd)}\n{res.stderr[-2000:]}"
        return np.array([[float(v) for v in line.split()] for line in res.stdout.splitlines() if line.strip()])

    def close(self):
        wineserver = pathlib.Path(WINE).with_name("wineserver")
        subprocess.run([str(wineserver), "-k"], env=self.env, capture_output=True)


@pytest.fixture(scope="module")
def drivers(tmp_path_factory):
    d = Drivers(tmp_path_factory.mktemp("drivers"))
    yield d
    d.close()


@pytest.fixture(scope="module")
def ur5(tmp_path_factory) -> pathlib.Path:
    """UR5 of example-robot-data through `mbfmu build --urdf`, every platform."""
    out = tmp_path_factory.mktemp("ur5")
    urdf = robots_dir() / "ur_description" / "urdf" / "ur5_robot.urdf"
    env = {**os.environ, "CARGO_TARGET_DIR": str(cli().parent.parent)}
    res = subprocess.run([str(cli()), "build", "--urdf", str(urdf), "--out", str(out)],
                         capture_output=True, text=True, env=env)
    assert res.returncode == 0, res.stderr[-3000:]
    return out


def run_everywhere(drivers: Drivers, fmu: pathlib.Path, version: str, tmp: pathlib.Path,
                   starts: dict[str, float] | None = None):
    """The default experiment (with these start values) on each platform, compared."""
    md = read_model_description(str(fmu))
    identifier = md.coSimulation.modelIdentifier
    ex = md.defaultExperiment
    outputs = [v for v in md.modelVariables if v.causality == "output" and v.type in ("Real", "Float64")]
    assert outputs, fmu
    vrs = [str(v.valueReference) for v in outputs]
    by_name = {v.name: v.valueReference for v in md.modelVariables}
    sets = [f"{by_name[k]}={v!r}" for k, v in (starts or {}).items()]
    with zipfile.ZipFile(fmu) as z:
        z.extractall(tmp)
    token = md.guid
    results = {}
    for folder, (tuple3, ext, _) in PLATFORMS.items():
        where = tuple3 if version == "fmi3" else folder
        library = tmp / "binaries" / where / f"{identifier}.{ext}"
        folder_path = tmp / "resources"
        if folder == "win64":
            # As a Windows importer gives it: Wine's drive Z: is the Unix root.
            windows = "Z:" + str(folder_path).replace("/", "\\")
            resources = "file:///" + windows.replace("\\", "/") + "/" if version == "fmi2" else windows + "\\"
        else:
            resources = folder_path.as_uri() + "/" if version == "fmi2" else str(folder_path) + "/"
        args = [version, token, resources, repr(float(ex.stopTime)), repr(float(ex.stepSize)), *sets, *vrs]
        results[folder] = drivers.run(folder, library, args)
    reference = results["linux64"]
    steps = round(float(ex.stopTime) / float(ex.stepSize))
    assert reference.shape == (steps + 1, len(vrs) + 1), reference.shape
    assert np.isfinite(reference).all()
    # A state's scale is its largest magnitude over the run; an output that is not a state
    # may be rounding noise of the states (a constraint residual or a slip of 1e-15 m), so
    # its scale is at least 1.
    states = {d.variable.derivative.valueReference for d in md.derivatives}
    is_state = np.array([True] + [v.valueReference in states for v in outputs])
    scale = np.abs(reference).max(axis=0)
    scale = np.where(is_state, np.maximum(scale, np.finfo(float).tiny), np.maximum(scale, 1.0))
    for folder, got in results.items():
        assert got.shape == reference.shape, folder
        error = (np.abs(got - reference) / scale).max()
        differ = int((got != reference).sum())
        print(f"{fmu.stem} {version} {folder}: {differ} of {got.size} values differ from x86_64 Linux's,"
              f" by at most {error:.1e} of their column's scale")
        assert error <= RELATIVE_OF.get(fmu.stem, RELATIVE), f"{folder}: {error:.3g}"
        if folder == "aarch64-linux":
            # The same glibc libm, no fused multiply-adds (Rust never contracts): the same bits.
            assert differ == 0, f"{fmu.stem}: aarch64 differs in {differ} values"


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
@pytest.mark.parametrize("name", ["MassSpringDamper", "NonlinearBicycle", "AndrewsSqueezer"])
def test_each_platform_runs_the_default_experiment(drivers, name, version, tmp_path):
    folder = fs.fmu_dir() if version == "fmi2" else fmu3_dir()
    run_everywhere(drivers, folder / f"{name}.fmu", version, tmp_path)


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_a_urdf_robot_runs_on_each_platform(drivers, ur5, version, tmp_path):
    folder = ur5 if version == "fmi2" else ur5.with_name(ur5.name + "3")
    # Released: no joint torque, so the arm falls and swings (its default experiment holds
    # it at rest, where the velocities are rounding noise with no digits to compare).
    md = read_model_description(str(folder / "ur5.fmu"))
    released = {v.name: 0.0 for v in md.modelVariables
                if v.causality == "input" and v.name.startswith("tau_")}
    run_everywhere(drivers, folder / "ur5.fmu", version, tmp_path, released)


def test_a_missing_toolchain_is_one_line_and_no_thinner_fmu(tmp_path):
    """A cross toolchain that is not there (Debian's rustc pointed elsewhere, installing
    forbidden): `mbfmu build` stops before compiling with one line naming the command that
    installs it and the host-only option, and writes no FMU; `--platforms host` builds."""
    env = {**os.environ, "MBFMU_CROSS_RUSTC": str(tmp_path / "no-rustc"), "MBFMU_NO_INSTALL": "1",
           "CARGO_TARGET_DIR": str(cli().parent.parent)}
    out = tmp_path / "fmus"
    res = subprocess.run([str(cli()), "build", "MassSpringDamper", "--out", str(out)],
                         capture_output=True, text=True, env=env)
    assert res.returncode == 1, res
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("mbfmu: building the x86_64-windows and aarch64-linux binaries needs"), lines[0]
    assert "scripts/install-cross" in lines[0] and "--platforms host" in lines[0], lines[0]
    assert not out.exists() or not any(out.iterdir())
    res = subprocess.run([str(cli()), "build", "MassSpringDamper", "--out", str(out), "--platforms", "host"],
                         capture_output=True, text=True, env=env)
    assert res.returncode == 0, res.stderr[-2000:]
    with zipfile.ZipFile(out / "MassSpringDamper.fmu") as z:
        assert [n for n in z.namelist() if n.startswith("binaries/")] == ["binaries/linux64/MassSpringDamper.so"]
