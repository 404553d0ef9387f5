"""The conditions figure: each condition's P_phys posterior and each contrast's difference.

Reads the DataTree of a fit with conditions (its attribute ``conditions``, written by
:func:`turgorbayes.workflows.conditions.fit_conditions`, names each condition's variables).
"""

import json

import numpy as np

from turgorbayes.plots.style import figure, rc, save
from turgorbayes.workflows.fit_data import flat_draws, plot_title, posterior_tree

__all__ = ["condition_draws", "conditions_figure", "wall_assumption"]


def condition_draws(fit, quantity="P_phys"):
    """``{condition: draws (SI)}`` of ``quantity`` in file order, and the reference's name.

    Raises
    ------
    ValueError
        The fit has no conditions.
    """
    dt = posterior_tree(fit)
    spec = dt.attrs.get("conditions")
    if not spec:
        raise ValueError("this fit has no conditions (no condition column in its data)")
    spec = json.loads(spec)
    return ({n: flat_draws(dt, spec["variables"][n][quantity]) for n in spec["names"]},
            spec["reference"])


def wall_assumption(fit):
    """The walls a fit's contrasts assume, in words (one line)."""
    spec = json.loads(posterior_tree(fit).attrs.get("conditions") or "{}")
    prior = spec.get("wall_prior") or {}
    if spec.get("series") and all(spec["series"]):
        return "each condition's wall (E0t) measured by its own osmotic series"
    if not prior:
        return "assumes one wall for every condition (a wall change would read as turgor)"
    return ("walls may differ: " + ", ".join(
        ("ln E0t ratio" if q == "E0t" else "gamma difference") + f" sd {sd:g}"
        for q, sd in prior.items()) + " (prior; measured only with bulged cells)")


def conditions_figure(fit, path=None):
    """Left: each condition's P_phys posterior [kPa]; right: the posterior of each
    condition's P_phys minus the reference's [kPa], its 90 % interval shaded.

    Parameters
    ----------
    fit : turgorbayes.workflows.fit.FitResult or xarray.DataTree
    path : path-like, optional
        PNG to write.

    Returns
    -------
    matplotlib.figure.Figure
    """
    draws, ref = condition_draws(fit)
    with rc():
        fig = figure((8.0, 3.2))
        left, right = fig.subplots(1, 2)
        for name, x in draws.items():
            left.hist(x / 1e3, bins=60, density=True, histtype="step", lw=1.5, label=name)
        left.set_xlabel(r"$P_\mathrm{phys}$ [kPa]")
        left.set_ylabel("posterior density")
        left.legend(frameon=False)
        for name, x in draws.items():
            if name == ref:
                continue
            d = (x - draws[ref]) / 1e3
            lo, hi = np.quantile(d, [0.05, 0.95])
            right.hist(d, bins=60, density=True, histtype="step", lw=1.5,
                       label=f"{name} - {ref} (90 % shaded)")
            right.axvspan(lo, hi, alpha=0.15)
        right.axvline(0.0, color="k", lw=0.8)
        right.set_xlabel(r"difference of $P_\mathrm{phys}$ [kPa]")
        right.legend(frameon=False)
        right.set_title(wall_assumption(fit), fontsize="small", wrap=True)
        fig.suptitle(plot_title(posterior_tree(fit)))
    return save(fig, path)
