"""Figure of one whole force map: the height map with the fitted axis and the crest, and the
cross-section with the fitted arc (docs/curves.md, Whole force maps).
"""

import numpy as np

from turgorbayes.curves.crosssection import arc_height
from turgorbayes.formatting import format_pm
from turgorbayes.plots.style import REJECTED_COLOR, figure, fit_text, rc, save

__all__ = ["map_figure"]


def _height_panel(ax, result):
    """Height above the substrate [nm] (contact height less its median where there is no
    cross-section) on the grid, with no-contact pixels, the axis, arc and crest pixels."""
    p, s = result.pixels, result.section
    z = s.elevation if s is not None else p.height - np.nanmedian(p.height)
    grid = np.full((p.iy.max() + 1, p.ix.max() + 1), np.nan)
    grid[p.iy, p.ix] = z * 1e9
    x0, y0 = p.x[p.ix == p.ix.min()].mean(), p.y[p.iy == p.iy.min()].mean()
    extent = np.array([p.ix.min() - 0.5, p.ix.max() + 0.5, p.iy.min() - 0.5, p.iy.max() + 0.5])
    um = 1e6 * np.concatenate([x0 + (extent[:2] - p.ix.min()) * p.pitch,
                               y0 + (extent[2:] - p.iy.min()) * p.pitch])
    image = ax.imshow(grid[p.iy.min():, p.ix.min():], origin="lower", extent=um, cmap="viridis",
                      interpolation="nearest", gid="height_map")
    ax.figure.colorbar(image, ax=ax, label="height [nm]" if s is not None
                       else "contact height - median [nm]", shrink=0.85, pad=0.02)
    bad = ~np.isfinite(p.height)
    ax.plot(p.x[bad] * 1e6, p.y[bad] * 1e6, "x", color=REJECTED_COLOR, ms=7, mew=1.5,
            label=f"no contact ({bad.sum()})", gid="no_contact")
    if s is not None:
        _axis_marks(ax, result)
    if result.dome is not None:
        _dome_marks(ax, result)
    ax.set_xlabel("x [µm]")
    ax.set_ylabel("y [µm]")
    ax.legend(loc="upper left", fontsize="small", framealpha=0.8)


def _axis_marks(ax, result):
    p, s = result.pixels, result.section
    half = s.half_length
    ends = np.array([-half, half])
    ax.plot((s.center[0] + ends * np.cos(s.angle)) * 1e6, (s.center[1] + ends * np.sin(s.angle)) * 1e6,
            "w--", lw=1.2, label="fitted axis", gid="axis")
    ax.plot(p.x[s.arc] * 1e6, p.y[s.arc] * 1e6, "o", mfc="none", mec="w", ms=6,
            label=f"arc fit ({s.arc.sum()})", gid="arc_pixels")
    ok = np.array([c.accepted for c in result.crest], bool)
    crest = result.crest_index
    ax.plot(p.x[crest[ok]] * 1e6, p.y[crest[ok]] * 1e6, "s", mfc="none", mec="C3", ms=9, mew=1.5,
            label=f"crest curves ({ok.sum()} ok)", gid="crest_pixels")
    if (~ok).any():
        ax.plot(p.x[crest[~ok]] * 1e6, p.y[crest[~ok]] * 1e6, "s", mfc="none", mec="k", ms=9,
                mew=1.5, ls="none", label=f"crest rejected ({(~ok).sum()})", gid="crest_rejected")


def _dome_marks(ax, result):
    """The bulge's dome pixels (triangles), its fitted apex (plus) and the apex curves (stars;
    black: rejected)."""
    p, d = result.pixels, result.dome
    ax.plot(p.x[d.dome] * 1e6, p.y[d.dome] * 1e6, "^", mfc="none", mec="C1", ms=7,
            label=f"bulge dome ({d.dome.sum()})", gid="dome_pixels")
    ax.plot([d.apex_x * 1e6], [d.apex_y * 1e6], "+", color="C1", ms=12, mew=2,
            label=f"apex, R_b = {format_pm(d.R_b * 1e9, d.R_b_err * 1e9)} nm", gid="bulge_apex")
    idx = d.apex_index
    ok = np.array([c.accepted for c in result.apex], bool) if result.apex else np.ones(idx.size, bool)
    ax.plot(p.x[idx[ok]] * 1e6, p.y[idx[ok]] * 1e6, "*", mfc="none", mec="C3", ms=14, mew=1.5,
            ls="none", label=f"apex curves ({ok.sum()} ok)", gid="apex_pixels")
    if (~ok).any():
        ax.plot(p.x[idx[~ok]] * 1e6, p.y[idx[~ok]] * 1e6, "*", mfc="none", mec="k", ms=14,
                mew=1.5, ls="none", label=f"apex rejected ({(~ok).sum()})", gid="apex_rejected")


