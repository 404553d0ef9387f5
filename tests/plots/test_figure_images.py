"""Image comparison of the main figures against stored baselines, plus checks of their artists.

Inputs are synthetic and fixed (seeded): a small posterior tree drawn around the paper's
published parameters (docs/physics.md, Published values) with cells on the model curve plus
noise, and a fixed set of check results for the misfit figure; the sampler never runs, so a
change of the inference code does not move these images. Rendering uses matplotlib's defaults
with its test font settings (DejaVu Sans, fixed hinting) at a fixed dpi, and each PNG is compared
with ``tests/plots/baseline_images/<name>.png`` by ``matplotlib.testing.compare.compare_images``
(RMS of the 0-255 pixel difference over the whole image). The RMS dilutes local changes:
dropping the bulged cells' horizontal error bars from Fig. 3 costs only 2.0, the old faint band
opacity 1.5, the grey band of Fig. 2b 4.0 (docs/figures/before_after/README.md), so the usual
tolerance of 10-20 would pass them. :data:`TOL` is therefore 1: matplotlib's wheels bundle
their own FreeType, and with the test font settings the same matplotlib version renders
bit-identical PNGs on every machine (RMS 0 here); a new matplotlib version may need new
baselines.

To accept a deliberate change of a figure, run with ``TURGORBAYES_UPDATE_BASELINES=1`` and
look at the new PNGs before committing them.
"""

import os
import re
import shutil
from pathlib import Path
from types import SimpleNamespace

import matplotlib as mpl
import numpy as np
import pytest
import xarray as xr
from matplotlib.testing import set_font_settings_for_testing, set_reproducibility_for_testing
from matplotlib.testing.compare import compare_images
from matplotlib.text import Text

from turgorbayes import plots
from turgorbayes.physics import forward
from turgorbayes.workflows.bands import baseline_bands, pressure_grid

mpl.use("Agg")

BASELINES = Path(__file__).parent / "baseline_images"
#: RMS tolerance of the comparison (0-255 pixel values); see the module docstring.
TOL = 1.0
DPI = 72
PAPER = plots.PUBLISHED


@pytest.fixture(autouse=True)
def _test_rc():
    """Matplotlib defaults with the test font settings, restored afterwards."""
    with mpl.rc_context():
        mpl.rcdefaults()
        set_font_settings_for_testing()
        set_reproducibility_for_testing()
        yield


def _compare(fig, name, tmp_path):
    """Render ``fig`` and compare it with its baseline (or write it when updating)."""
    actual = tmp_path / f"{name}.png"
    fig.savefig(actual, dpi=DPI)
    expected = BASELINES / f"{name}.png"
    if os.environ.get("TURGORBAYES_UPDATE_BASELINES") == "1":
        BASELINES.mkdir(exist_ok=True)
        shutil.copyfile(actual, expected)
    assert expected.is_file(), f"no baseline {expected}; run with TURGORBAYES_UPDATE_BASELINES=1"
    result = compare_images(str(expected), str(actual), tol=TOL)
    assert result is None, result


def _texts(fig):
    return [t.get_text() for t in fig.findobj(Text) if t.get_text()]


def _cells(fig):
    """Texts of the cells of every table in ``fig``."""
    from matplotlib.table import Cell

    return [c.get_text().get_text() for c in fig.findobj(Cell)]


def _no_zero_p(fig):
    """No p-value printed as zero: no "p = 0" / "p = 0.000", no table cell "0" / "0.000"."""
    bad = [t for t in _texts(fig) if re.search(r"p = 0(\.0*)?(?![\d.])", t)]
    bad += [t for t in _cells(fig) if re.fullmatch(r"0(\.0*)?( flagged| cleared)?", t)]
    assert not bad, bad


# ---------------------------------------------------------------------------------- inputs
N_BULGED, N_INTACT, CHAINS, DRAWS = 30, 15, 2, 150


