r"""The one posterior engine of fit, criticism and SBC: settings, seeds, engines, one ladder.

Every posterior of the package comes from :func:`fit_posterior`:

* one settings type, :class:`Settings` (:meth:`Settings.for_criticism` gives the criticism's
  defaults; ``turgorbayes.workflows.fit.FitSettings`` and
  ``turgorbayes.workflows.criticize.CriticismSettings`` are these two);
* one seed scheme, :func:`stream_rng` (``SeedSequence([seed, stream, *keys])``; every use has
  its own stream number, listed in :data:`STREAMS`, and a named thing, such as a candidate
  model or a cell, its own key, :func:`stable_key`; :func:`stream_seed` is the integer seed of
  a stream, for a function that takes a seed);
* three engines from one Laplace fit (:func:`turgorbayes.inference.mode.laplace_fit`, or the
  caller's mode and covariance): ``"emcee"`` (:func:`mcmc_posterior`), ``"importance"``
  (:func:`importance_posterior`, PSIS) and ``"laplace"`` (:func:`laplace_posterior`, draws
  from the normal approximation);
* one ladder (:func:`fit_posterior`): more effort while a posterior is unconverged, and the
  mode search restarted from any draw that beats the mode;
* one convergence rule per engine (:func:`judge`), written into :attr:`Posterior.converged`
  and :attr:`Posterior.reasons`;
* one result, :class:`Posterior` (weighted draws; :meth:`Posterior.datatree` gives the ArviZ
  DataTree with the weights as ``sample_stats.log_weight`` where importance sampling is used).

The design and its references: ``docs/statistics.md``, "One posterior engine".
"""

import dataclasses
import hashlib
import logging
from dataclasses import dataclass, field

import numpy as np
from arviz_stats.base import array_stats
from scipy import stats
from scipy.special import logsumexp

from turgorbayes.inference import diagnostics, sampling
from turgorbayes.inference import population_noise as pop_noise
from turgorbayes.inference.likelihood import DEFAULT_NODES
from turgorbayes.inference.mode import LaplaceFit, ModeSearch, laplace_fit
from turgorbayes.physics.parameters import DERIVED, QUANTITIES

__all__ = [
    "ENGINES",
    "K_MAX",
    "MAX_MODE_RESTARTS",
    "MODE_BEATEN_NATS",
    "START_SHRINK",
    "START_SPREAD",
    "STREAMS",
    "Posterior",
    "Settings",
    "batched",
    "datatree",
    "fit_posterior",
    "given_laplace",
    "importance_posterior",
    "judge",
    "laplace_posterior",
    "mcmc_posterior",
    "psis_weights",
    "resample",
    "stable_key",
    "stream_rng",
    "stream_seed",
    "walker_start",
    "weighted_quantiles",
    "weighted_stats",
]

logger = logging.getLogger(__name__)

#: The engines of :func:`fit_posterior`.
ENGINES = ("emcee", "importance", "laplace")
#: Largest acceptable Pareto k of an importance-sampled posterior.
K_MAX = 0.7
#: A draw whose log posterior exceeds the mode's by more than this [nats] means the mode
#: search failed: it is restarted from that draw.
MODE_BEATEN_NATS = 1.0
#: Restarts of the mode search from a beating draw; each runs the importance sampler again
#: from the new mode before any emcee run (emcee starts from the last mode).
MAX_MODE_RESTARTS = 3
#: Display key and SI factor of the derived moduli in summaries.
_DERIVED = {name: (QUANTITIES[name].key, QUANTITIES[name].factor) for name in DERIVED}

