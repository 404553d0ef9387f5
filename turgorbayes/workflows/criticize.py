r"""The criticism workflow: fit the baseline, check it, fit every effect, compare, select.

:func:`criticize` runs the whole workflow on one data set (``turgorbayes criticize``) and
returns a :class:`CriticismResult`; :func:`criticism_dict` is the content of
``criticism.json`` (keys :data:`CRITICISM_KEYS`). The workflow is described in
``docs/effects.md``.
"""

import hashlib
import json
import time
import warnings
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from turgorbayes import effects
from turgorbayes.cache import MISSING
from turgorbayes.cache import key as cache_key
from turgorbayes.cells.medium import MEDIUM_COLUMN, medium_levels
from turgorbayes.cells.order import measurement_order
from turgorbayes.criticism import checks as checks_module
from turgorbayes.criticism import misfit_band, stacking
from turgorbayes.criticism import verdict as verdict_module
from turgorbayes.criticism.loo import compare, exact_loo
from turgorbayes.criticism.selection import DELTA_ELPD_MIN, P_GAIN_MIN, select
from turgorbayes.effects import outliers
from turgorbayes.effects.conditions import (
    ConditionsExtendedModel,
    conditions_reason,
    has_conditions,
    own_walls,
)
from turgorbayes.effects.series import SeriesModel
from turgorbayes.errors import DataError
from turgorbayes.inference import start_check, table_check
from turgorbayes.inference.conditions import CONDITION_COLUMN, condition_set
from turgorbayes.inference.engine import Settings, batched, fit_posterior, stream_rng, stream_seed
from turgorbayes.parallel import ordered_imap
from turgorbayes.workflows.flags import flag_cells

__all__ = [
    "CRITICISM_KEYS",
    "CriticismResult",
    "CriticismSettings",
    "candidate_key",
    "candidate_seed",
    "check_criticism_data",
    "conditions_design",
    "criticism_dict",
    "criticism_model",
    "criticize",
    "data_digest",
    "failed_candidate",
    "is_series",
    "jsonable",
    "model_class",
    "predictive_checks",
]

#: What a candidate's fit may raise without ending the criticism: numerical failures (an
#: overflow, a singular matrix, a mode search or sampler that gives up). The candidate is
#: recorded with the reason (:func:`failed_candidate`) and left out of the comparison; a
#: programming error (TypeError, KeyError, ...) still ends the run.
NUMERICAL_FAILURES = (ArithmeticError, ValueError, np.linalg.LinAlgError, RuntimeError)

#: criticism.json: top-level keys and the sub-keys of the nested entries.
CRITICISM_KEYS = {
    "misfit_detected": None,
    "checks": ("name", "statistic", "p_value", "flagged"),
    "candidates": ("effect", "delta_elpd", "delta_se", "estimate", "convergence", "failed"),
    "selected_effect": None,
    "cause": None,
    "gain": ("delta_elpd", "se"),
    "parameters": ("baseline", "extended", "model_average", "widened"),
    "baseline_convergence": ("engine", "converged", "reasons", "attempts", "laplace"),
    "flagged_cells": ("cell_id", "quantity", "score", "reason"),
    "fe_table": ("fraction_of_draws", "cells", "boxes", "domain", "approximate"),
    "verdict": ("status", "selected", "remaining_checks", "text", "conditions"),
    "headline": None,
    "misfit_band": ("applied", "scales", "shifts", "sd"),
}


