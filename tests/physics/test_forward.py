"""Tests of the forward model (turgorbayes.physics.forward).

References: the wall module's bracketed root finder and explicit pressure law
(turgorbayes.physics.wall, itself tested against ODE integration), the gamma = 1 closed form of
docs/physics.md ("Wall law"), the paper's own numbers (Deng et al. 2011, table 1) and the shipped FE
surrogate evaluated through an independent path.
"""

import numpy as np
from numpy.testing import assert_allclose, assert_array_equal

from turgorbayes.physics import forward, wall


def random_walls(rng, n):
    """Wide random parameters: gamma in [0, 3], E0t 1e-3..1 N/m, R0 200..1000 nm, P 0.1-300 kPa."""
    return (np.exp(rng.uniform(np.log(100.0), np.log(300e3), n)), rng.uniform(0, 3, n),
            np.exp(rng.uniform(np.log(1e-3), 0.0, n)), rng.uniform(200e-9, 1000e-9, n))


def test_radius_matches_wall_root_finder(rng):
    # reference: wall.radius_at_pressure (scipy elementwise.find_root on the same law)
    P, g, E0t, R0 = random_walls(rng, 4000)
    g[:20], g[20:40] = 1.0, 0.0  # the closed-form special cases
    fast = forward.radius_at_pressure(P, g, E0t, R0)
    ref = wall.radius_at_pressure(P, g, E0t, R0)
    assert_array_equal(np.isnan(fast), np.isnan(ref))
    assert np.isfinite(ref).sum() > 2500
    ok = np.isfinite(ref)
    assert_allclose(fast[ok], ref[ok], rtol=1e-11)


def test_radius_solves_the_explicit_pressure_law(rng):
    # reference: the explicit P(R_c) of docs/physics.md, "Wall law" (wall.pressure_at_radius)
    P, g, E0t, R0 = random_walls(rng, 2000)
    R = forward.radius_at_pressure(P, g, E0t, R0)
    ok = np.isfinite(R)
    assert_allclose(wall.pressure_at_radius(R[ok], g[ok], E0t[ok], R0[ok]), P[ok], rtol=1e-9)


def test_gamma_one_closed_form():
    # docs/physics.md, "Wall law": gamma -> 1, P/P0 = (R0/R) exp[(E0t/(P0 R0)) (1 - R0/R)]
    P = np.geomspace(500.0, 60e3, 50)
    E0t, R0, P0 = 0.026, 464.2e-9, 5e3
    R = forward.radius_at_pressure(P, 1.0, E0t, R0, P0)
    rho = R0 / R
    assert_allclose(P0 * rho * np.exp(E0t / (P0 * R0) * (1 - rho)), P, rtol=1e-12)


def test_paper_numbers():
    # Deng et al. 2011 (docs/physics.md): with the table's values, R_c(29 kPa) = 540.7 nm,
    # E_par/E_perp = 0.457, P R_c/(E_perp t) = 0.0706 (the paper's self-consistency check)
    t = forward.cell_terms(29e3, 1.22, 0.026, 464.2e-9, surrogate=False)
    assert_allclose(t["R_c"], 540.7e-9, rtol=2e-4)
    assert_allclose(t["ratio"], 0.457, rtol=2e-3)
    assert_allclose(t["x"], 0.0706, rtol=2e-3)


def test_anisotropy_matches_wall(rng):
    # reference: wall.anisotropy (its own radius inversion and modulus formula)
    P, g, E0t, R0 = random_walls(rng, 1000)
    ours = forward.cell_terms(P, g, E0t, R0, surrogate=False)["ratio"]
    ref = wall.anisotropy(P, g, E0t, R0)
    ok = np.isfinite(ref) & np.isfinite(ours)
    assert ok.sum() > 500
    assert_allclose(ours[ok], ref[ok], rtol=1e-10)


def test_unreachable_pressure_is_nan_with_reason():
    # gamma < 1: the wall can bear at most wall.max_pressure; beyond it no radius exists
    E0t, g, R0 = 0.01, 0.5, 500e-9
    P_max = float(wall.max_pressure(g, E0t, R0))
    P = np.array([0.5 * P_max, 1.01 * P_max, 3 * P_max])
    codes, reasons = forward.explain_nan(P, g, E0t, R0, surrogate=False)
    assert_array_equal(codes, [forward.DEFINED, forward.UNREACHABLE_PRESSURE,
                               forward.UNREACHABLE_PRESSURE])
    assert "largest pressure" in reasons[forward.UNREACHABLE_PRESSURE]
    R = forward.radius_at_pressure(P, g, E0t, R0)
    assert np.isfinite(R[0]) and np.isnan(R[1:]).all()


def test_invalid_input_is_nan_with_reason():
    codes, _ = forward.explain_nan(np.array([-1.0, 0.0, np.nan, 5e3]), 1.2, 0.026, 464e-9,
                                   surrogate=False)
    assert_array_equal(codes, [forward.INVALID_INPUT] * 3 + [forward.DEFINED])


