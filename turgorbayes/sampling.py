"""Affine-invariant ensemble sampling (emcee) of a few global parameters, run to convergence.

The walkers of one emcee ensemble are not independent chains (each proposal is built from
the other walkers), so :func:`run_ensembles` runs several *independent* ensembles, each
seeded from the user's seed through :class:`numpy.random.SeedSequence`. Each ensemble runs
until its length exceeds ``tol`` integrated autocorrelation times (Sokal's rule, as in the
emcee documentation), checked every ``check_every`` steps. Burn-in and thinning follow from
the final autocorrelation time: ``burn = ceil(burn_taus * tau)``, ``thin = ceil(tau)``, so
consecutive stored draws of one walker are nearly independent and the stored draws of an
ensemble (ordered step-major, walker-minor) can be handed to ArviZ as one chain.

The log-probability function is *vectorized*: it receives all walkers at once, an array
``(n_walkers, n_dim)``, and returns ``(n_walkers,)`` log densities (``-inf`` outside the
support; NaN is treated as ``-inf``).
"""

import logging
import math
from dataclasses import dataclass

import emcee
import numpy as np
from tqdm.auto import tqdm

__all__ = [
    "DEFAULT_MOVES",
    "EnsembleRun",
    "SamplingResult",
    "default_moves",
    "ensemble_seeds",
    "run_ensemble",
    "run_ensembles",
]

logger = logging.getLogger(__name__)


def default_moves():
    """Differential-evolution moves: 80 % DE, 20 % DE snooker (ter Braak & Vrugt 2008).

    DE moves mix better than the stretch move for the correlated, few-dimensional
    posteriors of this package (gamma and E0t are strongly correlated).
    """
    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


#: Name of the default move set, recorded in outputs.
DEFAULT_MOVES = "0.8 DEMove + 0.2 DESnookerMove"


@dataclass
class EnsembleRun:
    """One emcee ensemble after its run.

    Attributes
    ----------
    chain : ndarray (n_steps, n_walkers, n_dim)
        Every step of every walker, in sampler coordinates.
    log_prob : ndarray (n_steps, n_walkers)
    tau : ndarray (n_dim,)
        Integrated autocorrelation time per coordinate [steps], estimated after burn-in.
    burn, thin : int
        Steps discarded at the start; stride of the stored draws.
    converged : bool
        True when ``n_steps - burn > tol * max(tau)`` and tau was stable between checks.
    acceptance : float
        Mean acceptance fraction over walkers.
    seed : int
        The integer seed this ensemble's random state was built from.
    """

    chain: np.ndarray
    log_prob: np.ndarray
    tau: np.ndarray
    burn: int
    thin: int
    converged: bool
    acceptance: float
    seed: int

    @property
    def n_steps(self):
        return self.chain.shape[0]

    def draws(self):
        """Post-burn-in, thinned draws ``(n_draws, n_dim)``, step-major then walker."""
        kept = self.chain[self.burn :: self.thin]
        return kept.reshape(-1, kept.shape[-1])

    def draws_log_prob(self):
        kept = self.log_prob[self.burn :: self.thin]
        return kept.reshape(-1)


@dataclass
class SamplingResult:
    """Independent ensembles of one posterior (see :func:`run_ensembles`)."""

    ensembles: list
    tol: float

    @property
    def converged(self):
        """All ensembles longer than ``tol`` autocorrelation times."""
        return all(e.converged for e in self.ensembles)

    @property
    def n_draws(self):
        """Draws per ensemble kept by :meth:`draws` (the shortest ensemble's count)."""
        return min(e.draws().shape[0] for e in self.ensembles)

    def draws(self):
        """Array ``(n_ensembles, n_draws, n_dim)``: one ArviZ chain per ensemble.

        Ensembles are truncated to a common number of draws (the *last* ``n_draws``
        draws are kept, i.e. the ones furthest from the start).
        """
        n = self.n_draws
        return np.stack([e.draws()[-n:] for e in self.ensembles])

    def draws_log_prob(self):
        n = self.n_draws
        return np.stack([e.draws_log_prob()[-n:] for e in self.ensembles])

    @property
    def tau(self):
        """Largest autocorrelation time of each coordinate over ensembles [steps]."""
        return np.max([e.tau for e in self.ensembles], axis=0)

    @property
    def n_steps(self):
        return [e.n_steps for e in self.ensembles]


def _finite_log_prob(log_prob_fn):
    def wrapped(p):
        lp = np.asarray(log_prob_fn(p), dtype=float)
        return np.where(np.isnan(lp), -np.inf, lp)

    return wrapped


def _tau(chain, c=5):
    """Integrated autocorrelation time per coordinate, walkers averaged (emcee's estimator)."""
    return emcee.autocorr.integrated_time(chain, c=c, tol=0, quiet=True)


def _check(chain, tau_old, tol, burn_taus, rtol):
    """Return (tau, burn, done) for a chain ``(n, n_walkers, n_dim)`` so far."""
    n = chain.shape[0]
    # estimate tau on the part after the current burn-in guess (a quarter to start with)
    burn = n // 4 if tau_old is None else min(n // 2, math.ceil(burn_taus * np.max(tau_old)))
    tau = _tau(chain[burn:])
    stable = tau_old is not None and np.all(np.abs(tau - tau_old) < rtol * tau)
    burn = math.ceil(burn_taus * np.max(tau))
    done = bool(np.all(np.isfinite(tau)) and (n - burn) > tol * np.max(tau) and stable)
    return tau, burn, done


