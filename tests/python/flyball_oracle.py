"""Independent reference for IFToMM benchmark A05, the stiff flyball governor (docs/iftomm-sources.md, "A05").

Built from the benchmark description only (Pinocchio + SciPy, nothing from the project's Rust code):

* z up along the shaft, origin at the shaft's bottom bearing; gravity 9.81 m/s^2 along -z; 10 s.
* Tree of four joints, coordinates q = (shaft, s, alpha_A, alpha_B):
  - `shaft`: JointModelRZ on the ground at the origin. Shaft: 1.0 x 0.01 x 0.01 m prism along z,
    0.3 kg, centre of mass (0, 0, 0.5).
  - `s`: JointModelPZ on the shaft (placement identity), so s is the height of the slider centre
    above the shaft bottom; the slider (0.1 m cube, 3 kg) turns with the shaft.
  - `alpha_A`: JointModelRY on the shaft at A = (+0.05, 0, 1). A right-handed turn alpha about +y
    takes +x to (cos alpha, 0, -sin alpha): rod A, laid along the joint frame's +x, points down
    and out at alpha below the horizontal.
  - `alpha_B`: the same JointModelRY, but its joint frame at B = (-0.05, 0, 1) is turned by pi
    about z (Pinocchio placement rotation), so its local +y is the shaft's -y and its local +x
    the shaft's -x: rod B points along (-cos alpha_B, 0, -sin alpha_B), a turn about -y.
    (The "rotated frame" option, not a mirrored body.)
  - Each rod: 1.0 x 0.01 x 0.01 m prism, 0.3 kg, centre 0.5 m along the rod; plus a 5 kg point
    mass (pin.Inertia with zero rotational inertia) at 1 m, both appended to the rod's joint.
* Two spring-dampers between the slider's side points (+-0.05, 0, 0) (slider frame = shaft
  orientation) and the rod midpoints; F = K (l - l0) + C dl/dt, K = 8e5 N/m, C = 4e4 N s/m,
  l0 = 0.5 m, pulling the two points together when positive. Generalised force
  Q = -sum F J_l^T with J_l = u^T (J_rod point - J_slider point), u the unit vector slider -> rod,
  the point Jacobians from Pinocchio frames (LOCAL_WORLD_ALIGNED).
* q'' = M^-1 (Q - h) with M from pin.crba and h = pin.nonLinearEffects (Coriolis + gravity).
* State y = (q, q', E_dissipated), dE_dissipated/dt = sum C (dl/dt)^2 (the 9th state), so
  E + E_dissipated is a first integral (E = T + m g z of the centres of mass + K/2 (l - l0)^2,
  zero with every centre at z = 0 and the springs at rest, the FMU's convention).
* Start: s = 0.5, alpha_A = alpha_B = pi/6 (the springs exactly at rest length), shaft turning at
  2 pi rad/s, every other rate 0.

Integration: SciPy's Radau (the springs make it stiff: the damper modes decay at ~1e4 1/s, the
rest of the motion has a period ~1 s) at rtol = 1e-12, atol = 1e-13 with a finite-difference
Jacobian; outputs by restarting at every requested time (no dense-output interpolation, whose
collocation polynomial is a lower order than the step). About 15 s of CPU for 1001 times;
`reference` caches by the tuple of times. test_flyball_oracle.py checks this against a hand
Lagrangian (a second route, no Pinocchio), the energy balance, the symmetry, the conserved
angular momentum and an independent integration.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pinocchio as pin
from scipy.integrate import solve_ivp

GRAVITY = 9.81  # [m/s^2], along -z
T_END = 10.0

# bodies (prisms: I = m (a^2 + b^2) / 12 about each axis through the centre)
SHAFT_LENGTH, SHAFT_SIDE, SHAFT_MASS = 1.0, 0.01, 0.3
ROD_LENGTH, ROD_SIDE, ROD_MASS = 1.0, 0.01, 0.3
SLIDER_SIDE, SLIDER_MASS = 0.1, 3.0
BALL_MASS = 5.0  # point mass at the free end of each rod
HINGE_X = 0.05  # rods hinged at (+-0.05, 0, 1) on the shaft
HINGE_Z = 1.0
SPRING_ON_ROD = 0.5  # spring attached at the rod midpoint, 0.5 m from the hinge
SPRING_ON_SLIDER = 0.05  # slider side point (+-0.05, 0, 0) from the slider centre

I_ROD_AXIAL = ROD_MASS * (2 * ROD_SIDE**2) / 12.0  # 5e-6
I_ROD_TRANSVERSE = ROD_MASS * (ROD_LENGTH**2 + ROD_SIDE**2) / 12.0  # 0.0250025
I_SHAFT_AXIAL = SHAFT_MASS * (2 * SHAFT_SIDE**2) / 12.0  # 5e-6
I_SHAFT_TRANSVERSE = SHAFT_MASS * (SHAFT_LENGTH**2 + SHAFT_SIDE**2) / 12.0  # 0.0250025
I_SLIDER = SLIDER_MASS * (2 * SLIDER_SIDE**2) / 12.0  # 0.005

K_SPRING = 8e5  # [N/m]
C_DAMPER = 4e4  # [N s/m]
REST_LENGTH = 0.5  # [m]

NAMES = ("shaft", "s", "alpha_A", "alpha_B")
Q0 = np.array([0.0, 0.5, np.pi / 6, np.pi / 6])
V0 = np.array([2 * np.pi, 0.0, 0.0, 0.0])
Y0 = np.concatenate([Q0, V0, [0.0]])  # + E_dissipated

RTOL, ATOL = 1e-12, 1e-13


def _rot_z(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


class PinocchioFlyball:
    """The 4-DOF tree in Pinocchio and the two spring-dampers on it."""

    nq = 4

    def __init__(self):
        m = pin.Model()
        m.gravity.linear = np.array([0.0, 0.0, -GRAVITY])
        op = pin.FrameType.OP_FRAME

        j_shaft = m.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "shaft")
        m.appendBodyToJoint(
            j_shaft,
            pin.Inertia(SHAFT_MASS, np.array([0.0, 0.0, SHAFT_LENGTH / 2]),
                        np.diag([I_SHAFT_TRANSVERSE, I_SHAFT_TRANSVERSE, I_SHAFT_AXIAL])),
            pin.SE3.Identity(),
        )
        j_slider = m.addJoint(j_shaft, pin.JointModelPZ(), pin.SE3.Identity(), "s")
        m.appendBodyToJoint(j_slider, pin.Inertia(SLIDER_MASS, np.zeros(3), I_SLIDER * np.eye(3)),
                            pin.SE3.Identity())
        rod = pin.Inertia(ROD_MASS, np.array([ROD_LENGTH / 2, 0.0, 0.0]),
                          np.diag([I_ROD_AXIAL, I_ROD_TRANSVERSE, I_ROD_TRANSVERSE]))
        ball = pin.Inertia(BALL_MASS, np.array([ROD_LENGTH, 0.0, 0.0]), np.zeros((3, 3)))
        self.spring_frames = []
        for name, side, rot in (("alpha_A", +1.0, np.eye(3)), ("alpha_B", -1.0, _rot_z(np.pi))):
            j = m.addJoint(j_shaft, pin.JointModelRY(), pin.SE3(rot, np.array([side * HINGE_X, 0.0, HINGE_Z])), name)
            m.appendBodyToJoint(j, rod, pin.SE3.Identity())
            m.appendBodyToJoint(j, ball, pin.SE3.Identity())
            f_slider = m.addFrame(pin.Frame(f"slider_{name}", j_slider,
                                            pin.SE3(np.eye(3), np.array([side * SPRING_ON_SLIDER, 0.0, 0.0])), op))
            f_rod = m.addFrame(pin.Frame(f"rod_{name}", j, pin.SE3(np.eye(3), np.array([SPRING_ON_ROD, 0.0, 0.0])), op))
            self.spring_frames.append((f_slider, f_rod))
        self.model, self.data = m, m.createData()

    def springs(self, q, v):
        """Per spring: length l, rate dl/dt, and the row J_l = dl/dq (4,)."""
        pin.computeJointJacobians(self.model, self.data, q)
        pin.updateFramePlacements(self.model, self.data)
        rf = pin.LOCAL_WORLD_ALIGNED
        out = []
        for fs_, fr in self.spring_frames:
            d = self.data.oMf[fr].translation - self.data.oMf[fs_].translation
            length = np.linalg.norm(d)
            u = d / length
            Jd = (pin.getFrameJacobian(self.model, self.data, fr, rf)[:3]
                  - pin.getFrameJacobian(self.model, self.data, fs_, rf)[:3])
            Jl = u @ Jd
            out.append((length, Jl @ v, Jl))
        return out

    def spring_force(self, q, v):
        """Generalised force of the two spring-dampers and the power they dissipate."""
        Q = np.zeros(4)
        power = 0.0
        for length, rate, Jl in self.springs(q, v):
            Q -= (K_SPRING * (length - REST_LENGTH) + C_DAMPER * rate) * Jl
            power += C_DAMPER * rate**2
        return Q, power

    def mass(self, q):
        M = pin.crba(self.model, self.data, q)
        return np.triu(M) + np.triu(M, 1).T  # Pinocchio fills the upper triangle only

    def bias(self, q, v):
        return pin.nonLinearEffects(self.model, self.data, q, v)  # Coriolis + centrifugal + gravity

    def accel(self, q, v):
        Q, power = self.spring_force(q, v)
        return np.linalg.solve(self.mass(q), Q - self.bias(q, v)), power

    def rhs(self, t, y):
        q, v = y[:4], y[4:8]
        a, power = self.accel(q, v)
        return np.concatenate([v, a, [power]])

    def energy(self, q, v):
        """T + sum m g z_c + K/2 (l - l0)^2 (computePotentialEnergy is -sum m g.c = sum m 9.81 z_c)."""
        spring = sum(0.5 * K_SPRING * (length - REST_LENGTH) ** 2 for length, _, _ in self.springs(q, v))
        return (pin.computeKineticEnergy(self.model, self.data, q, v)
                + pin.computePotentialEnergy(self.model, self.data, q) + spring)

    def angular_momentum_z(self, q, v):
        """z component of the angular momentum about the origin, from Pinocchio's centroidal momentum."""
        pin.computeCentroidalMomentum(self.model, self.data, q, v)
        h = self.data.hg
        return h.angular[2] + np.cross(self.data.com[0], h.linear)[2]

    def spring_lengths(self, q):
        return np.array([length for length, _, _ in self.springs(q, np.zeros(4))])


