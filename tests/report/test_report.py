"""Tests of ``turgorbayes report`` (turgorbayes.report, cli.report).

References: the diagnostic thresholds of turgorbayes.inference.diagnostics (R-hat < 1.01, ESS >= 400,
Vehtari et al. 2021) on hand-made summaries, including the boundary values; the files the
fit and criticism write (summary.json, criticism.json) for the numbers the page must show.
One short fit (deliberately not converged) and one short criticism are shared.
"""

import base64
import json
import math
import re
from types import SimpleNamespace

import pytest

from turgorbayes import formatting, report, surrogate
from turgorbayes.cells.table import example_path, read_cells
from turgorbayes.cli import main
from turgorbayes.report.criticism import write_outputs
from turgorbayes.workflows import fit as results
from turgorbayes.workflows.bands import extended_bands, pressure_grid, write_bands
from turgorbayes.workflows.criticize import CriticismSettings, criticize

TINY = results.FitSettings(n_walkers=12, n_ensembles=4, max_steps=200, check_every=100,
                           n_nodes=4, max_draws_per_chain=100, progress=False)
CRIT = CriticismSettings(n_draws=400, n_rep=100, ess_min=50, max_refits=0,
                         effects=("wall_softening",))


def _summary(**over):
    """A summary.json whose diagnostics all pass, with ``over`` replacing parameter fields."""
    entry = {"mean": 1.0, "sd": 0.1, "q05": 0.8, "q50": 1.0, "q95": 1.2, "r_hat": 1.002,
             "ess_bulk": 900.0, "ess_tail": 800.0}
    params = {"gamma": dict(entry), "R0_nm": dict(entry)}
    params["gamma"].update(over)
    return {"converged": True, "parameters": params,
            "loo": {"elpd": 1.0, "se": 1.0, "p_loo": 4.0, "n_pareto_k_bad": 0}}


def test_published_table_in_summary_units():
    # Deng, Sun & Shaevitz 2011, table 1, as report.md and report.html print them
    assert report.fit.PUBLISHED_TABLE == {
        "gamma": (1.22, 0.12), "E0t_N_per_m": (0.026, 0.001), "R0_nm": (464.2, 0.9),
        "P_phys_kPa": (29.0, 3.0), "E_perp_MPa": (49.0, 20.0), "E_par_MPa": (23.0, 8.0)}


#: Tests of the module-scoped ``out_dir`` (a fit and a criticism) carry this ``xdist_group``:
#: one process of ``pytest -n 2 --dist loadgroup`` computes it once.
OUT_DIR_GROUP = pytest.mark.xdist_group("report_out_dir")


@pytest.fixture(scope="module")
def out_dir(tmp_path_factory):
    if not surrogate.default_path().is_file():
        pytest.skip("shipped surrogate table not built yet")
    table = surrogate.load()
    cells = read_cells(example_path())
    d = tmp_path_factory.mktemp("fit")
    fit = results.fit_cells(cells, "baseline", seed=4, surrogate=table, settings=TINY)
    results.write_results(fit, d)
    report.fit.write_report(fit, d / "report.md")
    crit = criticize(cells, table, seed=4, settings=CRIT)
    write_outputs(crit, d / "crit")
    name = crit.selected or "wall_softening"
    write_bands(extended_bands(crit.posteriors[name], pressure_grid(fit)),
                      d / "crit" / "extended_bands.json")
    return d


def test_no_warning_when_every_diagnostic_passes():
    assert report.diagnostic_warnings(_summary()) == []


@pytest.mark.parametrize(("over", "match"), [
    ({"r_hat": 1.01}, r"R-hat of gamma is 1\.0100 \(needs < 1\.01\)"),  # boundary fails
    ({"r_hat": 1.2}, r"R-hat of gamma is 1\.2000"),
    ({"ess_bulk": 399.0}, r"ess_bulk of gamma is 399 \(needs >= 400\)"),
    ({"ess_tail": 12.0}, r"ess_tail of gamma is 12"),
])
def test_each_failed_diagnostic_is_named(over, match):
    (w,) = report.diagnostic_warnings(_summary(**over))
    assert re.search(match, w), w


def test_boundary_values_that_pass():
    # exactly ESS 400 passes (>= 400); R-hat just below 1.01 passes
    assert report.diagnostic_warnings(_summary(ess_bulk=400.0, r_hat=1.0099)) == []


def test_convergence_pareto_and_criticism_warnings():
    s = _summary()
    s["converged"] = False
    s["loo"]["n_pareto_k_bad"] = 3
    cdiag = {"models": {"wall_softening": {"converged": False, "engine": "emcee",
                                           "reasons": ["R-hat of gamma is 1.05"],
                                           "loo": {"n_bad_not_refitted": 2}}}}
    w = report.diagnostic_warnings(s, cdiag)
    assert len(w) == 4
    assert "did NOT converge" in w[0] and "3 cell(s) with Pareto k" in w[1]
    assert "wall_softening (emcee) did NOT converge: R-hat of gamma is 1.05" in w[2]
    assert "2 cell(s) with high Pareto k were not refitted" in w[3]


