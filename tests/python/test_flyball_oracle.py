"""Tests of the A05 flyball-governor oracle (flyball_oracle.py) itself, before anything is compared with it.

The second route is `HandFlyball`, a Lagrangian written out by hand (numpy, no Pinocchio). With
q = (phi, s, alpha, beta) (shaft, slider, rod A, rod B) every mass point of a rod lies in the
shaft's x-z plane at (x, z) with x = +-(0.05 + r cos gamma), z = 1 - r sin gamma, and moves with
velocity (dx/dt, phi' x, dz/dt) in shaft axes, so there are no cross terms and
  T = 1/2 J(alpha, beta) phi'^2 + 1/2 m_slider s'^2 + 1/2 I_hinge (alpha'^2 + beta'^2),
  J = I_shaft,z + I_slider + sum_gamma [m_rod (0.05 + 0.5 c)^2 + m_ball (0.05 + c)^2
                                        + I_rod,axial sin^2 gamma + I_rod,transverse c^2],
  I_hinge = m_rod / 4 + I_rod,transverse + m_ball,
the spring length l(s, gamma) = |(0.5 cos gamma, 1 - 0.5 sin gamma - s)| (both springs stay in the
shaft's x-z plane), and phi is cyclic: J phi' is conserved. Its M, h, spring forces and energy
must equal Pinocchio's at random states, and its trajectory, integrated by LSODA instead of
Radau, the oracle's.

Invariants of the oracle's own solution: E + E_dissipated (the 9th state) constant, the
symmetric start staying symmetric, the angular momentum about z (from Pinocchio's centroidal
momentum, not from M) constant. Last, the curve read off the published plot, which is weak
(+-0.005 m) and printed as METRIC lines.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

import flyball_oracle as fo

TIMES = np.linspace(0.0, fo.T_END, 1001)  # the FMU's default output grid (shares the oracle's cache)

I_HINGE = fo.ROD_MASS * (fo.ROD_LENGTH / 2) ** 2 + fo.I_ROD_TRANSVERSE + fo.BALL_MASS * fo.ROD_LENGTH**2


@pytest.fixture(scope="module")
def ref():
    return fo.reference(TIMES)


class HandFlyball:
    """The closed-form Lagrangian above. q = (phi, s, alpha, beta)."""

    def _J(self, g):
        """A rod's share of J and its derivative d/dgamma."""
        c, s = np.cos(g), np.sin(g)
        xr, xb = fo.HINGE_X + fo.SPRING_ON_ROD * c, fo.HINGE_X + fo.ROD_LENGTH * c
        j = (fo.ROD_MASS * xr**2 + fo.BALL_MASS * xb**2
             + fo.I_ROD_AXIAL * s**2 + fo.I_ROD_TRANSVERSE * c**2)
        dj = (-2 * fo.ROD_MASS * xr * fo.SPRING_ON_ROD * s - 2 * fo.BALL_MASS * xb * fo.ROD_LENGTH * s
              + 2 * (fo.I_ROD_AXIAL - fo.I_ROD_TRANSVERSE) * s * c)
        return j, dj

    def inertia_z(self, q):
        return fo.I_SHAFT_AXIAL + fo.I_SLIDER + self._J(q[2])[0] + self._J(q[3])[0]

    def mass(self, q):
        return np.diag([self.inertia_z(q), fo.SLIDER_MASS, I_HINGE, I_HINGE])

    def bias(self, q, v):
        """d/dt dT/dq' - dT/dq + dV_gravity/dq at q'' = 0."""
        _, dja = self._J(q[2])
        _, djb = self._J(q[3])
        gm = fo.GRAVITY * (fo.ROD_MASS * fo.SPRING_ON_ROD + fo.BALL_MASS * fo.ROD_LENGTH)
        return np.array([
            (dja * v[2] + djb * v[3]) * v[0],
            fo.SLIDER_MASS * fo.GRAVITY,
            -0.5 * dja * v[0] ** 2 - gm * np.cos(q[2]),
            -0.5 * djb * v[0] ** 2 - gm * np.cos(q[3]),
        ])

    def springs(self, q, v):
        """(l, dl/dt, dl/dq) of spring A (on alpha) and spring B (on beta)."""
        out = []
        for k in (2, 3):
            g = q[k]
            dx, dz = fo.SPRING_ON_ROD * np.cos(g), fo.HINGE_Z - fo.SPRING_ON_ROD * np.sin(g) - q[1]
            length = np.hypot(dx, dz)
            Jl = np.zeros(4)
            Jl[1] = -dz / length
            Jl[k] = (-dx * fo.SPRING_ON_ROD * np.sin(g) - dz * fo.SPRING_ON_ROD * np.cos(g)) / length
            out.append((length, Jl @ v, Jl))
        return out

    def spring_force(self, q, v):
        Q, power = np.zeros(4), 0.0
        for length, rate, Jl in self.springs(q, v):
            Q -= (fo.K_SPRING * (length - fo.REST_LENGTH) + fo.C_DAMPER * rate) * Jl
            power += fo.C_DAMPER * rate**2
        return Q, power

    def rhs(self, t, y):
        q, v = y[:4], y[4:8]
        Q, power = self.spring_force(q, v)
        return np.concatenate([v, (Q - self.bias(q, v)) / np.diag(self.mass(q)), [power]])

    def energy(self, q, v):
        heights = (fo.SHAFT_MASS * fo.SHAFT_LENGTH / 2 + fo.SLIDER_MASS * q[1]
                   + sum(fo.ROD_MASS * (fo.HINGE_Z - fo.SPRING_ON_ROD * np.sin(g))
                         + fo.BALL_MASS * (fo.HINGE_Z - fo.ROD_LENGTH * np.sin(g)) for g in q[2:4]))
        spring = sum(0.5 * fo.K_SPRING * (length - fo.REST_LENGTH) ** 2 for length, _, _ in self.springs(q, v))
        return 0.5 * v @ self.mass(q) @ v + fo.GRAVITY * heights + spring


