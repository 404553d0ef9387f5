r"""Leave-one-out predictive accuracy of criticism posteriors and the gain of one model over another.

PSIS-LOO from weighted draws (:func:`psis_loo`), exact refits where Pareto k is large
(:func:`exact_loo`), and the pointwise comparison with its Bayesian-bootstrap probability of a
gain (:func:`compare`, :func:`gain_probability`); see ``docs/effects.md``.
"""

import math

import numpy as np
from scipy.special import logsumexp

from turgorbayes.criticism.posterior import _batched, _psis, _rng, fit_posterior

__all__ = ["compare", "exact_loo", "gain_probability", "psis_loo"]


def psis_loo(log_lik, log_w):
    """PSIS-LOO from weighted draws.

    .. math:: \\mathrm{elpd}_i = \\ln\\sum_s \\tilde v_{is}\\, p(y_i\\mid\\theta_s),\\qquad
              \\ln v_{is} = \\ln w_s - \\ln p(y_i\\mid\\theta_s)

    with :math:`\\tilde v` the Pareto-smoothed, normalized ratios (equal ``w`` for MCMC draws).

    Parameters
    ----------
    log_lik : ndarray (S, n)
    log_w : ndarray (S,)
        Normalized log weights of the draws.

    Returns
    -------
    dict
        ``elpd_i``, ``pareto_k``, ``lppd_i`` (ndarrays (n,)), ``elpd``, ``se``, ``p_loo``,
        ``good_k`` and ``n_bad`` (cells with k above ``good_k``).
    """
    ll = np.asarray(log_lik, float)
    S = ll.shape[0]
    lw, k = _psis((np.asarray(log_w, float)[:, None] - ll).T)
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

    Parameters
    ----------
    post : Posterior
    cells : turgorbayes.io.CellData
        The data ``post`` was fitted to.
    surrogate : turgorbayes.surrogate.Surrogate
    seed : int
    settings : CriticismSettings
    force : sequence of int
        Cells refitted whatever their k (for checks of the refit against PSIS).

    Returns
    -------
    dict
        :func:`psis_loo` output with ``elpd_i`` corrected, plus ``refitted`` (cell indices)
        and ``n_bad_left`` (bad cells not refitted, beyond ``settings.max_refits``).
    """
    loo = psis_loo(post.log_lik, post.log_w)
    bad = np.flatnonzero(loo["pareto_k"] > loo["good_k"])
    bad = bad[np.argsort(-loo["pareto_k"][bad])]
    n_bad = bad.size
    bad = np.concatenate([np.asarray(force, int), bad[~np.isin(bad, force)]])
    elpd_i = loo["elpd_i"].copy()
    refitted = []
    guess = post.model.to_physical(post.u_map[None])
    guess = {k: float(v[0]) for k, v in guess.items()}
    for n, i in enumerate(bad[:settings.max_refits]):
        keep = np.ones(post.model.obs.n_cells, bool)
        keep[i] = False
        sub = post.model.__class__(cells.take(keep), surrogate, effects=post.model.effects,
                                   P0=post.model.P0)
        p_i = fit_posterior(sub, guess, seed + 7919 * (n + 1), settings)
        ll_i = _batched(post.model.pointwise_log_likelihood, p_i.u, settings.batch)[:, i]
        elpd_i[i] = float(logsumexp(p_i.log_w + np.where(np.isnan(ll_i), -np.inf, ll_i)))
        refitted.append(int(i))
    out = dict(loo)
    out.update(elpd_i=elpd_i, elpd=float(elpd_i.sum()),
               se=float(math.sqrt(elpd_i.size * np.var(elpd_i))),
               p_loo=float(loo["lppd_i"].sum() - elpd_i.sum()), refitted=refitted,
               n_bad_left=int(max(n_bad - settings.max_refits, 0)))
    return out


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
            gain_probability(d, _rng(seed, 17), n_boot))


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
