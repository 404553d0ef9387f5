"""A candidate whose fit fails numerically does not end the criticism: it is recorded with its
reason, left out of the comparison, and named by the verdict (docs/effects.md, "Workflow").

References: the same criticism without the failing candidate (draws are keyed by the
candidate's name, so every other model's posterior is bit-identical), and the failure planted
by hand (an OverflowError raised inside the candidate's likelihood, the kind a mode search
meets when walkers leave the domain).
"""

import dataclasses
import json

import pytest
from numpy.testing import assert_array_equal

from turgorbayes import effects
from turgorbayes.report.criticism import write_outputs
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows.criticize import CriticismSettings, criticism_dict, criticize

SETTINGS = CriticismSettings(
    n_draws=1000, n_rep=200, max_refits=0, retry_factor=1, flag_draws=50, n_walkers=12,
    n_ensembles=4, tol=25, check_every=50, max_steps=4000)


def _overflow(ctx, v):
    raise OverflowError("cannot convert float infinity to integer")


def test_a_candidate_that_fails_is_recorded_and_the_criticism_goes_on(table, monkeypatch,
                                                                       tmp_path):
    cells = synthetic.simulate_cells(n_bulged=12, n_intact=8, seed=5, surrogate=table)[0]
    settings = dataclasses.replace(SETTINGS, effects=("pressure_error", "bad_curves"))
    clean = criticize(cells, table, seed=2, settings=dataclasses.replace(
        SETTINGS, effects=("pressure_error",)))
    monkeypatch.setattr(effects.get_effect("bad_curves"), "apply", _overflow)
    result = criticize(cells, table, seed=2, settings=settings)
    failed = next(c for c in result.candidates if c["effect"] == "bad_curves")
    assert failed["failed"] == "OverflowError: cannot convert float infinity to integer"
    assert failed["converged"] is False and failed["delta_elpd"] is None
    assert "bad_curves" not in result.posteriors and "bad_curves" not in result.stacking["weights"]
    # the other candidate is the run without the failing one, to the bit
    assert_array_equal(result.posteriors["pressure_error"].u, clean.posteriors["pressure_error"].u)
    assert result.verdict["status"] == clean.verdict["status"]
    assert ("Could not be fitted, so not considered: bad_curves (OverflowError: cannot convert "
            "float infinity to integer).") in result.verdict["text"]
    # the outputs are written and say it
    write_outputs(result, tmp_path)
    d = json.loads((tmp_path / "criticism.json").read_text())
    assert d == json.loads(json.dumps(criticism_dict(result)))
    entry = next(c for c in d["candidates"] if c["effect"] == "bad_curves")
    assert entry["failed"].startswith("OverflowError") and entry["delta_elpd"] is None
    assert "could not be fitted: OverflowError" in (tmp_path / "report.md").read_text()


def test_a_programming_error_still_ends_the_run(table, monkeypatch):
    # a TypeError is a bug, not a numerical failure: it must not be hidden as a failed fit
    cells = synthetic.simulate_cells(n_bulged=12, n_intact=8, seed=5, surrogate=table)[0]

    def bug(ctx, v):
        raise TypeError("unsupported operand")

    monkeypatch.setattr(effects.get_effect("bad_curves"), "apply", bug)
    with pytest.raises(TypeError, match="unsupported operand"):
        criticize(cells, table, seed=2, settings=dataclasses.replace(
            SETTINGS, effects=("bad_curves",)))
