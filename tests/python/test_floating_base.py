"""Floating base (issue 32): `mbfmu build --urdf FILE --floating-base`, the root link free.

- A one-link URDF (a brick, principal moments 1, 2, 3 kg m²) floating is the in-tree
  `RigidBody` FMU: the same body angular velocity and attitude quaternion over 10 s from
  ω = (1, 0.5, 0.2) rad/s (Euler's equations; its centre of mass falls as ½ g t², which
  does not touch the rotation). Both at rtol 1e-12: they differ by what two integrations of
  the same motion by two right-hand sides differ, ~1e-12; bound 1e-10.
- Legged robots and humanoids of example-robot-data floating (Talos reduced, whose
  grippers' mimics are on fixed joints, ignored; and Talos full, 12 moving mimic joints:
  q̈ then from the mass matrix reduced to the base and the independent joints, against
  Pinocchio's free-flyer model without mimics reduced by G, since Pinocchio 4.1 refuses
  Talos's mimic model): at random states
  (base anywhere, any attitude, moving; joints anywhere, moving, under torques),
  der(base_v…), der(base_w…) and der(J_dot) equal Pinocchio's free-flyer `aba` (base
  velocity linear then angular, in the base frame, as ours) to 1e-10 relative to
  max(1, |a|); der(base_x…) is R v and der(base_q…) is ½ q ⊗ (0, ω); E equals Pinocchio's
  kinetic plus potential energy. And the momentum about the centre of mass: its rate,
  Pinocchio's `computeCentroidalMomentumTimeVariation` at our accelerations, is (0, M g):
  gravity pulls the centre of mass and exerts no torque about it, whatever the joints do.
- The default experiment runs to its stop time in fmpy (the robot falls freely, its
  shape kept: q̈ = 0 and the base falls at g).
- Go2 also with --compile (the generated straight-line code, which the build checks it
  runs): the same checks. A floating arm with a mimic joint compiled (the reduced mass
  matrix of the base and the independent joints as straight-line code) equals the
  runtime's interpreted dynamics at random states; Talos full floating compiled says it
  runs the interpreted algorithm (its generated q̈ would be past the operations rustc
  compiles in reasonable time).
"""

from __future__ import annotations

import pathlib
import subprocess

import fmpy
import numpy as np
import pinocchio as pin
import pytest
from fmpy.validation import validate_fmu

import fmu_support as fs
from test_linearization import cli
from test_multibody_pinocchio import robots_dir
from test_real_robots import (BASE_Q, BASE_V, FreeFlyer, build, coordinate_damping, coordinate_friction,
                              random_unit_quaternion, urdf_joints)
from test_urdf_fmu import build_env

BRICK = """<robot name="brick"><link name="brick"><inertial><mass value="1"/>
<inertia ixx="1" ixy="0" ixz="0" iyy="2" iyz="0" izz="3"/></inertial></link></robot>"""

LEGGED = ["go2_description/urdf/go2.urdf", "solo_description/robots/solo12.urdf",
          "anymal_c_simple_description/urdf/anymal.urdf", "bolt_description/robots/bolt.urdf",
          "g1_description/urdf/g1_29dof_rev_1_0.urdf", "talos_data/robots/talos_reduced.urdf",
          "talos_data/robots/talos_full_v2.urdf"]


def test_a_floating_brick_is_the_in_tree_rigid_body(tmp_path):
    urdf = tmp_path / "brick.urdf"
    urdf.write_text(BRICK)
    res = build(urdf, tmp_path, "--floating-base", "--platforms", "host")
    assert res.returncode == 0, res.stderr
    fmu = tmp_path / "brick.fmu"
    assert not validate_fmu(str(fmu))
    ours = fmpy.simulate_fmu(str(fmu), stop_time=10, output_interval=0.01, relative_tolerance=1e-12,
                             start_values={"base_wx": 1.0, "base_wy": 0.5, "base_wz": 0.2},
                             output=BASE_V[3:] + BASE_Q[2:] + ["E"])
    theirs = fmpy.simulate_fmu(str(fs.fmu_file("RigidBody")), stop_time=10, output_interval=0.01,
                               relative_tolerance=1e-12,
                               output=["omega1", "omega2", "omega3", "q0", "q1", "q2", "q3"])
    pairs = list(zip(BASE_V[3:] + BASE_Q[3:], ["omega1", "omega2", "omega3", "q0", "q1", "q2", "q3"]))
    worst = max(np.abs(ours[a] - theirs[b]).max() for a, b in pairs)
    print(f"brick against RigidBody over 10 s: worst difference {worst:.2e}")
    assert worst < 1e-10
    t = ours["time"]
    assert np.allclose(ours["base_z"], -0.5 * 9.81 * t**2, rtol=1e-12, atol=1e-12)
    # E = ½ ωᵀ I ω + ½ m v² + m g z, constant: its last two terms cancel, each growing to
    # m g |z| = 4.8 kJ by t = 10 s, so E keeps what the integration leaves of them (rtol
    # 1e-12 of that size; measured 3.7e-10 J, 8e-14 of it).
    scale = 9.81 * np.abs(ours["base_z"]).max()
    assert np.ptp(ours["E"]) < 1e-12 * scale


