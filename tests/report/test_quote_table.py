"""Tests of the table of numbers to quote (turgorbayes.report.table).

Reference: the numbers of summary.json / criticism.json / criticism_diagnostics.json, written
here by hand in the structure `turgorbayes fit` and `criticize` write (copied from real
outputs) and read back independently with the json module; the csv is parsed with the csv
module. One slow test runs a real fit and compares against its summary.json.
"""

import csv
import io
import json
import re

import pytest

from turgorbayes.errors import TurgorBayesError
from turgorbayes.report.table import COLUMNS, NOT_RECORDED, SHARED_WALL_NOTE, quote_table, render

STATS = ("mean", "sd", "q05", "q50", "q95")
DEPENDENCIES = {"numpy": "2.5.5", "scipy": "1.18.1", "emcee": "3.1.6",
                "lock_sha256": "88c098711af7aadc6fcafe0fe518c589c5b2d1678f57fa6f863b7f1a284dbaa5"}


def _entry(mean, sd, diag=True):
    """A summary entry whose fields all differ, so a swapped column cannot pass."""
    out = {"mean": mean, "sd": sd, "q05": mean - 1.7 * sd, "q50": mean + 0.01 * sd,
           "q95": mean + 1.6 * sd}
    if diag:
        out.update(r_hat=1.0 + sd / 1000, ess_bulk=3000 + mean, ess_tail=2900 + mean)
    return out


def _summary(conditions=False):
    summary = {
        "model": "baseline",
        "data": {"path": "cells.csv", "sha256": "a" * 64, "n_bulged": 72, "n_intact": 42},
        "surrogate": {"path": "k_over_PR.nc", "sha256": "b" * 64},
        "converged": True,
        "parameters": {"gamma": _entry(1.2833, 0.0401), "E0t_N_per_m": _entry(0.025051, 0.00057),
                       "R0_nm": _entry(467.71, 1.73), "P_phys_kPa": _entry(28.453, 0.5012),
                       "E_perp_MPa": _entry(54.751, 19.03), "E_par_MPa": _entry(23.941, 8.117)},
        "loo": {"elpd": 3335.1, "se": 16.5, "p_loo": 4.96, "n_pareto_k_bad": 0},
        "timing_s": 17.2, "version": "0.3.0.dev0", "dependencies": DEPENDENCIES, "seed": 7,
        "flagged_cells": [],
    }
    if conditions:
        summary["conditions"] = {
            "wt": {"P_phys_kPa": _entry(27.965, 0.6249, False), "R0_nm": _entry(462.79, 3.07, False)},
            "treated": {"P_phys_kPa": _entry(21.465, 2.0882, False),
                        "E0t_N_per_m": _entry(0.02983, 0.01019, False)}}
        summary["contrasts"] = [
            {"condition": "treated", "reference": "wt", "quantity": "P_phys_kPa",
             "difference": _entry(-6.5009, 1.99, False), "ratio": _entry(0.76775, 0.073, False),
             "prob_greater": 0.0056014, "assumes": ["gamma difference ~ N(0, 0.2)",
                                                    "ln(E0t ratio) ~ N(0, 0.35)"],
             "checked_by_data": False},
            # a summary of an older version: no assumes, no checked_by_data
            {"condition": "treated", "reference": "wt", "quantity": "R0_nm",
             "difference": _entry(4.897, 24.1, False), "ratio": _entry(1.0106, 0.052, False),
             "prob_greater": 0.63681}]
        summary["contrasts_shared_wall"] = [
            {"condition": "treated", "reference": "wt", "quantity": "P_phys_kPa",
             "difference": _entry(-6.4135, 0.602, False), "ratio": _entry(0.77087, 0.018, False),
             "prob_greater": 0.0, "assumes": ["gamma shared", "E0t shared"],
             "checked_by_data": False}]
        summary["wall_prior"] = {"gamma": 0.2, "E0t": 0.35}
    return summary


