"""src/multibody against Pinocchio (``pin``) on URDF robots.

examples/multibody_eval.rs (built here with cargo, release) reads a URDF and a JSON list of
(q, q̇, τ) and prints ABA's q̈, the mass matrix, the bias RNEA(q, q̇, 0), the energies and
the poses of the ends of branches. For the UR5 and the Panda of ``example-robot-data`` and
two double pendulums, at 100 seeded random states and torques each, they must equal
Pinocchio's ``aba``, ``crba`` (its upper triangle, symmetrised), ``rnea``,
``computeKineticEnergy``, ``computePotentialEnergy`` and frame placements.

Tolerances: q̈ to 1e-10 relative to max(1, |q̈ᵢ|) per component (two implementations in
floating point, the mass matrix's conditioning amplifying rounding); M, bias and energies to
1e-10 relative to max(1, the largest magnitude); positions to 1e-12 m.

Potential energy: Pinocchio's ``computePotentialEnergy`` is −Σ mᵢ g·cᵢ over the moving
bodies (the universe's inertia, with whatever is welded to the root, left out), zero with
every centre of mass at the base origin: ours is defined the same way and compared as is.

Damping: Pinocchio's ``aba`` ignores joint damping (its URDF parser stores it in
``model.damping`` but no algorithm uses it) while ours applies τ − d q̇. So the damping
vectors are first checked equal (by joint name) and Pinocchio is then given τ − d q̇.

Joints are matched by name (Pinocchio orders siblings its own way); a continuous joint has
(cos q, sin q) as Pinocchio's configuration. The Panda's ``panda_finger_joint2`` mimics
``panda_finger_joint1``: both sides read a copy with the ``<mimic>`` element removed (two
independent fingers), so that the tree's ABA is compared with ``pin.aba``, which refuses
mimics (the mimic model is compared in test_real_robots.py).

Run ``python tests/python/test_multibody_pinocchio.py --bench`` for ns per ABA call (Rust
in a loop, and ``pin.aba`` from Python in a loop, binding overhead included).
"""

from __future__ import annotations

import json
import os
import pathlib
import re
import subprocess
import sys
import time

import numpy as np
import pytest

import pinocchio as pin

REPO = pathlib.Path(__file__).resolve().parents[2]


def robots_dir() -> pathlib.Path:
    """``<site-packages>/cmeel.prefix/share/example-robot-data/robots``."""
    for base in map(pathlib.Path, sys.path):
        d = base / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if d.is_dir():
            return d
    raise FileNotFoundError("example-robot-data's robots/ folder is not on sys.path")


DOUBLE_PENDULUM = """<?xml version="1.0"?>
<robot name="double_pendulum">
  <link name="base"/>
  <link name="upper">
    <inertial>
      <origin xyz="0 0 -0.9"/>
      <mass value="1.3"/>
      <inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/>
    </inertial>
  </link>
  <link name="lower">
    <inertial>
      <origin xyz="0 0 -0.6"/>
      <mass value="0.7"/>
      <inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/>
    </inertial>
  </link>
  <link name="tip"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="upper"/>
    <axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="5"/>
    <dynamics damping="0.1"/>
  </joint>
  <joint name="elbow" type="continuous">
    <parent link="upper"/><child link="lower"/>
    <origin xyz="0 0 -0.9"/>
    <axis xyz="0 1 0"/>
  </joint>
  <joint name="tip_joint" type="fixed">
    <parent link="lower"/><child link="tip"/>
    <origin xyz="0 0 -0.6" rpy="0.1 0.2 0.3"/>
  </joint>
</robot>
"""


def build_example() -> pathlib.Path:
    subprocess.run(
        ["cargo", "build", "--release", "--quiet", "--example", "multibody_eval"],
        cwd=REPO,
        check=True,
    )
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    if not target.is_absolute():
        target = REPO / target
    return target / "release" / "examples" / "multibody_eval"


@pytest.fixture(scope="module")
def example() -> pathlib.Path:
    return build_example()


