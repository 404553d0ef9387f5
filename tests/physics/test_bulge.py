"""Tests of the liquid-membrane bulge model (docs/physics.md, "Bulge model")."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import integrate

from turgorbayes.physics import bulge

ALPHA = np.pi / 12


@pytest.mark.parametrize("xi", [np.pi / 2 - np.pi / 12, np.pi / 2])
def test_bulge_integral_closed_form_matches_quadrature(xi):
    # Reference: adaptive quadrature of the defining integral I(xi, a).
    for a in np.logspace(-6, 3, 37):
        ref, _ = integrate.quad(
            lambda z, a=a: np.sin(z) ** 2 / np.sqrt(np.sin(z) ** 2 + a), 0, xi, epsabs=0, epsrel=1e-13, limit=200
        )
        assert_allclose(bulge.bulge_integral(xi, a), ref, rtol=1e-9, atol=0)


def test_depth_vanishes_without_force_and_saturates_at_zero_tension():
    # F -> 0: undeformed bulge (h = 0). F -> pi P R_b^2 (sigma_b -> 0): h/R_b -> 1 + cot(alpha),
    # the limit of the three terms (h_global -> R_b, h_dent -> 0, h_cone -> R_b cot alpha).
    assert bulge.reduced_depth(0.0) == 0.0
    assert_allclose(bulge.reduced_depth(np.pi * (1 - 1e-12)), 1 + 1 / np.tan(ALPHA), rtol=1e-5)


def test_reduced_stiffness_in_papers_range_and_monotone():
    # The paper quotes k_b/(P R_b) between 0.35 and 0.38 for F/(P R_b^2) in [0.06, 0.1],
    # i.e. h/R_b from about 0.17 to 0.27 (Deng et al. 2011, supplement; docs/physics.md, "Bulge model").
    f = np.linspace(0.06, 0.1, 41)
    y = bulge.reduced_depth(f)
    assert_allclose([y[0], y[-1]], [0.17, 0.27], atol=0.005)
    k = bulge.reduced_stiffness(y)
    assert np.all((k > 0.35) & (k < 0.38))
    y_wide = np.logspace(-4, 0.6, 300)
    assert np.all(np.diff(bulge.reduced_stiffness(y_wide)) > 0)


def test_point_load_logarithm():
    # Liquid membrane under a point load: P R_b/k_b ~ (1/pi) ln(P R_b^2 / F) as F -> 0, so the
    # slope of P R_b/k_b against ln(1/f) between f = 1e-8 and 1e-6 is 1/pi (within 1%).
    f = np.array([1e-8, 1e-6])
    inv_k = bulge.reduced_depth(f) / f  # P R_b / k_b = (h/R_b)/f
    slope = (inv_k[0] - inv_k[1]) / np.log(f[1] / f[0])
    assert_allclose(slope, 1 / np.pi, rtol=0.01)


def test_reduced_force_inverts_reduced_depth(rng):
    f = np.pi * rng.uniform(1e-6, 0.999, 2000)
    assert_allclose(bulge.reduced_force(bulge.reduced_depth(f)), f, rtol=1e-9)


def test_pressure_round_trip_through_bulge_stiffness(rng):
    # P -> k_b at a given depth (forward model: force F, depth h(F), k_b = F/h) -> P.
    P = rng.uniform(1e3, 5e4, 500)
    R_b = rng.uniform(2e-7, 8e-7, 500)
    F = rng.uniform(0.01, 0.5, 500) * P * R_b**2
    h = bulge.indentation_depth(F, P, R_b)
    assert_allclose(bulge.pressure_from_bulge(F / h, R_b, h), P, rtol=1e-8)


def test_indentation_depth_scales_with_radius():
    # h/R_b depends only on F/(P R_b^2): doubling R_b and quadrupling F doubles h.
    h1 = bulge.indentation_depth(1e-9, 1e4, 5e-7)
    h2 = bulge.indentation_depth(4e-9, 1e4, 1e-6)
    assert_allclose(h2, 2 * h1, rtol=1e-12)


def test_vectorized_broadcasting():
    F = np.linspace(1e-10, 1e-9, 4)[:, None]
    P = np.array([1e4, 2e4, 3e4])[None, :]
    h = bulge.indentation_depth(F, P, 5e-7)
    assert h.shape == (4, 3)
    assert_allclose(h[2, 1], bulge.indentation_depth(F[2, 0], P[0, 1], 5e-7), rtol=1e-14)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"F": 1.0, "P": 1e4, "R_b": 5e-7}, "bulge tension"),
        ({"F": 1e-9, "P": 1e4, "R_b": -5e-7}, "R_b .* > 0"),
        ({"F": 1e-9, "P": 0.0, "R_b": 5e-7}, "P .* > 0"),
        ({"F": -1e-9, "P": 1e4, "R_b": 5e-7}, "F .* >= 0"),
        ({"F": 1e-9, "P": 1e4, "R_b": 5e-7, "alpha": np.pi / 2}, r"alpha .* \(0, pi/2\)"),
        ({"F": 1e-9, "P": 1e4, "R_b": 5e-7, "alpha": 0.0}, r"alpha .* \(0, pi/2\)"),
    ],
)
def test_unphysical_input_raises(kwargs, match):
    with pytest.raises(ValueError, match=match):
        bulge.indentation_depth(**kwargs)


def test_pressure_from_bulge_rejects_depth_beyond_zero_tension():
    with pytest.raises(ValueError, match="1 \\+ cot"):
        bulge.pressure_from_bulge(0.01, 5e-7, 5 * 5e-7)
