r"""Model criticism: find what the baseline gets wrong, name the cause, fit it, measure the gain.

The workflow (:func:`criticize`, ``turgorbayes criticize DATA.csv --out DIR``):

1. **Baseline fit** (:class:`turgorbayes.effects.ExtendedModel` without effects: the baseline
   model of :mod:`turgorbayes.inference.models`, latent bulge pressures integrated out per cell).
2. **Checks**: the posterior predictive battery of :mod:`turgorbayes.criticism.checks` (residual trends,
   scatter per group and observable, R_c-k_c residual correlation, tails, bulged vs intact,
   LOO-PIT) with its Bonferroni threshold (family-wise 5 %, :data:`turgorbayes.criticism.checks.FAMILY_ALPHA`).
3. **Every effect** of :mod:`turgorbayes.effects` fitted as an extension of the baseline.
4. **Comparison** by PSIS-LOO on the same per-cell points: for each extension
   :math:`\Delta = \sum_i (\mathrm{elpd}_i^{ext} - \mathrm{elpd}_i^{base})` and its standard error
   :math:`\mathrm{se} = \sqrt{n\,\mathrm{var}_i(\Delta_i)}` (Vehtari, Gelman & Gabry 2017).
   Pareto-k diagnostics are respected: every cell whose LOO importance weights have
   :math:`\hat k` above ArviZ's threshold :math:`\min(1 - 1/\log_{10}S, 0.7)` is refitted
   exactly without that cell (up to ``max_refits`` per model; any left over are counted and
   reported as unreliable).
5. **Selection rule** (:func:`select`): the extension with the largest gain is selected when
   :math:`\Delta > 4` nats **and** the gain is positive with probability at least 0.975 under
   the Bayesian bootstrap of the 114 pointwise differences (:data:`DELTA_ELPD_MIN`,
   :data:`P_GAIN_MIN`, :func:`gain_probability`). Four nats is a likelihood ratio of ~55,
   beyond what one extra parameter gains by chance on data without the effect (about -1 to +1);
   the probability condition is "Delta > 2 se" of the normal approximation (one-sided 0.977)
   made robust: when the gain comes from a few cells (corrupted curves) the se is dominated
   by those cells and the normal approximation fails (Sivula, Magnusson, Matamoros & Vehtari,
   arXiv:2008.10296), the bootstrap does not. Otherwise nothing is selected.
6. **Combination**: when an effect is selected, it is fitted together with the runner-up; the
   pair replaces it only if it beats the single effect by the same rule.

Inference engine (:func:`fit_posterior`)
-----------------------------------------
The posteriors have 4-7 parameters and are close to Gaussian in the sampler coordinates of
:mod:`turgorbayes.inference.priors`, and the workflow needs about seven of them per data set (and the power
study thousands), so by default each is computed by **Pareto-smoothed importance sampling**
(Vehtari, Simpson, Gelman, Yao & Gabry, JMLR 25, 2024): draws from a multivariate Student-t
(``df`` = 5) centred on the posterior mode with the inverse Hessian as scale, one round of
moment matching of the proposal to the weighted draws, and the Pareto :math:`\hat k` of the
importance weights as the reliability diagnostic. A posterior counts as converged when
:math:`\hat k \le 0.7` and the importance-sampling effective sample size
:math:`1/\sum_s \tilde w_s^2` is at least ``ess_min``. Otherwise the model is refitted with the
package's emcee sampler (:func:`turgorbayes.inference.sampling.run_ensembles`, four independent ensembles
run to 50 autocorrelation times, R-hat and ESS by ArviZ), as it is for every model with
``engine="emcee"``. PSIS-LOO of an importance-sampled posterior uses the raw LOO ratios
:math:`w_s / p(y_i\mid\theta_s)` relative to the proposal, so its :math:`\hat k_i` covers both
importance steps.
"""

import logging
import math
from dataclasses import dataclass, field