def _criticism(conditions=False):
    stats = {k: _entry(m, s, False) for k, m, s in (
        ("gamma", 1.2731, 0.057), ("E0t_N_per_m", 0.025381, 0.0008), ("R0_nm", 467.43, 2.7),
        ("P_phys_kPa", 28.502, 0.68), ("E_perp_MPa", 52.29, 18.1), ("E_par_MPa", 23.06, 7.7))}
    verdict = {"status": "partly_explained", "selected": "radius_spread", "remaining_checks": [],
               "text": "misfit partly explained", "conditions": None}
    if conditions:
        verdict["conditions"] = {
            "names": ["wt", "treated"], "reference": "wt", "adopted": "baseline",
            "values": {"adopted": {"wt": {"P_phys_kPa": {"q05": 1.0, "q50": 2.0, "q95": 3.0}}},
                       "model_average": {
                           "wt": {"P_phys_kPa": {"q05": 26.952, "q50": 28.242, "q95": 29.468}},
                           "treated": {"P_phys_kPa": {"q05": 24.810, "q50": 26.056,
                                                      "q95": 27.289}}}},
            "contrasts": {"adopted": [], "model_average": [
                {"condition": "treated", "reference": "wt", "quantity": "P_phys_kPa",
                 "difference": _entry(-2.1739, 0.65, False),
                 "ratio": _entry(0.92322, 0.022, False), "prob_greater": 0.00061506,
                 "sentence": "P_phys of treated is 2.18 kPa lower than wt [1.09, 3.22]"}]}}
    return {"misfit_detected": True, "checks": [], "candidates": [],
            "selected_effect": "radius_spread", "cause": "cells differ in width",
            "gain": {"delta_elpd": 1.5, "se": 1.7},
            "parameters": {"baseline": {"gamma": _entry(9.0, 9.0)}, "extended": None,
                           "model_average": stats},
            "baseline_convergence": {}, "flagged_cells": [], "fe_table": {},
            "verdict": verdict, "headline": "model_average"}


DIAGNOSTICS = {"seed": 11, "turgorbayes_version": "0.3.0.dev0", "dependencies": DEPENDENCIES,
               "data_sha256": "c" * 64, "settings": {}, "selection_rule": {}, "models": {},
               "candidates": [], "stacking": {}}


def _write(folder, name, content):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_text(json.dumps(content), encoding="utf-8")
    return folder


def _read(path):
    return json.loads(path.read_text(encoding="utf-8"))


def _csv_rows(folder):
    """The table as csv, parsed back with the csv module (reference: not the renderer)."""
    return list(csv.DictReader(io.StringIO(render(quote_table(folder), "csv"))))


def _find(rows, section, name, quantity):
    found = [r for r in rows if (r["section"], r["name"], r["quantity"]) == (section, name,
                                                                              quantity)]
    assert len(found) == 1, (section, name, quantity, found)
    return found[0]


def _assert_stats(row, entry, keys=STATS):
    for key in keys:
        if entry[key] is None:  # e.g. an R-hat that could not be computed
            assert row[key] == "", (row, key)
        else:
            assert float(row[key]) == entry[key], (row, key)  # csv keeps full precision


@pytest.fixture
def fit_dir(tmp_path):
    return _write(tmp_path / "fit", "summary.json", _summary())


@pytest.fixture
def conditions_dir(tmp_path):
    return _write(tmp_path / "exp_fit", "summary.json", _summary(conditions=True))


@pytest.fixture
def criticism_dir(tmp_path):
    d = _write(tmp_path / "crit", "criticism.json", _criticism())
    return _write(d, "criticism_diagnostics.json", DIAGNOSTICS)


def test_csv_of_a_fit_is_its_summary(fit_dir):
    rows = _csv_rows(fit_dir)
    summary = _read(fit_dir / "summary.json")  # reference: the file itself
    assert list(rows[0]) == list(COLUMNS)
    for key, entry in summary["parameters"].items():
        _assert_stats(_find(rows, "parameters", "baseline", key), entry,
                      STATS + ("r_hat", "ess_bulk"))
    assert {r["section"] for r in rows} == {"parameters", "provenance"}
    prov = {r["quantity"]: r["value"] for r in rows if r["section"] == "provenance"}
    assert prov == {"version": summary["version"], "data sha256": summary["data"]["sha256"],
                    "surrogate sha256": summary["surrogate"]["sha256"],
                    "seed": str(summary["seed"]), **summary["dependencies"]}