@dataclass
class CriticismSettings(Settings):
    """The settings of :func:`criticize`: the posterior engine's
    (:class:`turgorbayes.inference.engine.Settings`, with the criticism's defaults: engine
    ``"importance"``, emcee where it is unreliable, no progress bar) and the criticism's own.
    Tests use fewer draws.

    Attributes
    ----------
    n_rep : int
        Posterior draws of the predictive checks (>= 2/alpha resolves the threshold).
    max_refits : int
        Exact leave-one-out refits per model for cells with a large Pareto k.
    effects : tuple of str or None
        The candidate effects (None: every registered one that applies).
    flag_draws : int
        Draws of the adopted model screened for gross errors.
    per_condition : tuple of str
        Several conditions: the wall quantities freed per condition in every model
        (``"E0t"``, ``"E0t:NAME"``, as ``fit --per-condition``); empty: the wall shared.
    workers : int
        Processes that fit the candidates (:func:`turgorbayes.parallel.ordered_imap`); the
        criticism is the same whatever their number (each candidate's draws are keyed by its
        name).
    scheduler : str or None
        A Dask scheduler's address (or ``"local"``) to fit the candidates on instead.
    """

    engine: str = "importance"
    progress: bool = False
    n_rep: int = 1000
    max_refits: int = 10
    effects: tuple = None
    flag_draws: int = outliers.FLAG_DRAWS
    per_condition: tuple = ()
    workers: int = 1
    scheduler: str = None

    def __post_init__(self):
        if self.engine not in ("importance", "emcee"):  # needs a convergence check
            raise ValueError(f"engine must be 'importance' or 'emcee', got {self.engine!r}")
        super().__post_init__()
        for name in ("n_rep", "flag_draws"):
            if int(getattr(self, name)) < 2:
                raise ValueError(f"{name} must be an integer >= 2, got {getattr(self, name)!r}")
        if self.max_refits < 0:
            raise ValueError(f"max_refits must be >= 0, got {self.max_refits!r}")


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
    rng = stream_rng(seed, 11)
    idx = post.resample(settings.n_rep, rng)
    u = post.u[idx]
    y_rep = batched(lambda x: model.posterior_predictive(x, rng), u, 256)
    mu = batched(model.predicted_means, u, 256)
    obs = model.obs
    conditions = model.conditions
    y = {"R_c": obs.R_c, "k_c": obs.k_c}
    sigma = {"R_c": obs.R_c_err, "k_c": obs.k_c_err}
    group = np.where(obs.is_bulged, "bulged", "intact")
    levels = model.intact_levels()  # an osmotic series: the checks act within its levels
    stratum = None
    if levels is not None:
        stratum = np.zeros(obs.n_cells, int)
        stratum[obs.intact] = levels
    log_p = model.log_pressure_centre(model.to_physical(u))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = checks_module.run_checks(
            y, sigma, y_rep, mu, group, log_p, post.log_lik[idx],
            condition=None if conditions is None else conditions.index,
            order=measurement_order(model.cells)[0], stratum=stratum)
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
    flagged_cells: list = field(default_factory=list)  # _flag_adopted
    #: :func:`turgorbayes.inference.table_check.check_draws` of the adopted model
    fe_table: dict = None
    #: :func:`turgorbayes.criticism.verdict.verdict`: status, selected, remaining checks, text
    verdict: dict = None
    #: :func:`_misfit_band`: the headline's band when the misfit is not (fully) explained
    misfit_band: dict = None


def _estimate(summary, model):
    """``{key: {mean, q05, q95}}`` of an effect's own parameters."""
    keys = [p.key for e in model.effects for p in e.parameters]
    return {k: {f: summary[k][f] for f in ("mean", "q05", "q95")} for k in keys}


def model_class(cells):
    """The criticism's model of ``cells``: :class:`turgorbayes.effects.ExtendedModel`, or
    with several conditions :class:`turgorbayes.effects.conditions.ConditionsExtendedModel`
    (the wall shared, ``P_phys`` and ``R0`` per condition, effects within conditions), or for
    an osmotic series :class:`turgorbayes.effects.series.SeriesModel` (each intact cell at its
    medium level's turgor, effects within levels)."""
    if is_series(cells):
        return SeriesModel
    return ConditionsExtendedModel if has_conditions(cells) else effects.ExtendedModel


def is_series(cells):
    """Whether ``cells`` are an osmotic series: intact cells in media of two or more
    osmolarities (the ``medium_mOsm`` column)."""
    return medium_levels(cells).size > 1


def check_criticism_data(cells):
    """Refuse data the criticism cannot model, before anything is computed: one medium needs
    both groups of cells; an osmotic series needs intact cells (bulged ones optional) and no
    ``condition`` column with two or more conditions (a series per condition is not modelled).

    Raises
    ------
    DataError
    """
    if not is_series(cells):
        cells.require_both_groups()
        return cells
    if has_conditions(cells):
        raise DataError("an osmotic series with several conditions is not supported by "
                        "criticize: its models put every intact cell at its medium level's "
                        "turgor from one P_phys; criticize each condition's series on its own",
                        path=cells.path, column=CONDITION_COLUMN)
    return cells


