"""Where does a posterior ask the FE table for a stiffness it does not have?

The forward model has no stiffness outside the finite-element table, nor in its *buckled*
region (:meth:`turgorbayes.surrogate.Surrogate.buckled`: there the FE wall buckles under the
tip before ``h = R/20`` and ``k`` has no unique value, docs/fem.md, "The buckled corner"). The
likelihood gives such pressures zero probability, so a posterior avoids them because the model
is silent there, not because the data exclude them. This check counts that instead of hiding
it: for every posterior draw (thinned to at most :data:`MAX_DRAWS`) and cell, the share of the
cell's plausible pressures at which the stiffness is undefined, by reason:

* an intact cell: the draw's ``P_phys`` (a share of 0 or 1);
* a bulged cell: the pressures its bulge allows, i.e. its measured ``ln P`` with the bulge's
  sd (:attr:`turgorbayes.inference.observations.CellObservations.sd_log_P_bulge`), on
  :data:`N_NODES` Gauss-Hermite nodes whose weights sum to one.

For models that change the wall per cell or add a layer (``radius_spread``, ``wall_softening``,
``outer_membrane``) it uses the shared wall parameters ``gamma``, ``E0t``, ``R0`` of each
draw, i.e. the baseline wall: an approximation for those models, said so in the result.
"""

import numpy as np

from turgorbayes.physics import forward

__all__ = [
    "CHUNK_POINTS",
    "cell_shares",
    "check_draws",
    "check_fit",
    "describe",
    "MAX_DRAWS",
    "N_NODES",
    "REASONS",
    "SHARE_REPORTED",
    "undefined_shares",
]

#: Posterior draws used (evenly thinned).
MAX_DRAWS = 400
#: Points (draws x cells x nodes) of the forward model evaluated at once. The check of a
#: 10 000-cell fit (400 draws x 16 nodes) peaked at 0.43 GB in blocks of these, at 8.1 GB all
#: at once (studies/results/fit_large.txt); all at once grows with the cells.
CHUNK_POINTS = 1_000_000
#: Gauss-Hermite nodes over a bulged cell's measured ln P.
N_NODES = 16
#: A cell enters the report when its mean share over the draws is at least this.
SHARE_REPORTED = 1e-3
REASONS = {"buckled": forward.BUCKLED, "outside": forward.OUTSIDE_SURROGATE}


def undefined_shares(surrogate, P, weights, gamma, E0t, R0, P0=forward.P0_DEFAULT):
    """Weighted share of pressures at which the stiffness is undefined, per reason.

    Parameters
    ----------
    surrogate : turgorbayes.surrogate.Surrogate
    P : ndarray [Pa], shape (..., K)
        Pressures, the last axis the ones to be weighted.
    weights : ndarray, shape (K,) or broadcast to ``P``
        Weights of the last axis (summing to one).
    gamma, E0t, R0 : ndarray
        Wall parameters [-], [N/m], [m], broadcast against ``P``.
    P0 : float [Pa]

    Returns
    -------
    dict
        ``{"buckled": ndarray, "outside": ndarray}`` of the shape of ``P`` without its last axis.
    """
    codes = forward.cell_terms(P, gamma, E0t, R0, P0, surrogate=surrogate)["reason"]
    return {name: np.sum(np.where(codes == code, weights, 0.0), axis=-1)
            for name, code in REASONS.items()}


def _thinned(draws, names):
    flat = {n: np.asarray(draws[n], float).reshape(-1) for n in names}
    n = next(iter(flat.values())).size
    keep = np.unique(np.linspace(0, n - 1, min(n, MAX_DRAWS)).round().astype(int))
    return {k: v[keep] for k, v in flat.items()}


def cell_shares(draws, cells, surrogate, chunk_points=CHUNK_POINTS):
    """Per reason, the share for each (thinned draw, cell), shape ``(draws, cells)``.

    The draws are taken a few at a time, about ``chunk_points`` pressures per call of the
    forward model (memory, not the result: each point is computed alone).
    """
    from turgorbayes.inference.observations import observations_from_cells

    d = _thinned(draws, ("gamma", "E0t", "R0", "P_phys"))
    wall = tuple(d[n][:, None, None] for n in ("gamma", "E0t", "R0"))
    n_draws, n_cells = d["gamma"].size, len(cells.cell_id)
    out = {name: np.zeros((n_draws, n_cells)) for name in REASONS}
    bulged = np.flatnonzero(cells.is_bulged)
    intact = np.flatnonzero(~np.asarray(cells.is_bulged, bool))
    if intact.size:
        P = np.broadcast_to(d["P_phys"][:, None, None], (n_draws, intact.size, 1))
        _chunked_shares(out, intact, surrogate, P, np.ones(1), wall, chunk_points)
    if bulged.size:
        obs = observations_from_cells(cells)
        x, w = np.polynomial.hermite_e.hermegauss(N_NODES)
        P = np.exp(obs.log_P_bulge[:, None] + obs.sd_log_P_bulge[:, None] * x)[None]
        _chunked_shares(out, bulged, surrogate, P, w / w.sum(), wall, chunk_points)
    return out