#: The random streams of one seed (:func:`stream_rng`): a new use takes a new number, so adding
#: one does not change the draws of the others; a stream of named things (candidate models,
#: cells) keys each by its name (:func:`stable_key`), never by its position in a list, so adding
#: or reordering them does not change the draws of the others either. The sampler's own
#: streams are ``SeedSequence(seed).spawn(n_ensembles)``
#: (:func:`turgorbayes.inference.sampling.ensemble_seeds`).
STREAMS = {
    7: "importance sampling (importance_posterior)",
    8: "derived moduli of the emcee diagnostics (mcmc_posterior)",
    9: "draws of the Laplace approximation (laplace_posterior)",
    11: "criticism: predictive checks",
    13: "criticism: parameter summaries",
    14: "criticism: stacking",
    15: "criticism and fit: draws screened for gross errors (flag_cells)",
    16: "criticism: FE-table check",
    17: "criticism: Bayesian bootstrap of the LOO comparison",
    18: "criticism: the fit of a single-effect candidate (stream_seed keyed by the effect's name)",
    19: "criticism: the exact leave-one-out refit of a cell (stream_seed of the model's own "
        "fit seed, keyed by the cell's cell_id)",
    20: "criticism: the fit of the selected effect with the runner-up (stream_seed keyed by "
        "both names, selected first)",
    21: "criticism: the misfit band's offsets and derived moduli (turgorbayes.criticism."
        "misfit_band)",
    1000: "fit: derived quantities, replicates (1000 + 0)",
    1003: "fit: the population noise carried into the draws (1000 + 3)",
    2718: "fit: bootstrap of the plug-in latent population (population_noise, which spells "
          "out [seed, 2718] itself; with several conditions keyed by the condition's label)",
}


def stable_key(name):
    """The key of a named thing in a random stream (:func:`stream_rng`): the first 4 bytes of
    the SHA-256 of ``str(name)`` (UTF-8), as a big-endian integer in ``[0, 2**32)``.

    The same on every machine and run (unlike Python's ``hash``, salted per process), and
    one word of a :class:`numpy.random.SeedSequence`'s entropy, like a stream number.
    """
    return int.from_bytes(hashlib.sha256(str(name).encode("utf-8")).digest()[:4], "big")


def _entropy(seed, stream):
    """``[seed, *stream]`` as integers: stream numbers as given, names by :func:`stable_key`."""
    return [int(seed), *(stable_key(s) if isinstance(s, str) else int(s) for s in stream)]


def stream_rng(seed, *stream):
    """The generator of one random stream of a seed (each use has its own stream number,
    :data:`STREAMS`): ``default_rng(SeedSequence([seed, *stream]))``, where a ``str`` in
    ``stream`` (a model's or a cell's name) enters as its :func:`stable_key`."""
    return np.random.default_rng(np.random.SeedSequence(_entropy(seed, stream)))


def stream_seed(seed, *stream):
    """The integer seed of one random stream of a seed, for a function that takes a seed
    (:func:`fit_posterior`, whose engines draw from their own streams of it: :data:`STREAMS`
    7-9 and the sampler's ``SeedSequence(seed).spawn``).

    ``SeedSequence([seed, *stream]).generate_state(1)[0]`` (a ``uint32``, as
    :func:`turgorbayes.inference.sampling.ensemble_seeds`), with names keyed as in
    :func:`stream_rng`. A candidate model's fit is ``stream_seed(seed, 18, name)``: the same
    draws whatever other candidates are fitted, and in whatever order.
    """
    state = np.random.SeedSequence(_entropy(seed, stream)).generate_state(1, dtype=np.uint32)
    return int(state[0])


