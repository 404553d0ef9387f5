"""Planning a two-condition experiment (turgorbayes.workflows.design, ``turgorbayes design``).

References: counts of hand-made result rows (the summary's rates), the simulated truth of the
wall planted in a design's experiment (closed form of the wall law), and the measured block of
docs/validation.md ("A wall that may differ") for the end-to-end run.
"""

import click
import numpy as np
import pytest

from turgorbayes.cli.design import parse_truths
from turgorbayes.physics import wall
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows import design


def _row(label, number, in_90, p, width=4.0):
    q = [-width / 2, -1, 0, 1, width / 2]
    return {"truth_label": label, "number": number, "converged": True, "prob_greater": p,
            "difference_kPa": {"q05_q16_q50_q84_q95": q, "in_90": in_90, "in_68": in_90},
            "E0t_ratio": {"in_90": True}}


def test_summary_rates_are_the_counts_of_the_rows():
    # reference: 3 of 4 rows cover, 2 of 4 claim a direction (p 0.99 and 0.01), width 4 kPa
    rows = [_row("0.7:0:0", "headline", True, 0.99), _row("0.7:0:0", "headline", True, 0.01),
            _row("0.7:0:0", "headline", False, 0.5), _row("0.7:0:0", "headline", True, 0.94)]
    s = design.design_summary(rows)["0.7:0:0 headline"]
    assert s["n"] == 4 and s["difference_coverage_90"][0] == 0.75
    assert s["direction_claimed"][0] == 0.5
    assert s["difference_coverage_90"][1] == pytest.approx(np.sqrt(0.75 * 0.25 / 4))
    assert s["mean_width_90_kPa"] == pytest.approx(4.0)


def test_truths_are_read_or_refused_with_the_item():
    assert parse_truths("0.7:0:0,prior,1:0.1:-0.25") == [(0.7, 0.0, 0.0), "prior",
                                                         (1.0, 0.1, -0.25)]
    for bad in ("0.7:0", "x:0:0", "-1:0:0", "1:0:-1.5"):
        with pytest.raises(click.BadParameter, match=f"{bad!r}"):
            parse_truths(bad)


def test_an_experiment_plants_the_treated_wall(table):
    # reference: the wall law's closed form at the planted wall (E0t x 0.7, gamma + 0.1) and
    # the treated turgor (29 kPa x 0.8): noise-free intact cells sit exactly on it
    from turgorbayes.simulation import conditions as sc

    cells, truth = design.experiment(3, (0.7, 0.1, -0.2), {"wt": 8}, 5, table,
                                     {"E0t": 0.35, "gamma": 0.2})
    assert truth == (0.7, 0.1, -0.2)
    T = synthetic.PAPER_TRUTH
    clean, _ = sc.simulate_conditions({"wt": 29e3, "treated": 29e3 * 0.8}, n_intact=5,
                                      n_bulged={"wt": 8}, seed=3, surrogate=table, noise=False,
                                      walls={"treated": {"E0t": 0.7 * T.E0t,
                                                         "gamma": T.gamma + 0.1}})
    treated = (np.array(clean.extra["condition"]) == "treated") & ~clean.is_bulged
    R = wall.radius_at_pressure(29e3 * 0.8, T.gamma + 0.1, 0.7 * T.E0t, T.R0)
    np.testing.assert_allclose(clean.R_c[treated], R, rtol=1e-9)
    assert len(cells) == len(clean)


@pytest.mark.slow
def test_the_design_tells_a_softer_wall_from_a_turgor_drop(table):
    # simulated truths, the README's design (72 bulged cells in wt, 42 intact per condition),
    # data seed 5100, the first of the measured block (docs/validation.md: over 100 experiments
    # the headline claimed a change in 0 % with the wall x 0.7 and detected a 25 % drop in 100 %;
    # the shared-wall number claimed a change in 94 % with the wall alone changed)
    rows = design.simulate_design(truths=((0.7, 0.0, 0.0), (1.0, 0.0, -0.25)), n_experiments=1,
                                  seed=5100, surrogate=table, progress_bar=False)
    s = design.design_summary(rows)
    assert s["0.7:0:0 headline"]["direction_claimed"][0] == 0
    assert s["0.7:0:0 headline"]["difference_coverage_90"][0] == 1
    assert s["0.7:0:0 shared_wall"]["direction_claimed"][0] == 1
    assert s["1:0:-0.25 headline"]["direction_claimed"][0] == 1