def test_csv_of_a_criticism_folder(criticism_dir):
    rows = _csv_rows(criticism_dir)
    crit = _read(criticism_dir / "criticism.json")
    diag = _read(criticism_dir / "criticism_diagnostics.json")
    assert _find(rows, "verdict", "criticism", "status")["value"] == "partly_explained"
    assert _find(rows, "verdict", "criticism", "selected effect")["value"] == "radius_spread"
    quoted = crit["parameters"][crit["headline"]]
    assert len([r for r in rows if r["section"] == "quote"]) == len(quoted)
    for key, entry in quoted.items():
        _assert_stats(_find(rows, "quote", "model_average", key), entry)
    # the baseline (9.0 everywhere) is not what the verdict says to quote
    assert not any(r["mean"] == "9.0" for r in rows)
    prov = {r["quantity"]: r["value"] for r in rows if r["section"] == "provenance"}
    assert prov["data sha256"] == diag["data_sha256"]
    assert prov["seed"] == str(diag["seed"])
    assert prov["lock_sha256"] == diag["dependencies"]["lock_sha256"]


def test_fit_folder_with_its_criticism(fit_dir, criticism_dir):
    criticism_dir.rename(fit_dir / "criticism")  # where `criticize` writes by default
    rows = _csv_rows(fit_dir)
    summary = _read(fit_dir / "summary.json")
    crit = _read(fit_dir / "criticism" / "criticism.json")
    _assert_stats(_find(rows, "parameters", "baseline", "P_phys_kPa"),
                  summary["parameters"]["P_phys_kPa"])
    _assert_stats(_find(rows, "quote", "model_average", "P_phys_kPa"),
                  crit["parameters"]["model_average"]["P_phys_kPa"])
    assert [r["name"] for r in rows if r["quantity"] == "seed"] == ["fit", "criticism"]


def test_conditions_contrasts_and_their_assumptions(conditions_dir):
    rows = _csv_rows(conditions_dir)
    summary = _read(conditions_dir / "summary.json")
    for cond, quantities in summary["conditions"].items():
        for key, entry in quantities.items():
            _assert_stats(_find(rows, "condition", cond, key), entry)
    new, old = summary["contrasts"]
    row = _find(rows, "contrast", "treated vs wt", "P_phys_kPa difference")
    _assert_stats(row, new["difference"], ("mean", "q05", "q50", "q95"))
    assert float(row["value"]) == new["prob_greater"]
    assert "assumes: gamma difference ~ N(0, 0.2), ln(E0t ratio) ~ N(0, 0.35)" in row["note"]
    assert "checked by data: no" in row["note"]
    _assert_stats(_find(rows, "contrast", "treated vs wt", "P_phys_kPa ratio"), new["ratio"],
                  ("mean", "q05", "q50", "q95"))
    row = _find(rows, "contrast", "treated vs wt", "R0_nm difference")
    assert float(row["value"]) == old["prob_greater"]
    assert row["note"].count(NOT_RECORDED) == 2  # neither assumes nor checked_by_data
    shared = summary["contrasts_shared_wall"][0]
    row = _find(rows, "contrast (shared wall)", "treated vs wt", "P_phys_kPa difference")
    _assert_stats(row, shared["difference"], ("mean", "q05", "q50", "q95"))
    assert SHARED_WALL_NOTE in row["note"] and "gamma shared, E0t shared" in row["note"]
    assert SHARED_WALL_NOTE not in _find(rows, "contrast", "treated vs wt",
                                         "P_phys_kPa difference")["note"]
    assert "reference condition (wt)" in _find(rows, "parameters", "baseline", "gamma")["note"]


def test_conditions_of_a_criticism(tmp_path):
    d = _write(tmp_path / "crit", "criticism.json", _criticism(conditions=True))
    rows = _csv_rows(d)
    cond = _read(d / "criticism.json")["verdict"]["conditions"]
    for name, quantities in cond["values"]["model_average"].items():
        _assert_stats(_find(rows, "quote condition", name, "P_phys_kPa"),
                      quantities["P_phys_kPa"], ("q05", "q50", "q95"))
    contrast = cond["contrasts"]["model_average"][0]
    row = _find(rows, "quote contrast", "treated vs wt", "P_phys_kPa difference")
    _assert_stats(row, contrast["difference"], ("mean", "q05", "q50", "q95"))
    assert float(row["value"]) == contrast["prob_greater"]
    assert not any(r["q50"] == "2.0" for r in rows)  # the adopted model's values are not quoted
    assert not any(r["section"] == "provenance" for r in rows)  # no criticism_diagnostics.json


