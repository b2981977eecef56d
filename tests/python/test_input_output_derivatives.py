"""fmi2GetRealOutputDerivatives and fmi2SetRealInputDerivatives (issue 16).

- Output derivatives of every FMU at its default experiment against finite differences of
  the outputs in time (orders 1 and 2 where declared); FMUs that declare 0 refuse.
- Input derivatives followed exactly: a ramp and a parabola given as value + derivatives
  match the forced oscillator's exact response inside one long doStep.
- fmpy's simulate_fmu(..., set_input_derivatives=True) on a piecewise-linear input table
  is exact to the tolerance with any output interval (held inputs are not), once
  mbfmu.fmpy_input_derivatives_fix() has fixed fmpy 0.3.32's buffer; the README's recipe,
  run as it stands there.
"""

from __future__ import annotations

import math
import re
from ctypes import c_double, c_int, c_uint

import numpy as np
import pytest
import scipy.linalg
from fmpy import simulate_fmu

import fmu_support as fs

FMUS = sorted(p.stem for p in fs.fmu_dir().glob("*.fmu"))

# Finite differences around t1: the FMU at rtol 1e-12 (DOPRI5), steps of DELTA; a model
# whose DefaultExperiment ends before 0.4 s (AndrewsSqueezer: 0.03 s) at half its stop time,
# with DELTA = t1/400: its outputs change on ~1 ms, so t1/200 leaves a truncation of 6e-5
# in order 1, and t1/800 lets the projection's rounding over δ² reach 2e-3 in order 2
# (measured; t1/400: 4e-6 and 5e-4).
T1, DELTA, TOL = 0.2, 1e-3, 1e-12


def _t1_delta(stop: float) -> tuple[float, float]:
    t1 = min(T1, stop / 2)
    return t1, DELTA * t1 / T1 / (1 if t1 == T1 else 2)


def _outputs(model: fs.Model) -> list[str]:
    return [v.name for v in model.md.modelVariables
            if v.causality == "output" and v.type == "Real"]


def _derivatives(inst: fs.Instance, names, order: int) -> tuple[int, list[float]]:
    n = len(names)
    vr = (c_uint * n)(*[inst.model.vr[x] for x in names])
    out = (c_double * n)()
    st = inst.call("fmi2GetRealOutputDerivatives", vr, n, (c_int * n)(*[order] * n), out)
    return st, list(out)


@pytest.mark.parametrize("name", FMUS)
def test_output_derivatives_match_finite_differences(name, load_model, logs):
    model = load_model(name)
    max_order = int(model.md.coSimulation.maxOutputDerivativeOrder)
    names = _outputs(model)
    stop = float(model.md.defaultExperiment.stopTime)
    t1, delta = _t1_delta(stop)
    inst = model.instance(f"{name}_outder")
    try:
        inst.initialize({"solver": fs.SOLVER_DOPRI5}, tol=TOL, stop=stop)
        inst.step(t1 - 2 * delta)
        ys, exact = [], {}
        for k in range(5):
            ys.append(np.array(inst.get_reals(names)))
            if k == 2:
                for order in range(1, max_order + 1):
                    st, d = _derivatives(inst, names, order)
                    assert st == fs.fmi2OK, (name, order)
                    exact[order] = np.array(d)
                # One order above the declared one is refused, with one log line.
                mark = logs.mark()
                st, _ = _derivatives(inst, names[:1], max_order + 1)
                assert st == fs.fmi2Error
                assert len(logs.since(mark, inst.name)) == 1
            if k < 4:
                inst.step(delta)
    finally:
        inst.free()
    if max_order == 0:
        return
    y = np.array(ys)  # rows: t1 − 2δ … t1 + 2δ
    # Richardson-extrapolated central differences (truncation O(δ⁴) ≈ 1e-12 relative for
    # these rates): the residual is the integration's error amplified by 1/δ (order 1) or
    # 1/δ² (order 2), ~1e-12·|y| / 1e-3 and / 1e-6.
    d1 = (8 * (y[3] - y[1]) - (y[4] - y[0])) / (12 * delta)
    d2 = (16 * (y[3] + y[1]) - (y[4] + y[0]) - 30 * y[2]) / (12 * delta**2)
    fd = {1: d1, 2: d2}
    # Constrained systems are projected after every doStep, which moves the state by its
    # drift (≲ 1e-10 here): that over δ (1e-7) and δ² (1e-4) bounds the deviation too.
    for order, bound in ((1, 1e-5), (2, 1e-3)):
        if order > max_order:
            continue
        # Scale per output: the derivative itself, or the output's own size over 1 s (a
        # derivative that vanishes at t1 is compared absolutely against its variable).
        scale = np.maximum(np.abs(exact[order]), np.maximum(np.abs(y[2]), 1e-3))
        err = np.abs(exact[order] - fd[order]) / scale
        worst = int(np.argmax(err))
        print(f"METRIC {name} order {order}: max relative deviation {err[worst]:.1e} "
              f"({names[worst]})")
        assert err[worst] < bound, (name, order, names[worst], exact[order][worst],
                                    fd[order][worst])


