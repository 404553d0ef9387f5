"""The per-walker ln-P table of the wall (inference.pressure_grid) against the wall law itself."""

import numpy as np

from turgorbayes import forward, wall
from turgorbayes.inference.pressure_grid import LogPressureGrid


def test_soft_wall_with_a_zero_pressure_radius_is_tabulated(table):
    # gamma < 1: the wall law reaches P = 0 at a finite radius (docs/physics.md, Domain of the
    # wall law). Here (gamma 0.483, p = P0 R0/E0t = 0.044) that radius, s_zero = -0.083, lies
    # between two points of the table's coarse radius scan; the table used to start left of it,
    # in the undefined region, which made the walker's whole table NaN (every cell -inf).
    gamma, E0t, R0 = np.array([0.48306155, 1.22]), np.array([0.05288314, 0.026]), np.array([461.4e-9, 464.2e-9])
    lo, hi = np.log(300.0), np.log(60e3)
    grid = LogPressureGrid(lo, hi, 0.1, gamma, E0t, R0, 5e3, table)
    log_P = np.linspace(np.log(500.0), np.log(40e3), 37)
    ln_R, ln_k = grid(log_P)
    # independent reference: the bracketed root search of wall.radius_at_pressure
    R_ref = wall.radius_at_pressure(np.exp(log_P)[None, :], E0t[:, None], gamma[:, None], R0[:, None])
    _, k_ref = forward.cell_radius_and_stiffness(np.exp(log_P)[None, :], gamma[:, None], E0t[:, None],
                                                  R0[:, None], surrogate=table)
    assert np.isfinite(ln_R).all() and np.isfinite(ln_k).all()
    np.testing.assert_allclose(ln_R, np.log(R_ref), atol=1e-6)
    np.testing.assert_allclose(ln_k, np.log(k_ref), atol=1e-5)
