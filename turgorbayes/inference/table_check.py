"""Does a posterior lean on the part of the FE table that is good only to a few percent?

The shipped ``k/(PR)`` table interpolates to < 0.5 % almost everywhere, but in the grid cells
next to FE points whose force curve snapped before ``h = R/20`` (x > 0.38 with
``E_par/E_perp <= 0.6`` on the shipped table) it is good only to a few percent
(:meth:`turgorbayes.surrogate.Surrogate.reliable`). The paper's cells sit at x = 0.06-0.17,
far from there; a stiff-exponent posterior (gamma >~ 1.6 with pressures below 15 kPa) can
reach it. This check puts every cell, for every posterior draw, at its posterior-mean
pressure (:attr:`turgorbayes.results.FitResult.P_cell`) on the wall model of that draw and
asks whether its ``(x, ratio)`` is in such a cell.

For models that change the wall per cell or add a layer (``radius_spread``, ``wall_softening``,
``outer_membrane``) it uses the shared wall parameters ``gamma``, ``E0t``, ``R0`` of each
draw, i.e. the baseline wall: an approximation for those models, said so in the result.
"""

import numpy as np

from turgorbayes import forward

__all__ = ["check_fit", "describe", "unreliable"]

_WALL_EFFECTS = ("radius_spread", "wall_softening", "outer_membrane")


def unreliable(surrogate, P, gamma, E0t, R0, P0=forward.P0_DEFAULT):
    """True where the baseline wall at pressure ``P`` lands in an unreliable table cell.

    Parameters
    ----------
    surrogate : turgorbayes.surrogate.Surrogate
    P : array_like [Pa]
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    P0 : float [Pa]

    Returns
    -------
    numpy.ndarray of bool
        Broadcast shape of the inputs; False where the wall model is undefined.
    """
    terms = forward.cell_terms(P, gamma, E0t, R0, P0, surrogate=False)
    x, ratio = terms["x"], terms["ratio"]
    ok = np.isfinite(x) & np.isfinite(ratio)
    return ok & ~surrogate.reliable(np.where(ok, x, 1.0), np.where(ok, ratio, 1.0))


def check_fit(result):
    """Summary of :func:`unreliable` over a fit's draws and cells.

    Parameters
    ----------
    result : turgorbayes.results.FitResult

    Returns
    -------
    dict
        ``fraction_of_draws`` (draws with at least one cell in the region), ``cells``
        ({cell_id: fraction of draws} for the cells that enter it), ``boxes`` (the region:
        :attr:`turgorbayes.surrogate.Surrogate.unreliable_boxes`), ``approximate`` (True for
        models whose wall differs from the baseline's).
    """
    boxes = list(getattr(result.surrogate, "unreliable_boxes", []))
    approximate = any(e in result.model for e in _WALL_EFFECTS)
    out = {"fraction_of_draws": 0.0, "cells": {}, "boxes": boxes, "approximate": approximate}
    if not boxes:
        return out
    d = result.draws
    bad = unreliable(result.surrogate, result.P_cell, d["gamma"][..., None], d["E0t"][..., None],
                     d["R0"][..., None])
    per_cell = bad.reshape(-1, bad.shape[-1]).mean(axis=0)
    out["fraction_of_draws"] = float(bad.any(axis=-1).mean())
    out["cells"] = {str(c): float(f) for c, f in zip(result.cells.cell_id, per_cell, strict=True)
                    if f > 0}
    return out


def describe(check):
    """One sentence for reports and the command line ('' when no draw enters the region)."""
    f = check["fraction_of_draws"]
    if f == 0:
        return ""
    region = "; ".join(f"x {b['x'][0]:.3g}-{b['x'][1]:.3g}, ratio {b['ratio'][0]:.3g}-"
                       f"{b['ratio'][1]:.3g}" for b in check["boxes"])
    approx = " (checked on the baseline wall, approximate for this model)" if check["approximate"] else ""
    return (f"{100 * f:.1f} % of posterior draws put at least one cell ({len(check['cells'])} "
            f"cells in all) where the FE table is good only to a few percent, next to FE points "
            f"whose force curve snapped ({region}){approx}: treat k_c-driven numbers with care.")