import numpy as np
from arviz_stats.base import array_stats
from scipy import optimize, special, stats

from turgorbayes import effects, results
from turgorbayes.criticism import checks as checks_module
from turgorbayes.criticism import stacking
from turgorbayes.criticism.stacking import weighted_stats
from turgorbayes.inference import diagnostics, models, sampling

__all__ = [
    "CRITICISM_KEYS",
    "DELTA_ELPD_MIN",
    "K_MAX",
    "P_GAIN_MIN",
    "CriticismResult",
    "CriticismSettings",
    "Posterior",
    "cause_sentence",
    "compare",
    "criticism_dict",
    "criticize",
    "exact_loo",
    "find_mode",
    "fit_posterior",
    "gain_probability",
    "hessian_cov",
    "importance_posterior",
    "laplace",
    "mcmc_posterior",
    "predictive_checks",
    "psis_loo",
    "select",
]

logger = logging.getLogger(__name__)

#: Selection rule: the gain must exceed this many nats ...
DELTA_ELPD_MIN = 4.0
#: ... and be positive with at least this Bayesian-bootstrap probability (2 se if normal).
P_GAIN_MIN = 0.975
#: An unselected best extension gaining more than this is named as weak evidence in the cause
#: (not adopted): an outer membrane at its realistic size typically gains 2-4 nats only.
DELTA_ELPD_WEAK = 2.0
#: Largest acceptable Pareto k of an importance-sampled posterior.
K_MAX = 0.7
#: criticism.json: top-level keys (issue 5) and the sub-keys of the nested entries.
CRITICISM_KEYS = {
    "misfit_detected": None,
    "checks": ("name", "statistic", "p_value", "flagged"),
    "candidates": ("effect", "delta_elpd", "delta_se", "estimate"),
    "selected_effect": None,
    "cause": None,
    "gain": ("delta_elpd", "se"),
    "parameters": ("baseline", "extended"),
}
_DERIVED = {"E_perp": ("E_perp_MPa", 1e6), "E_par": ("E_par_MPa", 1e6)}


@dataclass
class CriticismSettings:
    """Settings of :func:`criticize` (CLI defaults; tests use fewer draws).

    Attributes
    ----------
    engine : str
        ``"importance"`` (PSIS importance sampling, emcee where it is unreliable) or
        ``"emcee"`` (every model by MCMC).
    n_draws : int
        Importance-sampling draws per round.
    df : float
        Degrees of freedom of the Student-t proposal.
    batch : int
        Draws per vectorized likelihood call.
    ess_min : float
        Smallest acceptable effective sample size.
    n_rep : int
        Posterior draws used by the predictive checks (>= 2/alpha resolves the threshold).
    max_refits : int
        Exact leave-one-out refits per model for cells with a large Pareto k.
    effects : tuple of str or None
        Candidate effects (None: every registered effect).
    mcmc : turgorbayes.results.FitSettings
        Sampler settings of the emcee engine.
    """

    engine: str = "importance"
    n_draws: int = 2000
    df: float = 5.0
    batch: int = 128
    ess_min: float = 400.0
    n_rep: int = 1000
    max_refits: int = 10
    effects: tuple = None
    mcmc: results.FitSettings = field(default_factory=lambda: results.FitSettings(progress=False))

    def __post_init__(self):
        if self.engine not in ("importance", "emcee"):
            raise ValueError(f"engine must be 'importance' or 'emcee', got {self.engine!r}")
        for name in ("n_draws", "batch", "n_rep"):
            if int(getattr(self, name)) < 2:
                raise ValueError(f"{name} must be an integer >= 2, got {getattr(self, name)!r}")
        if self.max_refits < 0:
            raise ValueError(f"max_refits must be >= 0, got {self.max_refits!r}")


def _rng(seed, *stream):
    return np.random.default_rng(np.random.SeedSequence([int(seed), *map(int, stream)]))


def _logsumexp(a, axis=None):
    return special.logsumexp(a, axis=axis)


