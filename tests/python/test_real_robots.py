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
one line (REFUSED); the legged, humanoid and flying ones (FLOATING: those example-robot-data's
loaders put on a free-flyer joint) with `--floating-base`, against Pinocchio's free-flyer
model (FreeFlyer, shared with test_floating_base.py). See the test's docstring, and
docs/robots.md for the measured table.
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
            "friction": float(dyn.get("friction", 0) or 0) if dyn is not None else 0.0,
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


def coordinate_friction(joints: dict[str, dict], ours: list[str]) -> np.ndarray:
    """Per coordinate: its joint's Coulomb friction F plus |r| F of each joint following it."""
    f = np.array([joints[j]["friction"] for j in ours])
    for j in joints.values():
        if j["mimic"]:
            of, r, _ = j["root"]
            f[ours.index(of)] += abs(r) * j["friction"]
    return f


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


# ------------------------------------------------------------------ floating base (its reference)

BASE_Q = ["base_x", "base_y", "base_z", "base_q0", "base_q1", "base_q2", "base_q3"]
BASE_V = ["base_vx", "base_vy", "base_vz", "base_wx", "base_wy", "base_wz"]


class FreeFlyer:
    """Pinocchio's model of a URDF on a free-flyer root joint, in our coordinate order. Its
    mimic joints (Talos's grippers: Pinocchio 4.1 refuses their mimic model) are joints of
    the model here, set from the joints they follow; its mass matrix and bias are reduced
    by G (base and independent joints → every velocity) as the mimic model would. (Shared
    by test_floating_base.py, which imports this module.)"""

    def __init__(self, urdf: pathlib.Path, ours: list[str]):
        self.model = pin.buildModelFromUrdf(str(urdf), pin.JointModelFreeFlyer())
        self.data = self.model.createData()
        self.ours = ours
        self.roots = {name: j["root"] for name, j in urdf_joints(urdf).items() if j["mimic"]}
        self.names = ours + list(self.roots)
        self.joints = [self.model.joints[self.model.getJointId(j)] for j in self.names]
        self.idx = np.array([j.idx_v for j in self.joints], dtype=int)
        assert len(self.names) + 6 == self.model.nv
        # G: our velocities (base, then our joints) → Pinocchio's.
        self.g = np.zeros((self.model.nv, 6 + len(ours)))
        self.g[:6, :6] = np.eye(6)
        for k, name in enumerate(self.names):
            of, r = (self.roots[name][0], self.roots[name][1]) if name in self.roots else (name, 1.0)
            self.g[self.idx[k], 6 + ours.index(of)] = r

    def q(self, base_q, q):
        full = list(q) + [r * q[self.ours.index(of)] + o for of, r, o in self.roots.values()]
        out = configuration(self.model, self.joints, full)
        w, x, y, z = base_q[3:]
        out[:7] = [*base_q[:3], x, y, z, w]  # Pinocchio's quaternion: scalar last
        return out

    def v(self, base_v, qd):
        return self.g @ np.concatenate([base_v, qd])

    def accelerations(self, pq, pv, tau):
        """(base acceleration, our joints' q̈): `aba` without mimics, else the reduced
        `Gᵀ M G a = Gᵀ (τ − nle)`."""
        if not self.roots:
            a = pin.aba(self.model, self.data, pq, pv, self.g[:, 6:] @ tau)
            return a[:6], a[self.idx[:len(self.ours)]]
        m = pin.crba(self.model, self.data, pq)
        m = np.triu(m) + np.triu(m, 1).T
        nle = pin.nonLinearEffects(self.model, self.data, pq, pv)
        # τ is already a force on the reduced coordinates (none on a mimic joint's own).
        force = np.concatenate([np.zeros(6), tau])
        a = np.linalg.solve(self.g.T @ m @ self.g, force - self.g.T @ nle)
        return a[:6], a[6:]

    def energy(self, pq, pv) -> float:
        return (pin.computeKineticEnergy(self.model, self.data, pq, pv)
                + pin.computePotentialEnergy(self.model, self.data, pq))


def random_unit_quaternion(rng):
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


