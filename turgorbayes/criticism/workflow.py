r"""The criticism workflow: fit the baseline, check it, fit every effect, compare, select.

:func:`criticize` runs the whole workflow on one data set (``turgorbayes criticize``) and
returns a :class:`CriticismResult`; :func:`criticism_dict` is the content of
``criticism.json`` (keys :data:`CRITICISM_KEYS`). The workflow is described in
``docs/effects.md``.
"""

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from turgorbayes import effects, results
from turgorbayes.criticism import checks as checks_module
from turgorbayes.criticism import stacking
from turgorbayes.criticism.loo import compare, exact_loo
from turgorbayes.criticism.posterior import _batched, _rng, fit_posterior
from turgorbayes.criticism.selection import DELTA_ELPD_MIN, P_GAIN_MIN, cause_sentence, select
from turgorbayes.effects import outliers
from turgorbayes.inference import models, start_check, table_check

__all__ = [
    "CRITICISM_KEYS",
    "CriticismResult",
    "CriticismSettings",
    "criticism_dict",
    "criticize",
    "flag_cells",
    "predictive_checks",
]

#: criticism.json: top-level keys and the sub-keys of the nested entries.
CRITICISM_KEYS = {
    "misfit_detected": None,
    "checks": ("name", "statistic", "p_value", "flagged"),
    "candidates": ("effect", "delta_elpd", "delta_se", "estimate", "convergence"),
    "selected_effect": None,
    "cause": None,
    "gain": ("delta_elpd", "se"),
    "parameters": ("baseline", "extended"),
    "baseline_convergence": ("engine", "converged", "reasons", "attempts", "laplace"),
    "flagged_cells": ("cell_id", "quantity", "score", "reason"),
    "fe_table": ("fraction_of_draws", "cells", "boxes", "domain", "approximate"),
}


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
    flag_draws : int
        Posterior draws of the adopted model at which the readings are screened for gross
        errors (:func:`flag_cells`).
    retry_factor : float
        Effort of the re-runs of an unconverged posterior: importance sampling with this many
        times the draws (when only its ESS fell short), emcee with this many times
        ``mcmc.max_steps`` (docs/statistics.md, "Posterior engines of the criticism").
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
    retry_factor: float = 3.0
    flag_draws: int = outliers.FLAG_DRAWS

    def __post_init__(self):
        if self.engine not in ("importance", "emcee"):
            raise ValueError(f"engine must be 'importance' or 'emcee', got {self.engine!r}")
        for name in ("n_draws", "batch", "n_rep", "flag_draws"):
            if int(getattr(self, name)) < 2:
                raise ValueError(f"{name} must be an integer >= 2, got {getattr(self, name)!r}")
        if self.max_refits < 0:
            raise ValueError(f"max_refits must be >= 0, got {self.max_refits!r}")
        if not self.retry_factor >= 1:
            raise ValueError(f"retry_factor must be >= 1 (re-runs use more effort, not less), "
                             f"got {self.retry_factor!r}")


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
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = checks_module.run_checks(y, sigma, y_rep, mu, group, log_p, post.log_lik[idx])
    return out, {"y": y, "sigma": sigma, "y_rep": y_rep, "mu": mu, "log_pressure": log_p,
                 "group": group}


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
    flagged_cells: list = field(default_factory=list)  # flag_cells
    #: :func:`turgorbayes.inference.table_check.check_draws` of the adopted model
    fe_table: dict = None


def _estimate(summary, model):
    """``{key: {mean, q05, q95}}`` of an effect's own parameters."""
    keys = [p.key for p in model.parameters[4:]]
    return {k: {f: summary[k][f] for f in ("mean", "q05", "q95")} for k in keys}


def _fit(cells, surrogate, names, guess, seed, settings):
    model = effects.ExtendedModel(cells, surrogate, names)
    u0 = model.to_u(model.start_values(guess))[0]
    if not np.isfinite(model.log_posterior(u0[None])[0]):  # name the cells at fault
        raise start_check.start_error(model, u0)
    post = fit_posterior(model, model.start_values(guess), seed, settings)
    return post, exact_loo(post, cells, surrogate, seed, settings)


