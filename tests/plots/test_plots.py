"""Tests of the figure module (turgorbayes.plots).

References: hand computations of the error-weighted bin means; the normal quantiles of a known
fake posterior (scipy.stats.norm); the paper's radius R_c(29 kPa) = 540.7 nm at its published
parameters (docs/physics.md, Published values) for a posterior concentrated there; the posterior draws
themselves for the unit conversion of the ArviZ panels. Figures are checked for their axes,
labels, units and number of artists. One small fit (not converged, on purpose: short) is shared.
"""

import dataclasses
import re

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from turgorbayes import criticism, effects, formatting, plots
from turgorbayes.cells.table import example_path, read_cells
from turgorbayes.workflows import fit as results
from turgorbayes.workflows.bands import (
    QUANTILES,
    baseline_bands,
    binned_means,
    curve_bands,
    extended_bands,
    pressure_grid,
    read_bands,
    write_bands,
    write_extended_bands,
)
from turgorbayes.workflows.fit_data import posterior_tree

TINY = results.FitSettings(n_walkers=12, n_ensembles=4, max_steps=200, check_every=100,
                           n_nodes=4, max_draws_per_chain=100, progress=False)
PAPER = plots.PUBLISHED


@pytest.fixture(scope="module")
def fit(table):
    return results.fit_cells(read_cells(example_path()), "baseline", seed=3, surrogate=table,
                             settings=TINY)


def _at_paper_values(fit):
    """The same fit with every draw of gamma, E0t, R0, P_phys at the published values."""
    draws = {n: np.full_like(v, PAPER[n]) if n in PAPER else v for n, v in fit.draws.items()}
    return dataclasses.replace(fit, draws=draws)


def test_binned_means_match_hand_computation():
    # two bins (edges 1, 10, 100 Pa): cells 0-1 in the first, 2-3 in the second
    P = np.array([1.0, 4.0, 20.0, 100.0])
    y = np.array([1.0, 3.0, 10.0, 20.0])
    err = np.array([1.0, 2.0, 1.0, 1.0])
    sd_logP = np.array([1.0, 0.5, 1.0, 1.0])
    out = binned_means(P, y, err, sd_logP, n_bins=2)
    # bin 1: w = (1, 1/4) -> mean (1 + 3/4)/(5/4) = 1.4, se = (5/4)^-1/2;
    #        v = (1, 4)   -> P = exp((0 + 4 ln 4)/5)
    # bin 2: equal weights -> mean 15, se 1/sqrt(2), P = exp((ln 20 + ln 100)/2) = sqrt(2000)
    expected = [[np.exp(4 * np.log(4) / 5), 1.4, (5 / 4) ** -0.5, 2],
                [np.sqrt(2000.0), 15.0, 2 ** -0.5, 2]]
    assert_allclose(out, expected, rtol=1e-12)


def test_binned_means_ten_log_bins_skip_empty_ones():
    # one cell per decade of pressure at 1, 10, ..., 1e9 Pa: 10 log-spaced bins, one cell each
    P = 10.0 ** np.arange(10)
    out = binned_means(P, np.arange(10.0), np.ones(10))
    assert out.shape == (10, 4)
    assert_allclose(out[:, 0], P, rtol=1e-12)
    # drop three cells: their bins are left out, not filled with NaN
    assert binned_means(P[[0, 4, 9]], np.ones(3), np.ones(3)).shape == (3, 4)


def test_curve_bands_recover_known_normal_quantiles(rng):
    # fake posterior of curves: R(P) ~ N(mu(P), sd(P)); the band edges are normal quantiles
    P = np.geomspace(1e3, 3e4, 7)
    mu, sd = 400e-9 + 5e-9 * np.log(P), 2e-9 + 1e-13 * P
    z = rng.standard_normal((40000, 1))
    bands = curve_bands(P, mu + sd * z, np.exp(z) * np.ones_like(P), "fake")
    expected = np.broadcast_to(stats.norm.ppf(np.array(QUANTILES))[:, None], (5, P.size))
    # standard error of a sample quantile at n = 40000: sqrt(q(1-q)/n)/phi(z_q) <= 0.014 sd
    # (q = 2.5 %); 4 standard errors allowed
    assert_allclose((bands.R - mu) / sd, expected, atol=0.055)
    # k = exp(z): lognormal quantiles exp(ppf(q)), same relative tolerance
    assert_allclose(bands.k[:, 0], np.exp(expected[:, 0]), rtol=0.055)


