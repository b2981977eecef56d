"""Rheonomic FMUs through fmpy (issue 14, systems.md §13): RotatingHoopBead and
PulledPendulum. The Jacobian comes from fmi2GetDirectionalDerivative; the closed forms are
written here, never in the models.
"""

from __future__ import annotations

import numpy as np
import pytest
from fmpy.fmi2 import fmi2Discard, fmi2LastSuccessfulTime

import fmu_support as fs
from test_nonlinear_bicycle import Instance, state_jacobian

G, R = 9.81, 0.5


@pytest.mark.parametrize("omega", [3.0, 6.0])
def test_bead_keeps_h_while_the_drive_does_work(load_model, omega):
    """h constant to 1e-9 relative over 20 s while E changes; ΔE = ∫ torque·Ω dt
    (trapezoid on the 1 ms output grid)."""
    model = load_model("RotatingHoopBead")
    res = fs.simulate(model, {"Omega": omega, "theta": 0.5, "phi_dot": omega}, tol=1e-12,
                      stop_time=20.0, output_interval=1e-3,
                      outputs=["theta", "phi", "E", "h", "torque"])
    t, e, h = res["time"], res["E"], res["h"]
    drift = np.max(np.abs(h - h[0])) / abs(h[0])
    work = np.concatenate([[0.0], np.cumsum(np.diff(t) * 0.5 * (res["torque"][1:] + res["torque"][:-1]) * omega)])
    balance = np.max(np.abs(e - e[0] - work))
    print(f"Omega={omega}: h drift {drift:.1e}, E range {np.ptp(e):.3e} J, balance {balance:.1e} J")
    assert drift < 1e-9
    assert np.ptp(e) > 1e-2
    assert balance < 1e-5 * np.ptp(e)
    assert np.max(np.abs(res["phi"] - omega * t)) < 1e-9


@pytest.mark.parametrize("omega", [3.0, 6.0])
def test_bead_bottom_eigenvalues_from_the_fmu_jacobian(omega):
    inst = Instance("RotatingHoopBead", {"Omega": omega, "theta": 0.0, "theta_dot": 0.0,
                                          "phi_dot": omega})
    try:
        a, _, _ = state_jacobian(inst)
        eig = np.linalg.eigvals(a)
        k = G / R - omega**2
        want = [1j * np.sqrt(k), -1j * np.sqrt(k)] if k > 0 else [np.sqrt(-k), -np.sqrt(-k)]
        for w in want:
            assert np.min(np.abs(eig - w)) < 1e-12, (eig, w)
    finally:
        inst.close()


def test_bead_rests_at_theta_star_and_oscillates_about_it_at_the_closed_form_frequency():
    omega = 6.0
    star = np.arccos(G / (R * omega**2))
    inst = Instance("RotatingHoopBead", {"theta": star, "theta_dot": 0.0}, tolerance=1e-12)
    try:
        a, _, _ = state_jacobian(inst)
        freq = np.sqrt(omega**2 - G**2 / (R**2 * omega**2))
        assert np.min(np.abs(np.linalg.eigvals(a) - 1j * freq)) < 1e-12
        t = 0.0
        for _ in range(200):
            inst.fmu.doStep(t, 0.1)
            t += 0.1
        (theta,) = inst.get("theta")
        assert abs(theta - star) < 1e-10, theta - star
    finally:
        inst.close()


def test_start_time_other_than_zero_puts_the_hoop_at_omega_t0(load_model):
    """setupExperiment(startTime=1.5): φ = Ω t0, φ̇ = Ω after initialisation; l = l0 + l_rate t0."""
    inst = load_model("RotatingHoopBead").instance("t0-bead").initialize({"theta": 0.4}, start=1.5)
    try:
        phi, phi_dot, theta = inst.get_reals(["phi", "phi_dot", "theta"])
        assert theta == 0.4 and abs(phi - 6.0 * 1.5) < 1e-13 and abs(phi_dot - 6.0) < 1e-13
        inst.step(0.5)
        assert abs(inst.get("phi") - 6.0 * 2.0) < 1e-9
    finally:
        inst.free()
    inst = load_model("PulledPendulum").instance("t0-pp").initialize({}, start=2.0)
    try:
        r, r_dot, l = inst.get_reals(["r", "r_dot", "l"])
        assert abs(r - 0.9) < 1e-13 and abs(r_dot + 0.05) < 1e-15 and abs(l - 0.9) < 1e-15
    finally:
        inst.free()


def test_pulled_pendulum_tension_and_power_balance(load_model):
    model = load_model("PulledPendulum")
    res = fs.simulate(model, {"theta": 0.3}, tol=1e-12, stop_time=10.0, output_interval=1e-3,
                      outputs=["theta", "theta_dot", "l", "E", "tension"])
    th, thd, l = res["theta"], res["theta_dot"], res["l"]
    tension = 1.0 * (G * np.cos(th) + l * thd**2)
    assert np.max(np.abs(res["tension"] - tension)) < 1e-12 * np.max(np.abs(tension))
    t, e = res["time"], res["E"]
    power = -res["tension"] * -0.05
    work = np.concatenate([[0.0], np.cumsum(np.diff(t) * 0.5 * (power[1:] + power[:-1]))])
    balance = np.max(np.abs(e - e[0] - work))
    print(f"pulled pendulum: E range {np.ptp(e):.3e} J, balance {balance:.1e} J")
    assert balance < 1e-5 * np.ptp(e)


def test_pulled_pendulum_stops_with_discard_before_l_reaches_zero(load_model, logs):
    """l = 1 − 0.05 t reaches 0.01 m at t = 19.8 s: fmi2Discard there, with a message naming
    the time, and no NaN."""
    inst = load_model("PulledPendulum").instance("discard-pp").initialize({})
    try:
        mark = logs.mark()
        status = None
        for _ in range(30):
            status = inst.do_step(1.0)
            if status != 0:
                break
        assert status == fmi2Discard, status
        st, when = inst.real_status(fmi2LastSuccessfulTime)
        assert abs(when - 19.8) < 1e-6, when
        assert all(np.isfinite(inst.get_reals(["theta", "theta_dot", "r", "tension"])))
        messages = [r.message for r in logs.since(mark, "discard-pp")]
        assert any("19.8" in m for m in messages), messages
    finally:
        inst.free()