def criticism_model(cells, surrogate, names, settings=None):
    """The criticism's model of ``cells`` with the effects ``names``: :func:`model_class`,
    with several conditions on the design of ``settings.per_condition`` (the wall quantities
    freed per condition; :func:`conditions_design`)."""
    cls = model_class(cells)
    if cls is ConditionsExtendedModel:
        return cls(cells, surrogate, names, conditions=conditions_design(cells, settings))
    return cls(cells, surrogate, names)


def conditions_design(cells, settings=None):
    """The :class:`~turgorbayes.inference.conditions.ConditionSet` of the criticism's models
    (reference: the first condition) with ``settings.per_condition`` freed, checked as
    ``fit --per-condition`` is (a condition without bulged cells is refused), or None for one
    condition (then ``per_condition`` is refused).

    Raises
    ------
    DataError
        ``per_condition`` without several conditions, or refused for these data.
    """
    per_condition = tuple(settings.per_condition or ())
    if not has_conditions(cells):
        if per_condition:
            raise DataError("--per-condition needs a condition column naming two or more "
                            "conditions (docs/data_format.md)", path=cells.path,
                            column=CONDITION_COLUMN)
        return None
    cs = condition_set(cells, None, per_condition)
    try:
        own_walls(cs)
    except ValueError as err:
        raise DataError(str(err), path=cells.path, column=CONDITION_COLUMN) from None
    return cs


def _fit(cells, surrogate, names, guess, seed, settings):
    """The posterior of the model with effects ``names`` and its exact LOO, both from ``seed``
    (the model's own: the baseline's is the workflow's, a candidate's a stream of it keyed by
    its name, :func:`candidate_seed`)."""
    model = criticism_model(cells, surrogate, names, settings)
    u0 = model.to_u(model.start_values(guess))[0]
    if not np.isfinite(model.log_posterior(u0[None])[0]):  # name the cells at fault
        raise start_check.start_error(model, u0)
    post = fit_posterior(model, model.start_values(guess), seed, settings)
    return post, exact_loo(post, cells, surrogate, seed, settings)


def _fit_candidate(job):
    """One candidate's fit and exact LOO (a worker's task): ``(name, posterior, loo, error,
    seconds)``, the error (one of :data:`NUMERICAL_FAILURES`) instead of the fit when it
    failed."""
    cells, surrogate, name, guess, seed, settings = job
    t = time.perf_counter()
    try:
        post, loo = _fit(cells, surrogate, [name], guess, candidate_seed(seed, [name]), settings)
    except NUMERICAL_FAILURES as err:
        return name, None, None, err, time.perf_counter() - t
    return name, post, loo, None, time.perf_counter() - t


def _fitted_candidates(cells, surrogate, names, guess, seed, settings, say, cache=None):
    """``(name, posterior, loo, error, seconds)`` of each candidate in ``names``, in order
    (:func:`_fit_candidate`): those ``cache`` holds (:func:`candidate_key`) taken from it
    (``seconds`` the original fit's), the others fitted on ``settings.workers`` processes (or
    its Dask scheduler) and stored in it as each is done."""
    keys = {n: candidate_key(cells, surrogate, n, guess, seed, settings) for n in names
            } if cache is not None else {}
    keys = {n: k for n, k in keys.items() if k is not None}
    stored = {n: cache.get(k) for n, k in keys.items()}
    todo = [n for n in names if stored.get(n, MISSING) is MISSING]
    if stored and len(todo) < len(names):
        say(f"{len(names) - len(todo)} of {len(names)} candidates from the cache {cache.folder}")
    if todo and (settings.workers > 1 or settings.scheduler is not None):
        say(f"fitting the {len(todo)} candidates on "
            + (f"the Dask cluster {settings.scheduler}" if settings.scheduler
               else f"{settings.workers} processes") + " ...")
    jobs = [(cells, surrogate, name, guess, seed, settings) for name in todo]
    fitted = ordered_imap(_fit_candidate, jobs, settings.workers, settings.scheduler)
    for name in names:
        if stored.get(name, MISSING) is not MISSING:
            yield _restored(stored[name], cells, surrogate, settings)
            continue
        entry = next(fitted)
        if name in keys:
            cache.put(keys[name], _storable(entry))
        yield entry


