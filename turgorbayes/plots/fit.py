"""Figures of a fit written by ``turgorbayes fit``: ``corner.png`` and ``fit.png``.

Thin wrappers of :mod:`turgorbayes.plots`, kept for the ``fit`` command: ``fit.png`` is the
paper's Fig. 3 (:func:`turgorbayes.plots.fig3`), ``corner.png`` the joint posterior
(:func:`turgorbayes.plots.corner_plot`).
"""

from turgorbayes.plots import PUBLISHED, corner_plot, fig3

__all__ = ["PUBLISHED", "plot_corner", "plot_fit"]


def plot_corner(result, path, reference=PUBLISHED):
    """Write the corner plot of gamma, E0t, R0, P_phys (published values as red lines).

    Parameters
    ----------
    result : turgorbayes.results.FitResult
    path : path-like
        PNG file to write.
    reference : dict, optional
        Values (SI) drawn as lines (the paper's table by default; None for none).
    """
    corner_plot(result, reference=reference, path=path)


def plot_fit(result, path, reference=PUBLISHED):
    """Write the paper's Fig. 3 of a fit (R_c and k_c against pressure, posterior bands).

    Parameters
    ----------
    result : turgorbayes.results.FitResult
    path : path-like
    reference : dict, optional
        Published parameters drawn as a dotted curve (None: omit).
    """
    fig3(result, reference=reference, seed=result.seed, path=path)
