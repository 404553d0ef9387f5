"""The per-walker ln-P table of the wall (inference.pressure_grid) against the wall law itself."""

import numpy as np

from turgorbayes.inference.pressure_grid import LogPressureGrid, WallGrid
from turgorbayes.physics import forward, wall


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
    R_ref = wall.radius_at_pressure(np.exp(log_P)[None, :], gamma[:, None], E0t[:, None], R0[:, None])
    _, k_ref = forward.cell_radius_and_stiffness(np.exp(log_P)[None, :], gamma[:, None], E0t[:, None],
                                                  R0[:, None], surrogate=table)
    assert np.isfinite(ln_R).all() and np.isfinite(ln_k).all()
    np.testing.assert_allclose(ln_R, np.log(R_ref), atol=1e-6)
    np.testing.assert_allclose(ln_k, np.log(k_ref), atol=1e-5)


def _model(edges, calls):
    """A wall model defined for ln P in [lo_r, hi_r] per row r (ln R_c = ln P / 2)."""
    def point_model(log_P, rows):
        calls.append(np.size(log_P))
        lo, hi = edges[0][rows], edges[1][rows]
        ok = (log_P >= lo) & (log_P <= hi)
        v = np.where(ok, 0.5 * log_P, np.nan)
        return v, v
    return point_model


def test_domain_ends_are_the_model_edges_to_the_bisection_accuracy():
    # Reference: the edges put into the model by hand. The grid (step 0.05 from ln 500 Pa to
    # ln 60 kPa) brackets each edge between two grid points; 20 halvings of that bracket must
    # land within step / 2**20 below a lower edge's complement, i.e. the returned end is the
    # last defined point: lo_found in [lo, lo + step/2**20], hi_found in [hi - step/2**20, hi].
    rng = np.random.default_rng(3)
    a, b = np.log(500.0), np.log(60e3)
    lo = rng.uniform(a + 0.3, a + 1.5, 6)
    hi = rng.uniform(b - 1.5, b - 0.3, 6)
    lo[0], hi[1] = -np.inf, np.inf  # defined to the grid's ends
    calls = []
    grid = WallGrid(a, b, 0.05, _model((lo, hi), calls), (3, 2))
    tol = 0.05 / 2**20
    assert grid.lo[0] == -np.inf and grid.hi[1] == np.inf
    assert np.all((grid.lo[1:] >= lo[1:]) & (grid.lo[1:] <= lo[1:] + tol))
    assert np.all((grid.hi[[0, 2, 3, 4, 5]] <= hi[[0, 2, 3, 4, 5]])
                  & (grid.hi[[0, 2, 3, 4, 5]] >= hi[[0, 2, 3, 4, 5]] - tol))
    # one call for the table, then 20 halvings in 5 calls of 15 points per row and end
    assert len(calls) == 1 + 2 * 5 and calls[1] == 15 * 5
    # queries: inside the domain the model's value, outside NaN
    q = np.array([[lo[2] + 1e-3, hi[2] - 1e-3, lo[2] - 1e-3]] * 3)
    lnR, _ = grid(q)
    assert np.allclose(lnR[1, 0, :2], 0.5 * q[1, :2], rtol=1e-9) and np.isnan(lnR[1, 0, 2])
