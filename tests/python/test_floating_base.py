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
"""

from __future__ import annotations

import pathlib

import fmpy
import numpy as np
import pinocchio as pin
import pytest
from fmpy.validation import validate_fmu

import fmu_support as fs
from test_multibody_pinocchio import robots_dir
from test_real_robots import (BASE_Q, BASE_V, FreeFlyer, build, coordinate_damping, coordinate_friction,
                              random_unit_quaternion, urdf_joints)

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


@pytest.fixture(scope="module", params=LEGGED)
def legged(request, tmp_path_factory):
    rel = request.param
    urdf = robots_dir() / rel
    out = tmp_path_factory.mktemp("floating")
    name = "F_" + "".join(c if c.isalnum() else "_" for c in pathlib.Path(rel).stem)
    res = build(urdf, out, "--floating-base", "--name", name, "--platforms", "host")
    assert res.returncode == 0, res.stderr[-2000:]
    print(res.stdout.strip())
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
