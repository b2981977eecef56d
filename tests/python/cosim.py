"""The split two-mass oscillator (issue 16), co-simulated through fmpy's low-level API.

Two MassSpringDamper FMUs: A (m1 = 1 kg, k1 = 100 N/m to the wall, x1(0) = 0.1 m) and B
(m2 = 1 kg, free). The master computes the coupling spring-damper's force
F = k2 (x2 − x1) + c2 (v2 − v1) (k2 = 100 N/m, c2 = 2 N·s/m) from their outputs at every
communication point and gives +F to A, −F to B. Reference: the monolithic TwoMassChain's
closed form (closed_form.tmc_exact).

Coupling schemes, per communication step [t_n, t_n + H]:
- ``order = 0`` (zero-order hold): the force at t_n is held over the step.
- ``order = 1``: the force's slope at t_n, from the FMUs' exact output derivatives (ẋ, v̇),
  is given with fmi2SetRealInputDerivatives: the FMUs integrate with F(t_n) + Ḟ (t − t_n).
- ``order = 2`` (Jacobi only): also F̈ from the second output derivatives (v̈ uses the
  slope just set).

Jacobi: both FMUs step from the values at t_n. Gauss–Seidel: A steps first; B's force then
takes A's part from A's values at both ends of the step (linear interpolation: its value and
slope at t_n from the secant; held at t_n + H for ``order = 0``), its own part extrapolated
as in Jacobi.
"""

from __future__ import annotations

import math

import numpy as np

import closed_form
import fmu_support as fs

K1, K2, C2, M1, M2, X0 = 100.0, 100.0, 2.0, 1.0, 1.0, 0.1
T_END = 2.0


def reference(t: float = T_END) -> np.ndarray:
    """(x1, x2, v1, v2) of the monolithic chain at t."""
    return closed_form.tmc_exact(
        [t], m1=M1, m2=M2, k1=K1, k2=K2, c2=C2, x1=X0, x2=0.0, v1=0.0, v2=0.0, F=0.0
    )[0]


class _Slave:
    """One MassSpringDamper instance: x, v out, F in (with derivatives)."""

    def __init__(self, model: fs.Model, name: str, k: float, x0: float, tol: float,
                 stop: float):
        self.inst = model.instance(name)
        vr = model.vr
        self.xv = [vr["x"], vr["v"]]
        self.f = vr["F"]
        # DOPRI5 at a tight tolerance: the FMUs' own integration error stays far below the
        # coupling error studied here.
        self.inst.initialize(
            {"m": 1.0, "k": k, "c": 0.0, "F_amp": 0.0, "x": x0, "v": 0.0,
             "solver": fs.SOLVER_DOPRI5},
            tol=tol,
            stop=stop,
        )
        # fmpy's wrappers of the two derivative functions take the component from here.
        self.inst.lib.component = self.inst.c

    def y(self) -> np.ndarray:
        return np.array(self.inst.get_reals(["x", "v"]))

    def set_force(self, f: float) -> None:
        self.inst.set(F=f)

    def dy(self, order: int) -> np.ndarray:
        """(x, v) derivatives of this order, exact (fmi2GetRealOutputDerivatives)."""
        return np.array(self.inst.lib.getRealOutputDerivatives(self.xv, [order, order]))

    def set_force_derivatives(self, derivatives: list[float]) -> None:
        n = len(derivatives)
        self.inst.lib.setRealInputDerivatives([self.f] * n, list(range(1, n + 1)), derivatives)

    def step(self, h: float) -> None:
        self.inst.step(h)

    def free(self) -> None:
        self.inst.free()


def _force(ya: np.ndarray, yb: np.ndarray) -> float:
    return K2 * (yb[0] - ya[0]) + C2 * (yb[1] - ya[1])


def _taylor(a: _Slave, b: _Slave, order: int) -> list[float]:
    """F's derivatives at t_n up to ``order`` from the slaves' output derivatives, setting
    each one before reading the next order (v̈ depends on Ḟ)."""
    out = []
    for k in range(1, order + 1):
        da, db = a.dy(k), b.dy(k)
        out.append(_force(da, db))
        a.set_force_derivatives(out)
        b.set_force_derivatives([-d for d in out])
    return out


def run(model: fs.Model, h: float, order: int, scheme: str = "jacobi",
        tol: float = 1e-12, t_end: float = T_END) -> float:
    """Global error at t_end: max over x1, x2 of |co-simulation − monolithic| (m)."""
    a = _Slave(model, f"cosimA_{scheme}_{order}", K1, X0, tol, t_end)
    b = _Slave(model, f"cosimB_{scheme}_{order}", 0.0, 0.0, tol, t_end)
    try:
        n = int(round(t_end / h))
        assert math.isclose(n * h, t_end), (h, t_end)
        for _ in range(n):
            ya, yb = a.y(), b.y()
            f = _force(ya, yb)
            a.set_force(f)
            b.set_force(-f)
            if scheme == "jacobi":
                _taylor(a, b, order)
                a.step(h)
                b.step(h)
                continue
            # Gauss–Seidel (orders 0 and 1): A first, with the Jacobi force (B is still at
            # t_n).
            assert order <= 1, "Gauss–Seidel is studied with orders 0 and 1"
            _taylor(a, b, order)
            a.step(h)
            ya1 = a.y()
            if order == 0:
                b.set_force(-_force(ya1, yb))
                b.step(h)
                continue
            # B: A's part interpolated over the step (secant), B's own part extrapolated
            # from its exact derivatives at t_n (the ones _taylor read).
            db = [b.dy(k) for k in range(1, order + 1)]
            slope_a = (ya1 - ya) / h
            fb = [-(K2 * (db[0][0] - slope_a[0]) + C2 * (db[0][1] - slope_a[1]))]
            b.set_force_derivatives(fb)
            b.step(h)
        ref = reference(t_end)
        return float(max(abs(a.y()[0] - ref[0]), abs(b.y()[0] - ref[1])))
    finally:
        a.free()
        b.free()


def observed_order(hs, errors) -> float:
    """Least-squares slope of log(error) against log(H)."""
    return float(np.polyfit(np.log(hs), np.log(errors), 1)[0])
