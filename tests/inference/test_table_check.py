"""The FE-table check takes the posterior draws a block at a time (turgorbayes/inference/
table_check.py, ``CHUNK_POINTS``): the shares are those of every draw at once, and no call of
the forward model sees more than the block's points.

Reference: the same function with one block holding every draw (the computation before the
blocks); the data are test_fit.py's buckled-corner design (gamma = 2.0, E0t = 0.02 N/m, bulge
pressures down to 0.5 kPa), whose low-pressure cells reach the table's buckled box, so both
reasons have non-zero shares to compare.
"""

import copy

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from turgorbayes.inference import table_check
from turgorbayes.simulation import cells as synthetic


@pytest.fixture(scope="module")
def design(table):
    """Cells reaching the buckled corner and 30 draws of a wall around their truth."""
    unbuckled = copy.copy(table)
    unbuckled.buckled_boxes = []  # the data take the interpolated values, as in test_fit.py
    truth = synthetic.Truth(gamma=2.0, E0t=0.02, R0=464.2e-9, P_phys=29e3)
    cells, _ = synthetic.simulate_cells(n_bulged=30, n_intact=12, seed=7, truth=truth,
                                        surrogate=unbuckled,
                                        design_kwargs={"P_range": (0.5e3, 25e3)})
    rng = np.random.default_rng(3)
    draws = {"gamma": rng.uniform(1.6, 2.4, 30), "E0t": rng.uniform(0.01, 0.03, 30),
             "R0": rng.uniform(440e-9, 490e-9, 30),
             # some draws' turgor beyond the table for the intact cells
             "P_phys": np.geomspace(5e3, 2e6, 30)}
    return cells, draws


def test_blocks_of_draws_give_the_shares_of_all_draws_at_once(design, table, monkeypatch):
    cells, draws = design
    reference = table_check.cell_shares(draws, cells, table, chunk_points=10**12)
    assert all(reference[name].any() for name in table_check.REASONS)  # not a vacuous test
    sizes, undefined = [], table_check.undefined_shares

    def recorded(surrogate, P, weights, *wall):
        sizes.append(np.broadcast_shapes(P.shape, *(np.shape(a) for a in wall)))
        return undefined(surrogate, P, weights, *wall)

    monkeypatch.setattr(table_check, "undefined_shares", recorded)
    n_bulged = int(np.count_nonzero(cells.is_bulged))
    block = 7 * n_bulged * table_check.N_NODES  # 7 draws of the bulged cells: 30 = 4 x 7 + 2
    shares = table_check.cell_shares(draws, cells, table, chunk_points=block)
    for name in table_check.REASONS:
        assert_array_equal(shares[name], reference[name], err_msg=name)
    # each call holds at most `block` points; the bulged cells' calls take 7, 7, 7, 7, 2 draws
    assert max(int(np.prod(s)) for s in sizes) <= block
    assert [s[0] for s in sizes if s[1] == n_bulged] == [7, 7, 7, 7, 2]
