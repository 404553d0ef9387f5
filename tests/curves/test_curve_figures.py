"""Per-curve figures and the overview page of ``turgorbayes curves``.

References: the synthetic curves' truths (contact height, k_c at R_c/20 by construction of
``cell_force``), the numbers of a reduction run without a trace, ``curves.csv`` as written by
the table writer, and the files on disk.
"""

import csv
import functools
import shutil
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np
import pytest
from matplotlib.colors import to_hex
from matplotlib.lines import Line2D
from numpy.testing import assert_allclose

from turgorbayes.cli import main
from turgorbayes.curves.reduce import CurveTrace, reduce_curve
from turgorbayes.plots.curves import REJECTED_COLOR, curve_figure
from turgorbayes.simulation.curves import bulge_force, cell_force, synthetic_curve, write_curve

K_C, R_C = 0.017, 540e-9  # cell body: secant k_c at R_c/20 by construction
P, R_B, H_B = 10e3, 500e-9, 110e-9  # bulge: P [Pa], R_b and h_b [m]


def _artist(ax, gid, kind=object):
    found = [a for a in ax.get_children() if a.get_gid() == gid and isinstance(a, kind)]
    assert len(found) == 1, (gid, found)
    return found[0]


def _x_extent(patch):
    """Data x-range of an axvspan patch (Rectangle or Polygon)."""
    verts = patch.get_patch_transform().transform(patch.get_path().vertices)
    return verts[:, 0].min(), verts[:, 0].max()


@pytest.fixture(scope="module")
def curves(tmp_path_factory):
    """A cell-body curve (indented to 2 R_c/20) and a bulge curve (to h_b) written through
    afmformats, with their truths (as the conftest writers, but once per module)."""
    folder = tmp_path_factory.mktemp("figs")
    laws = {"cell": (functools.partial(cell_force, k_c=K_C, h_ref=R_C / 20), 2 * R_C / 20, R_C),
            "bulge": (functools.partial(bulge_force, P=P, R_b=R_B), H_B, R_B)}
    out = {}
    for seed, (target, (law, depth, radius)) in enumerate(laws.items(), start=3):
        truth = synthetic_curve(law, depth, seed=seed)
        write_curve(truth, folder / f"{target}.tab")
        out[target] = (folder / f"{target}.tab", truth, radius)
    return out


def _reduced(curves, target):
    path, truth, radius = curves[target]
    trace = CurveTrace()
    result = reduce_curve(path, target, radius, trace=trace)
    assert result.ok, result.detail
    # the trace must not change the numbers: same result as a reduction without one
    assert result == reduce_curve(path, target, radius)
    return result, trace, truth


def test_contact_marker_sits_at_the_reported_contact_near_the_truth(curves):
    res, trace, truth = _reduced(curves, "cell")
    fig = curve_figure(res, trace, "c.tab", "c1", "cell")
    ax = fig.axes[0]
    marker = _artist(ax, "contact", Line2D)  # the errorbar's bars carry the gid too
    (x,), (y,) = marker.get_xdata(), marker.get_ydata()
    assert_allclose(x, res.contact_height * 1e6, rtol=1e-12)  # height axis in um
    assert abs(x - truth.contact_height * 1e6) < 2e-3  # within 2 nm of the synthetic truth
    # its error bar spans +- the reported contact error
    bars = next(c for c in ax.containers if marker in c.get_children())
    (seg,) = bars.lines[2][0].get_segments()
    assert_allclose(np.ptp(seg[:, 0]), 2 * res.contact_err * 1e6, rtol=1e-9)
    # the marker lies on the fitted baseline (+ the contact fit's offset), on the recorded force
    assert_allclose(y, (trace.baseline(trace.contact.z0) + trace.contact.offset) * 1e9, rtol=1e-12)
    lo, hi = _x_extent(_artist(ax, "baseline_region"))
    assert_allclose([lo, hi], sorted((trace.approach.height0 - np.array([0.0, trace.baseline.z_end]))
                                     * 1e6), rtol=1e-12)


