"""Affine-invariant ensemble sampling (emcee) of a few global parameters, run to convergence.

Independent ensembles, one vectorized call
------------------------------------------
The walkers of one emcee ensemble are not independent chains (each proposal is built from
the other walkers), so :func:`run_ensembles` runs ``n_ensembles`` *independent* ensembles.
To keep the likelihood vectorized over as many walkers as possible they advance in lockstep
inside one :class:`emcee.EnsembleSampler`: the move :class:`LockstepMove` treats the
sampler's walkers as ``n_ensembles`` disjoint blocks; each block draws its proposals only
from its own walkers (red-blue split, differential-evolution moves) with its *own* random
stream (``SeedSequence(seed).spawn(n_ensembles)``), and accepts with that stream too. The
blocks never exchange information, so they are independent chains in the statistical sense;
only their log densities are computed in one numpy call per half-step.

Stopping, burn-in, thinning
---------------------------
Every ``check_every`` steps the integrated autocorrelation time ``tau`` of each block is
estimated (emcee's walker-averaged estimator) on the part after the current burn-in guess.
The run stops when every block is longer than ``tol`` (default 50) times its largest tau
and tau changed by less than ``rtol`` since the previous check (Sokal's rule, emcee docs),
or at ``max_steps`` (then ``converged = False``). Burn-in is ``burn_taus`` tau, and the
draws are thinned by ``ceil(tau)`` so consecutive stored draws of a walker are nearly
independent; the stored draws of an ensemble (step-major, walker-minor) form one ArviZ
chain.

The log-probability function is *vectorized*: ``(n, n_dim) -> (n,)`` (``-inf`` outside
the support; NaN is treated as ``-inf``).
"""

import logging
import math
from dataclasses import dataclass, field

import emcee
import numpy as np
from emcee.state import State

from turgorbayes.errors import TurgorBayesError
from turgorbayes.progress import progress as show_progress

__all__ = [
    "DEFAULT_MOVES",
    "EnsembleRun",
    "LockstepMove",
    "SamplingResult",
    "StartError",
    "bar_position",
    "bar_total",
    "evenly_spaced",
    "default_moves",
    "ensemble_seeds",
    "progress_note",
    "run_ensembles",
]

logger = logging.getLogger(__name__)


class StartError(TurgorBayesError, RuntimeError):
    """No starting walker with a finite log density was found.

    Attributes
    ----------
    positions : ndarray (n_walkers, n_dim)
        The last starting positions tried (those still at ``-inf`` included), so that the
        caller can say which part of the model is at fault
        (:func:`turgorbayes.inference.start_check.start_error`).
    n_bad : int
        Walkers without a finite log density.
    """

    def __init__(self, message, positions, n_bad):
        super().__init__(message)
        self.positions = positions
        self.n_bad = n_bad


def default_moves():
    """Differential-evolution moves: 80 % DE, 20 % DE snooker (ter Braak & Vrugt 2008).

    DE moves mix better than the stretch move on the correlated, few-dimensional
    posteriors of this package (gamma and E0t are strongly correlated).
    """
    return [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]


#: Name of the default move set, recorded in outputs.
DEFAULT_MOVES = "per ensemble: 0.8 DEMove + 0.2 DESnookerMove"
#: Consecutive convergence checks with a coordinate no walker moved before a run is stopped.
STUCK_CHECKS = 5


def ensemble_seeds(seed, n_ensembles):
    """Independent integer seeds for ``n_ensembles`` ensembles derived from one user seed."""
    children = np.random.SeedSequence(seed).spawn(n_ensembles)
    return [int(c.generate_state(1, dtype=np.uint32)[0]) for c in children]


