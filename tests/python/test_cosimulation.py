"""The split two-mass oscillator (issue 16): two MassSpringDamper FMUs coupled by a
spring-damper the master computes (cosim.py), against the monolithic chain's closed form.

Zero-order hold of the coupling force converges like H; its first-order extrapolation from
the FMUs' exact output derivatives (fmi2GetRealOutputDerivatives → fmi2SetRealInputDerivatives)
like H², Jacobi and Gauss–Seidel alike; second order (Jacobi) like H³.

Measured (tol 1e-12, error at t = 2 s, H = 0.02 … 0.0025 s; docs/coupling.md has the table):
fitted orders 1.05 (Jacobi, hold), 1.23 (Gauss–Seidel, hold), 2.00 (Jacobi, order 1),
1.97 (Gauss–Seidel, order 1), 3.14 (Jacobi, order 2). The bounds below leave room for the
pre-asymptotic bend at the coarse end (Gauss–Seidel's hold: 1.4 between 0.02 and 0.01)
while telling the orders apart (an order-1 scheme cannot fit 1.7, an order-2 one 2.7).
"""

from __future__ import annotations

import pytest

import cosim

HS = [0.02, 0.01, 0.005, 0.0025]


@pytest.fixture(scope="module")
def errors(msd):
    runs = {("jacobi", 0), ("jacobi", 1), ("jacobi", 2), ("gauss_seidel", 0),
            ("gauss_seidel", 1)}
    return {key: [cosim.run(msd, h, key[1], key[0]) for h in HS] for key in sorted(runs)}


@pytest.mark.parametrize("scheme", ["jacobi", "gauss_seidel"])
def test_hold_converges_like_h(errors, scheme):
    p = cosim.observed_order(HS, errors[(scheme, 0)])
    print(f"METRIC {scheme} hold: order {p:.2f}, errors {errors[(scheme, 0)]}")
    assert 0.8 < p < 1.6


@pytest.mark.parametrize("scheme", ["jacobi", "gauss_seidel"])
def test_extrapolated_force_converges_like_h_squared(errors, scheme):
    p = cosim.observed_order(HS, errors[(scheme, 1)])
    print(f"METRIC {scheme} order 1: order {p:.2f}, errors {errors[(scheme, 1)]}")
    assert 1.7 < p < 2.5


def test_second_order_extrapolation_converges_like_h_cubed(errors):
    p = cosim.observed_order(HS, errors[("jacobi", 2)])
    print(f"METRIC jacobi order 2: order {p:.2f}, errors {errors[('jacobi', 2)]}")
    assert p > 2.7


@pytest.mark.parametrize("scheme", ["jacobi", "gauss_seidel"])
def test_extrapolation_is_far_more_accurate_at_h_001(errors, scheme):
    i = HS.index(0.01)
    hold, extrapolated = errors[(scheme, 0)][i], errors[(scheme, 1)][i]
    # Measured ratios 18 (Jacobi) and 200 (Gauss–Seidel): an order more in H = 0.01 with
    # error constants of the same size; 10 keeps a margin on the Jacobi one.
    assert extrapolated * 10 < hold, (hold, extrapolated)


def test_fmu_integration_error_is_negligible(msd):
    """The study measures the coupling, not the FMUs' integrators: rtol 1e-13 instead of
    1e-12 changes the finest second-order error (1.9e-8 m) by 4e-6 of itself (measured);
    5 % still tells a coupling error from an integration one."""
    a = cosim.run(msd, HS[-1], 2, "jacobi", tol=1e-12)
    b = cosim.run(msd, HS[-1], 2, "jacobi", tol=1e-13)
    assert abs(a - b) < 0.05 * a, (a, b)
