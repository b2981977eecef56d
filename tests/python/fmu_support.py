"""Helpers shared by the Python validation tests and their subprocess helper scripts.

Importable without pytest (the helper scripts run in fresh interpreters).

Logging: the FMUs call the variadic ``fmi2CallbackLogger`` with ``"%s"`` and the message
as the one extra argument, which a ctypes callback cannot read.  fmpy ships a small native
proxy (``fmpy.logging.addLoggerProxy``) that formats the message with ``vsnprintf`` and
then calls ONE process-global Python logger.  We therefore install one process-global
:class:`LogRecorder` and tell records apart by instance name (and by "records since mark").
"""

from __future__ import annotations

import atexit
import os
import shutil
import pathlib
import struct
import threading
from ctypes import byref, c_double, c_int, c_size_t, c_uint, c_void_p
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

import fmpy
from fmpy import calloc, extract, free, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2CallbackAllocateMemoryTYPE,
    fmi2CallbackFreeMemoryTYPE,
    fmi2CallbackFunctions,
    fmi2CallbackLoggerTYPE,
    fmi2CoSimulation,
    fmi2Discard,
    fmi2DoStepStatus,
    fmi2Error,
    fmi2Fatal,
    fmi2FMUstate,
    fmi2LastSuccessfulTime,
    fmi2ModelExchange,
    fmi2OK,
    fmi2PendingStatus,
    fmi2Terminated,
    fmi2Warning,
)
from fmpy.logging import addLoggerProxy

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parents[1]
MODELS = ("MassSpringDamper", "TwoMassChain")

# The contract these tests were written against: providesDirectionalDerivative = false and
# fmi2GetDirectionalDerivative -> fmi2Error.  test_directional_derivative.py checks the
# function against whatever the FMU declares; test_validate checks the declaration
# against this constant.
CONTRACT_PROVIDES_DIRECTIONAL_DERIVATIVE = True

STATUS_NAMES = {0: "OK", 1: "Warning", 2: "Discard", 3: "Error", 4: "Fatal", 5: "Pending"}

# ---------------------------------------------------------------------------------------
# Locating the FMUs
# ---------------------------------------------------------------------------------------


def fmu_dir() -> pathlib.Path:
    """``$MBFMU_FMU_DIR`` or ``<repo>/target/fmu``."""
    env = os.environ.get("MBFMU_FMU_DIR")
    return pathlib.Path(env) if env else REPO / "target" / "fmu"


def fmu_file(model: str) -> pathlib.Path:
    return fmu_dir() / f"{model}.fmu"


class MissingFMU(Exception):
    pass


# ---------------------------------------------------------------------------------------
# Logging
# ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class LogRecord:
    env: int | None
    instance: str
    status: int
    category: str
    message: str


def _dec(b) -> str:
    if b is None:
        return "<NULL>"
    return b.decode("utf-8", errors="replace")


class LogRecorder:
    """Process-global sink of every FMU log line (thread safe)."""

    def __init__(self):
        self._lock = threading.Lock()
        self.records: list[LogRecord] = []
        self.count = 0
        self.keep = True  # False: only count (leak test: no Python-side growth)

    def __call__(self, env, instance_name, status, category, message):
        with self._lock:
            self.count += 1
            if self.keep:
                self.records.append(
                    LogRecord(env, _dec(instance_name), int(status), _dec(category), _dec(message))
                )

    def mark(self) -> int:
        with self._lock:
            return len(self.records)

    def since(self, mark: int, instance: str | None = None) -> list[LogRecord]:
        with self._lock:
            recs = self.records[mark:]
        if instance is not None:
            recs = [r for r in recs if r.instance == instance]
        return recs


RECORDER = LogRecorder()
_LOGGER_THUNK = fmi2CallbackLoggerTYPE(RECORDER)  # must stay alive for the process


def _make_callbacks() -> fmi2CallbackFunctions:
    cb = fmi2CallbackFunctions()
    cb.logger = _LOGGER_THUNK
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    return cb