def urdf_files(tmp: pathlib.Path) -> dict[str, pathlib.Path]:
    robots = robots_dir()
    panda = (robots / "panda_description" / "urdf" / "panda.urdf").read_text()
    unmimicked = tmp / "panda_no_mimic.urdf"
    unmimicked.write_text(re.sub(r"<mimic[^>]*/>", "", panda))
    own = tmp / "double_pendulum.urdf"
    own.write_text(DOUBLE_PENDULUM)
    return {
        "ur5": robots / "ur_description" / "urdf" / "ur5_robot.urdf",
        "panda": unmimicked,
        "double_pendulum": own,
        "erd_double_pendulum": robots / "double_pendulum_description" / "urdf" / "double_pendulum.urdf",
    }


def configuration(model, joints, q) -> np.ndarray:
    """Positions of `joints` (Pinocchio joint models, one coordinate each of ours) as
    `model`'s configuration, the rest neutral ((cos, sin) for a continuous joint)."""
    out = pin.neutral(model)
    for j, x in zip(joints, q):
        if j.nq == 2:
            out[j.idx_q : j.idx_q + 2] = [np.cos(x), np.sin(x)]
        else:
            out[j.idx_q] = x
    return out


class Reference:
    """Pinocchio's model of a URDF, addressed by our joint order."""

    def __init__(self, path: pathlib.Path, joints: list[str]):
        self.model = pin.buildModelFromUrdf(str(path))
        self.data = self.model.createData()
        ids = [self.model.getJointId(name) for name in joints]
        assert all(i < self.model.njoints for i in ids), f"joints {joints} not all in Pinocchio's model"
        assert len(joints) == self.model.nv, "one coordinate per moving joint"
        self.joints = [self.model.joints[i] for i in ids]
        self.v_index = np.array([j.idx_v for j in self.joints])

    def q(self, q: np.ndarray) -> np.ndarray:
        """Our joint positions as Pinocchio's configuration ((cos, sin) for continuous)."""
        return configuration(self.model, self.joints, q)

    def v(self, v: np.ndarray) -> np.ndarray:
        out = np.zeros(self.model.nv)
        out[self.v_index] = v
        return out

    def ours(self, v: np.ndarray) -> np.ndarray:
        """A Pinocchio velocity-space vector in our order."""
        return np.asarray(v)[self.v_index]


def random_points(n: int, count: int, seed: int) -> list[dict]:
    rng = np.random.default_rng(seed)
    return [
        {
            "q": rng.uniform(-np.pi, np.pi, n).tolist(),
            "qd": rng.uniform(-2.0, 2.0, n).tolist(),
            "tau": rng.uniform(-10.0, 10.0, n).tolist(),
        }
        for _ in range(count)
    ]


def evaluate(example: pathlib.Path, urdf: pathlib.Path, points: list[dict]) -> dict:
    out = subprocess.run(
        [str(example), str(urdf)], input=json.dumps(points), capture_output=True, text=True
    )
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def joint_count(example: pathlib.Path, urdf: pathlib.Path) -> int:
    return len(evaluate(example, urdf, [])["joints"])


