"""Long titles of the curve and force-map figures stay on the canvas.

A rejected force map's figure once had its title cut at both sides above an empty canvas: the
title (file, cell, reason) was wrapped at a fixed number of characters, wider than the figure.
These tests render figures with long names and reasons to PNG and check, from the pixels and
from the renderer's text extents, that the title lies inside the canvas and above the axes.
Expected values come from the geometry alone: a PNG written without ``bbox_inches`` is
``figsize x dpi`` pixels, the figure's background is white (no ink), and a text inside the
canvas leaves the canvas' outermost rows and columns white.
"""

import functools
import io

import pytest
from matplotlib.image import imread

from turgorbayes.curves.reduce import CurveResult, CurveTrace, reduce_curve
from turgorbayes.plots.curves import curve_figure
from turgorbayes.plots.forcemap import map_figure
from turgorbayes.simulation.curves import cell_force, synthetic_curve, write_curve

#: A file name of 160 characters without a space (folders and a date), and a long reason.
LONG_NAME = "experiments/2026-11-20_turgor_series/" * 4 + "cell_0123_map.jpk-force-map"
LONG_REASON = ("could not read " + "/very/long/folder" * 8 + "/file.jpk-force: afmformats: "
               "FileFormatNotSupportedError: unknown format, " + "and more words " * 12)
R_C = 540e-9


def _title(fig):
    (title,) = [t for t in fig.texts if t.get_gid() == "title"]
    return title


def _pixels(fig):
    """The figure as written: PNG at the figure's dpi, RGB in 0-1."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=fig.dpi)
    buf.seek(0)
    return imread(buf)[..., :3]


def _check_inside(fig):
    """The PNG has the figure's size, no ink on its border; the title's (and any reason box's)
    extent lies inside the figure."""
    img = _pixels(fig)
    width, height = fig.get_size_inches() * fig.dpi
    assert img.shape[:2] == (round(height), round(width))  # figsize x dpi, no cropping
    ink = (img < 1.0).any(axis=2)  # white background: anything else is ink
    assert ink.any()
    # text running off the canvas leaves ink on its outermost rows and columns
    assert not ink[0].any() and not ink[-1].any(), "ink on the top or bottom edge"
    assert not ink[:, 0].any() and not ink[:, -1].any(), "ink on the left or right edge"
    renderer = fig.canvas.get_renderer()
    canvas = (0.0, 0.0, width, height)  # pixels, origin bottom left
    texts = [_title(fig)] + [t for ax in fig.axes for t in ax.texts if t.get_gid() == "reason"]
    for text in texts:
        box = text.get_window_extent(renderer)
        if text.get_bbox_patch() is not None:
            box = text.get_bbox_patch().get_window_extent(renderer)
        assert canvas[0] <= box.x0 and box.x1 <= canvas[2], (text.get_gid(), box, canvas)
        assert canvas[1] <= box.y0 and box.y1 <= canvas[3], (text.get_gid(), box, canvas)
    return _title(fig).get_window_extent(renderer)


def test_rejected_map_without_pixels_keeps_its_long_title_on_the_canvas():
    """The reported case: a force map rejected before it had pixels (an empty canvas)."""
    from types import SimpleNamespace

    result = SimpleNamespace(ok=False, status="unreadable_file", detail=LONG_REASON, n_curves=0,
                             pixels=None, section=None, dome=None, target="cell")
    fig = map_figure(result, LONG_NAME, "c0123")
    _check_inside(fig)
    text = _title(fig).get_text()
    assert text.startswith("experiments/") and "REJECTED: unreadable_file" in text
    # the whole reason is in the box below the title
    (box,) = [t for t in fig.axes[0].texts if t.get_gid() == "reason"]
    assert box.get_text().replace("\n", "").replace(" ", "") == \
        f"unreadable_file: {LONG_REASON}".replace(" ", "")


def test_unreadable_curve_keeps_its_long_title_on_the_canvas(tmp_path):
    result = CurveResult("unreadable_file", LONG_REASON)
    fig = curve_figure(result, CurveTrace(), LONG_NAME, "c0123", "cell")
    _check_inside(fig)
    # every character of the name is shown (wrapped, not cut)
    assert LONG_NAME in _title(fig).get_text().replace("\n", "")


@pytest.fixture(scope="module")
def too_shallow(tmp_path_factory):
    """A cell curve read with a radius whose R_c/20 is never reached: rejected, two panels."""
    path = tmp_path_factory.mktemp("title") / "c.tab"
    write_curve(synthetic_curve(functools.partial(cell_force, k_c=0.017, h_ref=R_C / 20),
                                2 * R_C / 20, seed=3), path)
    trace = CurveTrace()
    result = reduce_curve(path, "cell", 10 * R_C, trace=trace)
    assert result.status == "too_shallow" and trace.contact is not None
    return result, trace


def test_two_panel_figure_puts_a_long_title_above_its_axes(too_shallow):
    result, trace = too_shallow
    fig = curve_figure(result, trace, LONG_NAME, "c0123", "cell")
    assert len(fig.axes) == 2
    title = _check_inside(fig)
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:  # the axes with their tick labels, legend and offset text
        assert ax.get_tightbbox(renderer).y1 < title.y0
    # a long name takes more lines than a short one: the axes give way, the title is not cut
    short = curve_figure(result, trace, "c.tab", "c0123", "cell")
    assert _title(fig).get_text().count("\n") > _title(short).get_text().count("\n")
    assert fig.axes[0].get_position().y1 < short.axes[0].get_position().y1
