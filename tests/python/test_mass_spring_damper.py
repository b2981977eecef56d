"""MassSpringDamper against its closed-form solutions.

Error measure: max over the output grid of |FMU - exact|, divided by max |exact| of the
same signal (x and v separately), i.e. an error relative to the amplitude.
"""

from __future__ import annotations

import numpy as np
import pytest

import fmu_support as fs
from closed_form import msd_exact

SCENES = list(fs.MSD_SCENES)

# DOPRI5 at relative tolerance 1e-10: the local error per step is held to ~1e-10 of the
# state; over 10 s (~16 periods, >= 1e4 steps since the maximum step is solver_step =
# 1e-3) the global error can accumulate to a few hundred local errors.  1e-7 of the
# amplitude leaves a margin of ~1000x over tol while still catching any real mistake
# (a wrong coefficient, a wrong forcing phase, a lost half step are all >> 1e-6).
DOPRI_TOL = 1e-10
DOPRI_BOUND = 1e-7

# Classical RK4 at h = 1e-3: global error ~ N (w h)^5 / 120 = 1e4 * 1e-10 / 120 = 8.3e-9 of
# the amplitude for w = 10 rad/s over 10 s; the overdamped fast root (-47.9 1/s) gives
# ~2e-8 on v (measured with an independent Python RK4: max 2.03e-8).  Bound 5e-8.
RK4_BOUND = 5e-8
# FMU RK4 vs a reference RK4 written here (same method, same h): differences come only from
# floating-point evaluation order, accumulated over 1e4 steps: ~1e-13; bound 1e-10 (still
# 100x below the difference between h = 1e-3 and h = 5e-4).
RK4_SAME_METHOD_BOUND = 1e-10


def rel_err(got, want):
    return float(np.max(np.abs(np.asarray(got) - want)) / np.max(np.abs(want)))


def exact(scene, t):
    return msd_exact(t, **fs.scene_values("MassSpringDamper", scene))


@pytest.mark.parametrize("scene", SCENES)
def test_dopri5_matches_closed_form(msd, scene):
    res = fs.simulate(msd, fs.scene_values(msd.name, scene), solver=fs.SOLVER_DOPRI5,
                      tol=DOPRI_TOL, output_interval=1e-2)
    t = res["time"]
    assert t[0] == 0.0 and abs(t[-1] - 10.0) < 1e-12 and len(t) == 1001
    x, v = exact(scene, t)
    ex, ev = rel_err(res["x"], x), rel_err(res["v"], v)
    print(f"METRIC msd dopri5 {scene}: rel err x={ex:.3e} v={ev:.3e}")
    assert np.all(np.isfinite(res["x"])) and np.all(np.isfinite(res["v"]))
    assert ex < DOPRI_BOUND, f"{scene}: x error {ex:.3e} of amplitude"
    assert ev < DOPRI_BOUND, f"{scene}: v error {ev:.3e} of amplitude"


def _reference_rk4(p, h, n_sub, n_out):
    def f(t, y):
        force = p["F"] + p["F_amp"] * np.sin(p["F_omega"] * t)
        return np.array([y[1], (force - p["c"] * y[1] - p["k"] * y[0]) / p["m"]])

    y = np.array([p["x"], p["v"]])
    out = [y.copy()]
    t = 0.0
    for _ in range(n_out):
        for _ in range(n_sub):
            k1 = f(t, y)
            k2 = f(t + h / 2, y + h / 2 * k1)
            k3 = f(t + h / 2, y + h / 2 * k2)
            k4 = f(t + h, y + h * k3)
            y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            t = t + h
        out.append(y.copy())
    return np.array(out)


@pytest.mark.parametrize("scene", SCENES)
def test_rk4_matches_closed_form(msd, scene):
    sv = fs.scene_values(msd.name, scene)
    res = fs.simulate(msd, sv, solver=fs.SOLVER_RK4, solver_step=1e-3, tol=DOPRI_TOL,
                      output_interval=1e-2)
    t = res["time"]
    x, v = exact(scene, t)
    ex, ev = rel_err(res["x"], x), rel_err(res["v"], v)
    ref = _reference_rk4(sv, 1e-3, 10, len(t) - 1)
    sx, sv_ = rel_err(res["x"], ref[:, 0]), rel_err(res["v"], ref[:, 1])
    print(f"METRIC msd rk4 {scene}: rel err vs exact x={ex:.3e} v={ev:.3e}; "
          f"vs reference RK4 x={sx:.3e} v={sv_:.3e}")
    assert ex < RK4_BOUND and ev < RK4_BOUND, (ex, ev)
    assert sx < RK4_SAME_METHOD_BOUND and sv_ < RK4_SAME_METHOD_BOUND, (
        f"FMU RK4 differs from classical RK4 with h=1e-3 by {sx:.3e}/{sv_:.3e}")