# Built with --compile too: q̈ and the base's acceleration generated as straight-line code
# (the floating articulated-body algorithm), which the build checks it runs.
COMPILED = ["go2_description/urdf/go2.urdf"]


@pytest.fixture(scope="module", params=[(rel, False) for rel in LEGGED] + [(rel, True) for rel in COMPILED],
                ids=lambda p: pathlib.Path(p[0]).stem + (" compiled" if p[1] else ""))
def legged(request, tmp_path_factory):
    rel, compiled = request.param
    urdf = robots_dir() / rel
    out = tmp_path_factory.mktemp("floating")
    name = "F_" + "".join(c if c.isalnum() else "_" for c in pathlib.Path(rel).stem) + ("_C" if compiled else "")
    extra = ["--compile"] if compiled else []
    res = subprocess.run([str(cli()), "build", "--urdf", str(urdf), "--out", str(out), "--floating-base",
                          "--name", name, "--platforms", "host", *extra],
                         capture_output=True, text=True, env=build_env())
    assert res.returncode == 0, res.stderr[-2000:]
    print(res.stdout.strip())
    if compiled:
        assert "runs straight-line code generated for this mechanism" in res.stdout, res.stdout
    return urdf, fs.Model(name, out / f"{name}.fmu")


def test_a_floating_robot_equals_pinocchios_free_flyer(legged, instances):
    urdf, model = legged
    names = model.state_names
    nq = names.index("base_q3") + 1
    ours = names[: nq - 7]
    assert names[nq - 7:nq] == BASE_Q and names[nq:nq + len(ours)] == [f"{j}_dot" for j in ours]
    assert names[nq + len(ours):] == BASE_V
    ref = FreeFlyer(urdf, ours)
    n = len(ours)
    joints = urdf_joints(urdf)
    d, f = coordinate_damping(joints, ours), coordinate_friction(joints, ours)
    prismatic = np.array([model.vars[j].unit == "m" for j in ours], dtype=bool)
    inst = instances(model, model.name)
    rng = np.random.default_rng(20261129 + n)
    worst = {"a": 0.0, "E": 0.0, "rates": 0.0, "momentum": 0.0}
    mass = sum(inertia.mass for inertia in ref.model.inertias)
    for k in range(4):
        base_q = np.concatenate([rng.uniform(-2, 2, 3), random_unit_quaternion(rng)])
        base_v = rng.uniform(-1, 1, 6)
        q = rng.uniform(-np.pi, np.pi, n)
        q[prismatic] = rng.uniform(-0.05, 0.05, prismatic.sum())
        qd, tau = rng.uniform(-2, 2, n), rng.uniform(-1, 1, n)
        if k:
            inst.ok("fmi2Reset")
        values = {**dict(zip(BASE_Q, base_q)), **dict(zip(BASE_V, base_v)), **dict(zip(ours, q)),
                  **{f"{j}_dot": x for j, x in zip(ours, qd)}, **{f"tau_{j}": x for j, x in zip(ours, tau)},
                  "limit_events": 0}
        inst.initialize(values, tol=1e-10)
        pq, pv = ref.q(base_q, q), ref.v(base_v, qd)
        # Damping, and Coulomb friction −F sign(q̇) (every joint slips), as the FMU applies them.
        a_base, a_joints = ref.accelerations(pq, pv, tau - d * qd - f * np.sign(qd))
        got = np.array(inst.get_reals([f"der({v})" for v in BASE_V] + [f"der({j}_dot)" for j in ours]))
        want = np.concatenate([a_base, a_joints])
        worst["a"] = max(worst["a"], (np.abs(got - want) / np.maximum(1.0, np.abs(want))).max())
        energy = pin.computeKineticEnergy(ref.model, ref.data, pq, pv) + pin.computePotentialEnergy(ref.model, ref.data, pq)
        worst["E"] = max(worst["E"], abs(inst.get_reals(["E"])[0] - energy) / max(1.0, abs(energy)))
        # The base's kinematics: ṗ = R v, q̇ = ½ q ⊗ (0, ω).
        rot = pin.Quaternion(pq[6], *pq[3:6]).toRotationMatrix()
        w0, x0, y0, z0 = base_q[3:]
        wx, wy, wz = base_v[3:]
        spin = 0.5 * np.array([-x0 * wx - y0 * wy - z0 * wz, w0 * wx + y0 * wz - z0 * wy,
                               w0 * wy - x0 * wz + z0 * wx, w0 * wz + x0 * wy - y0 * wx])
        rates = np.array(inst.get_reals([f"der({v})" for v in BASE_Q]))
        worst["rates"] = max(worst["rates"], np.abs(rates - np.concatenate([rot @ base_v[:3], spin])).max())
        # Momentum about the centre of mass: rate (0, M g) at our accelerations.
        pa = ref.g @ got  # (the bias of the mimics' accelerations is 0: q = r q_J + o)
        dh = pin.computeCentroidalMomentumTimeVariation(ref.model, ref.data, pq, pv, pa)
        h_dot = np.concatenate([ref.data.dhg.linear, ref.data.dhg.angular])
        expected = np.array([0, 0, -9.81 * mass, 0, 0, 0])
        worst["momentum"] = max(worst["momentum"], np.abs(h_dot - expected).max() / (9.81 * mass))
        del dh
    print(f"{urdf.name}: {n} joints + floating base, worst {worst}")
    assert worst["a"] < 1e-10 and worst["E"] < 1e-10, worst
    assert worst["rates"] < 1e-14 and worst["momentum"] < 1e-10, worst


