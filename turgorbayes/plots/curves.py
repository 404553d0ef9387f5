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
from turgorbayes.plots.style import REJECTED_COLOR, figure, format_pm, rc, save, wrap_text

__all__ = ["FIGURE_DIR", "curve_figure", "figure_name", "reading_text", "shown_result",
           "write_curve_figures"]

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


# ------------------------------------------------------------------------------ panels
def _approach_panel(ax, trace):
    """Recorded force [nN] against height [um]: baseline region and fit, contact point."""
    a, base, found = trace.approach, trace.baseline, trace.contact
    height = (a.height0 - a.z) * 1e6
    ax.plot(height, a.force * 1e9, lw=0.6, color="C0", label="approach")
    if base is not None:
        ax.axvspan((a.height0 - base.z_end) * 1e6, height[0], color=_BASELINE_COLOR, alpha=0.2,
                   lw=0, gid="baseline_region", label="baseline region")
        ax.plot(height, base(a.z) * 1e9, ls="--", lw=1, color="k", gid="baseline",
                label="baseline (fit, extended)")
    if found is not None:
        f0 = base(found.z0) + found.offset
        ax.errorbar([(a.height0 - found.z0) * 1e6], [f0 * 1e9], xerr=[found.z0_err * 1e6],
                    fmt="o", ms=6, mfc="none", color=_CONTACT_COLOR, gid="contact",
                    label=f"contact {(a.height0 - found.z0) * 1e9:.1f} ± {found.z0_err * 1e9:.2g} nm")
    ax.invert_xaxis()  # the approach runs left to right
    ax.set_xlabel("height [µm] (approach →)")
    ax.set_ylabel("force [nN]")
    ax.legend(loc="upper left", fontsize="small")


def _indentation(trace):
    """Indentation ``h`` [m] and force ``F`` [N] from contact on (the reduction's step 4)."""
    found = trace.contact
    force = trace.force - found.offset
    return indentation(trace.z, force, trace.approach.spring_constant, found.z0), force


def _indentation_panel(ax, trace):
    """Force [nN] against indentation [nm] near contact: window, secant, reading depth."""
    h, force = _indentation(trace)
    sec, found = trace.secant, trace.contact
    h_max = float(np.max(h))
    near = h >= -0.6 * max(h_max, 0.0) - 5 * found.z0_err
    ax.plot(h[near] * 1e9, force[near] * 1e9, ".", ms=1.5, color="C0", label="force")
    ax.errorbar([0.0], [0.0], xerr=[found.z0_err * 1e9], fmt="o", ms=6, mfc="none",
                color=_CONTACT_COLOR, gid="contact_h", label="contact (h = 0)")
    if trace.depth_target is not None:
        ax.axvline(trace.depth_target * 1e9, ls=":", color="k", lw=1, gid="depth_target",
                   label=f"reading depth {trace.depth_target * 1e9:.1f} nm")
    if sec is not None:
        _secant(ax, sec)
    ax.axhline(0.0, color=_BASELINE_COLOR, lw=0.6)
    ax.set_xlabel("indentation h [nm]")
    ax.set_ylabel("force [nN]")
    ax.legend(loc="upper left", fontsize="small")


def _secant(ax, sec):
    """Fit window shaded; secant F = k h from contact to the reading depth, where k is read.

    Force [nN] over indentation [nm] is a slope in N/m, so the line's slope is ``k`` itself.
    """
    ax.axvspan(sec.window[0] * 1e9, sec.window[1] * 1e9, color=_SECANT_COLOR, alpha=0.18, lw=0,
               gid="window", label="fit window")
    depth_nm = sec.depth * 1e9
    ax.plot([0.0, depth_nm], [0.0, sec.k * depth_nm], color=_SECANT_COLOR, lw=1.8, gid="secant",
            label=f"secant k = {format_pm(sec.k * 1e3, sec.k_err * 1e3)} mN/m")
    ax.errorbar([depth_nm], [sec.k * depth_nm], xerr=[sec.depth_err * 1e9], fmt="s", ms=5,
                color=_SECANT_COLOR, gid="reading")


def _reason_box(ax, result):
    ax.set_axis_off()
    ax.set_position([0.0, 0.0, 1.0, 0.8])
    ax.text(0.5, 0.5, wrap_text(f"{result.status}: {result.detail}", 60), transform=ax.transAxes,
            ha="center", va="center", color=REJECTED_COLOR, gid="reason",
            bbox={"boxstyle": "round", "fc": "#fde2e2", "ec": REJECTED_COLOR})


