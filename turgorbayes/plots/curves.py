"""Figure of one reduced force curve: the approach with its baseline and contact point, and force
against indentation with the fit window and the secant (docs/curves.md, Looking at the curves).
"""

import dataclasses
import logging
import re
import time
from pathlib import Path

import numpy as np

from turgorbayes.curves.stiffness import indentation
from turgorbayes.formatting import format_pm
from turgorbayes.plots.style import REJECTED_COLOR, fit_text, rc
from turgorbayes.progress import progress as show_progress

__all__ = ["DPI", "FIGURE_DIR", "CurveCanvas", "CurveFigureWriter", "curve_figure", "figure_name",
           "reading_text", "shown_result", "write_curve_figures"]

logger = logging.getLogger(__name__)

#: Folder of the per-curve PNGs, beside ``curves.csv``.
FIGURE_DIR = "curve_figures"
#: Colour of a rejection's reason (the HTML page's warning red).
_BASELINE_COLOR, _CONTACT_COLOR, _SECANT_COLOR = "0.55", "C3", "C1"


def figure_name(row):
    """File name of a manifest row's figure: ``0012_curves_c001_cell_0.png``.

    The manifest line makes it unique (two rows may name files of the same name in different
    folders); the file's path, folders included, keeps it readable, and a curve of a force map
    past the first adds its index (``0013_map_c2.png``).

    Parameters
    ----------
    row : turgorbayes.curves.manifest.ManifestRow

    Returns
    -------
    str
    """
    stem = re.sub(r"[^A-Za-z0-9._-]+", "_", str(Path(row.name).with_suffix(""))).strip("._")
    index = row.curve_index
    return f"{row.line:04d}_{stem or 'curve'}" + (f"_curve{index}" if index else "") + ".png"


def shown_result(row, result):
    """``result`` with the curve's path in its ``detail`` written as in the manifest.

    afmformats names the file by its full path; figures and the overview page stay movable
    with the manifest's relative name instead.

    Parameters
    ----------
    row : turgorbayes.curves.manifest.ManifestRow
    result : turgorbayes.curves.reduce.CurveResult

    Returns
    -------
    CurveResult
    """
    detail = result.detail
    for path in (str(Path(row.file).resolve()), str(row.file)):
        detail = detail.replace(path, row.name)
    return dataclasses.replace(result, detail=detail)


# ------------------------------------------------------------------------------ layout
#: Resolution of the PNGs [dots per inch]: a two-panel figure is 1000 x 400 pixels.
DPI = 100
#: Figure size [in] by number of panels: force against height and against indentation (2),
#: the approach alone (1, no contact found), the reason alone (0, the file was not read).
_SIZES = {2: (10.0, 4.0), 1: (6.5, 4.0), 0: (6.5, 4.0)}
#: Fixed side and bottom margins (figure fractions): room for 7-character force ticks
#: ("-0.0025") and the axis labels. The top margin follows the title's height.
_MARGINS = {2: {"left": 0.09, "right": 0.985, "bottom": 0.13, "wspace": 0.28},
            1: {"left": 0.14, "right": 0.985, "bottom": 0.13}, 0: {}}
#: Space [pt] between the figure's edge and the title, and between the title and the axes
#: (an axis' offset text, e.g. "1e-3", sits above its axes).
_EDGE_PT, _GAP_PT = 5.0, 9.0


def _errorbar_update(container, x, y, xerr):
    """Move a one-point horizontal errorbar (marker and bar) to ``x +- xerr``, ``y``."""
    marker, _caps, (bars,) = container.lines
    marker.set_data([x], [y])
    bars.set_segments([[[x - xerr, y], [x + xerr, y]]])
    return [[x - xerr, y], [x + xerr, y]]


def _span_update(patch, x0, x1):
    """Move an ``axvspan`` to ``x0 .. x1`` (data)."""
    patch.set_x(x0)
    patch.set_width(x1 - x0)