def test_stiffness_composes_wall_and_surrogate(table, rng):
    # reference: the same quantities from the wall module's own functions and the table
    P = np.exp(rng.uniform(np.log(1e3), np.log(40e3), 200))
    g, E0t, R0 = 1.22, 0.026, 464.2e-9
    R, k = forward.cell_radius_and_stiffness(P, g, E0t, R0, surrogate=table)
    R_ref = wall.radius_at_pressure(P, g, E0t, R0)
    x = P * R_ref / wall.perp_modulus_times_thickness(P, g, E0t)
    k_ref = table(x, wall.anisotropy(P, g, E0t, R0), warn=False) * P * R_ref
    ok = np.isfinite(k_ref)
    assert ok.sum() > 100
    assert_allclose(R, R_ref, rtol=1e-11)
    assert_allclose(k[ok], k_ref[ok], rtol=1e-9)
    assert_array_equal(np.isnan(k), ~ok)


def test_outside_surrogate_is_nan_with_reason(table):
    # a very stiff, strongly stiffening wall at 100 kPa is barely inflated: x = P R/(E t) far
    # below any tabulated inflation number
    args = (np.array([20e3, 100e3]), np.array([1.22, 2.5]), np.array([0.026, 1.0]), 464e-9)
    x = forward.cell_terms(*args, surrogate=False)["x"]
    assert x[1] < table.domain["x"][0]  # the premise of the test
    codes, reasons = forward.explain_nan(*args, surrogate=table)
    assert_array_equal(codes, [forward.DEFINED, forward.OUTSIDE_SURROGATE])
    assert "surrogate" in reasons[forward.OUTSIDE_SURROGATE]
    R, k = forward.cell_radius_and_stiffness(*args, surrogate=table)
    assert np.isfinite(k[0]) and np.isnan(k[1]) and np.isfinite(R[1])


def test_buckled_region_is_nan_with_its_own_reason(table):
    # Reference: the wall's (x, ratio) without the table, and the table's buckled box. A wall
    # stiffening with gamma = 2 from E0t = 0.02 N/m reaches x ~ 0.43 at 0.6 kPa (inside the
    # box), x ~ 0.1 at 10 kPa (outside).
    args = (np.array([0.6e3, 10e3]), 2.0, 0.02, 464.2e-9)
    t = forward.cell_terms(*args, surrogate=False)
    (x0, x1), (r0, r1) = table.buckled_boxes[0]["x"], table.buckled_boxes[0]["ratio"]
    inside = (t["x"] >= x0) & (t["x"] <= x1) & (t["ratio"] >= r0) & (t["ratio"] <= r1)
    assert list(inside) == [True, False]  # the premise of the test
    codes, reasons = forward.explain_nan(*args, surrogate=table)
    assert_array_equal(codes, [forward.BUCKLED, forward.DEFINED])
    assert "buckles under the tip" in reasons[forward.BUCKLED]
    R, k = forward.cell_radius_and_stiffness(*args, surrogate=table)
    assert np.isnan(k[0]) and np.isfinite(R[0]) and np.isfinite(k[1])


def test_broadcasts_per_cell_parameters(table, rng):
    # per-cell R0 and E0t arrays (walkers x cells x nodes) equal element-by-element calls
    P = np.exp(rng.uniform(np.log(2e3), np.log(30e3), (1, 5, 3)))
    R0 = rng.uniform(440e-9, 490e-9, (4, 5, 1))
    E0t = rng.uniform(0.02, 0.03, (4, 1, 1))
    R, k = forward.cell_radius_and_stiffness(P, 1.1, E0t, R0, surrogate=table)
    assert R.shape == (4, 5, 3)
    for idx in [(0, 0, 0), (3, 4, 2), (2, 1, 1)]:
        r1, k1 = forward.cell_radius_and_stiffness(P[0, idx[1], idx[2]], 1.1, E0t[idx[0], 0, 0],
                                                   R0[idx[0], idx[1], 0], surrogate=table)
        assert_allclose([R[idx], k[idx]], [r1, k1], rtol=1e-12)


def test_stiffness_from_wall_is_the_surrogate_times_PR(table):
    # reference: the table called directly at x = P R_c/(E_perp t), times P R_c
    P, R, Et = np.array([10e3, 20e3, 30e3, 20e3]), np.full(4, 500e-9), np.array([0.1, 0.1, 0.1, 50.0])
    ratio = np.array([0.5, 0.6, np.nan, 0.6])
    t = forward.stiffness_from_wall(P, R, Et, ratio, table)
    x = P * R / Et
    assert_allclose(t["x"], x, rtol=1e-15)
    assert_allclose(t["k_c"][:2], table(x[:2], ratio[:2], warn=False) * P[:2] * R[:2], rtol=1e-14)
    assert_allclose(t["k_over_PR"][:2], table(x[:2], ratio[:2], warn=False), rtol=1e-14)
    # NaN anisotropy: invalid input; x = 2e-4, far below the table: outside the surrogate
    assert x[3] < table.domain["x"][0]
    assert_array_equal(t["reason"], [forward.DEFINED, forward.DEFINED, forward.INVALID_INPUT,
                                     forward.OUTSIDE_SURROGATE])
    assert np.isnan(t["k_c"][2:]).all()