def _forced_response(t, u0, u1, u2, m=1.0, k=100.0, c=2.0):
    """x(t) of m ẍ + c ẋ + k x = u0 + u1 t + u2 t²/2 from rest: the augmented linear system
    (x, v, F, Ḟ, F̈) propagated by its matrix exponential."""
    a = np.zeros((5, 5))
    a[0, 1] = 1.0
    a[1, :3] = [-k / m, -c / m, 1.0 / m]
    a[2, 3] = 1.0
    a[3, 4] = 1.0
    z = scipy.linalg.expm(a * t) @ np.array([0.0, 0.0, u0, u1, u2])
    return z[0], z[2]


@pytest.mark.parametrize("solver", [fs.SOLVER_DOPRI5, fs.SOLVER_RK4])
def test_polynomial_input_inside_one_long_step(msd, solver):
    u0, u1, u2 = 0.5, 3.0, -2.0
    inst = msd.instance(f"msd_ramp_{solver}")
    try:
        inst.initialize({"x": 0.0, "v": 0.0, "c": 2.0, "F": u0, "solver": solver,
                         "solver_step": 1e-3}, tol=1e-11)
        vr = (c_uint * 2)(msd.vr["F"], msd.vr["F"])
        inst.ok("fmi2SetRealInputDerivatives", vr, 2, (c_int * 2)(1, 2),
                (c_double * 2)(u1, u2))
        inst.step(1.5)
        x, f = inst.get_reals(["x", "F"])
    finally:
        inst.free()
    x_exact, f_exact = _forced_response(1.5, u0, u1, u2)
    # DOPRI5 at rtol 1e-11 (atol 1e-12 for x) and RK4 with h = 1e-3 on ω = 10 (global error
    # ~ (ωh)⁴ |x| ≈ 1e-10 |x|) are both far inside 1e-8; a held input is off by ~0.02.
    assert abs(x - x_exact) < 1e-8, (x, x_exact)
    # After the step the input is the polynomial's value at its end.
    assert f == pytest.approx(f_exact, rel=1e-15, abs=1e-15)


# A piecewise-linear force, each kink written twice: fmpy makes a repeated time an input
# event, ends a step there and takes the next segment's slope after it. It starts before
# t = 0 because fmpy holds the first value (zero slope) at the table's first time.
KNOTS = [(-1.0, -2.0), (0.0, 0.0), (0.3, 1.5), (0.8, -0.5), (1.2, 0.25), (2.0, 0.25)]


def _table():
    rows = [KNOTS[0]]
    for t, f in KNOTS[1:-1]:
        rows += [(t, f), (t, f)]
    rows.append(KNOTS[-1])
    return np.array(rows, dtype=[("time", np.float64), ("F", np.float64)])


def _piecewise_exact(times, m=1.0, k=100.0, c=2.0, knots=KNOTS):
    """x at `times` for the `knots` force from rest at t = 0: exact per linear segment."""
    a = np.zeros((4, 4))
    a[0, 1] = 1.0
    a[1, :3] = [-k / m, -c / m, 1.0 / m]
    a[2, 3] = 1.0
    knots = [(t, f) for t, f in knots if t >= 0.0]
    out, state, t_state = [], np.zeros(2), 0.0
    seg = 0
    for t in times:
        while seg + 1 < len(knots) and t > knots[seg + 1][0]:
            (ta, fa), (tb, fb) = knots[seg], knots[seg + 1]
            z = scipy.linalg.expm(a * (tb - t_state)) @ np.array(
                [*state, fa + (fb - fa) / (tb - ta) * (t_state - ta), (fb - fa) / (tb - ta)])
            state, t_state, seg = z[:2], tb, seg + 1
        (ta, fa), (tb, fb) = knots[seg], knots[min(seg + 1, len(knots) - 1)]
        slope = (fb - fa) / (tb - ta) if tb > ta else 0.0
        z = scipy.linalg.expm(a * (t - t_state)) @ np.array(
            [*state, fa + slope * (t_state - ta), slope])
        out.append(z[0])
    return np.array(out)


@pytest.fixture
def fmpy_derivative_buffers(monkeypatch):
    """fmpy 0.3.32 sizes its input-derivative buffer for 9 inputs (`(value_type * 9)()` in
    Input.__init__), so `derivatives[:] = d` raises for any other count:
    mbfmu.fmpy_input_derivatives_fix() gives each group of continuous inputs a buffer of its
    own size (what fmpy means to do). Undone after the test (monkeypatch restores the
    original Input.__init__)."""
    import fmpy.simulation as sim

    import mbfmu

    monkeypatch.setattr(sim.Input, "__init__", sim.Input.__init__)
    assert mbfmu.fmpy_input_derivatives_fix()
    assert not mbfmu.fmpy_input_derivatives_fix(), "a second call patches nothing"