# ------------------------------------------------------------------------------ settings
@dataclass
class Settings:
    """The settings of every posterior (``fit``, ``criticize``, SBC): one type.

    The defaults are the fit's (``turgorbayes fit``); :meth:`for_criticism` gives the
    criticism's (``turgorbayes criticize``: importance sampling, no progress bar).

    Attributes
    ----------
    engine : str
        ``"emcee"`` (MCMC), ``"importance"`` (PSIS importance sampling, emcee where it is
        unreliable) or ``"laplace"`` (draws from the normal approximation at the mode).
    n_walkers, n_ensembles, tol, check_every, max_steps : emcee
        Walkers per ensemble, independent ensembles, run length in autocorrelation times,
        steps between convergence checks, the most steps
        (:func:`turgorbayes.inference.sampling.run_ensembles`).
    max_draws_per_chain : int
        Each ensemble's draws thinned evenly to at most this many.
    progress : bool
        emcee's progress bar.
    n_nodes : int
        Gauss-Hermite nodes per bulged cell (the fit's models).
    population_noise : bool
        Carry the plug-in latent population's own estimation noise into the fit's posterior
        (:mod:`turgorbayes.inference.population_noise`, ``population_noise_bootstrap``
        bootstrap populations). Read by the fit; the criticism's posteriors do not carry it.
    n_draws : int
        Importance-sampling draws per round; draws of the Laplace engine.
    df : float
        Degrees of freedom of the Student-t proposal.
    batch : int
        Draws per vectorized likelihood call.
    ess_min : float
        Smallest acceptable importance-sampling ESS.
    retry_factor : float
        Effort of the re-runs of an unconverged posterior: importance sampling with this many
        times the draws (when only its ESS fell short), emcee with this many times
        ``max_steps``.
    n_rep, max_refits, effects, flag_draws : criticism
        Posterior draws of the predictive checks (>= 2/alpha resolves the threshold); exact
        leave-one-out refits per model for cells with a large Pareto k;
        candidate effects (None: all); draws of the adopted model screened for gross errors.
    per_condition : tuple of str
        Criticism with several conditions: the wall quantities freed per condition in every
        model (``"E0t"``, ``"E0t:NAME"``, as ``fit --per-condition``); empty: the wall shared.
    """

    engine: str = "emcee"
    n_walkers: int = 16
    n_ensembles: int = 4
    tol: float = 50.0
    check_every: int = 50
    max_steps: int = 20000
    max_draws_per_chain: int = 1000
    progress: bool = True
    n_nodes: int = DEFAULT_NODES
    population_noise: bool = True
    population_noise_bootstrap: int = pop_noise.N_BOOTSTRAP
    n_draws: int = 2000
    df: float = 5.0
    batch: int = 128
    ess_min: float = 400.0
    retry_factor: float = 3.0
    n_rep: int = 1000
    max_refits: int = 10
    effects: tuple = None
    flag_draws: int = 200  # turgorbayes.effects.outliers.FLAG_DRAWS (a test keeps them equal)
    per_condition: tuple = ()

    def __post_init__(self):
        if self.engine not in ENGINES:
            raise ValueError(f"engine must be one of {', '.join(map(repr, ENGINES))}, got "
                             f"{self.engine!r}")
        for name in ("n_draws", "batch", "n_rep", "flag_draws"):
            if int(getattr(self, name)) < 2:
                raise ValueError(f"{name} must be an integer >= 2, got {getattr(self, name)!r}")
        if self.max_refits < 0:
            raise ValueError(f"max_refits must be >= 0, got {self.max_refits!r}")
        if not self.retry_factor >= 1:
            raise ValueError(f"retry_factor must be >= 1 (re-runs use more effort, not less), "
                             f"got {self.retry_factor!r}")

    @property
    def mcmc(self):
        """The emcee settings: this object itself (the criticism's former ``mcmc`` field)."""
        return self

    @classmethod
    def for_criticism(cls, mcmc=None, **kwargs):
        """The criticism's settings (``CriticismSettings``): engine ``"importance"``, no
        progress bar, no population noise, unless given.

        Parameters
        ----------
        mcmc : Settings, optional
            Its emcee fields (walkers, ensembles, tol, check_every, max_steps,
            max_draws_per_chain, progress) are taken where ``kwargs`` does not name them (the
            criticism's settings once held the emcee settings as a separate object).
        **kwargs
            Any field of :class:`Settings`.
        """
        defaults = {"engine": "importance", "progress": False, "population_noise": False}
        if mcmc is not None:
            defaults.update({k: getattr(mcmc, k) for k in _EMCEE_FIELDS})
        engine = kwargs.get("engine", defaults["engine"])
        if engine not in ("importance", "emcee"):
            raise ValueError(f"engine must be 'importance' or 'emcee', got {engine!r}")
        return cls(**{**defaults, **kwargs})


#: The emcee fields of :class:`Settings`.
_EMCEE_FIELDS = ("n_walkers", "n_ensembles", "tol", "check_every", "max_steps",
                 "max_draws_per_chain", "progress")


# ------------------------------------------------------------------------------ result
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
        lp = self.lp if self.lp is not None else _log_posterior(self)
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


def _log_posterior(post):
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
def _log_lik_and_prior(model, u, batch):
    lp0 = model.log_prior(u)
    ll = np.full((len(u), model.obs.n_cells), -np.inf)
    ok = np.isfinite(lp0)
    if ok.any():
        with np.errstate(all="ignore"):
            ll[ok] = batched(model.pointwise_log_likelihood, u[ok], batch)
    ll = np.where(np.isnan(ll), -np.inf, ll)
    return ll, np.where(ok, lp0, -np.inf)


def psis_weights(log_ratios):
    """Pareto-smoothed, normalized log weights and ``k_hat`` of raw log ratios (last axis).

    ``arviz_stats``' ``psislw`` takes log-likelihood values (its ratios are their negatives), so
    it gets ``-log_ratios``, shifted to a maximum of 0.
    """
    r = np.asarray(log_ratios, float)
    r = r - np.max(r, axis=-1, keepdims=True)
    lw, k = array_stats.psislw(-r, r_eff=1.0, axis=-1)
    return lw, k