class LockstepMove(emcee.moves.Move):
    """Advance ``n_blocks`` independent ensembles with one log-probability call per half-step.

    Parameters
    ----------
    n_blocks : int
        Independent ensembles; the sampler has ``n_blocks * n_walkers`` walkers, block ``b``
        owning walkers ``b*n_walkers ... (b+1)*n_walkers - 1``.
    n_walkers : int
        Walkers per ensemble.
    seeds : sequence of int
        One seed per block (its proposal and acceptance stream).
    moves : list of (RedBlueMove, weight), optional
        Each block picks one per step with its own stream (:func:`default_moves`).
    """

    def __init__(self, n_blocks, n_walkers, seeds, moves=None):
        moves = default_moves() if moves is None else moves
        self.moves = [m for m, _ in moves]
        weights = np.array([w for _, w in moves], float)
        self.weights = weights / weights.sum()
        self.n_blocks, self.n_walkers = int(n_blocks), int(n_walkers)
        self.rngs = [np.random.RandomState(s) for s in seeds]
        if len(self.rngs) != self.n_blocks:
            raise ValueError(f"need {self.n_blocks} seeds, got {len(self.rngs)}")

    def propose(self, model, state):
        """One step of every block (emcee's red-blue scheme, per block)."""
        n_total = state.coords.shape[0]
        W = self.n_walkers
        chosen = [self.moves[rng.choice(len(self.moves), p=self.weights)] for rng in self.rngs]
        splits = []
        for rng, move in zip(self.rngs, chosen, strict=True):
            move.setup(state.coords[:W])
            inds = np.arange(W) % move.nsplits
            rng.shuffle(inds)
            splits.append(inds)
        accepted = np.zeros(n_total, dtype=bool)
        for r in range(max(m.nsplits for m in chosen)):
            # every block whose move has a split r proposes now; one vectorized call
            qs, factors, members, owners = [], [], [], []
            for b, (rng, inds, move) in enumerate(zip(self.rngs, splits, chosen, strict=True)):
                if r >= move.nsplits:
                    continue
                S = b * W + np.flatnonzero(inds == r)
                C = [state.coords[b * W + np.flatnonzero(inds == j)]
                     for j in range(move.nsplits) if j != r]
                q, f = move.get_proposal(state.coords[S], C, rng)
                qs.append(q)
                factors.append(f)
                members.append(S)
                owners.append(rng)
            state = self._accept(model, state, accepted, qs, factors, members, owners)
        return state, accepted

    def _accept(self, model, state, accepted, qs, factors, members, owners):
        q = np.concatenate(qs)
        new_log_prob, new_blobs = model.compute_log_prob_fn(q)
        start = 0
        for rng, S, f in zip(owners, members, factors, strict=True):
            diff = f + new_log_prob[start:start + S.size] - state.log_prob[S]
            accepted[S] = diff > np.log(rng.rand(S.size))
            start += S.size
        idx = np.concatenate(members)
        subset = np.zeros(state.coords.shape[0], dtype=bool)
        subset[idx] = True
        order = np.argsort(idx)  # Move.update expects the subset in walker order
        new_state = State(q[order], log_prob=new_log_prob[order],
                          blobs=None if new_blobs is None else new_blobs[order])
        return self.update(state, new_state, accepted, subset)


