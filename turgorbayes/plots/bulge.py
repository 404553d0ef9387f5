"""Figure 2b of the paper: the bulge's dimensionless force against indentation, stiffness inset."""

import numpy as np

from turgorbayes.physics import bulge

__all__ = ["plot_bulge_response"]


def plot_bulge_response(alpha=bulge.DEFAULT_ALPHA, ax=None, path=None, f_max=0.3, n=300):
    r"""Plot ``F/(P R_b^2)`` against ``h/R_b`` from the liquid-membrane bulge model.

    The inset shows the reduced secant stiffness ``k_b/(P R_b)`` against ``h/R_b``, with the
    paper's quoted range 0.35-0.38 (Deng, Sun & Shaevitz 2011, Fig. 2b) shaded grey; a legend
    names the curves and the band. Axes are labelled in words with their symbols.

    Parameters
    ----------
    alpha : float [rad]
        Cone half-angle.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into; default a new 5 x 4.2 inch figure.
    path : str or path-like, optional
        Write the figure there as PNG (150 dpi).
    f_max : float [-]
        Largest reduced force ``F/(P R_b^2)`` drawn.
    n : int
        Points per curve.

    Returns
    -------
    matplotlib.axes.Axes
        The main axes; the inset is ``ax.child_axes[0]``.
    """
    if ax is None:
        from matplotlib.figure import Figure

        ax = Figure(figsize=(5.0, 4.2), layout="constrained").add_subplot()
    f = np.linspace(0.0, f_max, n)
    y = bulge.reduced_depth(f, alpha)
    ax.plot(y, f, color="C0", lw=1.8)
    ax.set_xlabel(r"indentation / bulge radius, $h/R_b$")
    ax.set_ylabel(r"force / (pressure $\times$ bulge radius$^2$), $F/(P R_b^2)$")
    ax.set_xlim(0, y[-1])
    ax.set_ylim(0, f_max)
    _stiffness_inset(ax, f, y)
    _legend(ax)
    if path is not None:
        ax.figure.savefig(path, dpi=150)
    return ax


def _stiffness_inset(ax, f, y):
    """Inset: the secant stiffness ``k_b/(P R_b) = f/(h/R_b)`` and the paper's 0.35-0.38."""
    inset = ax.inset_axes([0.15, 0.56, 0.38, 0.36])
    inset.plot(y[1:], f[1:] / y[1:], color="C3", lw=1.4)
    inset.axhspan(0.35, 0.38, color="0.8", zorder=0)
    inset.set_xlabel(r"$h/R_b$", fontsize="small", labelpad=1)
    inset.set_ylabel(r"stiffness $k_b/(P R_b)$", fontsize="small", labelpad=1)
    inset.tick_params(labelsize="x-small")
    inset.set_xlim(0, y[-1])
    inset.set_ylim(0, 0.5)
    return inset


def _legend(ax):
    """Legend of the main curve, the inset's curve and its grey band (proxy artists)."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    handles = [Line2D([], [], color="C0", lw=1.8, label="force (liquid-membrane bulge)"),
               Line2D([], [], color="C3", lw=1.4, label="inset: secant stiffness"),
               Patch(color="0.8", label="inset: 0.35-0.38, the range\nquoted by Deng et al. 2011")]
    ax.legend(handles=handles, loc="lower right", fontsize="x-small", frameon=False)
