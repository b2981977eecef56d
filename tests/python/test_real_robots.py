"""Real robot files (issue 32): the URDFs of example-robot-data as they ship.

Mimic joints: the real Panda (its ``panda_finger_joint2`` mimics ``panda_finger_joint1``,
both damped) built with `mbfmu build --urdf` (the prebuilt runtime, no compiler; and with
--compile, the reduced q̈ generated as straight-line code) against
Pinocchio's mimic model (``buildModelFromUrdf(…, mimic=True)``: the mimicking joint has no
coordinate). Pinocchio's ``aba`` refuses mimics, so its q̈ is
``crba⁻¹ (τ − D v − nonLinearEffects)``; its model drops the mimic's damping, which ours
applies through the multiplier (−r² d v on the joint it follows), so ``D`` here is the
URDF's, composed the same way: an independent statement of the rule, from the file.

What must hold, at 50 random states and torques: ``der(J_dot)`` equal to Pinocchio's to
1e-10 relative to max(1, |q̈ᵢ|); ``E`` equal to its kinetic plus potential energy to 1e-10
relative to max(1, |E|); the mimic's outputs ``J``, ``J_dot`` equal to multiplier × the
followed joint's (+ offset); fmpy validates the FMU and runs its default experiment to the
stop time.

Every URDF of example-robot-data 6.0 (69 files): built, or refused for its own fault with
one line (REFUSED); see the test's docstring, and docs/robots.md for the measured table.
"""

from __future__ import annotations

import pathlib
import subprocess
import xml.etree.ElementTree as ET

import fmpy
import numpy as np
import pinocchio as pin
import pytest
from fmpy.validation import validate_fmu

import fmu_support as fs
from test_linearization import cli
from test_urdf_fmu import build_env
from test_multibody_pinocchio import configuration, robots_dir


def build(urdf: pathlib.Path, out: pathlib.Path, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(cli()), "build", "--urdf", str(urdf), "--out", str(out), *extra],
                          capture_output=True, text=True)


@pytest.fixture(scope="module", params=["runtime", "compiled"])
def panda(request, tmp_path_factory):
    """The Panda from the runtime, and compiled (--compile: the reduced q̈ generated as
    straight-line code, which the build checks it runs)."""
    out = tmp_path_factory.mktemp("panda_mimic")
    urdf = robots_dir() / "panda_description" / "urdf" / "panda.urdf"
    name = "PandaMimic" if request.param == "runtime" else "PandaMimicCompiled"
    extra = ["--compile"] if request.param == "compiled" else []
    res = subprocess.run([str(cli()), "build", "--urdf", str(urdf), "--out", str(out), "--name", name,
                          "--platforms", "host", *extra],
                         capture_output=True, text=True, env=build_env())
    assert res.returncode == 0, res.stderr
    print(res.stdout.strip())
    if request.param == "compiled":
        assert "runs straight-line code generated for this mechanism" in res.stdout, res.stdout
    return urdf, fs.Model(name, out / f"{name}.fmu")


def urdf_joints(urdf: pathlib.Path) -> dict[str, dict]:
    """Each joint's damping and, for a moving joint that mimics another, the joint at the
    end of its chain with the composed multiplier and offset (from the file)."""
    joints = {}
    # The robot's own <joint> elements (not those named inside <transmission>).
    for j in ET.parse(urdf).getroot().findall("joint"):
        dyn, mimic = j.find("dynamics"), j.find("mimic")
        joints[j.get("name")] = {
            "damping": float(dyn.get("damping", 0) or 0) if dyn is not None else 0.0,
            "mimic": None if mimic is None or j.get("type") == "fixed" else (
                mimic.get("joint"), float(mimic.get("multiplier", 1)), float(mimic.get("offset", 0))),
        }
    for j in joints.values():
        if j["mimic"]:
            of, r, o = j["mimic"]
            while joints[of]["mimic"]:
                of, r2, o2 = joints[of]["mimic"]
                r, o = r * r2, r * o2 + o
            j["root"] = (of, r, o)
    return joints