@dataclass
class EnsembleRun:
    """One ensemble after its run.

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
        Longer than ``tol`` taus, with tau stable between the last two checks.
    acceptance : float
        Mean acceptance fraction over the walkers.
    seed : int
        This ensemble's seed.
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
        return self.log_prob[self.burn :: self.thin].reshape(-1)


@dataclass
class SamplingResult:
    """Independent ensembles of one posterior (see :func:`run_ensembles`)."""

    ensembles: list
    tol: float
    n_steps: int
    seed: int
    moves: str = DEFAULT_MOVES
    #: Ensembles whose walkers stopped moving (the run was ended early for it; empty if none).
    stuck: list = field(default_factory=list)

    @property
    def converged(self):
        """All ensembles longer than ``tol`` autocorrelation times."""
        return all(e.converged for e in self.ensembles)

    @property
    def n_draws(self):
        """Draws per ensemble kept by :meth:`draws` (the shortest ensemble's count)."""
        return min(e.draws().shape[0] for e in self.ensembles)

    def draws(self):
        """``(n_ensembles, n_draws, n_dim)``: one ArviZ chain per ensemble (last draws kept)."""
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
    def acceptance(self):
        return float(np.mean([e.acceptance for e in self.ensembles]))


def _finite(log_prob_fn):
    def wrapped(p):
        lp = np.asarray(log_prob_fn(p), dtype=float)
        return np.where(np.isnan(lp), -np.inf, lp)

    return wrapped


def _block_tau(chain, burn_guess):
    """tau per coordinate of one block's chain ``(n, W, n_dim)`` after ``burn_guess`` steps."""
    return emcee.autocorr.integrated_time(chain[burn_guess:], c=5, tol=0, quiet=True)


class _Monitor:
    """Convergence bookkeeping of the blocks between checks."""

    def __init__(self, n_blocks, tol, burn_taus, rtol):
        self.tau = [None] * n_blocks
        self.burn = [0] * n_blocks
        self.done = [False] * n_blocks
        self.stuck = [0] * n_blocks  # consecutive checks with tau not estimable
        self.tol, self.burn_taus, self.rtol = tol, burn_taus, rtol

    def check(self, blocks):
        for b, chain in enumerate(blocks):
            n = chain.shape[0]
            old = self.tau[b]
            guess = n // 4 if old is None else min(n // 2, math.ceil(self.burn_taus * max(old)))
            raw = _block_tau(chain, guess)
            finite = bool(np.all(np.isfinite(raw)))
            self.stuck[b] = 0 if finite else self.stuck[b] + 1
            if not finite:
                # a coordinate no walker ever moved in (0/0): tau is unknown, at least the chain
                logger.warning("ensemble %d: autocorrelation time not estimable after %d steps "
                               "(walkers stuck); counted as not converged", b, n)
            tau = np.where(np.isfinite(raw), raw, float(n))
            stable = old is not None and bool(np.all(np.abs(tau - old) < self.rtol * tau))
            burn = math.ceil(self.burn_taus * np.max(tau))
            self.tau[b], self.burn[b] = tau, burn
            self.done[b] = bool(finite and stable and (n - burn) > self.tol * np.max(tau))
        return all(self.done)

    def stuck_blocks(self, checks):
        """Blocks whose tau was not estimable at each of the last ``checks`` checks."""
        return [b for b, n in enumerate(self.stuck) if n >= checks]

    def need(self):
        """Steps the slowest block needs by the current estimate."""
        return max(int(self.tol * np.max(t) + b) for t, b in zip(self.tau, self.burn,
                                                                 strict=True))


def _initial(log_prob_fn, init, rng, n_walkers, max_tries=100):
    """Starting walkers from ``init(rng)``, redrawing those with non-finite log density."""
    p0 = np.array(init(rng), dtype=float)
    if p0.ndim != 2 or p0.shape[0] != n_walkers:
        raise ValueError(f"init must return ({n_walkers}, n_dim) positions, got {p0.shape}")
    for _ in range(max_tries):
        bad = ~np.isfinite(log_prob_fn(p0))
        if not bad.any():
            return p0
        p0[bad] = np.array(init(rng), dtype=float)[bad]
    raise StartError(
        f"could not find finite starting log probabilities for {int(bad.sum())} of "
        f"{n_walkers} walkers after {max_tries} draws of the initializer",
        positions=p0, n_bad=int(bad.sum()),
    )


#: Per cent, elapsed time and the postfix (steps run / needed, tau); no rate (the unit is %).
_BAR_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| [{elapsed}{postfix}]"


def run_ensembles(log_prob_fn, init, seed, *, n_walkers, n_ensembles=4, tol=50.0,
                  check_every=100, max_steps=20000, min_steps=0, burn_taus=3.0, rtol=0.2,
                  moves=None, progress=True, stuck_checks=STUCK_CHECKS):
    """Run ``n_ensembles`` independent emcee ensembles until each is longer than ``tol`` tau.

    Parameters
    ----------
    log_prob_fn : callable
        Vectorized log density ``(n, n_dim) -> (n,)``.
    init : callable
        ``rng -> (n_walkers, n_dim)`` starting positions for one ensemble (walkers with a
        non-finite log density are redrawn, up to 100 times, then :class:`StartError`).
    seed : int
        User seed; ensemble ``b`` uses ``SeedSequence(seed).spawn(n_ensembles)[b]`` for its
        starting positions, proposals and acceptances.
    n_walkers : int
        Walkers per ensemble (>= 2 n_dim).
    n_ensembles : int
        Independent ensembles (>= 4 for between-chain diagnostics).
    tol : float
        Required length in integrated autocorrelation times.
    check_every : int
        Steps between convergence checks.
    max_steps : int
        Stop (not converged) after this many steps.
    min_steps : int
        Do not stop before this many steps.
    burn_taus : float
        Burn-in in units of tau.
    rtol : float
        Largest relative change of tau between the last two checks.
    moves : list of (move, weight), optional
        emcee red-blue moves (default :func:`default_moves`).
    progress : bool
        Progress towards convergence (:func:`turgorbayes.progress.progress`), in per cent of the steps the current
        autocorrelation times need (:func:`bar_total`, updated at every check); when that
        need grows the bar waits instead of moving back (:func:`bar_position`). Its postfix
        gives the steps run, the need and the largest tau (:func:`progress_note`); it ends at
        100 % when the run converges and short of it when ``max_steps`` stops the run.
    stuck_checks : int
        Stop (not converged, ``SamplingResult.stuck`` naming the ensembles) when an ensemble
        had a coordinate that no walker moved at this many consecutive checks: no accepted
        move in hundreds of steps, which more steps do not mend (a criticism re-run with
        3x ``max_steps`` of such a candidate took over 30 minutes for nothing).

    Returns
    -------
    SamplingResult
    """
    if n_ensembles < 1:
        raise ValueError(f"n_ensembles must be >= 1, got {n_ensembles}")
    log_prob_fn = _finite(log_prob_fn)
    seeds = ensemble_seeds(seed, n_ensembles)
    p0 = np.concatenate([_initial(log_prob_fn, init, np.random.default_rng(s), n_walkers)
                         for s in seeds])
    move = LockstepMove(n_ensembles, n_walkers, seeds, moves)
    sampler = emcee.EnsembleSampler(n_ensembles * n_walkers, p0.shape[1], log_prob_fn,
                                    vectorize=True, moves=[move])
    sampler.random_state = np.random.RandomState(seeds[0]).get_state()  # unused by the move
    monitor = _Monitor(n_ensembles, tol, burn_taus, rtol)
    state, done = p0, False
    # in per cent of the steps the current tau estimate needs; never moving back
    with show_progress(total=100, desc="sampling to convergence", unit="%", enabled=progress,
                       leave=True, bar_format=_BAR_FORMAT) as bar:
        while not done and sampler.iteration < max_steps and not monitor.stuck_blocks(stuck_checks):
            steps = min(check_every, max_steps - sampler.iteration)
            state = sampler.run_mcmc(state, steps, progress=False)
            chain = sampler.get_chain()
            done = monitor.check(_blocks(chain, n_ensembles, n_walkers))
            done = done and sampler.iteration >= min_steps
            need = max(monitor.need(), min_steps)
            total = bar_total(sampler.iteration, need, done, check_every)
            bar.set_postfix_str(f"{sampler.iteration}/{total} steps, " + progress_note(
                monitor, need, sampler.iteration, done, max_steps), refresh=False)
            bar.update(bar_position(bar.n, sampler.iteration, total) - bar.n)
    stuck = monitor.stuck_blocks(stuck_checks)
    if stuck:
        logger.warning("sampler stopped after %d steps: the walkers of ensemble(s) %s made no "
                       "move at %d consecutive checks", sampler.iteration,
                       ", ".join(map(str, stuck)), stuck_checks)
    elif not done:
        logger.warning("sampler not converged after %d steps (needs about %d by the current "
                       "autocorrelation times)", sampler.iteration, monitor.need())
    return _result(sampler, monitor, seeds, n_ensembles, n_walkers, tol, seed, stuck)


def bar_total(n, need, done, check_every):
    """Total of the progress bar after a convergence check at step ``n``.

    Parameters
    ----------
    n : int
        Steps run so far.
    need : int
        Steps the slowest ensemble needs by its current autocorrelation time
        (``tol`` tau plus burn-in, at least ``min_steps``).
    done : bool
        Whether the run has just converged.
    check_every : int
        Steps to the next check.

    Returns
    -------
    int
        ``n`` when converged (the bar ends at 100 %); otherwise ``need``, but at least the
        next check (``n + check_every``) when the length suffices and tau has not settled yet.
    """
    if done:
        return int(n)
    return int(max(need, n + check_every))


def bar_position(shown, n, total):
    """Position of the progress bar, in per cent, after a check at step ``n``.

    ``100 n / total``, but never below the position already ``shown``: when the steps needed
    grow (a longer autocorrelation time), the bar waits until the run catches up instead of
    moving back. 100 exactly when ``n`` reaches ``total`` (converged: :func:`bar_total`).
    """
    return max(float(shown), 100.0 * n / total)


def progress_note(monitor, need, n, done, max_steps):
    """Postfix of the progress bar: the current tau and what the run still waits for."""
    tau = max(np.max(t) for t in monitor.tau)
    if done:
        return f"converged: tau {tau:.1f}, {n} steps >= {need} needed"
    if need > max_steps:
        return f"tau {tau:.1f}, needs ~{need} steps > max {max_steps}"
    if need <= n:
        return f"tau {tau:.1f}, long enough; waiting for tau to settle"
    return f"tau {tau:.1f}, needs ~{need} steps"


def evenly_spaced(n, n_max):
    """Indices of at most ``n_max`` evenly spaced draws out of ``n`` (all if ``n <= n_max``)."""
    if n <= n_max:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, n_max)).astype(int))


def _blocks(chain, n_blocks, n_walkers):
    return [chain[:, b * n_walkers:(b + 1) * n_walkers] for b in range(n_blocks)]


def _result(sampler, monitor, seeds, n_blocks, n_walkers, tol, seed, stuck):
    chain, log_prob = sampler.get_chain(), sampler.get_log_prob()
    acc = sampler.acceptance_fraction
    # common burn-in and thinning so that every ensemble's draws mean the same thing
    burn = min(max(monitor.burn), chain.shape[0] - 1)
    thin = max(1, math.ceil(max(np.max(t) for t in monitor.tau)))
    runs = []
    for b in range(n_blocks):
        sl = slice(b * n_walkers, (b + 1) * n_walkers)
        runs.append(EnsembleRun(chain=chain[:, sl], log_prob=log_prob[:, sl],
                                tau=monitor.tau[b], burn=burn, thin=thin,
                                converged=monitor.done[b], acceptance=float(np.mean(acc[sl])),
                                seed=seeds[b]))
    return SamplingResult(ensembles=runs, tol=tol, n_steps=int(chain.shape[0]), seed=seed,
                          stuck=stuck)