def _storable(entry):
    """A candidate's ``(name, posterior, loo, error, seconds)`` without its posterior's model
    (rebuilt from the data and the name: :func:`_restored`)."""
    name, post, loo, err, seconds = entry
    return name, None if post is None else replace(post, model=None), loo, err, seconds


def _restored(entry, cells, surrogate, settings):
    """:func:`_storable`'s entry with its posterior's model rebuilt (:func:`criticism_model`)."""
    name, post, loo, err, seconds = entry
    if post is not None:
        post = replace(post, model=criticism_model(cells, surrogate, [name], settings))
    return name, post, loo, err, seconds


#: The fields of :class:`CriticismSettings` that do not change a candidate's fit (left out
#: of :func:`candidate_key`).
NOT_IN_FIT = ("workers", "scheduler", "progress", "effects", "n_rep", "flag_draws")


def candidate_key(cells, surrogate, name, guess, seed, settings):
    """The cache key of a candidate's fit (:func:`turgorbayes.cache.key`): the data's content
    (:func:`data_digest`), the surrogate's sha256, the candidate's name, its start (the
    baseline's mode), the seed, the settings that reach its fit (all but :data:`NOT_IN_FIT`)
    and the package version. None (not cached) for a surrogate without a sha256."""
    if surrogate.sha256 is None:
        return None
    fit = {k: v for k, v in asdict(settings).items() if k not in NOT_IN_FIT}
    return cache_key("candidate", data=data_digest(cells), surrogate=surrogate.sha256, name=name,
                     guess=guess, seed=seed, settings=fit)


def data_digest(cells):
    """The sha256 of the cells' content: ids, groups, every number to the bit and the extra
    columns (not their comments, path or file hash: the same data read from another file, or
    simulated, have the same digest)."""
    digest = hashlib.sha256(json.dumps([cells.cell_id, cells.group, dict(cells.extra)]).encode())
    for column in (cells.R_c, cells.R_c_err, cells.k_c, cells.k_c_err, cells.R_b, cells.R_b_err,
                   cells.k_b, cells.k_b_err, cells.h_b):
        digest.update(np.ascontiguousarray(column, dtype="<f8").tobytes())
    return digest.hexdigest()


def candidate_seed(seed, names):
    """The seed of a candidate model's fit and exact LOO: a stream of the workflow's ``seed``
    keyed by the model's effect names (:func:`turgorbayes.inference.engine.stream_seed`; stream
    18 for one effect, 20 for the selected effect with the runner-up, in that order), so that a
    candidate's draws do not depend on which other candidates are fitted, or in which order.
    """
    stream = {1: 18, 2: 20}[len(names)]
    return stream_seed(seed, stream, *names)


