"""``turgorbayes table DIR``: the command writes the rows of turgorbayes.report.table.

References: a hand-written summary.json read back independently with json, the csv parsed with
the csv module, and the exit status 2 that turgorbayes.cli.main gives every TurgorBayesError.
"""

import csv
import json

import pytest

from turgorbayes.cli import main

SUMMARY = {"model": "baseline", "data": {"path": "c.csv", "sha256": "d" * 64},
           "surrogate": {"path": "k.nc", "sha256": "e" * 64}, "version": "0.3.0.dev0",
           "seed": 5, "dependencies": {"numpy": "2.5.5", "lock_sha256": "f" * 64},
           "parameters": {"P_phys_kPa": {"mean": 28.453, "sd": 0.5012, "q05": 27.65,
                                         "q50": 28.44, "q95": 29.31, "r_hat": 1.0021,
                                         "ess_bulk": 3304.1, "ess_tail": 3254.4}}}


def _run(args, capsys):
    with pytest.raises(SystemExit) as exc:
        main(args)
    out = capsys.readouterr()
    return exc.value.code, out.out, out.err


@pytest.fixture
def fit_dir(tmp_path):
    (tmp_path / "fit").mkdir()
    (tmp_path / "fit" / "summary.json").write_text(json.dumps(SUMMARY), encoding="utf-8")
    return tmp_path / "fit"


def test_table_csv_to_file(fit_dir, tmp_path, capsys):
    out = tmp_path / "tables" / "quote.csv"
    code, stdout, _ = _run(["table", str(fit_dir), "--out", str(out)], capsys)
    assert code == 0 and stdout == f"wrote {out}\n"
    with open(out, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    entry = json.loads((fit_dir / "summary.json").read_text())["parameters"]["P_phys_kPa"]
    (row,) = [r for r in rows if r["quantity"] == "P_phys_kPa"]
    assert {k: float(row[k]) for k in ("mean", "sd", "q05", "q50", "q95", "r_hat", "ess_bulk")} \
        == {k: entry[k] for k in ("mean", "sd", "q05", "q50", "q95", "r_hat", "ess_bulk")}
    (row,) = [r for r in rows if r["quantity"] == "lock_sha256"]
    assert row["value"] == "f" * 64


@pytest.mark.parametrize(("fmt", "first"), [("markdown", "| section | name | quantity |"),
                                            ("latex", r"\begin{tabular}")])
def test_table_formats_print(fit_dir, capsys, fmt, first):
    code, stdout, _ = _run(["table", str(fit_dir), "--format", fmt], capsys)
    assert code == 0 and stdout.startswith(first)
    assert ("28.45" in stdout) and ("28.453" not in stdout)  # 4 significant digits


def test_table_of_a_folder_without_outputs(tmp_path, capsys):
    code, stdout, stderr = _run(["table", str(tmp_path)], capsys)
    assert code == 2 and stdout == ""
    assert stderr.count("\n") == 1
    assert stderr.startswith(f"error: {tmp_path} holds neither summary.json")
    assert "criticism.json" in stderr
