"""The result of every posterior engine: :class:`Posterior` (weighted draws), its ArviZ
DataTree (:func:`datatree`), and weighted summaries (docs/statistics.md, "One posterior
engine")."""

from dataclasses import dataclass, field

import numpy as np

from turgorbayes.parallel import ordered_map, pool_map, pool_open
from turgorbayes.physics.parameters import DERIVED, QUANTITIES

__all__ = ["Posterior", "batched", "datatree", "log_lik_and_prior", "log_posterior_draws", "resample",
           "weighted_quantiles", "weighted_stats"]

#: Display key and SI factor of the derived moduli in summaries.
_DERIVED = {name: (QUANTITIES[name].key, QUANTITIES[name].factor) for name in DERIVED}


@dataclass
class Posterior:
    """Weighted draws of one model's posterior.

    Attributes
    ----------
    model : object
        The model sampled (``to_physical``, ``log_prior``, ``pointwise_log_likelihood`` ...).
    u : ndarray (S, ndim)
        Draws in sampler coordinates (emcee: chain-major, ``n_chains`` chains).
    log_w : ndarray (S,)
        Normalized log weights (``-ln S`` each for MCMC and Laplace draws).
    log_lik : ndarray (S, n_cells) or None
        Pointwise log-likelihood of every draw (None when not asked for:
        :func:`fit_posterior` with ``pointwise=False``).
    engine : str
        ``"importance"``, ``"emcee"`` or ``"laplace"``.
    converged : bool
    reasons : list of str
        Why not converged (empty if converged).
    diagnostics : dict
        ``k_hat`` and ``ess`` (importance) or ``chain`` (R-hat, ESS per parameter) and
        ``n_steps``, ``tau``, ``stuck`` (emcee).
    u_map, cov : ndarray
        Posterior mode and inverse Hessian there (sampler coordinates).
    attempts : list of dict
        Earlier engine runs that did not converge (``engine``, ``converged``, ``reasons``,
        ``effort``), in order; empty when the first run converged.
    laplace : dict or None
        :meth:`turgorbayes.inference.mode.LaplaceFit.record` of the mode search and Hessian.
    lp : ndarray (S,) or None
        Log posterior of every draw.
    n_chains : int
        Chains ``u`` is made of (emcee: the ensembles; 1 otherwise).
    run : turgorbayes.inference.sampling.SamplingResult or None
        emcee's run (steps, burn-in, thinning, acceptance ...).
    """

    model: object
    u: np.ndarray
    log_w: np.ndarray
    log_lik: np.ndarray
    engine: str
    converged: bool
    reasons: list
    diagnostics: dict
    u_map: np.ndarray
    cov: np.ndarray
    attempts: list = field(default_factory=list)
    laplace: dict = None
    lp: np.ndarray = None
    n_chains: int = 1
    run: object = field(default=None, repr=False)

    @property
    def weights(self):
        return np.exp(self.log_w)

    @property
    def ess(self):
        """Effective sample size of the weights, ``1/sum w^2`` (S for equal weights)."""
        return float(1.0 / np.sum(self.weights**2))

    def chains(self, a):
        """``a`` (S, ...) per draw as ``(n_chains, S / n_chains, ...)``."""
        a = np.asarray(a)
        return a.reshape((self.n_chains, -1) + a.shape[1:])

    def convergence(self):
        """The per-candidate convergence record of ``criticism.json``.

        Returns
        -------
        dict
            ``engine``, ``converged``, ``reasons`` (of the final run), ``attempts`` (the
            earlier runs that did not converge) and ``laplace`` (mode search and Hessian).
        """
        return {"engine": self.engine, "converged": bool(self.converged),
                "reasons": list(self.reasons), "attempts": list(self.attempts),
                "laplace": self.laplace}

    def attempt(self, effort):
        """This run as an entry of ``attempts``."""
        return {"engine": self.engine, "converged": bool(self.converged),
                "reasons": list(self.reasons), "effort": effort}

    def resample(self, n, rng):
        """Indices of ``n`` draws resampled by weight (:func:`resample`)."""
        return resample(self.weights, n, rng)

    def physical(self, rng):
        """``{name: (S,)}`` physical values of every parameter and the derived moduli (SI)."""
        out = self.model.to_physical(self.u)
        out.update(batched(lambda u: self.model.derived(u, rng), self.u, 512))
        return out

    def summary(self, rng):
        """Per-parameter summaries keyed like ``summary.json`` (display units).

        Returns
        -------
        dict
            ``{key: {"mean", "sd", "q05", "q50", "q95", "r_hat", "ess_bulk", "ess_tail"}}``;
            for importance sampling ``r_hat`` is None and both ESS are the weights' ESS.
        """
        values = self.physical(rng)
        chain = self.diagnostics.get("chain", {})
        out = {}
        for name, (key, unit) in _display(self.model).items():
            entry = {k: v / unit for k, v in weighted_stats(values[name], self.weights).items()}
            d = chain.get(name)
            if d is None:
                entry.update(r_hat=None, ess_bulk=self.ess, ess_tail=self.ess)
            else:
                entry.update({k: (None if not np.isfinite(d[k]) else float(d[k]))
                              for k in ("r_hat", "ess_bulk", "ess_tail")})
            out[key] = entry
        return out

    def datatree(self, rng, cell_ids=None):
        """The posterior as an ArviZ DataTree (:func:`datatree`): ``posterior`` (every
        parameter and the derived moduli, SI, ``(n_chains, draws)``), ``log_likelihood``
        (``cells``) when known, and ``sample_stats`` (``lp``, and ``log_weight``, the
        normalized log weights, where importance sampling is used: draws then count by
        ``exp(log_weight)``, not equally)."""
        posterior = {k: self.chains(v) for k, v in self.physical(rng).items()}
        lp = self.lp if self.lp is not None else log_posterior_draws(self)
        log_weight = self.chains(self.log_w) if self.engine == "importance" else None
        log_lik = None if self.log_lik is None else self.chains(self.log_lik)
        return datatree(posterior, log_lik, self.chains(lp), log_weight, cell_ids)


