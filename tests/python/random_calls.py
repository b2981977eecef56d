"""Random call sequences through the FMI 2.0 C API of one FMU, Co-Simulation and Model
Exchange instances (about a third of the instances are Model Exchange ones, ME_SHARE).

Each sequence starts from no instance and makes random calls from the whole CS API —
instantiate (also with a wrong GUID, type or name), setup, initialization, Get/Set of
every type with valid and invalid value references and values (NaN, ±Inf, outside the
modelDescription's [min, max], wrong variability for the machine state), doStep with good
and bad steps and times, Get/Set/Free/Serialize/DeSerialize FMU state (also blobs mutated:
bits flipped, truncated or extended, header fields changed, and values at their offsets
overwritten with out-of-range ones), reset, terminate, directional derivatives, status
queries, debug logging, input and output derivatives, and fmi2CancelStep — in whatever
state the
machine is in; for Model Exchange instances also fmi2SetTime, fmi2Set/GetContinuousStates,
fmi2GetDerivatives, fmi2GetEventIndicators, fmi2GetNominalsOfContinuousStates, event mode
(fmi2EnterEventMode, fmi2NewDiscreteStates, fmi2EnterContinuousTimeMode) and
fmi2CompletedIntegratorStep, alone and as an importer's explicit Euler step with the step
events it asks for; each interface's functions are called on instances of the other too (all
refused), and blobs of one interface are deserialized into the other (refused). A model of
the standard's state machines (sections 4.2.4 and 3.2.3) says which calls are valid; the FMU's documented contract ("every rejected call returns fmi2Error, changes
nothing") says where a rejected call leaves it.

The oracles. A sequence stops at the first one violated and reports it with its seed:

  O1 crash   the batch of one FMU runs in a subprocess: a signal (segfault, abort) or a
             sequence that does not end within SEQUENCE_TIMEOUT seconds (faulthandler ends
             the process) is reported with the seed that was running.
  O2 inputs  a call with an invalid argument returns fmi2Error (fmi2Discard where the
             standard allows it: status kinds the slave cannot answer). Invalid: not
             allowed in the machine state; unknown value reference or one of another type;
             NULL with n > 0; a non-finite Real or one outside [min, max]; a variable whose
             variability or causality forbids setting it now; doStep with h <= 0 or not
             finite, at another time than the FMU's or past stopTime; a tolerance <= 0 or
             not finite; a serialized state that fmi2SerializeFMUstate did not write (every
             mutated blob: refused by fmi2DeSerializeFMUstate, or by fmi2SetFMUstate when
             restored; so a blob needs an integrity check, since a flipped bit in a value
             looks like a state; where it carries a CRC-32 the harness finds it and keeps it
             valid when it overwrites a value with an out-of-range one, so that the check
             of the values is tested too). Conversely a call with valid arguments must not
             fail (doStep may discard).
  O3 finite  after a call returning fmi2OK or fmi2Warning (and after a doStep's
             fmi2Discard, which keeps the last good state) in stepComplete, stepFailed or
             terminated, fmi2GetReal of every output and state returns fmi2OK and finite
             values; so do those returned by fmi2GetReal, fmi2GetRealStatus and
             fmi2GetDirectionalDerivative. (In initialization mode the values set are not
             yet checked together: fmi2ExitInitializationMode refuses a non-finite
             initial point. Derivatives are locals, not outputs.) After a discarded
             doStep lastSuccessfulTime lies in [t, t + h].
  O4 status  a call returns at least the worst status it logged (a line logged as
             fmi2Warning makes it return fmi2Warning or worse, never fmi2OK), and a call
             returning fmi2Error or fmi2Discard logged a line with that status.
  O5 leak    fmi2FreeInstance frees the FMU states still outstanding: glibc's heap in use
             (mallinfo2) after LEAK_CYCLES cycles of instantiate, initialize, doStep, three
             FMU states taken, fmi2FreeInstance without freeing them, grows by less than a
             tenth of one state's serialized size per cycle (a leak keeps at least three;
             measured today: ~950 bytes per state against 0-600 bytes in all for the same
             cycles with the states freed first, which must stay under the bound too).

Valid values stay near the start values (half the sequences go up to 1.5 decades off,
with loose tolerances and long steps: stiffness, divergence), solver_step >= 1e-3 s and
doStep h <= 0.5 s, so that valid work stays bounded; a sequence ends early after
SEQUENCE_BUDGET seconds. Seeds are fixed per model (model_seed_base).

Reproduce one sequence with its trace (the seed is in the failure report):

    python tests/python/random_calls.py MODEL --seed SEED [--calls N]

Diagnostics: --no-mutations (blobs only as written), --keep-going (count every violation
instead of stopping at the first; later ones can be consequences of earlier ones).

The batch protocol (used by test_random_calls.py): ``random_calls.py MODEL --batch FIRST
COUNT CALLS`` prints one JSON line {"begin": seed} before each sequence and one result
line after it, after one {"leak": ...} line.
"""

from __future__ import annotations

import ctypes
import faulthandler
import gc
import json
import math
import random
import struct
import sys
import time
import zlib
from ctypes import (byref, c_char_p, c_double, c_int, c_size_t, c_uint, c_void_p,
                    create_string_buffer)
from dataclasses import dataclass, field

from fmpy.fmi2 import fmi2EventInfo

import fmu_support as fs

OK, WARNING, DISCARD, ERROR = 0, 1, 2, 3
NAMES = fs.STATUS_NAMES

# Expected statuses of a call.
INVALID = frozenset({ERROR})
REFUSED = frozenset({DISCARD, ERROR})  # a status kind the slave cannot answer
VALID = frozenset({OK, WARNING})
STEP = frozenset({OK, WARNING, DISCARD})
ANY = None  # the standard leaves it open (or the model decides): not checked by O2

# Machine states (the harness's model of the standard's state machine).
NONE, INSTANTIATED, INIT, STEP_COMPLETE, STEP_FAILED, TERMINATED = (
    "none", "instantiated", "initializationMode", "stepComplete", "stepFailed", "terminated")
EVENT, CONT = "eventMode", "continuousTimeMode"  # Model Exchange's (CS: the step states)
# fmi2GetXXX, directional derivatives (each interface lives in its own states: a union)
GET_STATES = (INIT, STEP_COMPLETE, STEP_FAILED, TERMINATED, EVENT, CONT)
SET_STATES = (INSTANTIATED, INIT, STEP_COMPLETE, EVENT, CONT)  # fmi2SetReal (inputs)
SET_INT_STATES = (INSTANTIATED, INIT, STEP_COMPLETE, EVENT)  # fmi2SetInteger/Boolean/String
INPUT_DER_STATES = (INSTANTIATED, INIT, STEP_COMPLETE)  # SetRealInputDerivatives (CS only)
STATUS_STATES = (STEP_COMPLETE, STEP_FAILED, TERMINATED)  # fmi2GetStatus & co. (CS only)
ME_SHARE = 0.35  # of the instances a sequence makes: Model Exchange ones
# O3's states: the values set before and in initialization mode are checked together by
# fmi2ExitInitializationMode (an infeasible combination of in-range values is refused
# there), so the FMU vouches for its outputs from then on.
CHECKED_STATES = (STEP_COMPLETE, STEP_FAILED, TERMINATED)

SEQUENCE_TIMEOUT = 10.0  # s without the sequence ending: O1 (a hang)
SEQUENCE_BUDGET = 2.0  # s; a sequence that took longer ends after its current call (most
# take 0.02 s; valid but fast or stiff systems make some doSteps slow)
LEAK_CYCLES, LEAK_WARMUP = 300, 30
TRACE_KEPT = 16  # calls shown before a failure

U32_MAX = 2**32 - 1
BAD_VRS = (U32_MAX, 2**31, 99_999)


def or_not_finite(expect):
    """A getter's expected statuses: a valid one may also be refused when the value is not
    finite at this configuration (checked by Runner.refused_only_if_not_finite)."""
    return VALID | INVALID if expect == VALID else expect


class Failure(Exception):
    def __init__(self, oracle: str, message: str):
        super().__init__(message)
        self.oracle = oracle


# ---------------------------------------------------------------------------------------
# The model's interface, from its modelDescription.xml
# ---------------------------------------------------------------------------------------


def _num(s):
    return None if s is None else float(s)


@dataclass
class Var:
    name: str
    vr: int
    type: str
    causality: str
    variability: str
    initial: str | None
    start: float | None
    min: float | None
    max: float | None
    nominal: float
    items: tuple = ()  # Enumeration values

    def settable_in(self, state: str) -> bool:
        """May fmi2SetXXX set it in this state (FMI 2.0, 4.2.4 and 2.2.7)?"""
        if self.causality == "input":
            return state in SET_STATES
        if self.causality == "parameter":
            if self.variability == "tunable":
                return state in SET_STATES
            return state in (INSTANTIATED, INIT)
        if self.initial in ("exact", "approx") and self.variability != "constant":
            return state == INSTANTIATED or (state == INIT and self.initial == "exact")
        return False

    def in_range(self, v: float) -> bool:
        return (self.min is None or v >= self.min) and (self.max is None or v <= self.max)