def test_baseline_bands_collapse_on_the_published_curve(fit, table):
    # every draw at the published values: all quantiles equal R_c(29 kPa) = 540.7 nm (docs/physics.md)
    bands = baseline_bands(_at_paper_values(fit), P=[29e3], surrogate=table)
    assert_allclose(bands.R[:, 0], 540.7e-9, rtol=2e-4)


@pytest.fixture(scope="module")
def paper_posterior(fit, table):
    """Weighted draws of an effect-free ExtendedModel (the baseline), all at the paper's values."""
    model = effects.ExtendedModel(fit.cells, table, [])
    u = np.repeat(model.to_u(PAPER), 50, axis=0)
    return criticism.Posterior(model=model, u=u, log_w=np.full(50, -np.log(50)),
                               log_lik=np.zeros((50, 1)), engine="importance", converged=True,
                               reasons=[], diagnostics={}, u_map=u[0], cov=np.eye(u.shape[1]))


def test_extended_bands_of_effect_free_model_at_paper_values(paper_posterior):
    # an ExtendedModel without effects is the baseline: its curve at 29 kPa is 540.7 nm too
    bands = extended_bands(paper_posterior, [29e3], n_curves=20)
    assert_allclose(bands.R[:, 0], 540.7e-9, rtol=2e-4)
    assert "intact-cell wall" in bands.label


def test_write_extended_bands_only_when_an_extension_is_adopted(paper_posterior, tmp_path):
    from types import SimpleNamespace

    none = SimpleNamespace(selected=None, posteriors={})
    assert write_extended_bands(none, tmp_path / "a.json") is None
    assert not (tmp_path / "a.json").exists()
    adopted = SimpleNamespace(selected="x", posteriors={"x": paper_posterior})
    write_extended_bands(adopted, tmp_path / "b.json", n_curves=20)
    bands = read_bands(tmp_path / "b.json")
    # the grid covers the bulge pressures (0.90-26.8 kPa in the example) and P_phys = 29 kPa
    assert bands.P.min() < 0.90e3 and bands.P.max() > 29e3
    # log-linear interpolation of the median curve at 29 kPa: 540.7 nm (docs/physics.md, Published values)
    assert_allclose(np.interp(np.log(29e3), np.log(bands.P), bands.R[2]), 540.7e-9, rtol=5e-4)


def test_fig3_axes_units_and_artists(fit, table, tmp_path):
    P = pressure_grid(fit)
    ext = baseline_bands(_at_paper_values(fit), P, table, label="fake extension")
    fig = plots.fig3(fit, extended=ext, path=tmp_path / "fig3.png")
    assert (tmp_path / "fig3.png").stat().st_size > 20_000
    ax_R, ax_k = fig.axes
    for ax in (ax_R, ax_k):
        assert "[kPa]" in ax.get_xlabel() and ax.get_xscale() == "log"
        # 68 % and 95 % bands of two models: four filled areas
        assert sum(type(c).__name__ == "FillBetweenPolyCollection" for c in ax.collections) == 4
    assert "[nm]" in ax_R.get_ylabel() and "[pN/nm]" in ax_k.get_ylabel()
    assert ax_k.get_yscale() == "log"
    # the extension's median line is drawn in display units: the published curve, in nm
    (line,) = [ln for ln in ax_R.get_lines() if ln.get_label() == "fake extension: median"]
    x, y = line.get_data()
    assert_allclose(np.interp(29.0, x, y), 540.7, rtol=3e-4)  # docs/physics.md, Published values
    # bulged binned crosses: at most 10 bins, from the 72 bulged cells
    (binned,) = [c for c in ax_R.containers if c.get_label().startswith("bulged, weighted")]
    assert 5 <= len(binned.lines[0].get_xdata()) <= 10
    (cells,) = [c for c in ax_R.containers if c.get_label().startswith("bulged cells")]
    assert len(cells.lines[0].get_xdata()) == fit.cells.n_bulged
    # horizontal error bars: the bulge estimate's P exp(-/+ sd_log_P_bulge), from the tree
    tree = posterior_tree(fit)
    b = tree["constant_data"]["is_bulged"].values.astype(bool)
    P = tree["constant_data"]["P_bulge"].values[b] / 1e3
    s = tree["constant_data"]["sd_log_P_bulge"].values[b]
    (xbars,) = [c for c in cells.lines[2] if len(c.get_segments()) and
                np.ptp(np.asarray(c.get_segments())[:, :, 1], axis=1).max() == 0]
    seg = np.asarray(xbars.get_segments())
    assert_allclose(seg[:, 0, 0], P * np.exp(-s), rtol=1e-9)
    assert_allclose(seg[:, 1, 0], P * np.exp(s), rtol=1e-9)
    (intact,) = [c for c in ax_R.containers if c.get_label().startswith("intact cells")]
    assert len(intact.lines[0].get_xdata()) == fit.cells.n_intact
    assert intact.has_xerr and intact.has_yerr
    # one legend for the figure, outside the axes (no overlap with the data)
    assert len(fig.legends) == 1 and ax_R.get_legend() is None