def _rescale(ax, extra):
    """Autoscale to the lines and spans (as when they were first drawn), the error bars
    ``extra`` [(x, y), ...] included."""
    ax.relim()
    if extra:
        ax.update_datalim(extra)
    ax.autoscale_view()


class _Drawing:
    """One reused figure of a layout (number of panels and which marks a curve has): its
    artists are made once and each curve replaces their data, their labels and the title."""

    def __init__(self, key):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        panels, self.baseline, self.depth, self.secant = key
        self.panels = panels
        self.fig = Figure(figsize=_SIZES[panels], dpi=DPI)
        FigureCanvasAgg(self.fig)
        axes = self.fig.subplots(1, max(panels, 1), squeeze=False)[0]
        self.fig.subplots_adjust(**_MARGINS[panels])
        self.title = self.fig.suptitle("", fontsize="medium", gid="title", va="top",
                                       y=1 - _EDGE_PT / 72 / _SIZES[panels][1])
        self.labels = {}  # which legend text shows which changing label
        if panels == 0:
            self._make_reason(axes[0])
        else:
            self._make_approach(axes[0])
        if panels == 2:
            self._make_indentation(axes[1])

    # -- made once
    def _make_reason(self, ax):
        ax.set_axis_off()
        self.reason = ax.text(0.5, 0.5, "", transform=ax.transAxes, ha="center", va="center",
                              color=REJECTED_COLOR, gid="reason",
                              bbox={"boxstyle": "round", "fc": "#fde2e2", "ec": REJECTED_COLOR})

    def _make_approach(self, ax):
        """Recorded force [nN] against height [um]: baseline region and fit, contact point."""
        self.approach = ax.plot([], [], lw=0.6, color="C0", label="approach")[0]
        if self.baseline:
            self.base_span = ax.axvspan(0, 1, color=_BASELINE_COLOR, alpha=0.2, lw=0,
                                        gid="baseline_region", label="baseline region")
            self.base_line = ax.plot([], [], ls="--", lw=1, color="k", gid="baseline",
                                     label="baseline (fit, extended)")[0]
        if self.panels == 2:
            self.contact = ax.errorbar([0.0], [0.0], xerr=[0.0], fmt="o", ms=6, mfc="none",
                                       color=_CONTACT_COLOR, gid="contact", label="\0contact")
        ax.invert_xaxis()  # the approach runs left to right
        ax.set_xlabel("height [µm] (approach →)")
        ax.set_ylabel("force [nN]")
        self._legend(ax)

    def _make_indentation(self, ax):
        """Force [nN] against indentation [nm] near contact: window, secant, reading depth."""
        self.force = ax.plot([], [], ".", ms=1.5, color="C0", label="force")[0]
        self.contact_h = ax.errorbar([0.0], [0.0], xerr=[0.0], fmt="o", ms=6, mfc="none",
                                     color=_CONTACT_COLOR, gid="contact_h", label="contact (h = 0)")
        if self.depth:
            self.depth_line = ax.axvline(0.0, ls=":", color="k", lw=1, gid="depth_target",
                                         label="\0depth")
        if self.secant:  # fit window shaded; the secant F = k h from contact to the reading depth
            self.window = ax.axvspan(0, 1, color=_SECANT_COLOR, alpha=0.18, lw=0, gid="window",
                                     label="fit window")
            self.secant_line = ax.plot([0.0, 1.0], [0.0, 1.0], color=_SECANT_COLOR, lw=1.8,
                                       gid="secant", label="\0secant")[0]
            self.reading = ax.errorbar([0.0], [0.0], xerr=[0.0], fmt="s", ms=5,
                                       color=_SECANT_COLOR, gid="reading")
        ax.axhline(0.0, color=_BASELINE_COLOR, lw=0.6)
        ax.set_xlabel("indentation h [nm]")
        ax.set_ylabel("force [nN]")
        self._legend(ax)

    def _legend(self, ax):
        legend = ax.legend(loc="upper left", fontsize="small")
        for text in legend.get_texts():
            if text.get_text().startswith("\0"):
                self.labels[text.get_text()[1:]] = text

    def _label(self, artist, key, label):
        artist.set_label(label)
        self.labels[key].set_text(label)

    # -- per curve
    def draw(self, result, trace, name, cell_id, target):
        """Put one curve in the figure (:func:`curve_figure`) and return the figure."""
        axes = self.fig.axes
        if self.panels == 0:
            renderer = self.fig.canvas.get_renderer()
            fit_text(self.reason, [(f"{result.status}: {result.detail}", None)],
                     0.9 * self.fig.bbox.width, renderer)
        else:
            self._approach(axes[0], trace)
        if self.panels == 2:
            self._indentation(axes[1], trace)
        self._title(result, name, cell_id, target)
        return self.fig

    def _approach(self, ax, trace):
        a, base, found = trace.approach, trace.baseline, trace.contact
        height = (a.height0 - a.z) * 1e6
        self.approach.set_data(height, a.force * 1e9)
        bars = []
        if self.baseline:
            _span_update(self.base_span, (a.height0 - base.z_end) * 1e6, height[0])
            self.base_line.set_data(height, base(a.z) * 1e9)
        if self.panels == 2:
            f0 = base(found.z0) + found.offset
            bars = _errorbar_update(self.contact, (a.height0 - found.z0) * 1e6, f0 * 1e9,
                                    found.z0_err * 1e6)
            self._label(self.contact, "contact", f"contact {(a.height0 - found.z0) * 1e9:.1f} ± "
                                                 f"{found.z0_err * 1e9:.2g} nm")
        _rescale(ax, bars)

    def _indentation(self, ax, trace):
        h, force = _indentation(trace)
        sec, found = trace.secant, trace.contact
        near = h >= -0.6 * max(float(np.max(h)), 0.0) - 5 * found.z0_err
        self.force.set_data(h[near] * 1e9, force[near] * 1e9)
        bars = _errorbar_update(self.contact_h, 0.0, 0.0, found.z0_err * 1e9)
        if self.depth:
            depth = trace.depth_target * 1e9
            self.depth_line.set_xdata([depth, depth])
            self._label(self.depth_line, "depth", f"reading depth {depth:.1f} nm")
        if self.secant:  # force [nN] over indentation [nm] is N/m: the line's slope is k itself
            _span_update(self.window, sec.window[0] * 1e9, sec.window[1] * 1e9)
            depth_nm = sec.depth * 1e9
            self.secant_line.set_data([0.0, depth_nm], [0.0, sec.k * depth_nm])
            self._label(self.secant_line, "secant",
                        f"secant k = {format_pm(sec.k * 1e3, sec.k_err * 1e3)} mN/m")
            bars += _errorbar_update(self.reading, depth_nm, sec.k * depth_nm, sec.depth_err * 1e9)
        _rescale(ax, bars)

    def _title(self, result, name, cell_id, target):
        """File, cell and target; then ``k`` at its depth, or the rejection's reason in red (at
        most two lines: the whole reason is in curves.csv and on the overview page). Wrapped to
        the figure's width; the axes start below it."""
        head = f"{name}  ·  " + (f"cell {cell_id} " if cell_id else "") + f"({target})"
        if result.accepted:
            blocks = [(head, None), (f"{reading_text(result)}  ·  {result.status}", None)]
            color = "k"
        else:
            blocks = [(head, None), (f"REJECTED: {result.status}: {result.detail}", 2)]
            color = REJECTED_COLOR
        self.title.set_color(color)
        fig, edge = self.fig, _EDGE_PT / 72 * DPI
        extent = fit_text(self.title, blocks, fig.bbox.width - 2 * edge, fig.canvas.get_renderer())
        top = (extent.y0 - _GAP_PT / 72 * DPI) / fig.bbox.height
        if self.panels == 0:
            fig.axes[0].set_position([0.0, 0.0, 1.0, top])
        else:
            fig.subplots_adjust(top=top)