class Spec:
    def __init__(self, model: fs.Model):
        md = model.md
        self.model = model
        self.vars: list[Var] = []
        self.explicit_methods = ()  # fixed-step explicit: diverge at large steps
        for v in md.modelVariables:
            items = ()
            if v.type == "Enumeration" and v.declaredType is not None:
                items = tuple(int(i.value) for i in v.declaredType.items)
                self.explicit_methods = tuple(
                    int(i.value) for i in v.declaredType.items
                    if i.name in ("RK4", "ExplicitEuler"))
            self.vars.append(Var(
                v.name, v.valueReference, v.type, v.causality, v.variability, v.initial,
                _num(v.start), _num(v.min), _num(v.max), _num(v.nominal) or 1.0, items))
        self.by_vr = {v.vr: v for v in self.vars}
        self.reals = [v for v in self.vars if v.type == "Real"]
        self.ints = [v for v in self.vars if v.type in ("Integer", "Enumeration")]
        self.real_vrs = [v.vr for v in self.reals]
        self.states = [model.vars[n] for n in model.state_names]
        self.state_vrs = [v.valueReference for v in self.states]
        self.inputs = [v for v in self.reals if v.causality == "input"]
        self.unknowns = [v.vr for v in self.reals if v.causality == "output"] + [
            u.variable.valueReference for u in md.derivatives]
        self.knowns = self.state_vrs + [v.vr for v in self.inputs]
        # O3 checks the outputs and the states (not the derivatives: locals)
        self.checked_vrs = sorted({v.vr for v in self.reals if v.causality == "output"}
                                  | set(self.state_vrs))
        self.checked = set(self.checked_vrs)
        self.categories = [c.name.encode() for c in md.logCategories]
        self.default_tol = float(md.defaultExperiment.tolerance) if (
            md.defaultExperiment and md.defaultExperiment.tolerance) else 1e-8
        self.solver_step = next((v for v in self.reals if v.name == "solver_step"), None)
        self.max_vr = max(v.vr for v in self.vars)
        self.max_output_order = int(md.coSimulation.maxOutputDerivativeOrder or 0)
        self.n_states = len(self.state_vrs)
        self.n_indicators = int(md.numberOfEventIndicators or 0)
        self.state_nominals = [float(v.nominal) if v.nominal is not None else 1.0
                               for v in self.states]


# ---------------------------------------------------------------------------------------
# Values
# ---------------------------------------------------------------------------------------


def valid_real(v: Var, rng: random.Random, wide: float = 0.15) -> float:
    """A value in [min, max] near the start value: within ~30 %, or with probability
    `wide` up to 1.5 decades off (stiff, fast or diverging runs)."""
    if v.name == "solver_step":  # at least 1e-3 s: bounded work per doStep
        return 10 ** (rng.uniform(-3, -1) if rng.random() >= wide else rng.uniform(-2, -0.5))
    s = v.start if v.start is not None else 0.0
    scale = math.exp(rng.gauss(0.0, 0.3)) if rng.random() >= wide else 10 ** rng.uniform(-1.5, 1.5)
    if s != 0.0:
        x = s * scale
    else:
        x = v.nominal * scale * rng.choice((-0.3, 0.3))
        if v.min is not None and v.min >= 0.0:
            x = abs(x)
    if v.min is not None:
        x = max(x, v.min)
    if v.max is not None:
        x = min(x, v.max)
    return x


def invalid_real(v: Var, rng: random.Random) -> float | None:
    """A value the model must refuse for v (None if v has no range to leave and NaN/Inf
    were not drawn)."""
    r = rng.random()
    if r < 0.35:
        return rng.choice((math.nan, math.inf, -math.inf))
    options = []
    if v.min is not None:
        options.append(v.min - max(abs(v.min), 1.0) * 10 ** rng.uniform(-3, 3))
    if v.max is not None:
        options.append(v.max + max(abs(v.max), 1.0) * 10 ** rng.uniform(-3, 3))
    if options:
        return rng.choice(options)
    return rng.choice((math.nan, math.inf, -math.inf))


def valid_int(v: Var, rng: random.Random) -> int:
    if v.items:
        return rng.choice(v.items)
    lo = int(v.min) if v.min is not None else 1
    hi = int(v.max) if v.max is not None else lo + 10_000
    hi = min(hi, lo + 10_000)
    return rng.randint(lo, max(lo, hi))


def invalid_int(v: Var, rng: random.Random) -> int | None:
    if v.items:
        bad = [x for x in (0, -1, max(v.items) + 1, 2**31 - 1, -(2**31)) if x not in v.items]
        return rng.choice(bad)
    options = []
    if v.min is not None and v.min > -(2**31):
        options.append(int(v.min) - rng.randint(1, 1000))
    if v.max is not None and v.max < 2**31 - 1:
        options.append(int(v.max) + rng.randint(1, 1000))
    return rng.choice(options) if options else None


def finite(xs) -> bool:
    return all(math.isfinite(x) for x in xs)


def arr(ctype, values):
    return (ctype * max(len(values), 1))(*values)


# ---------------------------------------------------------------------------------------
# Serialized FMU states: integrity check and value offsets (layout-agnostic)
# ---------------------------------------------------------------------------------------


def _crc_variants(blob: bytes, p: int):
    """CRC-32 (zlib's) of the rest of the blob, as a field at offset p could be computed."""
    yield "skip", zlib.crc32(blob[:p] + blob[p + 4:])
    yield "zero", zlib.crc32(blob[:p] + b"\0\0\0\0" + blob[p + 4:])
    if len(blob) - p - 4 >= 8:  # (the CRC of nothing is 0: no match on zero bytes)
        yield "after", zlib.crc32(blob[p + 4:])
    if p >= 8:
        yield "before", zlib.crc32(blob[:p])


def find_crc(blob: bytes):
    """Where a CRC-32 over the blob is stored, if it carries one: (anchor, offset, how,
    endianness) with anchor "start" or "end"; None without one."""
    n = len(blob)
    positions = list(range(n - 4, max(n - 68, -1), -1)) + list(range(0, min(64, n - 3)))
    for p in positions:
        for end in ("<", ">"):
            stored = struct.unpack(end + "I", blob[p:p + 4])[0]
            for how, crc in _crc_variants(blob, p):
                if crc == stored:
                    anchor = ("end", n - p) if p >= n - 68 else ("start", p)
                    return anchor + (how, end)
    return None


def crc_offset(rule, n: int) -> int:
    return n - rule[1] if rule[0] == "end" else rule[1]


def crc_holds(rule, blob: bytes) -> bool:
    p = crc_offset(rule, len(blob))
    if not 0 <= p <= len(blob) - 4:
        return False
    want = dict(_crc_variants(blob, p)).get(rule[2])
    return struct.unpack(rule[3] + "I", blob[p:p + 4])[0] == want


def refresh_crc(rule, blob: bytearray) -> None:
    p = crc_offset(rule, len(blob))
    want = dict(_crc_variants(bytes(blob), p))[rule[2]]
    blob[p:p + 4] = struct.pack(rule[3] + "I", want)


def unique_offset(blob: bytes, value: float) -> int | None:
    """Offset of `value` as a little-endian double, if it occurs exactly once (and is
    distinctive enough not to be found by chance)."""
    pat = struct.pack("<d", value)
    if sum(b != 0 for b in pat) < 4:
        return None
    first = blob.find(pat)
    if first < 0 or blob.find(pat, first + 1) >= 0:
        return None
    return first


# ---------------------------------------------------------------------------------------
# One sequence
# ---------------------------------------------------------------------------------------


@dataclass
class StateRec:
    """What the harness knows about an FMU state (or a blob): the machine state, time and
    experiment it holds, the settable values, and every Real readable when it was taken."""
    machine: str
    time: float
    start: float
    stop: float | None
    tol: float
    values: dict  # vr -> value of the Real variables set or known (parameters, starts)
    readable: dict = field(default_factory=dict)  # vr -> value read at fmi2GetFMUstate
    tainted: bool = False  # deserialized from a corrupt blob (accepted: O2 at its restore)
    me: bool = False  # taken in a Model Exchange instance (refused by a CS one, and back)


