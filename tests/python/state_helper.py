"""Subprocess side of test_state.py: restore a serialized FMU state in a fresh process and
continue the simulation there.

usage: python state_helper.py SPEC.json

SPEC: {"model": ..., "blob": path, "n_steps": int, "h": float,
       "input_change": [step_index, {"F": value}] | null, "names": [...]}

The fresh instance is initialized with the XML defaults only (no scene start values), so
everything that makes the run differ from the defaults has to come from the blob.
Prints one line per communication point: repr() of t and of every requested value.
"""

import json
import sys

import fmu_support as fs


def main(spec_path):
    with open(spec_path) as f:
        spec = json.load(f)
    model = fs.Model(spec["model"])
    with open(spec["blob"], "rb") as f:
        blob = f.read()
    inst = model.instance(f"{model.name}_restored")
    inst.initialize(None, tol=None)
    st, state = inst.deserialize(blob)
    if st != fs.fmi2OK:
        print(f"DESERIALIZE-FAILED {st}")
        return 2
    st = inst.set_state(state)
    if st != fs.fmi2OK:
        print(f"SETSTATE-FAILED {st}")
        return 3
    inst.free_state(state)
    st, t = inst.real_status()
    if st != fs.fmi2OK:
        print(f"GETREALSTATUS-FAILED {st}")
        return 4
    inst.t = t
    names = spec["names"]
    change = spec.get("input_change")
    print(" ".join(repr(v) for v in [inst.t] + inst.get_reals(names)))
    for i in range(spec["n_steps"]):
        if change and i == change[0]:
            inst.set(**change[1])
        inst.step(spec["h"])
        print(" ".join(repr(v) for v in [inst.t] + inst.get_reals(names)))
    inst.free()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
