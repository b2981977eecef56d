"""The worker side: one FMU, extracted once per process, and one instance reused across runs.

A sweep's runs are short (a MassSpringDamper run is ~0.15 ms of FMU time), so everything
that is not the run itself is paid once: the FMU is unpacked once per process (cached by
the SHA-256 of its bytes), the shared library is loaded once, and one instance per thread
goes through fmi2Reset between runs instead of fmi2FreeInstance/fmi2Instantiate.
"""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
import threading
import zipfile
from ctypes import byref
from typing import Mapping, Sequence

import cloudpickle
import numpy as np
from fmpy import calloc, free, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
)
from fmpy.logging import addLoggerProxy

STATUS = {2: "discard", 3: "error", 4: "fatal"}


# --- FMU log messages -------------------------------------------------------------------
# The FMUs log through the variadic fmi2CallbackLogger, which ctypes cannot read; fmpy's
# native proxy formats the message and calls ONE process-global Python function. We route
# it to _log, which keeps the lines of each instance until the run that caused them is
# recorded (a failed run's row carries the FMU's own explanation, e.g. "value -1 for k is
# outside [0, inf]").

_LOG_LOCK = threading.Lock()
_LOGS: dict[str, list[str]] = {}


def _log(env, instance_name, status, category, message):
    name = instance_name.decode("utf-8", "replace") if instance_name else ""
    text = message.decode("utf-8", "replace") if message else ""
    with _LOG_LOCK:
        _LOGS.setdefault(name, []).append(text)


_CALLBACKS = fmi2CallbackFunctions()
_LOGGER = fmi2CallbackLoggerTYPE(_log)  # kept alive for the life of the process
_CALLBACKS.logger = _LOGGER
_CALLBACKS.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
_CALLBACKS.freeMemory = fmi2CallbackFreeMemoryTYPE(free)


def _route_log() -> None:
    """Point fmpy's process-global proxy at _log. Done before each batch, not at import:
    other fmpy code in the process (fmpy.simulate_fmu, a test suite) points it elsewhere."""
    addLoggerProxy(byref(_CALLBACKS))


def _take_log(name: str) -> list[str]:
    with _LOG_LOCK:
        return _LOGS.pop(name, [])


# --- Extraction, once per process ---------------------------------------------------------

_DIRS: dict[str, tuple[str, object]] = {}
_DIRS_LOCK = threading.Lock()
_INSTANCES: dict[tuple[str, int], "Instance"] = {}


def unpacked(data: bytes, digest: str):
    """(directory, model description) of the FMU with these bytes, extracted on first use."""
    with _DIRS_LOCK:
        if digest not in _DIRS:
            tmp = tempfile.mkdtemp(prefix=f"mbfmu-{digest[:12]}-")
            atexit.register(shutil.rmtree, tmp, True)
            path = os.path.join(tmp, "model.fmu")
            with open(path, "wb") as f:
                f.write(data)
            unzip = os.path.join(tmp, "unzipped")
            with zipfile.ZipFile(path) as z:
                z.extractall(unzip)
            _DIRS[digest] = (unzip, read_model_description(path))
        return _DIRS[digest]


def instance_for(data: bytes, digest: str) -> "Instance":
    """This thread's instance of the FMU (created on first use, then reused)."""
    key = (digest, threading.get_ident())
    inst = _INSTANCES.get(key)
    if inst is None:
        unzip, md = unpacked(data, digest)
        inst = _INSTANCES[key] = Instance(unzip, md, f"mbfmu-{os.getpid()}-{key[1]}")
    return inst


# --- One instance -----------------------------------------------------------------------


