"""Conditions measured as osmotic series on the command line: ``simulate --conditions
--osmotic-series`` -> ``fit`` -> ``table``, and what the command line refuses.

References: the simulation's truths (the JSON sidecar) and the option texts themselves.
"""

import contextlib
import io
import json

import pytest

from turgorbayes.cli import main


def _run(args):
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(printed), \
            pytest.raises(SystemExit) as exit_info:
        main(args)
    return exit_info.value.code, printed.getvalue()


def _simulate(path, *extra):
    return _run(["simulate", "--out", str(path), "--conditions", "wt:29,treated:29",
                 "--condition-wall", "treated:E0t=0.7", "--n-bulged", "0",
                 "--n-intact-per-condition", "16", "--seed", "3", *extra])


def test_simulate_writes_each_condition_as_a_series_with_its_truths(tmp_path, table):
    data = tmp_path / "two.csv"
    code, text = _simulate(data, "--osmotic-series", "0,100")
    assert code == 0, text
    assert "each an osmotic series at 0, 100 mOsm added" in text
    truths = json.loads(data.with_suffix(".json").read_text())
    assert truths["walls"] == {"treated": {"E0t": pytest.approx(0.7 * 0.026)}}
    wt, treated = (truths["conditions"][n]["osmotic"]["levels"] for n in ("wt", "treated"))
    assert [lv["medium_mOsm"] for lv in wt] == [300, 400]
    assert [lv["n_intact"] for lv in treated] == [8, 8]
    # both at 29 kPa in the growth medium; after the step the balance, which involves the
    # wall (a softer wall gives up more volume per kPa), puts them at different turgors
    assert wt[0]["P_kPa"] == pytest.approx(29) and treated[0]["P_kPa"] == pytest.approx(29)
    assert treated[1]["P_kPa"] != pytest.approx(wt[1]["P_kPa"], rel=1e-3)


def test_options_that_do_not_apply_to_series_are_refused(tmp_path, table):
    data = tmp_path / "two.csv"
    assert _simulate(data, "--osmotic-series", "0,100")[0] == 0
    code, text = _run(["fit", str(data), "--out", str(tmp_path / "f"), "--assume-shared-wall"])
    assert code == 2 and "do not apply to osmotic series" in text, text
    code, text = _run(["fit", str(data), "--out", str(tmp_path / "f"), "--per-condition", "R0"])
    assert code == 2 and "only gamma can be freed" in text, text
    # a condition measured in one medium only, without bulged cells: its wall is unknown
    lines = data.read_text().splitlines()
    head = [ln for ln in lines if ln.startswith("#")]
    rows = [ln for ln in lines if not ln.startswith("#")]
    col = rows[0].split(",").index("medium_mOsm")
    keep = [r for r in rows[1:] if not (r.startswith("treated") and r.split(",")[col] == "400")]
    one = tmp_path / "one_level.csv"
    one.write_text("\n".join(head + rows[:1] + keep) + "\n")
    code, text = _run(["fit", str(one), "--out", str(tmp_path / "g")])
    assert code == 2 and "condition 'treated'" in text and "wall is not identified" in text, text


@pytest.mark.slow
def test_command_line_conditions_series_end_to_end(tmp_path, table):
    data = tmp_path / "two.csv"
    assert _simulate(data, "--osmotic-series", "0,100")[0] == 0
    out = tmp_path / "fit"
    # the CLI's fewest steps: what is checked is the outputs' content and form, not the
    # estimates (their recovery: tests/inference/test_osmotic_conditions_model.py)
    code, text = _run(["fit", str(data), "--out", str(out), "--no-progress", "--walkers", "10",
                       "--max-steps", "100"])
    assert code == 0, text
    assert "each an osmotic series that measures its own wall" in text
    assert "E0t of treated is" in text and "times wt's" in text
    summary = json.loads((out / "summary.json").read_text())
    assert list(summary["conditions"]) == ["wt", "treated"]
    assert {"P_phys_kPa", "E0t_N_per_m", "R0_nm"} <= set(summary["conditions"]["treated"])
    quantities = [c["quantity"] for c in summary["contrasts"]]
    assert quantities == ["P_phys_kPa", "E0t_N_per_m", "R0_nm"]
    assert all(c["checked_by_data"] for c in summary["contrasts"])
    levels = summary["osmotic"]["levels"]
    assert [(lv["condition"], lv["medium_mOsm"]) for lv in levels] == [
        ("wt", 300), ("wt", 400), ("treated", 300), ("treated", 400)]
    assert not {"b", "P_level__0__0", "buffering__1", "E0t__1"} & set(summary["parameters"])
    assert summary["parameters"]["P_phys_kPa"]["mean"] == pytest.approx(
        summary["conditions"]["wt"]["P_phys_kPa"]["mean"])
    report = (out / "report.md").read_text()
    assert "## Conditions" in report and "| treated | 400 |" in report
    assert (out / "conditions.png").is_file()
    code, text = _run(["table", str(out)])
    assert code in (0, None) and "treated vs wt,E0t_N_per_m ratio" in text