class Sequence:
    def __init__(self, spec: Spec, lib, seed: int, n_calls: int, verbose: bool = False):
        self.spec = spec
        self.fn = lib._functions
        self.seed = seed
        self.rng = random.Random(seed)
        # Half the sequences draw their valid values wide, their tolerances loose and their
        # steps long (and so reach stiffness, divergence and fmi2Discard more often).
        self.wide = 0.6 if self.rng.random() < 0.5 else 0.1
        self.n_calls = n_calls
        self.verbose = verbose
        self.trace: list[str] = []
        self.coverage: dict[str, int] = {}  # "function in state: status" -> calls
        self.violations: list[tuple[str, str]] = []  # with KEEP_GOING
        self.comp = None  # c_void_p of the live instance
        self.me = False  # the live instance is a Model Exchange one
        self.n_inst = 0
        self.machine = NONE
        self.states: dict[int, tuple[c_void_p, StateRec]] = {}  # live fmi2FMUstate
        self.blobs: list[tuple[bytes, StateRec]] = []  # written by fmi2SerializeFMUstate
        self.crc_rule = None  # where the blobs carry a CRC-32, once found (find_crc)
        self._fresh_values()

    # -- bookkeeping ---------------------------------------------------------------------
    def _fresh_values(self):
        self.time, self.start, self.stop = 0.0, 0.0, None
        self.tol = self.spec.default_tol
        self.values = {v.vr: v.start for v in self.spec.reals if v.start is not None}

    def _rec(self, readable=None) -> StateRec:
        return StateRec(self.machine, self.time, self.start, self.stop, self.tol,
                        dict(self.values), dict(readable or {}), me=self.me)

    def _restore(self, rec: StateRec):
        self.machine, self.time, self.start = rec.machine, rec.time, rec.start
        self.stop, self.tol, self.values = rec.stop, rec.tol, dict(rec.values)

    def log(self, text: str):
        self.trace.append(text)
        if self.verbose:
            print(text)

    def fail(self, oracle: str, message: str):
        if self.KEEP_GOING:  # diagnostics: count every violation, go on as if none
            self.violations.append((oracle, message))
            if self.verbose:
                print(f"    VIOLATION {oracle}: {message}")
            return
        raise Failure(oracle, message)

    # -- the call wrapper: O2, O3 (returned values), O4 ---------------------------------
    def call(self, label: str, fname: str, *args, expect=ANY, logs_possible=True,
             after=None) -> int:
        if self.verbose:
            print(f"... {label}", flush=True)
            t0 = time.perf_counter()
        mark = fs.RECORDER.mark()
        st = int(self.fn[fname](*args))
        lines = fs.RECORDER.since(mark)
        if self.verbose and time.perf_counter() - t0 > 0.05:
            print(f"    ({time.perf_counter() - t0:.2f} s)")
        key = f"{fname[4:]} in {self.machine}: {NAMES.get(st, st)}"
        self.coverage[key] = self.coverage.get(key, 0) + 1
        shown = "ANY" if expect is None else "|".join(NAMES[s] for s in sorted(expect))
        self.log(f"[{len(self.trace)}] {label} -> {NAMES.get(st, st)} (expected {shown})"
                 + "".join(f"\n      log {NAMES.get(r.status, r.status)} {r.category}: "
                           f"{r.message}" for r in lines))
        if expect is not None and st not in expect:
            what = "an invalid call was accepted" if expect in (INVALID, REFUSED) else (
                "a valid call failed")
            self.fail("O2", f"{label}: {what}: returned {NAMES.get(st, st)}")
        if logs_possible:
            worst = max((r.status for r in lines), default=OK)
            if st < worst:
                self.fail("O4", f"{label}: logged a line with status {NAMES[worst]} but "
                                f"returned {NAMES.get(st, st)}")
            if st in (ERROR, DISCARD) and not any(r.status == st for r in lines):
                self.fail("O4", f"{label}: returned {NAMES[st]} without logging a line "
                                f"with that status")
        if after is not None:
            after(st)
        return st

    def refused_only_if_not_finite(self, function: str, st: int, expect) -> None:
        """O2 for a getter: a valid call may be refused only for a value that is not finite
        at this configuration, and then says so (its one line)."""
        if expect == VALID and st == ERROR:
            lines = [t for t in self.trace[-1:] if "is not finite at" in t]
            if not lines:
                self.fail("O2", f"{function}: a valid call failed (not for a non-finite value)")

    def check_finite(self, label: str):
        """O3: every Real variable reads OK and finite."""
        if self.comp is None or self.machine not in CHECKED_STATES or self.me:
            # (Model Exchange: the importer sets the states; each getter's own oracle holds)
            return
        vrs = self.spec.checked_vrs
        out = (c_double * len(vrs))()
        st = int(self.fn["fmi2GetReal"](self.comp, arr(c_uint, vrs), len(vrs), out))
        if st != OK:
            self.fail("O3", f"after {label}: fmi2GetReal of the outputs and states returned "
                            f"{NAMES.get(st, st)}")
        bad = [(self.spec.by_vr[vr].name, x) for vr, x in zip(vrs, out)
               if not math.isfinite(x)]
        if bad:
            self.fail("O3", f"after {label} returned OK: non-finite values {bad}")

    def read_all(self) -> dict:
        if self.comp is None or self.machine not in GET_STATES:
            return {}
        n = len(self.spec.real_vrs)
        out = (c_double * n)()
        st = int(self.fn["fmi2GetReal"](self.comp, arr(c_uint, self.spec.real_vrs), n, out))
        return dict(zip(self.spec.real_vrs, out)) if st == OK else {}

    # -- the run ------------------------------------------------------------------------
    ACTIONS = [
        ("setup", 3), ("enter", 3), ("exit", 3), ("set_real", 7), ("get_real", 3),
        ("set_int", 2), ("get_int", 2), ("bool_string", 1.5), ("do_step", 12),
        ("get_state", 3), ("set_state", 3), ("free_state", 2), ("state_size", 1),
        ("serialize", 2.5), ("deserialize", 5), ("reset", 1), ("terminate", 1),
        ("dir_der", 2), ("status", 2), ("debug_logging", 1), ("unsupported", 0.3),
        ("derivatives", 2),
        ("free_instance", 0.4), ("bad_instantiate", 0.6), ("null_component", 0.5),
        ("platform", 0.2),
        # Model Exchange (refused on Co-Simulation instances)
        ("me_time", 2), ("me_states", 3), ("me_get", 4), ("me_event", 3), ("me_integrate", 8),
    ]
    ME_ACTIONS = {"me_time", "me_states", "me_get", "me_event", "me_integrate"}
    CS_ACTIONS = {"do_step", "status", "derivatives", "unsupported"}

    # More of the calls that move the machine on where they are valid, so that every
    # state is visited often (stepComplete most).
    BOOST = {
        INSTANTIATED: {"setup": 3, "enter": 4, "set_real": 3, "set_int": 4},
        INIT: {"exit": 6, "set_real": 3, "set_int": 4},
        STEP_COMPLETE: {"do_step": 4},
        STEP_FAILED: {"terminate": 3, "set_state": 2},
        TERMINATED: {"reset": 3, "set_state": 2},
        EVENT: {"me_event": 4, "me_get": 1.5},
        CONT: {"me_integrate": 4},
    }

    KEEP_GOING = False  # --keep-going: diagnostics only (after a violation the
    # harness's model of the FMU may be wrong, so later ones can be consequences)
    MUTATE = True  # --no-mutations: only blobs as written (to look past today's O2)

    def run(self) -> dict:
        names = [a for a, _ in self.ACTIONS]
        weights = [w for _, w in self.ACTIONS]
        result = {"seed": self.seed, "calls": 0, "failure": None, "coverage": self.coverage}
        t0 = time.monotonic()
        try:
            for i in range(self.n_calls):
                if time.monotonic() - t0 > SEQUENCE_BUDGET:
                    result["cut"] = True
                    break
                result["calls"] = i + 1
                if self.comp is None:
                    # Without an instance only fmi2Instantiate and the calls that take none.
                    action = self.rng.choices(
                        ("instantiate", "bad_instantiate", "null_component", "platform"),
                        (20, 1, 1, 0.5))[0]
                    if action == "instantiate":
                        self.instantiate()
                        continue
                else:
                    boost = self.BOOST.get(self.machine, {})
                    if self.wide > 0.5 and self.machine == STEP_COMPLETE:
                        boost = {"do_step": 10}  # long runs: stiffness shows after a while
                    # The other interface's functions: now and then (all refused).
                    other = self.CS_ACTIONS if self.me else self.ME_ACTIONS
                    action = self.rng.choices(
                        names, [w * boost.get(a, 1) * (0.1 if a in other else 1)
                                for a, w in zip(names, weights)])[0]
                getattr(self, "do_" + action)()
        except Failure as f:
            result["failure"] = {"oracle": f.oracle, "message": str(f),
                                 "trace": self.trace[-TRACE_KEPT:]}
        finally:
            self.cleanup()
        if self.violations:
            result["violations"] = self.violations
        result["seconds"] = round(time.monotonic() - t0, 3)
        return result

    def cleanup(self):
        if self.comp is not None:
            for ptr, _ in list(self.states.values()):
                self.fn["fmi2FreeFMUstate"](self.comp, byref(ptr))
            self.fn["fmi2FreeInstance"](self.comp)
        self.states.clear()
        self.comp = None

    # -- instances ----------------------------------------------------------------------
    def instantiate(self):
        m = self.spec.model
        self.n_inst += 1
        name = f"rc{self.seed}_{self.n_inst}".encode()
        logging_on = int(self.rng.random() < 0.2)
        me = self.rng.random() < ME_SHARE
        mark = fs.RECORDER.mark()
        comp = self.fn["fmi2Instantiate"](name, fs.fmi2ModelExchange if me else
                                          fs.fmi2CoSimulation, m.guid.encode(),
                                          m.resource_uri(), byref(fs.CALLBACKS),
                                          0, logging_on)
        self.log(f"[{len(self.trace)}] fmi2Instantiate({name.decode()}, "
                 f"{'ModelExchange' if me else 'CoSimulation'}, loggingOn="
                 f"{logging_on}) -> {'instance' if comp else 'NULL'}")
        if not comp:
            lines = fs.RECORDER.since(mark)
            self.fail("O2", f"fmi2Instantiate with valid arguments returned NULL: {lines}")
        self.comp, self.machine, self.me = c_void_p(comp), INSTANTIATED, me
        self._fresh_values()

    def do_free_instance(self):
        if self.comp is None:
            return
        # FMU states still outstanding are the FMU's to free (O5 checks it).
        self.fn["fmi2FreeInstance"](self.comp)
        self.log(f"[{len(self.trace)}] fmi2FreeInstance with {len(self.states)} FMU "
                 f"states outstanding")
        self.comp, self.machine = None, NONE
        self.states.clear()

    def do_bad_instantiate(self):
        m, rng = self.spec.model, self.rng
        args = dict(name=f"rcbad{self.seed}".encode(), kind=fs.fmi2CoSimulation,
                    guid=m.guid.encode(), cb=byref(fs.CALLBACKS))
        what = rng.choice(["wrong GUID", "other GUID case", "type -1", "type 7",
                           "NULL name", "empty name", "NULL GUID", "NULL callbacks"])
        if what == "wrong GUID":
            args["guid"] = b"{00000000-1111-2222-3333-444444444444}"
        elif what == "other GUID case":
            args["guid"] = m.guid.swapcase().encode()
            if args["guid"] == m.guid.encode():
                args["guid"] = b"{" + args["guid"][1:-1][::-1] + b"}"
        elif what == "type -1":
            args["kind"] = -1
        elif what == "type 7":
            args["kind"] = 7
        elif what == "NULL name":
            args["name"] = None
        elif what == "empty name":
            args["name"] = b""
        elif what == "NULL GUID":
            args["guid"] = None
        else:
            args["cb"] = None
        mark = fs.RECORDER.mark()
        comp = self.fn["fmi2Instantiate"](args["name"], args["kind"], args["guid"],
                                          m.resource_uri(), args["cb"], 0, 0)
        lines = fs.RECORDER.since(mark)
        self.log(f"[{len(self.trace)}] fmi2Instantiate({what}) -> "
                 f"{'instance' if comp else 'NULL'}; {len(lines)} log lines")
        if comp:
            self.fn["fmi2FreeInstance"](c_void_p(comp))
            self.fail("O2", f"fmi2Instantiate with {what} returned an instance")
        if what != "NULL callbacks" and not any(r.status == ERROR for r in lines):
            self.fail("O4", f"fmi2Instantiate with {what} returned NULL without logging an "
                            f"error")

    def do_null_component(self):
        rng = self.rng
        f, args = rng.choice([
            ("fmi2DoStep", (c_double(0.0), c_double(0.01), 1)),
            ("fmi2GetReal", (arr(c_uint, [0]), 1, (c_double * 1)())),
            ("fmi2SetReal", (arr(c_uint, [0]), 1, arr(c_double, [1.0]))),
            ("fmi2Terminate", ()), ("fmi2Reset", ()), ("fmi2EnterInitializationMode", ()),
            ("fmi2SetFMUstate", (None,)),
        ])
        self.call(f"{f}(NULL component)", f, None, *args, expect=INVALID,
                  logs_possible=False)

    def do_platform(self):
        tp = self.fn["fmi2GetTypesPlatform"]()
        ver = self.fn["fmi2GetVersion"]()
        self.log(f"[{len(self.trace)}] fmi2GetTypesPlatform/GetVersion -> {tp!r} {ver!r}")
        if tp != b"default" or ver != b"2.0":
            self.fail("O2", f"fmi2GetTypesPlatform/fmi2GetVersion returned {tp!r}, {ver!r}")

    # -- life cycle ---------------------------------------------------------------------
    def do_setup(self):
        rng = self.rng
        tol_defined = rng.random() < 0.7
        tol = 10 ** rng.uniform(-9, -1) if rng.random() >= self.wide else 10 ** rng.uniform(-3, -1)
        start = 0.0 if rng.random() < 0.6 else rng.uniform(-5.0, 5.0)
        stop_defined = rng.random() < 0.2
        stop = start + 10 ** rng.uniform(-1, 2)
        valid = True
        any_ = False
        r = rng.random()
        if r < 0.12:
            tol_defined, tol, valid = True, rng.choice(
                (0.0, -1e-6, math.nan, math.inf, -math.inf)), False
        elif r < 0.17:
            tol_defined, tol, any_ = True, rng.choice((1.0, 2.0, 1e3)), True
        elif r < 0.24:
            start, valid = rng.choice((math.nan, math.inf, -math.inf)), False
        elif r < 0.31:
            stop_defined, stop, valid = True, rng.choice(
                (start - 1.0, math.nan, math.inf)), False
        if self.machine != INSTANTIATED:
            valid, any_ = False, False
        expect = ANY if any_ else (VALID if valid else INVALID)

        def after(st):
            if st in (OK, WARNING):
                self.tol = tol if tol_defined else self.spec.default_tol
                self.start = self.time = start
                self.stop = stop if stop_defined else None
                self.check_finite("fmi2SetupExperiment")

        self.call(f"fmi2SetupExperiment(tol {tol if tol_defined else 'undefined'}, start "
                  f"{start}, stop {stop if stop_defined else 'undefined'})",
                  "fmi2SetupExperiment", self.comp, int(tol_defined), c_double(tol),
                  c_double(start), int(stop_defined), c_double(stop), expect=expect,
                  after=after)

    def do_enter(self):
        def after(st):
            if st in (OK, WARNING):
                self.machine = INIT
                self.check_finite("fmi2EnterInitializationMode")

        self.call("fmi2EnterInitializationMode", "fmi2EnterInitializationMode", self.comp,
                  expect=VALID if self.machine == INSTANTIATED else INVALID, after=after)

    def do_exit(self):
        def after(st):
            if st in (OK, WARNING):
                self.machine = EVENT if self.me else STEP_COMPLETE
                self.time = self.start
                self.check_finite("fmi2ExitInitializationMode")

        # In initialization mode the model may still refuse (a non-finite initial point,
        # a solver this system cannot use).
        self.call("fmi2ExitInitializationMode", "fmi2ExitInitializationMode", self.comp,
                  expect=ANY if self.machine == INIT else INVALID, after=after)

    def do_terminate(self):
        def after(st):
            if st in (OK, WARNING):
                self.machine = TERMINATED
                self.check_finite("fmi2Terminate")

        ok = self.machine in (STEP_COMPLETE, STEP_FAILED, EVENT, CONT)
        self.call("fmi2Terminate", "fmi2Terminate", self.comp,
                  expect=VALID if ok else INVALID, after=after)

    def do_reset(self):
        def after(st):
            if st in (OK, WARNING):
                self.machine = INSTANTIATED
                self._fresh_values()

        self.call("fmi2Reset", "fmi2Reset", self.comp, expect=VALID, after=after)

    # -- values -------------------------------------------------------------------------
    def _vr_list(self, pool: list[int], k: int, bad_prob: float):
        """k value references from pool (none if it is empty); with probability bad_prob
        an unknown one among them."""
        vrs = [self.rng.choice(pool) for _ in range(k)] if pool else []
        bad = False
        if self.rng.random() < bad_prob:
            bad_vr = self.rng.choice(BAD_VRS + (self.spec.max_vr + 1,))
            vrs.insert(self.rng.randint(0, len(vrs)), bad_vr)
            bad = True
        return vrs, bad

    def do_set_real(self):
        rng, spec = self.rng, self.spec
        state = self.machine
        k = rng.choice((0, 1, 1, 1, 2, 3)) if rng.random() < 0.95 else 0
        settable = [v for v in spec.reals if v.settable_in(state)]
        pool = settable if (settable and rng.random() < 0.8) else spec.reals
        chosen = [rng.choice(pool) for _ in range(k)]
        values, invalid = [], state not in SET_STATES
        for v in chosen:
            if not v.settable_in(state):
                invalid = True
            if rng.random() < 0.2:
                x = invalid_real(v, rng)
                invalid = True
            else:
                x = valid_real(v, rng, self.wide)
            values.append(x)
        vrs = [v.vr for v in chosen]
        r = rng.random()
        null = None
        if r < 0.06:
            bad = rng.choice(BAD_VRS + (spec.max_vr + 1,))
            vrs.append(bad)
            values.append(1.0)
            invalid = True
        elif r < 0.09 and vrs:
            null, invalid = rng.choice(("vr", "value")), True
        elif r < 0.12 and spec.ints:
            vrs.append(rng.choice(spec.ints).vr)  # an Enumeration through fmi2SetReal
            values.append(1.0)
            invalid = True
        n = len(vrs)
        vr_arg = None if null == "vr" else arr(c_uint, vrs)
        val_arg = None if null == "value" else arr(c_double, values)
        names = [spec.by_vr[x].name if x in spec.by_vr else str(x) for x in vrs]

        def after(st):
            if st in (OK, WARNING):
                for vr, x in zip(vrs, values):
                    self.values[vr] = x
                self.check_finite("fmi2SetReal")

        self.call(f"fmi2SetReal({list(zip(names, values))}{', NULL ' + null if null else ''})",
                  "fmi2SetReal", self.comp, vr_arg, n, val_arg,
                  expect=INVALID if invalid else VALID, after=after)

    def do_get_real(self):
        rng, spec = self.rng, self.spec
        k = rng.choice((0, 1, 2, 4, len(spec.real_vrs)))
        vrs, bad = self._vr_list(spec.real_vrs, k, 0.15)
        if not bad and spec.ints and rng.random() < 0.07:
            vrs.append(rng.choice(spec.ints).vr)
            bad = True
        null = None
        if vrs and rng.random() < 0.05:
            null, bad = rng.choice(("vr", "value")), True
        n = len(vrs)
        out = (c_double * max(n, 1))()
        if self.machine == INSTANTIATED:
            # Reading before initialization mode: not in the CS state table, but asked for
            # by importers (start values); the FMU may answer or refuse.
            expect = INVALID if bad else ANY
        elif self.machine not in GET_STATES:
            expect = INVALID
        else:
            expect = INVALID if bad else VALID

        def after(st):
            # No non-finite number leaves with fmi2OK, in any state and for any variable
            # (derivatives too); one the model cannot compute is refused with its line.
            if st == OK and not finite(list(out)[:n]):
                self.fail("O3", f"fmi2GetReal returned OK with non-finite values "
                                f"{list(zip(vrs, list(out)))}")
            self.refused_only_if_not_finite("fmi2GetReal", st, expect)

        self.call(f"fmi2GetReal({vrs}{', NULL ' + null if null else ''})", "fmi2GetReal",
                  self.comp, None if null == "vr" else arr(c_uint, vrs), n,
                  None if null == "value" else out, expect=or_not_finite(expect), after=after)

    def do_set_int(self):
        rng, spec = self.rng, self.spec
        state = self.machine
        invalid = state not in SET_INT_STATES
        model_decides = False
        vrs, values = [], []
        for _ in range(rng.choice((0, 1, 1, 2))):
            if spec.ints and rng.random() < 0.9:
                v = rng.choice(spec.ints)
                if not v.settable_in(state):
                    invalid = True
                x = invalid_int(v, rng) if rng.random() < 0.25 else None
                if x is None:
                    x = valid_int(v, rng)
                    if v.items and self.wide > 0.5 and spec.explicit_methods and rng.random() < 0.3:
                        x = rng.choice(spec.explicit_methods)
                    model_decides |= bool(v.items)  # a method the system cannot use
                else:
                    invalid = True
            else:
                v = rng.choice(spec.reals)  # a Real through fmi2SetInteger
                x, invalid = 1, True
            vrs.append(v.vr)
            values.append(x)
        if rng.random() < 0.08:
            vrs.append(rng.choice(BAD_VRS))
            values.append(1)
            invalid = True
        # The model re-checks the method it holds against the parameters on every call.
        model_decides |= any(v.items for v in spec.ints)
        expect = INVALID if invalid else (ANY if model_decides else VALID)

        def after(st):
            if st in (OK, WARNING):
                self.check_finite("fmi2SetInteger")

        self.call(f"fmi2SetInteger({list(zip(vrs, values))})", "fmi2SetInteger", self.comp,
                  arr(c_uint, vrs), len(vrs), arr(c_int, values), expect=expect,
                  after=after)

    def do_get_int(self):
        rng, spec = self.rng, self.spec
        vrs, bad = self._vr_list([v.vr for v in spec.ints], rng.choice((0, 1, 2)), 0.15)
        if rng.random() < 0.1:
            vrs.append(rng.choice(spec.real_vrs))
            bad = True
        if self.machine == INSTANTIATED:
            expect = INVALID if bad else ANY
        else:
            expect = INVALID if (bad or self.machine not in GET_STATES) else VALID
        out = (c_int * max(len(vrs), 1))()
        self.call(f"fmi2GetInteger({vrs})", "fmi2GetInteger", self.comp, arr(c_uint, vrs),
                  len(vrs), out, expect=expect)

    def do_bool_string(self):
        """The models have no Boolean or String variables: any value reference is invalid."""
        rng = self.rng
        f = rng.choice(("fmi2GetBoolean", "fmi2SetBoolean", "fmi2GetString", "fmi2SetString"))
        setter = f.startswith("fmi2Set")
        n = 0 if rng.random() < 0.3 else rng.randint(1, 2)
        vrs = [rng.choice(self.spec.real_vrs + [99_999]) for _ in range(n)]
        if f.endswith("String"):
            values = (c_char_p * max(n, 1))(*([b"x"] * n if setter else []))
        else:
            values = (c_int * max(n, 1))()
        if n > 0 or self.machine not in (SET_INT_STATES if setter else GET_STATES + (
                INSTANTIATED,)):
            expect = INVALID
        else:  # nothing to get or set (a getter in instantiated: see do_get_real)
            expect = ANY if (not setter and self.machine == INSTANTIATED) else VALID
        self.call(f"{f}({vrs})", f, self.comp, arr(c_uint, vrs), n, values, expect=expect)

    # -- doStep -------------------------------------------------------------------------
    def do_do_step(self):
        rng = self.rng
        t = self.time
        r = rng.random()
        if r < 0.85 - 0.4 * self.wide:
            h = 10 ** rng.uniform(-4, -1.3)
        elif r < 0.9:
            h = 10 ** rng.uniform(-1.3, -0.3)  # long (more often in wide sequences)
        else:
            h = 10 ** rng.uniform(-9, -6)
        valid = True
        if self.stop is not None and t + h > self.stop:
            h = self.stop - t
            if not h > 1e-9:
                h = 1e-3
                valid = False  # past stopTime
        r = rng.random()
        if r < 0.05:
            h, valid = rng.choice((0.0, -0.0, -1e-3, math.nan, math.inf, -math.inf)), False
        elif r < 0.10:
            t, valid = t + rng.choice((1.0, -1.0)) * 10 ** rng.uniform(-5, 0) * max(
                1.0, abs(t)), False
        elif r < 0.12:
            t, valid = rng.choice((math.nan, math.inf)), False
        elif r < 0.14 and self.stop is not None:
            h, valid = self.stop - t + 10 ** rng.uniform(-4, 0) * max(1.0, abs(self.stop)), False
        expect = STEP if (valid and self.machine == STEP_COMPLETE) else INVALID
        t_before = self.time

        def after(st):
            if st in (OK, WARNING):
                self.time = t + h
                self.check_finite(f"fmi2DoStep({t}, {h})")
            elif st == DISCARD:
                self.machine = STEP_FAILED
                self.check_finite(f"fmi2DoStep({t}, {h}) discarded")
                # lastSuccessfulTime lies in [t, t + h]
                v = c_double(math.nan)
                st2 = int(self.fn["fmi2GetRealStatus"](self.comp, fs.fmi2LastSuccessfulTime,
                                                       byref(v)))
                if st2 != OK or not (t_before <= v.value <= t + h):
                    self.fail("O3", f"after a discarded doStep from {t_before}: "
                                    f"lastSuccessfulTime {v.value} ({NAMES.get(st2, st2)})")

        self.call(f"fmi2DoStep({t!r}, {h!r})", "fmi2DoStep", self.comp, c_double(t),
                  c_double(h), int(rng.random() < 0.5), expect=expect, after=after)

    # -- FMU states ---------------------------------------------------------------------
    def _live(self):
        return list(self.states.items())

    def do_get_state(self):
        rng = self.rng
        live = self._live()
        if rng.random() < 0.05:
            self.call("fmi2GetFMUstate(NULL)", "fmi2GetFMUstate", self.comp, None,
                      expect=INVALID)
            return
        readable = self.read_all()
        if live and rng.random() < 0.3:
            key, (ptr, rec) = rng.choice(live)
            if rec.tainted:
                return
            before = ptr.value

            def after_reuse(st):
                if st in (OK, WARNING):
                    if ptr.value != before:
                        self.fail("O2", "fmi2GetFMUstate into an existing state moved it")
                    self.states[key] = (ptr, self._rec(readable))
                    self.check_finite("fmi2GetFMUstate")

            self.call("fmi2GetFMUstate(existing)", "fmi2GetFMUstate", self.comp, byref(ptr),
                      expect=VALID, after=after_reuse)
            return
        ptr = c_void_p()

        def after(st):
            if st in (OK, WARNING):
                if not ptr.value or ptr.value in self.states:
                    self.fail("O2", f"fmi2GetFMUstate returned OK and state {ptr.value}")
                self.states[ptr.value] = (ptr, self._rec(readable))
                self.check_finite("fmi2GetFMUstate")

        self.call("fmi2GetFMUstate(new)", "fmi2GetFMUstate", self.comp, byref(ptr),
                  expect=VALID, after=after)

    def do_set_state(self):
        live = self._live()
        if not live or self.rng.random() < 0.05:
            self.call("fmi2SetFMUstate(NULL)", "fmi2SetFMUstate", self.comp, None,
                      expect=INVALID)
            return
        key, (ptr, rec) = self.rng.choice(live)
        self._set_state(ptr, rec)

    def _set_state(self, ptr, rec: StateRec):
        tainted = rec.tainted

        def after(st):
            if st in (OK, WARNING):
                self._restore(rec)
                self.check_finite("fmi2SetFMUstate")

        self.call(f"fmi2SetFMUstate({'state from a corrupt blob' if tainted else rec.machine}"
                  f" at t = {rec.time})", "fmi2SetFMUstate", self.comp, ptr,
                  expect=INVALID if tainted else VALID, after=after)

    def do_free_state(self):
        live = self._live()
        r = self.rng.random()
        if r < 0.05:
            self.call("fmi2FreeFMUstate(NULL)", "fmi2FreeFMUstate", self.comp, None,
                      expect=INVALID)
            return
        if not live or r < 0.1:
            null = c_void_p()
            self.call("fmi2FreeFMUstate(&NULL)", "fmi2FreeFMUstate", self.comp, byref(null),
                      expect=ANY)
            return
        key, (ptr, rec) = self.rng.choice(live)

        def after(st):
            if st in (OK, WARNING):
                del self.states[key]

        self.call("fmi2FreeFMUstate", "fmi2FreeFMUstate", self.comp, byref(ptr),
                  expect=ANY if rec.tainted else VALID, after=after)

    def do_state_size(self):
        live = [(k, v) for k, v in self._live() if not v[1].tainted]
        size = c_size_t()
        if not live or self.rng.random() < 0.1:
            self.call("fmi2SerializedFMUstateSize(NULL state)", "fmi2SerializedFMUstateSize",
                      self.comp, None, byref(size), expect=INVALID)
            return
        _, (ptr, _) = self.rng.choice(live)
        null = self.rng.random() < 0.1
        self.call("fmi2SerializedFMUstateSize" + ("(NULL size)" if null else ""),
                  "fmi2SerializedFMUstateSize", self.comp, ptr, None if null else byref(size),
                  expect=INVALID if null else VALID)

    def do_serialize(self):
        live = [(k, v) for k, v in self._live() if not v[1].tainted]
        if not live:
            return
        _, (ptr, rec) = self.rng.choice(live)
        size = c_size_t()
        st = self.call("fmi2SerializedFMUstateSize", "fmi2SerializedFMUstateSize", self.comp,
                       ptr, byref(size), expect=VALID)
        if st not in (OK, WARNING):
            return
        n = size.value
        r = self.rng.random()
        if r < 0.08:
            buf, m = create_string_buffer(n + 8), n + self.rng.choice((-1, 1, 8))
            if m < 0:
                m = 1
            self.call(f"fmi2SerializeFMUstate(size {m} != {n})", "fmi2SerializeFMUstate",
                      self.comp, ptr, buf, m, expect=INVALID)
            return
        if r < 0.12 and n > 0:
            self.call("fmi2SerializeFMUstate(NULL buffer)", "fmi2SerializeFMUstate",
                      self.comp, ptr, None, n, expect=INVALID)
            return
        buf = create_string_buffer(n)
        st = self.call("fmi2SerializeFMUstate", "fmi2SerializeFMUstate", self.comp, ptr, buf,
                       n, expect=VALID)
        if st in (OK, WARNING):
            blob = buf.raw
            self.blobs.append((blob, rec))
            if len(self.blobs) > 12:
                del self.blobs[self.rng.randrange(len(self.blobs))]
            if self.crc_rule is None or not crc_holds(self.crc_rule, blob):
                self.crc_rule = find_crc(blob)

    def do_deserialize(self):
        rng = self.rng
        if not self.blobs or rng.random() < 0.04:
            what = rng.choice(("NULL bytes", "size 0", "NULL state"))
            ptr = c_void_p()
            if what == "NULL bytes":
                args = (None, 16, byref(ptr))
            elif what == "size 0":
                args = (create_string_buffer(1), 0, byref(ptr))
            else:
                blob = self.blobs[0][0] if self.blobs else b"\0" * 16
                args = (create_string_buffer(blob, len(blob)), len(blob), None)
            st = self.call(f"fmi2DeSerializeFMUstate({what})", "fmi2DeSerializeFMUstate",
                           self.comp, *args, expect=INVALID)
            return
        blob, rec = rng.choice(self.blobs)
        mutated, how = (None, "as written") if (
            not self.MUTATE or rng.random() < 0.45) else self.mutate(blob, rec)
        data = blob if mutated is None else mutated
        reuse = None
        live = [(k, v) for k, v in self._live() if not v[1].tainted]
        if live and rng.random() < 0.25:
            reuse = rng.choice(live)
        ptr = reuse[1][0] if reuse else c_void_p()
        before = ptr.value
        st = self.call(f"fmi2DeSerializeFMUstate({len(data)} bytes, {how}"
                       f"{', into an existing state' if reuse else ''})",
                       "fmi2DeSerializeFMUstate", self.comp,
                       create_string_buffer(data, len(data)), len(data), byref(ptr),
                       expect=INVALID if rec.me != self.me else (
                           VALID if mutated is None else ANY))
        if st not in (OK, WARNING):
            return
        if reuse and ptr.value != before:
            self.fail("O2", "fmi2DeSerializeFMUstate into an existing state moved it")
        key = reuse[0] if reuse else ptr.value
        if mutated is None:
            self.states[key] = (ptr, StateRec(**{**rec.__dict__}))
            return
        # A corrupt blob was taken: restoring it must fail (O2), now.
        tainted = StateRec(**{**rec.__dict__, "tainted": True})
        self.states[key] = (ptr, tainted)
        self._set_state(ptr, tainted)

    def mutate(self, blob: bytes, rec: StateRec):
        """A copy of blob that fmi2SerializeFMUstate did not write, and how it was made."""
        rng = self.rng
        b = bytearray(blob)
        n = len(b)
        for _ in range(8):
            kind = rng.choice(("flip", "flip", "byte", "truncate", "extend", "header",
                               "value", "value", "value"))
            if kind == "flip":
                k = rng.randint(1, 3)
                for _ in range(k):
                    p = rng.randrange(n)
                    b[p] ^= 1 << rng.randrange(8)
                how = f"{k} bit(s) flipped"
            elif kind == "byte":
                p = rng.randrange(n)
                b[p] = (b[p] + rng.randint(1, 255)) % 256
                how = f"byte {p} changed"
            elif kind == "truncate":
                m = rng.randrange(n)
                b = b[:m]
                how = f"truncated to {m} bytes"
            elif kind == "extend":
                b += bytes(rng.randrange(256) for _ in range(rng.randint(1, 9)))
                how = "bytes appended"
            elif kind == "header":
                p = rng.choice((8, 12, 16 + rng.randrange(4)))  # version, GUID length/bytes
                b[p] = (b[p] + rng.randint(1, 255)) % 256
                how = f"header byte {p} changed"
            else:
                got = self.overwrite_value(b, rec)
                if got is None:
                    continue
                how = got
            if bytes(b) != blob:
                return bytes(b), how
            b = bytearray(blob)
        b[rng.randrange(n)] ^= 0x10
        return bytes(b), "1 bit flipped"

    def overwrite_value(self, b: bytearray, rec: StateRec) -> str | None:
        """Overwrites one value whose offset is known (it occurs once in the blob) with one
        the model must refuse; keeps a CRC-32 the blob carries valid, so that what is
        tested is the check of the values, not the checksum."""
        rng, spec = self.rng, self.spec
        crc = self.crc_rule is not None and crc_holds(self.crc_rule, bytes(b))
        cands = []
        for vr, x in rec.values.items():  # parameters and inputs: the values last set
            v = spec.by_vr.get(vr)
            if v is not None and v.causality in ("parameter", "input") and (
                    v.min is not None or v.max is not None or rng.random() < 0.3):
                cands.append((v.name, x, v))
        for vr, x in rec.readable.items():
            v = spec.by_vr[vr]
            if vr in spec.state_vrs:
                cands.append((v.name, x, v))
        cands.append(("tolerance", rec.tol, None))
        rng.shuffle(cands)
        state_vrs = set(spec.state_vrs)
        for name, x, v in cands:
            p = unique_offset(bytes(b), x)
            if p is None:
                continue
            if v is None:  # the tolerance
                bad = rng.choice((0.0, -1e-6, math.nan, math.inf))
            elif v.vr in state_vrs and rec.machine not in (INSTANTIATED, INIT):
                # after initialisation a state is the integration's (ME: the importer's
                # solver steps past a declared [min, max]): only finite is required
                bad = rng.choice((math.nan, math.inf, -math.inf))
            else:
                bad = invalid_real(v, rng)
            b[p:p + 8] = struct.pack("<d", bad)
            if crc:
                refresh_crc(self.crc_rule, b)
                return f"{name} = {x!r} overwritten with {bad!r} (CRC-32 kept valid)"
            return f"{name} = {x!r} overwritten with {bad!r}"
        return None

    # -- the rest -----------------------------------------------------------------------
    def do_dir_der(self):
        rng, spec = self.rng, self.spec
        unknowns, bad_u = self._vr_list(spec.unknowns, rng.randint(1, 3), 0.1)
        knowns, bad_k = self._vr_list(spec.knowns, rng.randint(1, 3), 0.1)
        seeds = [rng.gauss(0.0, 1.0) for _ in knowns]
        any_ = False
        if rng.random() < 0.1:
            seeds[rng.randrange(len(seeds))] = rng.choice((math.nan, math.inf))
            any_ = True
        if rng.random() < 0.1:
            knowns[rng.randrange(len(knowns))] = rng.choice(spec.reals).vr
            any_ = True
        null = None
        if rng.random() < 0.05:
            null = rng.choice(("unknown", "known", "dvKnown", "dvUnknown"))
        unknown_vr = any(vr not in spec.by_vr for vr in unknowns + knowns)
        invalid = unknown_vr or null is not None
        out = (c_double * len(unknowns))()
        if invalid:
            expect = INVALID
        elif self.machine == INSTANTIATED or any_:
            expect = ANY
        else:
            expect = VALID if self.machine in GET_STATES else INVALID

        def after(st):
            if st == OK and not finite(list(out)):
                self.fail("O3", f"fmi2GetDirectionalDerivative returned OK with "
                                f"{list(out)}")
            self.refused_only_if_not_finite("fmi2GetDirectionalDerivative", st, expect)

        self.call(f"fmi2GetDirectionalDerivative({unknowns}, {knowns}, {seeds}"
                  f"{', NULL ' + null if null else ''})", "fmi2GetDirectionalDerivative",
                  self.comp, None if null == "unknown" else arr(c_uint, unknowns),
                  len(unknowns), None if null == "known" else arr(c_uint, knowns),
                  len(knowns), None if null == "dvKnown" else arr(c_double, seeds),
                  None if null == "dvUnknown" else out, expect=or_not_finite(expect),
                  after=after)

    def do_status(self):
        rng = self.rng
        f, ctype = rng.choice([("fmi2GetStatus", c_int), ("fmi2GetRealStatus", c_double),
                               ("fmi2GetIntegerStatus", c_int),
                               ("fmi2GetBooleanStatus", c_int),
                               ("fmi2GetStringStatus", c_char_p)])
        kind = rng.choice((0, 1, 2, 3, 42, -1))
        value = ctype()
        null = rng.random() < 0.05
        answerable = (f, kind) in (("fmi2GetRealStatus", 2), ("fmi2GetBooleanStatus", 3))
        if null or self.machine not in STATUS_STATES or self.me:
            expect = INVALID
        elif answerable:
            expect = VALID
        elif (f, kind) in (("fmi2GetStatus", 0), ("fmi2GetStringStatus", 1)):
            expect = frozenset({OK, DISCARD, ERROR})  # DoStepStatus / PendingStatus
        else:
            expect = REFUSED

        def after(st):
            if st == OK and f == "fmi2GetRealStatus" and not math.isfinite(value.value):
                self.fail("O3", f"fmi2GetRealStatus({kind}) returned OK with {value.value}")
            if st == OK and (f, kind) == ("fmi2GetRealStatus", 2) and value.value != self.time \
                    and self.machine == STEP_COMPLETE:
                self.fail("O2", f"lastSuccessfulTime {value.value!r}, the FMU's time is "
                                f"{self.time!r}")

        self.call(f"{f}(kind {kind}{', NULL value' if null else ''})", f, self.comp, kind,
                  None if null else byref(value), expect=expect, after=after)

    def do_debug_logging(self):
        rng = self.rng
        cats = rng.sample(self.spec.categories, rng.randint(0, len(self.spec.categories)))
        invalid = False
        r = rng.random()
        if r < 0.15:
            cats.append(b"noSuchCategory")
            invalid = True
        elif r < 0.2 and cats:
            cats[rng.randrange(len(cats))] = None
            invalid = True
        null_array = bool(cats) and rng.random() < 0.05
        on = int(rng.random() < 0.5)
        self.call(f"fmi2SetDebugLogging({on}, {cats}{', NULL array' if null_array else ''})",
                  "fmi2SetDebugLogging", self.comp, on, len(cats),
                  None if null_array else (c_char_p * max(len(cats), 1))(*cats),
                  expect=INVALID if (invalid or null_array) else VALID)

    def do_unsupported(self):
        """fmi2CancelStep (canRunAsynchronuously = false): always refused."""
        self.call("fmi2CancelStep", "fmi2CancelStep", self.comp, expect=INVALID)

    def _derivative_args(self, allowed_vrs, max_order):
        """Random (vrs, orders, values) for the two derivative functions, and whether the
        value references (of `allowed_vrs`, or others) and orders (1 … `max_order`, or 0,
        −1, one above) are bad; values are 0 or, sometimes, one NaN/±Inf."""
        rng, spec = self.rng, self.spec
        n = rng.randint(1, 3)
        vrs, _ = self._vr_list(allowed_vrs or spec.real_vrs, n, 0.1)
        if rng.random() < 0.1:
            vrs[rng.randrange(len(vrs))] = rng.choice(spec.real_vrs)
        bad = any(vr not in allowed_vrs for vr in vrs)
        orders = [rng.randint(1, max(max_order, 1)) for _ in vrs]
        if rng.random() < 0.1 or max_order < 1:
            orders[rng.randrange(len(orders))] = rng.choice((0, -1, max_order + 1))
            bad = True
        values = [0.0 for _ in vrs]
        if rng.random() < 0.1:
            values[rng.randrange(len(values))] = rng.choice((math.nan, math.inf, -math.inf))
        return vrs, orders, values, bad

    def do_derivatives(self):
        """fmi2SetRealInputDerivatives (inputs, orders 1–2, finite values; valid ones are 0,
        so the other oracles' expectations of the inputs hold) and
        fmi2GetRealOutputDerivatives (outputs, orders up to maxOutputDerivativeOrder; the
        model may refuse one that needs ∂/∂t with its parameters: not checked by O2)."""
        rng, spec = self.rng, self.spec
        null = rng.random() < 0.05
        if rng.random() < 0.5:
            f = "fmi2SetRealInputDerivatives"
            vrs, orders, values, bad = self._derivative_args([v.vr for v in spec.inputs], 2)
            bad |= not finite(values)
            ok_state = self.machine in INPUT_DER_STATES and not self.me
            expect = INVALID if (bad or null or not ok_state) else VALID
            self.call(f"{f}({vrs}, {orders}, {values}{', NULL' if null else ''})", f,
                      self.comp, arr(c_uint, vrs), len(vrs), arr(c_int, orders),
                      None if null else arr(c_double, values), expect=expect)
            return
        f = "fmi2GetRealOutputDerivatives"
        vrs, orders, _, bad = self._derivative_args(spec.checked_vrs, spec.max_output_order)
        out = (c_double * len(vrs))()
        ok_state = self.machine in STATUS_STATES and not self.me
        expect = INVALID if (bad or null or not ok_state) else ANY

        def after(st):
            if st == OK and not finite(list(out)):
                self.fail("O3", f"{f} returned OK with {list(out)}")

        self.call(f"{f}({vrs}, {orders}{', NULL' if null else ''})", f, self.comp,
                  arr(c_uint, vrs), len(vrs), arr(c_int, orders), None if null else out,
                  expect=expect, after=after)


    # -- Model Exchange -----------------------------------------------------------------
    def _me_expect(self, allowed) -> frozenset:
        return VALID if (self.me and self.machine in allowed) else INVALID

    def _me_read(self, fname: str, n: int, allowed, label: str | None = None,
                 discard_ok: bool = False):
        """A getter of n values (continuous states, derivatives, event indicators,
        nominals): sometimes with a wrong count or NULL. O3: OK means finite values (and
        positive nominals). Returns (status, values)."""
        rng = self.rng
        count, null = n, False
        r = rng.random()
        if r < 0.06:
            count = n + rng.choice((1, -1 if n > 0 else 2))
        elif r < 0.1 and n > 0:
            null = True
        out = (c_double * max(count, 1))()
        expect = INVALID if (count != n or null) else self._me_expect(allowed)
        if expect == VALID and discard_ok:
            expect = frozenset({OK, WARNING, DISCARD})

        def after(st):
            vals = list(out)[:count]
            if st == OK and not finite(vals):
                self.fail("O3", f"{fname} returned OK with {vals}")
            if st == OK and fname == "fmi2GetNominalsOfContinuousStates" and not all(
                    v > 0 for v in vals):
                self.fail("O3", f"{fname} returned OK with {vals}")

        st = self.call(f"{label or fname}(n {count}{', NULL' if null else ''})", fname,
                       self.comp, None if null else out, count, expect=expect, after=after)
        return st, list(out)[:count]

    def do_me_time(self):
        rng = self.rng
        t = self.time + rng.choice((1.0, 1.0, 1.0, -1.0)) * 10 ** rng.uniform(-5, -1)
        bad = rng.random() < 0.15
        if bad:
            t = rng.choice((math.nan, math.inf, -math.inf))
        expect = INVALID if bad else self._me_expect((EVENT, CONT))

        def after(st):
            if st in (OK, WARNING):
                self.time = t

        self.call(f"fmi2SetTime({t!r})", "fmi2SetTime", self.comp, c_double(t),
                  expect=expect, after=after)

    def do_me_states(self):
        """fmi2SetContinuousStates: near the states held (sometimes far), or invalid."""
        rng, spec = self.rng, self.spec
        n = spec.n_states
        x = [0.0] * n
        if self.me and self.machine in (INIT, EVENT, CONT, TERMINATED):
            out = (c_double * max(n, 1))()
            if int(self.fn["fmi2GetContinuousStates"](self.comp, out, n)) == OK:
                x = list(out)[:n]
        scale = 0.05 if rng.random() >= self.wide else 1.0
        x = [v + rng.gauss(0.0, scale) * nom for v, nom in zip(x, spec.state_nominals)]
        count, null, bad = n, False, False
        r = rng.random()
        if r < 0.12 and n:
            x[rng.randrange(n)] = rng.choice((math.nan, math.inf, -math.inf))
            bad = True
        elif r < 0.18:
            count, bad = n + rng.choice((1, -1)), True
            x = (x + [0.0])[:max(count, 0)]
        elif r < 0.22 and n:
            null, bad = True, True
        expect = INVALID if bad else self._me_expect((CONT,))
        self.call(f"fmi2SetContinuousStates({x}{', NULL' if null else ''})",
                  "fmi2SetContinuousStates", self.comp,
                  None if null else arr(c_double, x), max(count, 0), expect=expect)

    def do_me_get(self):
        spec = self.spec
        f, n, allowed = self.rng.choice([
            ("fmi2GetContinuousStates", spec.n_states, (INIT, EVENT, CONT, TERMINATED)),
            ("fmi2GetDerivatives", spec.n_states, (EVENT, CONT, TERMINATED)),
            ("fmi2GetEventIndicators", spec.n_indicators, (INIT, EVENT, CONT, TERMINATED)),
            ("fmi2GetNominalsOfContinuousStates", spec.n_states,
             (INSTANTIATED, EVENT, CONT, TERMINATED)),
        ])
        self._me_read(f, n, allowed, discard_ok=f in ("fmi2GetDerivatives",
                                                     "fmi2GetEventIndicators"))

    def do_me_event(self):
        rng = self.rng
        f = rng.choice(("fmi2EnterEventMode", "fmi2NewDiscreteStates",
                        "fmi2EnterContinuousTimeMode", "fmi2CompletedIntegratorStep"))
        if f == "fmi2EnterEventMode":
            self.call(f, f, self.comp, expect=self._me_expect((EVENT, CONT)),
                      after=lambda st: self._move(st, EVENT))
        elif f == "fmi2EnterContinuousTimeMode":
            self.call(f, f, self.comp, expect=self._me_expect((EVENT,)),
                      after=lambda st: self._move(st, CONT))
        elif f == "fmi2NewDiscreteStates":
            self._new_discrete_states(null=rng.random() < 0.08)
        else:
            self._completed_step(null=rng.random() < 0.08)

    def _move(self, st, machine):
        if st in (OK, WARNING):
            self.machine = machine

    def _new_discrete_states(self, null=False):
        info = fmi2EventInfo()
        expect = INVALID if null else self._me_expect((EVENT,))
        st = self.call(f"fmi2NewDiscreteStates{'(NULL)' if null else ''}",
                       "fmi2NewDiscreteStates", self.comp, None if null else byref(info),
                       expect=expect)
        return st, info

    def _completed_step(self, null=False):
        enter, terminate = c_int(7), c_int(7)

        def after(st):
            if st == OK and (enter.value not in (0, 1) or terminate.value not in (0, 1)):
                self.fail("O3", f"fmi2CompletedIntegratorStep returned OK with "
                                f"{enter.value}, {terminate.value}")

        expect = INVALID if null else self._me_expect((CONT,))
        st = self.call(f"fmi2CompletedIntegratorStep{'(NULL)' if null else ''}",
                       "fmi2CompletedIntegratorStep", self.comp, int(self.rng.random() < 0.5),
                       None if null else byref(enter), byref(terminate), expect=expect,
                       after=after)
        return st, bool(enter.value == 1), bool(terminate.value == 1)

    def do_me_integrate(self):
        """One explicit Euler step as an importer takes it: states and derivatives read, time
        and states set, fmi2CompletedIntegratorStep, and the step event it asks for (event
        mode, fmi2NewDiscreteStates, back to continuous-time mode)."""
        if not (self.me and self.machine == CONT):
            self._completed_step()
            return
        n = self.spec.n_states
        st, x = self._me_read("fmi2GetContinuousStates", n, (CONT,), "step: states")
        if st != OK or len(x) != n:
            return
        st, dx = self._me_read("fmi2GetDerivatives", n, (CONT,), "step: derivatives",
                               discard_ok=True)
        if st != OK or len(dx) != n:
            return
        h = 10 ** self.rng.uniform(-4, -1.5)
        t = self.time + h
        st = self.call(f"step: fmi2SetTime({t!r})", "fmi2SetTime", self.comp, c_double(t),
                       expect=VALID)
        if st == OK:
            self.time = t
        xn = [a + h * b for a, b in zip(x, dx)]
        valid = finite(xn)
        self.call(f"step: fmi2SetContinuousStates({xn})", "fmi2SetContinuousStates",
                  self.comp, arr(c_double, xn), n, expect=VALID if valid else INVALID)
        st, enter, terminate = self._completed_step()
        if st != OK or not (enter or terminate):
            return
        st = self.call("step event: fmi2EnterEventMode", "fmi2EnterEventMode", self.comp,
                       expect=VALID, after=lambda st: self._move(st, EVENT))
        st, info = self._new_discrete_states()
        if st != OK or info.terminateSimulation:
            return
        self.call("step event: fmi2EnterContinuousTimeMode", "fmi2EnterContinuousTimeMode",
                  self.comp, expect=VALID, after=lambda st: self._move(st, CONT))

