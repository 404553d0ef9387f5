"""Tests of the generic ``discrepancy`` candidate (turgorbayes.effects.discrepancy).

References: scipy.stats.multivariate_normal for the joint density of a cell's two readings;
the baseline likelihood (nesting: no extra scatter is the baseline); simulated truth for the
generative side (sample variances and correlation of the planted deviations).
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from turgorbayes import effects
from turgorbayes.effects import ExtendedModel
from turgorbayes.effects.discrepancy import bivariate_logpdf
from turgorbayes.inference.observations import stiffness_sd
from turgorbayes.simulation import cells as synthetic

TRUE = {"gamma": 1.22, "E0t": 0.026, "R0": 464.2e-9, "P_phys": 29e3}


@pytest.fixture(scope="module")
def cells(table):
    return synthetic.simulate_cells(seed=21, surrogate=table)[0]


def test_bivariate_density_is_scipys_multivariate_normal(rng):
    # reference: scipy.stats.multivariate_normal with the covariance written out by hand, in
    # nm (metres and N/m differ by 1e11 in scale, which scipy's eigen-solver calls singular):
    # a density per m is the density per nm plus ln(1e9)
    R_obs, R_err, R = 540e-9, 15e-9, 530e-9
    k_obs, k_err, k = 0.031, 0.004, 0.028
    for s_R, s_k, rho in [(0.03, 0.1, 0.5), (0.0, 0.2, -0.3), (0.05, 0.0, 0.9)]:
        sd_k = stiffness_sd(k, k_obs, k_err)
        n = 1e9
        cov = [[(n * R_err) ** 2 + (n * R * s_R) ** 2, rho * n * R * s_R * k * s_k],
               [rho * n * R * s_R * k * s_k, sd_k**2 + (k * s_k) ** 2]]
        ref = stats.multivariate_normal([n * R, k], cov).logpdf([n * R_obs, k_obs]) + np.log(n)
        assert_allclose(bivariate_logpdf(R_obs, R, R_err, k_obs, k, k_err, s_R, s_k, rho), ref,
                        rtol=1e-12)


def test_no_extra_scatter_is_the_baseline(table, cells, rng):
    # reference: the baseline likelihood (nesting); with every sd at 1e-12 the joint density is
    # the product of the two independent Gaussians to ~1e-20
    model = ExtendedModel(cells, table, ["discrepancy"])
    base = ExtendedModel(cells, table)
    U = base.to_u(TRUE) + np.r_[0.05, 0.05, 3.0, 0.03] * rng.standard_normal((5, 4))
    null = dict(TRUE, s_R_bulged=1e-12, s_k_bulged=1e-12, s_R_intact=1e-12, s_k_intact=1e-12,
                rho_d=0.3)
    U_ext = np.hstack([U, np.tile(model.to_u(null)[0, 4:], (len(U), 1))])
    # the effect's context takes the 16-node rule for bulged cells: agreement to the baseline's
    # own quadrature error (~1e-5, tests/inference/test_likelihood.py)
    assert_allclose(model.pointwise_log_likelihood(U_ext), base.pointwise_log_likelihood(U),
                    rtol=0, atol=2e-5)


def test_extra_scatter_of_the_intact_stiffness_only_changes_the_intact_cells(table, cells, rng):
    # reference: the group structure of the model: the bulged cells' density is unchanged to
    # the quadrature error when only s_k_intact grows, the intact cells' is lowered where the
    # readings sit near the model (a wider density is lower at its centre)
    model = ExtendedModel(cells, table, ["discrepancy"])
    v0 = dict(TRUE, s_R_bulged=1e-12, s_k_bulged=1e-12, s_R_intact=1e-12, s_k_intact=1e-12,
              rho_d=0.0)
    a = model.pointwise_log_likelihood(model.to_u(v0))[0]
    b = model.pointwise_log_likelihood(model.to_u(dict(v0, s_k_intact=0.3)))[0]
    bulged = np.asarray(cells.is_bulged)
    assert_allclose(a[bulged], b[bulged], atol=1e-9)
    assert np.all(b[~bulged] != a[~bulged])


def test_planted_discrepancy_has_the_requested_scatter_and_correlation(table, rng):
    # reference: simulated truth; 2000 draws: the sd of each planted log deviation within
    # 3 standard errors (sd/sqrt(2n) = 0.0022 at 0.1) and the correlation within 0.1 of 0.6
    e = effects.get_effect("discrepancy")
    v = {"s_R_bulged": 0.05, "s_k_bulged": 0.1, "s_R_intact": 0.1, "s_k_intact": 0.2,
         "rho_d": 0.6}
    bound = e.bind(type("C", (), {"is_bulged": np.arange(2000) < 1000})())
    k = np.ones(2000)
    R = np.ones(2000)
    every = np.ones(2000, bool)
    lk = np.log(bound.observe_k(k, k, v, every, rng))
    lR = np.log(bound.observe_R(R, v, every, rng))
    b = np.arange(2000) < 1000
    for x, group, sd in [(lR, b, 0.05), (lk, b, 0.1), (lR, ~b, 0.1), (lk, ~b, 0.2)]:
        assert abs(np.std(x[group]) - sd) < 3 * sd / np.sqrt(2 * 1000)
    for group in (b, ~b):
        assert abs(np.corrcoef(lR[group], lk[group])[0, 1] - 0.6) < 0.1


def test_discrepancy_names_no_cause_and_does_not_combine(table, cells):
    # reference: the design (docs/effects.md, "The verdict"): the generic candidate is never a
    # named cause and describes misfit on its own
    assert effects.get_effect("discrepancy").names_cause is False
    assert all(effects.get_effect(n).names_cause for n in effects.effect_names()
               if n != "discrepancy")
    model = ExtendedModel(cells, table, ["heavy_tails", "discrepancy"])
    v = model.to_physical(model.to_u(dict(TRUE, q_t=0.3, s_R_bulged=0.01, s_k_bulged=0.01,
                                          s_R_intact=0.01, s_k_intact=0.01, rho_d=0.0)))
    with pytest.raises(ValueError, match="describes misfit on its own"):
        model.context(v)
