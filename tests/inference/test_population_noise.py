"""Tests of carrying the plug-in population's estimation noise (inference.population_noise).

References: simulated truths (populations deconvolved from independent data sets of the same
design give the estimate's true sampling noise), exact mode refits (against the linearized
shift), the sampler's own draws (a fit with and without the noise on the same seed), and the
covariance of Gaussian draws. The fit's use of it: tests/workflows/test_fit.py.
"""

import numpy as np
import pytest
from scipy import stats

from turgorbayes import effects
from turgorbayes.inference import mode, models, observations, population, population_noise
from turgorbayes.simulation import cells as synthetic

SCALE = 3  # 216 bulged + 126 intact cells: the population's noise is 0.1-0.2 posterior sds


@pytest.fixture(scope="module")
def laplace(table):
    cells, _ = synthetic.simulate_cells(72 * SCALE, 42 * SCALE, seed=77, surrogate=table)
    model = effects.ExtendedModel(cells, table, [])
    guess = models.PaperWLS(cells, table).fit().estimate
    lap = mode.laplace_fit(model, model.to_u(model.start_values(guess))[0])
    return model, lap


def test_bootstrap_noise_matches_populations_of_independent_data_sets(table, laplace):
    # simulated truth of the estimate's noise: populations deconvolved (same grid, same
    # number of functions) from the bulges of 30 independent data sets of the same design.
    # The bootstrap's shift sds must match theirs within sampling error (30 shifts each: an
    # sd is known to about 13 %, a ratio of two to 19 %; bounds at about 2.5 of those). A
    # bootstrap that did not resample (zero shifts) or resampled without replacement (the
    # same population every time) fails the lower bound.
    model, lap = laplace
    plug_in = model.obs.population
    others = []
    for seed in range(5000, 5030):
        cells, _ = synthetic.simulate_cells(72 * SCALE, 1, seed=seed, surrogate=table)
        obs = observations.observations_from_cells(cells)
        others.append(population.deconvolve(obs.log_P_bulge, obs.sd_log_P_bulge,
                                            df=plug_in.df, grid=plug_in.grid))
    sd = np.sqrt(np.diag(lap.cov))
    independent = population_noise.mode_shifts(model, lap.u_map, lap.cov, others).std(
        axis=0, ddof=1) / sd
    rng = np.random.default_rng(3)
    boot = population_noise.mode_shifts(
        model, lap.u_map, lap.cov,
        population_noise.bootstrap_populations(plug_in, 30, rng)).std(axis=0, ddof=1) / sd
    assert np.all(independent > 0.03), independent  # the effect under test is there
    ratio = boot / independent
    assert np.all((ratio > 0.55) & (ratio < 1.8)), (boot, independent)


def test_linear_shift_matches_an_exact_mode_refit(laplace):
    # the linearization of the module docstring against an exact refit of the mode with the
    # bootstrap population (measured at 20x: median difference 0.001 posterior sds)
    model, lap = laplace
    pops = population_noise.bootstrap_populations(model.obs.population, 2,
                                                  np.random.default_rng(5))
    shifts = population_noise.mode_shifts(model, lap.u_map, lap.cov, pops)
    sd = np.sqrt(np.diag(lap.cov))
    for pop, shift in zip(pops, shifts, strict=True):
        with population_noise.using_population(model, pop):
            refit = mode.find_mode(model, lap.u_map)
        assert np.max(np.abs(shift - (refit - lap.u_map)) / sd) < 0.02
        assert np.max(np.abs(shift / sd)) > 0.02  # a shift to compare


def test_a_population_given_as_known_carries_no_noise(table, laplace):
    # nothing was estimated: the plug-in's noise is zero by construction
    model, lap = laplace
    known = population.GridPopulation(model.obs.population.grid, model.obs.population.log_mass)
    with population_noise.using_population(model, known):
        sigma = population_noise.shift_covariance(model, lap.u_map, lap.cov, seed=1)
    assert np.all(sigma == 0)


def test_carried_draws_have_the_requested_covariance():
    # closed form: draws plus independent N(0, S) noise; the sample covariance of the added
    # noise over 40,000 draws matches S to about 1 % (4 standard errors: 3 %)
    rng = np.random.default_rng(11)
    S = np.array([[0.04, 0.01], [0.01, 0.09]])
    u = rng.standard_normal((40000, 2))
    added = population_noise.carry(u, S, np.random.default_rng(12)) - u
    assert np.allclose(np.cov(added, rowvar=False), S, rtol=0.04, atol=0.002)


def test_carried_draws_stay_inside_the_prior_support():
    # each posterior averaged over the population is zero outside the prior's support: draws
    # at 0.5 moved by N(0, 0.3^2) and cut to [0, 1] follow the normal truncated there
    # (closed form: scipy.stats.truncnorm, whose sd is 0.2206 for +-1.667 sds)
    def log_prior(v):
        return np.where((v[:, 0] >= 0) & (v[:, 0] <= 1), 0.0, -np.inf)

    u = np.full((20000, 1), 0.5)
    out = population_noise.carry(u, np.array([[0.09]]), np.random.default_rng(4), log_prior)
    assert np.all((out >= 0) & (out <= 1))
    expected_sd = stats.truncnorm.std(-0.5 / 0.3, 0.5 / 0.3, loc=0.5, scale=0.3)
    assert abs(out.std() / expected_sd - 1) < 0.03
    assert abs(out.mean() - 0.5) < 0.006
