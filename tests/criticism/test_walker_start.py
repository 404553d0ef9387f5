"""emcee's starting walkers of the criticism find the support when the Laplace spread is wrong.

Seen in the open-world study (a `discrepancy` candidate whose Hessian had a clipped negative
eigenvalue): walkers drawn at twice a far too wide Laplace spread never had a finite density,
and the whole criticism stopped on a StartError.
"""

import numpy as np
import pytest

from turgorbayes.inference import sampling
from turgorbayes.inference.engine import walker_start


def _ball(radius):
    """Log density finite only within ``radius`` of the origin (a bounded support)."""
    return lambda u: np.where(np.linalg.norm(u, axis=1) < radius, 0.0, -np.inf)


def test_walkers_start_inside_a_small_support_from_a_far_too_wide_covariance():
    # reference: a support of radius 0.5 about the mode and a covariance of sd 100: at a fixed
    # spread a walker lands inside with probability ~1e-10 per draw; shrinking by 0.8 per
    # redraw, the spread falls below 0.1 sd of 100 (10) after ~14 redraws and below 0.005
    # after ~48, where every walker lands inside
    u_map, cov = np.zeros(3), 1e4 * np.eye(3)
    log_prob = _ball(0.5)
    p0 = sampling._initial(log_prob, walker_start(u_map, cov, 12), np.random.default_rng(1), 12)
    assert np.all(np.isfinite(log_prob(p0)))
    assert len(np.unique(p0.round(12), axis=0)) == 12  # distinct walkers, not one point
    # the fixed spread (no shrinking) fails on the same problem: the test can fail
    with pytest.raises(sampling.StartError):
        sampling._initial(log_prob, walker_start(u_map, cov, 12, shrink=1.0),
                          np.random.default_rng(1), 12)


def test_the_first_draw_has_the_full_spread():
    # reference: the first positions are u_map + 2 L z (L the Cholesky factor), so their sd
    # about the mode is twice the Laplace sd
    cov = np.diag([1.0, 4.0])
    init = walker_start(np.array([1.0, -1.0]), cov, 20000)
    p = init(np.random.default_rng(0))
    np.testing.assert_allclose(p.std(axis=0), 2 * np.sqrt(np.diag(cov)), rtol=0.03)
    np.testing.assert_allclose(p.mean(axis=0), [1.0, -1.0], atol=0.1)