# ------------------------------------------------------------------------------ posteriors
@dataclass
class Posterior:
    """Weighted draws of one model's posterior.

    Attributes
    ----------
    model : turgorbayes.effects.ExtendedModel
    u : ndarray (S, ndim)
        Draws in sampler coordinates.
    log_w : ndarray (S,)
        Normalized log weights (``-ln S`` each for MCMC draws).
    log_lik : ndarray (S, n_cells)
        Pointwise log-likelihood of every draw.
    engine : str
        ``"importance"`` or ``"emcee"``.
    converged : bool
    reasons : list of str
        Why not converged (empty if converged).
    diagnostics : dict
        ``k_hat`` and ``ess`` (importance) or ``chain`` (R-hat, ESS per parameter), ``ensembles``.
    u_map, cov : ndarray
        Posterior mode and inverse Hessian there (sampler coordinates).
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

    @property
    def weights(self):
        return np.exp(self.log_w)

    @property
    def ess(self):
        """Effective sample size of the weights, ``1/sum w^2`` (S for equal weights)."""
        return float(1.0 / np.sum(self.weights**2))

    def resample(self, n, rng):
        """Indices of ``n`` draws resampled by weight (systematic resampling)."""
        c = np.cumsum(self.weights)
        c /= c[-1]
        return np.minimum(np.searchsorted(c, (rng.random() + np.arange(n)) / n), c.size - 1)

    def physical(self, rng):
        """``{name: (S,)}`` physical values of every parameter and the derived moduli (SI)."""
        out = self.model.to_physical(self.u)
        out.update(_batched(lambda u: self.model.derived(u, rng), self.u, 512))
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


def _display(model):
    """posterior name -> (summary key, SI per display unit), baseline first, then effects."""
    out = {p.name: (p.key, p.factor) for p in model.parameters[:4]}
    out.update(_DERIVED)
    out.update({p.name: (p.key, p.factor) for p in model.parameters[4:]})
    return out


def _batched(fn, u, batch):
    """Apply ``fn`` to ``u`` in batches; concatenates arrays or dicts of arrays."""
    parts = [fn(u[i:i + batch]) for i in range(0, len(u), batch)]
    if isinstance(parts[0], dict):
        return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return np.concatenate(parts)


# ------------------------------------------------------------------------------ mode, Laplace
def _steps(u):
    return 1e-4 * np.maximum(np.abs(u), 1.0)


def find_mode(model, u0, maxiter=200):
    """Posterior mode in sampler coordinates (BFGS, vectorized central-difference gradients).

    Parameters
    ----------
    model : object
        With a vectorized ``log_posterior(u (W, ndim)) -> (W,)``.
    u0 : ndarray (ndim,)
        Start (finite log posterior).

    Returns
    -------
    ndarray (ndim,)
    """
    u0 = np.asarray(u0, float)
    d = u0.size
    if not np.isfinite(model.log_posterior(u0[None])[0]):
        raise ValueError("the starting point of the mode search has a non-finite log posterior")

    def fg(u):
        h = _steps(u)
        pts = np.vstack([u, u + np.diag(h), u - np.diag(h)])
        lp = model.log_posterior(pts)
        if not np.isfinite(lp[0]):
            return np.inf, np.zeros(d)
        g = (lp[1:d + 1] - lp[d + 1:]) / (2 * h)
        return -lp[0], np.where(np.isfinite(g), -g, 0.0)

    res = optimize.minimize(fg, u0, jac=True, method="BFGS",
                            options={"maxiter": maxiter, "gtol": 1e-3})
    return res.x if np.isfinite(res.fun) and res.fun <= fg(u0)[0] else u0


def hessian_cov(model, u, steps=None):
    """Inverse of the finite-difference Hessian of ``-log_posterior`` at ``u`` (one call).

    The Hessian is scaled to unit diagonal and its eigenvalues are clipped at 1e-3 there, so a
    direction in which the log posterior is flat or not concave gets a large but finite
    variance instead of a negative or infinite one.

    Returns
    -------
    ndarray (ndim, ndim)
    """
    u = np.asarray(u, float)
    k = u.size
    h = 1e-3 * np.maximum(np.abs(u), 1.0) if steps is None else np.asarray(steps, float)
    pts, idx = [u], {}
    for i in range(k):
        for si in (1, -1):
            idx[(i, si)] = len(pts)
            pts.append(u + si * h[i] * np.eye(k)[i])
    for i in range(k):
        for j in range(i + 1, k):
            for si in (1, -1):
                for sj in (1, -1):
                    idx[(i, j, si, sj)] = len(pts)
                    pts.append(u + si * h[i] * np.eye(k)[i] + sj * h[j] * np.eye(k)[j])
    f = -model.log_posterior(np.array(pts))
    if not np.all(np.isfinite(f)):
        raise ValueError("the Hessian stencil leaves the region where the model is defined")
    H = np.empty((k, k))
    for i in range(k):
        H[i, i] = (f[idx[(i, 1)]] - 2 * f[0] + f[idx[(i, -1)]]) / h[i] ** 2
        for j in range(i + 1, k):
            H[i, j] = H[j, i] = (f[idx[(i, j, 1, 1)]] - f[idx[(i, j, 1, -1)]]
                                 - f[idx[(i, j, -1, 1)]] + f[idx[(i, j, -1, -1)]]) / (4 * h[i] * h[j])
    # clip in scale-free units (coordinates differ by orders of magnitude in scale)
    D = np.sqrt(np.maximum(np.abs(np.diag(H)), 1e-12))
    vals, vecs = np.linalg.eigh(0.5 * (H + H.T) / np.outer(D, D))
    vals = np.maximum(vals, 1e-3)
    return ((vecs / vals) @ vecs.T) / np.outer(D, D)


def laplace(model, guess):
    """Mode and covariance (two Hessian passes, the second with steps of 0.2 posterior sd).

    A stencil that leaves the model's domain is retried with steps ten times smaller. If no
    finite Hessian exists (the mode sits on the edge of the region where the model is defined,
    e.g. where the radius saturates), a diagonal covariance of 1 % of each coordinate (at
    least 0.01) is returned with a warning: the engines then explore from there and their own
    diagnostics (Pareto k, R-hat, ESS) decide whether the posterior is usable.
    """
    u_map = find_mode(model, model.to_u(guess)[0])
    steps = 1e-3 * np.maximum(np.abs(u_map), 1.0)
    cov = None
    for _ in range(4):
        try:
            cov = hessian_cov(model, u_map, steps)
            break
        except ValueError:
            steps = steps / 10
    if cov is None:
        logger.warning("%s: no finite Hessian at the posterior mode (the mode is on the edge of "
                       "the model's domain); using a diagonal proposal covariance", model.name)
        return u_map, np.diag((1e-2 * np.maximum(np.abs(u_map), 1.0)) ** 2)
    try:
        cov = hessian_cov(model, u_map, steps=0.2 * np.sqrt(np.diag(cov)))
    except ValueError:
        pass
    return u_map, cov


# ------------------------------------------------------------------------------ engines
def _log_lik_and_prior(model, u, batch):
    lp0 = model.log_prior(u)
    ll = np.full((len(u), model.obs.n_cells), -np.inf)
    ok = np.isfinite(lp0)
    if ok.any():
        with np.errstate(all="ignore"):
            ll[ok] = _batched(model.pointwise_log_likelihood, u[ok], batch)
    ll = np.where(np.isnan(ll), -np.inf, ll)
    return ll, np.where(ok, lp0, -np.inf)


def _psis(log_ratios):
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
    """PSIS importance sampling around the mode (module docstring).

    The first proposal is a split-t around the mode (:class:`_SplitT`: the Laplace axes with
    separate scales on each side, fitted to the log posterior's decay, so skewed posteriors are
    followed), as a defensive mixture (Hesterberg, Technometrics 37, 185, 1995) with a copy
    three times wider (weight 0.2) that keeps the weights bounded. While a round gives
    ``k_hat > 0.5`` or an ESS below half the draws of a round (at most :data:`_ROUNDS` rounds),
    the next round draws from a split-t with the weighted mean and covariance of all draws so
    far, and all draws are weighted against the equal mixture of the proposals
    (deterministic-mixture multiple importance sampling, Owen & Zhou, JASA 95, 135, 2000).

    Returns
    -------
    Posterior
        ``converged`` False (with reasons) when ``k_hat > K_MAX`` or the ESS is too small.
    """
    rng = _rng(seed, 7)
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
        log_q = _logsumexp([q.logpdf(u) for q in proposals], axis=0) - np.log(len(proposals))
        raw = lp - log_q
        finite = np.isfinite(raw)
        if finite.sum() < 10:
            raise ValueError(f"{model.name}: fewer than 10 of {raw.size} importance draws have a "
                             "finite posterior density")
        log_w = np.full(raw.shape, -np.inf)
        log_w[finite], k_hat = _psis(raw[finite])
        w = np.exp(log_w)
        ess = float(1 / np.sum(w**2))
        if round_ < _ROUNDS - 1 and (k_hat > 0.5 or ess < 0.5 * settings.n_draws):
            scale = np.cov(u.T, aweights=w + 1e-300) + 1e-12 * np.eye(u.shape[1])
            proposals.append(_SplitT(w @ u, scale, settings.df))
            continue
        break
    reasons = []
    if not k_hat <= K_MAX:
        reasons.append(f"importance sampling unreliable: Pareto k = {k_hat:.2f} > {K_MAX}")
    if not ess >= settings.ess_min:
        reasons.append(f"importance-sampling ESS {ess:.0f} < {settings.ess_min:.0f}")
    keep = w > 0
    return Posterior(model=model, u=u[keep], log_w=log_w[keep], log_lik=ll[keep],
                     engine="importance", converged=not reasons, reasons=reasons,
                     diagnostics={"k_hat": float(k_hat), "ess": ess, "rounds": len(proposals),
                                  "n_draws": int(u.shape[0])},
                     u_map=np.asarray(u_map), cov=np.asarray(cov))


def mcmc_posterior(model, u_map, cov, seed, settings):
    """The package's emcee sampler (independent ensembles run to 50 tau) from the mode."""
    import arviz_base as azb

    s = settings.mcmc
    chol = np.linalg.cholesky(cov)

    def init(rng):
        return u_map + 2.0 * rng.standard_normal((s.n_walkers, model.ndim)) @ chol.T

    run = sampling.run_ensembles(model.log_posterior, init, seed, n_walkers=s.n_walkers,
                                 n_ensembles=s.n_ensembles, tol=s.tol,
                                 check_every=s.check_every, max_steps=s.max_steps,
                                 progress=s.progress)
    draws = run.draws()
    keep = np.unique(np.round(np.linspace(0, draws.shape[1] - 1,
                                          min(draws.shape[1], s.max_draws_per_chain))).astype(int))
    draws = draws[:, keep]
    C, D, d = draws.shape
    u = draws.reshape(C * D, d)
    ll, _ = _log_lik_and_prior(model, u, settings.batch)
    phys = model.to_physical(u)
    phys.update(_batched(lambda x: model.derived(x, _rng(seed, 8)), u, 512))
    dt = azb.from_dict({"posterior": {k: np.asarray(v).reshape(C, D) for k, v in phys.items()}})
    chain = diagnostics.chain_diagnostics(dt, list(phys))
    ok, reasons = diagnostics.is_converged(run.converged, {n: chain[n] for n in model.names})
    return Posterior(model=model, u=u, log_w=np.full(len(u), -np.log(len(u))), log_lik=ll,
                     engine="emcee", converged=ok, reasons=reasons,
                     diagnostics={"chain": chain, "n_steps": run.n_steps, "tau": run.tau.tolist(),
                                  "n_chains": C},
                     u_map=np.asarray(u_map), cov=np.asarray(cov))