def criticize(cells, surrogate, seed=0, settings=None, progress=None, cache=None):
    """Run the whole criticism workflow on a data set.

    1. Fit the baseline (:class:`turgorbayes.effects.ExtendedModel` without effects) and run
       the predictive checks of :mod:`turgorbayes.criticism.checks` on it.
    2. Fit every effect of :mod:`turgorbayes.effects` as an extension of the baseline and
       compare each with the baseline by leave-one-out (:func:`~turgorbayes.criticism.compare`).
    3. Select by :func:`~turgorbayes.criticism.select`; if an effect is selected, fit it together
       with the runner-up and adopt the pair only if it beats the single effect by the same rule.
    4. Average all fitted models by stacking (:mod:`turgorbayes.criticism.stacking`).

    See ``docs/effects.md``. With several conditions (a ``condition`` column) every model is
    the baseline with conditions plus its effects (:func:`model_class`; docs/effects.md,
    "Several conditions"), the checks include ``conditions_R_c_k_c``, and effects that are
    not condition-aware are not candidates
    (:func:`turgorbayes.effects.conditions.conditions_reason`); ``settings.per_condition``
    frees the wall per condition in every model (:func:`conditions_design`), and the verdict
    says whether the check ran and carries the contrasts
    (:func:`turgorbayes.criticism.conditions.conditions_verdict`).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
        Bulged and intact cells.
    surrogate : turgorbayes.surrogate.Surrogate
    seed : int
        Seed of every random draw: the baseline's fit, and each candidate's through a stream
        keyed by its name (:func:`candidate_seed`), not by its place among the candidates.
    settings : CriticismSettings, optional
    progress : callable, optional
        ``progress(message)`` when a candidate's fit starts and after each step.
    cache : turgorbayes.cache.Cache, optional
        Candidates whose fit it holds (:func:`candidate_key`) are not fitted again; every
        candidate fitted is stored in it as soon as it is done (a failed one too). The
        criticism is the same with or without it.

    Returns
    -------
    CriticismResult
    """
    t0 = time.perf_counter()
    settings = CriticismSettings() if settings is None else settings
    say = progress or (lambda msg: None)
    check_criticism_data(cells)
    design = conditions_design(cells, settings)  # a refused --per-condition fails at once
    names = list(settings.effects) if settings.effects is not None else effects.effect_names()
    skipped = {n: effects.get_effect(n).not_applicable_reason(cells)
               or conditions_reason(n, cells, design) for n in names}
    skipped = {n: why for n, why in skipped.items() if why}
    if settings.effects is not None and skipped:  # asked for by name: say why not
        name, why = next(iter(skipped.items()))
        effects.get_effect(name).bind(cells)
        if effects.get_effect(name).series_refusal(cells):
            raise DataError(f"{name} is not a candidate for an osmotic series: {why}",
                            path=cells.path, column=MEDIUM_COLUMN)
        if conditions_reason(name, cells, design):
            raise DataError(f"{name} is not a candidate for data with several conditions: "
                            f"{why}", path=cells.path, column=CONDITION_COLUMN)
    names = [n for n in names if n not in skipped]
    for name, why in skipped.items():
        say(f"not a candidate for these data: {name} ({why})")
    say(f"candidates ({len(names)}): {', '.join(names)}")
    if design is not None and design.freed:
        say("the wall per condition: " + "; ".join(
            f"{q} of {', '.join(n)}" for q, n in design.freed.items()))
    wls = criticism_model(cells, surrogate, [], settings).least_squares().fit()
    posts, loos = {}, {}
    posts["baseline"], loos["baseline"] = _fit(cells, surrogate, [], wls.estimate, seed, settings)
    say(f"baseline: {_status(posts['baseline'], loos['baseline'])}")
    base_map = {k: float(v[0]) for k, v in
                posts["baseline"].model.to_physical(posts["baseline"].u_map[None]).items()}
    chk, arrays = {}, {}
    chk["baseline"], arrays["baseline"] = predictive_checks(posts["baseline"], seed, settings)
    say(f"checks: {sum(c['flagged'] for c in chk['baseline'])} of {len(chk['baseline'])} flagged")
    candidates, summaries = [], {}  # summaries: each model's, computed once (_summary)
    for i, (name, post, loo, err, seconds) in enumerate(
            _fitted_candidates(cells, surrogate, names, base_map, seed, settings, say, cache)):
        say(f"candidate {i + 1}/{len(names)}: {name} ...")
        if err is not None:  # recorded, left out of the comparison
            candidates.append(failed_candidate(name, err))
            say(f"{name}: could not be fitted ({candidates[-1]['failed']}); left out")
            continue
        posts[name], loos[name] = post, loo
        candidates.append(_candidate(name, post, loo, loos["baseline"], seed, summaries))
        say(f"{name}: delta elpd {candidates[-1]['delta_elpd']:.1f} +- "
            f"{candidates[-1]['delta_se']:.1f} (P(gain > 0) = {candidates[-1]['p_gain']:.3f}); "
            f"{_status(post, loo)}; {seconds:.0f} s")
    best, runner, generic = _select_named(candidates)
    selected = best["effect"] if best else None
    if best and runner:
        selected = _fit_pair(cells, surrogate, posts, loos, candidates, best, runner, seed,
                             settings, say, summaries)
    if selected:
        chk[selected], arrays[selected] = predictive_checks(posts[selected], seed, settings)
        if generic is not None and generic["converged"]:
            d, se, p = compare(loos[selected], loos[generic["effect"]], seed)
            generic["vs_selected"] = {"delta_elpd": -d, "se": se, "p_gain": 1.0 - p}
            generic["selected_identified"] = bool(d > DELTA_ELPD_MIN and p >= P_GAIN_MIN)
    gain = compare(loos[selected], loos["baseline"], seed) if selected else (0.0, 0.0, 0.0)
    summaries = {name: _summary(posts[name], name, seed, summaries) for name in posts}
    usable = [n for n in posts if n == "baseline" or posts[n].converged]
    stacked = stacking.stack({n: posts[n] for n in usable}, {n: loos[n] for n in usable},
                             stream_rng(seed, 14))
    say("model average (stacking): " + ", ".join(f"{n} {w:.2f}" for n, w in
                                                 stacked["weights"].items() if w >= 0.005))
    fe_table = check_table(posts, selected, cells, surrogate, seed)
    result = CriticismResult(cells=cells, seed=seed, settings=settings, posteriors=posts,
                             loo=loos, checks=chk, check_arrays=arrays, candidates=candidates,
                             selected=selected, runner_up=runner["effect"] if runner else None,
                             gain=gain, summaries=summaries, stacking=stacked,
                             fe_table=fe_table)
    result.verdict = verdict_module.verdict(result, generic)
    result.misfit_band = _misfit_band(result, generic, cells, surrogate, settings)
    if result.misfit_band and result.misfit_band["applied"]:
        result.verdict["text"] += " " + misfit_band.sentence(result.misfit_band)
    result.flagged_cells = _flag_adopted(posts, selected, cells, seed, settings.flag_draws,
                                         result.verdict, chk)
    say(f"{readings_heading(result.verdict)}: {len(result.flagged_cells)}"
        + "".join(f"; {f['cell_id']} {f['quantity']} ({f['score']:.2f})"
                  for f in result.flagged_cells))
    say(f"verdict: {result.verdict['status']}")
    result.timing_s = time.perf_counter() - t0
    return result


