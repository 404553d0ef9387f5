r"""Leave-one-out predictive accuracy of criticism posteriors and the gain of one model over another.

PSIS-LOO from weighted draws (:func:`psis_loo`), exact refits where Pareto k is large
(:func:`exact_loo`), and the pointwise comparison with its Bayesian-bootstrap probability of a
gain (:func:`compare`, :func:`gain_probability`); see ``docs/effects.md``.
"""

import dataclasses
import math

import numpy as np
from scipy.special import logsumexp

from turgorbayes.inference.engine import (
    batched,
    fit_posterior,
    given_laplace,
    psis_weights,
    stream_rng,
    stream_seed,
)
from turgorbayes.inference.mode import laplace_fit

__all__ = ["compare", "exact_loo", "gain_probability", "psis_loo", "with_full_data_observations"]


def psis_loo(log_lik, log_w):
    """PSIS-LOO from weighted draws.

    .. math:: \\mathrm{elpd}_i = \\ln\\sum_s \\tilde v_{is}\\, p(y_i\\mid\\theta_s),\\qquad
              \\ln v_{is} = \\ln w_s - \\ln p(y_i\\mid\\theta_s)

    with :math:`\\tilde v` the Pareto-smoothed, normalized LOO ratios. ``w`` are the draws'
    weights as given: equal for MCMC draws; for an importance-sampled posterior the stored
    :attr:`Posterior.log_w`, which are already Pareto-smoothed (not the raw
    posterior/proposal ratios). The ``pareto_k`` of a cell therefore judges the leave-one-out
    step given those weights; the importance step is judged by its own ``k_hat``
    (:func:`~turgorbayes.criticism.importance_posterior`).

    Parameters
    ----------
    log_lik : ndarray (S, n)
    log_w : ndarray (S,)
        Normalized log weights of the draws (Pareto-smoothed ones for importance sampling).

    Returns
    -------
    dict
        ``elpd_i``, ``pareto_k``, ``lppd_i`` (ndarrays (n,)), ``elpd``, ``se``, ``p_loo``,
        ``good_k`` and ``n_bad`` (cells with k above ``good_k``).
    """
    ll = np.asarray(log_lik, float)
    S = ll.shape[0]
    lw, k = psis_weights((np.asarray(log_w, float)[:, None] - ll).T)
    elpd_i = logsumexp(lw + ll.T, axis=1)
    lppd_i = logsumexp(log_w[:, None] + ll, axis=0)
    good_k = min(1 - 1 / math.log10(S), 0.7)
    k = np.asarray(k, float)
    return {"elpd_i": elpd_i, "pareto_k": k, "lppd_i": lppd_i,
            "elpd": float(elpd_i.sum()), "se": float(math.sqrt(elpd_i.size * np.var(elpd_i))),
            "p_loo": float(lppd_i.sum() - elpd_i.sum()), "good_k": good_k,
            "n_bad": int(np.count_nonzero(k > good_k))}


def exact_loo(post, cells, surrogate, seed, settings, force=()):
    """Replace PSIS values of cells with large Pareto k by exact leave-one-out refits.

    Cell ``i`` is refitted on the other cells and scored by the full model, both reading the
    cells as the full data do (:func:`with_full_data_observations`: the latent-pressure
    population and pooled errors of the full data), as the PSIS values of every other cell
    do, whose leave-one-out posteriors are reweighted full-data posteriors. Both are estimated
    from data every candidate model shares (bulge pressures, reported errors), so what cell
    ``i`` contributes to them is common to all models and cancels in their comparison
    (``docs/statistics.md``, "Posterior engines of the criticism").

    Parameters
    ----------
    post : Posterior
    cells : turgorbayes.cells.table.CellData
        The data ``post`` was fitted to.
    surrogate : turgorbayes.surrogate.Surrogate
    seed : int
        The seed ``post`` was fitted with; the refit of cell ``i`` takes stream 19 of it keyed
        by the cell's ``cell_id`` (:func:`~turgorbayes.inference.engine.stream_seed`), so its
        draws do not depend on which other cells are refitted, or in which order.
    settings : CriticismSettings
    force : sequence of int
        Cells refitted whatever their k (for checks of the refit against PSIS).

    Returns
    -------
    dict
        :func:`psis_loo` output with ``elpd_i`` corrected, plus ``refitted`` (cell indices),
        ``refits_unconverged`` (those whose refit did not converge: fitted with the engines'
        ordinary effort, without the re-runs of :func:`fit_posterior`) and ``n_bad_left``
        (bad cells not refitted, beyond ``settings.max_refits``).
    """
    loo = psis_loo(post.log_lik, post.log_w)
    bad = np.flatnonzero(loo["pareto_k"] > loo["good_k"])
    bad = bad[np.argsort(-loo["pareto_k"][bad])]
    n_bad = bad.size
    bad = np.concatenate([np.asarray(force, int), bad[~np.isin(bad, force)]])
    elpd_i = loo["elpd_i"].copy()
    refitted, unconverged = [], []
    # a refit gets the engines' ordinary effort, not the re-runs (up to max_refits per model)
    refit_settings = dataclasses.replace(settings, retry_factor=1.0)
    cov = posterior_covariance(post) if bad.size and settings.max_refits else None
    for i in bad[:settings.max_refits]:
        keep = np.ones(post.model.obs.n_cells, bool)
        keep[i] = False
        sub = post.model.without(keep, cells, surrogate, with_full_data_observations)
        # the refit's own mode, and the full posterior's covariance around it (one cell fewer
        # moves the posterior little; its draws' covariance is exact where the Laplace one at
        # the mode is not: a curved ridge of two near-degenerate effects)
        start = given_laplace(sub, laplace_fit(sub, post.u_map).u_map, cov)
        # the refit's own pointwise log-likelihood is not needed (the full model scores it)
        p_i = fit_posterior(sub, None, stream_seed(seed, 19, str(cells.cell_id[i])),
                            refit_settings, laplace=start, pointwise=False)
        if not p_i.converged:
            unconverged.append(int(i))
        ll_i = batched(post.model.pointwise_log_likelihood, p_i.u, settings.batch)[:, i]
        elpd_i[i] = float(logsumexp(p_i.log_w + np.where(np.isnan(ll_i), -np.inf, ll_i)))
        refitted.append(int(i))
    out = dict(loo)
    out.update(elpd_i=elpd_i, elpd=float(elpd_i.sum()),
               se=float(math.sqrt(elpd_i.size * np.var(elpd_i))),
               p_loo=float(loo["lppd_i"].sum() - elpd_i.sum()), refitted=refitted,
               refits_unconverged=unconverged,
               n_bad_left=int(max(n_bad - settings.max_refits, 0)))
    return out