def datatree(posterior, log_lik, lp, log_weight=None, cell_ids=None, groups=None, dims=None):
    """The DataTree of a posterior, the one layout of ``posterior.nc``.

    Parameters
    ----------
    posterior : dict
        Name -> ``(chain, draw, ...)`` SI.
    log_lik : ndarray (chain, draw, cell) or None
        Pointwise log-likelihood (group ``log_likelihood``, variable ``cells``).
    lp : ndarray (chain, draw)
        Log posterior (``sample_stats.lp``).
    log_weight : ndarray (chain, draw), optional
        Normalized log importance weights (``sample_stats.log_weight``).
    cell_ids : sequence of str, optional
        Coordinates of the ``cell`` dimension.
    groups : dict, optional
        More groups (``posterior_predictive``, ``observed_data``, ``constant_data`` ...).
    dims : dict, optional
        Variable -> dimension names beyond ``(chain, draw)``.
    """
    import arviz_base as azb

    data = {"posterior": dict(posterior)}
    if log_lik is not None:
        data["log_likelihood"] = {"cells": log_lik}
    data.update(groups or {})
    data["sample_stats"] = {"lp": lp}
    if log_weight is not None:
        data["sample_stats"]["log_weight"] = log_weight
    coords = None if cell_ids is None else {"cell": list(cell_ids)}
    dims = {"cells": ["cell"], **(dims or {})} if cell_ids is not None else dims
    return azb.from_dict(data, dims=dims, coords=coords)


def resample(weights, n, rng):
    """Indices of ``n`` draws resampled by ``weights`` (systematic resampling: one uniform
    from ``rng``)."""
    c = np.cumsum(weights)
    c /= c[-1]
    return np.minimum(np.searchsorted(c, (rng.random() + np.arange(n)) / n), c.size - 1)


def log_posterior_draws(post):
    """Log posterior of every draw (from the stored log-likelihood when there is one)."""
    if post.log_lik is not None:
        lp = np.asarray(post.model.log_prior(post.u), float) + post.log_lik.sum(axis=1)
    else:
        lp = batched(post.model.log_posterior, post.u, 512)
    return np.where(np.isnan(lp), -np.inf, lp)


def _display(model):
    """posterior name -> (summary key, SI per display unit), baseline first, then effects."""
    out = {p.name: (p.key, p.factor) for p in model.parameters[:4]}
    out.update(_DERIVED)
    out.update({p.name: (p.key, p.factor) for p in model.parameters[4:]})
    return out


