"""Tests of the stress-stiffening wall model (docs/physics.md, "Wall law", "Anisotropy")."""

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal
from scipy import integrate, optimize

from turgorbayes.physics import wall

# The paper's table (Deng et al. 2011, table 1; turgorbayes.physics.parameters.PUBLISHED).
E0T, GAMMA, R0, P0 = 0.026, 1.22, 464.2e-9, 5e3


def test_papers_self_consistency():
    # Deng et al. 2011 (docs/physics.md): with the published values, R_c(29 kPa) = 540.7 nm,
    # E_par/E_perp = 0.457, E_perp = 49.3 MPa, E_par = 22.5 MPa at t = 4.5 nm.
    P, t = 29e3, 4.5e-9
    R_c = wall.radius_at_pressure(P, GAMMA, E0T, R0)
    ratio = wall.anisotropy(P, GAMMA, E0T, R0)
    E_perp = wall.perp_modulus_times_thickness(P, GAMMA, E0T) / t
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

    P_end = min(30e3, 0.9 * float(wall.max_pressure(gamma, E0T, R0)))
    P_eval = np.linspace(P0, P_end, 7)
    sol = integrate.solve_ivp(rhs, (P0, P_end), [R0], t_eval=P_eval, rtol=1e-11, atol=1e-22)
    assert_allclose(wall.radius_at_pressure(P_eval, gamma, E0T, R0), sol.y[0], rtol=1e-7)


@pytest.mark.parametrize("gamma", [0.3, 0.8, 1.0, 1.22, 2.5])
def test_round_trips(gamma, rng):
    P = rng.uniform(500, 0.99 * min(1e5, float(wall.max_pressure(gamma, E0T, R0))), 300)
    R = wall.radius_at_pressure(P, gamma, E0T, R0)
    assert_allclose(wall.pressure_at_radius(R, gamma, E0T, R0), P, rtol=1e-8)
    assert_allclose(wall.radius_at_pressure(wall.pressure_at_radius(R, gamma, E0T, R0), gamma, E0T, R0), R, rtol=1e-8)


def test_continuous_through_gamma_one():
    # The closed form has (gamma - 1) in a denominator; the exponential limit must join it.
    P = np.array([1e3, 5e3, 29e3])
    r = [wall.radius_at_pressure(P, g, E0T, R0) for g in (1 - 1e-6, 1.0, 1 + 1e-6)]
    assert_allclose(r[0], r[1], rtol=1e-6)
    assert_allclose(r[2], r[1], rtol=1e-6)
    # and the gamma = 1 branch is the paper's exponential form exactly
    rho = R0 / r[1]
    assert_allclose(P0 * rho * np.exp(E0T / (P0 * R0) * (1 - rho)), P, rtol=1e-10)
    a = [wall.anisotropy(P, g, E0T, R0) for g in (1 - 1e-6, 1.0, 1 + 1e-6)]
    assert_allclose(a[0], a[1], rtol=1e-5)
    assert_allclose(a[2], a[1], rtol=1e-5)


@pytest.mark.parametrize("gamma", [0.0, 0.8, 1.0, 1.22])
def test_anisotropy_from_half_tension_pressure(gamma):
    # Independent route: E_par is the modulus at the axial tension P R/2, i.e. at the pressure
    # P' whose circumferential tension equals P R/2: E_par/E_perp = (P'/P)^gamma.
    P = 20e3
    R = wall.radius_at_pressure(P, gamma, E0T, R0)
    P_half = optimize.brentq(
        lambda q: q * wall.radius_at_pressure(q, gamma, E0T, R0) - P * R / 2, 1.0, P, xtol=1e-12, rtol=1e-14
    )
    assert_allclose(wall.anisotropy(P, gamma, E0T, R0), (P_half / P) ** gamma, rtol=1e-8)


def test_pressure_maximum_for_gamma_below_one():
    gamma = 0.8
    # Brute force: the largest pressure along a fine radius grid.
    R = np.linspace(R0, 10 * R0, 200001)
    P = wall.pressure_at_radius(R, gamma, E0T, R0)
    P_max = wall.max_pressure(gamma, E0T, R0)
    assert_allclose(P_max, np.nanmax(P), rtol=1e-8)
    assert_allclose(wall.max_radius(gamma, E0T, R0), R[np.nanargmax(P)], rtol=1e-4)
    assert np.isfinite(wall.radius_at_pressure(0.999 * P_max, gamma, E0T, R0))
    assert np.isnan(wall.radius_at_pressure(1.001 * P_max, gamma, E0T, R0))
    with pytest.raises(ValueError, match="exceeds the largest pressure"):
        wall.radius_at_pressure([1e3, 1.001 * P_max], gamma, E0T, R0, errors="raise")