class CurveCanvas:
    """Draws curve figures (:func:`curve_figure`) into figures made once and reused.

    A new Matplotlib figure with its axes, ticks and legends costs more than drawing it; here
    each layout (two panels, one, or the reason alone; with or without a baseline, a reading
    depth, a secant) gets one figure when first needed, and every later curve of that layout
    only replaces the data of its lines, spans and markers, its legend labels and its title.
    What a figure shows does not depend on the curves drawn before it.
    """

    def __init__(self):
        self._drawings = {}

    def draw(self, result, trace, name="", cell_id="", target="cell", path=None):
        """:func:`curve_figure` in a reused figure (valid until the next call).

        Returns
        -------
        matplotlib.figure.Figure
        """
        panels = 0 if trace.approach is None else 1 if trace.contact is None else 2
        key = (panels, panels > 0 and trace.baseline is not None,
               panels == 2 and trace.depth_target is not None, panels == 2 and trace.secant is not None)
        with rc():
            if key not in self._drawings:
                self._drawings[key] = _Drawing(key)
            fig = self._drawings[key].draw(result, trace, name, cell_id, target)
            if path is not None:  # zlib level 1: 4x faster than the default 6, files 1.3x larger
                fig.canvas.print_png(path, pil_kwargs={"compress_level": 1})
        return fig


