"""Tests of the A04 Bricard oracle (bricard_oracle.py) itself, before anything is compared with it.

Besides the invariants (energy, loop residuals, rank 4 of 5, one DOF) two other routes check it:

* `NumpyChain`: the kinematics and Newton-Euler dynamics of a serial revolute chain written out in
  numpy (no Pinocchio). In the oracle's joint order it must give the same closure, G, gamma, M,
  h and energy at random states; with the loop cut at J1 instead of J6 (tree J6, J5, .., J2 from
  the other end, other coordinates, other mass matrix) its simulation must give the same P3.
* `period_quadrature`: the motion has one DOF, so energy alone fixes it: t(theta) =
  int dtheta / theta_dot with theta = q1 and (1/2) m_eff(theta) theta_dot^2 = E0 - V(theta),
  a quadrature that uses neither gamma, h nor the integrator.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import bricard_oracle as bo

TIMES = np.linspace(0.0, bo.T_END, 201)


@pytest.fixture(scope="module")
def ref():
    return bo.reference(TIMES)


def _skew(a):
    return np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


def _rot(axis, angle):  # Rodrigues, unit axis
    K = _skew(axis)
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K


class NumpyChain:
    """Serial chain over the joints `order` (indices into JOINT_POINTS), the remaining joint closing it.

    Body k runs from joint order[k] to the next joint of the loop; coordinate k is its rotation
    about that joint's axis relative to the previous body (right-handed, axis fixed in the parent).
    """

    nq = 5

    def __init__(self, order):
        self.p, self.a = bo.JOINT_POINTS[order], bo.JOINT_AXES[order]
        cut = (set(range(6)) - set(order)).pop()
        self.c, self.ca = bo.JOINT_POINTS[cut], bo.JOINT_AXES[cut]
        ends = np.vstack([self.p[1:], self.c])
        self.com0 = (self.p + ends) / 2
        self.I0 = [bo.rod_inertia(e - s) for s, e in zip(self.p, ends)]
        self.perp = [k for k in range(3) if self.ca[k] == 0]
        self.k3 = int(np.flatnonzero((self.p == bo.P3_0).all(axis=1))[0])  # body starting at P3

    def _kin(self, q, v):
        """Per body: R, origin o, world axis, omega, alpha, origin acceleration (all with q'' = 0)."""
        R, o, w, al, ao = np.eye(3), self.p[0].copy(), np.zeros(3), np.zeros(3), np.zeros(3)
        out = []
        for k in range(5):
            if k:
                r = R @ (self.p[k] - self.p[k - 1])  # joint k's point lies on body k-1 too
                o, ao = o + r, ao + np.cross(al, r) + np.cross(w, np.cross(w, r))
            ax = R @ self.a[k]
            al = al + np.cross(w, ax) * v[k]  # the axis turns with the parent
            w = w + ax * v[k]
            R = _rot(ax, q[k]) @ R
            out.append((R, o, ax, w, al, ao))
        return out

    def _point(self, kin, k, x0):
        """World position, Jacobian (3 x 5) and velocity-product acceleration of body k's point x0."""
        R, o, _, w, al, ao = kin[k]
        x = o + R @ (x0 - self.p[k])
        J = np.zeros((3, 5))
        for i in range(k + 1):
            J[:, i] = np.cross(kin[i][2], x - kin[i][1])
        d = x - o
        return x, J, ao + np.cross(al, d) + np.cross(w, np.cross(w, d))

    def _closure(self, q, v):
        kin = self._kin(q, v)
        xa, Ja, aa = self._point(kin, 4, self.c)
        xb, Jb, ab = self._point(kin, 4, self.c + self.ca)
        ph = np.concatenate([xa - self.c, (xb - self.c - self.ca)[self.perp]])
        return ph, np.vstack([Ja, Jb[self.perp]]), -np.concatenate([aa, ab[self.perp]])

    def closure(self, q):
        return self._closure(q, np.zeros(5))[0]

    def jacobian(self, q):
        return self._closure(q, np.zeros(5))[1]

    def gamma(self, q, v):
        return self._closure(q, v)[2]

    def _bodies(self, q, v):
        kin = self._kin(q, v)
        for k in range(5):
            R, _, _, w, al, _ = kin[k]
            x, Jv, a = self._point(kin, k, self.com0[k])
            Jw = np.zeros((3, 5))
            Jw[:, : k + 1] = np.array([kin[i][2] for i in range(k + 1)]).T
            yield x, Jv, a, Jw, w, al, R @ self.I0[k] @ R.T

    def mass(self, q):
        return sum(bo.MASS * Jv.T @ Jv + Jw.T @ I @ Jw for _, Jv, _, Jw, _, _, I in self._bodies(q, np.zeros(5)))

    def bias(self, q, v):
        g = np.array([0.0, -bo.GRAVITY, 0.0])
        return sum(
            Jv.T @ (bo.MASS * (a - g)) + Jw.T @ (I @ al + np.cross(w, I @ w))
            for _, Jv, a, Jw, w, al, I in self._bodies(q, v)
        )

    def energy(self, q, v):
        return sum(
            0.5 * bo.MASS * np.sum((Jv @ v) ** 2) + 0.5 * w @ I @ w + bo.MASS * bo.GRAVITY * x[1]
            for x, Jv, _, _, w, _, I in self._bodies(q, v)
        )

    def p3(self, q):
        return self._kin(q, np.zeros(5))[self.k3][1]