def synthetic_tree(table, seed=11, shift=0.0):
    """A posterior tree around the published parameters, with cells on the model plus noise.

    ``shift`` moves the draws of gamma (a stand-in "extension" with other curves).
    """
    rng = np.random.default_rng(seed)
    shape = (CHAINS, DRAWS)
    post = {"gamma": rng.normal(PAPER["gamma"] + shift, 0.04, shape),
            "E0t": rng.normal(PAPER["E0t"], 6e-4, shape),
            "R0": rng.normal(PAPER["R0"], 1.7e-9, shape),
            "P_phys": rng.normal(PAPER["P_phys"], 600.0, shape)}
    n = N_BULGED + N_INTACT
    bulged = np.arange(n) < N_BULGED
    P_true = np.where(bulged, np.exp(rng.uniform(np.log(1e3), np.log(25e3), n)), PAPER["P_phys"])
    R, k = forward.cell_radius_and_stiffness(P_true, PAPER["gamma"], PAPER["E0t"], PAPER["R0"],
                                             surrogate=table)
    R_err, k_err = np.full(n, 8e-9), 0.12 * k
    sd_logP = np.where(bulged, 0.15, np.nan)
    P_bulge = np.where(bulged, P_true * np.exp(sd_logP * rng.standard_normal(n)), np.nan)
    P_cell = np.where(bulged, P_true * np.exp(0.1 * rng.standard_normal((*shape, n))),
                      post["P_phys"][..., None])
    cd, cc = ("chain", "draw"), ("chain", "draw", "cell")
    dt = xr.DataTree.from_dict({
        "posterior": xr.Dataset({**{k_: (cd, v) for k_, v in post.items()}, "P_cell": (cc, P_cell)}),
        "observed_data": xr.Dataset({"R_c": ("cell", R + R_err * rng.standard_normal(n)),
                                     "k_c": ("cell", k + k_err * rng.standard_normal(n))}),
        "constant_data": xr.Dataset({"is_bulged": ("cell", bulged), "P_bulge": ("cell", P_bulge),
                                     "sd_log_P_bulge": ("cell", sd_logP),
                                     "R_c_err": ("cell", R_err), "k_c_err": ("cell", k_err)}),
    })
    dt.attrs.update(model="baseline", converged=1, simulated_data=1)
    return dt


#: Check names of the criticism battery (turgorbayes.criticism.checks) with fixed p-values:
#: baseline, extension, counted from N_REP replicates (loo_pit: analytic). Zeros must print as
#: "< 0.001" (1/N_REP).
P_VALUES = {"trend_R_c": (0.59, 0.61), "trend_k_c": (0.56, 0.5),
            "scatter_R_c_bulged": (0.0, 0.27), "scatter_R_c_intact": (0.0, 0.73),
            "scatter_k_c_bulged": (0.31, 0.35), "scatter_k_c_intact": (0.36, 0.43),
            "correlation_R_c_k_c": (0.83, 0.79), "max_abs_z_R_c": (0.15, 0.21),
            "max_abs_z_k_c": (0.06, 0.0004), "kurtosis_R_c": (0.24, 0.34),
            "kurtosis_k_c": (0.053, 0.033), "bulged_vs_intact_R_c": (0.39, 0.35),
            "bulged_vs_intact_k_c": (0.13, 0.1), "loo_pit_R_c": (0.0002, 0.43),
            "loo_pit_k_c": (0.47, 0.45)}
ALPHA = 0.05 / len(P_VALUES)
N_REP = 1000


