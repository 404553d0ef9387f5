"""Simulation-based calibration of the fit (Talts et al., arXiv:1804.06788, 2018).

Draw parameters from a prior, simulate a data set at them, fit it with *the same* prior, and
record the rank of each true parameter among the posterior draws. If the simulator, the
likelihood and the posterior engine agree, every rank is uniform on ``0..L`` (``L`` draws);
a bias piles the ranks at one end, intervals that are too narrow pile them at both ends, too
wide in the middle (docs/validation.md, "Simulation-based calibration").

The baseline's own priors are flat over ranges far wider than any data set constrains, and most
of that range is outside the FE table, so the calibration uses :data:`SBC_PRIORS`: informative
priors around the paper's values, a few posterior sds wide at the paper's size, under which
the fit is run too (the model's priors are replaced, as SBC requires). Measurement-error sizes
are drawn per replication over the ranges labs report (:data:`ERROR_SCALE`).

Posterior engine: the package's one engine (:func:`turgorbayes.inference.engine.fit_posterior`,
from one Laplace fit per replication), so the calibration checks the posterior fit and
criticism use. ``engine="laplace"``: ``L`` draws from ``N(mode, cov)`` in the sampler
coordinates, cheap enough for hundreds of replications; ``"importance"``: the criticism's
posterior (Pareto-smoothed importance sampling checked by its k and ESS, emcee where that
fails) with ``L`` draws resampled by weight, the exact posterior where it converges, at a few
seconds per replication; ``"mcmc"``: the fit's emcee, ``L`` draws evenly spaced. A replication
whose posterior does not converge (the engine's rule) is left out and named.

Models: the baseline, or the baseline plus effects (``sbc_model(effects=["radius_spread"])``):
each replication then draws the effects' parameters from their own priors too, and simulates
the data with each effect at its drawn size.
"""

from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from turgorbayes.effects import ExtendedModel, get_effect
from turgorbayes.inference import engine as posterior_engine
from turgorbayes.inference import models, priors
from turgorbayes.inference.engine import weighted_stats
from turgorbayes.inference.mode import laplace_fit
from turgorbayes.physics.parameters import BASELINE, P0, PUBLISHED
from turgorbayes.simulation.cells import ErrorModel, Truth, simulate_cells

__all__ = ["ENGINES", "ERROR_SCALE", "SBC_PRIORS", "SBCResult", "rank_uniformity", "run_sbc", "sbc_model",
           "truth_summary"]

#: Priors of the calibration (sampler coordinates: gamma linear, the others logarithmic):
#: centred on the paper's values, 2-3 posterior sds of the paper's data set wide.
SBC_PRIORS = {
    "gamma": priors.Normal(PUBLISHED["gamma"], 0.08),
    "E0t": priors.LogNormal(PUBLISHED["E0t"], 0.06),
    "R0": priors.LogNormal(PUBLISHED["R0"], 0.01),
    "P_phys": priors.LogNormal(PUBLISHED["P_phys"], 0.06),
}
#: Each replication multiplies the simulator's default error sizes (docs/validation.md,
#: "Simulated data") by one factor drawn uniformly from this range: labs report stiffness
#: errors of 5-20 %, radius errors of 10-40 nm.
ERROR_SCALE = (0.6, 1.5)


def sbc_model(base=models.BaselineModel, prior=None, effects=None):
    """``base`` with its parameters' priors replaced by ``prior`` (default :data:`SBC_PRIORS`).

    With ``effects`` (names; an empty sequence for the baseline itself) the class is an
    :class:`turgorbayes.effects.ExtendedModel` with those effects, the extra parameters keeping
    their own priors unless ``prior`` names them; ``effect_names`` records them.
    """
    prior = SBC_PRIORS if prior is None else prior

    def replaced(parameters):
        return tuple(replace(p, prior=prior.get(p.name, p.prior)) for p in parameters)

    if effects is None:
        return type(f"SBC{base.__name__}", (base,), {"parameters": replaced(base.parameters)})
    names = tuple(effects)

    def __init__(self, cells, surrogate, **kwargs):
        ExtendedModel.__init__(self, cells, surrogate, names, **kwargs)
        self.parameters = replaced(self.parameters)

    extra = tuple(q for n in names for q in get_effect(n).parameters)
    return type("SBCExtendedModel", (ExtendedModel,),
                {"__init__": __init__, "effect_names": names,
                 "parameters": replaced(models.BASELINE_PARAMETERS + extra)})


