r"""The plug-in population's own estimation noise, carried into the posterior.

Why
---
The bulged cells' latent pressures are integrated against a population density ``g``
deconvolved once from the bulge estimates and then held fixed (a plug-in, empirical-Bayes
prior: :mod:`turgorbayes.inference.population`). That estimate is noisy, and a posterior
computed with a fixed ``g`` does not know it. Measured (docs/validation.md, "Calibration as
experiments grow"): refitting a data set with a population deconvolved from an *independent*
data set's bulges moves ``gamma``'s posterior mean by 0.26 (10x the paper's cells) to 0.31
(20x) posterior sds per estimate of ``g``; that is part of why the hard-edged design's
intervals are too narrow at 20x. A hierarchical population (``g``'s spline coefficients
sampled with the wall parameters) carries this noise too, but costs about 100x the fit.

Method: a two-step correction (Murphy & Topel, J. Bus. Econ. Stat. 3, 370, 1985), in the
posterior's form
----------------------------------------------------------------------------------------
The posterior that knows ``g`` only up to its estimate's noise is the plug-in's posterior
averaged over that noise, ``p(u | data) = E_g[p(u | data, g)]``. To first order in the change
of ``g`` only the mode moves, by

.. math::

    \delta_b = C\,\big[\nabla_u \ln p(u^* \mid \mathrm{data}, g_b)
                       - \nabla_u \ln p(u^* \mid \mathrm{data}, \hat g)\big],

with ``u*`` the mode, ``C`` the Laplace covariance there and ``g_b`` a draw of the estimate's
noise: the population deconvolved (same grid, same number of spline functions) from the
``b``-th bootstrap resample of the bulge estimates (Efron & Tibshirani 1993; ``B =``
:data:`N_BOOTSTRAP`). So the averaged posterior is the plug-in's convolved with
``N(0, Sigma_g)``, ``Sigma_g = Cov_b(delta_b)``: :func:`carry` adds an independent draw of it
to every posterior draw. The shifts are centred (the plug-in's location is kept; their mean
would be a bootstrap bias estimate, a different question).

Measured (``studies/population_noise.py``; docs/validation.md, "The plug-in population's
noise, carried"): the bootstrap's shift sds match those of populations from independent data
sets (20x the paper's cells, 40 data sets: ``gamma`` 0.320 against 0.330 posterior sds,
``E0t`` 0.276 / 0.264, ``R0`` 0.159 / 0.154, ``P_phys`` 0.174 / 0.182); the linear shift and
an exact refit of the mode differ by a median 0.0015 posterior sds (95th percentile 0.009, 80
populations). Intervals widen by ``sqrt(1 + r^2)``, ``r`` the shift's sd in posterior sds:
0.3-0.9 % at the paper's size (``r`` 0.08-0.14), 3.7-5.0 % for ``E0t`` and ``gamma`` at 20x,
where it brings ``gamma``'s 90 % intervals on the hard-edged design from 85.0 to 88.0 %
coverage (300 data sets).

Only a population estimated from the bulges by deconvolution
(:class:`~turgorbayes.inference.population.DeconvolvedPopulation`, the default) is
resampled; any other population is treated as known (``Sigma_g = 0``). With an effect that
widens the bulge (``extra_log_sd``), each ``g_b`` is again a family of populations in it.
"""

import contextlib
import dataclasses

import numpy as np

from turgorbayes.inference.likelihood import CellLikelihood
from turgorbayes.inference.mode import value_and_gradient
from turgorbayes.inference.population import DeconvolvedPopulation, deconvolve_family

__all__ = ["N_BOOTSTRAP", "bootstrap_populations", "bootstrap_shifts", "carry", "mode_shifts",
           "shift_covariance", "using_population"]

#: Bootstrap populations per fit: the relative sd of a variance estimated from ``B`` shifts is
#: ``sqrt(2/(B - 1))`` (32 % at 20), and ``Sigma_g`` is 5-10 % of the posterior's variance at
#: 10-20x the paper's cells, so the total variance is known to about 3 %.
N_BOOTSTRAP = 20


