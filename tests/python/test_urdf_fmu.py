"""`mbfmu build --urdf` end to end: a robot's URDF becomes an FMU, checked against Pinocchio.

Robots: the UR5 of example-robot-data (as shipped), its Panda (a copy with the finger's
``<mimic>`` removed, so that ``pin.aba``, which refuses mimics, is the reference: the mimic
is tested in test_real_robots.py; and its joint damping removed so that the
energy test has none to lose), the damped double pendulum of test_multibody_pinocchio.py
(a continuous joint, a fixed tilted tip: damping against ``pin.aba`` given τ − d q̇), and a
double pendulum with the in-tree DoublePendulum's parameters. Each is built once per
session with the CLI into a temporary folder (a module-scope fixture; the crates share
target/urdf-target, so mbfmu compiles once for all of them).

What must hold:
- the FMU's state derivatives (``der(J_dot)`` by fmi2GetReal after the states and inputs
  were set and the instance initialised; fmi2Reset between points, as states can only be
  set before initialisation) equal ``pin.aba`` at 100 random states and torques, to 1e-10
  relative to max(1, |q̈ᵢ|); the energy output ``E`` equals Pinocchio's kinetic plus
  potential energy to 1e-10 relative to max(1, |E|); the tips' poses its frame placements
  to 1e-12;
- the directional derivatives of ``der(J_dot)`` with respect to the states and inputs equal
  ``pin.computeABADerivatives`` (``ddq_dq``, ``ddq_dv``, ``Minv``) to 1e-8 relative to
  max(1, the largest entry of the block) (both exact: dual numbers against Pinocchio's
  analytic derivatives; the bound leaves the mass matrix's conditioning room); those with
  respect to the inputs, M⁻¹, inverted, equal ``pin.crba`` to 1e-10;
- the FMU runs the straight-line q̈ generated into its crate (``src/dynamics.rs``): the
  build says so (it checks the compiled crate's generated code is of the URDF's mechanism);
- no damping, no input: ``E`` constant over 10 s on UR5 and Panda to 1e-9 relative, with
  DOPRI5 at rtol 1e-13 (the integrator's energy error, not the model's: DOPRI5 is not
  symplectic; the model's E is exactly T + V);
- fmpy's validation passes; names, units and ranges are the URDF's;
- the page draws the mechanism (documentation/mechanism.svg, loaded by Chromium): one
  marker per joint in each of its two views, of the joint's kind, where Pinocchio's forward
  kinematics puts the joint at q = 0, the ends of branches at the FMU's pose outputs (read
  back through the axes' tick labels, to 0.05 px); every scene has its picture;
- the double pendulum URDF with DoublePendulum's parameters gives that FMU's trajectory
  (the tolerance is derived at the test).
"""

from __future__ import annotations

import json
import os
import pathlib
import re
import subprocess
import time
import xml.etree.ElementTree as ET
import zipfile
import ctypes
from ctypes import byref, c_double, c_uint

import fmpy
import numpy as np
import pinocchio as pin
import pytest
from fmpy.validation import validate_fmu

import fmu_support as fs
from test_linearization import cli
from test_multibody_pinocchio import DOUBLE_PENDULUM, Reference, robots_dir

# The in-tree DoublePendulum's parameters (m1 = m2 = 1 kg, r1 = l2 = 1 m, g = 9.81) as a
# URDF: point masses at the rods' ends. URDF needs a positive definite inertia; 1e-20
# kg m² is below rounding next to m r² = 1 (1 + 1e-20 == 1 in doubles), so the bodies are
# point masses to the last bit. Angles about +y from hanging down: the shoulder is θ1, the
# elbow the relative angle φ − θ1 (DoublePendulum's φ is absolute).
DP_PARAMETERS = """<?xml version="1.0"?>
<robot name="double_pendulum_parameters">
  <link name="base"/>
  <link name="rod1">
    <inertial>
      <origin xyz="0 0 -1"/>
      <mass value="1"/>
      <inertia ixx="1e-20" ixy="0" ixz="0" iyy="1e-20" iyz="0" izz="1e-20"/>
    </inertial>
  </link>
  <link name="rod2">
    <inertial>
      <origin xyz="0 0 -1"/>
      <mass value="1"/>
      <inertia ixx="1e-20" ixy="0" ixz="0" iyy="1e-20" iyz="0" izz="1e-20"/>
    </inertial>
  </link>
  <joint name="shoulder" type="continuous">
    <parent link="base"/><child link="rod1"/>
    <axis xyz="0 1 0"/>
  </joint>
  <joint name="elbow" type="continuous">
    <parent link="rod1"/><child link="rod2"/>
    <origin xyz="0 0 -1"/>
    <axis xyz="0 1 0"/>
  </joint>
</robot>
"""

# robot -> (modelIdentifier, --name given or None)
ROBOTS = {
    "ur5": ("ur5", None),
    "panda": ("panda", None),
    "damped": ("damped_pendulum", "damped_pendulum"),
    "dp": ("DoublePendulumURDF", "DoublePendulumURDF"),
    # The compiler-free route: the prebuilt mechanism runtime reads the robot from the FMU.
    "ur5 runtime": ("ur5", None),
    "kinova runtime": ("kinova", None),
    "z1 runtime": ("z1_description", None),
}
RUNTIME = " runtime"


