"""Independent reference for IFToMM benchmark A04, Bricard's mechanism (docs/iftomm-sources.md, "A04").

Built from the benchmark description only (Pinocchio + SciPy, nothing from the project):

* Five rods of 1 m, 1 kg, square section 0.1 m, on the edges of a unit cube; revolute joints
  J1..J6 at JOINT_POINTS about JOINT_AXES; gravity 9.81 in -y; released from rest; 10 s.
* Open tree ground -J1- rod1 -J2- rod2 -J3- rod3 -J4- rod4 -J5- rod5, coordinates q1..q5,
  all 0 in the drawn cube. qi is the right-handed rotation of rod i relative to its parent about
  the axis of Ji, fixed in the parent (so at q = 0 the world axis listed): q1 > 0 turns rod 1
  about +y (its tip (1,0,0) goes to -z), q2 about +z, q3 about +x, q4 about +y, q5 about +z.
* J6 closes the loop: rod 5's point (0,0,1) stays at the ground's (3 equations), and rod 5's
  point that is at (1,0,1) when q = 0 (1 m along J6's axis) keeps y = 0, z = 1 (2 equations).
  Five residuals, rank 4 everywhere (the Bricard redundancy), so 1 DOF.
* Dynamics M q'' + h = G^T lam, G q'' = gamma = -(dG/dt) q', solved in the null space of G:
  a truncated SVD of G at rank 4 (see `_svd` for why not an rcond) gives N = null(G) (one column),
  q'' = pinv(G) gamma + N z with (N^T M N) z = N^T (-h - M pinv(G) gamma). No lambda is needed,
  and the redundant row costs nothing.
* Drift: DOP853 at rtol = atol = 1e-12 on (q, q'), restarted at every output time after a
  projection of q (Gauss-Newton with pinv(G)) and q' (orthogonal projection onto null(G)) back
  onto the constraint manifold. Chosen over a 1-DOF reduced form because it needs no choice of
  independent coordinate (q2 and q4 turn back mid-swing, so they are none; that q1 is one was
  only learnt from the solution) and it is the textbook index-1 DAE route. Unprojected, the loop residual after one interval is ~1e-15 for
  0.05 s, ~5e-13 for 1 s, 1.5e-11 for all 10 s at once (returned as 'drift'), so the projection
  only stops it accumulating; P3 from a 201-point and an 11-point grid agree to 6e-13.

`simulate` takes any model object with the methods of `PinocchioBricard` (the tests plug in a
numpy one with the loop cut at J1 instead, as a second route).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from scipy.integrate import solve_ivp

LENGTH = 1.0  # rod length [m]
MASS = 1.0  # rod mass [kg]
SIDE = 0.1  # square cross-section side [m]
GRAVITY = 9.81  # [m/s^2], along -y
I_AXIAL = MASS * (SIDE**2 + SIDE**2) / 12.0  # about the rod axis, through the COM
I_TRANSVERSE = MASS * (LENGTH**2 + SIDE**2) / 12.0  # about a transverse axis through the COM
T_END = 10.0

# Joint i+1 at JOINT_POINTS[i] about JOINT_AXES[i] (world, drawn configuration); rod i+1 runs
# from JOINT_POINTS[i] to JOINT_POINTS[i+1] (i = 0..4). J6 (index 5) is rod 5 - ground.
JOINT_POINTS = np.array(
    [[0, 0, 0], [1, 0, 0], [1, -1, 0], [1, -1, 1], [0, -1, 1], [0, 0, 1]], dtype=float
)
JOINT_AXES = np.array(
    [[0, 1, 0], [0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 0]], dtype=float
)
P3_0 = JOINT_POINTS[2].copy()  # rod 2 - rod 3 joint, the reported point
E_0 = -3.0 * MASS * GRAVITY  # energy at rest: rod COM heights 0, -0.5, -1, -1, -0.5
# The motion: q1 = q3 = q5 runs 0 -> pi -> 0 (at pi the cube mirrored in x = 0, same potential
# energy, so at rest again), q2 = q4 from 0 down to -pi/6 and back, twice per period.
PERIOD = 4.991711513687  # [s], by the energy quadrature in test_bricard_oracle.py (checked there)
DOF_RANK = 4  # rank of the 5 closure rows everywhere on the loop: 5 - 4 = 1 DOF


def rod_inertia(direction):
    """3x3 inertia about the COM of a rod lying along the unit vector `direction` (world axes)."""
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    return I_TRANSVERSE * np.eye(3) + (I_AXIAL - I_TRANSVERSE) * np.outer(d, d)


class PinocchioBricard:
    """The tree J1..J5 in Pinocchio; closure at J6. Body frames are parallel to the world at q = 0."""

    nq = 5

    def __init__(self):
        m = pin.Model()
        m.gravity.linear = np.array([0.0, -GRAVITY, 0.0])
        kinds = {0: pin.JointModelRX, 1: pin.JointModelRY, 2: pin.JointModelRZ}
        parent = 0
        for i in range(5):
            prev = JOINT_POINTS[i - 1] if i else np.zeros(3)
            jm = kinds[int(np.argmax(JOINT_AXES[i]))]()
            parent = m.addJoint(parent, jm, pin.SE3(np.eye(3), JOINT_POINTS[i] - prev), f"J{i + 1}")
            rod = JOINT_POINTS[i + 1] - JOINT_POINTS[i]
            m.appendBodyToJoint(parent, pin.Inertia(MASS, rod / 2, rod_inertia(rod)), pin.SE3.Identity())
        # closure points on rod 5, in J5's frame: J6 itself and 1 m further along J6's axis
        c = JOINT_POINTS[5] - JOINT_POINTS[4]
        op = pin.FrameType.OP_FRAME
        self.fa = m.addFrame(pin.Frame("J6", 5, pin.SE3(np.eye(3), c), op))
        self.fb = m.addFrame(pin.Frame("J6+axis", 5, pin.SE3(np.eye(3), c + JOINT_AXES[5]), op))
        self.perp = [k for k in range(3) if JOINT_AXES[5][k] == 0]  # the 2 directions across J6's axis
        self.model, self.data = m, m.createData()

    def closure(self, q):
        pin.framesForwardKinematics(self.model, self.data, q)
        a = self.data.oMf[self.fa].translation - JOINT_POINTS[5]
        b = self.data.oMf[self.fb].translation - (JOINT_POINTS[5] + JOINT_AXES[5])
        return np.concatenate([a, b[self.perp]])

    def jacobian(self, q):
        rf = pin.LOCAL_WORLD_ALIGNED
        ja = pin.computeFrameJacobian(self.model, self.data, q, self.fa, rf)[:3]
        jb = pin.computeFrameJacobian(self.model, self.data, q, self.fb, rf)[:3]
        return np.vstack([ja, jb[self.perp]])

    def gamma(self, q, v):
        """-(dG/dt) v: minus the classical acceleration of the closure points with q'' = 0."""
        pin.forwardKinematics(self.model, self.data, q, v, np.zeros(5))
        rf = pin.LOCAL_WORLD_ALIGNED
        aa = pin.getFrameClassicalAcceleration(self.model, self.data, self.fa, rf).linear
        ab = pin.getFrameClassicalAcceleration(self.model, self.data, self.fb, rf).linear
        return -np.concatenate([aa, ab[self.perp]])

    def mass(self, q):
        M = pin.crba(self.model, self.data, q)
        return np.triu(M) + np.triu(M, 1).T  # Pinocchio fills the upper triangle only

    def bias(self, q, v):
        return pin.nonLinearEffects(self.model, self.data, q, v)  # Coriolis + gravity

    def energy(self, q, v):
        # computePotentialEnergy is -sum m g.c = sum m 9.81 y_c: y measured from 0 as asked
        return pin.computeKineticEnergy(self.model, self.data, q, v) + pin.computePotentialEnergy(
            self.model, self.data, q
        )

    def p3(self, q):
        pin.forwardKinematics(self.model, self.data, q)
        return self.data.oMi[3].translation.copy()  # origin of J3 (on rods 2 and 3)


def _svd(G, rank=DOF_RANK):
    """Truncated SVD of G at the known rank 4 (the tests check the gap: sigma4 > 0.1, sigma5 < 1e-13).

    Not an rcond threshold: Runge-Kutta stages lie off the loop, where sigma5 ~ their distance to
    it; a stage 1e-9 off would count as rank 5 under rcond 1e-10 (no null space, no motion), and
    a vector field that switches like that spoils the step (with rcond 1e-10, output intervals of
    1.2 s and more gave overflowing rejected trial steps while developing).
    Fixed-rank truncation extends the field smoothly off the manifold and equals pinv on it.
    """
    U, S, Vt = np.linalg.svd(G)
    return U[:, :rank], S[:rank], Vt[:rank].T, Vt[rank:].T  # range basis, sigmas, row space, null space


def accel(model, q, v):
    """q'' of the constrained system (null-space method, tolerant of the redundant row)."""
    U, S, V, N = _svd(model.jacobian(q))
    qdd_p = V @ ((U.T @ model.gamma(q, v)) / S)  # pinv(G) gamma
    M = model.mass(q)
    z = np.linalg.solve(N.T @ M @ N, N.T @ (-model.bias(q, v) - M @ qdd_p))
    return qdd_p + N @ z


def project(model, q, v):
    """Back onto the manifold: q by Gauss-Newton with pinv(G), then v onto null(G)."""
    for _ in range(20):
        phi = model.closure(q)
        if np.max(np.abs(phi)) < 1e-15:
            break
        U, S, V, _ = _svd(model.jacobian(q))
        q = q - V @ ((U.T @ phi) / S)
    N = _svd(model.jacobian(q))[3]
    return q, N @ (N.T @ v)


def simulate(model, times, q0=None, rtol=1e-12, atol=1e-12):
    """q, v, drift at sorted `times` (>= 0), from rest at q0 (default the cube, q = 0)."""
    n = model.nq
    q = np.zeros(n) if q0 is None else np.asarray(q0, dtype=float)
    v = np.zeros(n)
    fun = lambda t, y: np.concatenate([y[n:], accel(model, y[:n], y[n:])])  # noqa: E731
    t0 = 0.0
    qs, vs, drift = [], [], []
    for t in np.asarray(times, dtype=float):
        if t > t0:
            sol = solve_ivp(fun, (t0, t), np.concatenate([q, v]), method="DOP853", rtol=rtol, atol=atol)
            assert sol.success, sol.message
            q, v = sol.y[:n, -1], sol.y[n:, -1]
            t0 = t
        drift.append(np.max(np.abs(model.closure(q))))  # before projection: the integrator's own
        q, v = project(model, q, v)
        qs.append(q)
        vs.append(v)
    return np.array(qs), np.array(vs), np.array(drift)


def reference(times, model=None) -> dict:
    """P3 (len(times) x 3), E, residual (max |closure|), drift (same, before projection), q, v."""
    model = model or PinocchioBricard()
    q, v, drift = simulate(model, times)
    return {
        "t": np.asarray(times, dtype=float),
        "P3": np.array([model.p3(x) for x in q]),
        "E": np.array([model.energy(x, y) for x, y in zip(q, v)]),
        "residual": np.array([np.max(np.abs(model.closure(x))) for x in q]),
        "drift": drift,
        "q": q,
        "v": v,
    }