def fit_posterior(model, guess, seed, settings):
    """Posterior of ``model`` by the configured engine (module docstring).

    Parameters
    ----------
    model : turgorbayes.effects.ExtendedModel
    guess : dict
        Physical starting values of every parameter (SI).
    seed : int
    settings : CriticismSettings

    Returns
    -------
    Posterior
    """
    u_map, cov = laplace(model, guess)
    post = None
    if settings.engine == "importance":
        try:
            post = importance_posterior(model, u_map, cov, seed, settings)
        except ValueError as err:
            logger.info("%s: %s; falling back to emcee", model.name, err)
        else:
            if post.converged:
                return post
            logger.info("%s: %s; falling back to emcee", model.name, "; ".join(post.reasons))
    try:
        return mcmc_posterior(model, u_map, cov, seed, settings)
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as err:
        if post is None:
            raise
        post.reasons.append(f"the emcee fallback failed ({err}); importance-sampling draws kept")
        return post


# ------------------------------------------------------------------------------ LOO
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
    elpd_i = _logsumexp(lw + ll.T, axis=1)
    lppd_i = _logsumexp(log_w[:, None] + ll, axis=0)
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
        elpd_i[i] = float(_logsumexp(p_i.log_w + np.where(np.isnan(ll_i), -np.inf, ll_i)))
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


