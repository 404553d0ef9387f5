"""Figure helpers shared by every plot: a Figure without pyplot, font sizes, PNG output."""

__all__ = ["FONT", "PN_PER_NM", "figure", "rc", "save"]

#: Font sizes of the fit figures.
FONT = {"font.size": 11, "axes.labelsize": 12, "legend.fontsize": 9.5}
#: N/m per pN/nm (the stiffness axes are in pN/nm = mN/m).
PN_PER_NM = 1e-3


def figure(figsize):
    """A :class:`matplotlib.figure.Figure` with constrained layout, made without pyplot."""
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def rc():
    """Context manager setting :data:`FONT`."""
    import matplotlib as mpl

    return mpl.rc_context(FONT)


def save(fig, path, dpi=130):
    """Write ``fig`` as PNG to ``path`` (if not None); return ``fig``."""
    if path is not None:
        fig.savefig(path, dpi=dpi)
    return fig