#: Importance-sampling rounds at most (each adapts the proposal to the weighted draws so far).
_ROUNDS = 3
#: Defensive mixture proposal: weight and variance factor of the wide component.
_WIDE_WEIGHT, _WIDE_VAR = 0.2, 9.0


class _SplitT:
    """Defensive mixture of split-t densities (Geweke, Econometrica 57, 1317, 1989).

    Along each principal axis ``v_j`` of ``cov`` the scale is ``q_j+`` on the positive and
    ``q_j-`` on the negative side, so a skewed posterior is followed; with a common chi-square
    divisor, :math:`u = m + V(q^{\\pm}\\circ z)`, ``z`` standard multivariate t, the density is
    :math:`t(z)\\prod_j 1/q_j^{\\pm}` (a bijection, normalized). The mixture adds the same density
    with scales three times larger (weight 0.2).
    """

    def __init__(self, loc, cov, df, q_plus=None, q_minus=None):
        self.loc = np.asarray(loc, float)
        lam, self.V = np.linalg.eigh(0.5 * (cov + cov.T))
        s = np.sqrt(np.maximum(lam, 1e-300))
        self.qp = s if q_plus is None else np.asarray(q_plus, float)
        self.qm = s if q_minus is None else np.asarray(q_minus, float)
        self.df = float(df)

    def draw(self, n, rng):
        d = self.loc.size
        z = rng.standard_normal((n, d)) / np.sqrt(rng.chisquare(self.df, n) / self.df)[:, None]
        z *= np.where(rng.random(n) < _WIDE_WEIGHT, np.sqrt(_WIDE_VAR), 1.0)[:, None]
        return self.loc + (np.where(z > 0, self.qp, self.qm) * z) @ self.V.T

    def logpdf(self, u):
        y = (np.atleast_2d(u) - self.loc) @ self.V
        q = np.where(y > 0, self.qp, self.qm)
        z = y / q
        d = self.loc.size
        base = stats.multivariate_t.logpdf(z, loc=np.zeros(d), shape=np.eye(d), df=self.df)
        wide = stats.multivariate_t.logpdf(z, loc=np.zeros(d), shape=_WIDE_VAR * np.eye(d),
                                           df=self.df)
        mix = np.logaddexp(np.log1p(-_WIDE_WEIGHT) + base, np.log(_WIDE_WEIGHT) + wide)
        return mix - np.sum(np.log(q), axis=1)


def _split_scales(model, loc, cov, levels=(1.5, 3.0)):
    """Geweke's split scales along the principal axes from the log posterior's decay.

    At ``loc +- c s_j v_j`` a Gaussian falls by ``c^2/2``; the scale on each side is
    ``s_j c / sqrt(2 drop)``, the largest over the levels ``c`` (heavier is safer), kept within
    [0.5, 4] times ``s_j`` (a side beyond the support gets 0.5).
    """
    lam, V = np.linalg.eigh(0.5 * (cov + cov.T))
    s = np.sqrt(np.maximum(lam, 1e-300))
    d = loc.size
    pts = [loc]
    for c in levels:
        pts += [loc + c * s[j] * V[:, j] for j in range(d)] + [loc - c * s[j] * V[:, j]
                                                                for j in range(d)]
    lp = model.log_posterior(np.array(pts))
    qp, qm = np.full(d, 0.5) * s, np.full(d, 0.5) * s
    for i, c in enumerate(levels):
        block = lp[1 + 2 * d * i: 1 + 2 * d * (i + 1)]
        for side, q in ((block[:d], qp), (block[d:], qm)):
            drop = lp[0] - side
            with np.errstate(divide="ignore", invalid="ignore"):
                scale = np.where(np.isfinite(drop) & (drop > 0), s * c / np.sqrt(2 * drop), 0.5 * s)
            q[:] = np.maximum(q, np.clip(scale, 0.5 * s, 4 * s))
    return qp, qm