def test_rk4_and_dopri5_are_different_methods(msd):
    """The solver switch must have an effect (guards against `solver` being ignored)."""
    sv = fs.scene_values(msd.name, "free")
    a = fs.simulate(msd, sv, solver=fs.SOLVER_RK4, solver_step=1e-2, stop_time=2.0)
    b = fs.simulate(msd, sv, solver=fs.SOLVER_DOPRI5, solver_step=1e-2, stop_time=2.0)
    # RK4 with h = 1e-2 (w h = 0.1): phase error ~ 200 * 1e-5 / 120 = 1.7e-5 of the amplitude,
    # DOPRI5 at 1e-10 is ~1e-9: they must differ by > 1e-6 relative.
    d = rel_err(a["x"], b["x"])
    print(f"METRIC msd rk4(h=1e-2) vs dopri5 difference: {d:.3e}")
    assert d > 1e-6


def test_free_energy_conserved(msd):
    res = fs.simulate(msd, fs.scene_values(msd.name, "free"), tol=DOPRI_TOL, output_interval=1e-2)
    E = res["E"]
    E0 = 0.5 * 100.0 * 0.1**2
    assert E[0] == pytest.approx(E0, rel=1e-15)
    drift = float(np.max(np.abs(E - E0)) / E0)
    print(f"METRIC msd free energy drift: {drift:.3e}")
    # DOPRI5 at rtol 1e-10 is not symplectic: the energy drifts with the accumulated
    # amplitude error (~1e-9 here); 1e-8 relative is the contract's bound.
    assert drift < 1e-8


@pytest.mark.parametrize("scene", SCENES)
def test_energy_output_formula(msd, scene):
    """E = 1/2 m v^2 + 1/2 k x^2 at every output point (pure evaluation: rounding only, 1e-13)."""
    sv = fs.scene_values(msd.name, scene)
    res = fs.simulate(msd, sv, tol=1e-8, output_interval=0.1)
    E = 0.5 * sv["m"] * res["v"] ** 2 + 0.5 * sv["k"] * res["x"] ** 2
    scale = max(float(np.max(np.abs(E))), 1e-300)
    assert float(np.max(np.abs(res["E"] - E))) / scale < 1e-13


# ---------------------------------------------------------------------------------------
# Communication-step independence
# ---------------------------------------------------------------------------------------


def _uneven_steps(stop=10.0, seed=1234):
    """Uneven communication steps that land (to within an ulp) on many multiples of 0.1,
    sometimes skip one, and include very small (1e-7 s) and large (0.3 s) steps."""
    rng = np.random.default_rng(seed)
    steps = []
    t = 0.0
    k = 0
    while k < round(stop / 0.1):
        jump = 3 if rng.random() < 0.1 else (2 if rng.random() < 0.2 else 1)
        k = min(k + jump, round(stop / 0.1))
        target = k * 0.1
        n = int(rng.integers(1, 5))
        span = target - t
        fr = np.sort(rng.random(n - 1)) if n > 1 else np.array([])
        cuts = [t + span * f for f in fr]
        if n > 2 and rng.random() < 0.5:
            cuts[0] = t + 1e-7  # a tiny step
        for c in cuts:
            if c > t:
                steps.append(c - t)
                t = t + (c - t)
        steps.append(target - t)
        t = t + (target - t)
    return steps


def _at(times, values, grid):
    """values at the grid times (times equal within 1e-12 s); NaN where absent."""
    out = np.full(len(grid), np.nan)
    j = np.searchsorted(times, grid - 1e-12)
    for i, (g, jj) in enumerate(zip(grid, j)):
        if jj < len(times) and abs(times[jj] - g) < 1e-12:
            out[i] = values[jj]
    return out


@pytest.mark.parametrize("scene", ["damped", "resonance"])
def test_communication_step_independence(msd, scene):
    sv = fs.scene_values(msd.name, scene)
    grid = np.arange(101) * 0.1
    runs = {}
    for dt in (1e-3, 1e-2, 0.1):
        res = fs.simulate(msd, sv, tol=DOPRI_TOL, output_interval=dt)
        runs[f"dt={dt}"] = (res["time"], res["x"], res["v"])
    steps = _uneven_steps()
    assert min(steps) > 0
    t, vals = fs.run_steps(msd, sv, steps, tol=DOPRI_TOL, names=["x", "v"])
    runs["uneven"] = (t, vals[:, 0], vals[:, 1])
    assert abs(t[-1] - 10.0) < 1e-12

    x_ref, v_ref = exact(scene, grid)
    ax, av = np.max(np.abs(x_ref)), np.max(np.abs(v_ref))
    ref_name = "dt=0.01"
    rx = _at(runs[ref_name][0], runs[ref_name][1], grid)
    rv = _at(runs[ref_name][0], runs[ref_name][2], grid)
    assert not np.any(np.isnan(rx))
    worst = {}
    for name, (tt, x, v) in runs.items():
        gx, gv = _at(tt, x, grid), _at(tt, v, grid)
        common = ~np.isnan(gx)
        assert common.sum() >= 50, f"{name}: only {common.sum()} common times"
        dx = float(np.max(np.abs(gx[common] - rx[common])) / ax)
        dv = float(np.max(np.abs(gv[common] - rv[common])) / av)
        worst[name] = (dx, dv)
    print(f"METRIC msd step-independence {scene}: " +
          ", ".join(f"{k}: x {a:.2e} v {b:.2e}" for k, (a, b) in worst.items()))
    # The contract: agreement within ~10x the tolerance (relative to the amplitude).
    for name, (dx, dv) in worst.items():
        assert dx < 10 * DOPRI_TOL and dv < 10 * DOPRI_TOL, f"{name}: {dx:.3e} / {dv:.3e}"