def _misfit_band(result, generic, cells, surrogate, settings):
    """The misfit band of a ``partly_explained`` or ``unexplained`` verdict
    (:mod:`turgorbayes.criticism.misfit_band`): the generic description's extra scatter per
    channel, each parameter's shift for an offset of that size, their sd and the model
    average with those biases; None for the other verdicts, ``applied`` False (with the
    reason) when no converged generic description gives the scatter."""
    if result.verdict["status"] not in misfit_band.WIDENED_STATUSES:
        return None
    scales = None
    if generic is not None and generic["converged"]:
        scales = effects.get_effect(generic["effect"]).channel_scales(
            result.summaries[generic["effect"]])
    if not scales:
        return {"applied": False, "reason": "no converged generic description of the misfit "
                "(discrepancy) measures its size"}
    shifts = misfit_band.offset_shifts(
        result.posteriors["baseline"], cells,
        lambda c: criticism_model(c, surrogate, [], settings), scales)
    sd = misfit_band.band_sd(shifts)
    weights = result.stacking["weights"]
    params = stacking.stacked_summary({n: result.posteriors[n] for n in weights}, weights,
                                      stream_rng(result.seed, 21), bias_sd=sd)
    return {"applied": True, "scales": dict(scales),
            "shifts": shifts, "sd": sd, "parameters": params}


def _select_named(candidates):
    """The selection rule over the candidates that name a cause, and the best generic one.

    Returns ``(best, runner_up, generic)``: the selected named candidate (or None), the
    second-best named candidate (or None) and the best converged generic candidate
    (``names_cause`` False; None if there is none), with ``passes``: whether it passes the
    rule against the baseline. A generic candidate is never selected: it tells the verdict
    whether misfit remains and whether a named cause is identified beyond extra scatter.
    """
    named = [c for c in candidates if verdict_module.names_cause(c["effect"])]
    best, runner = select(named)
    generic = [c for c in candidates if not verdict_module.names_cause(c["effect"])]
    # the best converged one; an unconverged one only when none converged (the verdict then
    # cannot tell a named effect from extra scatter)
    gen = max(generic, key=lambda c: (c["converged"], c["delta_elpd"]), default=None)
    if gen is not None:
        gen["passes"] = select([gen])[0] is not None
    return best, runner, gen