def coordinate_damping(joints: dict[str, dict], ours: list[str]) -> np.ndarray:
    """Per coordinate: its joint's damping plus r² × that of each joint following it."""
    d = np.array([joints[j]["damping"] for j in ours])
    for j in joints.values():
        if j["mimic"]:
            of, r, _ = j["root"]
            d[ours.index(of)] += r * r * j["damping"]
    return d


class PinocchioMimic:
    """Pinocchio's model of a URDF with its mimic joints (no coordinate of their own),
    addressed in our coordinate order; q̈ = crba⁻¹ (τ − D q̇ − nonLinearEffects), as its
    ``aba`` refuses mimics. Its energy functions refuse them too: the energies are those of
    the model read without mimics, every joint set (a mimic's q = r q_joint + o)."""

    def __init__(self, urdf: pathlib.Path, ours: list[str]):
        self.free = pin.buildModelFromUrdf(str(urdf))
        self.free_data = self.free.createData()
        self.ours = ours
        self.roots = {name: j["root"] for name, j in urdf_joints(urdf).items() if j["mimic"]}
        try:
            self.model = pin.buildModelFromUrdf(str(urdf), mimic=True)
        except ValueError:
            # Pinocchio 4.1 refuses some files' mimics ("the parent joint of the mimic
            # joint is not in the kinematic tree": Talos's grippers): q̈ then from the model
            # without mimics, its mass matrix and bias reduced by G here.
            self.model = None
            return
        self.data = self.model.createData()
        assert len(ours) == self.model.nv, (ours, self.model.nv)
        self.joints = [self.model.joints[self.model.getJointId(j)] for j in ours]
        self.idx = np.array([j.idx_v for j in self.joints])

    def q(self, q: np.ndarray) -> np.ndarray:
        return configuration(self.model, self.joints, q)

    def v(self, v: np.ndarray) -> np.ndarray:
        out = np.zeros(self.model.nv)
        out[self.idx] = v
        return out

    def qdd(self, q, qd, force) -> np.ndarray:
        if self.model is None:
            return self.reduced_qdd(q, qd, force)
        pq = self.q(q)
        m = pin.crba(self.model, self.data, pq)
        m = np.triu(m) + np.triu(m, 1).T
        nle = pin.nonLinearEffects(self.model, self.data, pq, self.v(qd))
        return np.linalg.solve(m, self.v(force) - nle)[self.idx]

    def full(self, q, qd):
        """Every joint's position and velocity in the model without mimics, and G (its
        velocities = G q̇)."""
        names, qs, vs = list(self.ours), list(q), list(qd)
        g = np.zeros((self.free.nv, len(self.ours)))
        for name, (of, r, o) in self.roots.items():
            i = self.ours.index(of)
            names.append(name)
            qs.append(r * q[i] + o)
            vs.append(r * qd[i])
        joints = [self.free.joints[self.free.getJointId(j)] for j in names]
        pq = configuration(self.free, joints, qs)
        pv = np.zeros(self.free.nv)
        idx = [j.idx_v for j in joints]
        pv[idx] = vs
        for k, name in enumerate(names):
            of, r = (self.roots[name][0], self.roots[name][1]) if name in self.roots else (name, 1.0)
            g[idx[k], self.ours.index(of)] = r
        return pq, pv, g

    def reduced_qdd(self, q, qd, force) -> np.ndarray:
        pq, pv, g = self.full(q, qd)
        m = pin.crba(self.free, self.free_data, pq)
        m = np.triu(m) + np.triu(m, 1).T
        nle = pin.nonLinearEffects(self.free, self.free_data, pq, pv)
        return np.linalg.solve(g.T @ m @ g, force - g.T @ nle)

    def energy(self, q, qd) -> float:
        pq, pv, _ = self.full(q, qd)
        return (pin.computeKineticEnergy(self.free, self.free_data, pq, pv)
                + pin.computePotentialEnergy(self.free, self.free_data, pq))