@pytest.mark.slow
@OUT_DIR_GROUP
def test_cli_report_is_self_contained(out_dir, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["report", str(out_dir), "--criticism", str(out_dir / "crit")])
    assert exit_info.value.code == 0
    captured = capsys.readouterr()
    # the short fit is not converged: the command and the page both say so
    assert "warning: The fit did NOT converge" in captured.err
    page = (out_dir / "report.html").read_text()
    summary = json.loads((out_dir / "summary.json").read_text())
    crit = json.loads((out_dir / "crit" / "criticism.json").read_text())
    assert "class='warn'" in page and "did NOT converge" in page
    for text in (summary["data"]["sha256"], summary["surrogate"]["sha256"], summary["version"],
                 f"<td>fit seed</td><td>{summary['seed']}</td>", "SIMULATED DATA",
                 crit["checks"][0]["name"], "Model criticism"):
        assert text in page, text
    # the headline number of summary.json, as the table prints it (4 significant digits)
    assert f"{summary['parameters']['P_phys_kPa']['mean']:.4g} ±" in page
    # the criticism's model average (criticism_diagnostics.json), its P_phys median included
    stack = json.loads((out_dir / "crit" / "criticism_diagnostics.json").read_text())["stacking"]
    assert abs(sum(stack["weights"].values()) - 1) < 1e-9
    assert "Model average (stacking" in page
    assert f"{stack['parameters']['P_phys_kPa']['q50']:.4g} [" in page
    # figures are embedded PNGs (Fig. 3, corner, residuals, trace, rank, misfit) and nothing
    # is loaded from elsewhere
    images = re.findall(r'<img [^>]*src="([^"]+)"', page)
    assert len(images) == 6
    for src in images:
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n"
    assert "no <code>extended_bands.json</code>" not in page
    # the two wall thicknesses are explained under the parameters (docs/outputs.md)
    assert report.html._sentence(report.text.thickness_note()) in page


@OUT_DIR_GROUP
def test_report_without_criticism_says_how_to_get_one(out_dir, tmp_path):
    path = report.write_report(out_dir, out=tmp_path / "r.html")
    page = path.read_text()
    assert "No <code>criticism.json</code> found" in page
    assert len(re.findall(r"<img ", page)) == 5


def test_report_on_a_directory_without_fit_exits_2(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["report", str(tmp_path)])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "is not a fit output directory: posterior.nc, summary.json missing" in err


# ------------------------------------------------------------- p-values, thickness, MC error
def test_p_values_never_print_as_zero_or_one():
    # reference: a p-value counted from n posterior-predictive replicates is a multiple of 1/n,
    # so a count of 0 (or n) only bounds it by 1/n (or 1 - 1/n)
    fmt = formatting.format_p_value
    assert fmt(0.0, 1000) == "< 0.001"
    assert fmt(0.0, 100) == "< 0.01"
    assert fmt(1.0, 1000) == "> 0.999"
    assert fmt(1.0, 400) == "> 0.9975"
    assert fmt(0.012, 1000) == "0.012"
    assert fmt(0.999, 1000) == "0.999"  # 999 of 1000: a count, printed as it is
    # analytic p-values (LOO-PIT uniformity test): as computed, an underflow bounded
    assert fmt(1.65e-11) == "1.65e-11"
    assert fmt(0.0) == "< 1e-300"
    assert fmt(float("nan"), 1000) == fmt(None) == "n/a"


def _fake_criticism(p_values, n_rep=100):
    """A CriticismResult stand-in with baseline checks of the given p-values."""
    checks = [{"name": name, "statistic": 1.0, "p_value": p, "flagged": p < 0.01}
              for name, p in p_values.items()]
    return SimpleNamespace(selected=None, checks={"baseline": checks},
                           settings=SimpleNamespace(n_rep=n_rep))


def test_criticism_report_prints_p_values_of_zero_as_bounds():
    # reference: format_p_value's rule above; scatter_* and max_abs_z_* count 100 replicates,
    # loo_pit_* is ArviZ's analytic uniformity test
    result = _fake_criticism({"scatter_R_c_bulged": 0.0, "max_abs_z_k_c": 1.0,
                              "trend_R_c": 0.25, "loo_pit_R_c": 0.0})
    rows = {line.split("|")[1].strip(" `"): line.split("|")[3].strip()
            for line in report.criticism._checks_table(result) if line.startswith("| `")}
    assert rows == {"scatter_R_c_bulged": "1, < 0.01 **FLAGGED**", "max_abs_z_k_c": "1, > 0.99",
                    "trend_R_c": "1, 0.25", "loo_pit_R_c": "1, < 1e-300 **FLAGGED**"}