def _fit_pair(cells, surrogate, posts, loos, candidates, best, runner, seed, settings, say,
              summaries):
    """Fit the selected effect with the runner-up; the pair's name if it beats the single
    effect by the selection rule, else the single effect's."""
    pair = [best["effect"], runner["effect"]]
    name = effects.model_name(pair)
    say(f"pair: {name} (the selected effect with the runner-up) ...")
    guess = {}
    for n in pair:
        post = posts[n]
        guess.update({k: float(v[0]) for k, v in post.model.to_physical(post.u_map[None]).items()
                      if k not in guess})
    try:
        posts[name], loos[name] = _fit(cells, surrogate, pair, guess,
                                       candidate_seed(seed, pair), settings)
    except NUMERICAL_FAILURES as err:  # the single effect stands
        candidates.append(failed_candidate(name, err))
        say(f"{name}: could not be fitted ({candidates[-1]['failed']}); left out")
        return best["effect"]
    cand = _candidate(name, posts[name], loos[name], loos["baseline"], seed, summaries)
    candidates.append(cand)
    d, se, p = compare(loos[name], loos[best["effect"]], seed)
    cand["vs_selected"] = {"delta_elpd": d, "se": se, "p_gain": p}
    say(f"{name}: delta elpd vs {best['effect']} {d:.1f} +- {se:.1f}")
    if posts[name].converged and d > DELTA_ELPD_MIN and p >= P_GAIN_MIN:
        return name
    return best["effect"]


def readings_heading(verdict):
    """What flagged readings are called under a verdict (gross errors only when that is the
    explained cause)."""
    return ("readings that look like gross errors" if verdict_module.gross_error_verdict(verdict)
            else "readings the model cannot explain")


def _flag_adopted(posts, selected, cells, seed, n_draws=None, verdict=None, checks=None):
    """Readings the adopted model (``selected``; the baseline if None) cannot explain, screened
    by :func:`turgorbayes.workflows.fit.flag_cells` (the one screen of fit and criticism) at
    ``n_draws`` draws resampled by weight: with its fitted fraction of gross errors if it has
    the ``outliers`` effect, else with 1 % of readings assumed to be gross errors. Screening the
    adopted model, not the baseline, keeps a population effect (e.g. cells that differ in
    width) from being reported as many gross errors. Unless the ``verdict`` explains the data
    by gross errors, each reading's reason says it is unexplained and names the flagged check
    (of ``checks``) that points at it, without a probability of a gross error."""
    post = posts[selected or "baseline"]
    gross = verdict is None or verdict_module.gross_error_verdict(verdict)
    flags = flag_cells(post.model, post.model.to_physical(post.u), cells.cell_id, n_draws,
                       weights=post.weights, rng=stream_rng(seed, 15), gross=gross)
    if gross:
        return flags
    model_checks = (checks or {}).get(selected or "baseline", [])
    ids = list(cells.cell_id)
    for f in flags:
        i = ids.index(f["cell_id"])
        group = "bulged" if cells.is_bulged[i] else "intact"
        f["reason"] = (f"{outliers.reading_phrase(post.model, i, f['quantity'])} is a reading "
                       f"the model cannot explain ({_pointing_check(f['quantity'], group, model_checks)})")
    return flags


def _pointing_check(quantity, group, checks):
    """The flagged checks of ``quantity`` in ``group`` (or of both groups), as a phrase."""
    other = "intact" if group == "bulged" else "bulged"
    names = [c["name"] for c in checks if c["flagged"] and quantity in c["name"]
             and other not in c["name"]
             and not (group == "intact" and c["name"].startswith("conditions_"))]
    if not names:
        return "no single check points at it; it stands out in the leave-one-out screen"
    return "check " + ", ".join(names) + " points at it"


def check_table(posts, selected, cells, surrogate, seed):
    """Where the adopted model (``selected``; the baseline if None) asks the FE table for a
    stiffness it does not have (:func:`turgorbayes.inference.table_check.check_draws`, at
    :data:`~turgorbayes.inference.table_check.MAX_DRAWS` posterior draws)."""
    post, v = _adopted_draws(posts, selected, table_check.MAX_DRAWS, stream_rng(seed, 16))
    parts = post.model.condition_values(v)  # several conditions: each at its own values
    return table_check.check_draws(v, cells, surrogate,
                                   approximate=effects.changes_wall(selected or "baseline"),
                                   parts=parts)


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