def test_a_floating_robot_falls_freely_in_its_default_experiment(legged):
    """Released at rest, no torques: every body falls at g, the shape kept (the joints' q̈
    is 0 and the base's v̇ is Rᵀ g) to the stop time."""
    urdf, model = legged
    stop = float(model.md.defaultExperiment.stopTime)
    run = fmpy.simulate_fmu(str(model.path), output=["base_z", "base_vz", "E"])
    assert run["time"][-1] == pytest.approx(stop)
    t = run["time"]
    assert np.allclose(run["base_z"], -0.5 * 9.81 * t**2, rtol=1e-9, atol=1e-9)
    assert np.ptp(run["E"]) < 1e-9 * max(1.0, np.abs(run["E"]).max())


# A floating arm (a prismatic joint, products of inertia, an off-origin root) with a pointer
# following the shoulder at half its angle: src/multibody/floating_tests.rs's ARM with_mimic.
ARM_WITH_MIMIC = """<robot name="arm">
  <link name="torso"><inertial><origin xyz="0.05 -0.02 0.1"/><mass value="4"/>
    <inertia ixx="0.3" ixy="0.01" ixz="-0.02" iyy="0.25" iyz="0.015" izz="0.2"/></inertial></link>
  <link name="upper"><inertial><origin xyz="0.1 0.02 -0.15"/><mass value="1.5"/>
    <inertia ixx="0.025" ixy="0.001" ixz="0.002" iyy="0.03" iyz="-0.001" izz="0.015"/></inertial></link>
  <link name="slider"><inertial><origin xyz="0 0.03 0.05"/><mass value="0.8"/>
    <inertia ixx="0.004" ixy="0" ixz="0.0005" iyy="0.005" iyz="0" izz="0.003"/></inertial></link>
  <link name="hand"><inertial><origin xyz="0.02 0 -0.04"/><mass value="0.5"/>
    <inertia ixx="0.002" ixy="0.0001" ixz="0" iyy="0.0015" iyz="0.0002" izz="0.001"/></inertial></link>
  <link name="pointer"><inertial><origin xyz="0.05 0.02 0.1"/><mass value="0.3"/>
    <inertia ixx="0.002" ixy="0.0001" ixz="0" iyy="0.003" iyz="0" izz="0.0025"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="torso"/><child link="upper"/>
    <origin xyz="0.1 0.2 0.3" rpy="0.3 -0.2 0.5"/><axis xyz="0 0.6 0.8"/>
    <limit lower="-3" upper="3" effort="50" velocity="5"/><dynamics damping="0.2"/></joint>
  <joint name="slide" type="prismatic"><parent link="upper"/><child link="slider"/>
    <origin xyz="0.2 0 -0.3" rpy="0 0.4 0"/><axis xyz="1 0 0"/>
    <limit lower="-0.5" upper="0.5" effort="50" velocity="1"/></joint>
  <joint name="wrist" type="continuous"><parent link="slider"/><child link="hand"/>
    <origin xyz="0 0.1 0" rpy="-0.3 0 0.2"/><axis xyz="1 0 0"/></joint>
  <joint name="follower" type="revolute"><parent link="hand"/><child link="pointer"/>
    <origin xyz="0.05 0 -0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/>
    <mimic joint="shoulder" multiplier="0.5" offset="0.1"/><dynamics damping="0.1"/></joint>
</robot>"""