def coordinates(model: fs.Model) -> tuple[list[str], bool]:
    """Our joint coordinates in state order, and whether the FMU has a floating base (its
    states: the joints' q, base_x … base_q3, the joints' q̇, base_vx … base_wz)."""
    names = model.state_names
    if "base_q3" not in names:
        return names[: len(names) // 2], False
    nq = names.index("base_q3") + 1
    ours = names[: nq - 7]
    assert names[nq - 7:nq] == BASE_Q and names[nq:nq + len(ours)] == [f"{j}_dot" for j in ours]
    assert names[nq + len(ours):] == BASE_V, names
    return ours, True


def worst_against_pinocchio(model: fs.Model, urdf: pathlib.Path, inst, rng, states: int,
                            torques: bool = True) -> dict[str, float]:
    """The largest relative differences, over `states` random states, of our q̈ (with a
    floating base, the base's acceleration too: der(base_v…), der(base_w…)) from
    Pinocchio's, relative to max(1, |a|), and of E from its kinetic plus potential energy,
    relative to max(1, |E|). Fixed base: its mimic model (PinocchioMimic); floating: its
    free-flyer model (FreeFlyer) at a random base position, attitude and velocity. Joints
    anywhere (prismatic ones within ±5 cm), moving at up to 2 rad/s, under torques within
    their effort limits (at most 1) unless not `torques`; the URDF's damping applied,
    and its Coulomb friction (−F sign(q̇): every joint slips)."""
    ours, floating = coordinates(model)
    n = len(ours)
    ref = FreeFlyer(urdf, ours) if floating else PinocchioMimic(urdf, ours)
    joints = urdf_joints(urdf)
    d = coordinate_damping(joints, ours)
    f = coordinate_friction(joints, ours)
    prismatic = np.array([model.vars[j].unit == "m" for j in ours], dtype=bool)
    span = np.array([min(1.0, -float(model.vars[f"tau_{j}"].min or -1.0), float(model.vars[f"tau_{j}"].max or 1.0))
                     for j in ours])
    der = [f"der({v})" for v in BASE_V] if floating else []
    der += [f"der({j}_dot)" for j in ours]
    worst = {"qdd": 0.0, "E": 0.0}
    for k in range(states):
        q = rng.uniform(-np.pi, np.pi, n)
        q[prismatic] = rng.uniform(-0.05, 0.05, prismatic.sum())
        qd = rng.uniform(-2, 2, n)
        tau = rng.uniform(-1, 1, n) * span if torques else np.zeros(n)
        if floating:
            base = (np.concatenate([rng.uniform(-2, 2, 3), random_unit_quaternion(rng)]),
                    rng.uniform(-1, 1, 6))
            initialised_at(inst, ours, q, qd, tau, reset=k > 0, base=base)
            pq, pv = ref.q(base[0], q), ref.v(base[1], qd)
            want = np.concatenate(ref.accelerations(pq, pv, tau - d * qd - f * np.sign(qd)))
            energy = ref.energy(pq, pv)
        else:
            initialised_at(inst, ours, q, qd, tau, reset=k > 0)
            want = ref.qdd(q, qd, tau - d * qd - f * np.sign(qd))
            energy = ref.energy(q, qd)
        got = np.array(inst.get_reals(der))
        worst["qdd"] = max(worst["qdd"], (np.abs(got - want) / np.maximum(1.0, np.abs(want))).max(initial=0.0))
        worst["E"] = max(worst["E"], abs(inst.get_reals(["E"])[0] - energy) / max(1.0, abs(energy)))
    return worst


def initialised_at(inst, ours: list[str], q, qd, tau, reset: bool, base=None) -> None:
    """The instance initialised at (q, q̇, τ) with limit events off (fmi2Reset first when
    `reset`: states can only be set before initialisation); `base` = (base_q, base_v) sets
    a floating base's states too."""
    if reset:
        inst.ok("fmi2Reset")
    values = {j: x for j, x in zip(ours, q)}
    if base is not None:
        values.update(zip(BASE_Q, base[0]))
        values.update(zip(BASE_V, base[1]))
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

# The files built with --floating-base. Authority: example-robot-data's own loaders
# (example-robot-data-loaders 5.0, the loaders of these files: robots_loader.py, talos.py,
# human.py), which load each of these on a free-flyer root joint (`free_flyer = True`), a
# file without a loader as its siblings, and the flying robots. Every other file is fixed
# (the loaders' `free_flyer = False`: arms, hands, pendulums, Baxter, Alex's upper body,
# TIAGo and TIAGo Pro, the Talos arm) but the SO-100 and SO-101, which the loader floats
# and which are desk arms: fixed here as the other arms.
FLOATING = frozenset([
    # Quadrupeds (their loaders float them; walking needs a free trunk).
    "a1_description/urdf/a1.urdf",
    "anymal_b_simple_description/robots/anymal.urdf",
    "anymal_c_simple_description/urdf/anymal.urdf",
    "b1_description/urdf/b1.urdf",
    "go1_description/urdf/go1.urdf",
    "go2_description/urdf/go2.urdf",
    "hyq_description/robots/hyq_no_sensors.urdf",
    "laikago_description/urdf/laikago.urdf",
    "quadruped_description/urdf/quadruped.urdf",
    "solo_description/robots/solo.urdf",
    "solo_description/robots/solo12.urdf",
    # Quadrupeds carrying an arm, and Centauro's four wheeled legs (their loaders float them).
    "anymal_b_simple_description/robots/anymal-kinova.urdf",
    "b1_description/urdf/b1-z1.urdf",
    "centauro_description/urdf/centauro.urdf",
    # Bipeds and humanoids (their loaders float them).
    "alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf",
    "bolt_description/robots/bolt.urdf",
    "g1_description/urdf/g1_29dof_rev_1_0.urdf",
    "g1_description/urdf/g1_29dof_with_hand_rev_1_0.urdf",
    "human_description/robots/human.urdf",
    "icub_description/robots/icub.urdf",
    "icub_description/robots/icub_reduced.urdf",
    "romeo_description/urdf/romeo.urdf",
    "simple_humanoid_description/urdf/simple_humanoid.urdf",
    "simple_humanoid_description/urdf/simple_humanoid_classical.urdf",
    "talos_data/robots/talos_full_v2.urdf",
    "talos_data/robots/talos_full_v2_box.urdf",
    "talos_data/robots/talos_reduced.urdf",
    "talos_data/robots/talos_reduced_box.urdf",
    # Humanoids without a loader of their own: variants of files their loaders float.
    "romeo_description/urdf/romeo_laas_small.urdf",
    "romeo_description/urdf/romeo_small.urdf",
    "talos_data/robots/talos_reduced_corrected.urdf",
    # PR2: a mobile manipulator, which its loader floats (its wheeled base is not modelled).
    "pr2_description/urdf/pr2.urdf",
    # Flying: quadrotors (Hector's and Iris's loaders float them; iris.urdf, no loader, is
    # iris_simple with its four rotors) and aerial manipulators (Borinot's, Hextilt's loaders).
    "hector_description/robots/quadrotor_base.urdf",
    "iris_description/robots/iris.urdf",
    "iris_description/robots/iris_simple.urdf",
    "borinot_description/urdf/borinot_flying_arm_2.urdf",
    "hextilt_description/urdf/hextilt_flying_arm_5.urdf",
])

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
}