def _title(fig, result, name, cell_id, target, width):
    """File, cell and target; then ``k`` at its depth, or the rejection's reason in red."""
    head = f"{name}  ·  " + (f"cell {cell_id} " if cell_id else "") + f"({target})"
    if result.ok:
        fig.suptitle(f"{head}\n{reading_text(result)}  ·  ok", fontsize="medium", gid="title")
    else:
        reason = wrap_text(f"REJECTED: {result.status}: {result.detail}", width).split("\n")
        if len(reason) > 2:  # the whole reason is in curves.csv and on the overview page
            reason = [reason[0], reason[1] + " ..."]
        fig.suptitle("\n".join([head, *reason]), color=REJECTED_COLOR, fontsize="medium", gid="title")


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
    if not result.ok:
        return ""
    slope = result.slope
    if not np.isfinite(result.k) and np.isfinite(slope):
        return f"glass slope {format_pm(slope, result.slope_err)}"
    depth = f"h = {result.depth * 1e9:.1f} nm" if result.depth_err == 0 else \
        f"h_b = {format_pm(result.depth * 1e9, result.depth_err * 1e9)} nm"
    return f"k = {format_pm(result.k * 1e3, result.k_err * 1e3)} mN/m at {depth}"


def curve_figure(result, trace, name="", cell_id="", target="cell", path=None):
    """Figure of one reduced curve: what the reduction saw and where it read ``k``.

    Left: the recorded force [nN] against height [um] (the approach runs left to right), the
    baseline region shaded, the fitted baseline dashed, the contact point (circle, with its
    error as a horizontal bar). Right: force against indentation ``h`` [nm] from contact, the
    stiffness fit window shaded, the secant ``F = k h`` from contact to the depth where ``k``
    is read (``R_c/20`` on cells, dotted; ``h_b`` on bulges, square). A rejected curve shows
    what was reached before the rejection (the approach alone if no contact was found), and
    its reason in red in the title (and in a box when the file could not be read).

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
    with rc():
        panels = 0 if trace.approach is None else 1 if trace.contact is None else 2
        fig = _frame(panels)
        axes = fig.axes
        if panels == 0:
            _reason_box(axes[0], result)
        else:
            _approach_panel(axes[0], trace)
        if panels == 2:
            _indentation_panel(axes[1], trace)
        _title(fig, result, name, cell_id, target, 110 if panels == 2 else 70)
        return save(fig, path, dpi=100)


def _frame(panels):
    """The figure and its 1 or 2 axes, with fixed margins.

    Constrained layout costs ~40 % of the time of a figure, which adds up over thousands of
    curves; this one layout needs no solver.
    """
    two = panels == 2
    fig = figure((10.0, 4.0) if two else (6.5, 4.0))
    fig.set_layout_engine(None)
    fig.subplots(1, 2 if two else 1)
    # room for 7-character force ticks ("-0.0025") and three title lines
    fig.subplots_adjust(left=0.09 if two else 0.14, right=0.985, bottom=0.13, top=0.82,
                        wspace=0.28)
    return fig


def _same(a, b):
    """Whether two CurveResults agree (NaN equal to NaN)."""
    numbers = ("k", "k_err", "depth", "depth_err", "contact_height", "contact_err", "slope")
    return a.status == b.status and all(
        np.array_equal(getattr(a, n), getattr(b, n), equal_nan=True) for n in numbers)


def write_curve_figures(result, folder, progress=False, only=None):
    """Write one PNG per curve of a manifest (:func:`curve_figure`, :func:`figure_name`).

    Each curve is reduced again with a :class:`~turgorbayes.curves.reduce.CurveTrace` (the
    reduction keeps no arrays); the re-run must give the reported result, else a warning is
    logged and the figure shows the re-run. A whole force map's row gets the map's figure
    (:func:`turgorbayes.plots.forcemap.map_figure`) from its kept reduction.

    Parameters
    ----------
    result : turgorbayes.curves.pipeline.ManifestResult
    folder : path-like
        Created if needed.
    progress : bool
        Show a tqdm progress bar.
    only : sequence of bool, optional
        Draw only these rows (e.g. :func:`turgorbayes.curves.pipeline.problem_rows`); default
        every row.

    Returns
    -------
    names : list of str or None
        File name of each curve's figure inside ``folder``, in manifest order (None for a row
        not drawn).
    seconds : float
        Wall time of the re-reductions and figures.
    """
    from tqdm import tqdm

    from turgorbayes.curves.pipeline import reduce_row
    from turgorbayes.curves.reduce import CurveTrace

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    only = [True] * len(result.results) if only is None else list(only)
    pairs = list(zip(result.manifest.rows, result.results, only, strict=True))
    names, start = [], time.perf_counter()
    for row, reported, draw in tqdm(pairs, desc="figures", unit="curve", disable=not progress):
        if not draw:
            names.append(None)
            continue
        if row.whole_map:  # the reduced map is kept: its figure needs no re-run
            from turgorbayes.plots.forcemap import map_figure

            names.append(figure_name(row))
            map_figure(result.maps[row.line], row.name, row.cell_id, folder / names[-1])
            continue
        trace = CurveTrace()
        again = reduce_row(row, result.settings, trace)
        if not _same(again, reported):
            logger.warning("%s: re-reduced for its figure, it gave %s, not the reported %s (file "
                           "changed?); the figure shows the re-run", row.name, again, reported)
        names.append(figure_name(row))
        curve_figure(shown_result(row, again), trace, row.name, row.cell_id, row.target,
                     folder / names[-1])
    return names, time.perf_counter() - start