def _readme_recipe() -> str:
    """The README's fmpy input-derivative example (its ```python block that calls the fix)."""
    text = (fs.REPO / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    [block] = [b for b in blocks if "fmpy_input_derivatives_fix" in b]
    return block


def test_fmpy_as_pinned_needs_the_fix(msd):
    """fmpy 0.3.32 (tests/requirements.txt) without the fix: the README's ValueError. When a
    new fmpy passes, the README's paragraph about the fix can go."""
    common = dict(start_values={"x": 0.0, "v": 0.0}, stop_time=0.5, output_interval=0.1,
                  input=_table(), output=["x"])
    with pytest.raises(ValueError, match="Can only assign sequence of same size"):
        simulate_fmu(msd.unzipdir, model_description=msd.md, set_input_derivatives=True,
                     **common)


def test_the_readme_recipe_follows_the_input_to_1e12(monkeypatch):
    """The README's block as it stands, on MassSpringDamper (m = 1 kg, k = 100 N/m): every
    output within 1e-12 m of the exact response (measured 1.8e-13); held, off by 1e-2 m."""
    import fmpy.simulation as sim

    monkeypatch.setattr(sim.Input, "__init__", sim.Input.__init__)
    code = _readme_recipe()
    assert '"target/fmu/MassSpringDamper.fmu"' in code
    code = code.replace('"target/fmu/MassSpringDamper.fmu"',
                        repr(str(fs.fmu_file("MassSpringDamper"))))
    fs.ensure_logger()
    scope: dict = {}
    exec(compile(code, "README.md", "exec"), scope)
    r, table = scope["r"], scope["F"]
    knots = [(-1.0, -5.0), (0.0, 0.0), (0.3, 1.5), (0.8, -0.5), (2.0, -0.5)]
    assert np.allclose(np.interp([-1, 0, 0.3, 0.8, 2], table["time"], table["F"]),
                       [f for _, f in knots])
    err = np.max(np.abs(r["x"] - _piecewise_exact(r["time"], knots=knots)))
    print(f"METRIC README recipe: error {err:.1e} m")
    assert len(r["time"]) >= 9 and err < 1e-12
    held = simulate_fmu(str(fs.fmu_file("MassSpringDamper")), input=table,
                        start_values={"x": 0, "v": 0, "c": 2}, relative_tolerance=1e-12,
                        stop_time=2, output_interval=0.25, output=["x"])
    err_held = np.max(np.abs(held["x"] - _piecewise_exact(held["time"], knots=knots)))
    assert 5e-3 < err_held < 2e-2, err_held


@pytest.mark.parametrize("interval", [0.07, 0.25, 0.5])
def test_simulate_fmu_with_input_derivatives_is_exact(msd, interval, fmpy_derivative_buffers):
    common = dict(start_values={"x": 0.0, "v": 0.0, "c": 2.0, "solver": fs.SOLVER_DOPRI5},
                  stop_time=2.0, output_interval=interval, relative_tolerance=1e-11,
                  input=_table(), output=["x"])
    fs.ensure_logger()
    with_d = simulate_fmu(msd.unzipdir, model_description=msd.md, set_input_derivatives=True,
                          **common)
    held = simulate_fmu(msd.unzipdir, model_description=msd.md, **common)
    exact = _piecewise_exact(with_d["time"])
    err = np.max(np.abs(with_d["x"] - exact))
    err_held = np.max(np.abs(held["x"] - _piecewise_exact(held["time"])))
    print(f"METRIC output interval {interval}: error {err:.1e} with input derivatives, "
          f"{err_held:.1e} held")
    # rtol 1e-11 on |x| ≲ 0.02 (atol 1e-12): the integration error over 2 s stays below
    # 1e-9; the hold's error is the input's change over a step times 1/k, ≳ 1e-4 here.
    assert err < 1e-9
    assert err_held > 1e3 * max(err, 1e-12)


def test_time_forced_oscillator_refuses_order_two(load_model, logs):
    """MassSpringDamper with its harmonic forcing on: f reads t, so the states' second
    derivative is refused (one log line); the first stays (ẋ = f)."""
    msd = load_model("MassSpringDamper")
    inst = msd.instance("msd_forced_outder")
    try:
        inst.initialize({"F_amp": 1.0, "solver": fs.SOLVER_DOPRI5}, tol=1e-10, stop=1.0)
        inst.step(0.1)
        st, d = _derivatives(inst, ["x", "E"], 1)
        assert st == fs.fmi2OK and d[0] == inst.get_reals(["v"])[0]
        mark = logs.mark()
        st, _ = _derivatives(inst, ["x"], 2)
        assert st == fs.fmi2Error
        recs = logs.since(mark, inst.name)
        assert len(recs) == 1 and "∂/∂t" in recs[0].message
    finally:
        inst.free()
    assert not math.isnan(d[1])