def period_quadrature(thetas, n=60):
    """t(theta) from 0 to each theta (q1 rising from rest) by energy, Gauss-Legendre in s.

    theta = pi (1 - cos s) / 2 makes the integrand smooth (theta_dot ~ sqrt(theta) at the rest
    points 0 and pi) and Gauss nodes avoid the 0/0 at the ends.
    """
    m = bo.PinocchioBricard()

    def on_curve(theta, guess):  # q with q1 = theta on the loop, and the tangent with dq1 = 1
        q = guess.copy()
        q[0] = theta
        for _ in range(30):
            ph = m.closure(q)
            if np.max(np.abs(ph)) < 1e-15:
                break
            q[1:] -= np.linalg.lstsq(m.jacobian(q)[:, 1:], ph, rcond=None)[0]
        N = bo._svd(m.jacobian(q))[3][:, 0]
        return q, N / N[0]

    # continuation table for Newton's starting guesses
    grid = np.linspace(0.0, np.pi, 65)
    table, q = [], np.zeros(5)
    for th in grid:
        q, _ = on_curve(th, q)
        table.append(q)
    table = np.array(table)

    def t_of(theta):
        smax = np.arccos(1.0 - 2.0 * theta / np.pi)
        x, w = np.polynomial.legendre.leggauss(n)
        s, w = smax * (x + 1) / 2, w * smax / 2
        total = 0.0
        for si, wi in zip(s, w):
            th = np.pi * (1 - np.cos(si)) / 2
            q, tq = on_curve(th, np.array([np.interp(th, grid, c) for c in table.T]))
            thdot = np.sqrt(2 * (bo.E_0 - m.energy(q, np.zeros(5))) / (tq @ m.mass(q) @ tq))
            total += wi * (np.pi / 2) * np.sin(si) / thdot
        return total

    return np.array([t_of(th) for th in thetas])


def test_initial_state(ref):
    assert np.array_equal(ref["P3"][0], [1.0, -1.0, 0.0])
    assert np.array_equal(ref["q"][0], np.zeros(5)) and ref["residual"][0] == 0.0
    assert abs(ref["E"][0] - bo.E_0) < 1e-14  # -3 m g: COM heights 0, -.5, -1, -1, -.5


def test_energy_and_loop_residual(ref):
    assert np.max(np.abs(ref["E"] - bo.E_0)) <= 1e-10 * abs(bo.E_0)
    assert np.max(ref["residual"]) <= 1e-12
    assert np.max(ref["drift"]) <= 1e-11  # the integrator alone stays on the loop: projection is a touch-up


def test_rank_four_of_five_one_dof(ref):
    """G is 5 x 5 with rank 4 at every output point (not just at q = 0), whichever joint is cut."""
    m = bo.PinocchioBricard()
    for q, v in zip(ref["q"][::20], ref["v"][::20]):
        S = np.linalg.svd(m.jacobian(q), compute_uv=False)
        assert S[3] > 0.1 and S[4] < 1e-13, S  # exactly one null direction: 1 DOF
        assert np.max(np.abs(m.jacobian(q) @ v)) < 1e-12  # the velocity lies along it
    S = np.linalg.svd(NumpyChain([5, 4, 3, 2, 1]).jacobian(np.zeros(5)), compute_uv=False)
    assert S[3] > 0.1 and S[4] < 1e-13, S