def initialised_at(inst, ours: list[str], q, qd, tau, reset: bool) -> None:
    """The instance initialised at (q, q̇, τ) with limit events off (fmi2Reset first when
    `reset`: states can only be set before initialisation)."""
    if reset:
        inst.ok("fmi2Reset")
    values = {j: x for j, x in zip(ours, q)}
    values.update({f"{j}_dot": x for j, x in zip(ours, qd)})
    values.update({f"tau_{j}": x for j, x in zip(ours, tau)})
    values["limit_events"] = 0.0
    inst.initialize(values, tol=1e-10)


def test_mimic_joints_equal_pinocchios_mimic_model(panda, instances):
    urdf, model = panda
    n = len(model.state_names) // 2
    ours = model.state_names[:n]
    ref = PinocchioMimic(urdf, ours)
    assert n == 8 and "panda_finger_joint2" not in ours, ours
    joints = urdf_joints(urdf)
    mimics = {name: j["root"] for name, j in joints.items() if j["mimic"]}
    assert list(mimics) == ["panda_finger_joint2"]
    d = coordinate_damping(joints, ours)
    assert d[ours.index("panda_finger_joint1")] > joints["panda_finger_joint1"]["damping"]
    der = [f"der({j}_dot)" for j in ours]
    inst = instances(model, "panda_mimic")
    rng = np.random.default_rng(20261128)
    worst = {"qdd": 0.0, "E": 0.0, "mimic": 0.0}
    for k in range(50):
        q = rng.uniform(-np.pi, np.pi, n)
        q[7] = rng.uniform(0.0, 0.04)
        qd, tau = rng.uniform(-2, 2, n), rng.uniform(-10, 10, n)
        initialised_at(inst, ours, q, qd, tau, reset=k > 0)
        want = ref.qdd(q, qd, tau - d * qd)
        got = np.array(inst.get_reals(der))
        worst["qdd"] = max(worst["qdd"], (np.abs(got - want) / np.maximum(1.0, np.abs(want))).max())
        energy = ref.energy(q, qd)
        worst["E"] = max(worst["E"], abs(inst.get_reals(["E"])[0] - energy) / max(1.0, abs(energy)))
        for name, (of, r, o) in mimics.items():
            i = ours.index(of)
            got_q, got_v = inst.get_reals([name, f"{name}_dot"])
            worst["mimic"] = max(worst["mimic"], abs(got_q - (r * q[i] + o)), abs(got_v - r * qd[i]))
    print(f"panda with its mimic: worst {worst}")
    assert worst["qdd"] < 1e-10, worst
    assert worst["E"] < 1e-10, worst
    assert worst["mimic"] < 1e-15, worst


def test_the_mimic_fmu_validates_and_runs_its_default_experiment(panda):
    _, model = panda
    assert validate_fmu(str(model.path)) == []
    stop = float(model.md.defaultExperiment.stopTime)
    res = fmpy.simulate_fmu(str(model.path), output=["E", "panda_finger_joint2"])
    assert res["time"][-1] == pytest.approx(stop)
    assert np.isfinite(res["E"]).all()


# ------------------------------------------------------------- every example-robot-data URDF

# The files refused for their own fault: (what the one line must say, why it is the file's).
REFUSED = {
    "ur_description/urdf/ur3.urdf": ("has no links", "an empty <robot> (its links are in ur3_robot.urdf)"),
    "romeo_description/urdf/romeo.urdf": ("moves only massless links",
                                          "the hands' joints move links without mass or inertia"),
    "romeo_description/urdf/romeo_laas_small.urdf": ("negative beyond rounding",
                                                     "a principal moment of −5 % of the largest; "
                                                     "Pinocchio's mass matrix of it is singular"),
    "icub_description/robots/icub.urdf": ("the mass matrix is singular",
                                          "the head is a point mass: Pinocchio's mass matrix has "
                                          "condition 1.6e17 at the neutral configuration"),
    "alex_description/urdf/alex_psyonic_hands.urdf": ("which does not exist",
                                                      "its mimics name joints the file does not have"),
    "hector_description/robots/quadrotor_base.urdf": ("has no moving joint",
                                                      "a single rigid body: nothing moves without a floating base"),
    "iris_description/robots/iris_simple.urdf": ("has no moving joint",
                                                 "a single rigid body: nothing moves without a floating base"),
}