def _summary(post, name, seed, summaries):
    """``post.summary`` (stream 13 of ``seed``) of model ``name``, kept in ``summaries``: a
    candidate's estimate and the result's summaries are the same summary, computed once."""
    if name not in summaries:
        summaries[name] = post.summary(stream_rng(seed, 13))
    return summaries[name]


def _candidate(name, post, loo, loo_base, seed, summaries):
    d, se, p = compare(loo, loo_base, seed)
    summary = _summary(post, name, seed, summaries)
    return {"effect": name, "delta_elpd": d, "delta_se": se, "p_gain": p,
            "estimate": _estimate(summary, post.model),
            "converged": bool(post.converged), "convergence": post.convergence(),
            "failed": None}


def failed_candidate(name, err):
    """The entry of a candidate whose fit raised ``err`` (one of
    :data:`NUMERICAL_FAILURES`): no gain, not converged, and ``failed`` the reason (the
    exception's type and message), so that the comparison leaves it out and the verdict names
    it."""
    reason = f"{type(err).__name__}: {err}".strip().rstrip(":")
    return {"effect": name, "delta_elpd": None, "delta_se": None, "p_gain": None,
            "estimate": {}, "converged": False,
            "convergence": {"engine": None, "converged": False, "reasons": [reason],
                            "attempts": [], "laplace": None},
            "failed": reason}


def criticism_dict(result):
    """The ``criticism.json`` content (keys exactly :data:`CRITICISM_KEYS`).

    ``misfit_detected`` is true unless the verdict is ``no_misfit`` (a flagged baseline check,
    a selected extension or a generic description of misfit passing the rule are each
    evidence against the baseline); ``checks`` are the baseline's; ``verdict`` is
    :func:`turgorbayes.criticism.verdict.verdict`; ``headline`` names the entry of
    ``parameters`` to quote (:data:`turgorbayes.criticism.verdict.HEADLINE`, or ``widened``:
    the model average with the misfit band when the verdict is ``partly_explained`` or
    ``unexplained``, :mod:`turgorbayes.criticism.misfit_band`; ``misfit_band`` holds its
    channel scales, each parameter's shifts and their sd, null for the other verdicts);
    ``candidates``
    the single effects and, if one was selected, its pair with the runner-up; ``gain`` is the
    adopted model's over the baseline (0 and 0 when nothing is adopted, and then
    ``parameters.extended`` is null); parameter entries have the fields of ``summary.json``
    (for importance sampling ``r_hat`` is null and both ESS are the weights' ESS). Each
    candidate's ``convergence`` and ``baseline_convergence`` are
    :meth:`~turgorbayes.criticism.Posterior.convergence` (engine, converged, reasons, the
    unconverged attempts before, the mode search and Hessian clipping); an unconverged
    candidate is never selected.
    """
    candidates = [jsonable({k: c[k] for k in CRITICISM_KEYS["candidates"]})
                  for c in result.candidates]
    band = result.misfit_band
    widened = bool(band and band["applied"])
    return {
        "misfit_detected": result.verdict["status"] != "no_misfit",
        "checks": [{k: c[k] for k in CRITICISM_KEYS["checks"]} for c in result.checks["baseline"]],
        "candidates": candidates,
        "selected_effect": result.selected,
        "cause": result.verdict["text"],
        "gain": {"delta_elpd": float(result.gain[0]), "se": float(result.gain[1])},
        "parameters": {"baseline": result.summaries["baseline"],
                       "extended": result.summaries[result.selected] if result.selected else None,
                       "model_average": result.stacking["parameters"],
                       "widened": band["parameters"] if widened else None},
        "baseline_convergence": jsonable(result.posteriors["baseline"].convergence()),
        "flagged_cells": list(result.flagged_cells),
        "fe_table": jsonable(result.fe_table),
        "verdict": jsonable(result.verdict),
        "headline": "widened" if widened else verdict_module.HEADLINE[result.verdict["status"]],
        "misfit_band": None if band is None else jsonable(
            {k: v for k, v in band.items() if k != "parameters"}),
    }


def jsonable(x):
    """Numpy scalars and arrays in nested dicts and lists as Python numbers and lists (for JSON)."""
    if isinstance(x, dict):
        return {k: jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    return x
