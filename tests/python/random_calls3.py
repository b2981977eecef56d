"""Random call sequences through the FMI 3.0 C API of one FMU (the FMI 3.0 twin in
``<MBFMU_FMU_DIR>3``), on Co-Simulation instances (with and without eventModeUsed, early
return and an intermediateUpdate callback) and Model Exchange instances: the FMI 3.0
counterpart of random_calls.py, with its oracles

  O1 crash   the batch runs in a subprocess (a signal or a hang is reported with the seed);
  O2 inputs  a call with an invalid argument (wrong state, unknown value reference or one
             of another type, NULL with n > 0, a non-finite value, a parameter or the time
             set after initialisation, a bad step, a mutated FMU state blob, wrong counts,
             a function of the other interface, clocks, an unknown instantiation token)
             returns fmi3Error (NULL from instantiation); a valid call does not fail
             (doStep may discard; reads in Initialization Mode may refuse values that do
             not fit together yet);
  O3 finite  values returned with fmi3OK / fmi3Warning are finite;
  O4 status  a call returning fmi3Error logged a line with that status, one returning
             fmi3OK logged no warning or error.

Run as ``python random_calls3.py MODEL FIRST_SEED COUNT CALLS``: prints one JSON line.
"""

from __future__ import annotations

import ctypes
import faulthandler
import json
import math
import os
import pathlib
import random
import sys
import time
import xml.etree.ElementTree as ET
import zipfile
from ctypes import (CFUNCTYPE, POINTER, byref, c_bool, c_char_p, c_double, c_int, c_int32,
                    c_int64, c_size_t, c_uint8, c_uint32, c_void_p)

from fmpy import extract

LOG = CFUNCTYPE(None, c_void_p, c_int, c_char_p, c_char_p)
UPDATE = CFUNCTYPE(None, c_void_p, c_double, c_bool, c_bool, c_bool, c_bool, POINTER(c_bool),
                   POINTER(c_double))

LINES: list[tuple[int, str]] = []


@LOG
def _log(env, status, category, message):
    LINES.append((status, message.decode(errors="replace")))


UPDATES = [0]


@UPDATE
def _update(env, t, set_req, get_allowed, finished, can_return, requested, early_time):
    UPDATES[0] += 1
    requested[0] = bool(env) and (UPDATES[0] % 2 == 0)


class Failure(Exception):
    def __init__(self, oracle, message):
        super().__init__(f"{oracle}: {message}")
        self.oracle = oracle


class Spec:
    """What the FMI 3.0 model description declares."""

    def __init__(self, fmu: pathlib.Path):
        with zipfile.ZipFile(fmu) as z:
            root = ET.fromstring(z.read("modelDescription.xml"))
        self.token = root.get("instantiationToken").encode()
        self.identifier = root.find("CoSimulation").get("modelIdentifier")
        self.floats, self.ints, self.enums = {}, {}, {}
        for v in root.find("ModelVariables"):
            entry = dict(v.attrib)
            vr = int(entry["valueReference"])
            {"Float64": self.floats, "Int32": self.ints, "Enumeration": self.enums}[v.tag][vr] = entry
        self.time = next(vr for vr, v in self.floats.items() if v["causality"] == "independent")
        ms = root.find("ModelStructure")
        self.derivatives = [int(e.get("valueReference")) for e in ms.findall("ContinuousStateDerivative")]
        self.states = [int(self.floats[d]["derivative"]) for d in self.derivatives]
        self.outputs = [int(e.get("valueReference")) for e in ms.findall("Output")]
        self.nz = len(ms.findall("EventIndicator"))
        self.step = float(root.find("DefaultExperiment").get("stepSize"))
        self.inputs = [vr for vr, v in self.floats.items() if v["causality"] == "input"]
        self.params = [vr for vr, v in self.floats.items() if v["causality"] == "parameter"
                       and v["name"] not in ("solver_step",)]
        self.all = list(self.floats) + list(self.ints) + list(self.enums)
        self.bad = max(self.all) + 1 + 7


