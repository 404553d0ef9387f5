"""``turgorbayes simulate --conditions`` with bulged cells per condition and walls of a
condition's own (``--n-bulged-per-condition``, ``--condition-wall``).

References: the closed-form wall law (:func:`turgorbayes.physics.wall.radius_at_pressure`)
at the planted wall and each cell's simulated true pressure; the spec's own numbers.
"""

import json
import re

import numpy as np
import pytest

from turgorbayes.cells.table import read_cells
from turgorbayes.physics import wall
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation import conditions as synthetic_conditions

TRUTH = synthetic.PAPER_TRUTH


def _run(*args):
    from turgorbayes.cli import main

    with pytest.raises(SystemExit) as exit_:
        main(["simulate", *args])
    return exit_.value.code


def test_condition_wall_plants_the_wall_round_trip(tmp_path, table):
    out = tmp_path / "exp.csv"
    assert _run("--out", str(out), "--conditions", "wt:29,treated:22", "--noise-free",
                "--n-intact-per-condition", "4", "--n-bulged-per-condition", "5",
                "--condition-wall", "treated:E0t=0.7", "--condition-wall",
                "treated:gamma=1.4,R0=480") == 0
    cells = read_cells(out)
    truths = json.loads(out.with_suffix(".json").read_text())
    labels = np.array(cells.extra["condition"])
    # bulged cells in every condition: 5 each
    assert [int(np.sum(cells.is_bulged & (labels == n))) for n in ("wt", "treated")] == [5, 5]
    # the truths: E0t a factor of the shared --E0t, gamma a value, R0 in nm (SI in JSON)
    planted = {"E0t": 0.7 * TRUTH.E0t, "gamma": 1.4, "R0": 480e-9}
    assert truths["walls"]["treated"] == pytest.approx(planted, rel=1e-12)
    assert "wt" not in truths["walls"]
    # closed form: each noise-free cell's R_c is the wall law's radius at its true pressure
    # (bulged: its own; intact: its condition's turgor) with its condition's wall
    ids = list(cells.cell_id)
    for name, w in (("wt", {"gamma": TRUTH.gamma, "E0t": TRUTH.E0t, "R0": TRUTH.R0}),
                    ("treated", planted)):
        tc = truths["conditions"][name]["cells"]
        P = np.array(tc["P_kPa"]) * 1e3
        i = [ids.index(cid) for cid in tc["cell_id"]]
        R = wall.radius_at_pressure(P, w["gamma"], w["E0t"], w["R0"], TRUTH.P0)
        np.testing.assert_allclose(cells.R_c[i], R, rtol=1e-9)
    intact_treated = (labels == "treated") & ~cells.is_bulged
    np.testing.assert_allclose(
        cells.R_c[intact_treated],
        wall.radius_at_pressure(22e3, 1.4, 0.7 * TRUTH.E0t, 480e-9, TRUTH.P0), rtol=1e-9)


def test_bad_wall_specs_name_the_value(tmp_path, capsys):
    base = ["--out", str(tmp_path / "x.csv"), "--conditions", "wt:29,treated:22"]
    cases = [("treated:E0t=-0.7", "E0t must be a positive number .*got '-0.7'"),
             ("treated:E0t=soft", "got 'soft'"),
             ("mutant:E0t=0.7", "no condition 'mutant'"),
             ("treated:P_phys=3", "'P_phys=3' is not QUANTITY=VALUE"),
             ("treated", "needs NAME:QUANTITY=VALUE")]
    for spec, message in cases:
        assert _run(*base, "--condition-wall", spec) != 0
        assert re.search(message, capsys.readouterr().err), spec
    with pytest.raises(ValueError, match="E0t of treated given twice"):
        synthetic_conditions.parse_walls(["treated:E0t=0.7", "treated:E0t=0.8"],
                                         ["wt", "treated"], TRUTH)
    for text, message in (("wt:3,mutant:2", "'mutant' is not a condition"),
                          ("wt:x", "must be an integer >= 0, got 'x'"),
                          ("0", "at least one bulged cell")):
        with pytest.raises(ValueError, match=message):
            synthetic_conditions.parse_bulged_counts(text, ["wt", "treated"])
    # counts: one number for every condition, or by name (a condition not named gets none)
    assert synthetic_conditions.parse_bulged_counts("36", ["wt", "treated"]) == {
        "wt": 36, "treated": 36}
    assert synthetic_conditions.parse_bulged_counts("wt:72", ["wt", "treated"]) == {"wt": 72}
    assert _run("--out", str(tmp_path / "y.csv"), "--condition-wall", "wt:E0t=0.7") != 0
    assert "need --conditions" in capsys.readouterr().err