@pytest.mark.parametrize("target", ["cell", "bulge"])
def test_secant_slope_is_the_reported_k_over_the_reported_window(curves, target):
    res, trace, truth = _reduced(curves, target)
    fig = curve_figure(res, trace, "x.tab", "c1", target)
    ax = fig.axes[1]
    secant = _artist(ax, "secant")
    (x0, x1), (y0, y1) = secant.get_xdata(), secant.get_ydata()
    assert (x0, y0) == (0.0, 0.0)  # through the contact point
    # force [nN] over indentation [nm] is N/m: the slope is k itself
    assert_allclose((y1 - y0) / (x1 - x0), res.k, rtol=1e-12)
    assert_allclose(x1, res.depth * 1e9, rtol=1e-12)  # up to where k is read
    assert_allclose(_x_extent(_artist(ax, "window")), np.array(res.window) * 1e9, rtol=1e-12)
    if target == "cell":  # read at R_c/20 (the input), and k near the law's k_c (2 %, test_recovery)
        assert_allclose(_artist(ax, "depth_target").get_xdata()[0], R_C / 20 * 1e9, rtol=1e-12)
        assert abs(res.k / K_C - 1) < 0.02
    else:  # read at the deepest point, near the h_b the curve was driven to
        assert abs(x1 / (H_B * 1e9) - 1) < 0.02
    assert _title(fig)[0].endswith("·  ok")


def _title(fig):
    title = _artist(fig, "title")
    return title.get_text(), to_hex(title.get_color())


def test_too_shallow_curve_shows_its_reason_in_red(curves):
    path, _, _ = curves["cell"]
    trace = CurveTrace()
    res = reduce_curve(path, "cell", 10 * R_C, trace=trace)  # R_c/20 = 270 nm, never reached
    assert res.status == "too_shallow"
    fig = curve_figure(res, trace, "c.tab", "c1", "cell")
    text, color = _title(fig)
    assert "REJECTED: too_shallow" in text and res.detail in text
    assert color == to_hex(REJECTED_COLOR) == "#cc0000"
    assert len(fig.axes) == 2  # the contact was found: indentation panel, no secant
    assert not [a for a in fig.axes[1].get_children() if a.get_gid() in ("secant", "window")]
    assert_allclose(_artist(fig.axes[1], "depth_target").get_xdata()[0], 10 * R_C / 20 * 1e9)


def test_curve_without_contact_shows_the_raw_approach_and_its_reason(tmp_path):
    flat = synthetic_curve(lambda h: 0.0 * np.asarray(h), 50e-9, seed=2)  # nothing to touch
    write_curve(flat, tmp_path / "flat.tab")
    trace = CurveTrace()
    res = reduce_curve(tmp_path / "flat.tab", "cell", R_C, trace=trace)
    assert res.status == "no_contact"
    fig = curve_figure(res, trace, "flat.tab", "c9", "cell")
    assert len(fig.axes) == 1
    (line,) = [a for a in fig.axes[0].get_lines() if a.get_label() == "approach"]
    assert_allclose(line.get_xdata(), flat.data["height (measured)"] * 1e6, rtol=1e-6)  # raw height
    text, color = _title(fig)
    assert f"REJECTED: no_contact: {res.detail}" in text.replace("\n", " ") and color == "#cc0000"


