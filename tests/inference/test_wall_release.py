"""A condition's wall released from the reference's (turgorbayes.inference.wall_release).

References: the forward model itself evaluated at the solution (the method rests on the
released wall predicting the very radius and stiffness the shared wall predicted: the data
cannot tell them apart), the identity at a zero-width prior, and a closed form of the weight
where the forward model is linear in the unknowns.
"""

import numpy as np
import pytest

from turgorbayes.inference import conditions, wall_release
from turgorbayes.physics import forward
from turgorbayes.simulation import cells as synthetic

TRUTH = synthetic.PAPER_TRUTH


def _draws(n=200, seed=0):
    rng = np.random.default_rng(seed)
    return {"P": 29e3 * np.exp(0.05 * rng.standard_normal(n)),
            "R0": TRUTH.R0 * (1 + 0.01 * rng.standard_normal(n)),
            "gamma": TRUTH.gamma + 0.05 * rng.standard_normal(n),
            "E0t": TRUTH.E0t * np.exp(0.03 * rng.standard_normal(n))}


def test_released_wall_predicts_the_same_radius_and_stiffness(table):
    # reference: the forward model at the shared wall and at the released one (two direct
    # evaluations); the released wall differs (drawn from the prior), the prediction does not
    v = _draws()
    out = wall_release.release(v, conditions.WALL_PRIOR, np.random.default_rng(1), TRUTH.P0,
                               table)
    ok = np.isfinite(out["log_weight"])
    assert ok.mean() > 0.9, out["failed"]
    before = forward.cell_radius_and_stiffness(v["P"], v["gamma"], v["E0t"], v["R0"], TRUTH.P0,
                                               table)
    after = forward.cell_radius_and_stiffness(out["P"], out["gamma"], out["E0t"], out["R0"],
                                              TRUTH.P0, table)
    for b, a in zip(before, after, strict=True):
        np.testing.assert_allclose(a[ok], b[ok], rtol=1e-7)
    # the wall did move: the E0t ratios are the prior's lognormal (sd of the log 0.35)
    assert np.std(np.log(out["E0t"] / v["E0t"])) == pytest.approx(0.35, rel=0.15)
    assert np.max(np.abs(out["P"][ok] / v["P"][ok] - 1)) > 0.1


def test_a_zero_difference_is_the_identity(table):
    # reference: with a prior of (numerically) zero width the wall is the reference's, the
    # solve returns the draw itself and every weight is 1 (log 0)
    v = _draws(50)
    out = wall_release.release(v, {"E0t": 1e-12, "gamma": 1e-12}, np.random.default_rng(2),
                               TRUTH.P0, table)
    np.testing.assert_allclose(out["P"], v["P"], rtol=1e-8)
    np.testing.assert_allclose(out["R0"], v["R0"], rtol=1e-8)
    np.testing.assert_allclose(out["log_weight"], 0.0, atol=1e-5)


def test_a_wall_that_cannot_produce_the_draw_gets_no_weight(table):
    # reference: the priors' supports; a turgor pushed outside [1, 200] kPa is impossible
    v = _draws(50)
    narrow = {"P": (28e3, 30e3), "R0": wall_release.PRIOR_BOUNDS["R0"]}
    out = wall_release.release(v, {"E0t": 0.35}, np.random.default_rng(3), TRUTH.P0, table,
                               prior_bounds=narrow)
    outside = ~np.isfinite(out["log_weight"])
    assert outside.sum() == out["failed"] > 0
    inside = ~outside
    assert np.all((out["P"][inside] >= 28e3) & (out["P"][inside] <= 30e3))