def select(candidates, delta_min=DELTA_ELPD_MIN, p_min=P_GAIN_MIN):
    """The selection rule (module docstring).

    Parameters
    ----------
    candidates : sequence of dict
        Each with ``effect``, ``delta_elpd`` and ``p_gain``.

    Returns
    -------
    best : dict or None
        The best candidate if it passes the rule, else None.
    runner_up : dict or None
        The second best (None if fewer than two).
    """
    ranked = sorted(candidates, key=lambda c: -c["delta_elpd"])
    if not ranked:
        return None, None
    best = ranked[0]
    ok = best["delta_elpd"] > delta_min and best["p_gain"] >= p_min
    return (best if ok else None), (ranked[1] if len(ranked) > 1 else None)


# ------------------------------------------------------------------------------ checks
def predictive_checks(post, seed, settings):
    """The :mod:`turgorbayes.criticism.checks` battery on a posterior.

    Returns
    -------
    checks : list of dict
        ``{"name", "statistic", "p_value", "flagged"}``.
    arrays : dict
        ``y``, ``sigma``, ``y_rep``, ``mu``, ``log_pressure`` and ``group`` (for figures).
    """
    model = post.model
    rng = _rng(seed, 11)
    idx = post.resample(settings.n_rep, rng)
    u = post.u[idx]
    y_rep = _batched(lambda x: model.posterior_predictive(x, rng), u, 256)
    mu = _batched(model.predicted_means, u, 256)
    obs = model.obs
    y = {"R_c": obs.R_c, "k_c": obs.k_c}
    sigma = {"R_c": obs.R_c_err, "k_c": obs.k_c_err}
    group = np.where(obs.is_bulged, "bulged", "intact")
    log_p = model._log_pressure_centre(model.to_physical(u))
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = checks_module.run_checks(y, sigma, y_rep, mu, group, log_p, post.log_lik[idx])
    return out, {"y": y, "sigma": sigma, "y_rep": y_rep, "mu": mu, "log_pressure": log_p,
                 "group": group}


