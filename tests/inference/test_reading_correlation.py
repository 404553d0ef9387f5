"""Correlated readings: a cell's R_c and k_c as one bivariate normal observation
(turgorbayes.inference.reading_correlation; docs/statistics.md, "Correlated readings").

References: scipy's multivariate normal density (closed form), scipy's scalar minimizer for
the Gauss-Newton step of a linear model (whose optimum the step reaches exactly), the sample
correlation of many draws, and brute-force dense quadrature of each bulged cell's integral
over ln P (trapezoid on 24001 points, the forward model evaluated directly, the readings'
density from scipy).
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import optimize, stats

from turgorbayes import effects
from turgorbayes.cells.correlation import with_error_correlation
from turgorbayes.effects import ExtendedModel
from turgorbayes.effects.discrepancy import bivariate_logpdf as discrepancy_logpdf
from turgorbayes.inference import likelihood, models, observations
from turgorbayes.inference import reading_correlation as rc
from turgorbayes.inference.context import gaussian_k_logpdf, gaussian_R_logpdf
from turgorbayes.physics import forward
from turgorbayes.simulation import cells as synthetic

RHO = -0.7
THETA = (1.22, 0.026, 464.2e-9, 29e3)  # the simulated truth (gamma, E0t, R0, P_phys)


def _scipy_logpdf(R_obs, R, R_err, k_obs, k, k_err, rho):
    """The readings' density from scipy: covariance [[sR^2, rho sR sk], [., sk^2]], sk = rel k
    (in nm and mN/m, where scipy's eigenvalue tolerance is not fooled by SI's tiny numbers;
    back to SI by the Jacobian ln(1e9 x 1e3))."""
    a, b = 1e9, 1e3
    sR, sk = R_err * a, k_err / k_obs * k * b
    cov = [[sR**2, rho * sR * sk], [rho * sR * sk, sk**2]]
    return (stats.multivariate_normal([R * a, k * b], cov).logpdf([R_obs * a, k_obs * b])
            + np.log(a * b))


def test_bivariate_density_is_scipys(rng):
    for _ in range(20):
        R, k = rng.uniform(400e-9, 600e-9), rng.uniform(0.005, 0.05)
        R_err, rel, rho = rng.uniform(5e-9, 25e-9), rng.uniform(0.05, 0.2), rng.uniform(-.95, .95)
        R_obs, k_obs = R + R_err * rng.normal(), k * (1 + rel * rng.normal())
        k_err = rel * k_obs
        ref = _scipy_logpdf(R_obs, R, R_err, k_obs, k, k_err, rho)
        assert_allclose(rc.bivariate_logpdf(R_obs, R, R_err, k_obs, k, k_err, rho), ref,
                        rtol=1e-12)
        # the same as the radius' density times the stiffness' conditional one
        kc, kc_err = rc.conditional_stiffness(R_obs, R, R_err, k_obs, k, k_err, rho)
        split = gaussian_R_logpdf(R_obs, R, R_err) + gaussian_k_logpdf(k_obs, kc, kc_err)
        assert_allclose(split, ref, rtol=1e-12)
        # the discrepancy effect's covariance without its extra scatter is the same density
        assert_allclose(discrepancy_logpdf(R_obs, R, R_err, k_obs, k, k_err, 0.0, 0.0, 0.0, rho),
                        ref, rtol=1e-12)


def _negative_log_density(x, a_R, b_R, a_k, b_k, rho, mu, s):
    e_R, e_k = b_R - a_R * x, b_k - a_k * x
    return 0.5 * (x - mu) ** 2 / s**2 + 0.5 * (e_R**2 - 2 * rho * e_R * e_k + e_k**2) / (1 - rho**2)


def test_centre_step_is_the_optimum_of_a_linear_model(rng):
    # residuals linear in x: one Gauss-Newton step lands on the minimum of the quadratic
    for _ in range(10):
        a_R, b_R, a_k, b_k = rng.normal(size=4) * [3, 1, 3, 1]
        rho, mu, s = rng.uniform(-0.9, 0.9), rng.normal(), rng.uniform(0.1, 1)
        p, q = rc.centre_terms(a_R, b_R, a_k, b_k, rho)

        ref = optimize.minimize_scalar(_negative_log_density, bracket=(-10, 10), tol=1e-12,
                                       args=(a_R, b_R, a_k, b_k, rho, mu, s)).x
        assert_allclose((mu / s**2 + q) / (1 / s**2 + p), ref, rtol=0, atol=1e-6)


def test_correlated_normals():
    z_R, z_k = rc.correlated_normals(np.random.default_rng(1), (200_000,), RHO)
    # sample correlation of 2e5 draws: sd (1 - rho^2)/sqrt(n) = 0.0011
    assert_allclose(np.corrcoef(z_R, z_k)[0, 1], RHO, atol=0.005)
    assert_allclose(z_k.std(), 1.0, atol=0.005)
    # without a correlation: the draws of two independent standard normals, in that order
    a = rc.correlated_normals(np.random.default_rng(2), (5,), None)
    g = np.random.default_rng(2)
    assert np.array_equal(a[0], g.standard_normal(5)) and np.array_equal(a[1], g.standard_normal(5))


def test_cell_rho_takes_the_known_ones_first():
    known = np.array([[0.3], [np.nan], [-0.5]])
    walkers = np.array([0.1, -0.2])
    out = rc.cell_rho(known, walkers, 3)
    assert out.shape == (2, 3, 1)
    assert_allclose(out[:, :, 0], [[0.3, 0.1, -0.5], [0.3, -0.2, -0.5]])
    assert rc.cell_rho(np.full((3, 1), np.nan), None, 3) is None
    assert rc.cell_rho(np.zeros((3, 1)), None, 3) is None


@pytest.fixture(scope="module")
def correlated(table):
    """64 bulged + 48 intact cells with R_c-k_c errors correlated at RHO (simulated), with and
    without the column."""
    inj = [effects.get_effect("correlated_errors").injection(RHO)]
    cells, _ = synthetic.simulate_cells(64, 48, seed=5, surrogate=table, effects=inj)
    return cells, with_error_correlation(cells, RHO)


def _brute_force(obs, table, gamma, E0t, R0, P_phys, rho):
    """Per-cell log-likelihood by dense trapezoid quadrature (bulged) and directly (intact)."""
    z = np.linspace(-12, 12, 24001)
    out = np.empty(obs.n_cells)
    for j, i in enumerate(obs.bulged):
        s = obs.sd_log_P_bulge[j]
        log_P = obs.log_P_bulge[j] + s * z
        R, k = forward.cell_radius_and_stiffness(np.exp(log_P), gamma, E0t, R0, surrogate=table)
        sk = obs.k_c_err[i] / obs.k_c[i] * k
        e_R, e_k = (obs.R_c[i] - R) / obs.R_c_err[i], (obs.k_c[i] - k) / sk
        f = (-0.5 * (e_R**2 - 2 * rho * e_R * e_k + e_k**2) / (1 - rho**2)
             - np.log(2 * np.pi * obs.R_c_err[i] * sk * np.sqrt(1 - rho**2))
             + stats.norm.logpdf(z) + obs.population.log_pdf(log_P))
        f = np.where(np.isfinite(f), f, -np.inf)
        m = f.max()
        out[i] = np.log(np.trapezoid(np.exp(f - m), z)) + m
    R, k = forward.cell_radius_and_stiffness(P_phys, gamma, E0t, R0, surrogate=table)
    for i in obs.intact:
        out[i] = _scipy_logpdf(obs.R_c[i], R, obs.R_c_err[i], obs.k_c[i], k, obs.k_c_err[i], rho)
    return out


def test_likelihood_with_the_column_matches_brute_force(correlated, table):
    _, with_column = correlated
    obs = observations.observations_from_cells(with_column)
    assert_allclose(obs.rho_R_k, RHO)
    ref = _brute_force(obs, table, *THETA, RHO)
    ours = likelihood.CellLikelihood(obs, table).pointwise(*([v] for v in THETA))[0]
    assert_allclose(ours, ref, rtol=0, atol=1e-4)
    # and it is not the independent readings' likelihood (the test can fail)
    assert np.max(np.abs(ours - _brute_force(obs, table, *THETA, 0.0))) > 0.1


def _at(model, theta, **extra):
    v = dict(zip(("gamma", "E0t", "R0", "P_phys"), theta, strict=True), **extra)
    return model.pointwise_log_likelihood(np.atleast_2d(model.to_u(v)))[0]


def test_effect_is_the_column_for_cells_without_one(correlated, table):
    # the effect's rho for every cell (context path) = the same rho given by the column
    # (baseline path): both against the brute-force reference
    without, with_column = correlated
    obs = observations.observations_from_cells(without)
    ref = _brute_force(obs, table, *THETA, RHO)
    effect = _at(ExtendedModel(without, table, ["correlated_errors"]), THETA, rho_e=RHO)
    assert_allclose(effect, ref, rtol=0, atol=1e-4)
    assert_allclose(_at(ExtendedModel(with_column, table), THETA), ref, rtol=0, atol=1e-4)
    # a known correlation wins over the effect's: with the column the effect changes nothing
    assert_allclose(_at(ExtendedModel(with_column, table, ["correlated_errors"]), THETA,
                        rho_e=0.5), ref, rtol=0, atol=1e-4)
    # at its null the effect is the baseline
    assert_allclose(_at(ExtendedModel(without, table, ["correlated_errors"]), THETA, rho_e=0.0),
                    _at(ExtendedModel(without, table), THETA), rtol=0, atol=1e-12)


def test_correlation_composes_with_an_effect_of_the_walls(correlated, table):
    # radius_spread integrates each cell over its own R0: with tau_R -> 0 it is the cells'
    # correlated likelihood (the column's) again
    _, with_column = correlated
    ref = _at(ExtendedModel(with_column, table), THETA)
    spread = _at(ExtendedModel(with_column, table, ["radius_spread"]), THETA, tau_R=1e-5)
    assert_allclose(spread, ref, rtol=0, atol=2e-4)


def test_replicates_carry_the_correlation(correlated, table):
    # the model's replicated readings about their means: correlated at RHO with the column,
    # independent without (2000 draws x 112 cells: sd of the correlation ~0.002)
    without, with_column = correlated
    u = np.repeat(np.atleast_2d(models.BaselineModel(with_column, table).to_u(
        dict(zip(("gamma", "E0t", "R0", "P_phys"), THETA, strict=True)))), 2000, axis=0)
    for cells, rho in ((with_column, RHO), (without, 0.0)):
        for model in (models.BaselineModel(cells, table), ExtendedModel(cells, table)):
            rep = model.posterior_predictive(u, np.random.default_rng(3))
            R, k = model.lik.forward(np.log(np.full((1, 1), THETA[3])), *THETA[:3])
            intact = model.obs.intact
            e_R = (rep["R_c"][:, intact] - R[0, 0]) / model.obs.R_c_err[intact]
            e_k = rep["k_c"][:, intact] / k[0, 0] - 1
            assert_allclose(np.corrcoef(e_R.ravel(), e_k.ravel())[0, 1], rho, atol=0.01)


def test_mixtures_condition_only_their_good_branch(correlated, table):
    # each reading is a gross error (or a bad curve) with its own probability; the correctly
    # read pair is the bivariate normal. Closed form for an intact cell, from scipy:
    # outliers:   (1-f)^2 N2 + (1-f) f N(R) B(k) + f (1-f) B(R) N(k) + f^2 B(R) B(k)
    # bad_curves: (1-f) N2 + f N(R) C(k)
    from turgorbayes.effects.bad_curves import BAD_LOG_SD, BAD_MEDIAN_RATIO
    from turgorbayes.effects.outliers import OUTLIER_LOG_SD

    without, _ = correlated
    obs = observations.observations_from_cells(without)
    R, k = forward.cell_radius_and_stiffness(THETA[3], *THETA[:3], surrogate=table)
    f = 0.05
    for name, size in (("outliers", "f_out"), ("bad_curves", "f_bad")):
        model = ExtendedModel(without, table, ["correlated_errors", name])
        ours = _at(model, THETA, rho_e=RHO, **{size: f})[obs.intact]
        for i, value in zip(obs.intact, ours, strict=True):
            Ro, Re, ko, ke = obs.R_c[i], obs.R_c_err[i], obs.k_c[i], obs.k_c_err[i]
            n2 = np.exp(_scipy_logpdf(Ro, R, Re, ko, k, ke, RHO))
            nR = stats.norm.pdf(Ro, R, Re)
            nk = stats.norm.pdf(ko, k, ke / ko * k)
            if name == "outliers":
                bR = stats.lognorm.pdf(Ro, OUTLIER_LOG_SD, scale=R)
                bk = stats.lognorm.pdf(ko, OUTLIER_LOG_SD, scale=k)
                ref = ((1 - f) ** 2 * n2 + (1 - f) * f * nR * bk + f * (1 - f) * bR * nk
                       + f * f * bR * bk)
            else:
                ck = stats.lognorm.pdf(ko, BAD_LOG_SD, scale=k * BAD_MEDIAN_RATIO)
                ref = (1 - f) * n2 + f * nR * ck
            assert_allclose(value, np.log(ref), rtol=0, atol=1e-6)


def test_several_conditions_carry_each_cells_correlation(table):
    # the per-condition observations subset the correlations with the cells. References: the
    # column itself (each condition's part holds its cells' values), the same data with the
    # rows interleaved across conditions (each cell's log-likelihood must follow the cell, not
    # its row), and the model without the column (the correlation is read)
    from turgorbayes.effects.conditions import ConditionsExtendedModel
    from turgorbayes.simulation import conditions as synthetic_conditions

    cells = synthetic_conditions.simulate_conditions(
        {"wt": 29e3, "treated": 22e3}, n_intact=8, n_bulged={"wt": 12, "treated": 12},
        seed=1, surrogate=table)[0]
    rho = np.linspace(-0.8, 0.6, len(cells))  # each cell its own correlation
    cells = with_error_correlation(cells, rho)
    plain = ConditionsExtendedModel(with_error_correlation(cells, np.full(len(cells), np.nan)),
                                    table)
    model = ConditionsExtendedModel(cells, table)
    for c in range(2):
        assert_allclose(model.parts[c].obs.rho_R_k, rho[model.idx[c]])
    u = model.to_u(model.start_values(models.PaperWLS(cells, table).fit().estimate))
    ll = model.pointwise_log_likelihood(u)
    order = np.argsort(np.arange(len(cells)) % 5, kind="stable")  # rows interleaved
    shuffled = ConditionsExtendedModel(cells.take(order), table)
    assert_allclose(shuffled.pointwise_log_likelihood(u), ll[:, order], rtol=1e-10)
    assert not np.allclose(ll, plain.pointwise_log_likelihood(u))
