"""turgorbayes.simulation.planted: each planted effect's design (reference: the designs as
docs/validation.md states them: calibration in 6 sessions, radius_spread with 8-12 nm radius
errors (smaller than the default ErrorModel's 15-25 nm), the paper's 72 bulged + 42 intact
cells)."""

import numpy as np

from turgorbayes.simulation.planted import planted_cells


def test_each_effect_is_drawn_with_its_own_design(table):
    cal = planted_cells("calibration", 1, table)
    assert cal.n_bulged == 72 and cal.n_intact == 42
    assert len(set(cal.extra["session"])) == 6
    spread = planted_cells("radius_spread", 1, table, n_bulged=20, n_intact=10)
    assert np.all((spread.R_c_err >= 8e-9) & (spread.R_c_err <= 12e-9))
    null = planted_cells("null", 1, table, n_bulged=20, n_intact=10)
    assert "session" not in null.extra
    assert np.all((null.R_c_err >= 15e-9) & (null.R_c_err <= 25e-9))