@pytest.mark.parametrize("robot", ["ur5", "panda", "double_pendulum", "erd_double_pendulum"])
def test_dynamics_equal_pinocchio(example, tmp_path, robot):
    urdf = urdf_files(tmp_path)[robot]
    n = joint_count(example, urdf)
    points = random_points(n, 100, seed=20261126 + n)
    ours = evaluate(example, urdf, points)
    ref = Reference(urdf, ours["joints"])
    model, data = ref.model, ref.data

    damping = np.array(ours["damping"])
    np.testing.assert_array_equal(damping, ref.ours(model.damping))

    worst = {"qdd": 0.0, "M": 0.0, "bias": 0.0, "energy": 0.0, "tip": 0.0}
    for p, r in zip(points, ours["points"]):
        q, qd, tau = (np.array(p[k]) for k in ("q", "qd", "tau"))
        pq, pv = ref.q(q), ref.v(qd)

        # Pinocchio ignores damping: give it τ − d q̇.
        qdd = ref.ours(pin.aba(model, data, pq, pv, ref.v(tau - damping * qd)))
        err = np.abs(np.array(r["qdd"]) - qdd) / np.maximum(1.0, np.abs(qdd))
        worst["qdd"] = max(worst["qdd"], err.max())

        m = pin.crba(model, data, pq)
        m = np.triu(m) + np.triu(m, 1).T
        m = m[np.ix_(ref.v_index, ref.v_index)]
        worst["M"] = max(worst["M"], np.abs(np.array(r["mass_matrix"]) - m).max() / max(1.0, np.abs(m).max()))

        bias = ref.ours(pin.rnea(model, data, pq, pv, np.zeros(model.nv)))
        worst["bias"] = max(worst["bias"], np.abs(np.array(r["bias"]) - bias).max() / max(1.0, np.abs(bias).max()))

        kinetic = pin.computeKineticEnergy(model, data, pq, pv)
        potential = pin.computePotentialEnergy(model, data, pq)
        worst["energy"] = max(
            worst["energy"],
            abs(r["kinetic"] - kinetic) / max(1.0, abs(kinetic)),
            abs(r["potential"] - potential) / max(1.0, abs(potential)),
        )

        pin.framesForwardKinematics(model, data, pq)
        for name, tip in zip(ours["tips"], r["tips"]):
            placement = data.oMf[model.getFrameId(name, pin.BODY)]
            worst["tip"] = max(worst["tip"], np.abs(np.array(tip["position"]) - placement.translation).max())
            x, y, z, w = pin.Quaternion(placement.rotation).coeffs()
            ours_q = np.array(tip["quaternion"])
            # A quaternion and its negative are the same rotation.
            sign = 1.0 if np.dot(ours_q, [w, x, y, z]) >= 0 else -1.0
            worst["tip"] = max(worst["tip"], np.abs(ours_q - sign * np.array([w, x, y, z])).max())
            assert abs(np.linalg.norm(ours_q) - 1.0) < 1e-12

    print(f"{robot}: n={n}, worst relative errors {worst}")
    assert worst["qdd"] < 1e-10, worst
    assert worst["M"] < 1e-10, worst
    assert worst["bias"] < 1e-10, worst
    assert worst["energy"] < 1e-10, worst
    assert worst["tip"] < 1e-12, worst


def test_a_mimic_of_a_missing_joint_is_refused_with_one_line(example, tmp_path):
    """Mimic joints are read (test_real_robots.py checks their dynamics); one naming a joint
    the file does not have is refused with one line naming both."""
    panda = (robots_dir() / "panda_description" / "urdf" / "panda.urdf").read_text()
    bad = tmp_path / "panda_bad_mimic.urdf"
    bad.write_text(re.sub(r'<mimic joint="panda_finger_joint1"', '<mimic joint="nowhere"', panda))
    out = subprocess.run([str(example), str(bad)], input="[]", capture_output=True, text=True)
    assert out.returncode != 0
    line = out.stderr.strip()
    assert "\n" not in line
    assert 'joint "panda_finger_joint2": mimics joint "nowhere", which does not exist' in line, line


def bench(count: int = 200_000) -> None:
    """ns per ABA call: Rust (the example's loop) and pin.aba from Python (with overhead)."""
    import tempfile

    example = build_example()
    with tempfile.TemporaryDirectory() as tmp:
        files = urdf_files(pathlib.Path(tmp))
        # The double pendulum too: across nv = 2, 6, 9 the slope of pin.aba's time is its
        # cost per joint, the intercept mostly the Python binding's overhead.
        for robot in ("double_pendulum", "ur5", "panda"):
            rust = subprocess.run(
                [str(example), str(files[robot]), "--bench", str(count * 5)],
                capture_output=True, text=True, check=True,
            )
            rust_ns = json.loads(rust.stdout)["ns_per_aba"]
            model = pin.buildModelFromUrdf(str(files[robot]))
            data = model.createData()
            rng = np.random.default_rng(1)
            states = [
                (
                    pin.neutral(model) + rng.uniform(-1, 1, model.nq),
                    rng.uniform(-2, 2, model.nv),
                    rng.uniform(-10, 10, model.nv),
                )
                for _ in range(64)
            ]
            aba = pin.aba
            for q, v, tau in states:
                aba(model, data, q, v, tau)
            start = time.perf_counter()
            for k in range(count):
                q, v, tau = states[k & 63]
                aba(model, data, q, v, tau)
            py_ns = (time.perf_counter() - start) / count * 1e9
            print(f"{robot}: nv={model.nv} Rust ABA {rust_ns:.0f} ns/call; pin.aba from Python {py_ns:.0f} ns/call (binding overhead included)")


if __name__ == "__main__":
    if "--bench" in sys.argv:
        bench()
    else:
        sys.exit(pytest.main([__file__, "-q"]))