# One struct for every instance we create; kept alive for the whole process (an FMU may
# keep the pointer until fmi2FreeInstance).
CALLBACKS = _make_callbacks()
addLoggerProxy(byref(CALLBACKS))  # CALLBACKS.logger := native proxy; proxy -> RECORDER
_KEEP = [CALLBACKS]


_ENSURE_LOCK = threading.Lock()
AUTO_ENSURE_LOGGER = True  # Instance() re-routes the proxy first (off in the leak helper)


def ensure_logger() -> None:
    """(Re-)route fmpy's global native logger proxy to RECORDER.

    Something else (e.g. ``simulate_fmu(logger=...)``) may have re-pointed it."""
    with _ENSURE_LOCK:
        tmp = _make_callbacks()
        addLoggerProxy(byref(tmp))
        _KEEP.append(tmp)
        if len(_KEEP) > 64:
            del _KEEP[1:32]


# ---------------------------------------------------------------------------------------
# Model / instance wrappers
# ---------------------------------------------------------------------------------------

_MODEL_CACHE: dict[tuple[str, str], "Model"] = {}


class Model:
    """An FMU on disk, extracted once, with its model description."""

    def __init__(self, name: str, path: pathlib.Path | None = None):
        path = pathlib.Path(path) if path else fmu_file(name)
        if not path.is_file():
            raise MissingFMU(
                f"FMU {path} does not exist (build it with `cargo run --release --bin mbfmu -- "
                f"build --all` or point MBFMU_FMU_DIR at the directory holding {name}.fmu)"
            )
        self.name = name
        self.path = path
        self.md = read_model_description(str(path))
        self.unzipdir = extract(str(path))
        atexit.register(shutil.rmtree, self.unzipdir, True)
        self.guid = self.md.guid
        if self.md.coSimulation is None:
            raise AssertionError(f"{path} declares no CoSimulation interface")
        self.identifier = self.md.coSimulation.modelIdentifier
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.real_names = [v.name for v in self.md.modelVariables if v.type == "Real"]
        self.int_names = [
            v.name for v in self.md.modelVariables if v.type in ("Integer", "Enumeration")
        ]
        # states in ModelStructure/Derivatives order (fallback: strip "der(...)")
        self.state_names = [
            u.variable.derivative.name if u.variable.derivative is not None
            else u.variable.name[4:-1]
            for u in self.md.derivatives
        ]

    @classmethod
    def get(cls, name: str) -> "Model":
        key = (name, str(fmu_file(name)))
        if key not in _MODEL_CACHE:
            _MODEL_CACHE[key] = cls(name)
        return _MODEL_CACHE[key]

    def library(self, instance_name: str | None = None) -> FMU2Slave:
        """Load the shared library (dlopen; refcounted) without instantiating."""
        return FMU2Slave(
            guid=self.guid,
            modelIdentifier=self.identifier,
            unzipDirectory=self.unzipdir,
            instanceName=instance_name,
        )

    def resource_uri(self) -> bytes:
        return pathlib.Path(self.unzipdir, "resources").as_uri().encode()

    def instance(self, name: str | None = None, logging_on: bool = False, lib=None) -> "Instance":
        return Instance(self, name or f"{self.name}_inst", logging_on=logging_on, lib=lib)