def test_unreadable_file_gets_a_figure_with_its_reason(tmp_path):
    (tmp_path / "bad.tab").write_text("garbage\n")
    trace = CurveTrace()
    res = reduce_curve(tmp_path / "bad.tab", "cell", R_C, trace=trace)
    fig = curve_figure(res, trace, "bad.tab", "c9", "cell", path=tmp_path / "bad.png")
    box = _artist(fig.axes[0], "reason")
    assert box.get_text().startswith("unreadable_file:") and to_hex(box.get_color()) == "#cc0000"
    assert (tmp_path / "bad.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ------------------------------------------------------------------------------ command line
class _Page(HTMLParser):
    """Rows of the curve table (class attribute, text) and every link of the page."""

    def __init__(self):
        super().__init__()
        self.rows, self.links, self._in_body = [], [], False

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        self._in_body |= tag == "tbody"
        if tag == "tr" and self._in_body:
            self.rows.append([attrs.get("class"), ""])
        self.links += [attrs[k] for k in ("href", "src") if k in attrs]

    def handle_endtag(self, tag):
        self._in_body &= tag != "tbody"

    def handle_data(self, data):
        if self._in_body and self.rows:
            self.rows[-1][1] += data + "|"


def _page(path):
    parser = _Page()
    parser.feed(path.read_text(encoding="utf-8"))
    return parser


def _run(argv):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    assert exit_info.value.code == 0


@pytest.fixture(scope="module")
def raw(tmp_path_factory, table):
    """2 bulged + 1 intact simulated cells' raw curves (3 per cell and target: 15 curves), plus
    an unreadable curve whose cell id needs escaping."""
    folder = tmp_path_factory.mktemp("raw")
    _run(["simulate", "--out", str(folder / "X.csv"), "--raw-curves", str(folder / "raw"),
          "--n-bulged", "2", "--n-intact", "1", "--P-range-kPa", "5", "25", "--seed", "4"])
    (folder / "raw" / "bad.tab").write_text("garbage\n")
    with open(folder / "raw" / "manifest.csv", "a") as fh:
        fh.write('bad.tab,"bad<1>&",cell,540,10,,,simulated\n')
    return folder / "raw"


@pytest.fixture(scope="module")
def run_out(raw, tmp_path_factory):
    out = tmp_path_factory.mktemp("out")
    _run(["curves", str(raw / "manifest.csv"), "--out", str(out / "cells.csv"), "--no-progress",
          "--figures", "all"])
    return out


def test_cli_writes_one_figure_per_curve_and_a_page_whose_links_resolve(run_out, tmp_path):
    table = list(csv.DictReader(open(run_out / "curves.csv")))
    assert len(table) == 3 * 3 + 3 * 2 + 1  # 3 cell curves per cell, 3 bulge curves per bulged
    pngs = sorted((run_out / "curve_figures").iterdir())
    assert len(pngs) == len(table)
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)
    page = _page(run_out / "curves.html")
    assert len(page.rows) == len(table)
    # rows in manifest order with their curve index, rejected ones (and only those) highlighted
    assert [r[1].split("|")[0] for r in page.rows] == [t["file"] for t in table]
    assert [r[1].split("|")[1] for r in page.rows] == [t["curve_index"] for t in table]
    assert [r[0] for r in page.rows] == ["accepted" if t["status"] == "ok" else "rejected"
                                         for t in table]
    assert "unreadable_file" in page.rows[-1][1]
    n_ok = sum(t["status"] == "ok" for t in table)
    text = (run_out / "curves.html").read_text(encoding="utf-8")
    assert f"{n_ok} of {len(table)} curves accepted" in text and n_ok == len(table) - 1
    assert "bad&lt;1&gt;&amp;" in text and "bad<1>" not in text  # escaped
    # every figure linked; links relative, resolving beside the page even after a move
    figures = {link for link in page.links if link.endswith(".png")}
    assert {f"curve_figures/{p.name}" for p in pngs} == figures
    assert str(run_out) not in text and str(raw) not in text
    moved = shutil.copytree(run_out, tmp_path / "moved")
    for link in page.links:
        url = urlparse(link)
        assert not url.scheme and not url.path.startswith("/"), link
        assert (moved / unquote(url.path)).is_file(), link


