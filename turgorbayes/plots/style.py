"""Figure helpers shared by every plot: a Figure without pyplot, fonts, number formats, axes."""

import math
import textwrap

import numpy as np

from turgorbayes._moved import deprecated_attributes
from turgorbayes.formatting import format_p_value

__all__ = ["FONT", "PN_PER_NM", "REJECTED_COLOR", "figure", "fit_text", "format_p",
           "log_axis", "rc", "save", "wrap_text"]

#: Names that moved out of this module (:mod:`turgorbayes._moved`).
__getattr__ = deprecated_attributes(__name__, {"format_pm": "turgorbayes.formatting"})

#: Font sizes of the fit figures.
FONT = {"font.size": 11, "axes.labelsize": 12, "legend.fontsize": 9.5}
#: Colour of a rejected curve's marks and reason (curve figures, force maps).
REJECTED_COLOR = "#c00"
#: N/m per pN/nm (the stiffness axes are in pN/nm = mN/m).
PN_PER_NM = 1e-3
#: Mantissas of the labelled minor ticks of a log pressure axis (2 and 5 per decade).
_LABELLED_MINOR = (2, 5)


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


def format_p(p, n_rep=None):
    """A p-value for figure text: ``"p = 0.412"``, ``"p < 0.0014"``, ``"p = n/a"``.

    The number is :func:`turgorbayes.formatting.format_p_value`'s (the reports' rule):
    a p-value counted from ``n_rep`` replicates is only bounded, by ``1/n_rep``, where none
    or all of them are as extreme; ``n_rep`` None for an analytic p-value.
    """
    text = format_p_value(p, n_rep)
    return "p " + text if text[0] in "<>" else "p = " + text


def _minor_label(value, _pos=None):
    """Label a minor tick of a log axis only at mantissas 2 and 5 (``"2"``, ``"0.5"``, ``"20"``)."""
    if value <= 0:
        return ""
    mantissa = value / 10 ** math.floor(math.log10(value) + 1e-9)
    return f"{value:g}" if any(abs(mantissa - m) < 1e-6 for m in _LABELLED_MINOR) else ""


def log_axis(ax, which="x"):
    """Log scale labelled at 1, 10, 100 (major) and at 2, 5, 20, 50 (minor ticks).

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    which : {"x", "y"}
    """
    from matplotlib.ticker import FuncFormatter, LogLocator

    axis = ax.xaxis if which == "x" else ax.yaxis
    (ax.set_xscale if which == "x" else ax.set_yscale)("log")
    axis.set_major_locator(LogLocator(base=10.0))
    axis.set_major_formatter(FuncFormatter(lambda v, _pos=None: f"{v:g}"))
    axis.set_minor_locator(LogLocator(base=10.0, subs=np.arange(2.0, 10.0)))
    axis.set_minor_formatter(FuncFormatter(_minor_label))
    ax.tick_params(axis=which, which="minor", labelsize="small")


def wrap_text(text, width):
    """``text`` broken into lines of at most ``width`` characters (a rejection's reason)."""
    return "\n".join(textwrap.wrap(text, width)) or text


def _wrapped(blocks, chars):
    """Each block's paragraphs wrapped at ``chars`` characters, a block longer than its
    ``max_lines`` cut there with `` ...`` (the whole text is elsewhere: curves.csv, the page)."""
    lines = []
    for text, max_lines in blocks:
        block = [line for para in text.split("\n") for line in wrap_text(para, chars).split("\n")]
        if max_lines is not None and len(block) > max_lines:
            block = block[:max_lines]
            block[-1] = block[-1][:max(chars - 4, 1)].rstrip() + " ..."
        lines += block
    return "\n".join(lines)


def fit_text(artist, blocks, width, renderer):
    """Set ``artist``'s text to ``blocks`` wrapped so that it is at most ``width`` pixels wide.

    Titles name files, cells and a rejection's reason, of any length; a fixed number of
    characters per line fits one font and figure width only. Here the text is measured by
    ``renderer`` and wrapped again, at fewer characters, until its extent fits.

    Parameters
    ----------
    artist : matplotlib.text.Text
    blocks : sequence of (str, int or None)
        Text (``\n`` starts a new line) and the most lines it may take (None: no limit).
    width : float
        Pixels, at the renderer's dpi.
    renderer : matplotlib.backend_bases.RendererBase

    Returns
    -------
    matplotlib.transforms.Bbox
        The text's extent in pixels.
    """
    chars = max(len(line) for text, _ in blocks for line in text.split("\n"))
    while True:
        artist.set_text(_wrapped(blocks, chars))
        extent = artist.get_window_extent(renderer)
        if extent.width <= width or chars <= 8:
            return extent
        # the widest line's mean glyph width gives the next try; at least one character fewer
        chars = max(8, min(chars - 1, int(chars * width / extent.width)))