def importance_posterior(model, u_map, cov, seed, settings):
    """PSIS importance sampling around the mode (Vehtari et al., JMLR 25, 2024).

    The first proposal is a split-t around the mode (:class:`_SplitT`: the Laplace axes with
    separate scales on each side, fitted to the log posterior's decay, so skewed posteriors are
    followed), as a defensive mixture (Hesterberg, Technometrics 37, 185, 1995) with a copy
    three times wider (weight 0.2) that keeps the weights bounded. While a round gives
    ``k_hat > 0.5`` or an ESS below half the draws of a round (at most :data:`_ROUNDS` rounds),
    the next round draws from a split-t with the weighted mean and covariance of all draws so
    far, and all draws are weighted against the equal mixture of the proposals
    (deterministic-mixture multiple importance sampling, Owen & Zhou, JASA 95, 135, 2000).

    Parameters
    ----------
    model : object
    u_map : ndarray (ndim,)
        Posterior mode (sampler coordinates).
    cov : ndarray (ndim, ndim)
        Laplace covariance there.
    seed : int
    settings : Settings
        Uses ``n_draws``, ``df``, ``batch`` and ``ess_min``.

    Returns
    -------
    Posterior
        ``converged`` False (with reasons) when ``k_hat > K_MAX`` or the importance-sampling
        ESS :math:`1/\\sum_s \\tilde w_s^2` is below ``settings.ess_min``.
    """
    rng = stream_rng(seed, 7)
    u_map, cov = np.asarray(u_map, float), np.asarray(cov, float)
    proposals = [_SplitT(u_map, cov, settings.df, *_split_scales(model, u_map, cov))]
    us, lls, lps = [], [], []
    for round_ in range(_ROUNDS):
        u = proposals[-1].draw(settings.n_draws, rng)
        ll, lp0 = _log_lik_and_prior(model, u, settings.batch)
        us.append(u)
        lls.append(ll)
        lps.append(lp0 + ll.sum(axis=1))
        u, ll, lp = np.concatenate(us), np.concatenate(lls), np.concatenate(lps)
        log_q = logsumexp([q.logpdf(u) for q in proposals], axis=0) - np.log(len(proposals))
        raw = lp - log_q
        finite = np.isfinite(raw)
        if finite.sum() < 10:
            raise ValueError(f"{model.name}: fewer than 10 of {raw.size} importance draws have a "
                             "finite posterior density")
        log_w = np.full(raw.shape, -np.inf)
        log_w[finite], k_hat = psis_weights(raw[finite])
        w = np.exp(log_w)
        ess = float(1 / np.sum(w**2))
        if round_ < _ROUNDS - 1 and (k_hat > 0.5 or ess < 0.5 * settings.n_draws):
            scale = np.cov(u.T, aweights=w + 1e-300) + 1e-12 * np.eye(u.shape[1])
            proposals.append(_SplitT(w @ u, scale, settings.df))
            continue
        break
    record = {"k_hat": float(k_hat), "ess": ess, "rounds": len(proposals),
              "n_draws": int(u.shape[0])}
    ok, reasons = judge("importance", record, settings)
    keep = w > 0
    return Posterior(model=model, u=u[keep], log_w=log_w[keep], log_lik=ll[keep],
                     engine="importance", converged=ok, reasons=reasons, diagnostics=record,
                     u_map=np.asarray(u_map), cov=np.asarray(cov), lp=lp[keep])


def mcmc_posterior(model, u_map, cov, seed, settings):
    """The package's emcee sampler from the mode (:func:`turgorbayes.inference.sampling.run_ensembles`).

    Walkers start at ``u_map`` with twice the Laplace spread (:func:`walker_start`);
    independent ensembles run to ``settings.tol`` autocorrelation times; each ensemble's draws
    are thinned evenly to ``settings.max_draws_per_chain``; R-hat and ESS come from ArviZ.

    Returns
    -------
    Posterior
        Equal weights, ``n_chains`` the ensembles, ``lp`` the sampler's log posterior,
        ``log_lik`` None (:func:`fit_posterior` adds it); ``converged`` by :func:`judge`.
    """
    import arviz_base as azb

    s = settings
    init = walker_start(u_map, cov, s.n_walkers)
    run = sampling.run_ensembles(model.log_posterior, init, seed, n_walkers=s.n_walkers,
                                 n_ensembles=s.n_ensembles, tol=s.tol,
                                 check_every=s.check_every, max_steps=s.max_steps,
                                 progress=s.progress)
    draws = run.draws()
    keep = sampling.evenly_spaced(draws.shape[1], s.max_draws_per_chain)
    draws = draws[:, keep]
    lp = run.draws_log_prob()[:, keep]
    C, D, d = draws.shape
    u = draws.reshape(C * D, d)
    phys = model.to_physical(u)
    phys.update(batched(lambda x: model.derived(x, stream_rng(seed, 8)), u, 512))
    dt = azb.from_dict({"posterior": {k: np.asarray(v).reshape(C, D) for k, v in phys.items()}})
    chain = diagnostics.chain_diagnostics(dt, list(phys))
    record = {"chain": chain, "n_steps": run.n_steps, "tau": run.tau.tolist(), "n_chains": C,
              "stuck": list(run.stuck), "sampler_converged": bool(run.converged)}
    ok, reasons = judge("emcee", record, settings, model.names)
    return Posterior(model=model, u=u, log_w=np.full(len(u), -np.log(len(u))), log_lik=None,
                     engine="emcee", converged=ok, reasons=reasons, diagnostics=record,
                     u_map=np.asarray(u_map), cov=np.asarray(cov), lp=lp.reshape(-1),
                     n_chains=C, run=run)