def load(spec: Spec, fmu: pathlib.Path):
    d = pathlib.Path(extract(str(fmu)))
    # This machine's binary (the FMU carries Windows and aarch64 ones too).
    so = d / "binaries" / "x86_64-linux" / f"{spec.identifier}.so"
    lib = ctypes.CDLL(str(so))
    P = c_void_p
    sig = {
        "fmi3InstantiateCoSimulation": (P, [c_char_p, c_char_p, c_char_p, c_bool, c_bool, c_bool,
                                            c_bool, P, c_size_t, P, LOG, UPDATE]),
        "fmi3InstantiateModelExchange": (P, [c_char_p, c_char_p, c_char_p, c_bool, c_bool, P, LOG]),
        "fmi3FreeInstance": (None, [P]),
        "fmi3EnterInitializationMode": (c_int, [P, c_bool, c_double, c_double, c_bool, c_double]),
        "fmi3DoStep": (c_int, [P, c_double, c_double, c_bool, P, P, P, P]),
        "fmi3GetFloat64": (c_int, [P, P, c_size_t, P, c_size_t]),
        "fmi3SetFloat64": (c_int, [P, P, c_size_t, P, c_size_t]),
        "fmi3GetInt32": (c_int, [P, P, c_size_t, P, c_size_t]),
        "fmi3GetInt64": (c_int, [P, P, c_size_t, P, c_size_t]),
        "fmi3SetInt64": (c_int, [P, P, c_size_t, P, c_size_t]),
        "fmi3GetBoolean": (c_int, [P, P, c_size_t, P, c_size_t]),
        "fmi3GetClock": (c_int, [P, P, c_size_t, P]),
        "fmi3SetTime": (c_int, [P, c_double]),
        "fmi3SetContinuousStates": (c_int, [P, P, c_size_t]),
        "fmi3GetContinuousStates": (c_int, [P, P, c_size_t]),
        "fmi3GetContinuousStateDerivatives": (c_int, [P, P, c_size_t]),
        "fmi3GetEventIndicators": (c_int, [P, P, c_size_t]),
        "fmi3CompletedIntegratorStep": (c_int, [P, c_bool, P, P]),
        "fmi3UpdateDiscreteStates": (c_int, [P, P, P, P, P, P, P]),
        "fmi3GetFMUState": (c_int, [P, P]),
        "fmi3SetFMUState": (c_int, [P, P]),
        "fmi3FreeFMUState": (c_int, [P, P]),
        "fmi3SerializedFMUStateSize": (c_int, [P, P, P]),
        "fmi3SerializeFMUState": (c_int, [P, P, P, c_size_t]),
        "fmi3DeserializeFMUState": (c_int, [P, P, c_size_t, P]),
        "fmi3GetDirectionalDerivative": (c_int, [P, P, c_size_t, P, c_size_t, P, c_size_t, P, c_size_t]),
        "fmi3GetAdjointDerivative": (c_int, [P, P, c_size_t, P, c_size_t, P, c_size_t, P, c_size_t]),
    }
    for name in ("fmi3ExitInitializationMode", "fmi3EnterEventMode", "fmi3Terminate", "fmi3Reset",
                 "fmi3EnterContinuousTimeMode", "fmi3EnterStepMode", "fmi3EnterConfigurationMode"):
        sig[name] = (c_int, [P])
    for name, (res, args) in sig.items():
        f = getattr(lib, name)
        f.restype, f.argtypes = res, args
    return lib


def arr(ctype, values):
    return (ctype * max(1, len(values)))(*values)


OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3
# Seconds of sequences per FMU, after at least MIN_SEQUENCES of them.
BUDGET = float(os.environ.get("MBFMU_RANDOM_BUDGET3", "20"))
MIN_SEQUENCES = 10


