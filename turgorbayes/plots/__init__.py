"""Every figure of turgorbayes, shared by the notebook, ``turgorbayes report`` and ``fit``.

A fit is passed as a :class:`turgorbayes.results.FitResult` or as the DataTree of
``posterior.nc``; figures are :class:`matplotlib.figure.Figure` objects made without pyplot,
and each function takes ``path`` to write a PNG. Reference: Deng, Sun & Shaevitz, Phys. Rev.
Lett. 107, 158101 (2011).
"""

from turgorbayes.plots.bands import (
    QUANTILES,
    CurveBands,
    baseline_bands,
    binned_means,
    curve_bands,
    extended_bands,
    pressure_grid,
    read_bands,
    write_bands,
    write_extended_bands,
)
from turgorbayes.plots.bulge import plot_bulge_response as fig2b
from turgorbayes.plots.curves import curve_figure, write_curve_figures
from turgorbayes.plots.data import posterior_tree
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

__all__ = [
    "DISPLAY",
    "PUBLISHED",
    "QUANTILES",
    "CurveBands",
    "baseline_bands",
    "binned_means",
    "corner_plot",
    "curve_bands",
    "curve_figure",
    "extended_bands",
    "fig2b",
    "fig3",
    "fig4",
    "misfit_plot",
    "posterior_tree",
    "pressure_grid",
    "rank_plot",
    "rank_pvalues",
    "read_bands",
    "residual_plot",
    "standardized_residuals",
    "trace_plot",
    "write_bands",
    "write_curve_figures",
    "write_extended_bands",
]