def every_urdf() -> list[str]:
    root = robots_dir()
    return sorted(str(p.relative_to(root)) for p in root.rglob("*.urdf"))


def identifier_of(rel: str) -> str:
    return "R_" + "".join(c if c.isalnum() else "_" for c in rel.removesuffix(".urdf"))


def base_options(rel: str) -> list[str]:
    return ["--floating-base"] if rel in FLOATING else []


def test_example_robot_data_has_the_69_files_of_its_version_6():
    assert len(every_urdf()) == 69
    assert FLOATING <= set(every_urdf())
    assert len(FLOATING) == 37


@pytest.mark.parametrize("rel", every_urdf())
def test_every_urdf_builds_and_runs_or_is_refused_for_its_own_fault(rel, tmp_path, instances):
    """`mbfmu build --urdf FILE` (the runtime, this machine's binary; `--floating-base` for
    FLOATING): either an FMU whose default experiment fmpy runs to its stop time and whose
    der(J_dot) and E (floating: and the base's der(base_v…), der(base_w…)) equal
    Pinocchio's (fixed: its mimic model; floating: its free-flyer model, at a random base
    pose and velocity) at 3 random states to 1e-10 relative, or one `mbfmu:` line saying
    what is wrong with the file (REFUSED). A floating robot's default experiment is a free
    fall (no ground): base_z = −½ g t². A single rigid body floating (Hector's
    quadrotor_base, Iris's iris_simple) is an FMU of base states alone."""
    urdf = robots_dir() / rel
    identifier = identifier_of(rel)
    res = build(urdf, tmp_path, "--name", identifier, "--platforms", "host", *base_options(rel))
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
    ours, floating = coordinates(model)
    assert floating == (rel in FLOATING)
    stop = float(model.md.defaultExperiment.stopTime)
    run = fmpy.simulate_fmu(str(model.path), output=["E", "base_z"] if floating else ["E"])
    assert run["time"][-1] == pytest.approx(stop) and np.isfinite(run["E"]).all()
    if floating:
        # No ground: released at rest with no torques, it falls freely, its shape kept.
        t = run["time"]
        assert np.allclose(run["base_z"], -0.5 * 9.81 * t**2, rtol=1e-9, atol=1e-9)
    inst = instances(model, identifier)
    rng = np.random.default_rng(20261128 + len(ours))
    worst = worst_against_pinocchio(model, urdf, inst, rng, 3)
    print(f"{rel}: {len(ours)} coordinates{' + floating base' if floating else ''}, worst {worst}")
    assert worst["qdd"] < 1e-10 and worst["E"] < 1e-10, worst