class Sequence:
    def __init__(self, spec: Spec, lib, seed: int, n_calls: int):
        self.spec, self.lib, self.rng, self.n = spec, lib, random.Random(seed), n_calls
        self.seed = seed
        self.c = None
        self.states_made = []  # our FMU state pointers (c_void_p)
        self.blobs = []
        self.calls = 0

    # -- the call and its oracles --
    def call(self, fname, *args, expect, label=""):
        """`expect`: the set of statuses that would be right."""
        mark = len(LINES)
        st = getattr(self.lib, fname)(*args)
        self.calls += 1
        lines = LINES[mark:]
        what = f"{fname}{label} in {self.state} ({self.iface})"
        if st not in expect:
            raise Failure("O2", f"{what} returned {st}, expected {sorted(expect)}; log {lines}")
        worst = max((s for s, _ in lines), default=0)
        if st == ERROR and self.c is not None and not any(s == ERROR for s, _ in lines):
            raise Failure("O4", f"{what} returned fmi3Error without an error line")
        if st == OK and worst >= WARNING:
            raise Failure("O4", f"{what} returned fmi3OK after logging {lines}")
        return st

    def finite(self, values, what):
        if not all(math.isfinite(v) for v in values):
            raise Failure("O3", f"{what}: non-finite values {list(values)} with status OK")

    # -- the sequence --
    def run(self):
        try:
            for _ in range(self.n):
                if self.c is None:
                    self.instantiate()
                    continue
                # Half the calls move the instance on (valid in its state), so that every
                # state is reached; the rest are any call, valid or not.
                progress = self.PROGRESS.get(self.state) if self.rng.random() < 0.5 else None
                if progress is not None:
                    progress(self)
                    continue
                action = self.rng.choices(self.ACTIONS, weights=[w for w, _ in self.WEIGHTS])[0]
                action(self)
        finally:
            self.free()
        return self.calls

    def free(self):
        if self.c is not None:
            self.lib.fmi3FreeInstance(self.c)
            self.calls += 1
        self.c = None
        self.states_made = []

    def instantiate(self):
        r = self.rng
        if r.random() < 0.05:
            mark = len(LINES)
            c = self.lib.fmi3InstantiateModelExchange(b"x", b"{wrong}", None, False, False, None, _log)
            self.calls += 1
            if c:
                raise Failure("O2", "a wrong instantiationToken was accepted")
            if len(LINES) == mark:
                raise Failure("O4", "a refused instantiation logged nothing")
            return
        self.iface = "ME" if r.random() < 0.4 else "CS"
        if self.iface == "ME":
            self.c = self.lib.fmi3InstantiateModelExchange(b"me", self.spec.token, None, False,
                                                           False, None, _log)
            self.event_mode_used = False
        else:
            self.event_mode_used = r.random() < 0.5
            early = r.random() < 0.5
            cb = _update if r.random() < 0.5 else UPDATE()
            self.c = self.lib.fmi3InstantiateCoSimulation(
                b"cs", self.spec.token, None, False, False, self.event_mode_used, early, None, 0,
                c_void_p(1 if r.random() < 0.5 else 0), _log, cb)
        self.calls += 1
        if not self.c:
            raise Failure("O2", f"a valid {self.iface} instantiation failed: {LINES[-3:]}")
        self.state, self.time = "Instantiated", 0.0

    # -- actions --
    def do_free(self):
        self.free()

    def do_enter_init(self):
        r = self.rng
        bad = r.random() < 0.3
        tol = r.choice([float("nan"), -1.0, 2.0]) if bad else 10 ** r.uniform(-8, -4)
        valid = self.state == "Instantiated" and not bad
        st = self.call("fmi3EnterInitializationMode", self.c, True, tol, 0.0, False, 0.0,
                       expect={OK} if valid else {ERROR})
        if st == OK:
            self.state = "Init"

    def do_exit_init(self):
        valid = self.state == "Init"
        st = self.call("fmi3ExitInitializationMode", self.c,
                       expect={OK, WARNING, ERROR} if valid else {ERROR})
        if valid and st != ERROR:
            self.state = "Event" if (self.iface == "ME" or self.event_mode_used) else "Step"

    def do_step(self):
        r = self.rng
        kind = r.random()
        # Steps of 1, 3 and 10 times the DefaultExperiment's stepSize (the stiff
        # AndrewsSqueezer's 0.37 s steps cost half a second each).
        h, t = self.spec.step * r.choice([1, 3, 10]), self.time
        if kind < 0.15:
            h = r.choice([0.0, -0.1, float("nan"), float("inf")])
        elif kind < 0.25:
            t = self.time + r.choice([0.5, -0.5, 1e3])
        # (after a discarded step the instance is in Step Mode at lastSuccessfulTime: FMI
        # 3.0 has no stepFailed, a discarded call leaves the FMU where it can continue)
        valid = self.iface == "CS" and self.state == "Step" and kind >= 0.25
        outs = [c_uint8(9), c_uint8(9), c_uint8(9), c_double(math.nan)]
        st = self.call("fmi3DoStep", self.c, t, h, True, *[byref(o) for o in outs],
                       expect={OK, WARNING, DISCARD} if valid else {ERROR})
        if st in (OK, WARNING, DISCARD):
            last = outs[3].value
            if not (self.time <= last <= self.time + h + 1e-9):
                raise Failure("O3", f"lastSuccessfulTime {last} outside [{self.time}, {self.time + h}]")
            if outs[2].value and not 0 < last - self.time <= h:
                raise Failure("O3", f"an early return without progress: {last}")
            self.time = last
            if outs[0].value and self.event_mode_used and r.random() < 0.8:
                self.call("fmi3EnterEventMode", self.c, expect={OK})
                self.state = "Event"

    def do_get_float(self):
        r = self.rng
        pool = list(self.spec.floats)
        vrs = r.sample(pool, k=r.randint(1, min(6, len(pool))))
        bad = r.random() < 0.2
        if bad:
            vrs.append(r.choice([self.spec.bad, *self.spec.ints, *self.spec.enums]))
        readable = self.state in ("Init", "Event", "CT", "Step", "Terminated")
        expect = {ERROR} if (bad or not readable) else (
            {OK, WARNING, ERROR} if self.state == "Init" else {OK, WARNING})
        out = (c_double * len(vrs))()
        st = self.call("fmi3GetFloat64", self.c, arr(c_uint32, vrs), len(vrs), out, len(vrs),
                       expect=expect)
        if st in (OK, WARNING):
            self.finite(out, "fmi3GetFloat64")

    def do_set_float(self):
        r = self.rng
        s = self.spec
        kind = r.random()
        if kind < 0.4 and s.inputs:
            vr = r.choice(s.inputs)
            var = s.floats[vr]
            v = float(var.get("start", 0.0)) + r.uniform(-0.1, 0.1)
            v = min(max(v, float(var.get("min", -math.inf))), float(var.get("max", math.inf)))
            valid = self.state in ("Instantiated", "Init", "CT", "Step", "Event")
        elif kind < 0.6:
            vr = s.time
            v, valid = 1.0, False
        elif kind < 0.8 and s.params:
            vr = r.choice(s.params)
            v = float(s.floats[vr].get("start", 1.0))
            valid = self.state in ("Instantiated", "Init")
        else:
            vr = r.choice(s.inputs or s.params or [s.time])
            v, valid = r.choice([float("nan"), float("inf"), -float("inf")]), False
        self.call("fmi3SetFloat64", self.c, arr(c_uint32, [vr]), 1, arr(c_double, [v]), 1,
                  expect={OK} if valid else {ERROR})

    def do_get_int(self):
        r = self.rng
        s = self.spec
        readable = self.state in ("Init", "Event", "CT", "Step", "Terminated")
        if r.random() < 0.5 and s.ints:
            vr = r.choice(list(s.ints) + [r.choice(list(s.floats))])
            out = (c_int32 * 1)()
            valid = readable and vr in s.ints
            self.call("fmi3GetInt32", self.c, arr(c_uint32, [vr]), 1, out, 1,
                      expect={OK} if valid else {ERROR})
        else:
            vr = r.choice(list(s.enums) + list(s.ints))
            out = (c_int64 * 1)()
            valid = readable and vr in s.enums
            self.call("fmi3GetInt64", self.c, arr(c_uint32, [vr]), 1, out, 1,
                      expect={OK} if valid else {ERROR})

    def do_set_enum(self):
        """An Enumeration parameter set to its start (valid before initialization ends), to a
        code no item has, or an Int64 set on a Float64 variable (both refused)."""
        r = self.rng
        s = self.spec
        params = [vr for vr, v in s.enums.items() if v["causality"] == "parameter"]
        if not params:
            return
        kind = r.random()
        vr = r.choice(params)
        if kind < 0.6:
            v = int(s.enums[vr]["start"])
            valid = self.state in ("Instantiated", "Init")
        elif kind < 0.8:
            v, valid = -7, False
        else:
            vr, v, valid = r.choice(list(s.floats)), 0, False
        self.call("fmi3SetInt64", self.c, arr(c_uint32, [vr]), 1, arr(c_int64, [v]), 1,
                  expect={OK} if valid else {ERROR})

    def do_unsupported(self):
        r = self.rng
        choice = r.randrange(4)
        if choice == 0:
            self.call("fmi3GetBoolean", self.c, arr(c_uint32, [0]), 1, (c_uint8 * 1)(), 1,
                      expect={ERROR})
        elif choice == 1:
            self.call("fmi3GetClock", self.c, arr(c_uint32, [0]), 1, (c_uint8 * 1)(),
                      expect={ERROR})
        elif choice == 2:
            self.call("fmi3EnterConfigurationMode", self.c, expect={ERROR})
        else:  # a NULL instance: fmi3Error, nothing logged
            st = self.lib.fmi3Terminate(None)
            self.calls += 1
            if st != ERROR:
                raise Failure("O2", f"fmi3Terminate(NULL) returned {st}")

    def do_terminate(self):
        valid = self.state in ("Event", "CT", "Step")
        st = self.call("fmi3Terminate", self.c, expect={OK} if valid else {ERROR})
        if st == OK:
            self.state = "Terminated"

    def do_reset(self):
        self.call("fmi3Reset", self.c, expect={OK})
        self.state, self.time = "Instantiated", 0.0

    def do_modes(self):
        r = self.rng
        f = getattr(self, "_mode", None) or r.choice(
            ["fmi3EnterEventMode", "fmi3EnterContinuousTimeMode", "fmi3EnterStepMode",
             "fmi3UpdateDiscreteStates"])
        me, st8 = self.iface == "ME", self.state
        if f == "fmi3EnterEventMode":
            valid = (me and st8 == "CT") or (not me and st8 == "Step" and self.event_mode_used)
            new = "Event"
            args = ()
        elif f == "fmi3EnterContinuousTimeMode":
            valid, new, args = me and st8 == "Event", "CT", ()
        elif f == "fmi3EnterStepMode":
            valid, new, args = (not me) and st8 == "Event", "Step", ()
        else:
            valid, new = st8 == "Event", st8
            args = tuple(byref(c_uint8()) for _ in range(5)) + (byref(c_double()),)
        st = self.call(f, self.c, *args, expect={OK, WARNING} if valid else {ERROR})
        if st != ERROR:
            self.state = new

    def do_me(self):
        r = self.rng
        s = self.spec
        nx = len(s.states)
        me = self.iface == "ME"
        f = r.choice(["time", "get_x", "set_x", "dx", "z", "completed"])
        wrong_n = r.random() < 0.15
        n = nx + (1 if wrong_n else 0)
        if f == "time":
            t = r.choice([self.time + 0.01, float("nan")])
            valid = me and self.state in ("Event", "CT") and math.isfinite(t)
            st = self.call("fmi3SetTime", self.c, t, expect={OK} if valid else {ERROR})
            if st == OK:
                self.time = t
        elif f == "get_x":
            out = (c_double * max(1, n))()
            valid = me and not wrong_n and self.state in ("Init", "Event", "CT", "Terminated")
            st = self.call("fmi3GetContinuousStates", self.c, out, n,
                           expect={OK} if valid else {ERROR})
            if st == OK:
                self.finite(out[:n], "fmi3GetContinuousStates")
        elif f == "set_x":
            out = (c_double * max(1, nx))()
            x = [float(s.floats[v].get("start", 0.0)) for v in s.states]
            if me and self.state in ("Event", "CT"):
                if self.lib.fmi3GetContinuousStates(self.c, out, nx) == OK:
                    x = list(out[:nx])
                self.calls += 1
            bad = r.random() < 0.15
            if bad and x:
                x[r.randrange(len(x))] = float("nan")
            valid = me and not wrong_n and not bad and self.state == "CT"
            x = [v * (1 + 1e-6 * r.uniform(-1, 1)) for v in x] + [0.0] * (n - nx)
            self.call("fmi3SetContinuousStates", self.c, arr(c_double, x), n,
                      expect={OK} if valid else {ERROR})
        elif f in ("dx", "z"):
            count = (s.nz if f == "z" else nx) + (1 if wrong_n else 0)
            out = (c_double * max(1, count))()
            fname = "fmi3GetEventIndicators" if f == "z" else "fmi3GetContinuousStateDerivatives"
            # FMI 3.0.2 section 2.3: both in Initialization, Event, Continuous-Time Mode and
            # Terminated (unlike FMI 2.0, derivatives in Initialization Mode too).
            states = ("Init", "Event", "CT", "Terminated")
            valid = me and not wrong_n and self.state in states
            st = self.call(fname, self.c, out, count,
                           expect={OK, WARNING, DISCARD} if valid else {ERROR})
            if st in (OK, WARNING):
                self.finite(out[:count], fname)
        else:
            enter, term = c_uint8(), c_uint8()
            valid = me and self.state == "CT"
            self.call("fmi3CompletedIntegratorStep", self.c, True, byref(enter), byref(term),
                      expect={OK} if valid else {ERROR})

    def do_derivative(self):
        r = self.rng
        s = self.spec
        adjoint = r.random() < 0.5
        unknowns = r.sample(s.derivatives + s.outputs, k=r.randint(1, len(s.derivatives)))
        knowns = r.sample(s.states + s.inputs, k=r.randint(1, len(s.states)))
        bad = r.random() < 0.2
        if bad:
            knowns[0] = r.choice([s.bad, s.time])
        nu, nk = len(unknowns), len(knowns)
        n_seed, n_sens = (nu, nk) if adjoint else (nk, nu)
        wrong = r.random() < 0.1
        seed = [r.uniform(-1, 1) for _ in range(n_seed)]
        out = (c_double * max(1, n_sens))()
        ok_state = self.state in ("Init", "Event", "CT", "Step", "Terminated")
        valid = ok_state and not bad and not wrong
        fname = "fmi3GetAdjointDerivative" if adjoint else "fmi3GetDirectionalDerivative"
        st = self.call(fname, self.c, arr(c_uint32, unknowns), nu, arr(c_uint32, knowns), nk,
                       arr(c_double, seed), n_seed + (1 if wrong else 0), out, n_sens,
                       expect={OK, WARNING, ERROR} if valid else {ERROR})
        if st in (OK, WARNING):
            self.finite(out[:n_sens], fname)

    def do_state(self):
        r = self.rng
        choice = r.randrange(5)
        if choice == 0 or not self.states_made:
            p = c_void_p()
            self.call("fmi3GetFMUState", self.c, byref(p), expect={OK})
            self.states_made.append((p, self.state, self.time))
        elif choice == 1:
            p, state, t = r.choice(self.states_made)
            self.call("fmi3SetFMUState", self.c, p, expect={OK})
            # Co-Simulation: Step Mode and Event Mode share the restored core state; the
            # instance stays in the one it was in (only fmi3EnterStepMode leaves Event Mode).
            if self.iface == "CS" and state in ("Step", "Event"):
                self.state = "Event" if self.state == "Event" else "Step"
            else:
                self.state = state
            self.time = t
        elif choice == 2:
            i = r.randrange(len(self.states_made))
            p = self.states_made.pop(i)[0]
            self.call("fmi3FreeFMUState", self.c, byref(p), expect={OK})
            if p.value:
                raise Failure("O2", "fmi3FreeFMUState left the pointer set")
        else:
            p = r.choice(self.states_made)[0]
            size = c_size_t()
            self.call("fmi3SerializedFMUStateSize", self.c, p, byref(size), expect={OK})
            buf = (c_uint8 * size.value)()
            self.call("fmi3SerializeFMUState", self.c, p, buf, size.value, expect={OK})
            blob = bytearray(buf)
            mutated = choice == 4
            if mutated:
                how = r.randrange(3)
                if how == 0:
                    i = r.randrange(len(blob))
                    blob[i] ^= 1 << r.randrange(8)
                elif how == 1:
                    blob = blob[:r.randrange(len(blob))]
                else:
                    blob += bytes([r.randrange(256)])
            q = c_void_p()
            st = self.call("fmi3DeserializeFMUState", self.c, arr(c_uint8, blob), len(blob),
                           byref(q), expect={ERROR} if mutated else {OK})
            if st == OK:
                self.call("fmi3FreeFMUState", self.c, byref(q), expect={OK})
            elif q.value:
                raise Failure("O2", "a refused blob made a state")

    def do_progress_event(self):
        if self.iface == "ME":
            if self.rng.random() < 0.5:
                self.do_modes_named("fmi3UpdateDiscreteStates")
            self.do_modes_named("fmi3EnterContinuousTimeMode")
        else:
            self.do_modes_named("fmi3EnterStepMode")

    def do_progress_ct(self):
        if self.rng.random() < 0.1:
            self.do_modes_named("fmi3EnterEventMode")
        else:
            self.do_me()

    def do_modes_named(self, f):
        self._mode = f
        try:
            self.do_modes()
        finally:
            self._mode = None

    ACTIONS = [do_free, do_enter_init, do_exit_init, do_step, do_get_float, do_set_float,
               do_get_int, do_unsupported, do_terminate, do_reset, do_modes, do_me,
               do_derivative, do_state, do_set_enum]
    WEIGHTS = [(1, 0), (8, 0), (8, 0), (25, 0), (12, 0), (8, 0), (4, 0), (3, 0), (2, 0),
               (1, 0), (10, 0), (14, 0), (6, 0), (8, 0), (3, 0)]