def criticize(cells, surrogate, seed=0, settings=None, progress=None):
    """Run the whole criticism workflow on a data set.

    1. Fit the baseline (:class:`turgorbayes.effects.ExtendedModel` without effects) and run
       the predictive checks of :mod:`turgorbayes.criticism.checks` on it.
    2. Fit every effect of :mod:`turgorbayes.effects` as an extension of the baseline and
       compare each with the baseline by leave-one-out (:func:`~turgorbayes.criticism.compare`).
    3. Select by :func:`~turgorbayes.criticism.select`; if an effect is selected, fit it together
       with the runner-up and adopt the pair only if it beats the single effect by the same rule.
    4. Average all fitted models by stacking (:mod:`turgorbayes.criticism.stacking`).

    See ``docs/effects.md``.

    Parameters
    ----------
    cells : turgorbayes.io.CellData
        Bulged and intact cells.
    surrogate : turgorbayes.surrogate.Surrogate
    seed : int
        Seed of every random draw.
    settings : CriticismSettings, optional
    progress : callable, optional
        ``progress(message)`` when a candidate's fit starts and after each step.

    Returns
    -------
    CriticismResult
    """
    t0 = time.perf_counter()
    settings = CriticismSettings() if settings is None else settings
    say = progress or (lambda msg: None)
    cells.require_both_groups()
    names = list(settings.effects) if settings.effects is not None else effects.effect_names()
    skipped = {n: effects.get_effect(n).not_applicable_reason(cells) for n in names}
    skipped = {n: why for n, why in skipped.items() if why}
    if settings.effects is not None and skipped:  # asked for by name: say why not
        effects.get_effect(next(iter(skipped))).bind(cells)
    names = [n for n in names if n not in skipped]
    for name, why in skipped.items():
        say(f"not a candidate for these data: {name} ({why})")
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
        say(f"candidate {i + 1}/{len(names)}: {name} ...")
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
        say(f"pair: {name} (the selected effect with the runner-up) ...")
        guess = {k: float(v[0]) for k, v in
                 posts[best["effect"]].model.to_physical(posts[best["effect"]].u_map[None]).items()}
        guess.update({k: float(v[0]) for k, v in posts[runner["effect"]].model.to_physical(
            posts[runner["effect"]].u_map[None]).items() if k not in guess})
        posts[name], loos[name] = _fit(cells, surrogate, pair, guess, seed + 9973, settings)
        cand = _candidate(name, posts[name], loos[name], loos["baseline"], seed)
        candidates.append(cand)
        d, se, p = compare(loos[name], loos[best["effect"]], seed)
        cand["vs_selected"] = {"delta_elpd": d, "se": se, "p_gain": p}
        if posts[name].converged and d > DELTA_ELPD_MIN and p >= P_GAIN_MIN:
            selected = name
        say(f"{name}: delta elpd vs {best['effect']} {d:.1f} +- {se:.1f}")
    if selected:
        chk[selected], arrays[selected] = predictive_checks(posts[selected], seed, settings)
    gain = compare(loos[selected], loos["baseline"], seed) if selected else (0.0, 0.0, 0.0)
    summaries = {name: posts[name].summary(_rng(seed, 13)) for name in posts}
    usable = [n for n in posts if n == "baseline" or posts[n].converged]
    stacked = stacking.stack({n: posts[n] for n in usable}, {n: loos[n] for n in usable},
                             _rng(seed, 14))
    say("model average (stacking): " + ", ".join(f"{n} {w:.2f}" for n, w in
                                                 stacked["weights"].items() if w >= 0.005))
    flagged = flag_cells(posts, selected, cells, seed, settings.flag_draws)
    say(f"readings that look like gross errors: {len(flagged)}"
        + "".join(f"; {f['cell_id']} {f['quantity']} ({f['score']:.2f})" for f in flagged))
    fe_table = check_table(posts, selected, cells, surrogate, seed)
    return CriticismResult(cells=cells, seed=seed, settings=settings, posteriors=posts, loo=loos,
                           checks=chk, check_arrays=arrays, candidates=candidates,
                           selected=selected, runner_up=runner["effect"] if runner else None,
                           gain=gain, summaries=summaries, timing_s=time.perf_counter() - t0,
                           stacking=stacked, flagged_cells=flagged, fe_table=fe_table)