class Instance:
    """An FMI 2.0 Co-Simulation instance, reused across runs by fmi2Reset.

    This is what a custom ``run(inst, point)`` of :func:`mbfmu.sweep` receives, already
    reset and with the start values of the run set (Instantiated state). It offers the
    few steps a run needs: :meth:`initialize`, :meth:`simulate`, :meth:`get`,
    :meth:`jacobian` and :meth:`state_matrix`.
    """

    def __init__(self, unzip_dir: str, md, name: str):
        self.md = md
        self.name = name
        self.variables = {v.name: v for v in md.modelVariables}
        self.vr = {n: v.valueReference for n, v in self.variables.items()}
        self.slave = FMU2Slave(guid=md.guid, unzipDirectory=unzip_dir,
                               modelIdentifier=md.coSimulation.modelIdentifier,
                               instanceName=name)
        self.slave.instantiate(callbacks=_CALLBACKS)
        self.fresh = True

    # lifecycle ----------------------------------------------------------------------------

    def prepare(self) -> None:
        """Back to the Instantiated state for the next run (fmi2Reset unless fresh)."""
        if not self.fresh:
            self.slave.reset()
        self.fresh = False
        _take_log(self.name)

    def renew(self) -> None:
        """A new instance after a failed run: after fmi2Error/fmi2Fatal the FMU's state is
        not to be trusted, so we do not reset it. The library stays loaded."""
        try:
            self.slave.fmi2FreeInstance(self.slave.component)
        finally:
            self.slave.instantiate(callbacks=_CALLBACKS)
            self.fresh = True

    def messages(self) -> list[str]:
        """The FMU's log lines since :meth:`prepare` (cleared by reading)."""
        return _take_log(self.name)

    # values -------------------------------------------------------------------------------

    def set(self, values: Mapping[str, float]) -> None:
        """Set start values by name, with the call of each variable's type."""
        reals, ints, bools = ([], []), ([], []), ([], [])
        for name, value in values.items():
            var = self.variables[name]
            if var.type == "Real":
                reals[0].append(var.valueReference), reals[1].append(float(value))
            elif var.type in ("Integer", "Enumeration"):
                ints[0].append(var.valueReference), ints[1].append(int(round(value)))
            elif var.type == "Boolean":
                bools[0].append(var.valueReference), bools[1].append(bool(value))
            else:
                raise TypeError(f"{name}: cannot set a {var.type} from a number")
        if reals[0]:
            self.slave.setReal(*reals)
        if ints[0]:
            self.slave.setInteger(*ints)
        if bools[0]:
            self.slave.setBoolean(*bools)

    def get(self, names: Sequence[str]) -> list[float]:
        """Real values by name."""
        return self.slave.getReal([self.vr[n] for n in names])

    # runs ---------------------------------------------------------------------------------

    def initialize(self, stop_time: float | None = None, tolerance: float | None = None,
                   start_time: float = 0.0) -> None:
        """fmi2SetupExperiment and fmi2EnterInitializationMode (the state in which the
        directional derivatives are read at the start values)."""
        if tolerance is None and self.md.defaultExperiment is not None:
            tol = self.md.defaultExperiment.tolerance
            tolerance = float(tol) if tol is not None else None
        self.slave.setupExperiment(tolerance=tolerance, startTime=start_time, stopTime=stop_time)
        self.slave.enterInitializationMode()

    def simulate(self, stop_time: float, outputs: Sequence[str], step: float | None = None,
                 tolerance: float | None = None) -> dict[str, float]:
        """Initialize, step to ``stop_time`` and return the final value of each output.

        ``step=None`` is one fmi2DoStep over the whole interval: only the final values are
        recorded, and the FMU's own solver chooses its steps inside it.
        """
        self.initialize(stop_time, tolerance)
        self.slave.exitInitializationMode()
        n = 1 if step is None else max(1, int(np.ceil(stop_time / step - 1e-9)))
        h = stop_time / n
        for i in range(n):
            self.slave.doStep(i * h, h)
        return dict(zip(outputs, self.get(outputs)))

    def jacobian(self, unknowns: Sequence[str], knowns: Sequence[str]) -> np.ndarray:
        """∂unknowns/∂knowns, one fmi2GetDirectionalDerivative per column."""
        uvr = [self.vr[n] for n in unknowns]
        kvr = [self.vr[n] for n in knowns]
        cols = [self.slave.getDirectionalDerivative(uvr, kvr, [float(i == j) for i in range(len(kvr))])
                for j in range(len(kvr))]
        return np.array(cols, dtype=float).T.reshape(len(uvr), len(kvr))

    def state_names(self) -> list[str]:
        """The continuous states, in the order of <Derivatives>."""
        return [d.variable.derivative.name for d in self.md.derivatives]

    def state_matrix(self) -> np.ndarray:
        """A = ∂der(x)/∂x at the current point (call :meth:`initialize` first)."""
        ders = [d.variable.name for d in self.md.derivatives]
        return self.jacobian(ders, self.state_names())


def run_batch(data: bytes, digest: str, spec: dict, start: int, values: np.ndarray):
    """Run the points ``values`` (one row per run, columns ``spec["names"]``) on this
    thread's instance; one task of a sweep. Points go in and results come out as arrays,
    which dask passes without walking them element by element.

    Every exception of a run is caught into its row, so a bad point never fails the task
    (and so never the sweep). Returns (start, results, statuses, {row: message}) where
    results is an (n, outputs) array for simulations, a list of dicts for a custom run.
    """
    _route_log()
    inst = instance_for(data, digest)
    run = None if spec["run"] is None else cloudpickle.loads(spec["run"])
    fixed, names = spec["fixed"], spec["names"]
    n = len(values)
    results = np.full((n, len(spec["outputs"])), np.nan) if run is None else [None] * n
    statuses, messages = ["ok"] * n, {}
    for i in range(n):
        point = dict(zip(names, values[i].tolist()))
        try:
            inst.prepare()
            inst.set({**fixed, **point})  # one fmi2SetReal; the point wins over --set
            if run is None:
                out = inst.simulate(spec["stop_time"], spec["outputs"], spec["step"],
                                    spec["tolerance"])
                results[i] = list(out.values())
            else:
                results[i] = dict(run(inst, point))
        except Exception as exc:  # the row records it; the next run gets a new instance
            status = STATUS.get(getattr(exc, "status", None), "error") \
                if isinstance(exc, FMICallException) else "error"
            log = inst.messages()
            statuses[i] = status
            messages[i] = f"{exc}" + (" FMU log: " + " | ".join(log) if log else "")
            try:
                inst.renew()
            except Exception:
                _INSTANCES.pop((digest, threading.get_ident()), None)
                inst = instance_for(data, digest)
    return start, results, statuses, messages