# ---------------------------------------------------------------------------------------
# O5: FMU states freed with their instance
# ---------------------------------------------------------------------------------------


class _Mallinfo2(ctypes.Structure):
    _fields_ = [(n, c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd",
                                        "usmblks", "fsmblks", "uordblks", "fordblks",
                                        "keepcost")]


def heap_in_use() -> int:
    libc = ctypes.CDLL(None)
    f = libc.mallinfo2
    f.restype = _Mallinfo2
    m = f()
    return int(m.uordblks + m.hblkhd)


def leak_check(spec: Spec, lib, cycles: int = LEAK_CYCLES, warmup: int = LEAK_WARMUP):
    fn, m = lib._functions, spec.model

    def cycle(i: int, leave: bool) -> int:
        comp = fn["fmi2Instantiate"](f"leak{i}".encode(), fs.fmi2CoSimulation,
                                     m.guid.encode(), m.resource_uri(), byref(fs.CALLBACKS),
                                     0, 0)
        assert comp, "fmi2Instantiate failed"
        c = c_void_p(comp)
        assert fn["fmi2SetupExperiment"](c, 1, c_double(1e-6), c_double(0.0), 0,
                                         c_double(0.0)) == OK
        assert fn["fmi2EnterInitializationMode"](c) == OK
        assert fn["fmi2ExitInitializationMode"](c) == OK
        assert fn["fmi2DoStep"](c, c_double(0.0), c_double(0.01), 1) in (OK, WARNING)
        s1, s2, s3 = c_void_p(), c_void_p(), c_void_p()
        assert fn["fmi2GetFMUstate"](c, byref(s1)) == OK
        assert fn["fmi2GetFMUstate"](c, byref(s2)) == OK
        size = c_size_t()
        assert fn["fmi2SerializedFMUstateSize"](c, s1, byref(size)) == OK
        buf = create_string_buffer(size.value)
        assert fn["fmi2SerializeFMUstate"](c, s1, buf, size.value) == OK
        assert fn["fmi2DeSerializeFMUstate"](c, buf, size.value, byref(s3)) == OK
        if not leave:
            for s in (s1, s2, s3):
                assert fn["fmi2FreeFMUstate"](c, byref(s)) == OK
        fn["fmi2FreeInstance"](c)
        return size.value

    def grow(leave: bool) -> tuple[int, int]:
        for i in range(warmup):
            cycle(i, leave)
        gc.collect()
        before = heap_in_use()
        for i in range(cycles):
            n = cycle(i, leave)
        gc.collect()
        return heap_in_use() - before, n

    control, blob = grow(leave=False)
    leaked, blob = grow(leave=True)
    bound = cycles * blob // 10
    return {"cycles": cycles, "state_bytes": blob, "bound": bound,
            "growth_states_freed": control, "growth_states_left": leaked,
            "ok": leaked < bound and control < bound}