def test_rk4_fixed_step_independent_of_communication_step(msd):
    """RK4 with solver_step 1e-3: communication steps 1e-2 and 0.1 are both multiples of the
    internal step, so the results at common times must agree to rounding (1e-12 relative)."""
    sv = fs.scene_values(msd.name, "damped")
    a = fs.simulate(msd, sv, solver=fs.SOLVER_RK4, output_interval=1e-2)
    b = fs.simulate(msd, sv, solver=fs.SOLVER_RK4, output_interval=0.1)
    grid = np.arange(101) * 0.1
    xa, xb = _at(a["time"], a["x"], grid), _at(b["time"], b["x"], grid)
    d = float(np.nanmax(np.abs(xa - xb)) / np.nanmax(np.abs(xa)))
    print(f"METRIC msd rk4 dt=0.01 vs dt=0.1: {d:.3e}")
    assert d < 1e-12


def test_lands_exactly_on_t_plus_h(msd, instances):
    inst = instances(msd, "msd_land").initialize(fs.scene_values(msd.name, "damped"))
    t = 0.0
    for h in (0.1, 1e-3, 0.07, 1e-9, 0.3333333333333333, 2.5):
        assert inst.do_step(h, t) == fs.fmi2OK
        t = t + h
        st, last = inst.real_status()
        assert st == fs.fmi2OK
        assert last == t, f"lastSuccessfulTime {last!r} != t + h = {t!r}"
    # and the next step from exactly that time is accepted
    assert inst.do_step(0.01, t) == fs.fmi2OK


def test_input_force_is_used(msd, instances):
    """Setting F between steps changes the trajectory as the closed form says (step scene
    from rest with F applied only from t = 1: x(t) = step response shifted by 1 s)."""
    sv = fs.scene_values(msd.name, "step")
    sv_rest = dict(sv, F=0.0)
    inst = instances(msd, "msd_input").initialize(sv_rest, tol=DOPRI_TOL)
    for _ in range(100):
        inst.step(0.01)
    assert inst.get_reals(["x", "v"]) == [0.0, 0.0]
    inst.set(F=1.0)
    xs, ts = [], []
    for _ in range(300):
        inst.step(0.01)
        ts.append(inst.t)
        xs.append(inst.get("x"))
    x, _ = exact("step", np.array(ts) - 1.0)
    e = rel_err(xs, x)
    print(f"METRIC msd input F applied at t=1: rel err {e:.3e}")
    assert e < DOPRI_BOUND


def test_tolerance_from_setup_experiment_or_default_experiment(msd):
    """DOPRI5's tolerance: fmi2SetupExperiment's when toleranceDefined, else the
    DefaultExperiment's (1e-8).  With a large maximum step (solver_step = 0.1) the step-size
    control is what limits accuracy, so the tolerance must show in the results:
    - no tolerance given  == tolerance 1e-8 given, bit for bit;
    - tolerance 1e-4 gives a different (and less accurate) trajectory."""
    sv = fs.scene_values(msd.name, "damped")
    steps = [0.05] * 200
    kw = dict(names=["x", "v"], solver_step=0.1)
    t, undefined = fs.run_steps(msd, sv, steps, tol=None, **kw)
    _, tight = fs.run_steps(msd, sv, steps, tol=1e-8, **kw)
    _, loose = fs.run_steps(msd, sv, steps, tol=1e-4, **kw)
    x, _ = exact("damped", t)
    e_def, e_tight, e_loose = (rel_err(r[:, 0], x) for r in (undefined, tight, loose))
    print(f"METRIC msd tolerance: undefined {e_def:.3e}, 1e-8 {e_tight:.3e}, 1e-4 {e_loose:.3e}")
    assert np.array_equal(undefined, tight), "without toleranceDefined the DefaultExperiment tolerance 1e-8 must be used"
    assert not np.array_equal(loose, tight)
    assert e_loose > e_tight


def test_solver_step_only_sets_the_fixed_step(msd):
    """solver_step is RK4's step; DOPRI5 chooses its own steps, so it must not care."""
    sv = fs.scene_values(msd.name, "damped")
    steps = [0.5] * 20
    _, big = fs.run_steps(msd, sv, steps, tol=1e-6, solver_step=0.5, names=["x", "v"])
    _, small = fs.run_steps(msd, sv, steps, tol=1e-6, solver_step=1e-3, names=["x", "v"])
    assert np.array_equal(big, small)
    # RK4 does: h = 0.5 on w = 10 rad/s is past its stability limit (h w = 5 > 2.83).
    t, rk_small = fs.run_steps(msd, sv, steps[:2], tol=1e-6, solver_step=1e-3, names=["x"],
                               solver=fs.SOLVER_RK4)
    x, _ = exact("damped", t)
    assert rel_err(rk_small[:, 0], x) < 1e-8