def test_markdown_one_row_per_table_row(conditions_dir):
    rows = quote_table(conditions_dir)
    lines = render(rows, "markdown").splitlines()
    assert lines[0] == "| " + " | ".join(COLUMNS) + " |"
    assert lines[1] == "|---" * len(COLUMNS) + "|"
    assert len(lines) == 2 + len(rows)
    summary = _read(conditions_dir / "summary.json")
    for key, entry in summary["parameters"].items():
        cells = [c.strip() for c in lines[2 + [r["quantity"] for r in rows].index(key)]
                 .strip("|").split("|")]
        assert len(cells) == len(COLUMNS)
        assert cells[2] == key
        assert [float(c) for c in cells[4:9]] == [float(f"{entry[k]:.4g}") for k in STATS]


def test_latex_is_escaped_booktabs_with_four_digits(conditions_dir):
    text = render(quote_table(conditions_dir), "latex")
    summary = _read(conditions_dir / "summary.json")
    assert text.startswith(r"\begin{tabular}")
    assert r"\toprule" in text and r"\midrule" in text and r"\bottomrule" in text
    assert r"P\_phys\_kPa" in text and r"E0t\_N\_per\_m" in text
    assert r"\textasciitilde{} N(0, 0.2)" in text
    assert not re.search(r"(?<!\\)[_%#&~]", text.replace(" & ", " ").replace(r"\\", ""))
    gamma = summary["parameters"]["gamma"]
    line = next(x for x in text.splitlines() if x.startswith("parameters & baseline & gamma"))
    assert line.split(" & ")[4:9] == [f"{gamma[k]:.4g}" for k in STATS]
    assert line.split(" & ")[4] == "1.283"  # 1.2833 to 4 significant digits, by hand


def test_folder_without_outputs(tmp_path):
    with pytest.raises(TurgorBayesError, match=r"empty holds neither summary.json .* nor "
                                               r"criticism.json"):
        quote_table(_write(tmp_path / "empty", "notes.json", {}))
    with pytest.raises(TurgorBayesError, match="missing is not a folder"):
        quote_table(tmp_path / "missing")
    with pytest.raises(TurgorBayesError, match="format must be one of csv, markdown, latex"):
        render([], "html")


def test_unreadable_json_is_named(tmp_path):
    (tmp_path / "summary.json").write_text("{not json", encoding="utf-8")
    with pytest.raises(TurgorBayesError, match=r"cannot read .*summary.json: not JSON"):
        quote_table(tmp_path)


@pytest.mark.slow
def test_table_of_a_real_fit(tmp_path):
    from turgorbayes import surrogate
    from turgorbayes.cells.table import example_path, read_cells
    from turgorbayes.workflows import fit as results

    if not surrogate.default_path().is_file():
        pytest.skip("shipped surrogate table not built yet")
    settings = results.FitSettings(n_walkers=12, n_ensembles=4, max_steps=200, check_every=100,
                                   n_nodes=4, max_draws_per_chain=100, progress=False)
    fit = results.fit_cells(read_cells(example_path()), "baseline", seed=3,
                            surrogate=surrogate.load(), settings=settings)
    results.write_results(fit, tmp_path)
    summary = _read(tmp_path / "summary.json")  # reference: what the fit wrote
    rows = _csv_rows(tmp_path)
    assert len([r for r in rows if r["section"] == "parameters"]) == len(summary["parameters"])
    for key, entry in summary["parameters"].items():
        _assert_stats(_find(rows, "parameters", "baseline", key), entry,
                      STATS + ("r_hat", "ess_bulk"))
    prov = {r["quantity"]: r["value"] for r in rows if r["section"] == "provenance"}
    assert prov["data sha256"] == summary["data"]["sha256"]
    assert prov["surrogate sha256"] == summary["surrogate"]["sha256"]
    assert prov["lock_sha256"] == summary["dependencies"]["lock_sha256"]
