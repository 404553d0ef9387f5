"""Figure 4 of the paper: the finite-element reduced stiffness against the inflation number."""

import numpy as np

__all__ = ["plot_reduced_stiffness"]


def plot_reduced_stiffness(s, ax=None, path=None, n_curve=200):
    """Plot ``k_c/(P R_c)`` against ``P R_c/(E_perp t)``, one curve per anisotropy.

    FE points are drawn as markers at the FE's own inflation number, the interpolated surrogate
    as lines over its domain (as in Fig. 4 of Deng, Sun & Shaevitz 2011).

    Parameters
    ----------
    s : turgorbayes.surrogate.Surrogate
        From :func:`turgorbayes.surrogate.load`.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into; default a new 5 x 3.8 inch figure.
    path : str or path-like, optional
        If given, the figure is written there as PNG (150 dpi).
    n_curve : int
        Points per interpolated curve.

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib as mpl

    if ax is None:
        from matplotlib.figure import Figure

        ax = Figure(figsize=(5.0, 3.8), layout="constrained").add_subplot()
    table = s.table.transpose("ratio", "x", ...)
    ratios = s.grid["ratio"]
    colors = mpl.colormaps["viridis"](np.linspace(0.0, 0.9, ratios.size))
    xx = np.geomspace(*s.domain["x"], n_curve)
    for j, (ratio, color) in enumerate(zip(ratios, colors, strict=True)):
        ax.plot(table["x_actual"].values[j], table["k_over_PR"].values[j], "o", ms=4,
                color=color, label=None)
        ax.plot(xx, s(xx, ratio, warn=False), "-", lw=1.4, color=color, label=f"{ratio:g}")
    ax.set_xscale("log")
    ax.set_xlabel(r"$P R_c/(E_\perp t)$")
    ax.set_ylabel(r"$k_c/(P R_c)$")
    ax.legend(title=r"$E_\parallel/E_\perp$", frameon=False, fontsize="small")
    ax.set_title("FE points (markers) and surrogate (lines)", fontsize="medium")
    if path is not None:
        ax.figure.savefig(path, dpi=150)
    return ax