def test_fig3_from_disk_equals_in_memory(fit, tmp_path):
    import xarray as xr

    results.write_results(fit, tmp_path)
    dt = xr.open_datatree(tmp_path / "posterior.nc", engine="h5netcdf")
    a = plots.fig3(fit, reference=None).axes[0].get_lines()[0].get_ydata()
    b = plots.fig3(dt, reference=None).axes[0].get_lines()[0].get_ydata()
    assert_allclose(a, b, rtol=1e-12)


def test_figures_read_the_fit_tree_and_recompute_no_pressures(fit, monkeypatch):
    from turgorbayes.inference.observations import observations_from_cells

    # the tree holds the bulge-derived pressures, computed independently here
    obs = observations_from_cells(fit.cells)
    tree = posterior_tree(fit)
    assert tree is fit.tree
    assert_allclose(tree["constant_data"]["P_bulge"].values[obs.bulged],
                    np.exp(obs.log_P_bulge), rtol=1e-12)
    assert int(tree.attrs["converged"]) == int(fit.converged)

    def fail(*args, **kwargs):
        raise AssertionError("a figure recomputed the bulge pressures")

    monkeypatch.setattr(results, "observations_from_cells", fail)
    plots.fig3(fit, reference=None)
    plots.residual_plot(fit)
    # a changed copy of the fit gets a fresh tree, not the stale one
    moved = _at_paper_values(fit)
    assert moved.tree is None
    monkeypatch.undo()
    assert_allclose(posterior_tree(moved)["posterior"]["R0"].values, PAPER["R0"])


def test_fig3_rejects_bad_input(fit, table):
    with pytest.raises(ValueError, match="pressure must be 'bulge' or 'posterior', got 'x'"):
        plots.fig3(fit, pressure="x")
    with pytest.raises(TypeError, match="expected a FitResult or the DataTree .* got dict"):
        plots.fig3({"a": 1})
    dt = posterior_tree(fit)
    dt.attrs["surrogate_sha256"] = "0" * 64
    with pytest.raises(ValueError, match="surrogate table with sha256 0000"):
        plots.fig3(dt)


def test_bands_round_trip_through_json(fit, table, tmp_path):
    bands = baseline_bands(fit, surrogate=table, n_curves=50)
    write_bands(bands, tmp_path / "b.json")
    back = read_bands(tmp_path / "b.json")
    assert back.label == bands.label
    assert_allclose(back.R, bands.R, rtol=0, atol=0)
    text = (tmp_path / "b.json").read_text().replace("0.025,", "0.05,", 1)
    (tmp_path / "c.json").write_text(text)
    with pytest.raises(ValueError, match="bands at quantiles"):
        read_bands(tmp_path / "c.json")


def test_standardized_residuals_of_a_gaussian_predictive(rng):
    # y_rep ~ N(mu, sd): z = (y - mu)/sd up to sampling error of mean and sd at 20000 draws
    mu, sd = np.array([1.0, -2.0, 5.0]), np.array([0.5, 2.0, 0.1])
    y = np.array([1.5, 0.0, 4.8])
    z = plots.standardized_residuals(y, mu + sd * rng.standard_normal((20000, 3)))
    assert_allclose(z, (y - mu) / sd, atol=0.03)