def urdf_file(robot: str, tmp: pathlib.Path) -> pathlib.Path:
    robots = robots_dir()
    robot = robot.removesuffix(RUNTIME)
    if robot == "ur5":
        return robots / "ur_description" / "urdf" / "ur5_robot.urdf"
    if robot == "kinova":
        return robots / "kinova_description" / "robots" / "kinova.urdf"
    if robot == "z1":
        return robots / "z1_description" / "urdf" / "z1.urdf"
    if robot == "panda":
        text = (robots / "panda_description" / "urdf" / "panda.urdf").read_text()
        text = re.sub(r"<mimic[^>]*/>", "", text)
        text = re.sub(r'\bdamping="[^"]*"', 'damping="0"', text)
        path = tmp / "panda.urdf"
    elif robot == "damped":
        text, path = DOUBLE_PENDULUM, tmp / "damped_pendulum.urdf"
    else:
        text, path = DP_PARAMETERS, tmp / "dp_parameters.urdf"
    path.write_text(text)
    return path


def build_env():
    target = cli().parent.parent
    return {**os.environ, "CARGO_TARGET_DIR": str(target)}


class Built:
    def __init__(self, robot: str, fmu: pathlib.Path, urdf: pathlib.Path, seconds: float, stdout: str):
        self.robot, self.fmu, self.urdf, self.seconds, self.stdout = robot, fmu, urdf, seconds, stdout
        self.model = fs.Model(ROBOTS[robot][0], fmu)
        n = len(self.model.state_names) // 2
        self.joints = self.model.state_names[:n]
        self.ref = Reference(urdf, self.joints)


@pytest.fixture(scope="module")
def robot(tmp_path_factory):
    """robot(name) -> Built: its FMU, built with `mbfmu build --urdf` on first use."""
    out = tmp_path_factory.mktemp("urdf_fmus")
    cache: dict[str, Built] = {}

    def get(name: str) -> Built:
        if name not in cache:
            urdf = urdf_file(name, out)
            identifier, given = ROBOTS[name]
            env = build_env()
            if name.endswith(RUNTIME):
                # Every platform, from the prebuilt runtime, with no cargo, rustc or C
                # compiler reachable: PATH is an empty folder.
                where = out / "runtime"
                args = ["build", "--urdf", str(urdf), "--out", str(where)]
                env["PATH"] = str(tmp_path_factory.mktemp("empty_path"))
            else:
                # The compiled route (a crate with q̈ generated for the robot), this machine's
                # binary alone (test_platforms.py builds every platform's).
                where = out
                args = ["build", "--urdf", str(urdf), "--out", str(out), "--platforms", "host", "--compile"]
            if given:
                args += ["--name", given]
            start = time.perf_counter()
            res = subprocess.run([str(cli()), *args], capture_output=True, text=True, env=env)
            seconds = time.perf_counter() - start
            if res.returncode != 0:
                pytest.fail(f"mbfmu {' '.join(args)} failed:\n{res.stderr[-3000:]}", pytrace=False)
            print(f"{name}: built in {seconds:.0f} s: {res.stdout.strip()}")
            fmu = where / f"{identifier}.fmu"
            assert fmu.is_file(), res.stdout
            assert not list(where.glob(".*partial*")), "a partial file was left"
            cache[name] = Built(name, fmu, urdf, seconds, res.stdout)
        return cache[name]

    return get


def vrs(model, names):
    return (c_uint * len(names))(*[model.vr[n] for n in names])


def random_points(b: Built, count: int, seed: int):
    """States in [−π, π] rad (or ±0.05 m for a prismatic joint), velocities in [−2, 2],
    torques within the effort limits (at most 10)."""
    rng = np.random.default_rng(seed)
    n = len(b.joints)
    lo = np.array([float(b.model.vars[f"tau_{j}"].min or -10.0) for j in b.joints])
    hi = np.array([float(b.model.vars[f"tau_{j}"].max or 10.0) for j in b.joints])
    span = np.minimum(np.minimum(-lo, hi), 10.0)
    prismatic = np.array([b.model.vars[j].unit == "m" for j in b.joints])
    for _ in range(count):
        q = rng.uniform(-np.pi, np.pi, n)
        q[prismatic] = rng.uniform(-0.05, 0.05, prismatic.sum())
        yield q, rng.uniform(-2.0, 2.0, n), rng.uniform(-1.0, 1.0, n) * span


def initialised_at(inst, b: Built, q, qd, tau):
    values = {j: x for j, x in zip(b.joints, q)}
    values.update({f"{j}_dot": x for j, x in zip(b.joints, qd)})
    values.update({f"tau_{j}": x for j, x in zip(b.joints, tau)})
    values["limit_events"] = 0.0
    inst.initialize(values, tol=1e-10)


def damping(b: Built) -> np.ndarray:
    return b.ref.ours(b.ref.model.damping)


