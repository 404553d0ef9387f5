"""What a criticism returns: :class:`CriticismResult`, and the content of
``criticism.json`` (:func:`criticism_dict`, keys :data:`CRITICISM_KEYS`).
"""

from dataclasses import dataclass, field

import numpy as np

from turgorbayes.criticism import verdict as verdict_module
from turgorbayes.workflows.criticism_setup import CriticismSettings

__all__ = ["CRITICISM_KEYS", "CriticismResult", "criticism_dict", "jsonable"]

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
    "misfit_band": ("applied", "converged", "scales", "shifts", "sd"),
}


@dataclass
class CriticismResult:
    """Everything :func:`~turgorbayes.workflows.criticize.criticize` produced (see
    :func:`criticism_dict` for the JSON)."""

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
    #: :func:`turgorbayes.workflows.criticism_screens.flag_adopted`: readings the adopted
    #: model cannot explain
    flagged_cells: list = field(default_factory=list)
    #: :func:`turgorbayes.inference.table_check.check_draws` of the adopted model
    fe_table: dict = None
    #: :func:`turgorbayes.criticism.verdict.verdict`: status, selected, remaining checks, text
    verdict: dict = None
    #: the headline's band when the misfit is not (fully) explained
    #: (:mod:`turgorbayes.criticism.misfit_band`)
    misfit_band: dict = None


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
