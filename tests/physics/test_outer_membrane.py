"""Tests of the PG + outer-membrane envelope (turgorbayes.physics.outer_membrane, docs/outer_membrane.md)."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import integrate, optimize
from scipy.special import lambertw

from turgorbayes.physics import outer_membrane as om
from turgorbayes.physics import wall

# The paper's table (Deng et al. 2011, table 1; turgorbayes.physics.parameters.PUBLISHED).
E0T, GAMMA, R0, P0 = 0.026, 1.22, 464.2e-9, 5e3


def _paper_E_hat(tau, p, gamma):
    """The paper's reduced modulus (supplement, 'Anisotropy of the elastic modulus'), written
    directly from its formula: tau^gamma [1 - p gamma (tau^(1-gamma) - 1)/(1 - gamma)]."""
    if gamma == 1.0:
        return tau * (1 - p * np.log(tau))
    return tau**gamma * (1 - p * gamma / (1 - gamma) * (tau ** (1 - gamma) - 1))


def _ode_reference(gamma, E0t, Y_om, s_max, s_min=-0.12):
    """Dense solve_ivp integration of the constitutive laws, independent of the closed forms.

    Circumferential: dT_pg/ds = E0t E_hat(T_pg/(P0 R0)), T_pg(0) = P0 R0; dT_om/ds = Y_om,
    T_om(0) = 0. Returns a function s -> P(s) = (T_pg + T_om)/(R0 e^s).
    """
    A = P0 * R0
    p = A / E0t

    def rhs(s, T):
        return [E0t * _paper_E_hat(T[0] / A, p, gamma), Y_om]

    kw = {"rtol": 1e-12, "atol": 1e-20, "dense_output": True, "method": "DOP853"}
    up = integrate.solve_ivp(rhs, (0.0, s_max), [A, 0.0], **kw)
    down = integrate.solve_ivp(rhs, (0.0, s_min), [A, 0.0], **kw)

    def pressure(s):
        sol = up if s >= 0 else down
        T = sol.sol(s)
        return (T[0] + T[1]) / (R0 * np.exp(s))

    return pressure


def _axial_reference(gamma, E0t, Y_om, sigma_c_half):
    """Axial PG tension by integrating d tau/d eps = E_hat(tau)/p from tau(0) = 1/2 and finding the
    strain where tau + y eps equals the axial load (PR/2)/(P0 R0) with brentq on the dense solution."""
    A = P0 * R0
    p, y = A / E0t, Y_om / A

    def rhs(eps, tau):
        return [_paper_E_hat(tau[0], p, gamma) / p]

    span = (0.0, 0.5) if sigma_c_half > 0.5 else (0.0, -0.15)
    sol = integrate.solve_ivp(rhs, span, [0.5], rtol=1e-12, atol=1e-14, dense_output=True, method="DOP853")
    if sigma_c_half == 0.5:
        return 0.5
    eps = optimize.brentq(lambda e: sol.sol(e)[0] + y * e - sigma_c_half, 0.0, span[1], xtol=1e-15)
    return float(sol.sol(eps)[0])


@pytest.mark.parametrize("gamma", [0.0, 0.5, 0.8, 1.0, 1.22, 2.0])
def test_no_outer_membrane_reproduces_wall(gamma):
    # Y_om = 0 must be turgorbayes.physics.wall (the paper's model) to 1e-8: radius, anisotropy, E_perp t,
    # the explicit pressure and the largest reachable pressure.
    P = np.geomspace(300.0, 1e5, 41)
    R_wall = wall.radius_at_pressure(P, gamma, E0T, R0)
    assert_allclose(om.radius_at_pressure(P, gamma, E0T, R0, 0.0), R_wall, rtol=1e-8, equal_nan=True)
    assert_allclose(
        om.anisotropy(P, gamma, E0T, R0, 0.0), wall.anisotropy(P, gamma, E0T, R0), rtol=1e-8, equal_nan=True
    )
    ok = np.isfinite(R_wall)
    assert_allclose(
        om.perp_modulus_times_thickness(P[ok], gamma, E0T, R0, 0.0),
        wall.perp_modulus_times_thickness(P[ok], gamma, E0T),
        rtol=1e-8,
    )
    R = np.linspace(0.9, 1.15, 11) * R0
    assert_allclose(
        om.pressure_at_radius(R, gamma, E0T, R0, 0.0),
        wall.pressure_at_radius(R, gamma, E0T, R0),
        rtol=1e-12,
        equal_nan=True,
    )
    assert_allclose(om.max_pressure(gamma, E0T, R0, 0.0), wall.max_pressure(gamma, E0T, R0), rtol=1e-10)


def test_small_outer_membrane_is_continuous_with_none():
    P = np.array([1e3, 5e3, 29e3])
    for f in (om.radius_at_pressure, om.anisotropy, om.perp_modulus_times_thickness):
        assert_allclose(f(P, GAMMA, E0T, R0, 1e-12), f(P, GAMMA, E0T, R0, 0.0), rtol=1e-9)


@pytest.mark.parametrize("Y_om", [0.005, 0.026, 0.1])
def test_constant_moduli_lambert_w_closed_form(Y_om):
    # gamma = 0: both layers have constant moduli, so d(PR)/d ln R = E0t + Y_om = B and
    # P R = P0 R0 + B ln(R/R0) (derived by hand in docs/outer_membrane.md). Its inverse is
    # R = -(B/P) W0(-(P R0/B) exp(-P0 R0/B)), the pressure maximum (W argument -1/e) is
    # P_max = (B/R0) exp(P0 R0/B - 1); the moduli are E_perp t = E_par t = B, anisotropy 1.
    A, B = P0 * R0, E0T + Y_om
    P_max = B / R0 * np.exp(A / B - 1)
    assert_allclose(om.max_pressure(0.0, E0T, R0, Y_om), P_max, rtol=1e-10)
    P = np.geomspace(200.0, 0.999 * P_max, 25)
    R_exact = -(B / P) * lambertw(-(P * R0 / B) * np.exp(-A / B), 0).real
    assert_allclose(om.radius_at_pressure(P, 0.0, E0T, R0, Y_om), R_exact, rtol=1e-11)
    assert_allclose(om.pressure_at_radius(R_exact, 0.0, E0T, R0, Y_om), P, rtol=1e-11)
    assert_allclose(om.anisotropy(P, 0.0, E0T, R0, Y_om), 1.0, rtol=1e-12)
    assert_allclose(om.perp_modulus_times_thickness(P, 0.0, E0T, R0, Y_om), B, rtol=1e-12)
    # beyond the pressure maximum the model cannot hold the pressure: NaN, or an error on request
    assert np.isnan(om.radius_at_pressure(1.001 * P_max, 0.0, E0T, R0, Y_om))
    with pytest.raises(ValueError, match=r"exceeds the largest pressure .* Y_om = "):
        om.radius_at_pressure(1.001 * P_max, 0.0, E0T, R0, Y_om, errors="raise")


@pytest.mark.parametrize(("gamma", "Y_om"), [(1.22, 0.013), (1.22, 0.052), (0.8, 0.026), (1.0, 0.04), (0.5, 0.01)])
def test_radius_matches_dense_ode_integration(gamma, Y_om):
    # Independent route: integrate the constitutive ODEs (PG stiffening with its own tension via
    # the paper's E_hat, linear OM) with DOP853 at rtol 1e-12, then invert P(s) with brentq.
    pressure = _ode_reference(gamma, E0T, Y_om, s_max=0.6)
    for s in (-0.1, -0.05, 0.03, 0.1, 0.2):
        assert_allclose(om.pressure_at_radius(R0 * np.exp(s), gamma, E0T, R0, Y_om), pressure(s), rtol=1e-9)
    P = np.array([800.0, 3e3, 5e3, 12e3, 29e3])
    s_ref = [optimize.brentq(lambda s, t=t: pressure(s) - t, -0.12, 0.6, xtol=1e-14) for t in P]
    assert_allclose(om.radius_at_pressure(P, gamma, E0T, R0, Y_om), R0 * np.exp(s_ref), rtol=1e-9)


@pytest.mark.parametrize(("gamma", "Y_om"), [(1.22, 0.013), (1.22, 0.052), (0.8, 0.026), (1.0, 0.04)])
def test_anisotropy_matches_axial_ode_integration(gamma, Y_om):
    # Axial load P R/2 shared by the PG (tension integrated from its law from 1/2 at the reference)
    # and the OM (Y_om times the common axial strain); the moduli are E0t E_hat(tau) + Y_om.
    p = P0 * R0 / E0T
    P = np.array([1e3, 5e3, 20e3, 29e3])
    R = om.radius_at_pressure(P, gamma, E0T, R0, Y_om)
    pressure = _ode_reference(gamma, E0T, Y_om, s_max=0.25)
    expected = []
    for Pi, Ri in zip(P, R, strict=True):
        s = np.log(Ri / R0)
        # the circumferential PG tension from the ODE solution: total minus the OM's Y_om s
        tau_perp = (pressure(s) * Ri - Y_om * s) / (P0 * R0)
        tau_par = _axial_reference(gamma, E0T, Y_om, Pi * Ri / (2 * P0 * R0))
        E_par = E0T * _paper_E_hat(tau_par, p, gamma) + Y_om
        E_perp = E0T * _paper_E_hat(tau_perp, p, gamma) + Y_om
        expected.append(E_par / E_perp)
    assert_allclose(om.anisotropy(P, gamma, E0T, R0, Y_om), expected, rtol=1e-8)


def test_outer_membrane_tension_fraction_from_definition():
    # f = Y_om ln(R/R0)/(P R) by the OM law; zero at P0 (stress-free reference), negative below.
    P = np.array([2e3, 5e3, 29e3])
    Y = 0.026
    R = om.radius_at_pressure(P, GAMMA, E0T, R0, Y)
    f = om.outer_membrane_tension_fraction(P, GAMMA, E0T, R0, Y)
    assert_allclose(f, Y * np.log(R / R0) / (P * R), rtol=1e-12, atol=1e-15)
    assert f[0] < 0 < f[2]
    assert_allclose(f[1], 0.0, atol=1e-12)


def test_stiffer_envelope_expands_less():
    # A parallel layer adds stiffness: between P0 and 29 kPa the radius must grow less the larger
    # Y_om (d ln R/dP = 1/(E_perp t_tot - P R) > 0 shrinks as E_perp t_tot grows).
    Y = np.array([0.0, 0.01, 0.03, 0.1])
    R = om.radius_at_pressure(29e3, GAMMA, E0T, R0, Y)
    assert np.all(np.diff(R) < 0) and np.all(R > R0)


def test_saturating_pg_keeps_every_pressure_reachable():
    # gamma = 1.22, p = 0.089: the PG radius saturates (gamma p < gamma - 1) at
    # R_max = R0 (1 - gamma p/(gamma - 1))^(-1/gamma) < e R0, so P -> infinity there with or
    # without the OM; the envelope radius stays below R_max.
    p = P0 * R0 / E0T
    R_max = R0 * (1 - GAMMA * p / (GAMMA - 1)) ** (-1 / GAMMA)
    assert np.isinf(om.max_pressure(GAMMA, E0T, R0, 0.03))
    R = om.radius_at_pressure(np.array([1e5, 1e7]), GAMMA, E0T, R0, 0.03)
    assert np.all(R < R_max) and np.all(np.isfinite(R))


def test_broadcasting_matches_elementwise_loop(rng):
    E = rng.uniform(0.015, 0.04, (5, 1))
    g = rng.uniform(0.6, 1.6, (5, 1))
    R = rng.uniform(430e-9, 500e-9, (5, 1))
    Y = rng.uniform(0.0, 0.06, (5, 1))
    P = np.geomspace(1e3, 3e4, 7)
    for f in (om.radius_at_pressure, om.anisotropy, om.perp_modulus_times_thickness):
        grid = f(P, g, E, R, Y)
        assert grid.shape == (5, 7)
        loop = np.array([[f(Pj, g[i, 0], E[i, 0], R[i, 0], Y[i, 0]) for Pj in P] for i in range(5)])
        assert_allclose(grid, loop, rtol=1e-13)
    # per-cell R0 arrays (the radius_spread effect): shape (walkers, cells, nodes)
    R_nodes = R[:, :, None] * np.array([0.97, 1.0, 1.03])
    out = om.radius_at_pressure(P[None, :, None], g[:, :, None], E[:, :, None], R_nodes, Y[:, :, None])
    assert out.shape == (5, 7, 3)
    assert_allclose(out[..., 1], om.radius_at_pressure(P, g, E, R, Y), rtol=1e-13)
    assert_allclose(out[0, 0, 2], om.radius_at_pressure(P[0], g[0, 0], E[0, 0], 1.03 * R[0, 0], Y[0, 0]), rtol=1e-13)


def test_bad_input_messages():
    with pytest.raises(ValueError, match=r"Y_om .* must be finite and >= 0 N/m, got -0.01"):
        om.radius_at_pressure(1e4, GAMMA, E0T, R0, -0.01)
    with pytest.raises(ValueError, match=r"P must be finite and > 0 Pa, got -5.0"):
        om.radius_at_pressure([1e4, -5.0], GAMMA, E0T, R0, 0.01)
    with pytest.raises(ValueError, match=r"E0t must be finite and > 0 N/m"):
        om.anisotropy(1e4, GAMMA, 0.0, R0, 0.01)
    with pytest.raises(ValueError, match=r"errors must be 'nan' or 'raise', got 'ignore'"):
        om.radius_at_pressure(1e4, GAMMA, E0T, R0, 0.01, errors="ignore")


@pytest.mark.parametrize("gamma", [0.3, 0.8, 1.0, 1.05])
@pytest.mark.parametrize("Y_om", [0.003, 0.2])
def test_max_pressure_is_the_peak_of_the_explicit_curve(gamma, Y_om):
    # Brute force: the largest value of the explicit P(R) on a dense strain grid (step 1e-5) must be
    # max_pressure (these cases peak beyond the PG's own maximum or beyond s = 1, the scan path).
    s = np.linspace(-0.5, 4.0, 450_001)
    P = om.pressure_at_radius(R0 * np.exp(s), gamma, E0T, R0, Y_om)
    assert_allclose(om.max_pressure(gamma, E0T, R0, Y_om), np.nanmax(P), rtol=1e-9)
    # and just below it the radius is on the rising branch (left of the peak)
    i = np.nanargmax(P)
    R_below = om.radius_at_pressure(0.999 * P[i], gamma, E0T, R0, Y_om)
    assert np.log(R_below / R0) < s[i]


def test_envelope_at_pressure_equals_the_separate_functions(rng):
    P = np.geomspace(800.0, 3e4, 9)[:, None]
    g, Y = rng.uniform(0.6, 1.5, 4), rng.uniform(0.0, 0.05, 4)
    R_c, E_perp_t, ratio = om.envelope_at_pressure(P, g, E0T, R0, Y)
    assert_allclose(R_c, om.radius_at_pressure(P, g, E0T, R0, Y), rtol=1e-14)
    assert_allclose(E_perp_t, om.perp_modulus_times_thickness(P, g, E0T, R0, Y), rtol=1e-14)
    assert_allclose(ratio, om.anisotropy(P, g, E0T, R0, Y), rtol=1e-14)
    # and with Y_om = 0 the paper's model (turgorbayes.physics.wall) for all three
    R_c, E_perp_t, ratio = om.envelope_at_pressure(P, g, E0T, R0, 0.0)
    assert_allclose(R_c, wall.radius_at_pressure(P, g, E0T, R0), rtol=1e-8)
    assert_allclose(E_perp_t, wall.perp_modulus_times_thickness(P, g, E0T), rtol=1e-8)
    assert_allclose(ratio, wall.anisotropy(P, g, E0T, R0), rtol=1e-8)