def laplace_posterior(model, u_map, cov, seed, settings):
    """``settings.n_draws`` draws from the Laplace approximation ``N(u_map, cov)`` (sampler
    coordinates), equal weights: cheap, and exact only for a Gaussian posterior.

    Returns
    -------
    Posterior
        ``converged`` by :func:`judge` (the approximation has no check of its own; the ladder
        still restarts the mode search from a draw that beats the mode).
    """
    u = stream_rng(seed, 9).multivariate_normal(u_map, cov, size=settings.n_draws)
    lp = batched(model.log_posterior, u, settings.batch)
    ok, reasons = judge("laplace", {}, settings)
    return Posterior(model=model, u=u, log_w=np.full(len(u), -np.log(len(u))), log_lik=None,
                     engine="laplace", converged=ok, reasons=reasons,
                     diagnostics={"n_draws": int(len(u))}, u_map=np.asarray(u_map),
                     cov=np.asarray(cov), lp=np.where(np.isnan(lp), -np.inf, lp))


def judge(engine, record, settings, names=()):
    """The convergence rule, one per engine (``docs/statistics.md``, "One posterior engine").

    * ``"importance"``: Pareto ``k_hat <= K_MAX`` and the weights' ESS
      :math:`1/\\sum_s \\tilde w_s^2 \\ge` ``settings.ess_min``;
    * ``"emcee"``: :func:`turgorbayes.inference.diagnostics.is_converged` (every ensemble run
      to ``tol`` autocorrelation times; R-hat and bulk/tail ESS of every parameter of
      ``names``), and no ensemble's walkers stuck;
    * ``"laplace"``: no check (an approximation; always converged).

    Parameters
    ----------
    engine : str
    record : dict
        The engine's diagnostics: ``k_hat``, ``ess`` (importance); ``sampler_converged``,
        ``chain``, ``stuck``, ``n_steps`` (emcee).
    settings : Settings
    names : sequence of str
        The model's parameters (emcee).

    Returns
    -------
    converged : bool
    reasons : list of str
    """
    if engine == "laplace":
        return True, []
    if engine == "importance":
        reasons = []
        if not record["k_hat"] <= K_MAX:
            reasons.append(f"importance sampling unreliable: Pareto k = {record['k_hat']:.2f} > "
                           f"{K_MAX}")
        if not record["ess"] >= settings.ess_min:
            reasons.append(f"importance-sampling ESS {record['ess']:.0f} < "
                           f"{settings.ess_min:.0f}")
        return not reasons, reasons
    ok, reasons = diagnostics.is_converged(record["sampler_converged"],
                                           {n: record["chain"][n] for n in names})
    if record["stuck"]:
        reasons.append(f"walkers stuck: ensemble(s) {', '.join(map(str, record['stuck']))} made "
                       f"no move at {sampling.STUCK_CHECKS} consecutive checks (stopped after "
                       f"{record['n_steps']} steps)")
    return ok and not record["stuck"], reasons


#: Spread of emcee's starting walkers in Laplace sds, and its factor at every redraw.
START_SPREAD, START_SHRINK = 2.0, 0.8