def friction(b: Built) -> np.ndarray:
    """Each joint's Coulomb friction as Pinocchio's URDF parser reads it (its algorithms
    leave it out: the tests give it −F sign(q̇), as the FMU applies to a slipping joint)."""
    return b.ref.ours(b.ref.model.friction)


@pytest.mark.parametrize("name", ["ur5", "panda", "damped", "ur5 runtime", "kinova runtime", "z1 runtime"])
def test_state_derivatives_energy_and_poses_equal_pinocchio(robot, instances, name):
    b = robot(name)
    model, ref = b.model, b.ref
    pm, data = ref.model, ref.data
    d, f = damping(b), friction(b)
    n = len(b.joints)
    der = [f"der({j}_dot)" for j in b.joints]
    tips = [v.name[:-3] for v in model.md.modelVariables if v.name.endswith("_q0")]
    pose_names = [f"{t}_{s}" for t in tips for s in ("x", "y", "z", "q0", "q1", "q2", "q3")]
    inst = instances(model, f"{name}_aba")
    worst = {"qdd": 0.0, "E": 0.0, "pose": 0.0}
    for k, (q, qd, tau) in enumerate(random_points(b, 100, seed=20261127 + n)):
        if k:
            inst.ok("fmi2Reset")
        initialised_at(inst, b, q, qd, tau)
        got = np.array(inst.get_reals(der))
        pq, pv = ref.q(q), ref.v(qd)
        want = ref.ours(pin.aba(pm, data, pq, pv, ref.v(tau - d * qd - f * np.sign(qd))))
        worst["qdd"] = max(worst["qdd"], (np.abs(got - want) / np.maximum(1.0, np.abs(want))).max())
        energy = pin.computeKineticEnergy(pm, data, pq, pv) + pin.computePotentialEnergy(pm, data, pq)
        worst["E"] = max(worst["E"], abs(inst.get_reals(["E"])[0] - energy) / max(1.0, abs(energy)))
        poses = np.array(inst.get_reals(pose_names)).reshape(len(tips), 7)
        pin.framesForwardKinematics(pm, data, pq)
        for tip, pose in zip(tips, poses):
            placement = data.oMf[pm.getFrameId(tip, pin.BODY)]
            x, y, z, w = pin.Quaternion(placement.rotation).coeffs()
            sign = 1.0 if np.dot(pose[3:], [w, x, y, z]) >= 0 else -1.0
            worst["pose"] = max(worst["pose"], np.abs(pose[:3] - placement.translation).max(),
                                np.abs(pose[3:] - sign * np.array([w, x, y, z])).max())
    print(f"{name}: n = {n}, tips {tips}, worst {worst}")
    assert worst["qdd"] < 1e-10, worst
    assert worst["E"] < 1e-10, worst
    assert worst["pose"] < 1e-12, worst


@pytest.mark.parametrize("name", ["ur5", "panda", "damped", "ur5 runtime", "kinova runtime", "z1 runtime"])
def test_directional_derivatives_equal_pinocchios_aba_derivatives(robot, instances, name):
    b = robot(name)
    model, ref = b.model, b.ref
    pm, data = ref.model, ref.data
    d, f = damping(b), friction(b)
    n = len(b.joints)
    der = [f"der({j}_dot)" for j in b.joints]
    knowns = b.joints + [f"{j}_dot" for j in b.joints] + [f"tau_{j}" for j in b.joints]
    uvr = vrs(model, der)
    inst = instances(model, f"{name}_jac")
    worst = 0.0
    for k, (q, qd, tau) in enumerate(random_points(b, 20, seed=7 + n)):
        if k:
            inst.ok("fmi2Reset")
        initialised_at(inst, b, q, qd, tau)
        jac = np.zeros((n, 3 * n))
        for c, known in enumerate(knowns):
            out = (c_double * n)()
            inst.ok("fmi2GetDirectionalDerivative", uvr, n, vrs(model, [known]), 1,
                    (c_double * 1)(1.0), out)
            jac[:, c] = out
        # (Friction −F sign(q̇) of a slipping joint: constant in (q, q̇, τ).)
        pin.computeABADerivatives(pm, data, ref.q(q), ref.v(qd), ref.v(tau - d * qd - f * np.sign(qd)))
        ix = np.ix_(ref.v_index, ref.v_index)
        minv = np.triu(data.Minv) + np.triu(data.Minv, 1).T
        dq, dv, dtau = data.ddq_dq[ix], data.ddq_dv[ix], minv[ix]
        # q̈ = ABA(q, q̇, τ − D q̇): ∂/∂q̇ gains −M⁻¹ D.
        dv = dv - dtau * d[None, :]
        for got, want in [(jac[:, :n], dq), (jac[:, n:2 * n], dv), (jac[:, 2 * n:], dtau)]:
            worst = max(worst, np.abs(got - want).max() / max(1.0, np.abs(want).max()))
    print(f"{name}: worst relative difference of the Jacobian blocks {worst:.2e}")
    assert worst < 1e-8, worst