def _chunked_shares(out, columns, surrogate, P, weights, wall, chunk_points):
    """:func:`undefined_shares` of the pressures ``P`` ``(draws|1, n, K)`` at the walls
    ``(draws, 1, 1)``, a block of draws at a time, written into ``out[name][:, columns]``."""
    n_draws = wall[0].shape[0]
    step = max(1, int(chunk_points) // (P.shape[1] * P.shape[2]))
    for j in range(0, n_draws, step):
        rows = slice(j, j + step)
        part = undefined_shares(surrogate, P[rows] if P.shape[0] > 1 else P, weights,
                                *(a[rows] for a in wall))
        for name, share in part.items():
            out[name][rows, columns] = share


def check_fit(result, approximate=False):
    """:func:`check_draws` of a fit (:class:`turgorbayes.workflows.fit.FitResult`)."""
    return check_draws(result.draws, result.cells, result.surrogate, approximate=approximate)


def check_draws(draws, cells, surrogate, approximate=False, parts=None):
    """Summary of :func:`undefined_shares` over posterior draws and cells.

    Parameters
    ----------
    draws : dict
        Physical draws (SI) with at least ``gamma``, ``E0t``, ``R0``, ``P_phys`` (any shape).
    cells : turgorbayes.cells.table.CellData
    surrogate : turgorbayes.surrogate.Surrogate
    approximate : bool
        The model changes the wall the table is read at (an effect with
        :attr:`turgorbayes.effects.base.Effect.changes_wall`): the check, at the baseline's
        wall, is then an approximation, and says so.
    parts : list of (ndarray, dict), optional
        Several conditions: ``(cell indices, draws)`` per condition, its cells checked at its
        own draws (``draws`` is then not read).

    Returns
    -------
    dict
        ``fraction_of_draws`` (draws in which at least one cell has more than 1 % of its
        plausible pressures where the stiffness is undefined), ``cells`` ({cell_id:
        {"buckled": share, "outside": share}}, mean shares over the draws, for the cells
        whose total is at least :data:`SHARE_REPORTED`), ``boxes`` (the buckled region:
        :attr:`turgorbayes.surrogate.Surrogate.buckled_boxes`), ``domain`` (the table's),
        ``approximate`` (True for models whose wall differs from the baseline's).
    """
    s = surrogate
    if parts is None:
        shares = cell_shares(draws, cells, surrogate)
    else:
        shares = {name: np.zeros((0, len(cells.cell_id))) for name in REASONS}
        for idx, part_draws in parts:
            for name, share in cell_shares(part_draws, cells.take(idx), surrogate).items():
                if not shares[name].size:
                    shares[name] = np.zeros((share.shape[0], len(cells.cell_id)))
                shares[name][:, idx] = share
    total = shares["buckled"] + shares["outside"]
    mean = {name: v.mean(axis=0) for name, v in shares.items()}
    cells = {str(c): {name: float(mean[name][i]) for name in REASONS}
             for i, c in enumerate(cells.cell_id)
             if mean["buckled"][i] + mean["outside"][i] >= SHARE_REPORTED}
    domain = getattr(s, "domain", None)
    return {"fraction_of_draws": float(np.mean(np.any(total > 0.01, axis=1))), "cells": cells,
            "boxes": list(getattr(s, "buckled_boxes", [])),
            "domain": {k: list(v) for k, v in domain.items()} if domain else None,
            "approximate": bool(approximate)}


def describe(check):
    """One sentence for reports and the command line ('' when no cell is affected)."""
    if not check["cells"]:
        return ""
    parts = []
    for name, what in (("buckled", "where the FE wall buckles under the tip ({region})"),
                       ("outside", "outside the FE table ({domain})")):
        ids = [c for c, v in check["cells"].items() if v[name] >= SHARE_REPORTED]
        if not ids:
            continue
        worst = max(check["cells"][c][name] for c in ids)
        region = "; ".join(f"x {b['x'][0]:.3g}-{b['x'][1]:.3g}, ratio {b['ratio'][0]:.3g}-"
                           f"{b['ratio'][1]:.3g}" for b in check["boxes"])
        dom = check.get("domain") or {}
        domain = (f"x {dom['x'][0]:.3g}-{dom['x'][1]:.3g}, ratio {dom['ratio'][0]:.3g}-"
                  f"{dom['ratio'][1]:.3g}" if dom else "its domain")
        parts.append(f"{len(ids)} cell(s) {what.format(region=region, domain=domain)}, up to "
                     f"{100 * worst:.1f} % of their plausible pressures ({_ids(ids)})")
    approx = " (checked on the baseline wall, approximate for this model)" if check["approximate"] else ""
    return (f"the model has no stiffness at some pressures the data allow: "
            f"{'; '.join(parts)}; {100 * check['fraction_of_draws']:.1f} % of posterior draws "
            f"are affected (more than 1 % of a cell's pressures). The likelihood is zero there, "
            f"so these cells' pressures are pushed out of that region by the model, not by the "
            f"data{approx}.")


def _ids(ids, n=6):
    return ", ".join(ids[:n]) + (f" and {len(ids) - n} more" if len(ids) > n else "")
