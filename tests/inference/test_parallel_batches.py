"""Importance sampling's batches of draws evaluated on two forked processes give the serial
evaluation bit for bit (:func:`turgorbayes.inference.posterior.log_lik_and_prior`): a batch
holds the same draws whatever the number of workers. Reference: the serial evaluation
(workers = 1) of the same draws, compared to the bit.
"""

import dataclasses

import numpy as np
from numpy.testing import assert_array_equal

from turgorbayes.effects import ExtendedModel
from turgorbayes.inference.posterior import log_lik_and_prior
from turgorbayes.simulation import cells as synthetic


def test_two_workers_give_the_serial_batches(table):
    cells = synthetic.simulate_cells(12, 8, seed=3, surrogate=table)[0]
    # the pair of the bundled example's criticism: the dense gross-error branch inside the
    # radius integral, whose rules depend on every draw of a batch
    model = ExtendedModel(cells, table, ["radius_spread", "outliers"])
    wls = ExtendedModel(cells, table, []).least_squares().fit()
    u0 = model.to_u(model.start_values(wls.estimate))[0]
    rng = np.random.default_rng(4)
    u = u0 + 0.05 * rng.standard_normal((70, u0.size))  # 70 draws: batches 32, 32, 6
    u[5, 0] = np.inf  # a draw outside the prior stays -inf in both
    serial = log_lik_and_prior(model, u, 32, workers=1)
    parallel = log_lik_and_prior(model, u, 32, workers=2)
    assert np.isfinite(serial[0][0]).all() and np.isneginf(serial[0][5]).all()
    for a, b in zip(serial, parallel, strict=True):
        assert_array_equal(a, b)


def test_two_workers_give_the_serial_gross_error_screen(table):
    # reference: the serial screen (workers = 1) of the same draws, to the bit; one reading
    # made a gross error so that the screen has something to find
    from turgorbayes.effects.outliers import flagged_cells

    cells = synthetic.simulate_cells(12, 8, seed=3, surrogate=table)[0]
    k_c = cells.k_c.copy()
    k_c[15] *= 3.0
    cells = dataclasses.replace(cells, k_c=k_c)
    model = ExtendedModel(cells, table, ["radius_spread", "outliers"])
    wls = ExtendedModel(cells, table, []).least_squares().fit()
    u0 = model.to_u(model.start_values(wls.estimate))[0]
    u = u0 + 0.05 * np.random.default_rng(5).standard_normal((40, u0.size))
    v = dict(model.to_physical(u))
    serial = flagged_cells(model, v, cells.cell_id, batch=16, workers=1)
    parallel = flagged_cells(model, v, cells.cell_id, batch=16, workers=2)
    assert any(f["cell_id"] == cells.cell_id[15] and f["quantity"] == "k_c" for f in serial), serial
    assert serial == parallel


def test_a_task_pool_gives_the_serial_batches_and_screen(table):
    # reference: the serial evaluation of the same draws, to the bit; within an open task
    # pool (the criticism's candidates, each fitted in a thread) every batch is a task of it
    from turgorbayes.effects.outliers import flagged_cells
    from turgorbayes.parallel import task_pool

    cells = synthetic.simulate_cells(12, 8, seed=3, surrogate=table)[0]
    model = ExtendedModel(cells, table, ["radius_spread", "outliers"])
    wls = ExtendedModel(cells, table, []).least_squares().fit()
    u0 = model.to_u(model.start_values(wls.estimate))[0]
    u = u0 + 0.05 * np.random.default_rng(4).standard_normal((70, u0.size))
    v = dict(model.to_physical(u[:40]))
    serial = log_lik_and_prior(model, u, 32), flagged_cells(model, v, cells.cell_id, batch=16)
    with task_pool(2):
        pooled = log_lik_and_prior(model, u, 32), flagged_cells(model, v, cells.cell_id, batch=16)
    for a, b in zip(serial[0], pooled[0], strict=True):
        assert_array_equal(a, b)
    assert serial[1] == pooled[1]
