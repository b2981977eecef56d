"""The right-hand side of a scene, taken from the built FMU through the FMI 2.0 C API.

The peers of `mbfmu bench` (benches/peers.py: scipy; benches/cvode_bench.c: CVODE) do not
re-type any equation: they load target/fmu/<Model>.fmu's shared library and evaluate

    f(x) = der(x)          fmi2SetReal(states, x); fmi2GetReal(der(states))
    J(x) e_j               fmi2GetDirectionalDerivative(der(states), [state_j], [1.0])

on an instance left in Initialization Mode (instantiate, fmi2SetupExperiment,
fmi2EnterInitializationMode, fmi2SetReal of the scene's parameters and inputs): the mode in
which the standard lets an importer set the states of a co-simulation FMU. Value references
come from the FMU's modelDescription.xml (states in ModelStructure/Derivatives order).

The initial state is the one the FMU itself integrates from: a second instance goes through
fmi2ExitInitializationMode (which projects the start values onto the constraints, for the
systems that have any) and its states are read back.

Only the standard library and numpy; ctypes calls the C functions directly.
"""

from __future__ import annotations

import ctypes
import math
import os
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from ctypes import (CFUNCTYPE, POINTER, Structure, c_char_p, c_double, c_int, c_size_t,
                    c_uint, c_void_p)

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# FMI 2.0 types
fmi2Component = c_void_p
LOGGER = CFUNCTYPE(None, c_void_p, c_char_p, c_int, c_char_p, c_char_p)  # variadic tail unread
ALLOC = CFUNCTYPE(c_void_p, c_size_t, c_size_t)
FREE = CFUNCTYPE(None, c_void_p)
STEP_FINISHED = CFUNCTYPE(None, c_void_p, c_int)
CO_SIMULATION = 1


class Callbacks(Structure):
    _fields_ = [("logger", LOGGER), ("allocateMemory", ALLOC), ("freeMemory", FREE),
                ("stepFinished", STEP_FINISHED), ("componentEnvironment", c_void_p)]


_LOG = []


def _logger(env, instance, status, category, message):
    # The message is the first variadic argument ("%s", text): not readable from a ctypes
    # callback; the category and status are kept for diagnostics.
    _LOG.append((instance, status, category))


_libc = ctypes.CDLL(None)
_libc.calloc.restype = c_void_p
_libc.calloc.argtypes = [c_size_t, c_size_t]
_libc.free.argtypes = [c_void_p]
_KEEP = [LOGGER(_logger), ALLOC(lambda n, s: _libc.calloc(n, s)), FREE(lambda p: _libc.free(p))]
CALLBACKS = Callbacks(_KEEP[0], _KEEP[1], _KEEP[2], STEP_FINISHED(), None)


class FmiError(RuntimeError):
    pass


def fmu_path(model: str) -> str:
    d = os.environ.get("MBFMU_FMU_DIR") or os.path.join(ROOT, "target", "fmu")
    return os.path.join(d, f"{model}.fmu")


class Fmu:
    """One FMU on disk: unzipped once, its model description parsed, its library loaded."""

    _cache: dict[str, "Fmu"] = {}

    @classmethod
    def get(cls, model: str) -> "Fmu":
        if model not in cls._cache:
            cls._cache[model] = cls(fmu_path(model))
        return cls._cache[model]

    def __init__(self, path: str):
        if not os.path.isfile(path):
            raise FileNotFoundError(
                f"{path} is missing: build the FMUs with `cargo run --release --bin mbfmu -- build --all`")
        self.dir = tempfile.mkdtemp(prefix="mbfmu_peer_")
        with zipfile.ZipFile(path) as z:
            z.extractall(self.dir)
        root = ET.parse(os.path.join(self.dir, "modelDescription.xml")).getroot()
        self.guid = root.get("guid")
        self.name = root.find("CoSimulation").get("modelIdentifier")
        self.so = os.path.join(self.dir, "binaries", "linux64", self.name + ".so")
        svs = root.find("ModelVariables").findall("ScalarVariable")
        self.vars = {}  # name -> dict(vr, causality, nominal, derivative_of (1-based index))
        for sv in svs:
            real = sv.find("Real")
            info = dict(vr=int(sv.get("valueReference")), causality=sv.get("causality"),
                        real=real is not None)
            if real is not None:
                info["nominal"] = float(real.get("nominal", "1"))
                info["derivative"] = int(real.get("derivative")) if real.get("derivative") else None
            self.vars[sv.get("name")] = info
        by_index = [sv.get("name") for sv in svs]
        self.ders = [by_index[int(u.get("index")) - 1]
                     for u in root.find("ModelStructure").find("Derivatives").findall("Unknown")]
        self.states = [by_index[self.vars[d]["derivative"] - 1] for d in self.ders]
        self.state_vr = [self.vars[s]["vr"] for s in self.states]
        self.der_vr = [self.vars[d]["vr"] for d in self.ders]
        self.nominal = np.array([self.vars[s]["nominal"] for s in self.states])
        self.lib = ctypes.CDLL(self.so)
        L = self.lib
        L.fmi2Instantiate.restype = fmi2Component
        L.fmi2Instantiate.argtypes = [c_char_p, c_int, c_char_p, c_char_p, POINTER(Callbacks),
                                      c_int, c_int]
        L.fmi2FreeInstance.argtypes = [fmi2Component]
        L.fmi2SetupExperiment.argtypes = [fmi2Component, c_int, c_double, c_double, c_int, c_double]
        for f in ("fmi2EnterInitializationMode", "fmi2ExitInitializationMode"):
            getattr(L, f).argtypes = [fmi2Component]
        for f in ("fmi2SetReal", "fmi2GetReal"):
            getattr(L, f).argtypes = [fmi2Component, POINTER(c_uint), c_size_t, POINTER(c_double)]
        L.fmi2GetDirectionalDerivative.argtypes = [
            fmi2Component, POINTER(c_uint), c_size_t, POINTER(c_uint), c_size_t,
            POINTER(c_double), POINTER(c_double)]

    def vr(self, name: str) -> int:
        return self.vars[name]["vr"]


