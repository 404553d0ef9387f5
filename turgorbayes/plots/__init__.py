"""Every figure of turgorbayes, shared by the notebook, ``turgorbayes report`` and ``fit``.

A fit is passed as a :class:`turgorbayes.workflows.fit.FitResult` or as the DataTree of
``posterior.nc``; figures are :class:`matplotlib.figure.Figure` objects made without pyplot,
and each function takes ``path`` to write a PNG. Reference: Deng, Sun & Shaevitz, Phys. Rev.
Lett. 107, 158101 (2011).
"""

from turgorbayes._moved import deprecated_attributes
from turgorbayes.plots.bulge import plot_bulge_response as fig2b
from turgorbayes.plots.curves import curve_figure, write_curve_figures
from turgorbayes.plots.fit import (
    DISPLAY,
    PUBLISHED,
    corner_plot,
    fig3,
    rank_plot,
    rank_pvalues,
    residual_plot,
    standardized_residuals,
    trace_plot,
)
from turgorbayes.plots.misfit import misfit_plot
from turgorbayes.plots.surrogate import plot_reduced_stiffness as fig4

#: Names that moved to :mod:`turgorbayes.workflows` (they compute and write, draw nothing);
#: deprecated here, removed in 0.4.0.
_MOVED_NAMES = {
    **dict.fromkeys(("QUANTILES", "CurveBands", "baseline_bands", "binned_means", "curve_bands",
                     "extended_bands", "pressure_grid", "read_bands", "write_bands",
                     "write_extended_bands"), "turgorbayes.workflows.bands"),
    "posterior_tree": "turgorbayes.workflows.fit_data",
}
__getattr__ = deprecated_attributes(__name__, _MOVED_NAMES)

__all__ = [
    "DISPLAY",
    "PUBLISHED",
    "corner_plot",
    "curve_figure",
    "fig2b",
    "fig3",
    "fig4",
    "misfit_plot",
    "rank_plot",
    "rank_pvalues",
    "residual_plot",
    "standardized_residuals",
    "trace_plot",
    "write_curve_figures",
]
