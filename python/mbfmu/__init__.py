"""Parameter sweeps and Monte Carlo studies of mbfmu FMUs on dask.distributed.

    import mbfmu, numpy as np
    df = mbfmu.sweep("MassSpringDamper.fmu", {"k": np.linspace(1, 100, 50)},
                     fixed={"c": 0.0}, stop_time=2.0, outputs=["x", "v"])

The command line is ``python -m mbfmu.sweep --help``; docs/sweeps.md has the rest.
(``mbfmu.sweep`` is this function; the command line's module is only run with ``-m``.)

``mbfmu.fmpy_input_derivatives_fix()`` makes fmpy 0.3.32's
``simulate_fmu(..., set_input_derivatives=True)`` work (README, "Co-simulation coupling").
"""

from .core import linspace, points, sweep
from .fmpy_fix import fmpy_input_derivatives_fix
from .instance import Instance
from .linear import spectrum

__all__ = ["sweep", "points", "linspace", "Instance", "spectrum", "fmpy_input_derivatives_fix"]
__version__ = "0.1.0"
