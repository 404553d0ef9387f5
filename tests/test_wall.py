"""Tests of the stress-stiffening wall model (SCIENCE.md sections 3-4)."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import integrate, optimize

from turgorbayes import wall

# The paper's table (SCIENCE.md section 6).
E0T, GAMMA, R0, P0 = 0.026, 1.22, 464.2e-9, 5e3


def test_papers_self_consistency():
    # SCIENCE.md section 6: with the published values, R_c(29 kPa) = 540.7 nm,
    # E_par/E_perp = 0.457, E_perp = 49.3 MPa, E_par = 22.5 MPa at t = 4.5 nm.
    P, t = 29e3, 4.5e-9
    R_c = wall.radius_at_pressure(P, E0T, GAMMA, R0)
    ratio = wall.anisotropy(P, E0T, GAMMA, R0)
    E_perp = wall.perp_modulus_times_thickness(P, E0T, GAMMA) / t
    assert_allclose(R_c, 540.7e-9, rtol=2e-3)
    assert_allclose(ratio, 0.457, rtol=2e-3)
    assert_allclose(E_perp, 49.3e6, rtol=2e-3)
    assert_allclose(ratio * E_perp, 22.5e6, rtol=2e-3)


@pytest.mark.parametrize("gamma", [0.0, 0.5, 0.8, 1.0, 1.22, 2.0])
def test_radius_matches_integrated_ode(gamma):
    # Independent route: integrate the defining ODE E_perp t dR/R = d(P R) with
    # E_perp t = E0t (P/P0)^gamma, i.e. dR/dP = R^2 / (E_perp t - P R), from R(P0) = R0.
    def rhs(P, R):
        return R**2 / (E0T * (P / P0) ** gamma - P * R)

    P_end = min(30e3, 0.9 * float(wall.max_pressure(E0T, gamma, R0)))
    P_eval = np.linspace(P0, P_end, 7)
    sol = integrate.solve_ivp(rhs, (P0, P_end), [R0], t_eval=P_eval, rtol=1e-11, atol=1e-22)
    assert_allclose(wall.radius_at_pressure(P_eval, E0T, gamma, R0), sol.y[0], rtol=1e-7)


@pytest.mark.parametrize("gamma", [0.3, 0.8, 1.0, 1.22, 2.5])
def test_round_trips(gamma, rng):
    P = rng.uniform(500, 0.99 * min(1e5, float(wall.max_pressure(E0T, gamma, R0))), 300)
    R = wall.radius_at_pressure(P, E0T, gamma, R0)
    assert_allclose(wall.pressure_at_radius(R, E0T, gamma, R0), P, rtol=1e-8)
    assert_allclose(wall.radius_at_pressure(wall.pressure_at_radius(R, E0T, gamma, R0), E0T, gamma, R0), R, rtol=1e-8)


def test_continuous_through_gamma_one():
    # The closed form has (gamma - 1) in a denominator; the exponential limit must join it.
    P = np.array([1e3, 5e3, 29e3])
    r = [wall.radius_at_pressure(P, E0T, g, R0) for g in (1 - 1e-6, 1.0, 1 + 1e-6)]
    assert_allclose(r[0], r[1], rtol=1e-6)
    assert_allclose(r[2], r[1], rtol=1e-6)
    # and the gamma = 1 branch is the paper's exponential form exactly
    rho = R0 / r[1]
    assert_allclose(P0 * rho * np.exp(E0T / (P0 * R0) * (1 - rho)), P, rtol=1e-10)
    a = [wall.anisotropy(P, E0T, g, R0) for g in (1 - 1e-6, 1.0, 1 + 1e-6)]
    assert_allclose(a[0], a[1], rtol=1e-5)
    assert_allclose(a[2], a[1], rtol=1e-5)


@pytest.mark.parametrize("gamma", [0.0, 0.8, 1.0, 1.22])
def test_anisotropy_from_half_tension_pressure(gamma):
    # Independent route: E_par is the modulus at the axial tension P R/2, i.e. at the pressure
    # P' whose circumferential tension equals P R/2: E_par/E_perp = (P'/P)^gamma.
    P = 20e3
    R = wall.radius_at_pressure(P, E0T, gamma, R0)
    P_half = optimize.brentq(
        lambda q: q * wall.radius_at_pressure(q, E0T, gamma, R0) - P * R / 2, 1.0, P, xtol=1e-12, rtol=1e-14
    )
    assert_allclose(wall.anisotropy(P, E0T, gamma, R0), (P_half / P) ** gamma, rtol=1e-8)


def test_pressure_maximum_for_gamma_below_one():
    gamma = 0.8
    # Brute force: the largest pressure along a fine radius grid.
    R = np.linspace(R0, 10 * R0, 200001)
    P = wall.pressure_at_radius(R, E0T, gamma, R0)
    P_max = wall.max_pressure(E0T, gamma, R0)
    assert_allclose(P_max, np.nanmax(P), rtol=1e-8)
    assert_allclose(wall.max_radius(E0T, gamma, R0), R[np.nanargmax(P)], rtol=1e-4)
    assert np.isfinite(wall.radius_at_pressure(0.999 * P_max, E0T, gamma, R0))
    assert np.isnan(wall.radius_at_pressure(1.001 * P_max, E0T, gamma, R0))
    with pytest.raises(ValueError, match="exceeds the largest pressure"):
        wall.radius_at_pressure([1e3, 1.001 * P_max], E0T, gamma, R0, errors="raise")


def test_radius_saturates_for_gamma_above_one():
    # p = P0 R0/(E0 t) = 0.0893 and gamma = 1.22 give gamma p/(gamma-1) = 0.495 < 1: R_max =
    # R0 (1 - 0.495)^(-1/1.22), approached but never exceeded as P grows.
    p = P0 * R0 / E0T
    R_max = R0 * (1 - GAMMA * p / (GAMMA - 1)) ** (-1 / GAMMA)
    assert_allclose(wall.max_radius(E0T, GAMMA, R0), R_max, rtol=1e-12)
    assert np.isinf(wall.max_pressure(E0T, GAMMA, R0))
    R = wall.radius_at_pressure(np.array([1e5, 1e9, 1e15]), E0T, GAMMA, R0)
    assert np.all(np.diff(R) > 0) and np.all(R < R_max)
    assert_allclose(R[-1], R_max, rtol=5e-3)
    assert np.isnan(wall.pressure_at_radius(1.01 * R_max, E0T, GAMMA, R0))


def test_broadcasting_over_parameters():
    P = np.array([5e3, 29e3])[:, None]
    R0s = np.array([450e-9, 464.2e-9, 480e-9])[None, :]
    R = wall.radius_at_pressure(P, E0T, GAMMA, R0s)
    assert R.shape == (2, 3)
    assert_allclose(R[0], R0s[0], rtol=1e-12)  # R(P0) = R0 by definition


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((-1.0, E0T, GAMMA, R0), "P must be"),
        ((1e4, 0.0, GAMMA, R0), "E0t must be"),
        ((1e4, E0T, -0.1, R0), "gamma .* >= 0"),
        ((1e4, E0T, GAMMA, -R0), "R0 must be"),
    ],
)
def test_bad_parameters_raise(args, match):
    with pytest.raises(ValueError, match=match):
        wall.radius_at_pressure(*args)