@pytest.mark.parametrize("name", ["ur5", "panda", "damped", "ur5 runtime", "kinova runtime", "z1 runtime"])
def test_mass_matrix_through_the_fmu_equals_pinocchios_crba(robot, instances, name):
    """The FMU's mass matrix: q̈ = M⁻¹ (τ − d q̇ − b(q, q̇)) is affine in the inputs τ
    (``tau_J``), so the directional derivatives of ``der(J_dot)`` along each input are the
    columns of M⁻¹; inverted, they must equal ``pin.crba`` (its upper triangle,
    symmetrised) at 10 random states to 1e-10 relative to max(1, the largest entry).
    Measured: see the printed line."""
    b = robot(name)
    model, ref = b.model, b.ref
    pm, data = ref.model, ref.data
    n = len(b.joints)
    uvr = vrs(model, [f"der({j}_dot)" for j in b.joints])
    inst = instances(model, f"{name}_crba")
    ix = np.ix_(ref.v_index, ref.v_index)
    worst = 0.0
    for k, (q, qd, tau) in enumerate(random_points(b, 10, seed=11 + n)):
        if k:
            inst.ok("fmi2Reset")
        initialised_at(inst, b, q, qd, tau)
        minv = np.zeros((n, n))
        for c, j in enumerate(b.joints):
            out = (c_double * n)()
            inst.ok("fmi2GetDirectionalDerivative", uvr, n, vrs(model, [f"tau_{j}"]), 1,
                    (c_double * 1)(1.0), out)
            minv[:, c] = out
        m = np.linalg.inv(minv)
        crba = pin.crba(pm, data, ref.q(q))
        want = (np.triu(crba) + np.triu(crba, 1).T)[ix]
        worst = max(worst, np.abs(m - want).max() / max(1.0, np.abs(want).max()))
    print(f"{name}: worst relative difference of the FMU's M from pin.crba {worst:.2e}")
    assert worst < 1e-10, worst


def simulate(fmu, start, stop, outputs, rtol, interval=0.01):
    return fmpy.simulate_fmu(str(fmu), start_values=start, stop_time=stop, output_interval=interval,
                             relative_tolerance=rtol, output=outputs)


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_energy_is_constant_without_damping_or_input(robot, name):
    """From 0.4 rad on every joint (prismatic: 0.01 m), 1 rad/s (0.02 m/s), τ = 0 and limit
    events off (the arms swing through their limits), DOPRI5 at rtol 1e-13 for 10 s:
    max |E − E(0)| ≤ 1e-9 |E(0)|. Measured: see the printed line (Panda 2.7e-11; at rtol
    1e-12 it was 7.5e-10, too near the bound: DOPRI5's energy error is its truncation
    error, the model's E being exactly T + V)."""
    b = robot(name)
    assert np.all(damping(b) == 0.0)
    start = {"limit_events": 0.0}
    for j in b.joints:
        prismatic = b.model.vars[j].unit == "m"
        start[j] = 0.01 if prismatic else 0.4
        start[f"{j}_dot"] = 0.02 if prismatic else 1.0
        start[f"tau_{j}"] = 0.0
    res = simulate(b.fmu, start, 10.0, ["E"], rtol=1e-13)
    e = res["E"]
    drift = np.max(np.abs(e - e[0])) / abs(e[0])
    print(f"{name}: E(0) = {e[0]:.6f} J, max |E − E(0)| / |E(0)| = {drift:.2e} over 10 s")
    assert abs(e[0]) > 1.0
    assert drift < 1e-9, drift


@pytest.mark.parametrize("name", ["ur5", "panda", "damped", "dp"])
def test_fmu_validates_and_is_small(robot, name):
    b = robot(name)
    assert validate_fmu(str(b.fmu)) == []
    size = b.fmu.stat().st_size
    print(f"{name}: {size / 1e6:.2f} MB, built in {b.seconds:.0f} s")
    assert size < 5e6, size
    # It runs the q̈ generated for it (the build checked that code is of this mechanism).
    assert "runs straight-line code generated for this mechanism" in b.stdout, b.stdout
    with zipfile.ZipFile(b.fmu) as z:
        names = set(z.namelist())
    assert {"modelDescription.xml", "documentation/index.html",
            "resources/linearization.json"} <= names