Sequence.PROGRESS = {
    "Instantiated": Sequence.do_enter_init,
    "Init": Sequence.do_exit_init,
    "Event": Sequence.do_progress_event,
    "CT": Sequence.do_progress_ct,
    "Step": Sequence.do_step,
}


def batch(model: str, fmu_dir: pathlib.Path, first: int, count: int, n_calls: int) -> dict:
    fmu = fmu_dir / f"{model}.fmu"
    spec = Spec(fmu)
    lib = load(spec, fmu)
    failures, calls, done = [], 0, 0
    t0 = time.monotonic()
    for seed in range(first, first + count):
        # A time budget per FMU (after at least MIN_SEQUENCES): the stiff AndrewsSqueezer's
        # doSteps cost a tenth of a second each.
        if done >= MIN_SEQUENCES and time.monotonic() - t0 > BUDGET:
            break
        done += 1
        seq = Sequence(spec, lib, seed, n_calls)
        try:
            calls += seq.run()
        except Failure as e:
            calls += seq.calls
            failures.append({"seed": seed, "oracle": e.oracle, "message": str(e)[:2000]})
    return {"model": model, "sequences": done, "calls": calls, "failures": failures}


def main(argv):
    faulthandler.enable()
    model, fmu_dir, first, count, n_calls = argv[1], pathlib.Path(argv[2]), *map(int, argv[3:6])
    print(json.dumps(batch(model, fmu_dir, first, count, n_calls)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