def synthetic_criticism(seed=5):
    """Residual arrays and check results of a baseline and an adopted extension."""
    rng = np.random.default_rng(seed)
    n, d = N_BULGED + N_INTACT, 60
    group = np.where(np.arange(n) < N_BULGED, "bulged", "intact")
    log_p = np.where(group == "bulged", np.log(np.geomspace(1e3, 25e3, n)), np.log(29e3))
    arrays, checks = {}, {}
    for m, (name, spread) in enumerate((("baseline", 1.0), ("radius_spread", 1.8))):
        y = {o: rng.normal(0, 1.6, n) for o in ("R_c", "k_c")}
        mu = {o: y[o] * 0.1 * m + rng.normal(0, 0.2, (d, n)) for o in y}
        arrays[name] = {"y": y, "sigma": {o: np.ones(n) for o in y}, "mu": mu,
                        "y_rep": {o: mu[o] + spread * rng.standard_normal((d, n)) for o in y},
                        "log_pressure": np.broadcast_to(log_p, (d, n)), "group": group}
        checks[name] = [{"name": c, "statistic": 0.0, "p_value": p[m],
                         "flagged": p[m] < ALPHA / 2 or p[m] > 1 - ALPHA / 2}
                        for c, p in P_VALUES.items()]
    return SimpleNamespace(check_arrays=arrays, checks=checks, selected="radius_spread",
                           cells=SimpleNamespace(comments=["# simulated data"]),
                           settings=SimpleNamespace(n_rep=N_REP))


@pytest.fixture(scope="module")
def tree(table):
    return synthetic_tree(table)


# ----------------------------------------------------------------------------------- tests
def test_fig3_image_and_artists(tree, table, tmp_path):
    P = pressure_grid(tree)
    ext = baseline_bands(synthetic_tree(table, shift=0.08), P, table, n_curves=80,
                               label="extension")
    fig = plots.fig3(tree, extended=ext, surrogate=table, n_curves=80)
    for ax in fig.axes:
        bars = {c.get_label(): c for c in ax.containers}
        # bulged cells, their binned means, intact cells, the intact mean
        assert len(bars) == 4
        bulged = bars["bulged cells (±1 sd of pressure and of the reading)"]
        assert bulged.has_xerr and bulged.has_yerr
        assert len(bulged.lines[0].get_xdata()) == N_BULGED
        (intact,) = [c for label, c in bars.items() if label.startswith("intact cells")]
        assert intact.has_xerr and intact.has_yerr
        # intact cells are not jittered: all at the posterior median of P_phys [kPa]
        x = intact.lines[0].get_xdata()
        assert len(x) == N_INTACT
        assert np.ptp(x) == 0
        assert x[0] == pytest.approx(np.median(tree["posterior"]["P_phys"].values) / 1e3)
        ax.figure.canvas.draw()
        minor = {t.get_text() for t in ax.xaxis.get_minorticklabels()}
        assert {"2", "5", "20"} <= minor
        assert "[kPa]" in ax.get_xlabel()
    assert "[nm]" in fig.axes[0].get_ylabel() and "[pN/nm]" in fig.axes[1].get_ylabel()
    # baseline and extension medians both drawn, told apart by colour and line style
    lines = {ln.get_label(): ln for ln in fig.axes[0].get_lines()}
    base, other = lines["baseline: median"], lines["extension: median"]
    assert base.get_color() != other.get_color()
    assert base.get_linestyle() != other.get_linestyle()
    assert base.get_linewidth() > other.get_linewidth()
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "baseline: median, 68 % and 95 % bands" in legend
    assert "extension: median, 68 % and 95 % bands" in legend
    _compare(fig, "fig3", tmp_path)


def test_corner_image_and_titles(tree, tmp_path):
    fig = plots.corner_plot(tree)
    titles = [fig.axes[i * 5].get_title() for i in range(4)]
    # "label\nmean ± sd" with two significant digits of the sd
    R0 = tree["posterior"]["R0"].values.ravel() / 1e-9
    assert titles[2] == f"$R_0$ [nm]\n{np.mean(R0):.1f} ± {np.std(R0, ddof=1):.1f}"
    for t in titles:
        sd = t.split(" ± ")[1]
        assert len(sd.replace("0.", "").lstrip("0").replace(".", "")) == 2, t
    assert "mean ± sd" in fig.get_suptitle()
    _compare(fig, "corner", tmp_path)


