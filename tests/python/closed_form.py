"""Exact reference solutions for the scenes (independent of the FMU code)."""

from __future__ import annotations

import numpy as np
import scipy.linalg


def _homogeneous(t, m, k, c, x0, v0):
    """Solution of m x'' + c x' + k x = 0, x(0)=x0, x'(0)=v0 (closed form per damping case)."""
    t = np.asarray(t, dtype=float)
    wn = np.sqrt(k / m)
    zeta = c / (2.0 * np.sqrt(k * m))
    if abs(zeta - 1.0) < 1e-12:  # critically damped
        C = v0 + wn * x0
        e = np.exp(-wn * t)
        x = e * (x0 + C * t)
        v = e * (C - wn * (x0 + C * t))
    elif zeta < 1.0:  # undamped (zeta = 0) or underdamped
        s = zeta * wn
        wd = wn * np.sqrt(1.0 - zeta * zeta)
        B = (v0 + s * x0) / wd
        e = np.exp(-s * t)
        cs, sn = np.cos(wd * t), np.sin(wd * t)
        x = e * (x0 * cs + B * sn)
        v = e * (v0 * cs + (-s * B - wd * x0) * sn)
    else:  # overdamped
        q = np.sqrt(zeta * zeta - 1.0)
        r1 = -wn * (zeta - q)
        r2 = -wn * (zeta + q)
        A = (v0 - r2 * x0) / (r1 - r2)
        B = x0 - A
        x = A * np.exp(r1 * t) + B * np.exp(r2 * t)
        v = A * r1 * np.exp(r1 * t) + B * r2 * np.exp(r2 * t)
    return x, v


def msd_exact(t, m, k, c, F_amp, F_omega, x, v, F, **_ignored):
    """m x'' + c x' + k x = F + F_amp sin(F_omega t): particular + homogeneous solution."""
    t = np.asarray(t, dtype=float)
    w = F_omega
    # particular solution x_p = F/k + a sin(wt) + b cos(wt):
    #   (k - m w^2) a - c w b = F_amp,   c w a + (k - m w^2) b = 0
    if F_amp != 0.0:
        M = np.array([[k - m * w * w, -c * w], [c * w, k - m * w * w]])
        a, b = np.linalg.solve(M, np.array([F_amp, 0.0]))
    else:
        a = b = 0.0
    xp = F / k + a * np.sin(w * t) + b * np.cos(w * t)
    vp = a * w * np.cos(w * t) - b * w * np.sin(w * t)
    xh, vh = _homogeneous(t, m, k, c, x - (F / k + b), v - a * w)
    return xp + xh, vp + vh


def tmc_matrices(m1, m2, k1, k2, c2, **_ignored):
    A = np.array(
        [
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
            [-(k1 + k2) / m1, k2 / m1, -c2 / m1, c2 / m1],
            [k2 / m2, -k2 / m2, c2 / m2, -c2 / m2],
        ]
    )
    B = np.array([0.0, 0.0, 1.0 / m1, 0.0])
    return A, B


def tmc_exact(t, m1, m2, k1, k2, c2, x1, x2, v1, v2, F, **_ignored):
    """x(t) = e^{At} x0 + A^{-1}(e^{At} - I) B F   (F constant).  Rows: (x1, x2, v1, v2)."""
    A, B = tmc_matrices(m1, m2, k1, k2, c2)
    x0 = np.array([x1, x2, v1, v2])
    Ainv_BF = np.linalg.solve(A, B * F)
    out = np.empty((len(t), 4))
    for i, ti in enumerate(np.asarray(t, dtype=float)):
        E = scipy.linalg.expm(A * ti)
        out[i] = E @ x0 + (E @ Ainv_BF - Ainv_BF)
    return out


def tmc_energy(m1, m2, k1, k2, x1, x2, v1, v2, **_ignored):
    return 0.5 * m1 * v1**2 + 0.5 * m2 * v2**2 + 0.5 * k1 * x1**2 + 0.5 * k2 * (x2 - x1) ** 2


# ---------------------------------------------------------------------------------------
# Loop closures: the four-bar's position analysis, Andrews' squeezer's reference
# ---------------------------------------------------------------------------------------

# The four-bar of src/systems/four_bar.rs (link lengths are compiled into the FMU, not
# parameters): crank a, coupler b, rocker c, ground d (m).
FOUR_BAR = dict(a=0.1, b=0.35, c=0.3, d=0.4)


def freudenstein_rocker(theta2, a, b, c, d):
    """θ4 from θ2 by Freudenstein's equation K1 cos θ4 − K2 cos θ2 + K3 = cos(θ2 − θ4)
    (K1 = d/a, K2 = d/c, K3 = (a² − b² + c² + d²)/(2ac)), solved in tan(θ4/2): the open
    configuration (B above the ground link while the crank is up)."""
    k1, k2 = d / a, d / c
    k3 = (a * a - b * b + c * c + d * d) / (2 * a * c)
    s, co = np.sin(theta2), np.cos(theta2)
    P = co - k1 - k2 * co + k3
    Q = -2 * s
    R = k1 - (k2 + 1) * co + k3
    return 2 * np.arctan((-Q - np.sqrt(Q * Q - 4 * P * R)) / (2 * P))


# The IVP test set's andrews problem (Hairer & Wanner, Solving ODEs II, VII.7): the
# reference positions at t = 0.03 s and the consistent multipliers at t = 0.
ANDREWS_COORDINATES = ["beta", "Theta", "gamma", "Phi", "delta", "Omega", "epsilon"]
ANDREWS_REFERENCE = [0.1581077119629904e2, -0.1575637105984298e2, 0.4082224013073101e-1,
                     -0.5347301163226948, 0.5244099658805304, 0.5347301163226948,
                     0.1048080741042263e1]
ANDREWS_LAMBDA0 = [98.5668703962410896057654982170, -6.12268834425566265503114393122,
                   0.0, 0.0, 0.0, 0.0]