def simulate(model, times, y0=Y0, rtol=RTOL, atol=ATOL, method="Radau"):
    """The 9-state solution at sorted `times` (>= 0), restarting the integrator at every one."""
    y = np.array(y0, dtype=float)
    t0 = 0.0
    rows, nfev = [], 0
    step = None
    for t in np.asarray(times, dtype=float):
        if t > t0:
            kw = {"first_step": min(step, t - t0)} if step else {}
            sol = solve_ivp(model.rhs, (t0, t), y, method=method, rtol=rtol, atol=atol, **kw)
            assert sol.success, sol.message
            nfev += sol.nfev
            if len(sol.t) > 2:  # a representative step for the next start (the last one may be cut short)
                step = float(np.median(np.diff(sol.t)))
            y = sol.y[:, -1]
            t0 = t
        rows.append(y.copy())
    return np.array(rows), nfev


def _pack(model, times, Y, nfev=0) -> dict:
    q, v = Y[:, :4], Y[:, 4:8]
    out = {"t": np.asarray(times, dtype=float), "q": q, "v": v, "nfev": nfev}
    for i, name in enumerate(NAMES):
        out[name] = q[:, i]
        out[name + "_dot"] = v[:, i]
    out["E_dissipated"] = Y[:, 8]
    out["E"] = np.array([model.energy(a, b) for a, b in zip(q, v)])
    out["L_z"] = np.array([model.angular_momentum_z(a, b) for a, b in zip(q, v)])
    out["spring_lengths"] = np.array([model.spring_lengths(a) for a in q])
    return out


@lru_cache(maxsize=8)
def _reference(times: tuple, rtol: float, atol: float, method: str) -> dict:
    model = PinocchioFlyball()
    Y, nfev = simulate(model, times, rtol=rtol, atol=atol, method=method)
    return _pack(model, times, Y, nfev)


def reference(times, rtol=RTOL, atol=ATOL, method="Radau") -> dict:
    """Dict of arrays at `times`: shaft, s, alpha_A, alpha_B and their "_dot"s, E, E_dissipated,
    L_z (angular momentum about the shaft axis), spring_lengths (n x 2), q, v (n x 4).

    Cached (do not modify the arrays)."""
    return _reference(tuple(float(t) for t in times), float(rtol), float(atol), method)