# ------------------------------------------------------------------------------ workflow
@dataclass
class CriticismResult:
    """Everything :func:`criticize` produced (see :func:`criticism_dict` for the JSON)."""

    cells: object
    seed: int
    settings: CriticismSettings
    posteriors: dict  # model name -> Posterior
    loo: dict  # model name -> loo dict
    checks: dict  # model name -> list of check dicts
    check_arrays: dict  # model name -> arrays for figures
    candidates: list
    selected: str
    runner_up: str
    gain: tuple
    summaries: dict  # model name -> parameter summaries
    timing_s: float = 0.0
    stacking: dict = None  # turgorbayes.criticism.stacking.stack: model weights, model-averaged summaries


def _estimate(summary, model):
    """``{key: {mean, q05, q95}}`` of an effect's own parameters."""
    keys = [p.key for p in model.parameters[4:]]
    return {k: {f: summary[k][f] for f in ("mean", "q05", "q95")} for k in keys}


def _fit(cells, surrogate, names, guess, seed, settings):
    model = effects.ExtendedModel(cells, surrogate, names)
    post = fit_posterior(model, model.start_values(guess), seed, settings)
    return post, exact_loo(post, cells, surrogate, seed, settings)


def criticize(cells, surrogate, seed=0, settings=None, progress=None):
    """Run the whole criticism workflow on a data set (module docstring).

    Parameters
    ----------
    cells : turgorbayes.io.CellData
        Bulged and intact cells.
    surrogate : turgorbayes.surrogate.Surrogate
    seed : int
        Seed of every random draw.
    settings : CriticismSettings, optional
    progress : callable, optional
        ``progress(message)`` after each step.

    Returns
    -------
    CriticismResult
    """
    import time

    t0 = time.perf_counter()
    settings = CriticismSettings() if settings is None else settings
    say = progress or (lambda msg: None)
    cells.require_both_groups()
    names = list(settings.effects) if settings.effects is not None else effects.effect_names()
    for n in names:
        effects.get_effect(n)
    wls = models.PaperWLS(cells, surrogate).fit()
    posts, loos = {}, {}
    posts["baseline"], loos["baseline"] = _fit(cells, surrogate, [], wls.estimate, seed, settings)
    say(f"baseline: {_status(posts['baseline'], loos['baseline'])}")
    base_map = {k: float(v[0]) for k, v in
                posts["baseline"].model.to_physical(posts["baseline"].u_map[None]).items()}
    chk, arrays = {}, {}
    chk["baseline"], arrays["baseline"] = predictive_checks(posts["baseline"], seed, settings)
    say(f"checks: {sum(c['flagged'] for c in chk['baseline'])} of {len(chk['baseline'])} flagged")
    candidates = []
    for i, name in enumerate(names):
        posts[name], loos[name] = _fit(cells, surrogate, [name], base_map, seed + 101 * (i + 1),
                                       settings)
        candidates.append(_candidate(name, posts[name], loos[name], loos["baseline"], seed))
        say(f"{name}: delta elpd {candidates[-1]['delta_elpd']:.1f} +- "
            f"{candidates[-1]['delta_se']:.1f} (P(gain > 0) = {candidates[-1]['p_gain']:.3f}); "
            f"{_status(posts[name], loos[name])}")
    best, runner = select(candidates)
    selected = best["effect"] if best else None
    if best and runner:
        pair = [best["effect"], runner["effect"]]
        name = effects.model_name(pair)
        guess = {k: float(v[0]) for k, v in
                 posts[best["effect"]].model.to_physical(posts[best["effect"]].u_map[None]).items()}
        guess.update({k: float(v[0]) for k, v in posts[runner["effect"]].model.to_physical(
            posts[runner["effect"]].u_map[None]).items() if k not in guess})
        posts[name], loos[name] = _fit(cells, surrogate, pair, guess, seed + 9973, settings)
        cand = _candidate(name, posts[name], loos[name], loos["baseline"], seed)
        candidates.append(cand)
        d, se, p = compare(loos[name], loos[best["effect"]], seed)
        cand["vs_selected"] = {"delta_elpd": d, "se": se, "p_gain": p}
        if d > DELTA_ELPD_MIN and p >= P_GAIN_MIN:
            selected = name
        say(f"{name}: delta elpd vs {best['effect']} {d:.1f} +- {se:.1f}")
    if selected:
        chk[selected], arrays[selected] = predictive_checks(posts[selected], seed, settings)
    gain = compare(loos[selected], loos["baseline"], seed) if selected else (0.0, 0.0, 0.0)
    summaries = {name: posts[name].summary(_rng(seed, 13)) for name in posts}
    stacked = stacking.stack(posts, loos, _rng(seed, 14))
    say("model average (stacking): " + ", ".join(f"{n} {w:.2f}" for n, w in
                                                 stacked["weights"].items() if w >= 0.005))
    return CriticismResult(cells=cells, seed=seed, settings=settings, posteriors=posts, loo=loos,
                           checks=chk, check_arrays=arrays, candidates=candidates,
                           selected=selected, runner_up=runner["effect"] if runner else None,
                           gain=gain, summaries=summaries, timing_s=time.perf_counter() - t0,
                           stacking=stacked)


