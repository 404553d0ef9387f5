"""Tests of the latent-pressure population as a function of the bulge estimates' extra scatter
(turgorbayes.inference.population, "Extra scatter"; DeconvolvedPopulation, NormalPopulation).

References: simulated truths (a normal population of ln P seen with noise sqrt(s^2 + sigma^2):
the closed form of a normal convolved with normal noise), quadrature of the density, the
plain GridPopulation of the sigma = 0 estimate (today's baseline), and row-by-row evaluation
against the walker-vectorized one.
"""

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

from turgorbayes import effects
from turgorbayes.inference import likelihood, observations, population
from turgorbayes.simulation import cells as synthetic

THETAS = [  # (gamma, E0t [N/m], R0 [m], P_phys [Pa]): the truth and two parameter sets off it
    (1.22, 0.026, 464.2e-9, 29e3),
    (1.0, 0.030, 470e-9, 25e3),
    (1.5, 0.022, 458e-9, 33e3),
]


@pytest.fixture(scope="module")
def normal_family():
    """2000 cells: ln P ~ N(9, 0.5), reported s in [0.08, 0.16], extra scatter 0.3; the family
    at rows 0 and 0.3 (7 functions: a normal needs no more; ~10 s at 2000 cells)."""
    rng = np.random.default_rng(7)
    n, mu, tau, sigma = 2000, 9.0, 0.5, 0.3
    s = rng.uniform(0.08, 0.16, n)
    x = mu + tau * rng.standard_normal(n) + np.hypot(s, sigma) * rng.standard_normal(n)
    fam = population.deconvolve_family(x, s, sigmas=[0.0, sigma], df=population.DF)
    return fam, mu, tau, sigma


@pytest.fixture(scope="module")
def obs(table):
    """The paper's design (72 bulged cells), default (deconvolved) latent prior."""
    cells, _ = synthetic.simulate_cells(seed=11, surrogate=table)
    return observations.observations_from_cells(cells)


@pytest.fixture(scope="module")
def fam(obs):
    return obs.population


def _grid_moments(pop, log_mass):
    p = np.exp(log_mass)
    mean = p @ pop.grid
    return mean, p @ pop.grid**2 - mean**2


def test_the_member_at_the_extra_scatter_has_the_population_variance(normal_family):
    # closed form: ln P_hat ~ N(mu, sqrt(tau^2 + s^2 + sigma^2)), so deconvolving with noise
    # sqrt(s^2 + sigma^2) gives variance tau^2 = 0.25 and with s alone tau^2 + sigma^2 = 0.34.
    # Tolerance: 4 sampling sds of a variance, 4 x 0.355 sqrt(2/2000) = 0.045
    fam, mu, tau, sigma = normal_family
    n = fam.log_P_hat.size
    tol = 4 * (tau**2 + sigma**2 + np.mean(fam.sd**2)) * np.sqrt(2 / n)
    mean, var = _grid_moments(fam, fam.log_mass_at(sigma))
    assert abs(var - tau**2) < tol, var
    assert abs(mean - mu) < 4 * np.sqrt(0.355 / n)
    _, var0 = _grid_moments(fam, fam.log_mass_at(0.0))
    assert abs(var0 - (tau**2 + sigma**2)) < tol, var0
    # half-way: the mixture's variance is the members' average plus the spread of their means
    _, var_mid = _grid_moments(fam, fam.log_mass_at(sigma / 2))
    assert var_mid == pytest.approx((var + var0) / 2, abs=1e-4)


def test_the_zero_member_is_the_plain_deconvolution(fam):
    # reference: deconvolve() (today's estimate), bit for bit
    plain = population.deconvolve(fam.log_P_hat, fam.sd)
    assert_array_equal(fam.grid, plain.grid)
    assert_array_equal(fam.log_mass, plain.log_mass)
    assert_array_equal(fam.rows[0], plain.log_mass)
    assert_array_equal(fam.sigmas, population.SIGMA_GRID)
    assert fam.support == plain.support  # every member lives on the one grid
    with pytest.raises(ValueError, match="increase from 0"):
        population.deconvolve_family(fam.log_P_hat, fam.sd, sigmas=[0.1, 0.2])


@pytest.mark.parametrize("sigma", [0.0, 0.025, 0.12, 0.3, 0.77, 1.0, 1.4])
def test_the_mixture_density_integrates_to_one(fam, sigma):
    # quadrature: trapezoid over the support with 40001 points. The grid masses sum to 1 with
    # the end points at full weight, so the integral over the support is 1 minus half an end
    # cell's mass at each end (the sigma = 0 member's property), up to the cubic's
    # interpolation error (measured 4e-6 at the paper's 72 cells); a mixture of two members
    # must keep that
    t = np.linspace(*fam.support, 40001)
    for extra in (sigma, np.array([sigma])):  # scalar and per-walker
        f = np.exp(fam.log_pdf(t[None, :] if np.ndim(extra) else t, extra)).ravel()
        ends = 0.5 * fam.step * (f[0] + f[-1])
        assert abs(np.trapezoid(f, t) - (1 - ends)) < 2e-5
        assert ends < 1e-3
    assert np.sum(np.exp(fam.log_mass_at(sigma))) == pytest.approx(1, abs=1e-12)


