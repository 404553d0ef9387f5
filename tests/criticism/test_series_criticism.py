"""``turgorbayes criticize`` on an osmotic series (docs/effects.md, "Osmotic series").

References: the simulated truth (an osmotic series with osmoadaptation planted through
per-cell times after the shift, tau 10 min); the documented battery without bulged cells
(11 checks); the declared refusals (outer_membrane on a series, a series with conditions).
"""

import dataclasses
import json

import numpy as np
import pytest

from turgorbayes import effects
from turgorbayes.errors import DataError
from turgorbayes.report import criticism as report_criticism
from turgorbayes.simulation.osmotic import simulate_osmotic_series
from turgorbayes.workflows.criticize import CriticismSettings, check_criticism_data, criticize

SETTINGS = CriticismSettings(
    n_draws=1000, n_rep=700, max_refits=3, retry_factor=1,
    n_walkers=12, n_ensembles=4, tol=25, check_every=50,
    max_steps=4000, progress=False, flag_draws=50)


@pytest.mark.slow
def test_criticize_runs_on_a_series_with_osmoadaptation_among_the_candidates(table, tmp_path):
    # Truth planted: recovery time constant 600 s (Osmoadaptation.timed_injection). Before the
    # series was sampled at its reference turgor (inference/wall_reference.py) this candidate's
    # mode search stopped on R0's prior bound and missed it (docs/validation.md).
    osmo = effects.get_effect("osmoadaptation")
    cells, _ = simulate_osmotic_series(n_intact=48, n_bulged=0, seed=2, surrogate=table,
                                       effects=(osmo.timed_injection(600.0),))
    settings = dataclasses.replace(SETTINGS, effects=("osmoadaptation", "turgor_spread",
                                                      "outer_membrane"))
    with pytest.raises(DataError, match="osmotic series"):  # asked for by name: refused
        criticize(cells, table, seed=2, settings=settings)
    settings = dataclasses.replace(SETTINGS, effects=("osmoadaptation", "turgor_spread"))
    result = criticize(cells, table, seed=2, settings=settings)
    report_criticism.write_outputs(result, tmp_path)
    d = json.loads((tmp_path / "criticism.json").read_text())
    assert [c["effect"] for c in d["candidates"]][:2] == ["osmoadaptation", "turgor_spread"]
    assert len(d["checks"]) == 11  # no bulged cells: trend, bulged scatter, bulged_vs_intact off
    tau = d["candidates"][0]["estimate"]["tau_rec_s"]
    assert tau["q05"] < 600.0 < tau["q95"]  # the planted time constant


def test_a_series_with_conditions_is_refused(table):
    cells, _ = simulate_osmotic_series(n_intact=8, n_bulged=0, seed=1, surrogate=table)
    labels = tuple("a" if i % 2 else "b" for i in range(len(cells)))
    cells = dataclasses.replace(cells, extra=dict(cells.extra, condition=labels))
    with pytest.raises(DataError, match="several conditions"):
        check_criticism_data(cells)
    assert np.all(~cells.is_bulged)