def reading_text(result):
    """What an accepted curve gave: ``k = 17.08 ± 0.23 mN/m at h = 27.0 nm`` (glass reference
    curves: ``glass slope 1.012 ± 0.003``); empty for a rejected curve.

    Parameters
    ----------
    result : turgorbayes.curves.reduce.CurveResult

    Returns
    -------
    str
    """
    if not result.accepted:
        return ""
    slope = result.slope
    if not np.isfinite(result.k) and np.isfinite(slope):
        return f"glass slope {format_pm(slope, result.slope_err)}"
    depth = f"h = {result.depth * 1e9:.1f} nm" if result.depth_err == 0 else \
        f"h_b = {format_pm(result.depth * 1e9, result.depth_err * 1e9)} nm"
    return f"k = {format_pm(result.k * 1e3, result.k_err * 1e3)} mN/m at {depth}"


def _indentation(trace):
    """Indentation ``h`` [m] and force ``F`` [N] from contact on (the reduction's step 4)."""
    found = trace.contact
    force = trace.force - found.offset
    return indentation(trace.z, force, trace.approach.spring_constant, found.z0), force


def curve_figure(result, trace, name="", cell_id="", target="cell", path=None):
    """Figure of one reduced curve: what the reduction saw and where it read ``k``.

    Left: the recorded force [nN] against height [um] (the approach runs left to right), the
    baseline region shaded, the fitted baseline dashed, the contact point (circle, with its
    error as a horizontal bar). Right: force against indentation ``h`` [nm] from contact, the
    stiffness fit window shaded, the secant ``F = k h`` from contact to the depth where ``k``
    is read (``R_c/20`` on cells, dotted; ``h_b`` on bulges, square). A rejected curve shows
    what was reached before the rejection (the approach alone if no contact was found), and
    its reason in red in the title (and in a box when the file could not be read). The title
    is wrapped to the figure's width. Many curves: :class:`CurveCanvas` reuses its figures.

    Parameters
    ----------
    result : turgorbayes.curves.reduce.CurveResult
    trace : turgorbayes.curves.reduce.CurveTrace
        Filled by the same reduction (:func:`turgorbayes.curves.pipeline.reduce_row`).
    name, cell_id, target : str
        For the title (the manifest's file, cell and target).
    path : path-like, optional
        Write the PNG here.

    Returns
    -------
    matplotlib.figure.Figure
    """
    return CurveCanvas().draw(result, trace, name, cell_id, target, path)


def _same(a, b):
    """Whether two CurveResults agree (NaN equal to NaN)."""
    numbers = ("k", "k_err", "depth", "depth_err", "contact_height", "contact_err", "slope")
    return a.status == b.status and all(
        np.array_equal(getattr(a, n), getattr(b, n), equal_nan=True) for n in numbers)


