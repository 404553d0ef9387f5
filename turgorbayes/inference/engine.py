r"""The one posterior engine of fit, criticism and SBC: settings, seeds, engines, one ladder.

Every posterior of the package comes from :func:`fit_posterior`:

* the engine's settings, :class:`Settings` (``turgorbayes.workflows.fit.FitSettings`` and
  ``turgorbayes.workflows.criticize.CriticismSettings`` add the fit's and the criticism's);
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
import logging
from dataclasses import dataclass

import numpy as np

from turgorbayes.inference.engines import (
    K_MAX,
    START_SHRINK,
    START_SPREAD,
    given_laplace,
    importance_posterior,
    judge,
    laplace_posterior,
    mcmc_posterior,
    psis_weights,
    walker_start,
)
from turgorbayes.inference.likelihood import DEFAULT_NODES
from turgorbayes.inference.mode import laplace_fit
from turgorbayes.inference.posterior import (
    Posterior,
    batched,
    datatree,
    log_lik_and_prior,
    log_posterior_draws,
    resample,
    weighted_quantiles,
    weighted_stats,
)
from turgorbayes.inference.streams import STREAMS, stable_key, stream_rng, stream_seed

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
#: A draw whose log posterior exceeds the mode's by more than this [nats] means the mode
#: search failed: it is restarted from that draw.
MODE_BEATEN_NATS = 1.0
#: Restarts of the mode search from a beating draw; each runs the importance sampler again
#: from the new mode before any emcee run (emcee starts from the last mode).
MAX_MODE_RESTARTS = 3


# ------------------------------------------------------------------------------ settings
@dataclass
class Settings:
    """The posterior engine's settings (:func:`fit_posterior`); the fit's and the criticism's
    add their own fields (``turgorbayes.workflows.fit.FitSettings``,
    ``turgorbayes.workflows.criticize.CriticismSettings``).

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
    n_draws: int = 2000
    df: float = 5.0
    batch: int = 128
    ess_min: float = 400.0
    retry_factor: float = 3.0

    def __post_init__(self):
        if self.engine not in ENGINES:
            raise ValueError(f"engine must be one of {', '.join(map(repr, ENGINES))}, got "
                             f"{self.engine!r}")
        for name in ("n_draws", "batch"):
            if int(getattr(self, name)) < 2:
                raise ValueError(f"{name} must be an integer >= 2, got {getattr(self, name)!r}")
        if not self.retry_factor >= 1:
            raise ValueError(f"retry_factor must be >= 1 (re-runs use more effort, not less), "
                             f"got {self.retry_factor!r}")


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
    lp = np.asarray(post.lp if post.lp is not None else log_posterior_draws(post), float)
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
        post.log_lik = log_lik_and_prior(model, post.u, settings.batch,
                                         getattr(settings, "workers", 1))[0]
    return post