@dataclass(frozen=True)
class SBCResult:
    """Ranks of the truths among ``n_draws`` posterior draws, one row per replication.

    Attributes
    ----------
    names : tuple of str
    ranks : ndarray of int (n_replications, n_parameters)
        In ``0..n_draws``.
    n_draws : int
    z : ndarray (n_replications, n_parameters)
        ``(mode - truth)/sd`` in the sampler coordinates.
    seeds : ndarray of int
        The replications kept.
    unconverged : tuple of int
        Seeds of replications left out because their posterior did not converge (the engine's
        rule); reported, so that a calibration that drops many is not read as clean.
    """

    names: tuple
    ranks: np.ndarray
    n_draws: int
    z: np.ndarray
    seeds: np.ndarray
    unconverged: tuple = ()

    def p_values(self, n_bins=None):
        """Chi-square uniformity p-value of the ranks, per parameter (:func:`rank_uniformity`)."""
        return rank_uniformity(self.ranks, self.n_draws, n_bins)


def rank_uniformity(ranks, n_draws, n_bins=None):
    """Chi-square test that ranks in ``0..n_draws`` are uniform, per column.

    ``n_bins`` (default: about one bin per 5 expected ranks, at most 20) must divide
    ``n_draws + 1`` for equal-probability bins.
    """
    ranks = np.atleast_2d(np.asarray(ranks, int))
    n = ranks.shape[0]
    if n_bins is None:
        n_bins = max(d for d in range(2, 21) if (n_draws + 1) % d == 0 and n / d >= 5)
    if (n_draws + 1) % n_bins:
        raise ValueError(f"n_bins = {n_bins} must divide n_draws + 1 = {n_draws + 1}")
    counts = np.stack([np.bincount(r * n_bins // (n_draws + 1), minlength=n_bins)
                       for r in ranks.T])
    return stats.chisquare(counts, axis=1).pvalue


#: The posterior engines of :func:`run_sbc`.
ENGINES = ("laplace", "importance", "mcmc")


#: :func:`run_sbc`'s engine names -> the engine's.
_ENGINE = {"laplace": "laplace", "importance": "importance", "mcmc": "emcee"}


def _posterior_draws(model, lap, n_draws, engine, seed, rng):
    """``n_draws`` draws in the sampler coordinates from the one engine
    (:func:`turgorbayes.inference.engine.fit_posterior` from the Laplace fit ``lap``):
    resampled by weight (importance) or evenly spaced (emcee; Laplace draws are ``n_draws``
    already), with the mode and covariance the engine ends at; None if it did not converge."""
    settings = posterior_engine.Settings(
        engine=_ENGINE[engine], progress=False,
        n_draws=n_draws if engine == "laplace" else posterior_engine.Settings.n_draws)
    post = posterior_engine.fit_posterior(model, None, seed, settings, laplace=lap,
                                          pointwise=False)
    if not post.converged:
        return None
    if post.engine == "importance":
        idx = post.resample(n_draws, rng)
    else:
        idx = np.linspace(0, len(post.u) - 1, n_draws).round().astype(int)
    return post.u[idx], post.u_map, post.cov


def _replication(model_cls, seed, table, n_cells, n_draws, simulate_kwargs, engine="laplace"):
    rng = np.random.default_rng(seed)
    names = [p.name for p in model_cls.parameters]
    truth_u = np.array([p.prior.to_u(p.prior.sample(rng)) for p in model_cls.parameters])
    values = {n: float(p.prior.to_physical(u)) for n, p, u in
              zip(names, model_cls.parameters, truth_u, strict=True)}
    scale = rng.uniform(*ERROR_SCALE)
    e = ErrorModel()
    errors = replace(e, **{k: tuple(scale * v for v in getattr(e, k))
                           for k in ("R_c_sd", "k_c_rel_sd", "k_b_log_sd", "R_b_log_sd")})
    truth = Truth(P0=P0, **{k: values[k] for k in ("gamma", "E0t", "R0", "P_phys")})
    kwargs = dict(simulate_kwargs or {})
    kwargs["effects"] = list(kwargs.get("effects", ())) + [
        get_effect(n).injection(values[get_effect(n).size_parameter])
        for n in model_cls.effect_names]
    cells, _ = simulate_cells(*n_cells, truth=truth, seed=seed, errors=errors,
                                        surrogate=table, **kwargs)
    model = model_cls(cells, table)
    guess = models.PaperWLS(cells, table).fit().estimate
    lap = laplace_fit(model, model.to_u({k: guess.get(k, values[k]) for k in model.names})[0])
    out = _posterior_draws(model, lap, n_draws, engine, seed, rng)
    if out is None:
        return None
    draws, u_map, cov = out
    ranks = np.sum(draws < truth_u, axis=0)
    return ranks, (u_map - truth_u) / np.sqrt(np.diag(cov))


def run_sbc(table, n_replications, first_seed=0, n_cells=(72, 42), n_draws=99,
            model_cls=None, simulate_kwargs=None, progress=None, engine="laplace"):
    """Run the calibration (module docstring).

    Parameters
    ----------
    table : turgorbayes.surrogate.Surrogate
    n_replications : int
    first_seed : int
        Replication ``i`` uses seed ``first_seed + i`` for its truth, errors, data and draws.
    n_cells : (int, int)
        Bulged and intact cells per data set.
    n_draws : int
        Posterior draws per replication (ranks in ``0..n_draws``).
    model_cls : type, optional
        A model class with the SBC priors (default ``sbc_model()``).
    simulate_kwargs : dict, optional
        Passed to :func:`turgorbayes.simulation.cells.simulate_cells` (e.g. ``effects``: data from
        another model, to show that the calibration detects it).
    progress : callable, optional
        Wraps the replication range (e.g. :func:`turgorbayes.progress.progress`).
    engine : str
        ``"laplace"`` (mode and inverse Hessian), ``"importance"`` (the criticism's posterior,
        resampled) or ``"mcmc"`` (the fit's emcee: 4 ensembles of 16 walkers run to
        convergence, started from the Laplace fit); all from
        :func:`turgorbayes.inference.engine.fit_posterior`. A replication whose posterior does
        not converge is left out and named in ``unconverged``.

    Returns
    -------
    SBCResult
    """
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
    model_cls = sbc_model() if model_cls is None else model_cls
    seeds = np.arange(first_seed, first_seed + n_replications)
    loop = progress(seeds) if progress else seeds
    out = {int(s): _replication(model_cls, int(s), table, n_cells, n_draws, simulate_kwargs,
                                engine) for s in loop}
    kept = [s for s, o in out.items() if o is not None]
    return SBCResult(names=tuple(p.name for p in model_cls.parameters),
                     ranks=np.array([out[s][0] for s in kept]), n_draws=n_draws,
                     z=np.array([out[s][1] for s in kept]), seeds=np.array(kept),
                     unconverged=tuple(s for s, o in out.items() if o is None))


def truth_summary(model, post, truth, params=BASELINE):
    """A weighted posterior against the truth that simulated its data.

    Parameters
    ----------
    model : BaselineModel
        The model ``post`` samples (maps its draws to physical values).
    post : Posterior
        Draws ``u`` with ``weights`` and a ``converged`` flag
        (:func:`turgorbayes.inference.engine.fit_posterior`).
    truth : Truth
        The simulator's parameter values (attributes named as ``params``).
    params : tuple of str

    Returns
    -------
    dict
        ``converged``, and per parameter ``cover90`` (truth strictly inside the central 90 %
        interval), ``z`` (``(mean - truth) / sd``) and ``sd``.
    """
    phys = model.to_physical(post.u)
    out = {"converged": bool(post.converged)}
    for p in params:
        t, st = getattr(truth, p), weighted_stats(phys[p], post.weights)
        out[p] = {"cover90": bool(st["q05"] < t < st["q95"]),
                  "z": float((st["mean"] - t) / st["sd"]), "sd": st["sd"]}
    return out
