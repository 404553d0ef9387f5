"""Fit a data set with several conditions: the shared wall and per-condition turgor and radius
(:class:`turgorbayes.inference.conditions.ConditionsModel`; docs/statistics.md, "Several
conditions"), with the FE-table check per condition."""

import json

import numpy as np

from turgorbayes.inference import table_check
from turgorbayes.inference.conditions import condition_set, model_factory, variable
from turgorbayes.workflows.fit import fit_cells

__all__ = ["fit_conditions"]


def fit_conditions(cells, reference=None, per_condition=(), seed=0, surrogate=None,
                   settings=None):
    """Fit the baseline with conditions (module docstring).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
        With or without a ``condition`` column.
    reference : str, optional
        Reference condition of the contrasts (default: the first in file order).
    per_condition : sequence of str
        Freed wall parameters (:func:`condition_set`).
    seed : int
    surrogate : Surrogate, optional
        The shipped FE table if None.
    settings : turgorbayes.workflows.fit.FitSettings, optional

    Returns
    -------
    turgorbayes.workflows.fit.FitResult
        With ``conditions`` (a :class:`ConditionSet`); with one condition and nothing freed,
        exactly :func:`turgorbayes.workflows.fit.fit_cells`'s baseline fit.
    """
    cs = condition_set(cells, reference, per_condition)
    if len(cs.names) == 1 and not cs.freed:
        result = fit_cells(cells, "baseline", seed=seed, surrogate=surrogate,
                                   settings=settings)
    else:
        result = fit_cells(cells, model_factory(cs), seed=seed, surrogate=surrogate,
                                   settings=settings)
        _alias_diagnostics(result, cs)
        _recheck_table(result, cs)
    result.conditions = cs
    if result.tree is not None:
        result.tree.attrs["conditions"] = json.dumps(
            {"names": list(cs.names), "reference": cs.reference,
             "variables": {n: {q: variable(result, q, c) for q in ("P_phys", "gamma", "E0t", "R0")}
                           for c, n in enumerate(cs.names)}})
    return result


def _recheck_table(result, cs):
    """The FE-table check (:func:`turgorbayes.inference.table_check.check_draws`) with each
    condition's cells at its own parameters, into the result and its tree's attributes."""
    shares = {name: np.zeros((0, 0)) for name in table_check.REASONS}
    for c in range(len(cs.names)):
        idx = np.flatnonzero(cs.index == c)
        draws = {q: result.draws[cs.variable(q, c)] for q in ("P_phys", "gamma", "E0t", "R0")}
        part = table_check.cell_shares(draws, result.cells.take(idx), result.surrogate)
        for name, share in part.items():
            if not shares[name].size:
                shares[name] = np.zeros((share.shape[0], len(result.cells)))
            shares[name][:, idx] = share
    check = table_check.check_draws(result.draws, result.cells, result.surrogate, result.model)
    total = shares["buckled"] + shares["outside"]
    mean = {name: v.mean(axis=0) for name, v in shares.items()}
    check["fraction_of_draws"] = float(np.mean(np.any(total > 0.01, axis=1)))
    check["cells"] = {str(cid): {name: float(mean[name][i]) for name in table_check.REASONS}
                      for i, cid in enumerate(result.cells.cell_id)
                      if mean["buckled"][i] + mean["outside"][i] >= table_check.SHARE_REPORTED}
    result.table_check = check
    if result.tree is not None:
        result.tree.attrs["fe_table_undefined_fraction"] = check["fraction_of_draws"]
        result.tree.attrs["fe_table_undefined_note"] = table_check.describe(check)


def _alias_diagnostics(result, cs):
    """Convergence diagnostics of the reference condition's parameters under their
    baseline names (the draws of :meth:`ConditionsModel.derived`)."""
    for q in ("P_phys", "gamma", "E0t", "R0"):
        var = cs.variable(q, cs.ref)
        if var != q and var in result.chain_diag:
            result.chain_diag[q] = result.chain_diag[var]


# ---------------------------------------------------------------------- summaries