def test_misfit_image_and_text(tmp_path):
    fig = plots.misfit.plot_misfit(synthetic_criticism(), tmp_path / "misfit.png")
    texts, cells = _texts(fig), _cells(fig)
    _no_zero_p(fig)
    assert len(cells) == 9 * 5  # header and 8 kinds of check; R_c and k_c of 2 models
    # 3 flags of the baseline (p = 0, 0 of 1000 replicates; the analytic loo_pit 0.0002), 1 new
    # one of the extension (p = 0.0004: none of 1000 replicates, p < 0.001)
    assert cells.count("< 0.001 flagged") == 3 and "0.0002 flagged" in cells
    assert "0.27 cleared" in cells
    # readable titles, no raw check names anywhere
    assert not [t for t in texts + cells if re.search(r"\w+_[Rk]_c", t)]
    assert "scatter vs. errors, bulged cells" in cells
    axes = [ax for ax in fig.axes if ax.get_title(loc="left")]
    assert [ax.get_title(loc="left") for ax in axes] == [
        "baseline model: $R_c$", "baseline model: $k_c$",
        "adopted extension: radius spread: $R_c$", "adopted extension: radius spread: $k_c$"]
    # the extension's panels note the baseline's p-value of a flag they clear (in green)
    cleared = [t for t in axes[2].texts if "(baseline: p " in t.get_text()]
    assert sorted(t.get_text().split("(baseline: ")[1] for t in cleared) == [
        "p < 0.001)", "p < 0.001)", "p = 0.0002)"]
    assert all(t.get_color() == "#1e8449" for t in cleared)
    (new,) = axes[3].texts
    assert new.get_text() == "largest outlier: p < 0.001 (baseline: p = 0.06)"
    assert new.get_color() == "#c0392b"
    # legible where it is shown: the HTML report draws it at the page's width (its CSS:
    # max-width 1100 px, padding 1em = 16 px each side), scaled from the 110 dpi PNG; every
    # text must be >= 10 px there (pt / 72 x dpi x shown width / PNG width)
    from turgorbayes.report.html import CSS

    page = int(re.search(r"max-width:(\d+)px", CSS).group(1)) - 2 * 16
    scale = page / (fig.get_figwidth() * 110)
    small = {t.get_text()[:40]: round(t.get_fontsize() / 72 * 110 * scale, 1)
             for t in fig.findobj(Text) if t.get_text()
             and t.get_fontsize() / 72 * 110 * scale < 10}
    assert not small, small
    _compare(fig, "misfit", tmp_path)


def test_fig2b_image_and_legend(tmp_path):
    ax = plots.fig2b()
    assert "indentation" in ax.get_xlabel() and "force" in ax.get_ylabel()
    legend = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any("0.35-0.38" in t and "Deng" in t for t in legend)
    _compare(ax.figure, "fig2b", tmp_path)


def test_fig4_image_marks_the_buckled_corner(table, tmp_path):
    ax = plots.fig4(table)
    # the table's own flags (surrogates/README.md, docs/fem.md): two boxes, x 0.34-0.63 at
    # ratio 0.15-0.5 and x 0.46-0.63 at every ratio, each hatched over its x range
    hatched = [p for p in ax.patches if p.get_hatch() == "///"]
    assert len(table.buckled_boxes) == len(hatched) == 2
    spans = sorted((p.get_x(), p.get_width()) for p in hatched)
    boxes = sorted(b["x"] for b in table.buckled_boxes)
    assert [(pytest.approx(x0), pytest.approx(x1 - x0)) for x0, x1 in boxes] == spans
    (snaps,) = [ln for ln in ax.lines if ln.get_marker() == "x"]
    # 4 FE points that lost the path before R/20 and 7 whose force falls (surrogate info)
    assert len(snaps.get_xdata()) == 11 and np.min(snaps.get_xdata()) > 0.45
    (legend,) = ax.figure.legends
    assert "buckles under the tip" in legend.get_texts()[0].get_text()
    _compare(ax.figure, "fig4", tmp_path)