def test_names_units_and_ranges_are_the_urdfs(robot):
    b = robot("ur5")
    v = b.model.vars
    joints = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
              "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
    assert b.joints == joints
    assert b.model.state_names == joints + [f"{j}_dot" for j in joints]
    for j in joints:
        assert v[j].unit == "rad" and v[f"{j}_dot"].unit == "rad/s"
        tau = v[f"tau_{j}"]
        assert tau.causality == "input" and tau.unit == "N.m"
    # Effort limits: 150 N.m for the shoulder and elbow, 28 for the wrists (ur5_robot.urdf).
    def bounds(name):
        return float(v[name].min), float(v[name].max)

    assert bounds("tau_elbow_joint") == (-150.0, 150.0)
    assert bounds("tau_wrist_3_joint") == (-28.0, 28.0)
    assert v["E"].causality == "output" and v["E"].unit == "J"
    for link in ["ee_link", "tool0"]:
        for s in ("x", "y", "z", "q0", "q1", "q2", "q3"):
            assert v[f"{link}_{s}"].causality == "output"
    assert v["limit_events"].causality == "parameter"
    # The build said what it does not model.
    doc = zipfile.ZipFile(b.fmu).read("documentation/index.html").decode()
    assert "<li>Velocity limits of <math><mrow><mn>6</mn></mrow></math> joints are not enforced" in doc
    assert "Not modelled: velocity limits;" in doc
    assert "Joint position limits are end stops" in doc
    # The crate it wrote builds as a crate of one's own, and says what it runs.
    crate = cli().parent.parent / "urdf" / "ur5"
    env = {**build_env(), "CARGO_TARGET_DIR": str(cli().parent.parent / "urdf-target")}
    res = subprocess.run([str(cli()), "build", "--manifest-path", str(crate)], capture_output=True,
                         text=True, env=env)
    assert res.returncode == 0, res.stderr
    assert "runs straight-line code generated for this mechanism: 6 moving joints" in res.stdout
    assert (crate / "src" / "dynamics.rs").is_file()
    # A crate of one's own carries every platform's binary too (cross-built, FMI alone).
    with zipfile.ZipFile(crate / "target" / "fmu" / "ur5.fmu") as z:
        assert sorted(n for n in z.namelist() if n.startswith("binaries/")) == [
            "binaries/aarch64-linux/ur5.so", "binaries/linux64/ur5.so", "binaries/win64/ur5.dll"]


def test_an_edited_crate_gets_its_dynamics_generated_again(robot, tmp_path):
    """UR5's crate copied and its forearm made heavier in src/lib.rs: `mbfmu build
    --manifest-path` finds src/dynamics.rs of another mechanism (its fingerprint), writes it
    again for the edited one, builds again and runs it; a second build rewrites nothing."""
    robot("ur5")
    crate = tmp_path / "ur5_edited"
    source = cli().parent.parent / "urdf" / "ur5"
    crate.mkdir()
    for name in ["Cargo.toml", "Cargo.lock"]:
        (crate / name).write_bytes((source / name).read_bytes())
    (crate / "src").mkdir()
    before = (source / "src" / "dynamics.rs").read_text()
    (crate / "src" / "dynamics.rs").write_text(before)
    lib = (source / "src" / "lib.rs").read_text()
    assert 'Body::new("forearm_link", 2.275)' in lib
    (crate / "src" / "lib.rs").write_text(lib.replace('Body::new("forearm_link", 2.275)',
                                                     'Body::new("forearm_link", 2.5)'))
    env = {**build_env(), "CARGO_TARGET_DIR": str(cli().parent.parent / "urdf-target")}
    args = [str(cli()), "build", "--manifest-path", str(crate), "--out", str(tmp_path), "--platforms", "host"]
    res = subprocess.run(args, capture_output=True, text=True, env=env)
    assert res.returncode == 0, res.stderr
    print(res.stdout.strip())
    assert "runs straight-line code generated for this mechanism: 6 moving joints" in res.stdout
    assert "(src/dynamics.rs rewritten for the edited mechanism)" in res.stdout
    after = (crate / "src" / "dynamics.rs").read_text()
    fingerprint = re.compile(r"pub const FINGERPRINT: u64 = (0x[0-9a-f]+);")
    assert fingerprint.search(after).group(1) != fingerprint.search(before).group(1)
    res = subprocess.run(args, capture_output=True, text=True, env=env)
    assert res.returncode == 0, res.stderr
    assert "runs straight-line code generated for this mechanism" in res.stdout
    assert "rewritten" not in res.stdout
    assert (crate / "src" / "dynamics.rs").read_text() == after


def test_a_limit_ends_the_step_with_discard(robot, instances, logs):
    """The Panda released from rest with no torque falls onto a joint limit (a finger, a
    prismatic joint limited to [0, 0.04] m, slides onto one): fmi2Discard within the 2 s, at
    the instant of the crossing, with a log line naming joint and limit."""
    b = robot("panda")
    inst = instances(b.model, "panda_limit", logging_on=True)
    mark = logs.mark()
    # limit_events = 1: discard (the default, 2, makes the limit an end stop).
    inst.initialize({"limit_events": 1, **{f"tau_{j}": 0.0 for j in b.joints}}, tol=1e-8)
    status = inst.do_step(2.0)
    assert status == fs.fmi2Discard
    st, t = inst.real_status()
    assert 0.0 < t < 2.0
    lines = [r.message for r in logs.since(mark, "panda_limit")]
    assert any(re.search(r"joint panda_\w+ reached its (upper|lower) limit", m) for m in lines), lines
    # The state at the instant: that joint is at its limit.
    line = next(m for m in lines if "reached its" in m)
    joint, side = re.search(r"joint (\w+) reached its (upper|lower) limit", line).groups()
    print(line)
    value = float(re.search(r"limit (\S+) (rad|m) at t = ", line).group(1))
    assert abs(inst.get_reals([joint])[0] - value) < 1e-6, (line, side)