def bootstrap_populations(population, n_boot, rng):
    """Populations deconvolved from ``n_boot`` bootstrap resamples of the bulge estimates.

    Parameters
    ----------
    population : DeconvolvedPopulation
        The plug-in (its estimates ``log_P_hat``, ``sd``, grid, ``df`` and ``penalty`` are
        reused).
    n_boot : int
    rng : numpy.random.Generator

    Returns
    -------
    list of DeconvolvedPopulation
    """
    x, s = population.log_P_hat, population.sd
    out = []
    for _ in range(int(n_boot)):
        i = rng.integers(0, x.size, x.size)
        out.append(deconvolve_family(x[i], s[i], sigmas=population.sigmas, df=population.df,
                                     penalty=population.penalty, grid=population.grid))
    return out


@contextlib.contextmanager
def using_population(model, population):
    """``model`` with its latent population replaced by ``population`` inside the block (its
    likelihood rebuilt), restored afterwards."""
    obs, lik = model.obs, model.lik
    model.obs = dataclasses.replace(obs, population=population)
    model.lik = CellLikelihood(model.obs, lik.surrogate, n_nodes=lik.n_nodes, P0=lik.P0)
    try:
        yield model
    finally:
        model.obs, model.lik = obs, lik


def mode_shifts(model, u_map, cov, populations):
    """Linearized moves of the posterior mode when the population is each of ``populations``.

    Parameters
    ----------
    model : turgorbayes.inference.models.BaselineModel
        Its ``obs.population`` is the plug-in; ``model`` is left as it was.
    u_map : ndarray (ndim,)
        Posterior mode (sampler coordinates).
    cov : ndarray (ndim, ndim)
        Laplace covariance at ``u_map``.
    populations : sequence

    Returns
    -------
    ndarray (len(populations), ndim)
        ``delta_b`` of the module docstring (sampler coordinates).
    """
    g0 = value_and_gradient(model, u_map)[1]
    shifts = []
    for pop in populations:
        with using_population(model, pop):
            shifts.append(cov @ (value_and_gradient(model, u_map)[1] - g0))
    return np.array(shifts).reshape(len(shifts), u_map.size)


def bootstrap_shifts(model, u_map, cov, seed, n_boot=N_BOOTSTRAP):
    """The ``n_boot`` bootstrap populations of the model's plug-in (a
    :class:`DeconvolvedPopulation`) and the mode's shift under each, ``(n_boot, ndim)``
    (:func:`mode_shifts`); ``seed`` fixes the resamples."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 2718]))
    pops = bootstrap_populations(model.obs.population, n_boot, rng)
    return pops, mode_shifts(model, u_map, cov, pops)


def shift_covariance(model, u_map, cov, seed, n_boot=N_BOOTSTRAP):
    """``Sigma_g`` of the module docstring, ``(ndim, ndim)`` in sampler coordinates (zeros when
    the model's population was not deconvolved from its bulges)."""
    if not isinstance(model.obs.population, DeconvolvedPopulation):
        return np.zeros((u_map.size, u_map.size))
    shifts = bootstrap_shifts(model, u_map, cov, seed, n_boot)[1]
    return np.cov(shifts, rowvar=False).reshape(cov.shape)


def carry(u, sigma_g, rng, log_prior=None, max_rounds=20):
    """Posterior draws ``u (..., ndim)`` each moved by an independent ``N(0, sigma_g)`` draw.

    ``log_prior``: vectorized ``(n, ndim) -> (n,)``; a moved draw where it is not finite is
    moved again (up to ``max_rounds`` times, then left where the sampler put it): each
    posterior averaged over the population is zero outside the prior's support, so the
    convolution is cut to it.
    """
    u = np.asarray(u, float)
    if not np.any(sigma_g):
        return u.copy()
    flat = u.reshape(-1, u.shape[-1])
    out = flat.copy()
    todo = np.arange(len(flat))
    for _ in range(max_rounds):
        moved = flat[todo] + rng.multivariate_normal(np.zeros(u.shape[-1]), sigma_g,
                                                     size=todo.size, method="eigh")
        ok = np.ones(todo.size, bool) if log_prior is None else np.isfinite(log_prior(moved))
        out[todo[ok]] = moved[ok]
        todo = todo[~ok]
        if not todo.size:
            break
    return out.reshape(u.shape)