def _section_panel(ax, result):
    """Elevation [nm] against distance from the axis [nm] in the cell's middle, the arc fit."""
    s = result.section
    mid = s.middle & ~s.arc
    ax.plot(s.d[mid] * 1e9, s.elevation[mid] * 1e9, "o", mfc="none", color="0.5",
            label="middle, not fitted")
    ax.plot(s.d[s.arc] * 1e9, s.elevation[s.arc] * 1e9, "o", color="C0", label="fitted")
    ax.plot(s.d[s.crest] * 1e9, s.elevation[s.crest] * 1e9, "s", mfc="none", mec="C3", ms=9,
            label="crest")
    d = np.linspace(-1.2 * s.R, 1.2 * s.R, 401)
    ax.plot(d * 1e9, arc_height(d, s.R) * 1e9, "k-", lw=1,
            label=f"arc R = {format_pm(s.R * 1e9, s.R_err * 1e9)} nm", gid="arc_fit")
    ax.axvspan(s.d[s.crest].min() * 1e9 if s.crest.any() else 0, s.d[s.crest].max() * 1e9
               if s.crest.any() else 0, color="C3", alpha=0.1, lw=0)
    ax.set_xlabel("distance from the axis [nm]")
    ax.set_ylabel("height above substrate [nm]")
    ax.legend(loc="lower center", fontsize="small")


#: Space [pt] between the figure's edge and the title's text.
_EDGE_PT = 5.0


def _title(fig, result, name, cell_id):
    """File, cell, number of curves; then R_c, k_c (or k_b) or the rejection's reason in red
    (at most three lines; the whole reason is in curves.csv and on the overview page), wrapped
    to the figure's width (constrained layout puts the axes below it)."""
    head = f"{name}  ·  cell {cell_id}  ·  force map, {result.n_curves} curves"
    color = "k"
    if result.ok and result.target == "bulge":
        text = (f"k_b = {format_pm(result.k * 1e3, result.k_err * 1e3)} mN/m at h_b = "
                f"{result.depth * 1e9:.1f} nm  ·  {result.detail}")
        blocks = [(f"{head}, bulge", None), (text, None)]
    elif result.ok:
        s = result.section
        text = (f"R_c = {format_pm(s.R * 1e9, s.R_err * 1e9)} nm (fit), axis "
                f"{np.rad2deg(s.angle):.1f}°  ·  k_c = {format_pm(result.k * 1e3, result.k_err * 1e3)}"
                f" mN/m at {result.R_c / 20 * 1e9:.1f} nm  ·  {result.detail}")
        blocks = [(head, None), (text, None)]
    else:
        blocks, color = [(head, None), (f"REJECTED: {result.status}: {result.detail}", 3)], REJECTED_COLOR
    title = fig.suptitle("", color=color, fontsize="medium", gid="title")
    edge = _EDGE_PT / 72 * fig.dpi
    fit_text(title, blocks, fig.bbox.width - 2 * edge, fig.canvas.get_renderer())


def _reason_box(ax, result):
    """A map with no pixels: the whole reason, in a box filling the empty panel."""
    ax.set_axis_off()
    box = ax.text(0.5, 0.5, "", transform=ax.transAxes, ha="center", va="center",
                  color=REJECTED_COLOR, gid="reason",
                  bbox={"boxstyle": "round", "fc": "#fde2e2", "ec": REJECTED_COLOR})
    fig = ax.figure
    fit_text(box, [(f"{result.status}: {result.detail}", None)], 0.9 * fig.bbox.width,
             fig.canvas.get_renderer())


def map_figure(result, name="", cell_id="", path=None):
    """Figure of a reduced force map.

    Left: the contact heights on the grid (above the fitted substrate plane), no-contact
    pixels crossed, the fitted long axis, the pixels of the arc fit (circles) and the crest
    curves (squares; black: rejected). Right: the middle's heights against the distance from
    the axis with the fitted arc ``R + sqrt(R^2 - d^2)``. A rejected map shows what was
    reached (the heights alone, or only the reason in a box) with the reason in red. The title
    is wrapped to the figure's width.

    Parameters
    ----------
    result : turgorbayes.curves.forcemap.ForceMapResult
    name, cell_id : str
        For the title.
    path : path-like, optional
        Write the PNG here.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    with rc():
        panels = 0 if result.pixels is None else 1 if result.section is None else 2
        fig = figure((12.5, 5.0) if panels == 2 else (6.5, 5.0))
        FigureCanvasAgg(fig)  # measures the title's text
        axes = fig.subplots(1, max(panels, 1), squeeze=False)[0]
        if panels == 0:
            _reason_box(axes[0], result)
        else:
            _height_panel(axes[0], result)
        if panels == 2:
            _section_panel(axes[1], result)
        _title(fig, result, name, cell_id)
        return save(fig, path, dpi=100)
