"""fmi2Get/SetFMUstate and (de)serialization.  Restores must be bit-for-bit: all
comparisons are exact (float bit patterns / repr round trips), no tolerance."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import uuid

import pytest

import fmu_support as fs
from fmu_support import fmi2Error, fmi2OK

H = 0.01
N = 100  # steps of 0.01 s: t = 1 at the snapshot, t = 2 at the end
INPUT_CHANGE = [50, {"F": 2.0}]  # at t = 1.5 the input changes (in both runs)

SCENES = {"MassSpringDamper": "resonance", "TwoMassChain": "step"}
SOLVERS = {"dopri5": fs.SOLVER_DOPRI5, "rk4": fs.SOLVER_RK4}


def _start(model, solver):
    sv = fs.scene_values(model.name, SCENES[model.name])
    sv["solver"] = solver
    return sv


def _row(inst, names):
    return [inst.t] + inst.get_reals(names)


def _run_from(inst, names, n=N):
    rows = [_row(inst, names)]
    for i in range(n):
        if i == INPUT_CHANGE[0]:
            inst.set(**INPUT_CHANGE[1])
        inst.step(H)
        rows.append(_row(inst, names))
    return rows


def _bits(rows):
    return [[fs.float_bits(v) for v in r] for r in rows]


def _reference(model, solver, instances, names):
    """Uninterrupted run 0 -> 2 s without any state call."""
    ref = instances(model, f"{model.name}_ref").initialize(_start(model, solver), tol=1e-10)
    for _ in range(N):
        ref.step(H)
    return _run_from(ref, names)


@pytest.mark.parametrize("solver", list(SOLVERS))
def test_get_set_state_bit_for_bit(model, instances, solver):
    names = model.real_names
    ref_rows = _reference(model, SOLVERS[solver], instances, names)

    a = instances(model, f"{model.name}_gs").initialize(_start(model, SOLVERS[solver]), tol=1e-10)
    for _ in range(N):
        a.step(H)
    t1 = a.t
    snap1 = a.snapshot()
    s = a.get_state()
    assert a.snapshot() == snap1, "fmi2GetFMUstate changed the instance"
    first = _run_from(a, names)
    assert _bits(first) == _bits(ref_rows), "GetFMUstate perturbed the continuation"

    assert a.set_state(s) == fmi2OK
    st, t = a.real_status()
    assert st == fmi2OK and t == t1
    assert a.snapshot() == snap1
    a.t = t
    second = _run_from(a, names)
    assert _bits(second) == _bits(first)

    # the same state restored into another (default-initialized) instance of the model
    b = instances(model, f"{model.name}_gs_other").initialize(None, tol=None)
    assert b.set_state(s) == fmi2OK
    b.t = b.real_status()[1]
    assert b.snapshot() == snap1
    assert _bits(_run_from(b, names)) == _bits(first)
    a.free_state(s)


@pytest.mark.parametrize("solver", list(SOLVERS))
def test_serialized_state_in_fresh_process(model, instances, solver, tmp_path):
    names = model.real_names
    ref_rows = _reference(model, SOLVERS[solver], instances, names)

    a = instances(model, f"{model.name}_ser").initialize(_start(model, SOLVERS[solver]), tol=1e-10)
    for _ in range(N):
        a.step(H)
    s = a.get_state()
    blob = a.serialize(s)
    a.free_state(s)
    blob_path = tmp_path / "state.bin"
    blob_path.write_bytes(blob)
    spec = dict(model=model.name, blob=str(blob_path), n_steps=N, h=H,
                input_change=INPUT_CHANGE, names=names)
    spec_path = tmp_path / "spec.json"
    spec_path.write_text(json.dumps(spec))
    env = dict(os.environ, MBFMU_FMU_DIR=str(model.path.parent))
    proc = subprocess.run([sys.executable, str(fs.HERE / "state_helper.py"), str(spec_path)],
                          capture_output=True, text=True, timeout=300, env=env, cwd=str(fs.HERE))
    assert proc.returncode == 0, f"helper failed: {proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
    lines = [l for l in proc.stdout.splitlines() if l and not l.startswith("[")]
    got = [[float(x) for x in l.split()] for l in lines]
    assert len(got) == len(ref_rows)
    for i, (g, r) in enumerate(zip(got, ref_rows)):
        assert _bits([g]) == _bits([r]), (
            f"row {i} (t={r[0]!r}) differs after restore in a fresh process:\n"
            f" got {g}\n want {r}")


def test_serialize_size_and_determinism(model, instances):
    a = instances(model, f"{model.name}_size").initialize(_start(model, fs.SOLVER_DOPRI5))
    for _ in range(10):
        a.step(H)
    s = a.get_state()
    b1 = a.serialize(s)
    b2 = a.serialize(s)
    a.free_state(s)
    assert b1 == b2
    assert len(b1) > 16
    # the blob carries the GUID (as text, with or without braces, or as 16 raw bytes)
    g = model.guid.strip("{}")
    forms = [model.guid.encode(), g.encode(), g.upper().encode(), uuid.UUID(g).bytes]
    assert any(f in b1 for f in forms), "the model GUID is not in the serialized state"


def _blob(model, instances, tag):
    inst = instances(model, f"{model.name}_{tag}").initialize(_start(model, fs.SOLVER_DOPRI5))
    for _ in range(10):
        inst.step(H)
    s = inst.get_state()
    blob = inst.serialize(s)
    inst.free_state(s)
    return blob


def _corruptions(own: bytes, other: bytes, guid: str = "{x}"):
    flipped = bytes([own[0] ^ 0xFF]) + own[1:]
    out = {
        "other model's blob": other,
        "truncated to half": own[: len(own) // 2],
        "truncated by one byte": own[:-1],
        "truncated to 4 bytes": own[:4],
        "empty": b"",
        "corrupted magic": flipped,
    }
    # the GUID, changed in place (same length): a blob of "another model"
    g = guid.encode()
    i = own.find(g)
    if i >= 0:
        j = i + 1  # first hex digit after "{"
        c = b"0" if own[j:j + 1] != b"0" else b"1"
        out["GUID changed in place"] = own[:j] + c + own[j + 1:]
    else:
        out["GUID changed in place"] = None  # test fails: GUID not found in the blob
    # version: the word right after the magic.  The contract fixes only the order
    # (magic, version, GUID, data); the widths (8-byte magic, u32 LE version) are the
    # ones documented in src/fmi/snapshot.rs.
    v = int.from_bytes(own[8:12], "little") if len(own) >= 12 else 0
    out["version + 1"] = own[:8] + (v + 1).to_bytes(4, "little") + own[12:]
    # not in the contract, documented in src/fmi/snapshot.rs: a wrong length is rejected
    out["one trailing byte"] = own + b"\0"
    return out


CORRUPTIONS = list(_corruptions(b"x" * 16, b"yy"))


@pytest.mark.parametrize("kind", CORRUPTIONS)
def test_bad_blob_rejected(model, load_model, instances, logs, kind):
    other_name = "TwoMassChain" if model.name == "MassSpringDamper" else "MassSpringDamper"
    other = load_model(other_name)
    own_blob = _blob(model, instances, "own")
    other_blob = _blob(other, instances, "other")
    bad = _corruptions(own_blob, other_blob, model.guid)[kind]
    assert bad is not None, f"the GUID {model.guid} is not in the serialized state"

    inst = instances(model, f"{model.name}_victim").initialize(_start(model, fs.SOLVER_DOPRI5))
    twin = instances(model, f"{model.name}_twin").initialize(_start(model, fs.SOLVER_DOPRI5))
    for i in (inst, twin):
        for _ in range(3):
            i.step(H)
    before = inst.snapshot()
    mark = logs.mark()
    st, state = inst.deserialize(bad)
    assert st == fmi2Error, f"{kind}: fmi2DeSerializeFMUstate returned {fs.STATUS_NAMES.get(st, st)}"
    recs = logs.since(mark)
    assert len(recs) == 1 and recs[0].instance == inst.name, recs
    assert recs[0].status == fmi2Error and recs[0].category == "logStatusError", recs
    # unchanged and usable
    assert inst.snapshot() == before
    assert inst.do_step(H) == fmi2OK and twin.do_step(H) == fmi2OK
    assert inst.snapshot() == twin.snapshot()
    # the good blob is still accepted afterwards
    st, good = inst.deserialize(own_blob)
    assert st == fmi2OK
    assert inst.set_state(good) == fmi2OK
    inst.free_state(good)