class Instance:
    """One fmi2Component plus a tracked communication time."""

    def __init__(self, model: Model, name: str, logging_on: bool = False, lib: FMU2Slave | None = None,
                 kind: int = fmi2CoSimulation):
        if AUTO_ENSURE_LOGGER:
            ensure_logger()
        self.model = model
        self.name = name
        self.own_lib = lib is None
        self.lib = lib if lib is not None else model.library(name)
        self.fn = self.lib._functions  # raw ctypes function pointers (argtypes set by fmpy)
        comp = self.fn["fmi2Instantiate"](
            name.encode(),
            kind,
            model.guid.encode(),
            model.resource_uri(),
            byref(CALLBACKS),
            0,
            1 if logging_on else 0,
        )
        if not comp:
            raise RuntimeError(f"fmi2Instantiate returned NULL for {name}")
        self.c = c_void_p(comp)
        self.t = 0.0
        self.freed = False

    # -- raw calls returning the status ------------------------------------------------
    def call(self, fname: str, *args) -> int:
        return int(self.fn[fname](self.c, *args))

    def ok(self, fname: str, *args) -> None:
        st = self.call(fname, *args)
        if st not in (fmi2OK, fmi2Warning):
            raise FMICallException(function=fname, status=st)

    # -- life cycle ---------------------------------------------------------------------
    def setup(self, tol: float | None = None, start: float = 0.0, stop: float | None = None):
        self.ok(
            "fmi2SetupExperiment",
            1 if tol is not None else 0,
            tol if tol is not None else 0.0,
            start,
            1 if stop is not None else 0,
            stop if stop is not None else 0.0,
        )
        self.t = start

    def initialize(self, start_values: dict | None = None, tol: float | None = 1e-10,
                   start: float = 0.0, stop: float | None = None):
        self.setup(tol=tol, start=start, stop=stop)
        if start_values:
            self.set(**start_values)
        self.ok("fmi2EnterInitializationMode")
        self.ok("fmi2ExitInitializationMode")
        self.t = start
        return self

    def free(self):
        if not self.freed:
            self.fn["fmi2FreeInstance"](self.c)
            self.freed = True
            if self.own_lib:
                self.lib.freeLibrary()

    # -- values -------------------------------------------------------------------------
    def _is_int(self, name: str) -> bool:
        return self.model.vars[name].type in ("Integer", "Enumeration")

    def set(self, **values):
        for name, value in values.items():
            vr = (c_uint * 1)(self.model.vr[name])
            if self._is_int(name):
                self.ok("fmi2SetInteger", vr, 1, (c_int * 1)(int(value)))
            else:
                self.ok("fmi2SetReal", vr, 1, (c_double * 1)(float(value)))

    def get_reals(self, names: Sequence[str]) -> list[float]:
        vr = (c_uint * len(names))(*[self.model.vr[n] for n in names])
        out = (c_double * len(names))()
        self.ok("fmi2GetReal", vr, len(names), out)
        return list(out)

    def get_ints(self, names: Sequence[str]) -> list[int]:
        vr = (c_uint * len(names))(*[self.model.vr[n] for n in names])
        out = (c_int * len(names))()
        self.ok("fmi2GetInteger", vr, len(names), out)
        return list(out)

    def get(self, name: str):
        return self.get_ints([name])[0] if self._is_int(name) else self.get_reals([name])[0]

    def snapshot(self) -> tuple:
        """Every Real and Integer value, as bit patterns (so NaN/-0.0 compare exactly)."""
        reals = self.get_reals(self.model.real_names)
        ints = self.get_ints(self.model.int_names) if self.model.int_names else []
        return tuple(float_bits(r) for r in reals) + tuple(ints)

    # -- stepping -----------------------------------------------------------------------
    def do_step(self, h: float, t: float | None = None) -> int:
        """fmi2DoStep(t or self.t, h); on OK advances self.t to t + h. Returns status."""
        t0 = self.t if t is None else t
        st = self.call("fmi2DoStep", c_double(t0), c_double(h), 1)
        if st in (fmi2OK, fmi2Warning):
            self.t = t0 + h
        return st

    def step(self, h: float):
        st = self.do_step(h)
        if st not in (fmi2OK, fmi2Warning):
            raise FMICallException(function="fmi2DoStep", status=st)

    def real_status(self, kind=fmi2LastSuccessfulTime) -> tuple[int, float]:
        v = c_double(-12345.0)
        st = self.call("fmi2GetRealStatus", kind, byref(v))
        return st, v.value

    # -- FMU state ----------------------------------------------------------------------
    def get_state(self) -> c_void_p:
        s = fmi2FMUstate()
        self.ok("fmi2GetFMUstate", byref(s))
        return s

    def set_state(self, s) -> int:
        return self.call("fmi2SetFMUstate", s)

    def free_state(self, s):
        self.ok("fmi2FreeFMUstate", byref(s))

    def serialize(self, s) -> bytes:
        from ctypes import create_string_buffer

        size = c_size_t()
        self.ok("fmi2SerializedFMUstateSize", s, byref(size))
        buf = create_string_buffer(size.value)
        self.ok("fmi2SerializeFMUstate", s, buf, size)
        return buf.raw

    def deserialize(self, blob: bytes) -> tuple[int, c_void_p]:
        from ctypes import create_string_buffer

        s = fmi2FMUstate()
        buf = create_string_buffer(blob, len(blob)) if blob else create_string_buffer(1)
        st = self.call("fmi2DeSerializeFMUstate", buf, len(blob), byref(s))
        return st, s

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.free()


