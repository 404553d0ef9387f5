r"""The criticism workflow: fit the baseline, check it, fit every effect, compare, select.

:func:`criticize` runs the whole workflow on one data set (``turgorbayes criticize``) and
returns a :class:`CriticismResult`; :func:`criticism_dict` is the content of
``criticism.json`` (keys :data:`CRITICISM_KEYS`). The workflow is described in
``docs/effects.md``. Its parts, re-exported here: the settings and models
(:mod:`~turgorbayes.workflows.criticism_setup`), the candidates
(:mod:`~turgorbayes.workflows.criticism_candidates`), the checks of the fitted models
(:mod:`~turgorbayes.workflows.criticism_screens`) and the result
(:mod:`~turgorbayes.workflows.criticism_result`).
"""

import dataclasses
import time
from contextlib import nullcontext

import numpy as np

from turgorbayes import effects
from turgorbayes.cache import MISSING
from turgorbayes.cells.medium import MEDIUM_COLUMN
from turgorbayes.criticism import evidence, misfit_band, stacking
from turgorbayes.criticism import verdict as verdict_module
from turgorbayes.criticism.loo import compare, exact_loo
from turgorbayes.criticism.selection import DELTA_ELPD_MIN, P_GAIN_MIN, select
from turgorbayes.effects.conditions import conditions_reason
from turgorbayes.errors import DataError
from turgorbayes.inference import start_check
from turgorbayes.inference.conditions import CONDITION_COLUMN
from turgorbayes.inference.engine import fit_posterior, stream_rng
from turgorbayes.parallel import ordered_imap, pool_open, task_pool, threaded_imap
from turgorbayes.workflows.criticism_candidates import (
    candidate_entry,
    candidate_key,
    candidate_laplace,
    candidate_seed,
    data_digest,
    failed_candidate,
    fit_status,
    model_summary,
    restored_entry,
    storable_entry,
)
from turgorbayes.workflows.criticism_result import (
    CRITICISM_KEYS,
    CriticismResult,
    criticism_dict,
    jsonable,
)
from turgorbayes.workflows.criticism_screens import (
    check_table,
    flag_adopted,
    predictive_checks,
    readings_heading,
)
from turgorbayes.workflows.criticism_setup import (
    NUMERICAL_FAILURES,
    CriticismSettings,
    check_criticism_data,
    conditions_design,
    criticism_model,
    is_series,
    model_class,
    series_design,
)

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
    "series_design",
]


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
    settings = CriticismSettings() if settings is None else settings
    # several workers on this machine: forked once, kept for every fit's heavy steps (their
    # caches stay warm from model to model); a Dask scheduler takes the candidates instead
    local = settings.workers > 1 and settings.scheduler is None
    with task_pool(settings.workers) if local else nullcontext():
        return _criticize(cells, surrogate, seed, settings, progress, cache)


def _criticize(cells, surrogate, seed, settings, progress, cache):
    """:func:`criticize`'s steps."""
    t0 = time.perf_counter()
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
    guess = criticism_model(cells, surrogate, [], settings).start_guess()
    posts, loos = {}, {}
    posts["baseline"], loos["baseline"] = _fit(cells, surrogate, [], guess, seed, settings)
    say(f"baseline: {fit_status(posts['baseline'], loos['baseline'])}")
    base_map = {k: float(v[0]) for k, v in
                posts["baseline"].model.to_physical(posts["baseline"].u_map[None]).items()}
    chk, arrays = {}, {}
    chk["baseline"], arrays["baseline"] = predictive_checks(posts["baseline"], seed, settings)
    say(f"checks: {sum(c['flagged'] for c in chk['baseline'])} of {len(chk['baseline'])} flagged")
    candidates, summaries = [], {}  # summaries: each model's, computed once (model_summary)
    for i, (name, post, loo, err, seconds) in enumerate(
            _fitted_candidates(cells, surrogate, names, base_map, seed, settings, say, cache)):
        say(f"candidate {i + 1}/{len(names)}: {name} ...")
        if err is not None:  # recorded, left out of the comparison
            candidates.append(failed_candidate(name, err))
            say(f"{name}: could not be fitted ({candidates[-1]['failed']}); left out")
            continue
        posts[name], loos[name] = post, loo
        candidates.append(candidate_entry(name, post, loo, loos["baseline"], seed, summaries))
        say(f"{name}: delta elpd {candidates[-1]['delta_elpd']:.1f} +- "
            f"{candidates[-1]['delta_se']:.1f} (P(gain > 0) = {candidates[-1]['p_gain']:.3f}); "
            f"{fit_status(post, loo)}; {seconds:.0f} s")
    best, runner, generic = _select_named(candidates)
    selected = best["effect"] if best else None
    if best and runner:
        selected = _fit_pair(cells, surrogate, posts, loos, candidates, best, runner, seed,
                             settings, say, summaries)
    if selected:
        chk[selected], arrays[selected] = predictive_checks(posts[selected], seed, settings)
        if generic is not None and generic["converged"]:
            _compare_generic(generic, selected, posts, loos, seed)
    gain = compare(loos[selected], loos["baseline"], seed) if selected else (0.0, 0.0, 0.0)
    summaries = {name: model_summary(posts[name], name, seed, summaries) for name in posts}
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
    result.flagged_cells = flag_adopted(posts, selected, cells, seed, settings.flag_draws,
                                         result.verdict, chk, workers=settings.workers)
    say(f"{readings_heading(result.verdict)}: {len(result.flagged_cells)}"
        + "".join(f"; {f['cell_id']} {f['quantity']} ({f['score']:.2f})"
                  for f in result.flagged_cells))
    say(f"verdict: {result.verdict['status']}")
    result.timing_s = time.perf_counter() - t0
    return result


