"""Tests of the deconvolved latent-pressure population (turgorbayes.inference.population).

References: simulated truths (the true ln P are drawn, then observed with known noise), the
closed-form product of two Gaussians, and moments of draws against grid moments.
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import special, stats

from turgorbayes.inference import population


def _normal_population(mu, tau, n=2001):
    grid = np.linspace(mu - 10 * tau, mu + 10 * tau, n)
    log_mass = stats.norm.logpdf(grid, mu, tau)
    return population.GridPopulation(grid, log_mass - special.logsumexp(log_mass))


def test_deconvolution_recovers_a_log_uniform_population(rng):
    # simulated truth: ln P uniform over ln(1 kPa)..ln(25 kPa) (the synthetic design), seen
    # with per-cell noise s in [0.08, 0.16]. The deconvolved CDF must be as close to the true
    # one as the empirical CDF of n exact draws typically is: inside the Kolmogorov-Smirnov
    # band 1.95/sqrt(n) (p = 0.001)
    n = 3000
    lo, hi = np.log(1e3), np.log(25e3)
    true = rng.uniform(lo, hi, n)
    s = rng.uniform(0.08, 0.16, n)
    pop = population.deconvolve(true + s * rng.standard_normal(n), s)
    cdf = np.cumsum(np.exp(pop.log_mass))
    x = pop.grid
    true_cdf = np.clip((x - lo) / (hi - lo), 0, 1)
    assert np.max(np.abs(cdf - true_cdf)) < 1.95 / np.sqrt(n)
    mean = np.exp(pop.log_mass) @ x
    sd = np.sqrt(np.exp(pop.log_mass) @ x**2 - mean**2)
    # mean and sd of the uniform: (lo + hi)/2 and (hi - lo)/sqrt(12) = 0.929 (4 standard errors)
    assert abs(mean - (lo + hi) / 2) < 4 * 0.929 / np.sqrt(n)
    assert abs(sd - (hi - lo) / np.sqrt(12)) < 4 * 0.929 * np.sqrt(0.8 / 4 / n) + 0.005


def test_deconvolution_recovers_a_bimodal_population(rng):
    # simulated truth: two groups of cells, ln P ~ 0.5 N(8, 0.35) + 0.5 N(10.5, 0.45), noise
    # 0.15 (groups a few spline knots wide: DF = 7 functions over ~5 units of ln P)
    n = 3000
    true = np.where(rng.random(n) < 0.5, rng.normal(8, 0.35, n), rng.normal(10.5, 0.45, n))
    s = np.full(n, 0.15)
    pop = population.deconvolve(true + s * rng.standard_normal(n), s)
    true_cdf = 0.5 * stats.norm.cdf(pop.grid, 8, 0.35) + 0.5 * stats.norm.cdf(pop.grid, 10.5, 0.45)
    assert np.max(np.abs(np.cumsum(np.exp(pop.log_mass)) - true_cdf)) < 1.95 / np.sqrt(n)
    # a trough between the modes: density at 9.25 well below that at 8 and at 10.5
    d = pop.log_pdf(np.array([8.0, 9.25, 10.5]))
    assert d[1] < min(d[0], d[2]) - 1.0


def test_grid_posterior_moments_match_the_gaussian_product(rng):
    # closed form: N(a; x, s) N(x; mu, tau) = N(a; mu, sqrt(s^2+tau^2)) N(x; c, sigma)
    mu, tau = 9.0, 0.7
    pop = _normal_population(mu, tau)
    a, s = np.array([8.0, 9.3, 10.5]), np.array([0.1, 0.2, 0.3])
    mean, sd, log_norm = pop.moments(a, s)
    c = (tau**2 * a + s**2 * mu) / (s**2 + tau**2)
    sigma = s * tau / np.sqrt(s**2 + tau**2)
    assert_allclose(mean, c, atol=1e-6)
    assert_allclose(sd, sigma, rtol=1e-4)
    # log_norm is the marginal of a; masses are density x step, so compare with the density
    assert_allclose(log_norm, stats.norm.logpdf(a, mu, np.hypot(s, tau)), atol=1e-6)
    # the continuous density integrates to one and matches the normal between grid points
    x = rng.uniform(mu - 3 * tau, mu + 3 * tau, 20)
    assert_allclose(pop.log_pdf(x), stats.norm.logpdf(x, mu, tau), atol=1e-4)
    assert pop.log_pdf(np.array([pop.grid[0] - 1]))[0] == -np.inf


def test_posterior_draws_have_the_grid_moments(rng):
    # draws from sample_posterior against the closed-form Gaussian product (4 sd of the mean)
    mu, tau = 9.0, 0.7
    pop = _normal_population(mu, tau, n=601)  # step 0.023: adds 4e-5 to the draws' variance
    n = 40000
    a, s = np.full(n, 8.4), np.full(n, 0.25)
    draws = pop.sample_posterior(a, s, rng)
    c = (tau**2 * 8.4 + 0.25**2 * mu) / (0.25**2 + tau**2)
    sigma = 0.25 * tau / np.hypot(0.25, tau)
    assert abs(draws.mean() - c) < 4 * sigma / np.sqrt(n)
    assert abs(draws.std() - sigma) < 4 * sigma / np.sqrt(2 * n)
    assert stats.kstest(draws, stats.norm(c, sigma).cdf).pvalue > 1e-3


def test_deconvolution_refuses_bad_input():
    with pytest.raises(ValueError, match="at least 3 bulge estimates"):
        population.deconvolve([8.0, 9.0], [0.1, 0.1])
    with pytest.raises(ValueError, match="positive sds"):
        population.deconvolve([8.0, 9.0, np.nan], [0.1, 0.1, 0.1])


def test_the_family_grows_with_the_cells():
    # the sieve rule of the module docstring: 7 functions at the paper's 72 bulged cells,
    # 7 (10x)^(1/3) = 15 at 10x, 7 (20)^(1/3) = 19 at 20x, capped at MAX_DF
    assert [population.spline_functions(n) for n in (72, 720, 1440, 10**6)] == [
        7, 15, 19, population.MAX_DF]


def test_a_hard_edge_is_followed_as_the_cells_grow(rng):
    # simulated truth: ln P uniform over ln(1 kPa)..ln(25 kPa), no mass outside. With 3000
    # cells the fixed 7-function family leaks 3 % of the mass beyond the edges (measured:
    # 0.030); the grown family (24 functions) must leak less than half of that. The leak is
    # what biased the wall parameters at 10-20x the paper's cells (docs/validation.md).
    n = 3000
    lo, hi = np.log(1e3), np.log(25e3)
    true = rng.uniform(lo, hi, n)
    s = rng.uniform(0.08, 0.16, n)
    obs = true + s * rng.standard_normal(n)

    def leak(pop):
        return np.exp(pop.log_mass)[(pop.grid < lo) | (pop.grid > hi)].sum()

    fixed, grown = population.deconvolve(obs, s, df=population.DF), population.deconvolve(obs, s)
    assert leak(fixed) > 0.02
    assert leak(grown) < 0.5 * leak(fixed)