def _status(post, loo):
    conv = "converged" if post.converged else "NOT converged (" + "; ".join(post.reasons) + ")"
    return (f"{post.engine}, {conv}, elpd {loo['elpd']:.1f}, {loo['n_bad']} cells with high "
            f"Pareto k ({len(loo['refitted'])} refitted exactly)")


def _candidate(name, post, loo, loo_base, seed):
    d, se, p = compare(loo, loo_base, seed)
    return {"effect": name, "delta_elpd": d, "delta_se": se, "p_gain": p,
            "estimate": _estimate(post.summary(_rng(seed, 13)), post.model)}


def cause_sentence(result):
    """One sentence (or two, for a pair) naming the selected cause, with its fitted size."""
    if not result.selected:
        text = ("No cause found: the baseline model describes these data as well as any of the "
                f"{len(result.candidates)} candidate extensions by the selection rule.")
        best = max(result.candidates, key=lambda c: c["delta_elpd"], default=None)
        if best is not None and best["delta_elpd"] > DELTA_ELPD_WEAK:
            text += (f" Weak evidence for {best['effect']} (delta elpd {best['delta_elpd']:.1f} +- "
                     f"{best['delta_se']:.1f}, below the rule): if it is real, the baseline's "
                     "pressure and wall stiffness are biased; more cells would settle it.")
        return text
    post = result.posteriors[result.selected]
    summary = result.summaries[result.selected]
    parts = []
    for e in post.model.effects:
        key = next(p.key for p in e.parameters if p.name == e.size_parameter)
        parts.append(e.cause.format(size=summary[key]["q50"]))
    return " ".join(parts)