# ---------------------------------------------------------------------------------------
# Entry points
# ---------------------------------------------------------------------------------------


def model_seed_base(name: str) -> int:
    """The first seed of a model's batch: fixed, and different for every model."""
    return (zlib.crc32(name.encode()) % 100_000) * 1000


def run_batches(models, sequences: int, calls: int, workers: int = 2,
                extra: tuple = (), timeout: float = 900.0) -> dict:
    """The batch of every model in a subprocess of its own, `workers` at a time.

    Returns {model: {"leak": ..., "results": [...], "crashes": [...], "seconds": ...}}. A
    subprocess that dies (a signal, or faulthandler ending a sequence that hung) leaves a
    crash with the seed that was running; the batch then goes on from the next seed (up to
    three times)."""
    import os
    import subprocess
    import time
    from concurrent.futures import ThreadPoolExecutor

    here = os.path.dirname(os.path.abspath(__file__))

    def one(name: str) -> dict:
        out = {"leak": None, "results": [], "crashes": [], "seconds": 0.0}
        t0 = time.monotonic()
        first, left, leak = model_seed_base(name), sequences, True
        while left > 0 and len(out["crashes"]) < 3:
            cmd = [sys.executable, os.path.join(here, "random_calls.py"), name, "--batch",
                   str(first), str(left), str(calls), *([] if leak else ["--no-leak"]), *extra]
            try:
                p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                                   cwd=here)
                stdout, stderr, rc = p.stdout, p.stderr, p.returncode
            except subprocess.TimeoutExpired as e:
                stdout = e.stdout.decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
                stderr, rc = f"batch did not end within {timeout} s", "timeout"
            running, done = None, 0
            for line in stdout.splitlines():
                d = json.loads(line)
                if "leak" in d:
                    out["leak"] = d["leak"]
                elif "begin" in d:
                    running = d["begin"]
                else:
                    out["results"].append(d)
                    running, done = None, done + 1
            leak = False
            if rc == 0 and running is None:
                break
            out["crashes"].append({"seed": running, "returncode": rc,
                                   "stderr": stderr[-3000:]})
            if running is None:  # died loading the FMU or in the leak check
                break
            first, left = running + 1, left - done - 1
        out["seconds"] = time.monotonic() - t0
        return out

    # The largest binaries (the Lagrangian models, slowest per call) first, so that the
    # workers finish together.
    order = sorted(models, key=lambda n: -os.path.getsize(fs.fmu_file(n)))
    with ThreadPoolExecutor(max_workers=workers) as pool:
        done = dict(zip(order, pool.map(one, order)))
    return {n: done[n] for n in models}