def every_urdf() -> list[str]:
    root = robots_dir()
    return sorted(str(p.relative_to(root)) for p in root.rglob("*.urdf"))


def test_example_robot_data_has_the_69_files_of_its_version_6():
    assert len(every_urdf()) == 69


@pytest.mark.parametrize("rel", every_urdf())
def test_every_urdf_builds_and_runs_or_is_refused_for_its_own_fault(rel, tmp_path, instances):
    """`mbfmu build --urdf FILE` (the runtime, this machine's binary): either an FMU whose
    default experiment fmpy runs to its stop time and whose der(J_dot) and E equal
    Pinocchio's (mimic model) at 3 random states to 1e-10 relative, or one `mbfmu:` line
    saying what is wrong with the file (REFUSED)."""
    urdf = robots_dir() / rel
    identifier = "R_" + "".join(c if c.isalnum() else "_" for c in rel.removesuffix(".urdf"))
    res = build(urdf, tmp_path, "--name", identifier, "--platforms", "host")
    if rel in REFUSED:
        says, why = REFUSED[rel]
        lines = res.stderr.strip().splitlines()
        assert res.returncode == 1 and len(lines) == 1, res.stderr
        assert lines[0].startswith("mbfmu: ") and says in lines[0], (lines, why)
        assert not list(tmp_path.glob("*.fmu"))
        print(f"{rel}: refused ({why}): {lines[0]}")
        return
    assert res.returncode == 0, res.stderr[-2000:]
    print(res.stdout.strip())
    model = fs.Model(identifier, tmp_path / f"{identifier}.fmu")
    stop = float(model.md.defaultExperiment.stopTime)
    run = fmpy.simulate_fmu(str(model.path), output=["E"])
    assert run["time"][-1] == pytest.approx(stop) and np.isfinite(run["E"]).all()
    n = len(model.state_names) // 2
    ours = model.state_names[:n]
    ref = PinocchioMimic(urdf, ours)
    d = coordinate_damping(urdf_joints(urdf), ours)
    prismatic = np.array([model.vars[j].unit == "m" for j in ours])
    # Torques within the effort limits (at most 1).
    span = np.array([min(1.0, -float(model.vars[f"tau_{j}"].min or -1.0), float(model.vars[f"tau_{j}"].max or 1.0))
                     for j in ours])
    inst = instances(model, identifier)
    rng = np.random.default_rng(20261128 + n)
    worst = {"qdd": 0.0, "E": 0.0}
    for k in range(3):
        q = rng.uniform(-np.pi, np.pi, n)
        q[prismatic] = rng.uniform(-0.05, 0.05, prismatic.sum())
        qd, tau = rng.uniform(-2, 2, n), rng.uniform(-1, 1, n) * span
        initialised_at(inst, ours, q, qd, tau, reset=k > 0)
        want = ref.qdd(q, qd, tau - d * qd)
        got = np.array(inst.get_reals([f"der({j}_dot)" for j in ours]))
        worst["qdd"] = max(worst["qdd"], (np.abs(got - want) / np.maximum(1.0, np.abs(want))).max())
        energy = ref.energy(q, qd)
        worst["E"] = max(worst["E"], abs(inst.get_reals(["E"])[0] - energy) / max(1.0, abs(energy)))
    print(f"{rel}: {n} coordinates, worst {worst}")
    assert worst["qdd"] < 1e-10 and worst["E"] < 1e-10, worst
