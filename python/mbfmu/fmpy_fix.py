"""fmpy 0.3.32's ``simulate_fmu(..., set_input_derivatives=True)`` stops with
``ValueError: Can only assign sequence of same size``: ``Input.__init__`` makes each group's
input-derivative buffer 9 entries long (``(value_type * 9)()``) whatever the number of
inputs, and ``Input.apply`` assigns the group's derivatives to it. The fix gives each
buffer the size of its group, which is what fmpy means to do."""

from __future__ import annotations


def fmpy_input_derivatives_fix() -> bool:
    """Make ``fmpy.simulate_fmu(..., set_input_derivatives=True)`` work with fmpy 0.3.32
    for any number of continuous inputs: patches ``fmpy.simulation.Input`` in this process
    (what ``simulate_fmu`` uses). Harmless where fmpy sizes the buffer right already;
    calling it again does nothing. Returns whether it patched (False: done before)."""
    import fmpy.simulation as sim

    original = sim.Input.__init__
    if getattr(original, "_mbfmu_fix", False):
        return False

    def __init__(self, *args, **kwargs):
        original(self, *args, **kwargs)
        self.continuous = [
            info._replace(derivatives=(type(info.values)._type_ * len(info.vrs))())
            for info in self.continuous
        ]

    __init__._mbfmu_fix = True
    __init__.__doc__ = original.__doc__
    sim.Input.__init__ = __init__
    return True