def test_residual_plot(fit, tmp_path):
    fig = plots.residual_plot(fit, path=tmp_path / "r.png")
    ax_R, ax_k = fig.axes
    assert "[kPa]" in ax_R.get_xlabel() and "residual" in ax_R.get_ylabel()
    assert "R_c" in ax_R.get_title() and "k_c" in ax_k.get_title()
    bulged = [ln for ln in ax_R.get_lines() if ln.get_label() == "bulged cells"][0]
    assert len(bulged.get_xdata()) == fit.cells.n_bulged


def test_corner_plot(fit):
    fig = plots.corner_plot(fit)
    assert len(fig.axes) == 16
    assert "[nm]" in fig.axes[8].get_ylabel() and "[kPa]" in fig.axes[15].get_xlabel()
    # titles: mean ± sd of the draws in display units, as the report prints them
    E0t = fit.draws["E0t"].ravel()
    expected = formatting.format_pm(E0t.mean(), E0t.std(ddof=1))
    assert fig.axes[5].get_title() == f"$E_0t$ [N/m]\n{expected}"


# reference: a p-value counted from n replicates is a multiple of 1/n, so a count of 0 (or n)
# only bounds it by 1/n (or 1 - 1/n); an analytic one (n None) prints as computed
@pytest.mark.parametrize(("p", "n_rep", "text"), [
    (0.0, 1000, "p < 0.001"), (0.0004, 1000, "p < 0.001"), (0.0, 700, "p < 0.0014"),
    (0.001, 1000, "p = 0.001"), (0.0104, None, "p = 0.0104"), (0.39, 700, "p = 0.39"),
    (1.0, 1000, "p > 0.999"), (0.0, None, "p < 1e-300"), (float("nan"), None, "p = n/a")])
def test_format_p_never_prints_zero(p, n_rep, text):
    assert plots.style.format_p(p, n_rep) == text


@pytest.mark.parametrize(("value", "sd", "text"), [
    (0.0250034, 0.000976, "0.02500 ± 0.00098"),  # E0t [N/m]: 2 significant digits of the sd
    (467.91, 2.74, "467.9 ± 2.7"), (1.2813, 0.0402, "1.281 ± 0.040"),
    (12345.0, 230.0, "12340 ± 230"), (28.47, 0.5, "28.47 ± 0.50")])
def test_format_pm_rounds_to_the_sd(value, sd, text):
    assert formatting.format_pm(value, sd) == text


def test_trace_and_rank_plots_in_display_units(fit):
    fig = plots.trace_plot(fit)
    assert len(fig.axes) == 8  # density and trace for each of 4 parameters
    # the same labels as the corner plot: symbols with units
    (ax,) = [a for a in fig.axes if a.get_ylabel() == "$R_0$ [nm]"]
    drawn = np.concatenate([ln.get_ydata() for ln in ax.get_lines()])
    # the trace shows the posterior draws of R0 converted to nm (4 ensembles x 100 draws)
    assert drawn.size == fit.draws["R0"].size
    assert_allclose(np.sort(drawn), np.sort(fit.draws["R0"].ravel() / 1e-9), rtol=1e-12)
    fig = plots.rank_plot(fit)
    assert len(fig.axes) == 4
    assert {a.get_title() for a in fig.axes} == {r"$\gamma$", "$E_0t$ [N/m]", "$R_0$ [nm]",
                                                  r"$P_\mathrm{phys}$ [kPa]"}
    assert "uniform CDF" in fig.axes[0].get_ylabel()
    # ArviZ's uniformity envelope: one filled band per panel, visible y axis
    assert all(len(a.collections) >= 1 and a.yaxis.get_visible() for a in fig.axes)
    p = plots.rank_pvalues(fit)
    for a in fig.axes:
        (note,) = a.texts
        assert re.search(r"p (= 0\.\d+|< 0\.001)", note.get_text())
    assert set(p) == set(PAPER) and all(0 <= v <= 1 for v in p.values())