def describe(name: str, outcome: dict, calls: int, shown: int = 3) -> tuple[list, str]:
    """The failures of one model's batch as (oracle, seed, message), and a report showing
    the first of each oracle with the command that replays it."""
    failures = []
    for c in outcome["crashes"]:
        hang = c["returncode"] == "timeout" or "Timeout (" in c["stderr"]
        failures.append(("O1 (hang)" if hang else "O1 (crash)", c["seed"],
                         f"process ended ({c['returncode']}):\n{c['stderr']}"))
    for r in outcome["results"]:
        f = r["failure"]
        if f is not None:
            failures.append((f["oracle"], r["seed"], f["message"] + "\n    trace:\n      "
                             + "\n      ".join(f["trace"])))
    counts: dict[str, int] = {}
    first: dict[str, tuple] = {}
    for f in failures:
        counts[f[0]] = counts.get(f[0], 0) + 1
        first.setdefault(f[0], f)
    total = len(outcome["results"]) + len(outcome["crashes"])
    lines = [f"{name}: {len(failures)} of {total} sequences violated an oracle: {counts}"]
    for oracle, seed, message in list(first.values())[:shown]:
        lines.append(f"{oracle}, seed {seed}: {message}\n  replay: python tests/python/"
                     f"random_calls.py {name} --seed {seed} --calls {calls}")
    return failures, "\n".join(lines)