def _fit(cells, surrogate, names, guess, seed, settings):
    """The posterior of the model with effects ``names`` and its exact LOO, both from ``seed``
    (the model's own: the baseline's is the workflow's, a candidate's a stream of it keyed by
    its name, :func:`candidate_seed`)."""
    model = criticism_model(cells, surrogate, names, settings)
    start = model.start_values(guess)
    u0 = model.to_u(start)[0]
    if not np.isfinite(model.log_posterior(u0[None])[0]):  # name the cells at fault
        raise start_check.start_error(model, u0)
    lap = candidate_laplace(model, names, start, seed)
    post = fit_posterior(model, None, seed, settings, laplace=lap)
    return post, exact_loo(post, cells, surrogate, seed, settings)


def _fit_candidate(job):
    """One candidate's fit and exact LOO (a worker's task): ``(name, posterior, loo, error,
    seconds)``, the error (one of :data:`NUMERICAL_FAILURES`) instead of the fit when it
    failed."""
    cells, surrogate, name, guess, seed, settings = job
    # the candidates are the parallel work: a candidate's own fit stays serial (no nested
    # pools; the result does not depend on the workers either way)
    settings = dataclasses.replace(settings, workers=1)
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
    if pool_open():  # criticize's own task pool (several local workers)
        # each candidate in a thread, every heavy step of each on the same forked workers:
        # candidates take 1 to 4 s, so one candidate per worker leaves a worker idle at the end
        fitted = threaded_imap(_fit_candidate, jobs, settings.workers)
    else:
        fitted = ordered_imap(_fit_candidate, jobs, settings.workers, settings.scheduler)
    for name in names:
        if stored.get(name, MISSING) is not MISSING:
            yield restored_entry(stored[name], cells, surrogate, settings)
            continue
        entry = next(fitted)
        if name in keys:
            cache.put(keys[name], storable_entry(entry))
        yield entry
    fitted.close()  # every candidate is in: its threads and pool (if its own) end here


def _misfit_band(result, generic, cells, surrogate, settings):
    """The misfit band of a ``partly_explained`` or ``unexplained`` verdict
    (:mod:`turgorbayes.criticism.misfit_band`): the generic description's extra scatter per
    channel, each parameter's shift for an offset of that size, their sd and the model
    average with those biases; None for the other verdicts. A generic description whose
    sampler did not converge still sizes the band (``converged`` False: a rough size beats
    none where the misfit is not explained); ``applied`` is False (with the reason) only when
    none could be fitted."""
    if result.verdict["status"] not in misfit_band.WIDENED_STATUSES:
        return None
    scales = None
    if generic is not None and not generic.get("failed"):
        scales = effects.get_effect(generic["effect"]).channel_scales(
            result.summaries[generic["effect"]])
    if not scales:
        return {"applied": False, "reason": "no generic description of the misfit "
                "(discrepancy) could be fitted to measure its size"}
    shifts = misfit_band.offset_shifts(
        result.posteriors["baseline"], cells,
        lambda c: criticism_model(c, surrogate, [], settings), scales)
    sd = misfit_band.band_sd(shifts)
    weights = result.stacking["weights"]
    params = stacking.stacked_summary({n: result.posteriors[n] for n in weights}, weights,
                                      stream_rng(result.seed, 21), bias_sd=sd)
    return {"applied": True, "converged": bool(generic["converged"]), "scales": dict(scales),
            "shifts": shifts, "sd": sd, "parameters": params}


def _compare_generic(generic, selected, posts, loos, seed):
    """Record in ``generic`` (the best generic candidate's entry) its LOO gain over the selected
    model (``vs_selected``, with the Bayes factor of the two) and whether the selected model is
    identified beyond extra scatter (``selected_identified``, ``identified_by``): it beats the
    generic description by the selection rule (``"loo"``), or the generic description does not
    beat it by the rule and the marginal likelihood credits the named cause with predicting
    the pattern both fit (``"bayes_factor"``; :mod:`turgorbayes.criticism.evidence`)."""
    d, se, p = compare(loos[selected], loos[generic["effect"]], seed)
    bf = evidence.bayes_factor(posts[selected], posts[generic["effect"]])
    generic["vs_selected"] = {"delta_elpd": -d, "se": se, "p_gain": 1.0 - p, "bayes_factor": bf}
    generic_wins = -d > DELTA_ELPD_MIN and 1.0 - p >= P_GAIN_MIN
    by_loo = bool(d > DELTA_ELPD_MIN and p >= P_GAIN_MIN)
    by_bf = not by_loo and not generic_wins and bf is not None and bf["credits"]
    generic["selected_identified"] = by_loo or by_bf
    generic["identified_by"] = "loo" if by_loo else "bayes_factor" if by_bf else None


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
    cand = candidate_entry(name, posts[name], loos[name], loos["baseline"], seed, summaries)
    candidates.append(cand)
    d, se, p = compare(loos[name], loos[best["effect"]], seed)
    cand["vs_selected"] = {"delta_elpd": d, "se": se, "p_gain": p}
    say(f"{name}: delta elpd vs {best['effect']} {d:.1f} +- {se:.1f}")
    if posts[name].converged and d > DELTA_ELPD_MIN and p >= P_GAIN_MIN:
        return name
    return best["effect"]