class CurveFigureWriter:
    """Writes curve figures into one folder, one reused :class:`CurveCanvas` for all.

    Called as ``writer(row, result, trace)``, it is the ``on_curve`` of
    :func:`turgorbayes.curves.pipeline.reduce_manifest`: every curve is then drawn while it is
    reduced, from the arrays at hand, and needs no second reduction
    (``turgorbayes curves --figures all``). :func:`write_curve_figures` draws the rest.

    Parameters
    ----------
    folder : path-like
        Created at the first figure.

    Attributes
    ----------
    names : dict
        Manifest line -> file name of each figure written.
    seconds : float
        Wall time spent drawing and writing.
    """

    def __init__(self, folder):
        self.folder, self.names, self.seconds = Path(folder), {}, 0.0
        self._canvas = CurveCanvas()

    def __call__(self, row, result, trace):
        start = time.perf_counter()
        self.folder.mkdir(parents=True, exist_ok=True)
        name = figure_name(row)
        if row.whole_map:  # the reduced map (result: its ForceMapResult)
            from turgorbayes.plots.forcemap import map_figure

            map_figure(result, row.name, row.cell_id, self.folder / name)
        else:
            self._canvas.draw(shown_result(row, result), trace, row.name, row.cell_id, row.target,
                              self.folder / name)
        self.names[row.line] = name
        self.seconds += time.perf_counter() - start


def write_curve_figures(result, folder, progress=False, only=None, writer=None):
    """Write one PNG per curve of a manifest (:func:`curve_figure`, :func:`figure_name`).

    Each curve not yet drawn by ``writer`` is reduced again with a
    :class:`~turgorbayes.curves.reduce.CurveTrace` (the reduction keeps no arrays); the re-run
    must give the reported result, else a warning is logged and the figure shows the re-run. A
    whole force map's row gets the map's figure (:func:`turgorbayes.plots.forcemap.map_figure`)
    from its kept reduction.

    Parameters
    ----------
    result : turgorbayes.curves.pipeline.ManifestResult
    folder : path-like
        Created if needed.
    progress : bool
        Show progress (:func:`turgorbayes.progress.progress`).
    only : sequence of bool, optional
        Draw only these rows (e.g. :func:`turgorbayes.curves.pipeline.problem_rows`); default
        every row.
    writer : CurveFigureWriter, optional
        Passed to the reduction as its ``on_curve``: the rows it drew are not drawn again.

    Returns
    -------
    names : list of str or None
        File name of each curve's figure inside ``folder``, in manifest order (None for a row
        not drawn).
    seconds : float
        Wall time of the re-reductions and figures (``writer``'s drawing included).
    """
    from turgorbayes.curves.pipeline import reduce_row
    from turgorbayes.curves.reduce import CurveTrace

    writer = writer or CurveFigureWriter(folder)
    Path(folder).mkdir(parents=True, exist_ok=True)
    only = [True] * len(result.results) if only is None else list(only)
    todo = [(row, reported) for row, reported, draw in zip(result.manifest.rows, result.results, only,
                                                            strict=True)
            if draw and row.line not in writer.names]
    start, before = time.perf_counter(), writer.seconds
    for row, reported in show_progress(todo, desc="figures", unit="curve", enabled=progress):
        if row.whole_map:  # the reduced map is kept: its figure needs no re-run
            writer(row, result.maps[row.line], None)
            continue
        trace = CurveTrace()
        again = reduce_row(row, result.settings, trace)
        if not _same(again, reported):
            logger.warning("%s: re-reduced for its figure, it gave %s, not the reported %s (file "
                           "changed?); the figure shows the re-run", row.name, again, reported)
        writer(row, again, trace)
    names = [writer.names.get(row.line) if draw else None
             for row, draw in zip(result.manifest.rows, only, strict=True)]
    return names, before + time.perf_counter() - start