def _valid_start(log_prob_fn, p0, init, rng, max_tries=100):
    """Redraw walkers whose starting log probability is not finite."""
    p0 = np.array(p0, dtype=float)
    for _ in range(max_tries):
        bad = ~np.isfinite(log_prob_fn(p0))
        if not bad.any():
            return p0
        p0[bad] = init(rng)[bad]
    raise RuntimeError(
        f"could not find finite starting log probabilities for {int(bad.sum())} of "
        f"{len(p0)} walkers after {max_tries} draws of the initializer"
    )


def run_ensemble(log_prob_fn, init, seed, *, n_walkers, tol=50.0, check_every=100,
                 max_steps=20000, min_steps=0, burn_taus=3.0, rtol=0.05, moves=None,
                 progress=True, label="ensemble"):
    """Run one emcee ensemble until it is longer than ``tol`` autocorrelation times.

    Parameters
    ----------
    log_prob_fn : callable
        ``(n_walkers, n_dim) -> (n_walkers,)`` vectorized log density.
    init : callable
        ``rng -> (n_walkers, n_dim)`` starting positions (walkers with a non-finite
        log density are redrawn).
    seed : int
        Seed of this ensemble's initial draws and of emcee's random state.
    n_walkers : int
        Walkers (>= 2 n_dim + 2 recommended).
    tol : float
        Required chain length in units of the integrated autocorrelation time.
    check_every : int
        Steps between convergence checks.
    max_steps : int
        Give up (``converged = False``) after this many steps.
    min_steps : int
        Do not stop before this many steps.
    burn_taus : float
        Burn-in in units of tau.
    rtol : float
        tau must change by less than this fraction between two checks.
    moves : list, optional
        emcee moves; :func:`default_moves` if None.
    progress : bool
        Show a tqdm progress bar.

    Returns
    -------
    EnsembleRun
    """
    log_prob_fn = _finite_log_prob(log_prob_fn)
    rng = np.random.default_rng(seed)
    p0 = _valid_start(log_prob_fn, init(rng), init, rng)
    if p0.shape[0] != n_walkers:
        raise ValueError(f"init returned {p0.shape[0]} walkers, expected {n_walkers}")
    sampler = emcee.EnsembleSampler(
        n_walkers, p0.shape[1], log_prob_fn, vectorize=True,
        moves=default_moves() if moves is None else moves,
    )
    sampler.random_state = np.random.RandomState(seed % 2**32).get_state()
    state, tau, burn, done = p0, None, 0, False
    with tqdm(total=max_steps, desc=label, disable=not progress, leave=False) as bar:
        while not done and sampler.iteration < max_steps:
            steps = min(check_every, max_steps - sampler.iteration)
            state = sampler.run_mcmc(state, steps, progress=False)
            bar.update(steps)
            tau, burn, done = _check(sampler.get_chain(), tau, tol, burn_taus, rtol)
            done = done and sampler.iteration >= min_steps
            bar.set_postfix(tau=f"{np.max(tau):.1f}", need=int(tol * np.max(tau) + burn))
    if not done:
        logger.warning("%s: not converged after %d steps (tau = %s, needs %.0f steps)",
                       label, sampler.iteration, np.round(tau, 1), tol * np.max(tau) + burn)
    chain = sampler.get_chain()
    thin = max(1, math.ceil(np.max(tau)))
    burn = min(burn, chain.shape[0] - 1)
    return EnsembleRun(
        chain=chain, log_prob=sampler.get_log_prob(), tau=tau, burn=burn, thin=thin,
        converged=done, acceptance=float(np.mean(sampler.acceptance_fraction)), seed=seed,
    )


def ensemble_seeds(seed, n_ensembles):
    """Independent integer seeds for ``n_ensembles`` ensembles derived from one user seed."""
    children = np.random.SeedSequence(seed).spawn(n_ensembles)
    return [int(c.generate_state(1, dtype=np.uint64)[0]) for c in children]


def run_ensembles(log_prob_fn, init, seed, *, n_ensembles=4, progress=True, **kwargs):
    """Run ``n_ensembles`` independent ensembles (see :func:`run_ensemble`).

    Parameters
    ----------
    seed : int
        User seed; each ensemble gets its own stream via ``SeedSequence(seed).spawn``.
    n_ensembles : int
        Independent ensembles (>= 4 recommended for between-chain diagnostics).
    **kwargs
        Passed to :func:`run_ensemble` (``n_walkers`` is required).

    Returns
    -------
    SamplingResult
    """
    if n_ensembles < 1:
        raise ValueError(f"n_ensembles must be >= 1, got {n_ensembles}")
    runs = []
    for i, s in enumerate(ensemble_seeds(seed, n_ensembles)):
        label = f"ensemble {i + 1}/{n_ensembles}"
        runs.append(run_ensemble(log_prob_fn, init, s, progress=progress, label=label,
                                 **kwargs))
    return SamplingResult(ensembles=runs, tol=kwargs.get("tol", 50.0))
