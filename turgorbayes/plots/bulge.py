"""Figure 2b of the paper: the bulge's dimensionless force against indentation, stiffness inset."""

import numpy as np

from turgorbayes import bulge

__all__ = ["plot_bulge_response"]


def plot_bulge_response(alpha=bulge.DEFAULT_ALPHA, ax=None, path=None, f_max=0.3, n=300):
    r"""Plot ``F/(P R_b^2)`` against ``h/R_b`` from the liquid-membrane bulge model.

    The inset shows the reduced secant stiffness ``k_b/(P R_b)`` against ``h/R_b``, with the
    paper's quoted band 0.35-0.38 (Deng, Sun & Shaevitz 2011, Fig. 2b) shaded.

    Parameters
    ----------
    alpha : float [rad]
        Cone half-angle.
    ax : matplotlib.axes.Axes, optional
        Axes to draw into; default a new 4.5 x 3.6 inch figure.
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

        ax = Figure(figsize=(4.5, 3.6), layout="constrained").add_subplot()
    f = np.linspace(0.0, f_max, n)
    y = bulge.reduced_depth(f, alpha)
    ax.plot(y, f, color="C0", lw=1.8)
    ax.set_xlabel(r"indentation $h/R_b$")
    ax.set_ylabel(r"force $F/(P R_b^2)$")
    ax.set_xlim(0, y[-1])
    ax.set_ylim(0, f_max)
    inset = ax.inset_axes([0.17, 0.56, 0.38, 0.36])
    k = f[1:] / y[1:]
    inset.plot(y[1:], k, color="C3", lw=1.4)
    inset.axhspan(0.35, 0.38, color="0.85", zorder=0)
    inset.set_xlabel(r"$h/R_b$", fontsize="small", labelpad=1)
    inset.set_ylabel(r"$k_b/(P R_b)$", fontsize="small", labelpad=1)
    inset.tick_params(labelsize="x-small")
    inset.set_xlim(0, y[-1])
    inset.set_ylim(0, 0.5)
    if path is not None:
        ax.figure.savefig(path, dpi=150)
    return ax
