r"""The misfit band: how far a misfit the criticism cannot explain could move the headline.

When the verdict is ``partly_explained`` or ``unexplained``, the data hold extra scatter whose
cause is not known. Scatter of unknown cause may come with a shift shared by every reading of
a kind (a drifting calibration, a contact point read late on every curve, a wall law wrong in
the same direction for every cell), and such a shift moves the parameters without adding
scatter: the data cannot tell it from a change of ``P_phys`` or ``E0t``. In the spirit of
Kennedy and O'Hagan's model discrepancy (J. R. Stat. Soc. B 63, 425, 2001), whose constant
part is confounded with the calibration parameters, each observable ``o`` (``R_c``, ``k_c``)
gets an offset shared by every cell's reading (an instrument-level bias acts on both groups),

.. math:: \delta_o \sim N(0, s_o^2)

in its log readings, ``s_o`` the larger of the two groups' extra scatter that the generic
description (``discrepancy``) finds in it: a misfit that scatters readings by ``s_o`` may as
well shift them by as much. The offsets move the baseline's posterior mode by the linear
response

.. math:: \Delta u_o = \Sigma\, \partial_{\delta_o} \nabla_u \ln p(u^*; y(\delta_o)),

``Sigma`` the inverse Hessian at the mode ``u*`` (the Laplace covariance), the derivative a
central difference at ``delta_o = +-s_o``; each parameter ``theta`` then carries a bias of sd
``sqrt(sum_o Delta theta_o^2)`` (in ``ln theta`` for the positive ones, in ``theta`` for
``gamma``), which :func:`turgorbayes.criticism.stacking.stacked_summary` adds to the model
average's draws (``bias_sd``). The band is zero where the generic description finds no extra
scatter, and it is applied only when the verdict says the misfit is not (fully) explained: a
``no_misfit`` or ``explained`` headline is the model average unchanged (docs/effects.md, "The
misfit band").
"""

import dataclasses

import numpy as np

from turgorbayes.criticism.stacking import LINEAR
from turgorbayes.inference.mode import value_and_gradient

__all__ = ["WIDENED_STATUSES", "band_sd", "offset_shifts", "sentence", "shifted_cells"]

#: Verdicts whose headline carries the band.
WIDENED_STATUSES = ("partly_explained", "unexplained")


def shifted_cells(cells, quantity, log_offset):
    """``cells`` with ``quantity`` (``R_c`` or ``k_c``) of every cell multiplied by
    ``exp(log_offset)`` (their reported errors kept)."""
    values = np.asarray(getattr(cells, quantity), float) * np.exp(log_offset)
    return dataclasses.replace(cells, **{quantity: values})


def offset_shifts(post, cells, build, scales):
    """Each observable's shift of every parameter for an offset of one ``s`` (module
    docstring).

    Parameters
    ----------
    post : turgorbayes.inference.engine.Posterior
        The baseline's posterior (``model``, ``u_map``, ``cov``).
    cells : turgorbayes.cells.table.CellData
        The data it was fitted to.
    build : callable
        ``build(cells) -> model``: the same model on other readings.
    scales : dict
        ``{observable: s}``: the generic description's extra scatter of the observable's
        readings (:meth:`turgorbayes.effects.discrepancy.Discrepancy.channel_scales`).

    Returns
    -------
    dict
        ``{parameter: {observable: shift}}``: in ``ln theta`` (``theta`` for gamma), for
        every observable with ``s > 0``.
    """
    model, u = post.model, np.asarray(post.u_map, float)
    base = model.to_physical(u[None])
    out = {name: {} for name in base}
    for quantity, s in scales.items():
        if not s > 0:
            continue
        grads = [value_and_gradient(build(shifted_cells(cells, quantity, sign * s)), u)[1]
                 for sign in (1.0, -1.0)]
        du = np.asarray(post.cov, float) @ np.nan_to_num(0.5 * (grads[0] - grads[1]))
        moved = model.to_physical((u + du)[None])
        for name in base:
            a, b = float(base[name][0]), float(moved[name][0])
            out[name][quantity] = b - a if name in LINEAR else float(np.log(b / a))
    return out


def band_sd(shifts):
    """``{parameter: sd}``: the root sum of squares of each parameter's channel shifts."""
    return {name: float(np.sqrt(sum(d * d for d in by.values()))) for name, by in shifts.items()}


def sentence(band):
    """What the band adds to the verdict, in words (an applied band, :func:`band_sd` in
    ``band["sd"]``)."""
    sd = band["sd"]
    rough = ("" if band.get("converged", True) else " Its size comes from a generic description "
             "whose sampler did not converge, so it is rough.")
    return ("The misfit's cause is not known, so the quoted values carry the bias a shared "
            "offset of the readings of that size could hide (Kennedy-O'Hagan's model "
            f"discrepancy): sd {sd['P_phys']:.1%} for P_phys, {sd['E0t']:.1%} for E0t, "
            f"{sd['R0']:.1%} for R0 and {sd['gamma']:.2f} for gamma (the misfit band, "
            "parameters.widened)." + rough)
