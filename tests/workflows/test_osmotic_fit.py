"""An osmotic series from simulation to posterior: the truths recovered, and the command line
end to end (``simulate --osmotic-series`` -> ``fit``).

References: the simulation's truths (turgorbayes.simulation.osmotic).
"""

import contextlib
import io
import json

import numpy as np
import pytest

from turgorbayes.cli import main
from turgorbayes.inference.engine import Settings, fit_posterior
from turgorbayes.inference.osmotic import OsmoticModel, level_variable, osmotic_design
from turgorbayes.inference.posterior import weighted_stats
from turgorbayes.simulation.osmotic import simulate_osmotic_series


@pytest.mark.slow
def test_series_without_bulges_recovers_the_truths(table):
    cells, truths = simulate_osmotic_series(seed=1, surrogate=table)  # 4 levels x 30 cells
    model = OsmoticModel(cells, table, osmotic_design(cells))
    guess = model.start_values(model.least_squares().fit().estimate)
    post = fit_posterior(model, guess, 1, Settings(engine="importance", progress=False),
                         pointwise=False)
    assert post.converged
    values = post.physical(np.random.default_rng(1))
    p = truths["parameters"]
    truth = {"gamma": p["gamma"], "E0t": p["E0t_N_per_m"], "R0": p["R0_nm"] * 1e-9,
             "P_phys": p["P_phys_kPa"] * 1e3, "b": truths["osmotic"]["b"]}
    truth.update({level_variable(k): lv["P_kPa"] * 1e3
                  for k, lv in enumerate(truths["osmotic"]["levels"])})
    for name, x in truth.items():
        s = weighted_stats(values[name], post.weights)
        assert abs(s["mean"] - x) < 3 * s["sd"], (name, s, x)
    # turgor without a bulge, to the paper's +-3 kPa and better
    assert weighted_stats(values["P_phys"], post.weights)["sd"] < 1.5e3


def _run(args):
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(printed), \
            pytest.raises(SystemExit) as exit_info:
        main(args)
    return exit_info.value.code, printed.getvalue()


@pytest.mark.slow
def test_command_line_series_end_to_end(tmp_path, table):
    data = tmp_path / "series.csv"
    code, text = _run(["simulate", "--out", str(data), "--n-bulged", "0", "--n-intact", "48",
                       "--osmotic-series", "0,50,100,150", "--seed", "2"])
    assert code == 0, text
    assert "350 mOsm 19.6 kPa (12)" in text  # the balance at the paper's values, b = 0.3
    truths = json.loads(data.with_suffix(".json").read_text())
    assert [lv["medium_mOsm"] for lv in truths["osmotic"]["levels"]] == [300, 350, 400, 450]
    out = tmp_path / "fit"
    # the CLI's fewest steps: what is checked is the outputs' content and form, not the
    # estimates (their recovery: test_series_without_bulges_recovers_the_truths above)
    code, text = _run(["fit", str(data), "--out", str(out), "--no-progress", "--walkers", "10",
                       "--max-steps", "100", "--reference-medium", "300"])
    assert code == 0, text
    assert "fitting 0 bulged + 48 intact cells with model osmotic" in text
    assert "osmotic series (P_phys is the turgor at 300 mOsm" in text
    summary = json.loads((out / "summary.json").read_text())
    levels = summary["osmotic"]["levels"]
    assert [lv["medium_mOsm"] for lv in levels] == [300, 350, 400, 450]
    assert [lv["n_intact"] for lv in levels] == [12, 12, 12, 12]
    assert "b" not in summary["parameters"] and "P_level__0" not in summary["parameters"]
    assert summary["parameters"]["P_phys_kPa"]["mean"] == pytest.approx(
        levels[0]["turgor_kPa"]["mean"])
    for name in ("posterior.nc", "fit.png", "corner.png", "report.md"):
        assert (out / name).is_file()
    assert "## Osmotic series" in (out / "report.md").read_text()
    # the options of a series are refused without one; criticize accepts a series but refuses
    # a candidate that cannot act on one when asked for it by name (before any fit)
    code, text = _run(["fit", "--out", str(tmp_path / "x"), "--temperature-K", "300"])
    assert code == 2 and "--temperature-K need(s) intact cells measured in media of two" in text
    code, text = _run(["criticize", str(data), "--out", str(tmp_path / "c"),
                       "--effects", "outer_membrane"])
    assert code == 2 and "not a candidate for an osmotic series" in text, text


def test_criticize_takes_the_series_options_and_refuses_them_without_a_series(tmp_path, table):
    # Everything here is refused or built before any fit. Reference: the definition of the
    # reference medium (its level's turgor is P_phys, docs/statistics.md "Osmotic series").
    from turgorbayes.workflows.criticize import CriticismSettings, criticism_model

    cells, _ = simulate_osmotic_series(n_intact=24, n_bulged=0, seed=3, surrogate=table)
    settings = CriticismSettings(reference_medium=350.0, temperature=310.0, length_model="fixed")
    model = criticism_model(cells, table, [], settings)
    d = model.design
    assert (d.reference, d.temperature, d.length_model) == (350.0, 310.0, "fixed")
    v = {"gamma": np.array([1.22]), "E0t": np.array([0.026]), "R0": np.array([464.2e-9]),
         "P_phys": np.array([20e3]), "b": np.array([0.3])}
    assert model.level_states(v)["P"][0, d.ref] == pytest.approx(20e3, rel=1e-9)
    assert model.level_states(v)["P"][0, 0] > 20e3  # the lower osmolarity: more turgor
    data = tmp_path / "series.csv"
    code, text = _run(["simulate", "--out", str(data), "--n-bulged", "0", "--n-intact", "24",
                       "--osmotic-series", "0,50,100,150", "--seed", "3"])
    assert code == 0, text
    code, text = _run(["criticize", str(data), "--out", str(tmp_path / "c"),
                       "--reference-medium", "320"])
    assert code == 2 and "--reference-medium 320 mOsm is not a level" in text, text
    code, text = _run(["criticize", "--out", str(tmp_path / "d"), "--length-model", "fixed"])
    assert code == 2 and "--length-model need(s) intact cells measured in media of two" in text
