"""Tests of ``turgorbayes report`` (turgorbayes.report, cli.report).

References: the diagnostic thresholds of turgorbayes.inference.diagnostics (R-hat < 1.01, ESS >= 400,
Vehtari et al. 2021) on hand-made summaries, including the boundary values; the files the
fit and criticism write (summary.json, criticism.json) for the numbers the page must show.
One short fit (deliberately not converged) and one short criticism are shared.
"""

import base64
import json
import re

import pytest

from turgorbayes import criticism, plots, report, results, surrogate
from turgorbayes.cli import main
from turgorbayes.io import example_path, read_cells
from turgorbayes.report.criticism import write_outputs

TINY = results.FitSettings(n_walkers=12, n_ensembles=4, max_steps=200, check_every=100,
                           n_nodes=4, max_draws_per_chain=100, progress=False)
CRIT = criticism.CriticismSettings(n_draws=400, n_rep=100, ess_min=50, max_refits=0,
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


@pytest.fixture(scope="module")
def out_dir(tmp_path_factory):
    if not surrogate.default_path().is_file():
        pytest.skip("shipped surrogate table not built yet")
    table = surrogate.load()
    cells = read_cells(example_path())
    d = tmp_path_factory.mktemp("fit")
    fit = results.fit_cells(cells, "baseline", seed=4, surrogate=table, settings=TINY)
    results.write_results(fit, d)
    crit = criticism.criticize(cells, table, seed=4, settings=CRIT)
    write_outputs(crit, d / "crit")
    name = crit.selected or "wall_softening"
    plots.write_bands(plots.extended_bands(crit.posteriors[name], plots.pressure_grid(fit)),
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