def flag_cells(posts, selected, cells, seed, n_draws=outliers.FLAG_DRAWS):
    """Readings that look like gross errors (:func:`turgorbayes.effects.outliers.flagged_cells`)
    under the adopted model (``selected``; the baseline if None) at ``n_draws``
    posterior draws: with its fitted fraction of gross errors if it has the ``outliers``
    effect, else with 1 % of readings assumed to be gross errors. Screening the adopted model,
    not the baseline, keeps a population effect (e.g. cells that differ in width) from being
    reported as many gross errors."""
    post, v = _adopted_draws(posts, selected, n_draws, _rng(seed, 15))
    return outliers.flagged_cells(post.model, v, cells.cell_id)


def check_table(posts, selected, cells, surrogate, seed):
    """Where the adopted model (``selected``; the baseline if None) asks the FE table for a
    stiffness it does not have (:func:`turgorbayes.inference.table_check.check_draws`, at
    :data:`~turgorbayes.inference.table_check.MAX_DRAWS` posterior draws)."""
    _, v = _adopted_draws(posts, selected, table_check.MAX_DRAWS, _rng(seed, 16))
    return table_check.check_draws(v, cells, surrogate, selected or "baseline")


def _adopted_draws(posts, selected, n, rng):
    """The adopted posterior (``selected``; the baseline if None) and ``n`` of its draws
    resampled by ``rng``, in physical units (dict of ``(n,)`` arrays)."""
    post = posts[selected or "baseline"]
    return post, post.model.to_physical(post.u[post.resample(n, rng)])


def _status(post, loo):
    conv = "converged" if post.converged else "NOT converged (" + "; ".join(post.reasons) + ")"
    if post.attempts:
        conv += f" after {len(post.attempts)} unconverged run(s)"
    return (f"{post.engine}, {conv}, elpd {loo['elpd']:.1f}, {loo['n_bad']} cells with high "
            f"Pareto k ({len(loo['refitted'])} refitted exactly)")


def _candidate(name, post, loo, loo_base, seed):
    d, se, p = compare(loo, loo_base, seed)
    return {"effect": name, "delta_elpd": d, "delta_se": se, "p_gain": p,
            "estimate": _estimate(post.summary(_rng(seed, 13)), post.model),
            "converged": bool(post.converged), "convergence": post.convergence()}


def criticism_dict(result):
    """The ``criticism.json`` content (keys exactly :data:`CRITICISM_KEYS`).

    ``misfit_detected`` is true when any baseline check is flagged or an extension is selected
    (either is evidence against the baseline); ``checks`` are the baseline's; ``candidates``
    the single effects and, if one was selected, its pair with the runner-up; ``gain`` is the
    adopted model's over the baseline (0 and 0 when nothing is adopted, and then
    ``parameters.extended`` is null); parameter entries have the fields of ``summary.json``
    (for importance sampling ``r_hat`` is null and both ESS are the weights' ESS). Each
    candidate's ``convergence`` and ``baseline_convergence`` are
    :meth:`~turgorbayes.criticism.Posterior.convergence` (engine, converged, reasons, the
    unconverged attempts before, the mode search and Hessian clipping); an unconverged
    candidate is never selected.
    """
    flagged = any(c["flagged"] for c in result.checks["baseline"])
    candidates = [_jsonable({k: c[k] for k in CRITICISM_KEYS["candidates"]})
                  for c in result.candidates]
    return {
        "misfit_detected": bool(flagged or result.selected is not None),
        "checks": [{k: c[k] for k in CRITICISM_KEYS["checks"]} for c in result.checks["baseline"]],
        "candidates": candidates,
        "selected_effect": result.selected,
        "cause": cause_sentence(result),
        "gain": {"delta_elpd": float(result.gain[0]), "se": float(result.gain[1])},
        "parameters": {"baseline": result.summaries["baseline"],
                       "extended": result.summaries[result.selected] if result.selected else None},
        "baseline_convergence": _jsonable(result.posteriors["baseline"].convergence()),
        "flagged_cells": list(result.flagged_cells),
        "fe_table": _jsonable(result.fe_table),
    }


def _jsonable(x):
    """Numpy scalars and arrays in nested dicts and lists as Python numbers and lists."""
    if isinstance(x, dict):
        return {k: _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    return x
