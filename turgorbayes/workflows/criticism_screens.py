"""The checks of a criticism's fitted models: the posterior predictive checks
(:func:`predictive_checks`), the readings the adopted model cannot explain
(:func:`flag_adopted`) and where it leans on the FE table beyond its data
(:func:`check_table`).
"""

import warnings

import numpy as np

from turgorbayes import effects
from turgorbayes.cells.order import measurement_order
from turgorbayes.criticism import checks as checks_module
from turgorbayes.criticism import verdict as verdict_module
from turgorbayes.effects import outliers
from turgorbayes.effects.calibration import session_labels
from turgorbayes.inference import table_check
from turgorbayes.inference.engine import batched, stream_rng
from turgorbayes.inference.observations import stiffness_sd
from turgorbayes.workflows.flags import flag_cells

__all__ = ["adopted_draws", "check_table", "flag_adopted", "predictive_checks",
           "readings_heading"]


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
    # a stiffness's error is its reported relative error times the model value, as in the
    # likelihood (observations.stiffness_sd): the reported error of a reading that is far off
    # (a slipped curve reads half the stiffness, and half the error) would double its residual
    # (where a draw has no prediction its residual is NaN whatever the error)
    k_sd = stiffness_sd(mu["k_c"], obs.k_c, obs.k_c_err)
    sigma = {"R_c": obs.R_c_err,
             "k_c": np.where(np.isfinite(k_sd) & (k_sd > 0), k_sd, obs.k_c_err)}
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
            order=measurement_order(model.cells)[0], stratum=stratum,
            session=session_labels(model.cells))
    return out, {"y": y, "sigma": sigma, "y_rep": y_rep, "mu": mu, "log_pressure": log_p,
                 "group": group}


def readings_heading(verdict):
    """What flagged readings are called under a verdict (gross errors only when that is the
    explained cause)."""
    return ("readings that look like gross errors" if verdict_module.gross_error_verdict(verdict)
            else "readings the model cannot explain")


def flag_adopted(posts, selected, cells, seed, n_draws=None, verdict=None, checks=None,
                 workers=1):
    """Readings the adopted model (``selected``; the baseline if None) cannot explain, screened
    by :func:`turgorbayes.workflows.fit.flag_cells` (the one screen of fit and criticism) at
    ``n_draws`` draws resampled by weight: with its fitted fraction of gross errors if it has
    the ``outliers`` effect, else with 1 % of readings assumed to be gross errors. Screening the
    adopted model, not the baseline, keeps a population effect (e.g. cells that differ in
    width) from being reported as many gross errors. Unless the ``verdict`` explains the data
    by gross errors, each reading's reason says it is unexplained and names the flagged check
    (of ``checks``) that points at it, without a probability of a gross error. The screen's
    batches run on ``workers`` processes (the same flags on any number)."""
    post = posts[selected or "baseline"]
    gross = verdict is None or verdict_module.gross_error_verdict(verdict)
    flags = flag_cells(post.model, post.model.to_physical(post.u), cells.cell_id, n_draws,
                       weights=post.weights, rng=stream_rng(seed, 15), gross=gross,
                       workers=workers)
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
    post, v = adopted_draws(posts, selected, table_check.MAX_DRAWS, stream_rng(seed, 16))
    parts = post.model.condition_values(v)  # several conditions: each at its own values
    return table_check.check_draws(v, cells, surrogate,
                                   approximate=effects.changes_wall(selected or "baseline"),
                                   parts=parts)


def adopted_draws(posts, selected, n, rng):
    """The adopted posterior (``selected``; the baseline if None) and ``n`` of its draws
    resampled by ``rng``, in physical units (dict of ``(n,)`` arrays)."""
    post = posts[selected or "baseline"]
    return post, post.model.to_physical(post.u[post.resample(n, rng)])
