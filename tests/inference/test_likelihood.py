"""Tests of the per-cell likelihood with latent bulge pressures (turgorbayes.inference.likelihood).

References: brute-force dense quadrature (trapezoid over +-12 bulge sds, 24001 points, with
the forward model evaluated directly at every point), the bulge model's own pressure
inversion (finite differences of turgorbayes.physics.bulge.pressure_from_bulge), Gauss-Hermite
moment identities, and the forward model evaluated directly instead of interpolated.
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from turgorbayes.inference import likelihood, observations, pressure_grid, quadrature
from turgorbayes.inference.population import FlatPopulation, GridPopulation, NormalPopulation
from turgorbayes.physics import bulge, forward
from turgorbayes.simulation import cells as synthetic

THETAS = [  # (gamma, E0t [N/m], R0 [m], P_phys [Pa]): the truth and two parameter sets off it
    (1.22, 0.026, 464.2e-9, 29e3),
    (1.0, 0.030, 470e-9, 25e3),
    (1.5, 0.022, 458e-9, 33e3),
]


@pytest.fixture(scope="module")
def obs(table):
    cells, _ = synthetic.simulate_cells(seed=11, surrogate=table)
    return observations.observations_from_cells(cells)


def brute_force_bulged(obs, table, gamma, E0t, R0):
    """ln of the integral over ln P by the trapezoid rule on a dense grid (no GH, no grid)."""
    z = np.linspace(-12, 12, 24001)
    out = []
    for j, i in enumerate(obs.bulged):
        s = obs.sd_log_P_bulge[j]
        log_P = obs.log_P_bulge[j] + s * z
        R, k = forward.cell_radius_and_stiffness(np.exp(log_P), gamma, E0t, R0, surrogate=table)
        # bulge factor N(ln P_hat; ln P, s) d ln P = N(z) dz, times the latent prior of ln P
        pop = obs.population
        if isinstance(pop, FlatPopulation):
            prior = -np.log(observations.LOG_P_LATENT[1] - observations.LOG_P_LATENT[0])
        elif isinstance(pop, GridPopulation):
            prior = pop.log_pdf(log_P)
        else:  # scipy's normal density, independent of NormalPopulation.log_pdf
            prior = stats.norm.logpdf(log_P, pop.mu, pop.tau)
        f = (stats.norm.logpdf(obs.R_c[i], R, obs.R_c_err[i])
             # relative stiffness error: sd = (k_err/k_obs) x model k
             + stats.norm.logpdf(obs.k_c[i], k, obs.k_c_err[i] / obs.k_c[i] * k)
             + stats.norm.logpdf(z) + prior)
        f = np.where(np.isfinite(f), f, -np.inf)
        m = f.max()
        out.append(np.log(np.trapezoid(np.exp(f - m), z)) + m)
    return np.array(out)


@pytest.mark.parametrize("theta", THETAS)
def test_quadrature_matches_brute_force(obs, table, theta):
    # the default rule must be within 1e-4 of dense quadrature for every bulged cell
    assert isinstance(obs.population, GridPopulation)  # the default latent prior: deconvolved
    ref = brute_force_bulged(obs, table, *theta[:3])
    lik = likelihood.CellLikelihood(obs, table)
    ours = lik.pointwise(*([v] for v in theta))[0, obs.bulged]
    assert np.all(np.isfinite(ref))
    assert_allclose(ours, ref, rtol=0, atol=1e-4)  # the brief asks < 1e-3; we get ~1e-5


@pytest.mark.parametrize("latent", ["population", "flat"])
def test_other_latent_priors_match_brute_force(table, latent):
    # the normal population and the flat (functional) prior against the same dense rule
    cells, _ = synthetic.simulate_cells(seed=11, surrogate=table)
    obs = observations.observations_from_cells(cells, latent=latent)
    assert isinstance(obs.population, FlatPopulation) == (latent == "flat")
    theta = THETAS[0]
    ref = brute_force_bulged(obs, table, *theta[:3])
    ours = likelihood.CellLikelihood(obs, table).pointwise(*([v] for v in theta))[0, obs.bulged]
    assert_allclose(ours, ref, rtol=0, atol=1e-4)
    with pytest.raises(ValueError, match="latent prior must be one of flat, population, deconvolved"):
        observations.observations_from_cells(cells, latent="uniform")


def test_population_prior_recovers_the_spread_of_true_pressures(rng):
    # simulated truth: ln P ~ N(ln 5 kPa, 0.8), observed with per-cell noise s in [0.05, 0.2];
    # method of moments: tau^2 = var(ln P_hat) - mean(s^2) estimates 0.8^2 (sd ~ 0.8/sqrt(2n))
    n = 20000
    s = rng.uniform(0.05, 0.2, n)
    log_P_hat = np.log(5e3) + 0.8 * rng.standard_normal(n) + s * rng.standard_normal(n)
    mu, tau = observations.population_prior(log_P_hat, s)
    assert_allclose(mu, np.log(5e3), atol=4 * 0.8 / np.sqrt(n))
    assert_allclose(tau, 0.8, atol=4 * 0.8 / np.sqrt(2 * n))
    # no spread beyond the noise: the floor; fewer than 3 cells: flat
    assert observations.population_prior(np.log(5e3) + 0.1 * rng.standard_normal(50),
                                       np.full(50, 0.1)).tau >= observations.MIN_POPULATION_SD
    assert isinstance(observations.population_prior([8.0, 9.0], [0.1, 0.1]), FlatPopulation)


def test_latent_prior_is_the_product_of_two_gaussians(rng):
    # closed form: N(a; x, s) N(x; mu, tau) = N(a; mu, sqrt(s^2 + tau^2)) N(x; c, sigma)
    obs = observations.CellObservations(
        is_bulged=np.array([True, True]), R_c=np.ones(2), R_c_err=np.ones(2), k_c=np.ones(2),
        k_c_err=np.ones(2), log_P_bulge=np.array([8.0, 10.5]), sd_log_P_bulge=np.array([0.1, 0.3]),
        bulged=np.array([0, 1]), intact=np.array([], int), population=NormalPopulation(9.0, 0.7))
    c, sd, log_norm = (a[0, :, 0] for a in observations.latent_prior(obs))
    x = rng.normal(9, 1, 5)[:, None]
    lhs = (stats.norm.logpdf(obs.log_P_bulge, x, obs.sd_log_P_bulge)
           + stats.norm.logpdf(x, 9.0, 0.7))
    rhs = log_norm + stats.norm.logpdf(x, c, sd)
    assert_allclose(lhs, rhs, rtol=0, atol=1e-12)


def test_quadrature_converges_with_nodes(obs, table):
    # doubling the nodes changes nothing beyond 1e-4 (adaptive GH converges fast)
    theta = [[v] for v in THETAS[0]]
    a = likelihood.CellLikelihood(obs, table, n_nodes=likelihood.DEFAULT_NODES).pointwise(*theta)
    b = likelihood.CellLikelihood(obs, table, n_nodes=2 * likelihood.DEFAULT_NODES).pointwise(
        *theta)
    assert_allclose(a, b, rtol=0, atol=1e-4)


def test_grid_interpolation_matches_direct_evaluation(obs, table):
    # reference: the forward model at every node (grid_step=None)
    theta = [np.array([t[i] for t in THETAS]) for i in range(4)]
    fast = likelihood.CellLikelihood(obs, table).pointwise(*theta)
    direct = likelihood.CellLikelihood(obs, table, grid_step=None).pointwise(*theta)
    assert_allclose(fast, direct, rtol=0, atol=1e-5)


def test_per_cell_parameter_path_matches_shared(obs, table):
    # per-cell arrays holding the same value everywhere (the direct path used by extensions)
    g, e, r, p = ([v] for v in THETAS[1])
    lik = likelihood.CellLikelihood(obs, table)
    shared = lik.bulged(np.array(g), np.array(e), np.array(r))
    per_cell = lik.bulged(np.array(g), np.full((1, obs.bulged.size), e[0]), np.array(r))
    assert_allclose(per_cell, shared, rtol=0, atol=1e-5)


def test_intact_cells_are_gaussian_at_P_phys(obs, table):
    # reference: scipy.stats.norm at the forward model's R_c, k_c at P_phys
    theta = THETAS[0]
    R, k = forward.cell_radius_and_stiffness(theta[3], *theta[:3], surrogate=table)
    i = obs.intact
    ref = stats.norm.logpdf(obs.R_c[i], R, obs.R_c_err[i]) + stats.norm.logpdf(
        obs.k_c[i], k, obs.k_c_err[i] / obs.k_c[i] * k)  # relative stiffness error
    direct = likelihood.CellLikelihood(obs, table, grid_step=None)
    assert_allclose(direct.pointwise(*([v] for v in theta))[0, i], ref, rtol=1e-12)
    # the interpolation grid (default) agrees to far below the measurement errors
    ours = likelihood.CellLikelihood(obs, table).pointwise(*([v] for v in theta))[0, i]
    assert_allclose(ours, ref, rtol=0, atol=1e-5)


def test_bulge_pressure_sd_propagates_radius_through_depth_ratio():
    # reference: d ln P_hat / d ln R_b by finite differences of bulge.pressure_from_bulge,
    # which must equal -(1 - epsilon) of the linearized error model
    k_b, R_b, h_b = 9e-4, 500e-9, 110e-9
    d = 1e-6
    slope = (np.log(bulge.pressure_from_bulge(k_b, R_b * np.exp(d), h_b))
             - np.log(bulge.pressure_from_bulge(k_b, R_b * np.exp(-d), h_b))) / (2 * d)
    rel_k, rel_R = 0.1, 0.08
    log_P, sd = observations.bulge_log_pressure(k_b, rel_k * k_b, R_b, rel_R * R_b, h_b)
    assert_allclose(log_P, np.log(bulge.pressure_from_bulge(k_b, R_b, h_b)), rtol=1e-14)
    assert_allclose(sd, np.hypot(rel_k, slope * rel_R), rtol=1e-6)
    assert -1 < slope < -0.6  # r(h/R_b) partly cancels the explicit 1/R_b (docs/physics.md, Bulge model)


def test_bulge_pressure_sd_matches_monte_carlo(rng):
    # reference: simulate the lognormal measurement model and look at the spread of ln P_hat
    k_b, R_b, h_b = 9e-4, 500e-9, 110e-9
    n = 20000
    k_obs = k_b * np.exp(0.1 * rng.standard_normal(n))
    R_obs = R_b * np.exp(0.08 * rng.standard_normal(n))
    spread = np.std(np.log(bulge.pressure_from_bulge(k_obs, R_obs, h_b)))
    _, sd = observations.bulge_log_pressure(k_b, 0.1 * k_b, R_b, 0.08 * R_b, h_b)
    assert_allclose(sd, spread, rtol=0.03)  # MC error ~0.5 %, linearization < 1 %


def test_hermite_rule_moments():
    # E[z^2] = 1, E[z^4] = 3, E[z^6] = 15 under N(0, 1): exact for >= 4 nodes
    z, log_w = quadrature.hermite_rule(6)
    w = np.exp(log_w)
    assert_allclose([w.sum(), w @ z**2, w @ z**4, w @ z**6], [1, 1, 3, 15], rtol=1e-12)
    with pytest.raises(ValueError, match="positive integer"):
        quadrature.hermite_rule(0)


def test_grid_slopes_match_finite_differences(table):
    # reference: central differences of the forward model in ln P
    g, e, r = (np.array([v]) for v in THETAS[0][:3])
    grid = pressure_grid.LogPressureGrid(np.log(500.0), np.log(60e3), likelihood.GRID_STEP, g, e,
                                      r, 5e3, table)
    log_P = np.log(np.geomspace(1e3, 40e3, 25))
    lnR, dlnR, lnk, dlnk = grid(log_P, slope=True)
    h = 1e-4
    R_hi, k_hi = forward.cell_radius_and_stiffness(np.exp(log_P + h), *THETAS[0][:3],
                                                   surrogate=table)
    R_lo, k_lo = forward.cell_radius_and_stiffness(np.exp(log_P - h), *THETAS[0][:3],
                                                   surrogate=table)
    assert_allclose(dlnR[0], (np.log(R_hi) - np.log(R_lo)) / (2 * h), rtol=1e-4)
    assert_allclose(dlnk[0], (np.log(k_hi) - np.log(k_lo)) / (2 * h), rtol=1e-3, atol=1e-5)


def test_undefined_model_gives_minus_infinity(obs, table):
    # a wall that cannot reach the intact cells' pressure (gamma < 1 past its maximum)
    lik = likelihood.CellLikelihood(obs, table)
    ll = lik.pointwise([0.5], [0.003], [464e-9], [150e3])
    assert np.all(ll[0, obs.intact] == -np.inf)


def test_score_at_the_truth_is_zero_on_simulated_data(table):
    # Bartlett's identity: for a correctly specified model the expected score at the truth is
    # zero, so over n independent cells mean(score)/SE ~ N(0, 1). Reference: the simulated
    # truth. Fails when the data and the likelihood disagree: with the reported k_c errors
    # of version 0.1's generator (relative error x *true* k_c) z is 3-10 for all four
    # parameters at this size. (The flat latent prior's bias, gamma z ~ -1.5 here, is too
    # small to test at this size; studies/calibration_bias.py measures it.)
    from turgorbayes.inference import models

    truth = synthetic.PAPER_TRUTH
    cells, _ = synthetic.simulate_cells(n_bulged=5000, n_intact=2500, seed=21, surrogate=table)
    z = _mean_score_z(models.BaselineModel(cells, table), truth)
    assert np.all(np.abs(z) < 3.5), z


def _mean_score_z(model, truth):
    """``mean(score)/SE`` per parameter at the truth (Bartlett's identity: ~ N(0, 1))."""
    u0 = model.to_u({p: getattr(truth, p) for p in model.names})[0]
    h = 1e-3 * np.maximum(np.abs(u0), 1.0)
    U = np.repeat(u0[None], 2 * u0.size, axis=0)
    U[0::2] += np.diag(h)
    U[1::2] -= np.diag(h)
    ll = model.pointwise_log_likelihood(U)
    score = (ll[0::2] - ll[1::2]) / (2 * h[:, None])
    return score.mean(axis=1) / (score.std(axis=1) / np.sqrt(score.shape[1]))


@pytest.mark.slow
def test_pooled_relative_errors_survive_error_bars_independent_of_the_noise(table):
    # simulated truth with the error columns written as relative error x *true* value (error
    # bars that do not follow the noise, e.g. a slope fit's standard error). Reading each
    # cell's dk/k_obs as its relative error weights the cells read high more: the mean score
    # at the truth is then far from zero (measured z 5.1, 4.5, 1.8, 9.3 for gamma, E0t, R0,
    # P_phys at this size; pooled: 0.5, 2.0, 0.2, -0.1); the default
    # pooled reading must keep every |z| < 3.5 (docs/statistics.md, "Observation model").
    from turgorbayes.inference import models, observations

    truth = synthetic.PAPER_TRUTH
    cells, _ = synthetic.simulate_cells(n_bulged=5000, n_intact=2500, seed=21, surrogate=table,
                                        errors=synthetic.ErrorModel(reported="true"))
    pooled = models.BaselineModel(cells, table)
    z = _mean_score_z(pooled, truth)
    assert np.all(np.abs(z) < 3.5), z
    per_cell = models.BaselineModel(cells, table)
    per_cell.obs = observations.observations_from_cells(cells, relative_errors="reported")
    per_cell.lik = likelihood.CellLikelihood(per_cell.obs, table)
    assert np.max(np.abs(_mean_score_z(per_cell, truth))) > 3.5