def _random_states(n, seed=5):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = np.array([rng.uniform(-np.pi, np.pi), rng.uniform(0.3, 0.9),
                      rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2)])
        yield q, rng.uniform(-8, 8, 4)


def test_initial_state(ref):
    """Springs exactly at rest at the start; the numbers of docs/iftomm-sources.md (A05)."""
    m = fo.PinocchioFlyball()
    np.testing.assert_allclose(m.spring_lengths(fo.Q0), [0.5, 0.5], rtol=0, atol=1e-15)
    assert np.array_equal(ref["q"][0], fo.Q0) and np.array_equal(ref["v"][0], fo.V0)
    assert ref["E_dissipated"][0] == 0.0
    assert abs(ref["E"][0] - 238.885450) < 1e-6  # the "E ~ 239 J"
    pin.forwardKinematics(m.model, m.data, fo.Q0)
    ball_a = m.data.oMi[3].act(np.array([1.0, 0.0, 0.0]))  # joints: 1 shaft, 2 s, 3 alpha_A, 4 alpha_B
    ball_b = m.data.oMi[4].act(np.array([1.0, 0.0, 0.0]))
    np.testing.assert_allclose(ball_a, [0.05 + np.cos(np.pi / 6), 0, 0.5], atol=1e-15)  # (0.916, 0, 0.5)
    np.testing.assert_allclose(ball_b, [-0.05 - np.cos(np.pi / 6), 0, 0.5], atol=1e-15)  # rod B mirrored


def test_hand_lagrangian_matches_pinocchio():
    """M, h (Coriolis + gravity), the spring rows, their generalised force and E, at random states,
    to 1e-12 relative (rounding: the largest terms are K (l - l0) ~ 1e5 N, kept to ~1e-11 N)."""
    pm, hm = fo.PinocchioFlyball(), HandFlyball()
    worst = 0.0
    for q, v in _random_states(20):
        pairs = [(pm.mass(q), hm.mass(q)), (pm.bias(q, v), hm.bias(q, v)),
                 (pm.spring_force(q, v)[0], hm.spring_force(q, v)[0]),
                 (np.array([pm.spring_force(q, v)[1]]), np.array([hm.spring_force(q, v)[1]])),
                 (np.array([pm.energy(q, v)]), np.array([hm.energy(q, v)]))]
        pairs += [(a[2], b[2]) for a, b in zip(pm.springs(q, v), hm.springs(q, v))]
        for a, b in pairs:
            err = np.max(np.abs(a - b)) / max(1.0, np.max(np.abs(b)))
            worst = max(worst, err)
            assert err < 1e-12, (q, v, a, b)
        assert abs(pm.angular_momentum_z(q, v) - hm.inertia_z(q) * v[0]) < 1e-12 * abs(hm.inertia_z(q) * v[0]) + 1e-14
    print(f"METRIC A05 oracle: Pinocchio and the hand Lagrangian agree to {worst:.1e} (relative) at 20 random states")


