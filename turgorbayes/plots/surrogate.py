"""Figure 4 of the paper: the finite-element reduced stiffness against the inflation number."""

import numpy as np

__all__ = ["plot_reduced_stiffness"]

_HATCH = dict(facecolor="none", edgecolor="tab:red", hatch="///", lw=0.0, alpha=0.55)


def _snapping_points(s):
    """FE points whose force curve snaps (:func:`turgorbayes.surrogate.table.force_drops`)."""
    from turgorbayes.surrogate.table import force_drops

    if "F_N" not in s.table or "h_m" not in s.table:
        return []
    return force_drops(s.table)


def _draw_unreliable(ax, s):
    """Hatch the ``x`` range of each unreliable box; cross the snapping FE points.

    Returns
    -------
    list
        Legend handles (empty when the table flags nothing).
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    boxes = s.unreliable_boxes
    for box in boxes:
        ax.axvspan(*box["x"], zorder=0, **_HATCH)
    snaps = _snapping_points(s)
    if snaps:
        x = [p["x"] for p in snaps]
        y = [float(s.table["k_over_PR"].sel(ratio=p["ratio"]).values[
            np.argmin(np.abs(s.table["x_actual"].sel(ratio=p["ratio"]).values - p["x"]))])
            for p in snaps]
        ax.plot(x, y, "x", color="tab:red", ms=8, mew=2, zorder=5)
    if not boxes:
        return []
    ratios = ", ".join(f"{b['ratio'][0]:g}-{b['ratio'][1]:g}" for b in boxes)
    return [Patch(label=f"unreliable for $E_\\parallel/E_\\perp$ = {ratios}: the FE wall\n"
                        "buckles under the tip (Surrogate.reliable is False)", **_HATCH),
            Line2D([], [], ls="none", marker="x", color="tab:red", ms=8, mew=2,
                   label="FE force curve snaps (force_drops)")][:1 + bool(snaps)]


def _plane_inset(ax, s):
    """Inset: the table's (x, ratio) grid with the unreliable boxes hatched."""
    from matplotlib.patches import Rectangle

    inset = ax.inset_axes([0.1, 0.1, 0.3, 0.27])
    X, Rt = np.meshgrid(s.grid["x"], s.grid["ratio"])
    inset.plot(X.ravel(), Rt.ravel(), ".", color="0.4", ms=2)
    for box in s.unreliable_boxes:
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
    as lines over its domain (as in Fig. 4 of Deng, Sun & Shaevitz 2011). The region the table
    itself flags as unreliable (:attr:`Surrogate.unreliable_boxes`: grid cells next to an FE
    point whose force curve snaps because the axially soft wall buckles under the tip;
    ``docs/fem.md``, "The unreliable corner") is hatched over its ``x`` range, the snapping FE
    points are crossed, and an inset shows the boxes in the (``x``, anisotropy) plane. A table
    without force curves flags nothing and nothing is hatched.

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
        ``ax.get_legend()`` is the anisotropy legend; the unreliable region's legend is a
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
    handles = _draw_unreliable(ax, s)
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
