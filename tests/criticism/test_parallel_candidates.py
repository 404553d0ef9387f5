"""The candidates of a criticism fitted side by side give the serial criticism (docs/effects.md,
"Workflow"): each candidate's draws are keyed by its name, so the processes that fit them
cannot change them. Reference: the serial run (workers = 1), compared to the bit.
"""

import dataclasses
import pickle

import numpy as np
from numpy.testing import assert_array_equal

from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows.criticize import CriticismSettings, criticism_dict, criticize

SETTINGS = CriticismSettings(
    n_draws=1000, n_rep=200, max_refits=0, retry_factor=1, flag_draws=50, n_walkers=12,
    n_ensembles=4, tol=25, check_every=50, max_steps=4000,
    effects=("pressure_error", "turgor_spread", "bad_curves"))


def test_cells_survive_a_trip_to_a_worker(table):
    # reference: the cells themselves; the read-only extra columns come back read-only
    cells = synthetic.simulate_cells(4, 3, seed=1, surrogate=table, n_sessions=2)[0]
    back = pickle.loads(pickle.dumps(cells))
    assert_array_equal(back.k_c, cells.k_c) and back.cell_id == cells.cell_id
    assert dict(back.extra) == dict(cells.extra) and back.sha256 == cells.sha256
    assert not back.k_c.flags.writeable


def test_two_workers_give_the_serial_criticism(table):
    cells = synthetic.simulate_cells(30, 20, seed=5, surrogate=table)[0]
    runs = [criticize(cells, table, seed=2, settings=dataclasses.replace(SETTINGS, workers=w))
            for w in (1, 2)]
    for name in runs[0].posteriors:
        assert_array_equal(runs[0].posteriors[name].u, runs[1].posteriors[name].u, err_msg=name)
        assert_array_equal(runs[0].loo[name]["elpd_i"], runs[1].loo[name]["elpd_i"])
    d = [criticism_dict(r) for r in runs]
    assert d[0] == d[1]
    assert np.isfinite(d[0]["parameters"]["baseline"]["P_phys_kPa"]["mean"])