def walker_start(u_map, cov, n_walkers, spread=START_SPREAD, shrink=START_SHRINK):
    """Starting positions of emcee walkers about the mode: ``spread`` Laplace sds, narrower by
    ``shrink`` at every redraw of the same ensemble.

    ``sampling.run_ensembles`` redraws the walkers whose log density is not finite, with the
    ensemble's own generator; with a Laplace covariance far too wide in a bounded direction (a
    clipped Hessian eigenvalue) a fixed spread never lands inside the support, while the
    shrinking one ends near the mode, whose density is finite. Every ensemble starts at the
    full spread (a new generator resets it), so that R-hat can detect non-mixing.

    Returns
    -------
    callable
        ``rng -> (n_walkers, n_dim)`` positions.
    """
    chol = np.linalg.cholesky(cov)
    state = {"rng": None, "calls": 0}

    def init(rng):
        if rng is not state["rng"]:  # a new ensemble
            state["rng"], state["calls"] = rng, 0
        scale = spread * shrink ** state["calls"]
        state["calls"] += 1
        return u_map + scale * rng.standard_normal((n_walkers, len(u_map))) @ chol.T

    return init


def given_laplace(model, u_map, cov):
    """A caller's mode and covariance (e.g. :meth:`turgorbayes.inference.models.BaselineModel.start`)
    as the :class:`~turgorbayes.inference.mode.LaplaceFit` :func:`fit_posterior` starts from."""
    u_map = np.asarray(u_map, float)
    log_post = float(np.asarray(model.log_posterior(u_map[None]), float)[0])
    return LaplaceFit(u_map, np.asarray(cov, float), ModeSearch(u_map, log_post, True), None, [])


def _engine_ladder(model, lap, seed, settings, attempts, stop_if_beaten=False):
    """Run the engines from a Laplace fit, with more effort while the posterior is unconverged.

    ``"laplace"``: :func:`laplace_posterior` only. ``"importance"``: :func:`_importance_ladder`,
    then emcee if that did not converge (with ``stop_if_beaten``, not when a draw beat the
    mode: the caller restarts the mode search, far cheaper than emcee from a wrong mode). Then
    emcee, and emcee with ``settings.retry_factor`` times ``max_steps`` (the same seed, so the
    longer run repeats and continues the shorter one; no second run when the factor is 1, nor
    when the first run stopped on stuck walkers, which the longer one would repeat).
    Every unconverged run is appended to ``attempts``; the last run is returned (the last
    importance run if emcee fails outright).
    """
    if settings.engine == "laplace":
        return laplace_posterior(model, lap.u_map, lap.cov, seed, settings)
    post = None
    if settings.engine == "importance":
        post = _importance_ladder(model, lap, seed, settings, attempts)
        if post is not None and (post.converged
                                 or (stop_if_beaten and _beating_draw(post, lap) is not None)):
            return post
    for factor in dict.fromkeys((1, settings.retry_factor)):
        steps = int(factor * settings.max_steps)
        mc = dataclasses.replace(settings, max_steps=steps)
        try:
            mcmc = mcmc_posterior(model, lap.u_map, lap.cov, seed, mc)
        except (ValueError, RuntimeError, np.linalg.LinAlgError) as err:
            if post is None:
                raise
            post.reasons.append(f"the emcee fallback failed ({err}); importance-sampling draws "
                                "kept")
            return post
        if mcmc.converged or factor != 1 or mcmc.diagnostics.get("stuck"):
            return mcmc  # stuck walkers: the same seed with more steps would repeat them
        attempts.append(mcmc.attempt(f"at most {steps} steps"))
        logger.info("%s: %s; emcee again with %g times the steps", getattr(model, "name", "model"),
                    "; ".join(mcmc.reasons), settings.retry_factor)
    return mcmc


#: An importance run short only of ESS is repeated with at most this many times the draws.
MAX_DRAW_FACTOR = 4.0


def _importance_ladder(model, lap, seed, settings, attempts):
    """Importance sampling; again with more draws if only the ESS fell short (a Pareto k above
    :data:`K_MAX` is a proposal problem more draws do not fix). With a finite-variance
    proposal the ESS grows in proportion to the draws, so the re-run takes the draws the
    shortfall asks for (times 1.3), at least ``retry_factor`` times and at most
    :data:`MAX_DRAW_FACTOR` times ``n_draws``: far cheaper than the emcee fallback.

    Returns the last run (None if the draws had no finite density); unconverged runs are
    appended to ``attempts``.
    """
    effort = f"{settings.n_draws} draws per round"
    try:
        post = importance_posterior(model, lap.u_map, lap.cov, seed, settings)
    except ValueError as err:
        attempts.append({"engine": "importance", "converged": False, "reasons": [str(err)],
                         "effort": effort})
        return None
    if post.converged:
        return post
    attempts.append(post.attempt(effort))
    if post.diagnostics["k_hat"] > K_MAX:
        return post
    need = 1.3 * settings.ess_min / max(post.diagnostics["ess"], 1.0)
    factor = min(max(settings.retry_factor, need), MAX_DRAW_FACTOR)
    if factor <= 1:
        return post
    more = dataclasses.replace(settings, n_draws=int(np.ceil(factor * settings.n_draws)))
    post = importance_posterior(model, lap.u_map, lap.cov, seed, more)
    if not post.converged:
        attempts.append(post.attempt(f"{more.n_draws} draws per round"))
    return post