def criticism_dict(result):
    """The ``criticism.json`` content (keys exactly :data:`CRITICISM_KEYS`).

    ``misfit_detected`` is true when any baseline check is flagged or an extension is selected
    (either is evidence against the baseline); ``checks`` are the baseline's; ``candidates``
    the single effects and, if one was selected, its pair with the runner-up; ``gain`` is the
    adopted model's over the baseline (0 and 0 when nothing is adopted, and then
    ``parameters.extended`` is null); parameter entries have the fields of ``summary.json``
    (for importance sampling ``r_hat`` is null and both ESS are the weights' ESS).
    """
    flagged = any(c["flagged"] for c in result.checks["baseline"])
    candidates = [{k: c[k] for k in CRITICISM_KEYS["candidates"]} for c in result.candidates]
    return {
        "misfit_detected": bool(flagged or result.selected is not None),
        "checks": [{k: c[k] for k in CRITICISM_KEYS["checks"]} for c in result.checks["baseline"]],
        "candidates": candidates,
        "selected_effect": result.selected,
        "cause": cause_sentence(result),
        "gain": {"delta_elpd": float(result.gain[0]), "se": float(result.gain[1])},
        "parameters": {"baseline": result.summaries["baseline"],
                       "extended": result.summaries[result.selected] if result.selected else None},
    }