def test_between_rows_the_density_is_the_two_members_mixture(fam):
    # reference: (1 - t) g_k + t g_{k+1} evaluated from the rows' own log_pdf, row by row
    extra = np.array([0.0, 0.05, 0.07, 0.3, 2.0])
    pts = np.linspace(7.5, 10.0, 9)
    ours = fam.log_pdf(np.broadcast_to(pts, (extra.size, pts.size)), extra)
    for w, e in enumerate(extra):
        k = min(int(np.searchsorted(fam.sigmas, e, side="right")) - 1, fam.sigmas.size - 2)
        tt = min((e - fam.sigmas[k]) / (fam.sigmas[k + 1] - fam.sigmas[k]), 1.0)
        rows = [population.GridPopulation(fam.grid, fam.rows[j]) for j in (k, k + 1)]
        ref = np.log((1 - tt) * np.exp(rows[0].log_pdf(pts)) + tt * np.exp(rows[1].log_pdf(pts)))
        assert_allclose(ours[w], ref, rtol=1e-12, atol=1e-12)
    assert np.all(fam.log_pdf(np.array([[fam.grid[0] - 0.1]]), np.array([0.3])) == -np.inf)


def test_moments_and_draws_follow_the_member_of_each_walker(fam):
    # reference: GridPopulation on the mixed masses (its own posterior arithmetic); draws of
    # a walker have the mean of its posterior (4 standard errors)
    extra = np.array([0.0, 0.13, 0.3, 0.6])
    a, sd = np.array([[8.0, 9.3, 10.5]]), np.hypot(0.12, extra)[:, None]
    mean, msd, log_norm = fam.moments(a, sd, extra)
    for w, e in enumerate(extra):
        ref = population.GridPopulation(fam.grid, fam.log_mass_at(e)).moments(a[0], sd[w])
        for ours, theirs in zip((mean[w], msd[w], log_norm[w]), ref, strict=True):
            assert_allclose(ours, theirs, rtol=1e-10)
    rng = np.random.default_rng(3)
    n = 20000
    draws = fam.sample_posterior(np.full((extra.size, n), 9.3), np.broadcast_to(sd, (4, n)),
                                 rng, extra)
    assert np.all(np.abs(draws.mean(axis=1) - mean[:, 1]) < 4 * msd[:, 1] / np.sqrt(n))


def test_a_normal_population_from_moments_shrinks_by_the_extra_scatter(rng):
    # tau^2 -> max(tau^2 - sigma^2, floor^2) for a population estimated by moments; a known
    # normal population (no floor) does not depend on the extra scatter
    est = observations.population_prior(9 + 0.6 * rng.standard_normal(500), np.full(500, 0.1))
    assert est.floor == observations.MIN_POPULATION_SD
    extra = np.array([0.0, 0.3, 5.0])
    assert_allclose(est.sd_at(extra), np.sqrt(np.maximum(est.tau**2 - extra**2, 0.01)))
    x = np.array([[8.5], [8.5], [8.5]])
    assert_allclose(est.log_pdf(x, extra)[:, 0],
                    -0.5 * ((8.5 - est.mu) ** 2 / est.sd_at(extra) ** 2 + np.log(2 * np.pi))
                    - np.log(est.sd_at(extra)))
    known = population.NormalPopulation(9.0, 0.7)
    assert_array_equal(known.log_pdf(x, extra), known.log_pdf(x))


@pytest.mark.parametrize("theta", THETAS)
def test_zero_extra_scatter_is_the_baseline(obs, table, theta):
    # reference: the plain GridPopulation of the sigma = 0 estimate (today's baseline) in the
    # same likelihood; exactly equal for a scalar 0, to rounding for per-walker zeros
    assert isinstance(obs.population, population.DeconvolvedPopulation)
    plain = dataclasses.replace(obs, population=population.GridPopulation(
        obs.population.grid, obs.population.log_mass))
    ours, ref = (likelihood.CellLikelihood(o, table) for o in (obs, plain))
    args = [np.array([v]) for v in theta]
    assert_array_equal(ours.pointwise(*args), ref.pointwise(*args))
    walkers = [np.repeat(a, 3) for a in args[:3]]
    assert_allclose(ours.bulged(*walkers, extra_log_sd=np.zeros(3)), ref.bulged(*walkers),
                    rtol=1e-12)


def test_pressure_error_at_zero_is_the_baseline_and_otherwise_uses_the_member(obs, table):
    # reference: the baseline likelihood on the plain sigma = 0 population (sigma_P = 0), and
    # at sigma_P = 0.3 the same model with the population fixed at the 0.3 member (a
    # GridPopulation, which ignores the extra scatter)
    cells, _ = synthetic.simulate_cells(seed=11, surrogate=table)
    model = effects.ExtendedModel(cells, table, ["pressure_error"])
    assert_array_equal(model.obs.population.log_mass, obs.population.log_mass)
    values = dict(zip(("gamma", "E0t", "R0", "P_phys"), THETAS[0], strict=True))
    plain_obs = dataclasses.replace(model.obs, population=population.GridPopulation(
        model.obs.population.grid, model.obs.population.log_mass))
    ref = likelihood.CellLikelihood(plain_obs, table).pointwise(*([v] for v in THETAS[0]))
    u0 = model.to_u({**values, "sigma_P": 0.0})
    assert_allclose(model.pointwise_log_likelihood(u0), ref, rtol=1e-12)
    fixed = effects.ExtendedModel(cells, table, ["pressure_error"])
    fixed.obs = dataclasses.replace(model.obs, population=population.GridPopulation(
        model.obs.population.grid, model.obs.population.log_mass_at(0.3)))
    fixed.lik = likelihood.CellLikelihood(fixed.obs, table)
    u = model.to_u({**values, "sigma_P": 0.3})
    assert_allclose(model.pointwise_log_likelihood(u), fixed.pointwise_log_likelihood(u),
                    rtol=1e-10)
