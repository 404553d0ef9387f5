"""Figure 4 of the paper: the finite-element reduced stiffness against the inflation number."""

import numpy as np

__all__ = ["plot_reduced_stiffness"]

_HATCH = dict(facecolor="none", edgecolor="tab:red", hatch="///", lw=0.0, alpha=0.55)


def _buckled_points(s):
    """``(x_actual, k/PR)`` of the buckled FE points (:func:`turgorbayes.surrogate.buckled_points`)."""
    from turgorbayes.surrogate.table import buckled_points

    t = s.table.transpose("ratio", "x", ...)
    return [(float(t["x_actual"].values[j, i]), float(t["k_over_PR"].values[j, i]))
            for j, i in buckled_points(t)]


def _draw_buckled(ax, s):
    """Hatch the ``x`` range of each buckled box; cross the buckled FE points.

    Returns
    -------
    list
        Legend handles (empty when the table flags nothing).
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    boxes = s.buckled_boxes
    for box in boxes:
        ax.axvspan(*box["x"], zorder=0, **_HATCH)
    points = _buckled_points(s)
    if points:
        ax.plot(*zip(*points, strict=True), "x", color="tab:red", ms=8, mew=2, zorder=5)
    if not boxes:
        return []
    where = "; ".join(f"{b['ratio'][0]:g}-{b['ratio'][1]:g} at x > {b['x'][0]:.2g}" for b in boxes)
    return [Patch(label=f"no value for $E_\\parallel/E_\\perp$ = {where}:\nthe FE wall "
                        "buckles under the tip (Surrogate.buckled; s is NaN)", **_HATCH),
            Line2D([], [], ls="none", marker="x", color="tab:red", ms=8, mew=2,
                   label="buckled FE point (its force falls before R/20)")][:1 + bool(points)]


def _plane_inset(ax, s):
    """Inset: the table's (x, ratio) grid with the buckled boxes hatched."""
    from matplotlib.patches import Rectangle

    inset = ax.inset_axes([0.3, 0.6, 0.24, 0.27])  # above the curves, left of the legend
    X, Rt = np.meshgrid(s.grid["x"], s.grid["ratio"])
    inset.plot(X.ravel(), Rt.ravel(), ".", color="0.4", ms=2)
    for box in s.buckled_boxes:
        (x0, x1), (r0, r1) = box["x"], box["ratio"]
        inset.add_patch(Rectangle((x0, r0), x1 - x0, r1 - r0, **(_HATCH | {"lw": 1.0})))
    inset.set_xscale("log")
    inset.set_xlabel(r"$P R_c/(E_\perp t)$", fontsize="x-small", labelpad=1)
    inset.set_ylabel(r"$E_\parallel/E_\perp$", fontsize="x-small", labelpad=1)
    inset.tick_params(labelsize="xx-small")
    inset.set_title("FE grid", fontsize="x-small", pad=2)
    return inset


def plot_reduced_stiffness(s, ax=None, path=None, n_curve=200):
    """Plot ``k_c/(P R_c)`` against ``P R_c/(E_perp t)``, one curve per anisotropy.

    FE points are drawn as markers at the FE's own inflation number, the interpolated surrogate
    as lines over its domain (as in Fig. 4 of Deng, Sun & Shaevitz 2011); the lines have gaps
    where the table has no value. The buckled region (:attr:`Surrogate.buckled_boxes`: grid
    cells next to an FE point whose axially soft wall buckles under the tip before R/20;
    ``docs/fem.md``, "The buckled corner") is hatched over its ``x`` range, the buckled FE
    points are crossed, and an inset shows the boxes in the (``x``, anisotropy) plane. A table
    without buckled points hatches nothing.

    Parameters
    ----------
    s : turgorbayes.surrogate.Surrogate
        From :func:`turgorbayes.surrogate.load`.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into; default a new 5.4 x 4.6 inch figure.
    path : str or path-like, optional
        If given, the figure is written there as PNG (150 dpi).
    n_curve : int
        Points per interpolated curve.

    Returns
    -------
    matplotlib.axes.Axes
        ``ax.get_legend()`` is the anisotropy legend; the buckled region's legend is a
        figure legend (``ax.figure.legends``, when the table flags a region).
    """
    import matplotlib as mpl

    if ax is None:
        from matplotlib.figure import Figure

        ax = Figure(figsize=(5.4, 4.6), layout="constrained").add_subplot()
    table = s.table.transpose("ratio", "x", ...)
    ratios = s.grid["ratio"]
    colors = mpl.colormaps["viridis"](np.linspace(0.0, 0.9, ratios.size))
    xx = np.geomspace(*s.domain["x"], n_curve)
    for j, (ratio, color) in enumerate(zip(ratios, colors, strict=True)):
        ax.plot(table["x_actual"].values[j], table["k_over_PR"].values[j], "o", ms=4,
                color=color, label=None)
        ax.plot(xx, s(xx, ratio, warn=False), "-", lw=1.4, color=color, label=f"{ratio:g}")
    handles = _draw_buckled(ax, s)
    ax.set_xscale("log")
    ax.set_xlabel(r"$P R_c/(E_\perp t)$")
    ax.set_ylabel(r"$k_c/(P R_c)$")
    if handles:
        ax.figure.legend(handles=handles, loc="outside lower center", fontsize="small",
                         frameon=False)
        _plane_inset(ax, s)
    ax.legend(title=r"$E_\parallel/E_\perp$", frameon=False, fontsize="small", ncol=2,
              loc="upper right", bbox_to_anchor=(0.86, 1.0))
    ax.set_title("FE points (markers) and surrogate (lines)", fontsize="medium")
    if path is not None:
        ax.figure.savefig(path, dpi=150)
    return ax
