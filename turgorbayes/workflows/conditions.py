"""Fit a data set with several conditions: per-condition turgor and radius, and a wall that may
differ between conditions under a stated prior (the headline) or is shared (the number
conditional on that assumption) (:class:`turgorbayes.inference.conditions.ConditionsModel`;
docs/statistics.md, "Several conditions"), with the FE-table check per condition."""

import json

import numpy as np

from turgorbayes.inference import engine, models, table_check, wall_release
from turgorbayes.inference.conditions import (
    FREEABLE,
    WALL_PRIOR,
    condition_set,
    contrasts,
    model_factory,
    variable,
)
from turgorbayes.inference.engine import stream_rng
from turgorbayes.workflows.fit import fit_cells, to_datatree

__all__ = ["alias_diagnostics", "fit_conditions"]


def fit_conditions(cells, reference=None, per_condition=(), seed=0, surrogate=None,
                   settings=None, wall_prior=WALL_PRIOR):
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
    wall_prior : dict, optional
        How far each condition's wall may differ from the reference's (sd of ln E0t ratio
        and gamma difference, :data:`~turgorbayes.inference.conditions.WALL_PRIOR`); None or
        empty: one shared wall (``--assume-shared-wall``). With a prior, the shared-wall
        model is fitted too (same seed), and its contrasts, conditional on that assumption,
        are ``shared_wall_contrasts`` of the result.

    Returns
    -------
    turgorbayes.workflows.fit.FitResult
        With ``conditions`` (a :class:`ConditionSet`); with one condition and nothing freed,
        exactly :func:`turgorbayes.workflows.fit.fit_cells`'s baseline fit.
    """
    cs = condition_set(cells, reference, per_condition, wall_prior)
    if len(cs.names) == 1 and not cs.freed:
        result = fit_cells(cells, "baseline", seed=seed, surrogate=surrogate, settings=settings)
        result.conditions = cs
    else:
        result = fit_cells(cells, model_factory(cs), seed=seed, surrogate=surrogate,
                           settings=settings)
        alias_diagnostics(result, cs)
        result.conditions = cs
        if cs.wall_prior:
            result.shared_wall_contrasts = _shared_wall_contrasts(
                result, cells, reference, per_condition, seed, surrogate, settings)
            _release_walls(result, cs, seed)
        _recheck_table(result, cs)
    if result.tree is not None:
        result.tree.attrs["conditions"] = json.dumps(
            {"names": list(cs.names), "reference": cs.reference,
             "wall_prior": dict(cs.wall_prior), "bulged": list(cs.bulged),
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
    check = table_check.check_draws(result.draws, result.cells, result.surrogate)
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


def alias_diagnostics(result, cs):
    """Convergence diagnostics of the reference condition's parameters under their
    baseline names (the draws of :meth:`ConditionsModel.derived`)."""
    for q in ("P_phys", "gamma", "E0t", "R0"):
        var = cs.variable(q, cs.ref)
        if var != q and var in result.chain_diag:
            result.chain_diag[q] = result.chain_diag[var]


def _shared_wall_contrasts(result, cells, reference, per_condition, seed, surrogate, settings):
    """The contrasts if the wall were shared: from the sampled draws when no condition's wall
    was sampled (every prior wall is released afterwards), else from a shared-wall fit."""
    cs = result.conditions
    if not any(cs.tied(q, c) for q in FREEABLE for c in range(len(cs.names))):
        return contrasts(result, condition_set(cells, reference, per_condition))
    shared = fit_conditions(cells, reference, per_condition, seed=seed, surrogate=surrogate,
                            settings=settings, wall_prior=None)
    return contrasts(shared)


def _release_walls(result, cs, seed):
    """Each released condition's wall drawn from the prior and its turgor and radius moved
    along what its data cannot tell (:func:`turgorbayes.inference.wall_release.release`),
    then every per-draw array resampled by the importance weights (one index for all)."""
    released = [c for c in range(len(cs.names)) if any(cs.released(q, c) for q in FREEABLE)]
    if not released:
        return
    C, D = np.shape(result.lp)
    flat = {n: np.asarray(a, float).reshape(C * D) for n, a in result.draws.items()}
    rng = stream_rng(seed, 1010)
    log_w, report = np.zeros(C * D), {}
    for c in released:
        ref = {q: flat[cs.variable(q, cs.ref)] for q in ("gamma", "E0t")}
        old = {"P": flat[cs.variable("P_phys", c)], "R0": flat[cs.variable("R0", c)], **ref}
        prior = {q: sd for q, sd in cs.wall_prior.items() if cs.released(q, c)}
        new = wall_release.release(old, prior, rng, models.P0, result.surrogate)
        _moduli(flat, cs, c, old, new)
        flat.update({cs.variable("P_phys", c): new["P"], cs.variable("R0", c): new["R0"],
                     cs.variable("gamma", c): new["gamma"], cs.variable("E0t", c): new["E0t"]})
        log_w += new["log_weight"]
        report[cs.names[c]] = {"failed": new["failed"], "n": int(C * D)}
    w = np.exp(log_w - np.max(log_w))
    ess = float(np.sum(w) ** 2 / np.sum(w ** 2))
    idx = engine.resample(w / np.sum(w), C * D, rng)
    pick = lambda a: np.asarray(a).reshape((C * D,) + np.shape(a)[2:])[idx].reshape(np.shape(a))  # noqa: E731
    result.draws = {n: a[idx].reshape(C, D) for n, a in flat.items()}
    result.log_lik, result.lp = pick(result.log_lik), pick(result.lp)
    result.ppc = {n: pick(a) for n, a in result.ppc.items()}
    P_cell = pick(result.P_cell)
    for c in released:
        intact = (cs.index == c) & ~result.cells.is_bulged
        P_cell[:, :, intact] = result.draws[cs.variable("P_phys", c)][:, :, None]
    result.P_cell = P_cell
    result.wall_release = {"conditions": report, "ess": ess, "n": int(C * D)}
    attrs = dict(result.tree.attrs) if result.tree is not None else {}
    result.tree = to_datatree(result)
    result.tree.attrs.update(attrs)
    result.tree.attrs["wall_release"] = json.dumps(result.wall_release)


def _moduli(flat, cs, c, old, new):
    """E_perp, E_par of condition index ``c`` at its released wall, with each draw's own
    thickness (the shared-wall E_perp t over its E_perp)."""
    names = (cs.modulus_variable("E_perp", c), cs.modulus_variable("E_par", c))
    if names[0] not in flat:
        return
    t = old["E0t"] * (old["P"] / models.P0) ** old["gamma"] / flat[names[0]]
    moduli = models.moduli_at_pressure(new["P"], new["gamma"], new["E0t"], new["R0"], t,
                                       models.P0)
    flat.update(zip(names, moduli, strict=True))


# ---------------------------------------------------------------------- summaries