def bind_model_exchange(lib) -> None:
    """fmpy's FMU2Slave binds the Co-Simulation functions only: the Model Exchange ones of
    the same binary, added to its function table."""
    d, sz = ctypes.POINTER(c_double), c_size_t
    signatures = {
        "fmi2SetTime": [c_void_p, c_double],
        "fmi2SetContinuousStates": [c_void_p, d, sz],
        "fmi2GetContinuousStates": [c_void_p, d, sz],
        "fmi2GetDerivatives": [c_void_p, d, sz],
        "fmi2GetEventIndicators": [c_void_p, d, sz],
        "fmi2GetNominalsOfContinuousStates": [c_void_p, d, sz],
        "fmi2EnterEventMode": [c_void_p],
        "fmi2EnterContinuousTimeMode": [c_void_p],
        "fmi2NewDiscreteStates": [c_void_p, ctypes.POINTER(fmi2EventInfo)],
        "fmi2CompletedIntegratorStep": [c_void_p, c_int, ctypes.POINTER(c_int),
                                        ctypes.POINTER(c_int)],
    }
    for name, args in signatures.items():
        f = getattr(lib.dll, name)
        f.argtypes, f.restype = args, c_int
        lib._functions[name] = f


def load(model_name: str):
    fs.ensure_logger()
    fs.AUTO_ENSURE_LOGGER = False
    model = fs.Model(model_name)
    lib = model.library(f"{model_name}_random")
    bind_model_exchange(lib)
    return Spec(model), lib


