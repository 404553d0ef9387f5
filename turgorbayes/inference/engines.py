"""The three engines of :func:`turgorbayes.inference.engine.fit_posterior`, each from one
Laplace fit: PSIS importance sampling (:func:`importance_posterior`), emcee
(:func:`mcmc_posterior`) and draws from the normal approximation (:func:`laplace_posterior`),
with one convergence rule per engine (:func:`judge`); docs/statistics.md, "One posterior
engine"."""


import numpy as np
from scipy import stats
from scipy.special import logsumexp

from turgorbayes.inference import diagnostics, sampling
from turgorbayes.inference.mode import LaplaceFit, ModeSearch
from turgorbayes.inference.posterior import Posterior, batched, log_lik_and_prior
from turgorbayes.inference.streams import stream_rng

__all__ = ["K_MAX", "START_SHRINK", "START_SPREAD", "given_laplace", "importance_posterior",
           "judge", "laplace_posterior", "mcmc_posterior", "psis_weights", "walker_start"]

#: Largest acceptable Pareto k of an importance-sampled posterior.
K_MAX = 0.7

def psis_weights(log_ratios):
    """Pareto-smoothed, normalized log weights and ``k_hat`` of raw log ratios (last axis).

    ``arviz_stats``' ``psislw`` takes log-likelihood values (its ratios are their negatives), so
    it gets ``-log_ratios``, shifted to a maximum of 0.
    """
    r = np.asarray(log_ratios, float)
    r = r - np.max(r, axis=-1, keepdims=True)
    # imported here: arviz_stats takes ~0.9 s to import, which the commands that
    # never weigh draws (simulate, curves, validate) do without
    from arviz_stats.base import array_stats

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
        ll, lp0 = log_lik_and_prior(model, u, settings.batch, getattr(settings, "workers", 1))
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
              "n_draws": int(u.shape[0]), **importance_log_evidence(raw)}
    ok, reasons = judge("importance", record, settings)
    keep = w > 0
    return Posterior(model=model, u=u[keep], log_w=log_w[keep], log_lik=ll[keep],
                     engine="importance", converged=ok, reasons=reasons, diagnostics=record,
                     u_map=np.asarray(u_map), cov=np.asarray(cov), lp=lp[keep])


def importance_log_evidence(log_ratios):
    """The log marginal likelihood ``ln Z`` estimated from raw importance log ratios
    ``ln p(y|u) p(u) - ln q(u)`` (non-finite: weight 0) and its standard error.

    ``Z`` is the mean of the raw weights (unbiased, also for the deterministic mixture of
    several proposals: Owen & Zhou, JASA 95, 135, 2000); the error is the delta method's
    ``sd(w) / (mean(w) sqrt(S))``, trustworthy where the weights' Pareto ``k_hat`` is at most
    :data:`K_MAX` (docs/statistics.md, "Naming a cause the generic description also fits").

    Returns
    -------
    dict
        ``log_evidence`` and ``log_evidence_se`` (natural log; the model's log prior is a
        normalized density of the sampler coordinates, so ``Z`` is the model's evidence).
    """
    r = np.asarray(log_ratios, float)
    r = np.where(np.isfinite(r), r, -np.inf)
    top = np.max(r)
    w = np.exp(r - top)
    mean = np.mean(w)
    se = float(np.std(w, ddof=1) / (mean * np.sqrt(w.size)))
    return {"log_evidence": float(top + np.log(mean)), "log_evidence_se": se}


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
