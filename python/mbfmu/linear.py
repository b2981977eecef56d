"""Runs that are linearisations: eigenvalues of A = ∂der(x)/∂x from the FMU's
fmi2GetDirectionalDerivative, at the start values of each point of a sweep.

    df = mbfmu.sweep(fmu, {"v": np.linspace(0, 10, 101)}, run=mbfmu.spectrum)

gives per run ``max_re`` (the stability margin: the run's point is asymptotically stable
iff max_re < 0) and the eigenvalues ``re0, im0, re1, im1, ...`` sorted by real part
(largest first).
"""

from __future__ import annotations

import numpy as np


def spectrum(inst, point) -> dict[str, float]:
    """Eigenvalues of the state matrix at this run's start values (a ``run=`` for sweep)."""
    inst.initialize()
    ev = np.linalg.eigvals(inst.state_matrix())
    ev = ev[np.lexsort((-ev.imag, -ev.real))]
    out = {"max_re": float(ev.real.max())}
    for i, e in enumerate(ev):
        out[f"re{i}"], out[f"im{i}"] = float(e.real), float(e.imag)
    return out