def batch(model_name: str, first: int, count: int, n_calls: int, leak: bool) -> None:
    spec, lib = load(model_name)
    if leak:
        print(json.dumps({"leak": leak_check(spec, lib)}), flush=True)
    for seed in range(first, first + count):
        print(json.dumps({"begin": seed}), flush=True)
        faulthandler.dump_traceback_later(SEQUENCE_TIMEOUT, exit=True)
        result = Sequence(spec, lib, seed, n_calls).run()
        faulthandler.cancel_dump_traceback_later()
        fs.RECORDER.records.clear()
        print(json.dumps(result), flush=True)


def main(argv: list[str]) -> int:
    faulthandler.enable()
    model_name = argv[0]
    Sequence.MUTATE = "--no-mutations" not in argv
    Sequence.KEEP_GOING = "--keep-going" in argv
    if "--batch" in argv:
        i = argv.index("--batch")
        first, count, n_calls = (int(x) for x in argv[i + 1:i + 4])
        batch(model_name, first, count, n_calls, leak="--no-leak" not in argv)
        return 0
    seed = int(argv[argv.index("--seed") + 1])
    n_calls = int(argv[argv.index("--calls") + 1]) if "--calls" in argv else 200
    spec, lib = load(model_name)
    result = Sequence(spec, lib, seed, n_calls, verbose=True).run()
    failure = result["failure"]
    kept = result.get("violations", [])
    print(f"{model_name} seed {seed}: {result['calls']} calls, "
          + (f"{failure['oracle']}: {failure['message']}" if failure else
             f"{len(kept)} violations ({', '.join(sorted({o for o, _ in kept}))})" if kept
             else "no oracle violated"))
    return 0 if failure is None and not kept else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