def test_by_default_only_the_curves_to_look_at_are_drawn(raw, tmp_path, capsys):
    # reference: curves.csv's statuses and the command's own warnings (cells left out or read
    # with a low signal): every rejected curve is drawn, and nothing else but the curves of the
    # cells those warnings name; the page still lists every curve
    _run(["curves", str(raw / "manifest.csv"), "--out", str(tmp_path / "cells.csv"),
          "--no-progress"])
    said = capsys.readouterr().out
    table = list(csv.DictReader(open(tmp_path / "curves.csv")))
    drawn = {p.name.split("_")[0] for p in (tmp_path / "curve_figures").iterdir()}
    lines = {f"{int(t['manifest_line']):04d}": t for t in table}
    rejected = {k for k, t in lines.items() if t["status"] != "ok"}
    assert rejected and rejected <= drawn
    assert all(k in rejected or f"cell {lines[k]['cell_id']}" in said or
               lines[k]["cell_id"] in said.split("low signal")[-1] for k in drawn)
    assert len(drawn) < len(table)
    assert f"wrote figures of {len(drawn)} of {len(table)} curves" in said
    assert len(_page(tmp_path / "curves.html").rows) == len(table)


@pytest.mark.parametrize("flag", [["--figures", "none"], ["--no-figures"]])  # new, old name
def test_no_figures_writes_neither_figures_nor_page(raw, tmp_path, flag):
    _run(["curves", str(raw / "manifest.csv"), "--out", str(tmp_path / "cells.csv"),
          "--no-progress", *flag])
    assert (tmp_path / "curves.csv").is_file()
    assert not (tmp_path / "curve_figures").exists() and not (tmp_path / "curves.html").exists()
    # and the cache of reduced rows (tests/curves/test_curves_cache.py)
    assert sorted(p.name for p in Path(tmp_path).iterdir()) == [".cache", "cells.csv", "curves.csv"]


# ------------------------------------------------------------------------------ reused figures
def _png(fig):
    import io

    from matplotlib.image import imread

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=fig.dpi)
    buf.seek(0)
    return imread(buf)


def test_a_reused_figure_shows_the_same_as_a_fresh_one(curves):
    # reference: the figure of the cell curve drawn alone, in a new figure; drawn into a
    # figure that showed another reading first (the same curve read at 0.8 R_c/20 as a longer
    # named file: other data, limits, labels and title), every pixel must be the same
    from turgorbayes.plots.curves import CurveCanvas

    path, _, _ = curves["cell"]
    cell = _reduced(curves, "cell")
    other = CurveTrace()
    res = reduce_curve(path, "cell", 0.8 * R_C, trace=other)
    assert res.ok and res.depth != cell[0].depth
    fresh = _png(curve_figure(cell[0], cell[1], "c.tab", "c1", "cell"))
    canvas = CurveCanvas()
    first = canvas.draw(res, other, "a_much_longer_name_of_another_file_" * 4 + ".tab", "c2")
    assert "c2" in _title(first)[0]
    again = canvas.draw(cell[0], cell[1], "c.tab", "c1", "cell")
    assert again is first  # the same figure, reused
    assert_allclose(_png(again), fresh, atol=0)


def test_reduction_hands_each_curve_with_its_trace_to_on_curve(raw):
    # reference: the same manifest reduced without on_curve (the results must not change), and
    # the manifest's rows (one call per row, in order, each trace filled up to its contact)
    from turgorbayes.curves import read_manifest, reduce_manifest

    manifest = read_manifest(raw / "manifest.csv")
    calls = []
    with_calls = reduce_manifest(manifest, on_curve=lambda *a: calls.append(a))
    assert with_calls.results == reduce_manifest(manifest).results
    assert [row.line for row, _, _ in calls] == [row.line for row in manifest.rows]
    assert [res for _, res, _ in calls] == list(with_calls.results)
    for row, res, trace in calls:  # accepted: traced up to the secant; unreadable: nothing read
        assert isinstance(trace, CurveTrace)
        assert trace.secant is not None if res.ok else res.status == "unreadable_file", row.name
        assert (trace.approach is None) == (res.status == "unreadable_file"), row.name