def batched(fn, u, batch):
    """Apply ``fn`` to the rows of ``u`` in batches of ``batch`` (bounded memory).

    Concatenates the results: arrays along their first axis, dicts of arrays key by key.
    """
    parts = [fn(u[i:i + batch]) for i in range(0, len(u), batch)]
    if isinstance(parts[0], dict):
        return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return np.concatenate(parts)


def weighted_quantiles(x, w, qs):
    """Quantiles ``qs`` of draws ``x`` with weights ``w``: arviz-stats' quantile with weights
    (the inverse of the weighted empirical CDF, numpy's ``"inverted_cdf"``; integer weights
    give the quantiles of the draws repeated that many times)."""
    x, w = np.asarray(x, float), np.asarray(w, float)
    # imported here: arviz_stats takes ~0.9 s to import, which the commands that
    # never weigh draws (simulate, curves, validate) do without
    from arviz_stats.base import array_stats

    return array_stats.quantile(x, qs, weights=w / np.sum(w), method="inverted_cdf")


def weighted_stats(x, w):
    """Mean, sd and the 5/50/95 % quantiles of weighted draws (non-finite draws ignored)."""
    x = np.asarray(x, float)
    ok = np.isfinite(x)
    x, w = x[ok], w[ok] / np.sum(w[ok])
    q = weighted_quantiles(x, w, [0.05, 0.5, 0.95])
    mean = float(np.sum(w * x))
    return {"mean": mean, "sd": float(np.sqrt(np.sum(w * (x - mean) ** 2))), "q05": float(q[0]),
            "q50": float(q[1]), "q95": float(q[2])}


# ------------------------------------------------------------------------------ engines
#: The model of :func:`log_lik_and_prior`'s parallel batches: set before the pool forks, so
#: the workers inherit it instead of receiving a pickled copy with every batch.
_SHARED = {}


def log_lik_and_prior(model, u, batch, workers=1):
    """Pointwise log-likelihood ``(S, n_cells)`` and log prior ``(S,)`` of the draws ``u``.

    Parameters
    ----------
    model : object
        ``log_prior`` and ``pointwise_log_likelihood`` of sampler coordinates.
    u : ndarray (S, ndim)
        Draws (sampler coordinates).
    batch : int
        Draws per vectorized likelihood call.
    workers : int
        Processes the batches are spread over (:func:`turgorbayes.parallel.ordered_map`,
        forked). Every batch holds the same draws whatever the number of workers, so the
        result is the serial one bit for bit (a batch's rules depend on all its draws, e.g.
        the dense rule's panels, so the batches, not the draws, are the unit of work).

    Returns
    -------
    ll : ndarray (S, n_cells)
        -inf where the prior or the likelihood is not finite.
    lp0 : ndarray (S,)
    """
    lp0 = model.log_prior(u)
    ll = np.full((len(u), model.obs.n_cells), -np.inf)
    ok = np.isfinite(lp0)
    if ok.any():
        with np.errstate(all="ignore"):
            ll[ok] = _pointwise_batches(model, u[ok], batch, workers)
    ll = np.where(np.isnan(ll), -np.inf, ll)
    return ll, np.where(ok, lp0, -np.inf)


def _pointwise_batches(model, u, batch, workers):
    """:func:`batched` ``model.pointwise_log_likelihood`` over ``u``, the batches on
    ``workers`` forked processes, or on the workers of an open
    :func:`turgorbayes.parallel.task_pool` (a fit in one of its threads)."""
    starts = range(0, len(u), batch)
    if pool_open() or workers <= 1 or len(starts) <= 1:  # on the task pool, or here
        return np.concatenate(pool_map(_pointwise_rows, model, [(u[i:i + batch],)
                                                                for i in starts]))
    _SHARED.update(model=model, u=u, batch=batch)
    try:
        parts = ordered_map(_pointwise_batch, list(starts), workers, chunksize=1)
    finally:
        _SHARED.clear()
    return np.concatenate(parts)


def _pointwise_rows(model, u):
    """One batch of :func:`_pointwise_batches` (here, or a task pool's worker's task)."""
    with np.errstate(all="ignore"):
        return model.pointwise_log_likelihood(u)


def _pointwise_batch(start):
    """One batch of :func:`_pointwise_batches` (a worker's task; the model from ``_SHARED``)."""
    model, u = _SHARED["model"], _SHARED["u"]
    with np.errstate(all="ignore"):
        return model.pointwise_log_likelihood(u[start:start + _SHARED["batch"]])