def test_the_double_pendulum_urdf_gives_doublependulums_trajectory(robot):
    """DoublePendulum's parameters as a URDF against the in-tree FMU (its generated equations
    from the Lagrangian in absolute angles; ours ABA in relative ones): the same motion from
    θ1 = 0.5, φ = 0.8 rad with τ1 = 0.3, τ2 = −0.2 N.m held, over 10 s.

    With the fixed-step RK4 (solver = 1, 1 ms), to rounding. The two right-hand sides are the
    same function evaluated in different orders, so they differ by a few ulp, ~1e-16 |f|; both
    runs take the same 10⁴ steps, each adding such a difference, which this regular (not
    chaotic) swing carries with a bounded growth: 10⁴ · 2.2e-16 · |x| (≤ 3) · (a growth of
    10 at most) ≈ 7e-12. Bound 1e-11 rad (rad/s, J); measured: see the printed line (about
    1e-14 in the angles, 1e-13 in E).

    With DOPRI5 the step sizes are not shared: its error estimate is a difference of nearly
    equal stages, in which last-bit differences of f are relatively large, so the two runs
    take different steps and agree only to the integration's accuracy (3e-10 rad at rtol
    1e-10, measured): checked to 1e-8 there."""
    mine = robot("dp").fmu
    theirs = fs.fmu_file("DoublePendulum")
    assert theirs.is_file(), f"{theirs} missing: run `mbfmu build --all`"
    for solver, rtol, bound in [({"solver": 1, "solver_step": 1e-3}, 1e-10, 1e-11), ({}, 1e-10, 1e-8)]:
        a = simulate(mine, {"shoulder": 0.5, "elbow": 0.3, "tau_shoulder": 0.3, "tau_elbow": -0.2,
                            **solver},
                     10.0, ["shoulder", "elbow", "shoulder_dot", "elbow_dot", "E"], rtol=rtol)
        b = simulate(theirs, {"theta1": 0.5, "phi": 0.8, "tau1": 0.3, "tau2": -0.2, **solver},
                     10.0, ["theta1", "phi", "theta1_dot", "phi_dot", "E"], rtol=rtol)
        diffs = {
            "theta1": np.abs(a["shoulder"] - b["theta1"]).max(),
            "phi": np.abs(a["shoulder"] + a["elbow"] - b["phi"]).max(),
            "theta1_dot": np.abs(a["shoulder_dot"] - b["theta1_dot"]).max(),
            "phi_dot": np.abs(a["shoulder_dot"] + a["elbow_dot"] - b["phi_dot"]).max(),
            "E": np.abs(a["E"] - b["E"]).max(),
        }
        print(f"URDF double pendulum vs DoublePendulum over 10 s, {solver or 'DOPRI5'}: "
              + ", ".join(f"{k} {v:.1e}" for k, v in diffs.items()))
        assert np.abs(b["phi"]).max() > 0.5, "it moves"
        for name, diff in diffs.items():
            assert diff < bound, (solver, name, diff)


SVG = "{http://www.w3.org/2000/svg}"


def read_view(view):
    """One view of a stick figure read back: its axes, the px of a metre (px = a + b · value,
    through the tick labels, each checked on the line), and each marker's centre."""
    children = list(view)
    axes = {}
    for cls in ("htick", "vtick"):
        ticks = [(float(children[k + 1].text), float(c.get("x1" if cls == "htick" else "y1")))
                 for k, c in enumerate(children) if c.get("class") == cls]
        (v0, p0), (v1, p1) = ticks[0], ticks[-1]
        b = (p1 - p0) / (v1 - v0)
        a = p0 - b * v0
        assert all(abs(a + b * v - p) < 0.02 for v, p in ticks), ticks
        axes[cls] = (a, b)
    marks = []
    for e in view.iter():
        cls = e.get("class") or ""
        if not (cls.startswith("joint ") or cls == "end"):
            continue
        tag = e.tag.removeprefix(SVG)
        if tag == "circle":
            x, y = float(e.get("cx")), float(e.get("cy"))
        elif tag == "rect":
            x = float(e.get("x")) + float(e.get("width")) / 2
            y = float(e.get("y")) + float(e.get("height")) / 2
        else:
            p = [float(v) for v in re.split(r"[ ,]", e.get("points"))]
            x, y = p[0], (p[1] + p[5]) / 2
        (ah, bh), (av, bv) = axes["htick"], axes["vtick"]
        marks.append((cls, e.get("data-joint") or e.get("data-link"), tag,
                      ((x - ah) / bh, (y - av) / bv)))
    return view.get("data-h"), view.get("data-v"), axes["htick"][1], axes["vtick"][1], marks