def _best_draw(post):
    """Index and log posterior of the draw with the highest log posterior."""
    lp = np.asarray(post.lp if post.lp is not None else _log_posterior(post), float)
    lp = np.where(np.isnan(lp), -np.inf, lp)
    i = int(np.argmax(lp))
    return i, float(lp[i])


def _beating_draw(post, lap):
    """``(index, log posterior)`` of the best draw if it beats the mode by more than
    :data:`MODE_BEATEN_NATS` (the mode search failed), else None."""
    i, lp_best = _best_draw(post)
    return (i, lp_best) if lp_best > lap.mode.log_post + MODE_BEATEN_NATS else None


def fit_posterior(model, guess, seed, settings, laplace=None, pointwise=True):
    """Posterior of ``model`` by the configured engine, with more effort until it converges.

    The mode and Laplace covariance come from :func:`turgorbayes.inference.mode.laplace_fit`
    (from ``guess``), or are the caller's (``laplace``); the engines then run as in
    :func:`_engine_ladder` (importance sampling, more draws, emcee, emcee with more steps;
    ``"emcee"`` skips the first two, ``"laplace"`` draws from the approximation). If a draw's
    log posterior beats the mode's by more than :data:`MODE_BEATEN_NATS`, the mode search
    failed: it is restarted from that draw, and the engines are run again from the new mode
    unless the posterior already converged (then only ``u_map`` and ``cov`` are replaced). An
    importance run that shows the mode beaten does not go on to emcee: the search restarts
    first (up to :data:`MAX_MODE_RESTARTS` times; emcee runs from the last mode, and again
    after at most one restart from its own draws). The result records every unconverged
    attempt (``attempts``) and the mode search (``laplace``); see ``docs/statistics.md``,
    "One posterior engine".

    Parameters
    ----------
    model : object
        ``log_posterior``, ``log_prior``, ``to_u``, ``to_physical``, ``pointwise_log_likelihood``.
    guess : dict or None
        Physical starting values of every parameter (SI); unused when ``laplace`` is given.
    seed : int
    settings : Settings
    laplace : turgorbayes.inference.mode.LaplaceFit, optional
        The mode and covariance to start from (:func:`given_laplace`).
    pointwise : bool
        Store the pointwise log-likelihood of every draw (``Posterior.log_lik``); the fit,
        which computes its own after the population noise is carried, does without.

    Returns
    -------
    Posterior
    """
    lap = laplace if laplace is not None else laplace_fit(model, model.to_u(guess)[0])
    attempts, restarts, after_emcee = [], [], False
    for restarts_left in range(MAX_MODE_RESTARTS, -1, -1):
        post = _engine_ladder(model, lap, seed, settings, attempts,
                              stop_if_beaten=restarts_left > 0)
        beaten = _beating_draw(post, lap)
        # emcee runs again after at most one restart: it is the expensive engine
        if beaten is None or restarts_left == 0 or (after_emcee and post.engine == "emcee"):
            break
        after_emcee |= post.engine == "emcee"
        i, lp_best = beaten
        restarts.append(f"a draw beat the mode by {lp_best - lap.mode.log_post:.1f} nats: mode "
                        "search restarted from it")
        logger.info("%s: %s", getattr(model, "name", "model"), restarts[-1])
        lap = laplace_fit(model, post.u[i])
        if post.converged:
            post.u_map, post.cov = lap.u_map, lap.cov
            break
        attempts.append(post.attempt("before the mode restart"))
    lap.notes[:0] = restarts
    post.attempts, post.laplace = attempts, lap.record()
    if pointwise and post.log_lik is None:
        post.log_lik = _log_lik_and_prior(model, post.u, settings.batch)[0]
    return post