def _check(status, what):
    if status not in (0, 1):  # fmi2OK, fmi2Warning
        raise FmiError(f"{what} returned status {status}")


class SceneRhs:
    """f(x) and J(x) of one scene of one FMU, through the FMI C API.

    `start_values`: the scene's start values by name (parameters, inputs, states), as
    `mbfmu list --json` gives them. `forcing`: optional (input, amplitude, omega): the input is
    set to amplitude * sin(omega * t) before each evaluation (for a scene whose forcing the
    FMU computes from its own time, which a co-simulation importer cannot set; see peers.py).
    """

    def __init__(self, model: str, start_values: dict, forcing=None, stop_time=None):
        self.fmu = F = Fmu.get(model)
        self.n = len(F.states)
        self.start_values = dict(start_values)
        self.forcing = forcing
        L = F.lib
        self.c = self._instance("rhs", stop_time)
        self.x0 = self._projected_start(stop_time)
        n = self.n
        self._svr = (c_uint * n)(*F.state_vr)
        self._dvr = (c_uint * n)(*F.der_vr)
        self._x = (c_double * n)()
        self._dx = (c_double * n)()
        self._xv = np.ctypeslib.as_array(self._x)
        self._dxv = np.ctypeslib.as_array(self._dx)
        self._one = (c_double * 1)(1.0)
        self._col = (c_double * n)()
        self._colv = np.ctypeslib.as_array(self._col)
        self._known = [(c_uint * 1)(vr) for vr in F.state_vr]
        self._set, self._get, self._dd = L.fmi2SetReal, L.fmi2GetReal, L.fmi2GetDirectionalDerivative
        if forcing:
            self._fvr = (c_uint * 1)(F.vr(forcing[0]))
            self._fval = (c_double * 1)()
        self.nfev = 0
        self.njev = 0
        self._evr = (c_uint * 1)(F.vr("E")) if "E" in F.vars else None
        self._e = (c_double * 1)()

    def _instance(self, name, stop_time):
        F = self.fmu
        L = F.lib
        c = L.fmi2Instantiate(name.encode(), CO_SIMULATION, F.guid.encode(),
                              ("file://" + os.path.join(F.dir, "resources")).encode(),
                              ctypes.byref(CALLBACKS), 0, 0)
        if not c:
            raise FmiError(f"fmi2Instantiate({F.name}) returned NULL")
        c = c_void_p(c)
        _check(L.fmi2SetupExperiment(c, 0, 0.0, 0.0, 1 if stop_time else 0, stop_time or 0.0),
               "fmi2SetupExperiment")
        _check(L.fmi2EnterInitializationMode(c), "fmi2EnterInitializationMode")
        for k, v in self.start_values.items():
            if not F.vars[k]["real"]:
                continue
            vr = (c_uint * 1)(F.vr(k))
            _check(L.fmi2SetReal(c, vr, 1, (c_double * 1)(float(v))), f"fmi2SetReal({k})")
        return c

    def _projected_start(self, stop_time):
        """The states after fmi2ExitInitializationMode (projected onto the constraints)."""
        F = self.fmu
        c = self._instance("start", stop_time)
        try:
            _check(F.lib.fmi2ExitInitializationMode(c), "fmi2ExitInitializationMode")
            vr = (c_uint * self.n)(*F.state_vr)
            out = (c_double * self.n)()
            _check(F.lib.fmi2GetReal(c, vr, self.n, out), "fmi2GetReal(states)")
            return np.array(list(out))
        finally:
            F.lib.fmi2FreeInstance(c)

    def __call__(self, t, x):
        """der(x) at (t, x): a new numpy array."""
        self.nfev += 1
        if self.forcing:
            self._fval[0] = self.forcing[1] * math.sin(self.forcing[2] * t)
            _check(self._set(self.c, self._fvr, 1, self._fval), "fmi2SetReal(input)")
        self._xv[:] = x
        if self._set(self.c, self._svr, self.n, self._x) > 1:
            raise FmiError("fmi2SetReal(states) failed (a state outside its [min, max]?)")
        if self._get(self.c, self._dvr, self.n, self._dx) > 1:
            raise FmiError("fmi2GetReal(der) failed")
        return self._dxv.copy()

    def jac(self, t, x):
        """The exact Jacobian ∂der(x)/∂x: one fmi2GetDirectionalDerivative per column."""
        self.njev += 1
        self._xv[:] = x
        _check(self._set(self.c, self._svr, self.n, self._x), "fmi2SetReal(states)")
        J = np.empty((self.n, self.n))
        for j in range(self.n):
            _check(self._dd(self.c, self._dvr, self.n, self._known[j], 1, self._one, self._col),
                   "fmi2GetDirectionalDerivative")
            J[:, j] = self._colv
        return J

    def energy(self, x):
        """The output E at state x (NaN if the model has none)."""
        if self._evr is None:
            return float("nan")
        self._xv[:] = x
        _check(self._set(self.c, self._svr, self.n, self._x), "fmi2SetReal(states)")
        _check(self._get(self.c, self._evr, 1, self._e), "fmi2GetReal(E)")
        return self._e[0]

    def close(self):
        if self.c is not None:
            self.fmu.lib.fmi2FreeInstance(self.c)
            self.c = None