@pytest.mark.parametrize("name", ["ur5", "panda"])
def test_the_page_draws_the_mechanism_a_marker_per_joint_where_it_is(robot, instances, name, tmp_path):
    """The page's picture of the mechanism (documentation/mechanism.svg): shown in its own
    section and loaded by Chromium with every other image of the page (offline, no script);
    two views at one scale; in each, one marker per joint of the modelDescription, a circle
    for a joint in rad and a square for one in m, at the joint's place in Pinocchio's forward
    kinematics at q = 0 (``data.oMi``), and a diamond per end of a branch at the FMU's own
    pose outputs at q = 0; each scene has its picture, a marker per joint and instant."""
    from test_documentation_page import MEASURE, WINDOW, run_chromium

    b = robot(name)
    with zipfile.ZipFile(b.fmu) as z:
        z.extractall(tmp_path / "fmu")
    doc = tmp_path / "fmu" / "documentation"
    html = (doc / "index.html").read_text(encoding="utf-8")
    section = html[html.index('<h2 id="mechanism">'):html.index('<h2 id="equations">')]
    assert '<img src="mechanism.svg"' in section, section
    scenes = re.findall(r'<h3 id="scene-([^"]+)">', html)
    assert scenes
    for scene in scenes:
        assert f'<img src="scene_{scene}_mechanism.svg"' in html, scene

    measured = doc / "measured.html"
    measured.write_text(html.replace("</body>", MEASURE + "</body>"), encoding="utf-8")
    dom = run_chromium(tmp_path, "--virtual-time-budget=10000", WINDOW, "--hide-scrollbars",
                       "--dump-dom", measured.as_uri())
    images = json.loads(re.search(r'<pre id="mbfmu-measure">(.*?)</pre>', dom, re.S).group(1)
                        .replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&"))["images"]
    assert ["mechanism.svg", True] in images, images
    assert all(ok for _, ok in images), images

    n = len(b.joints)
    inst = instances(b.model, f"{name}_picture")
    initialised_at(inst, b, np.zeros(n), np.zeros(n), np.zeros(n))
    tips = [v.name[:-3] for v in b.model.md.modelVariables if v.name.endswith("_q0")]
    outputs = dict(zip(tips, np.array(inst.get_reals(
        [f"{t}_{c}" for t in tips for c in "xyz"])).reshape(len(tips), 3)))
    pm, data = b.ref.model, b.ref.data
    pin.forwardKinematics(pm, data, b.ref.q(np.zeros(n)))
    joints = {j: data.oMi[pm.getJointId(j)].translation for j in b.joints}

    views = [g for g in ET.parse(doc / "mechanism.svg").iter(f"{SVG}g") if g.get("class") == "view"]
    assert len(views) == 2
    scales = []
    worst = 0.0
    for view in views:
        h, v, bh, bv, marks = read_view(view)
        assert abs(bh + bv) < 1e-3 * bh, "equal scales, up is up"
        scales.append(bh)
        ih, iv = "xyz".index(h), "xyz".index(v)
        tol = 0.05 / bh  # 0.05 px of rounding, in metres
        drawn = [m for m in marks if m[0].startswith("joint ")]
        assert sorted(m[1] for m in drawn) == sorted(b.joints), "one marker per joint"
        for _, joint, tag, (x, y) in drawn:
            assert tag == ("rect" if b.model.vars[joint].unit == "m" else "circle"), joint
            want = joints[joint]
            worst = max(worst, abs(x - want[ih]), abs(y - want[iv]))
            assert abs(x - want[ih]) < tol and abs(y - want[iv]) < tol, (joint, h, v, x, y, want)
        ends = {m[1]: m[3] for m in marks if m[0] == "end"}
        assert sorted(ends) == sorted(tips)
        for tip, (x, y) in ends.items():
            want = outputs[tip]
            assert abs(x - want[ih]) < tol and abs(y - want[iv]) < tol, (tip, h, v, x, y, want)
    assert abs(scales[0] - scales[1]) < 1e-3 * scales[0]
    print(f"{name}: views {[(g.get('data-h'), g.get('data-v')) for g in views]}, "
          f"{scales[0]:.0f} px/m, joints within {worst:.1e} m of Pinocchio's")

    for scene in scenes:
        svg = ET.parse(doc / f"scene_{scene}_mechanism.svg")
        poses = [g for g in svg.iter(f"{SVG}g") if g.get("class") == "pose"]
        assert len(poses) in (6, 4, 2), (scene, len(poses))  # 3 instants (or fewer) × 2 views
        for pose in poses:
            drawn = sorted(e.get("data-joint") for e in pose.iter()
                           if (e.get("class") or "").startswith("joint "))
            assert drawn == sorted(b.joints), scene


# ------------------------------------------------- the compiler-free route: the runtime


@pytest.mark.parametrize("name", ["ur5 runtime", "kinova runtime", "z1 runtime"])
def test_the_runtime_builds_every_platform_without_a_compiler(robot, name):
    """`mbfmu build --urdf` with no cargo, rustc or C compiler on PATH writes a complete FMU
    (page, linearisation, reference result, both versions) from the prebuilt runtime: each
    platform's runtime binary under the robot's modelIdentifier, the URDF as given and the
    identifier as its resources. The time is printed (measured, not asserted)."""
    b = robot(name)
    identifier = ROBOTS[name][0]
    assert "interpreted by the prebuilt mechanism runtime" in b.stdout, b.stdout
    print(f"{name}: built in {b.seconds:.2f} s with no compiler on PATH")
    for fmu, fmi3 in [(b.fmu, False), (b.fmu.parent.with_name(b.fmu.parent.name + "3") / b.fmu.name, True)]:
        with zipfile.ZipFile(fmu) as z:
            names = z.namelist()
            folders = ["x86_64-linux", "x86_64-windows", "aarch64-linux"] if fmi3 else ["linux64", "win64", "aarch64-linux"]
            assert sorted(n for n in names if n.startswith("binaries/")) == sorted(
                f"binaries/{f}/{identifier}.{'dll' if 'win' in f else 'so'}" for f in folders)
            assert z.read("resources/mechanism.urdf") == b.urdf.read_bytes()
            assert z.read("resources/model_identifier.txt").decode() == identifier
            for part in ["documentation/index.html", "documentation/mechanism.svg",
                         "resources/linearization.json", "extra/org.fmi-standard.fmi-ls-ref/reference.csv"]:
                assert part in names, part
        assert validate_fmu(str(fmu)) == [], fmu


def test_the_runtime_and_the_compiled_crate_describe_the_same_fmu(robot):
    """UR5 from the runtime and from its compiled crate: the same modelDescription, FMI 2.0
    and 3.0, to the byte but for the instantiation token (the runtime's is a hash of the
    URDF text, its name and its variables, the same on every platform)."""
    compiled, runtime = robot("ur5"), robot("ur5 runtime")
    twin = lambda fmu: fmu.parent.with_name(fmu.parent.name + "3") / fmu.name
    token = re.compile(r'(guid|instantiationToken)="\{[0-9a-f-]+\}"')
    for a, b in [(compiled.fmu, runtime.fmu), (twin(compiled.fmu), twin(runtime.fmu))]:
        with zipfile.ZipFile(a) as za, zipfile.ZipFile(b) as zb:
            xa, xb = za.read("modelDescription.xml").decode(), zb.read("modelDescription.xml").decode()
            assert len(token.findall(xa)) == 1 and token.findall(xa) == token.findall(xb)
            assert token.sub("TOKEN", xa) == token.sub("TOKEN", xb), (a, b)
            assert token.search(xa).group(0) != token.search(xb).group(0)


def edited_copy(fmu: pathlib.Path, out: pathlib.Path, entry: str, edit) -> pathlib.Path:
    """`fmu` with its `entry` replaced by `edit(text)`."""
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == entry:
                text = data.decode()
                changed = edit(text)
                assert changed != text, f"the edit changed nothing in {entry}"
                data = changed.encode()
            dst.writestr(item, data)
    return out


UR5_EDITS = {
    "a mass changed": ("resources/mechanism.urdf",
                       lambda t: t.replace('<mass value="3.7"/>', '<mass value="3.8"/>', 1)),
    # The end effector's joint and link: still a valid URDF, of another mechanism.
    "a joint removed": ("resources/mechanism.urdf",
                        lambda t: re.sub(r'<joint name="ee_fixed_joint".*?</joint>\s*<link name="ee_link">.*?</link>',
                                         "", t, flags=re.S)),
    "a truncated file": ("resources/mechanism.urdf", lambda t: t[: len(t) // 2]),
    "another identifier": ("resources/model_identifier.txt", lambda t: "ur10"),
}


@pytest.mark.parametrize("edit", list(UR5_EDITS))
def test_an_edited_runtime_fmu_is_refused_at_instantiation(robot, logs, edit, tmp_path):
    """UR5's runtime FMU with its resources edited or damaged: FMI 2.0 and FMI 3.0
    instantiation return NULL with one log line (fmi2Error / fmi3Error) saying why; nothing
    runs a mechanism the modelDescription does not describe."""
    entry, change = UR5_EDITS[edit]
    fmu = edited_copy(robot("ur5 runtime").fmu, tmp_path / "ur5.fmu", entry, change)
    model = fs.Model("ur5", fmu)
    lib = model.library()
    try:
        name = f"ur5_{edit.replace(' ', '_')}"
        fs.ensure_logger()
        mark = logs.mark()
        comp = lib._functions["fmi2Instantiate"](name.encode(), fs.fmi2CoSimulation, model.guid.encode(),
                                                 model.resource_uri(), byref(fs.CALLBACKS), 0, 0)
        assert not comp, edit
        records = logs.since(mark)
        assert len(records) == 1 and records[0].status == fs.fmi2Error, records
        message = records[0].message
        print(f"{edit}: {message}")
        assert "\n" not in message.strip()
        assert ("does not match this binary" in message) or ("resources/mechanism.urdf" in message), message
    finally:
        lib.freeLibrary()
    # FMI 3.0: the same refusal through fmi3InstantiateCoSimulation.
    messages = []
    Log3 = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_char_p)
    log3 = Log3(lambda env, status, category, message: messages.append((status, message.decode())))
    so = ctypes.CDLL(str(pathlib.Path(model.unzipdir, "binaries", "linux64", "ur5.so")))
    inst3 = so.fmi3InstantiateCoSimulation
    inst3.restype = ctypes.c_void_p
    inst3.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_bool, ctypes.c_bool,
                      ctypes.c_bool, ctypes.c_bool, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p,
                      Log3, ctypes.c_void_p]
    resources = str(pathlib.Path(model.unzipdir, "resources")) + "/"
    assert not inst3(b"ur5_3", model.guid.encode(), resources.encode(), False, False, False, False,
                     None, 0, None, log3, None)
    assert len(messages) == 1 and messages[0][0] == 3, messages  # fmi3Error