def test_a_floating_mimic_arm_compiled_equals_the_runtime(tmp_path, instances):
    """The straight-line code --compile generates for a floating base with a mimic joint
    (the reduced mass matrix's CRBA and LDLᵀ, traced) against the runtime's interpreted
    dynamics (the same algorithm run over the model's arrays): every derivative at random
    states, 1e-12 relative to max(1, |a|) (two evaluation orders of the same arithmetic)."""
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(ARM_WITH_MIMIC)
    models = {}
    for name, extra in [("ArmRuntime", []), ("ArmCompiled", ["--compile"])]:
        res = subprocess.run([str(cli()), "build", "--urdf", str(urdf), "--out", str(tmp_path), "--floating-base",
                              "--name", name, "--platforms", "host", *extra],
                             capture_output=True, text=True, env=build_env())
        assert res.returncode == 0, res.stderr[-2000:]
        print(res.stdout.strip())
        models[name] = fs.Model(name, tmp_path / f"{name}.fmu")
    assert "runs straight-line code generated for this mechanism" in res.stdout, res.stdout
    joints = ["shoulder", "slide", "wrist"]
    derivatives = [f"der({v})" for v in models["ArmRuntime"].state_names]
    assert models["ArmCompiled"].state_names == models["ArmRuntime"].state_names
    runs = {name: instances(m, name) for name, m in models.items()}
    rng = np.random.default_rng(32)
    worst = 0.0
    for k in range(5):
        values = {**dict(zip(BASE_Q, np.concatenate([rng.uniform(-2, 2, 3), random_unit_quaternion(rng)]))),
                  **dict(zip(BASE_V, rng.uniform(-1, 1, 6))),
                  **dict(zip(joints, rng.uniform(-1, 1, 3) * [2, 0.3, 2])),
                  **{f"{j}_dot": x for j, x in zip(joints, rng.uniform(-2, 2, 3))},
                  **{f"tau_{j}": x for j, x in zip(joints, rng.uniform(-1, 1, 3))}, "limit_events": 0}
        got = {}
        for name, inst in runs.items():
            if k:
                inst.ok("fmi2Reset")
            inst.initialize(values, tol=1e-10)
            got[name] = np.array(inst.get_reals(derivatives))
        want = got["ArmRuntime"]
        worst = max(worst, (np.abs(got["ArmCompiled"] - want) / np.maximum(1.0, np.abs(want))).max())
    print(f"floating arm with a mimic joint, compiled against the runtime: worst {worst:.1e}")
    assert worst < 1e-12


def test_a_robot_past_the_generated_code_limit_says_it_runs_interpreted(tmp_path):
    """Talos full floating (12 moving mimic joints): its generated q̈ would take 38 491
    operations, which rustc compiles in 10 min; --compile builds its crate without it and
    says so."""
    urdf = robots_dir() / "talos_data/robots/talos_full_v2.urdf"
    res = subprocess.run([str(cli()), "build", "--urdf", str(urdf), "--out", str(tmp_path), "--floating-base",
                          "--name", "TalosFullC", "--platforms", "host", "--compile"],
                         capture_output=True, text=True, env=build_env())
    assert res.returncode == 0, res.stderr[-2000:]
    print(res.stdout.strip())
    assert "no straight-line code: its q̈ would take more than 20000 operations" in res.stdout, res.stdout
    assert (tmp_path / "TalosFullC.fmu").exists()