def float_bits(x: float) -> int:
    return struct.unpack("<Q", struct.pack("<d", x))[0]


# ---------------------------------------------------------------------------------------
# Scenes
# ---------------------------------------------------------------------------------------

MSD_DEFAULTS = dict(m=1.0, k=100.0, c=2.0, F_amp=0.0, F_omega=10.0, x=0.1, v=0.0, F=0.0)
MSD_SCENES = {
    "free": dict(c=0.0, x=0.1),
    "damped": dict(c=2.0, x=0.1),
    "critical": dict(c=20.0, x=0.1),
    "overdamped": dict(c=50.0, x=0.1),
    "step": dict(x=0.0, F=1.0),
    "resonance": dict(c=0.1, x=0.0, F_amp=1.0, F_omega=10.0),
}

TMC_DEFAULTS = dict(m1=1.0, m2=1.0, k1=100.0, k2=100.0, c2=2.0, x1=0.1, x2=0.0, v1=0.0, v2=0.0, F=0.0)
TMC_SCENES = {
    "release": dict(x1=0.1),
    "step": dict(x1=0.0, F=1.0),
    # x1 = x2 - k1 m2 x2 / (k2 (m1 + m2) + k1 m2): the fast mode starts unexcited
    "stiff": dict(k2=1e6, c2=10.0, x2=0.1, x1=0.1 - 10.0 / 2_000_100.0),
}

SOLVER_RK4 = 1
SOLVER_DOPRI5 = 2


def scene_values(model: str, scene: str) -> dict:
    """Full start-value set (defaults overlaid with the scene)."""
    if model == "MassSpringDamper":
        return {**MSD_DEFAULTS, **MSD_SCENES[scene]}
    return {**TMC_DEFAULTS, **TMC_SCENES[scene]}


def simulate(model: Model, start_values: dict, *, solver: int = SOLVER_DOPRI5,
             solver_step: float = 1e-3, tol: float = 1e-10, output_interval: float = 1e-2,
             stop_time: float = 10.0, outputs: Sequence[str] | None = None):
    """Run with fmpy.simulate_fmu (CS).  ``relative_tolerance`` is passed explicitly: for FMI
    2.0 CS fmpy hands it to fmi2SetupExperiment with toleranceDefined=true."""
    ensure_logger()
    sv = dict(start_values)
    sv["solver"] = int(solver)
    sv["solver_step"] = float(solver_step)
    if outputs is None:
        outputs = model.state_names + ["E"]
    return fmpy.simulate_fmu(
        model.unzipdir,
        model_description=model.md,
        fmi_type="CoSimulation",
        start_time=0.0,
        stop_time=stop_time,
        relative_tolerance=tol,
        output_interval=output_interval,
        start_values=sv,
        output=list(outputs),
        validate=True,
    )


def run_steps(model: Model, start_values: dict, steps: Iterable[float], *,
              solver: int = SOLVER_DOPRI5, solver_step: float = 1e-3, tol: float = 1e-10,
              names: Sequence[str] | None = None, instance_name: str | None = None):
    """Drive an FMU2Slave by hand with the given communication steps.

    Returns (times, values[len(times), len(names)]), time 0 included."""
    names = list(names or (model.state_names + ["E"]))
    inst = model.instance(instance_name or f"{model.name}_steps")
    try:
        sv = dict(start_values)
        sv["solver"] = solver
        sv["solver_step"] = solver_step
        inst.initialize(sv, tol=tol)
        times = [inst.t]
        rows = [inst.get_reals(names)]
        for h in steps:
            inst.step(h)
            times.append(inst.t)
            rows.append(inst.get_reals(names))
        return np.array(times), np.array(rows)
    finally:
        inst.free()
