"""Tests of the ``heavy_tails`` effect (docs/effects.md, heavy_tails).

References: scipy.stats' Student-t and normal densities in closed form (intact cells, whose
readings are independent given P_phys), the bad_curves mixture written out by hand, and a
Kolmogorov-Smirnov comparison of simulated errors with scipy's variance-matched t.
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from turgorbayes.effects import ExtendedModel, get_effect
from turgorbayes.effects.bad_curves import corrupted_logpdf
from turgorbayes.effects.heavy_tails import student_k_logpdf
from turgorbayes.physics import forward
from turgorbayes.simulation import cells as synthetic

TRUE = {"gamma": 1.22, "E0t": 0.026, "R0": 464.2e-9, "P_phys": 29e3}


@pytest.fixture(scope="module")
def cells(table):
    return synthetic.simulate_cells(seed=21, surrogate=table)[0]


def _pooled_rel(cells, group):
    rel = cells.k_c_err / cells.k_c
    return np.sqrt(np.mean(rel[group] ** 2))


@pytest.mark.parametrize("q", [2 / 3, 0.5, 0.1, 1e-4])
def test_density_is_the_variance_matched_student_t(q):
    # reference: scipy.stats.t with nu = 2/q and scale sd sqrt((nu - 2)/nu), sd = rel x model k
    k_obs = np.array([0.010, 0.017, 0.020, 0.035])
    k_err = 0.12 * k_obs
    k = 0.018
    nu = 2 / q
    ref = stats.t.logpdf(k_obs, nu, loc=k, scale=0.12 * k * np.sqrt((nu - 2) / nu))
    assert_allclose(student_k_logpdf(k_obs, k, k_err, q), ref, rtol=1e-10)


def test_density_tends_to_the_gaussian_as_q_goes_to_zero():
    # reference: scipy.stats.norm at q = 0; for small q, with z the reading's distance in
    # reported sds, the expansion ln t_nu - ln N = q (z^4 - 6 z^2 + 3)/8 + O(q^2) (nu = 2/q,
    # variance matched; its mean under N is 0, as two normalized densities require), so the
    # difference must shrink in proportion to q (no jump, no cancellation noise from two large
    # log-gammas)
    k_obs, k = np.array([0.010, 0.017, 0.030]), 0.018
    z = (k_obs - k) / (0.12 * k)
    ref = stats.norm.logpdf(k_obs, k, 0.12 * k)
    assert_allclose(student_k_logpdf(k_obs, k, 0.12 * k_obs, 0.0), ref, rtol=1e-12)
    for q in (1e-5, 1e-8, 1e-11):
        d = student_k_logpdf(k_obs, k, 0.12 * k_obs, q) - ref
        assert_allclose(d / q, (z**4 - 6 * z**2 + 3) / 8, rtol=1e-3)


def test_intact_cells_likelihood_is_normal_radius_times_student_stiffness(table, cells):
    # reference: an intact cell's readings are independent given P_phys: ln N(R_c; R, dR)
    # + ln t_nu(k_c; k, scale) with the group's pooled relative error (docs/statistics.md)
    q = 0.5
    model = ExtendedModel(cells, table, ["heavy_tails"])
    ll = model.pointwise_log_likelihood(model.to_u(dict(TRUE, q_t=q)))[0]
    R, k = forward.cell_radius_and_stiffness(TRUE["P_phys"], TRUE["gamma"], TRUE["E0t"],
                                             TRUE["R0"], 5e3, table)
    i = ~cells.is_bulged
    nu = 2 / q
    scale = _pooled_rel(cells, i) * k * np.sqrt((nu - 2) / nu)
    ref = (stats.norm.logpdf(cells.R_c[i], R, cells.R_c_err[i])
           + stats.t.logpdf(cells.k_c[i], nu, loc=k, scale=scale))
    assert_allclose(ll[i], ref, rtol=1e-10)


def test_with_bad_curves_in_either_order_the_mixture_wraps_the_student_density(table, cells):
    # reference: (1 - f) t_nu + f corrupted for an intact cell, written out; the order in which
    # the effects are named must not matter
    q, f = 2 / 3, 0.1
    v = dict(TRUE, q_t=q, f_bad=f)
    a = ExtendedModel(cells, table, ["bad_curves", "heavy_tails"])
    b = ExtendedModel(cells, table, ["heavy_tails", "bad_curves"])
    la = a.pointwise_log_likelihood(a.to_u(v))[0]
    lb = b.pointwise_log_likelihood(b.to_u(v))[0]
    assert_allclose(la, lb, rtol=1e-12)
    R, k = forward.cell_radius_and_stiffness(TRUE["P_phys"], TRUE["gamma"], TRUE["E0t"],
                                             TRUE["R0"], 5e3, table)
    i = ~cells.is_bulged
    nu = 2 / q
    scale = _pooled_rel(cells, i) * k * np.sqrt((nu - 2) / nu)
    k_dens = np.logaddexp(np.log1p(-f) + stats.t.logpdf(cells.k_c[i], nu, loc=k, scale=scale),
                          np.log(f) + corrupted_logpdf(cells.k_c[i], k))
    ref = stats.norm.logpdf(cells.R_c[i], R, cells.R_c_err[i]) + k_dens
    assert_allclose(la[i], ref, rtol=1e-10)


def test_simulated_errors_are_the_variance_matched_student_t():
    # reference: scipy.stats.t(3) scaled by sqrt(1/3) (variance 1); the Gaussian errors the
    # simulator made are rescaled to it. Kolmogorov-Smirnov on 20,000 readings: a Gaussian
    # left unchanged (D = 0.05 against this t) or the unmatched t_3 (D = 0.09) fail by far
    rng = np.random.default_rng(4)
    n, rel = 20000, 0.1
    k_true = np.full(n, 0.02)
    k_obs = k_true * (1 + rel * rng.standard_normal(n))
    out = get_effect("heavy_tails").observe_k(k_obs, k_true, {"q_t": 2 / 3}, np.ones(n, bool),
                                              rng)
    eps = (out / k_true - 1) / rel
    assert stats.kstest(eps, stats.t(3, scale=np.sqrt(1 / 3)).cdf).pvalue > 0.01
    assert stats.kstest(eps, stats.norm.cdf).pvalue < 1e-6


def test_simulated_errors_with_one_value_per_draw():
    # the posterior predictive passes one q per draw, (W, 1): a draw at q = 0 keeps its
    # Gaussian errors exactly, a draw at q = 2/3 gets the t_3 ones (reference as above)
    rng = np.random.default_rng(5)
    n, rel = 20000, 0.1
    k_true = np.full((2, n), 0.02)
    k_obs = k_true * (1 + rel * rng.standard_normal((2, n)))
    out = get_effect("heavy_tails").observe_k(k_obs, k_true, {"q_t": np.array([[0.0], [2 / 3]])},
                                              np.ones(n, bool), rng)
    assert np.array_equal(out[0], k_obs[0])
    eps = (out[1] / k_true[1] - 1) / rel
    assert stats.kstest(eps, stats.t(3, scale=np.sqrt(1 / 3)).cdf).pvalue > 0.01


@pytest.mark.slow
def test_replicated_stiffness_of_an_intact_cell_is_student_t(table, cells):
    # reference: scipy.stats.t(3) around the model stiffness with the variance-matched scale
    # (the group's pooled relative error); 4000 draws at one parameter value, so the
    # replicated readings of one intact cell are 4000 independent draws of its error (with
    # bad_curves in the model at f ~ 0 and named first: the t errors are still drawn)
    q, W = 2 / 3, 4000
    model = ExtendedModel(cells, table, ["bad_curves", "heavy_tails"])
    u = np.repeat(model.to_u(dict(TRUE, q_t=q, f_bad=1e-12)), W, axis=0)
    rep = model.posterior_predictive(u, np.random.default_rng(6))["k_c"]
    R, k = forward.cell_radius_and_stiffness(TRUE["P_phys"], TRUE["gamma"], TRUE["E0t"],
                                             TRUE["R0"], 5e3, table)
    i = int(np.flatnonzero(~cells.is_bulged)[0])
    sd = _pooled_rel(cells, ~cells.is_bulged) * k
    assert stats.kstest(rep[:, i], stats.t(3, loc=k, scale=sd / np.sqrt(3)).cdf).pvalue > 0.01
    assert stats.kstest(rep[:, i], stats.norm(k, sd).cdf).pvalue < 1e-4