def test_radius_saturates_for_gamma_above_one():
    # p = P0 R0/(E0 t) = 0.0893 and gamma = 1.22 give gamma p/(gamma-1) = 0.495 < 1: R_max =
    # R0 (1 - 0.495)^(-1/1.22), approached but never exceeded as P grows.
    p = P0 * R0 / E0T
    R_max = R0 * (1 - GAMMA * p / (GAMMA - 1)) ** (-1 / GAMMA)
    assert_allclose(wall.max_radius(GAMMA, E0T, R0), R_max, rtol=1e-12)
    assert np.isinf(wall.max_pressure(GAMMA, E0T, R0))
    R = wall.radius_at_pressure(np.array([1e5, 1e9, 1e15]), GAMMA, E0T, R0)
    assert np.all(np.diff(R) > 0) and np.all(R < R_max)
    assert_allclose(R[-1], R_max, rtol=5e-3)
    assert np.isnan(wall.pressure_at_radius(1.01 * R_max, GAMMA, E0T, R0))


def test_broadcasting_over_parameters():
    P = np.array([5e3, 29e3])[:, None]
    R0s = np.array([450e-9, 464.2e-9, 480e-9])[None, :]
    R = wall.radius_at_pressure(P, GAMMA, E0T, R0s)
    assert R.shape == (2, 3)
    assert_allclose(R[0], R0s[0], rtol=1e-12)  # R(P0) = R0 by definition


@pytest.mark.parametrize(
    ("args", "match"),
    [
        ((-1.0, GAMMA, E0T, R0), "P must be"),
        ((1e4, GAMMA, 0.0, R0), "E0t must be"),
        ((1e4, -0.1, E0T, R0), "gamma .* >= 0"),
        ((1e4, GAMMA, E0T, -R0), "R0 must be"),
    ],
)
def test_bad_parameters_raise(args, match):
    with pytest.raises(ValueError, match=match):
        wall.radius_at_pressure(*args)


# --------------------------------------------------------------------------- the kernel
# Reference throughout: the wall law of docs/physics.md ("Wall law") written out directly with
# numpy powers (gamma != 1) or the exp form (gamma = 1), independent of the log1p/expm1 kernel.


def explicit_log_pressure(s, p, gamma):
    """ln(P/P0) = ln[rho B^(1/(1-gamma))], B = 1 + (gamma-1)(rho^gamma - 1)/(gamma p)."""
    rho = np.exp(-s)
    if gamma == 1:
        return np.log(rho) + (1 - rho) / p
    B = 1 + (gamma - 1) * (rho**gamma - 1) / (gamma * p)
    with np.errstate(invalid="ignore"):
        return np.log(rho) + np.log(B) / (1 - gamma)


def explicit_reduced_modulus(sigma, p, gamma):
    """E_hat(sigma) = sigma^gamma [1 - p gamma (sigma^(1-gamma) - 1)/(1-gamma)]."""
    if gamma == 1:
        return sigma * (1 - p * np.log(sigma))
    return sigma**gamma * (1 - p * gamma * (sigma ** (1 - gamma) - 1) / (1 - gamma))