def posterior_covariance(post):
    """Weighted covariance of a posterior's draws (sampler coordinates): where the draws are
    fewer than the parameters can be told apart by, the Laplace covariance ``post.cov``."""
    w = np.exp(post.log_w - logsumexp(post.log_w))
    if 1.0 / np.sum(w ** 2) <= 10 * post.u.shape[1]:
        return post.cov
    return np.atleast_2d(np.cov(post.u, rowvar=False, aweights=w))


#: CellObservations fields with one entry per cell, per bulged cell, and the group indices.
_PER_CELL = ("is_bulged", "R_c", "R_c_err", "k_c", "k_c_err")
_PER_BULGED = ("log_P_bulge", "sd_log_P_bulge")


def with_full_data_observations(model, full_obs, keep):
    """``model`` (fitted to the cells ``keep``) reading the full data's observations of them.

    :func:`~turgorbayes.inference.observations.observations_from_cells` estimates the
    latent-pressure population, and pools the relative errors per group, from the model's own
    cells; a leave-one-out refit must read its cells exactly as the full model does
    (:func:`exact_loo`). The model's observations are replaced and its likelihood rebuilt on
    them (the model is edited in place and returned).

    Parameters
    ----------
    model : turgorbayes.effects.ExtendedModel
    full_obs : turgorbayes.inference.observations.CellObservations
    keep : ndarray of bool (n_cells,)

    Returns
    -------
    model
    """
    fields = {f.name for f in dataclasses.fields(full_obs)}
    unknown = (fields - set(_PER_CELL) - set(_PER_BULGED)
               - {"bulged", "intact", "population", "rho_R_k"})
    if unknown or model.lik.obs is not model.obs:
        raise ValueError(f"{model.name}: cannot subset the observations for a leave-one-out refit "
                         f"(unknown fields {sorted(unknown)}, or the likelihood holds other "
                         "observations than the model)")
    keep = np.asarray(keep, bool)
    new = {k: np.asarray(getattr(full_obs, k))[keep] for k in _PER_CELL}
    if full_obs.rho_R_k is not None:  # the cells' known error correlations; None where they
        # could not be matched to these cells (the likelihood warned and read them as unknown)
        same = np.shape(full_obs.rho_R_k) == keep.shape
        new["rho_R_k"] = np.asarray(full_obs.rho_R_k, float)[keep] if same else None
    keep_b = keep[full_obs.bulged]
    new.update({k: np.asarray(getattr(full_obs, k))[keep_b] for k in _PER_BULGED})
    new.update(bulged=np.flatnonzero(new["is_bulged"]), intact=np.flatnonzero(~new["is_bulged"]),
               population=full_obs.population)
    model.obs = dataclasses.replace(full_obs, **new)
    lik = model.lik
    model.lik = type(lik)(model.obs, model.surrogate, n_nodes=lik.n_nodes, P0=lik.P0,
                          grid_step=lik.grid_step, adapt=lik.adapt)
    return model


def compare(loo_ext, loo_base, seed=0, n_boot=4000):
    """Gain of an extension over the same cells.

    Returns
    -------
    delta : float
        :math:`\\Delta = \\sum_i (\\mathrm{elpd}^{ext}_i - \\mathrm{elpd}^{base}_i)` [nats].
    se : float
        :math:`\\sqrt{n\\,\\mathrm{var}_i(\\Delta_i)}`.
    p_gain : float
        Bayesian-bootstrap probability that the gain is positive (:func:`gain_probability`).
    """
    d = np.asarray(loo_ext["elpd_i"]) - np.asarray(loo_base["elpd_i"])
    return (float(d.sum()), float(math.sqrt(d.size * np.var(d))),
            gain_probability(d, stream_rng(seed, 17), n_boot))


def gain_probability(d, rng, n_boot=4000):
    """Bayesian-bootstrap probability that :math:`\\sum_i d_i > 0` (Rubin, Ann. Stat. 9, 130, 1981).

    The pointwise differences are reweighted by flat-Dirichlet weights:
    :math:`P(n\\sum_i w_i d_i > 0)`, ``w ~ Dirichlet(1, ..., 1)``. For normally distributed
    differences this is :math:`\\Phi(\\Delta/\\mathrm{se})`; unlike the normal approximation it
    stays right when the gain comes from a few cells (outliers), where the se is dominated by
    those cells (Sivula et al., arXiv:2008.10296).

    Parameters
    ----------
    d : ndarray (n,)
        Pointwise elpd differences.
    rng : numpy.random.Generator
    n_boot : int

    Returns
    -------
    float
    """
    d = np.asarray(d, float)
    w = rng.dirichlet(np.ones(d.size), size=n_boot)
    return float(np.mean(w @ d > 0))