def test_html_prints_p_values_of_zero_as_bounds():
    crit = {"gain": {"delta_elpd": 0.0, "se": 0.0}, "misfit_detected": True,
            "selected_effect": None, "cause": "none",
            "checks": [{"name": "scatter_R_c_bulged", "statistic": 4.3, "p_value": 0.0,
                        "flagged": True}],
            "candidates": [], "parameters": {"baseline": {}, "extended": None}}
    cdiag = {"settings": {"n_rep": 1000}}
    page = report.html._criticism(crit, cdiag)
    assert "<td>scatter_R_c_bulged</td><td>4.3</td><td>&lt; 0.001</td>" in page
    assert "<td>0</td>" not in page
    # without criticism_diagnostics.json the number of replicates is unknown: said in words
    page = report.html._criticism(crit, None)
    assert "<td>4.3</td><td>no replicate as extreme</td>" in page


def test_one_thickness_sentence_names_both_and_why():
    # references: docs/fem.md (the shipped FE table: t = 6 nm; 4.5 nm lowers k/(PR) by 2.1 %
    # at the physiological point) and docs/physics.md (moduli with t = 4.5 +- 1.5 nm)
    if not surrogate.default_path().is_file():
        pytest.skip("shipped surrogate table not built yet")
    from turgorbayes.surrogate.thickness import load_at_thickness

    table = surrogate.load()
    assert report.text.table_thickness_nm(table) == pytest.approx(6.0)
    note = report.text.thickness_note(6.0)
    for text in ("t = 4.5 +- 1.5 nm", "computed for a 6 nm wall", "2.1 %",
                 "--wall-thickness-nm 4.5"):
        assert text in note, text
    thin = load_at_thickness(4.5e-9, base=table)
    assert report.text.table_thickness_nm(thin) == pytest.approx(4.5)
    assert report.text.thickness_note(4.5).startswith("One wall thickness")


@OUT_DIR_GROUP
def test_criticism_report_says_why_its_baseline_differs_from_the_fit(out_dir):
    # reference: criticism.json's baseline sd and ESS; the Monte Carlo standard error of a
    # Gaussian median is sqrt(pi/2) sd/sqrt(ESS), of a 5 % quantile
    # sqrt(0.05 * 0.95)/phi(1.645) sd/sqrt(ESS) = 2.11 sd/sqrt(ESS)
    text = (out_dir / "crit" / "report.md").read_text()
    gamma = json.loads((out_dir / "crit" / "criticism.json").read_text())[
        "parameters"]["baseline"]["gamma"]
    unit = gamma["sd"] / math.sqrt(gamma["ess_bulk"])
    assert f"(gamma: +-{math.sqrt(math.pi / 2) * unit:.2g})" in text
    assert f"(+-{2.113 * unit:.2g})" in text
    assert "quote the fit's for the baseline" in text
    # and the two thicknesses, with the FE table's own (the shipped 6 nm table)
    assert report.text.thickness_note(6.0) in text
    # the fit's report.md says the same (the shipped table: 6 nm, docs/fem.md)
    assert report.text.thickness_note(6.0) in (out_dir / "report.md").read_text()


def _entry(q05, q50, q95):
    return {"mean": q50, "sd": (q95 - q05) / 3.29, "q05": q05, "q50": q50, "q95": q95,
            "r_hat": None, "ess_bulk": 900.0, "ess_tail": 900.0}


def test_the_fit_is_the_one_baseline_beside_the_extension():
    # reference: hand-made summary.json and criticism.json of the same data (one sha256). The
    # fit's P_phys (30.1 [28.2, 32.3]) differs from the criticism's own baseline posterior
    # (29.7 [27.9, 31.8]); the page's baseline column must be the fit's, and with a fit of other
    # data the criticism's own, labelled as such
    fit = {"model": "baseline", "data": {"sha256": "abc"},
           "parameters": {"P_phys_kPa": _entry(28.2, 30.1, 32.3)}}
    crit = {"gain": {"delta_elpd": 9.0, "se": 2.0}, "selected_effect": "radius_spread",
            "checks": [], "candidates": [],
            "parameters": {"baseline": {"P_phys_kPa": _entry(27.9, 29.7, 31.8),
                                        "gamma": _entry(1.1, 1.2, 1.3)},
                           "extended": {"P_phys_kPa": _entry(25.0, 27.0, 29.0)}}}
    cdiag = {"data_sha256": "abc", "models": {"baseline": {"engine": "importance"}}}
    page = report.html._criticism(crit, cdiag, fit)
    assert "<td>30.1 [28.2, 32.3]</td>" in page and "29.7 [" not in page
    assert "baseline (the fit)" in page and "27 [25, 29]" in page
    other = report.html._criticism(crit, dict(cdiag, data_sha256="other"), fit)
    assert "<td>29.7 [27.9, 31.8]</td>" in other and "30.1 [" not in other
    assert "baseline (the criticism" in other