def test_starts_downward():
    """From rest the centre of mass accelerates down (and q1 up, rod 1's tip swinging to -z)."""
    m = bo.PinocchioBricard()
    z = np.zeros(5)
    qdd = bo.accel(m, z, z)
    pin.centerOfMass(m.model, m.data, z, z, qdd)
    assert m.data.acom[0][1] < -0.1
    assert qdd[0] > 1.0
    r = bo.reference([0.0, 0.05])
    assert m.energy(r["q"][1], np.zeros(5)) < bo.E_0 - 1e-3  # potential energy went down
    assert r["P3"][1][0] < 1.0 and r["P3"][1][2] < 0.0  # P3 leaves (1,-1,0) towards -x, -z


def test_published_shape(ref):
    """The curve read off the official plot (docs/iftomm-sources.md, A04), to +-0.05."""
    x, y, zz = ref["P3"].T
    assert abs(x.max() - 1) < 0.05 and abs(x.min() + 1) < 0.05
    assert abs(TIMES[np.argmin(x)] - 2.5) < 0.05  # x minimum at ~2.5 s ...
    w = (TIMES > 4.0) & (TIMES < 6.0)
    assert abs(TIMES[w][np.argmax(x[w])] - 5.0) < 0.05 and abs(x[w].max() - 1) < 0.05  # ... +1 near 5 s
    assert abs(x[-1] - 1) < 0.05
    assert abs(y.min() + 1) < 0.05 and abs(y.max() + 0.87) < 0.05
    assert abs(zz.max()) < 0.05 and abs(zz.min() + 0.5) < 0.05


def test_numpy_chain_matches_pinocchio():
    """Same tree written by hand: every ingredient of the dynamics agrees to rounding."""
    pm, nm = bo.PinocchioBricard(), NumpyChain([0, 1, 2, 3, 4])
    rng = np.random.default_rng(4)
    for _ in range(5):
        q, v = rng.uniform(-np.pi, np.pi, 5), rng.uniform(-2, 2, 5)
        for f, args in [("closure", (q,)), ("jacobian", (q,)), ("gamma", (q, v)), ("mass", (q,)),
                        ("bias", (q, v)), ("energy", (q, v)), ("p3", (q,))]:
            np.testing.assert_allclose(getattr(nm, f)(*args), getattr(pm, f)(*args), rtol=0, atol=1e-12, err_msg=f)


def test_loop_cut_at_joint_one_agrees():
    """Tree J6..J2 (numpy, cut at J1): other coordinates, same motion. P3 to 1e-8 over 10 s."""
    t = np.linspace(0.0, bo.T_END, 11)
    a = bo.reference(t)
    b = bo.reference(t, model=NumpyChain([5, 4, 3, 2, 1]))
    assert np.max(np.abs(a["P3"] - b["P3"])) < 1e-10  # 8e-13 seen
    assert np.max(np.abs(b["E"] - bo.E_0)) < 1e-10 * abs(bo.E_0)


def test_period_by_energy_quadrature():
    """q1 runs 0 -> pi in half a period (the mirror image of the cube, same potential energy)."""
    t_half, t_half_way = period_quadrature([np.pi, np.pi / 2])
    r = bo.reference([t_half_way, t_half, 2 * t_half])
    assert abs(r["q"][0][0] - np.pi / 2) < 1e-9
    assert np.max(np.abs(r["v"][1:])) < 1e-8  # at rest again at T/2 and T
    np.testing.assert_allclose(r["P3"][1], [-1.0, -1.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(r["P3"][2], [1.0, -1.0, 0.0], atol=1e-9)
    assert abs(2 * t_half - bo.PERIOD) < 1e-9
    assert abs(bo.PERIOD - 5.0) < 0.05  # the published "about 5 s"


def test_symmetric_motion(ref):
    """Observed structure, stated in bricard_oracle: q1 = q3 = q5 in [0, pi], q2 = q4 in [-pi/6, 0]."""
    q = ref["q"]
    assert np.max(np.abs(q[:, [2, 4]] - q[:, [0]])) < 1e-12 and np.max(np.abs(q[:, 3] - q[:, 1])) < 1e-12
    assert q[:, 0].min() > -1e-12 and q[:, 0].max() < np.pi + 1e-12
    assert abs(q[:, 1].min() + np.pi / 6) < 1e-3 and q[:, 1].max() < 1e-12