@pytest.mark.parametrize("gamma", [0.3, 0.8, 1.0, 1.0 + 1e-9, 1.22, 2.5])
@pytest.mark.parametrize("p", [0.02, 0.0893, 0.7, 3.0])
def test_kernel_pressure_matches_explicit_law(gamma, p):
    s = np.linspace(-0.4, 0.4, 81)
    # gamma = 1 + 1e-9: the explicit power form loses ~1e-7 to cancellation; the kernel must
    # instead be continuous with the gamma = 1 exp form (they differ by O(1e-9) relative/p^2)
    near_one = gamma == 1.0 + 1e-9
    g_ref, tol = (1.0, {"rtol": 1e-7, "atol": 1e-8}) if near_one else (gamma, {"rtol": 1e-12, "atol": 1e-13})
    ref = explicit_log_pressure(s, p, g_ref)
    log_p, slope = wall.log_pressure_and_slope(s, p, gamma)
    ok = np.isfinite(ref)
    assert_array_equal(np.isfinite(log_p), ok)
    assert_allclose(log_p[ok], ref[ok], **tol)
    assert_array_equal(wall.log_pressure_ratio(s, p, gamma), log_p)
    assert_allclose(wall.log_tension_ratio(s, p, gamma)[ok], (ref + s)[ok], **tol)
    # slope: central difference of the explicit law
    h = 1e-6
    fd = (explicit_log_pressure(s + h, p, g_ref) - explicit_log_pressure(s - h, p, g_ref)) / (2 * h)
    good = ok & np.isfinite(fd)
    assert_allclose(slope[good], fd[good], rtol=1e-6, atol=1e-6)


def test_kernel_is_finite_at_gamma_zero():
    # gamma -> 0: E_perp t = E0t (Hookean), ln(P/P0) = -s + s/p (d(PR) = E0t dR/R from P0 R0)
    s = np.linspace(-0.3, 0.3, 13)
    p = 0.4
    log_p, slope = wall.log_pressure_and_slope(s, p, 0.0)
    assert_allclose(log_p, -s + np.log1p(s / p), rtol=1e-12, atol=1e-15)
    assert_allclose(slope, -1 + 1 / (p + s), rtol=1e-12)


@pytest.mark.parametrize("gamma", [0.0, 0.5, 1.0, 1.22])
def test_kernel_strain_inverts_tension(gamma):
    # reference: log_tension_ratio (the forward law) composed with its inverse is the identity
    p, s = 0.3, np.linspace(-0.2, 0.3, 11)
    tau = np.exp(wall.log_tension_ratio(s, p, gamma))
    assert_allclose(wall.strain_at_tension(tau, p, gamma), s, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("gamma", [0.0, 0.5, 1.0, 1.5])
def test_kernel_branch_end_is_the_pressure_maximum(gamma):
    # p = 0.7 >= (gamma-1)/gamma: no saturation; the end is where the explicit law peaks
    p = 0.7
    s_end, log_p_max = wall.reduced_branch_end(np.array(p), np.array(gamma))
    s = np.linspace(float(s_end) - 0.2, float(s_end) + 0.2, 40001)
    ref = explicit_log_pressure(s, p, gamma) if gamma > 0 else -s + np.log1p(s / p)
    assert_allclose(s_end, s[np.nanargmax(ref)], atol=2e-5)
    assert_allclose(log_p_max, np.nanmax(ref), rtol=1e-9)


def test_kernel_branch_end_saturates():
    # gamma p < gamma - 1: the bracket vanishes at rho^gamma = 1 - gamma p/(gamma - 1)
    p, gamma = 0.1, 2.0
    s_end, log_p_max = wall.reduced_branch_end(np.array(p), np.array(gamma))
    assert_allclose(s_end, -np.log(1 - gamma * p / (gamma - 1)) / gamma, rtol=1e-14)
    assert np.isinf(log_p_max)


@pytest.mark.parametrize("gamma", [0.0, 0.6, 1.0, 1.22, 2.0])
def test_kernel_anisotropy_matches_explicit_modulus(gamma):
    p, sigma = 0.09, np.linspace(0.5, 6.0, 12)
    ref = explicit_reduced_modulus(sigma / 2, p, gamma) / explicit_reduced_modulus(sigma, p, gamma)
    ok = ref > 0
    assert_allclose(wall.anisotropy_at_tension(np.log(sigma), p, gamma)[ok], ref[ok], rtol=1e-12)


def test_ratio_helpers():
    # log1p(z)/z and expm1(z)/z: numpy directly away from 0, the limit 1 at 0
    z = np.array([-0.5, -1e-3, 1e-3, 0.7, 5.0])
    assert_allclose(wall.log1p_ratio(z), np.log1p(z) / z, rtol=1e-15)
    assert_allclose(wall.expm1_ratio(z), np.expm1(z) / z, rtol=1e-15)
    assert wall.log1p_ratio(0.0) == 1.0 and wall.expm1_ratio(0.0) == 1.0
    assert_allclose(wall.log1p_ratio(1e-10), 1 - 5e-11, rtol=1e-15)