def test_hand_lagrangian_trajectory_agrees(ref):
    """The hand equations integrated by LSODA (a BDF/Adams code, not Radau) give the same motion.
    1e-9: the two integrators at 1e-12 differ by ~5e-11 in s and alpha, 3e-10 in the shaft angle."""
    t = TIMES[::50]
    sol = solve_ivp(HandFlyball().rhs, (0.0, fo.T_END), fo.Y0, method="LSODA", t_eval=t,
                    rtol=1e-12, atol=1e-13, first_step=1e-6)
    assert sol.success, sol.message
    err = {name: np.max(np.abs(sol.y[i] - ref[name][::50])) for i, name in enumerate(fo.NAMES)}
    err["E_dissipated"] = np.max(np.abs(sol.y[8] - ref["E_dissipated"][::50]))
    print("METRIC A05 oracle vs hand Lagrangian + LSODA: " + ", ".join(f"{k} {v:.1e}" for k, v in err.items()))
    assert max(err.values()) < 1e-9, err


def test_radau_converged():
    """Radau at 1e-12 against Radau at 1e-13 and DOP853 (explicit, so ~5e5 evaluations: only 1 s of
    motion) at 1e-12: the oracle's own integration error is ~1e-13, far below the 1e-6 it referees."""
    t = np.linspace(0.0, 1.0, 11)
    a = fo.reference(t)
    b = fo.reference(t, rtol=1e-13, atol=1e-14)
    c = fo.reference(t, method="DOP853")
    for other in (b, c):
        for name in ("s", "alpha_A", "alpha_B", "shaft", "shaft_dot", "E_dissipated"):
            assert np.max(np.abs(a[name] - other[name])) < 1e-11, name


def test_energy_balance(ref):
    """E + E_dissipated is a first integral (no input, a free shaft): to 1e-10 relative (1e-14 seen)."""
    total = ref["E"] + ref["E_dissipated"]
    drift = np.max(np.abs(total - total[0])) / total[0]
    print(f"METRIC A05 oracle: |E + E_dissipated - E(0)| / E(0) <= {drift:.1e}; "
          f"E_dissipated(10 s) = {ref['E_dissipated'][-1]:.6e} J")
    assert drift < 1e-10
    assert np.all(np.diff(ref["E_dissipated"]) > 0)  # the dampers only take energy out
    # small: the springs hardly stretch (< 1e-4 m), so the motion is almost conservative
    assert 2e-3 < ref["E_dissipated"][-1] < 5e-3
    assert np.max(np.abs(ref["spring_lengths"] - fo.REST_LENGTH)) < 1e-4


def test_symmetry_and_angular_momentum(ref):
    """The symmetric start stays symmetric; L_z (no torque about z) stays at J(pi/6) 2 pi."""
    sym = np.max(np.abs(ref["alpha_A"] - ref["alpha_B"]))
    L = ref["L_z"]
    dL = np.max(np.abs(L - L[0])) / L[0]
    print(f"METRIC A05 oracle: |alpha_A - alpha_B| <= {sym:.1e} rad, |L_z - L_z(0)| / L_z(0) <= {dL:.1e}")
    assert sym < 1e-12
    assert dL < 1e-11
    assert abs(L[0] - HandFlyball().inertia_z(fo.Q0) * 2 * np.pi) < 1e-12
    # the shaft speeds up when the balls come in (J smaller) and slows when they go out
    J = np.array([HandFlyball().inertia_z(q) for q in ref["q"]])
    np.testing.assert_allclose(ref["shaft_dot"], L[0] / J, rtol=1e-11)


def test_published_curve(ref):
    """The official s(t) as plotted by OSIM (docs/iftomm-sources.md, A05), read to about +-0.005 m."""
    s = ref["s"]

    def at(t):
        return s[int(round(t / 0.01))]

    first = TIMES <= 1.0
    i_max = int(np.argmax(s[first]))
    print(f"METRIC A05 oracle vs the plot: first maximum s = {s[i_max]:.4f} m at t = {TIMES[i_max]:.2f} s "
          f"(plot 0.743 at ~0.5), s(1.0) = {at(1.0):.4f} (~0.50), s(3.0) = {at(3.0):.4f} (~0.513), "
          f"s(10) = {at(10.0):.4f} (~0.62, falling)")
    assert abs(s[i_max] - 0.743) < 0.005 and abs(TIMES[i_max] - 0.5) < 0.05
    assert abs(at(1.0) - 0.50) < 0.005
    assert abs(at(3.0) - 0.513) < 0.005
    assert abs(at(10.0) - 0.62) < 0.005 and s[-1] < s[-2]
    assert s.min() > 0.5 - 1e-3 and s.max() < 0.745 + 5e-3  # amplitude 0.50-0.745 throughout
