"""Tests of turgorbayes.criticism.stacking (model averaging of the criticism's models).

References: the stacking optimum of two models found independently by root finding on the
derivative of the log score; the moments and median of a two-component normal mixture.
"""

import numpy as np
from numpy.testing import assert_allclose
from scipy import optimize, stats

from turgorbayes.criticism import stacking
from turgorbayes.workflows.fit import SUMMARY_PARAMETERS


def _loo(elpd_i):
    e = np.asarray(elpd_i, float)
    return {"elpd_i": e, "elpd": e.sum(), "se": np.sqrt(e.size * e.var()), "p_loo": 4.0,
            "good_k": 0.7, "n_bad": 0}


def test_two_model_weights_match_the_root_of_the_log_score_derivative():
    # Reference: for two models the stacking weight w of model a maximizes
    # sum_i ln(w p_a,i + (1 - w) p_b,i); its derivative sum_i (p_a - p_b)/(w p_a + (1-w) p_b)
    # vanishes there (scipy.optimize.brentq, independent of ArviZ's constrained optimizer).
    rng = np.random.default_rng(3)
    la = rng.normal(-1.0, 0.6, 114)
    lb = la + rng.normal(0.0, 0.8, 114)  # better on some cells, worse on others
    pa, pb = np.exp(la), np.exp(lb)
    w_ref = optimize.brentq(lambda w: np.sum((pa - pb) / (w * pa + (1 - w) * pb)), 1e-9, 1 - 1e-9)
    w = stacking.stacking_weights({"a": _loo(la), "b": _loo(lb)})
    assert 0.05 < w_ref < 0.95  # an interior optimum, so the test can tell
    assert_allclose(w["a"], w_ref, atol=2e-3)
    assert_allclose(w["a"] + w["b"], 1.0, atol=1e-12)


def test_a_model_better_on_every_cell_takes_all_the_weight():
    # Reference: if p_a > p_b on every cell, the log score rises with w up to w = 1.
    la = np.full(50, -1.0)
    w = stacking.stacking_weights({"b": _loo(la - 0.5), "a": _loo(la)})
    assert list(w) == ["b", "a"]  # the order of the input
    assert w["a"] > 0.99


class _FakePosterior:
    """Equal-weight draws of every shared parameter from one normal distribution (SI)."""

    def __init__(self, loc, n, seed):
        self.x = np.random.default_rng(seed).normal(loc, 1.0, n)
        self.weights = np.full(n, 1.0 / n)

    def physical(self, rng):
        return {name: self.x * unit for name, (_, unit) in SUMMARY_PARAMETERS.items()}


def test_model_average_is_the_weighted_mixture():
    # Reference: mixture 0.3 N(0, 1) + 0.7 N(10, 1): mean 7 (exactly the weighted mean of the
    # two samples), sd sqrt(1 + 0.3 * 0.7 * 100), median m with 0.3 Phi(m) + 0.7 Phi(m - 10)
    # = 1/2, i.e. m = 10 + Phi^-1(0.2 / 0.7) up to Phi(m) ~ 1.
    posts = {"a": _FakePosterior(0.0, 40000, 1), "b": _FakePosterior(10.0, 20000, 2)}
    out = stacking.stacked_summary(posts, {"a": 0.3, "b": 0.7}, np.random.default_rng(0))
    assert set(out) == {key for key, _ in SUMMARY_PARAMETERS.values()}
    e = out["P_phys_kPa"]
    assert_allclose(e["mean"], 0.3 * posts["a"].x.mean() + 0.7 * posts["b"].x.mean(), rtol=1e-12)
    assert_allclose(e["sd"], np.sqrt(1 + 0.21 * 100), rtol=0.01)
    assert_allclose(e["q50"], 10 + stats.norm.ppf(0.2 / 0.7), atol=0.03)
    # a model with zero weight contributes nothing
    only_b = stacking.stacked_summary(posts, {"a": 0.0, "b": 1.0}, np.random.default_rng(0))
    assert_allclose(only_b["gamma"]["mean"], posts["b"].x.mean(), rtol=1e-12)


def test_single_model_gets_weight_one():
    assert stacking.stacking_weights({"a": _loo(np.full(10, -1.0))}) == {"a": 1.0}


def test_weighted_quantiles_are_the_quantiles_of_the_repeated_draws():
    # reference: numpy.quantile (method "inverted_cdf", the inverse empirical CDF) of the draws
    # repeated in proportion to their integer weights; equal weights are the draws themselves
    from turgorbayes.criticism.stacking import weighted_quantiles

    rng = np.random.default_rng(3)
    x = rng.normal(size=400)
    qs = [0.05, 0.16, 0.5, 0.84, 0.95]
    assert_allclose(weighted_quantiles(x, np.ones(400), qs),
                    np.quantile(x, qs, method="inverted_cdf"), rtol=1e-12)
    counts = rng.integers(1, 4, 400)
    assert_allclose(weighted_quantiles(x, counts.astype(float), qs),
                    np.quantile(np.repeat(x, counts), qs, method="inverted_cdf"), rtol=1e-12)
