"""Measurement order: the ``order`` checks of the criticism and the ``drift`` effect
(docs/effects.md, "drift"; docs/data_format.md, "Measurement order").

References: scipy's least-squares regression (the checks' statistic is the sum over the groups
of the squared t of the residuals' slope on the order), the optional column's own values, and
simulated truths (every stiffness drifting by 30 % over a session measured in random order,
the rows then in measurement order; the null: the same design without a drift).
"""

import dataclasses

import numpy as np
import pytest
from scipy import stats

from turgorbayes import effects
from turgorbayes.cells.order import TIME_COLUMN, measurement_order
from turgorbayes.cells.table import CellData
from turgorbayes.criticism import checks
from turgorbayes.effects import ExtendedModel
from turgorbayes.errors import DataError
from turgorbayes.inference import models
from turgorbayes.inference.engine import fit_posterior
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows.criticize import (
    CriticismSettings,
    criticism_dict,
    criticize,
    predictive_checks,
)

SETTINGS = CriticismSettings(n_draws=1000, n_rep=700, max_refits=0, retry_factor=1,
                             n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                             max_steps=4000, flag_draws=50)
DRIFT = np.log(1.3)


def _with_extra(cells, extra):
    fields = ("R_c", "R_c_err", "k_c", "k_c_err", "R_b", "R_b_err", "k_b", "k_b_err", "h_b")
    return CellData(cell_id=cells.cell_id, group=cells.group, extra=extra,
                    comments=cells.comments, **{f: getattr(cells, f) for f in fields})


def _in_measurement_order(drift, seed, table):
    """64 bulged + 48 intact cells at 33 kPa, stiffnesses drifting by ``drift`` over a session
    measured in random order; rows in measurement order, the time column dropped."""
    cells, _ = synthetic.simulate_cells(64, 48, truth=synthetic.Truth(P_phys=33e3), seed=seed,
                                        surrogate=table,
                                        effects=[effects.get_effect("drift").injection(drift)])
    minutes = np.array([float(t) for t in cells.extra[TIME_COLUMN]])
    cells = cells.take(np.argsort(minutes, kind="stable"))
    return _with_extra(cells, {k: v for k, v in cells.extra.items() if k != TIME_COLUMN})


def test_order_statistic_is_the_groups_squared_slopes():
    rng = np.random.default_rng(4)
    z = rng.standard_normal((3, 40))
    order = np.linspace(-0.5, 0.5, 40)
    group = np.array(["bulged", "intact"] * 20)
    z[:, group == "intact"] += 2.0 * order[group == "intact"]
    def t(d, g):
        fit = stats.linregress(order[group == g], z[d, group == g])
        return fit.slope / fit.stderr

    ref = [t(d, "bulged") ** 2 + t(d, "intact") ** 2 for d in range(3)]
    np.testing.assert_allclose(checks.order_drift(z, order, group), ref, rtol=1e-10)


def test_measurement_order_reads_time_min_or_the_rows(table):
    cells, _ = synthetic.simulate_cells(3, 2, seed=1, surrogate=table)
    s, source = measurement_order(cells)
    assert source == "row order" and np.allclose(s, [-0.5, -0.25, 0.0, 0.25, 0.5])
    timed = _with_extra(cells, {TIME_COLUMN: ("10", "0", "30", "20", "40")})
    s, source = measurement_order(timed)
    assert source == TIME_COLUMN and np.allclose(s, [-0.25, -0.5, 0.25, 0.0, 0.5])
    bad = _with_extra(cells, {TIME_COLUMN: ("10", "0", "soon", "20", "40")})
    with pytest.raises(DataError, match="time_min.*finite number of minutes, got 'soon'.*b003"):
        measurement_order(bad)


def _order_checks(cells, table, seed):
    model = ExtendedModel(cells, table)
    post = fit_posterior(model, model.start_values(models.PaperWLS(cells, table).fit().estimate),
                         seed, SETTINGS)
    return {c["name"]: c for c in predictive_checks(post, seed, SETTINGS)[0]
            if c["name"].startswith("order_")}


def test_order_check_flags_a_drift_and_not_its_null(table):
    # simulated truth (seed 1 of studies/order_drift.py, whose rates are in docs/effects.md)
    drifted = _order_checks(_in_measurement_order(DRIFT, 1, table), table, 1)
    assert drifted["order_k_c"]["flagged"] and drifted["order_k_c"]["p_value"] < 1e-3
    null = _order_checks(_in_measurement_order(0.0, 1, table), table, 1)
    assert not any(c["flagged"] for c in null.values()), null


@pytest.mark.slow
def test_criticize_names_the_drift_and_measures_it(table):
    # simulated truth: beta = ln 1.3; candidates: the drift and its look-alikes
    cells = _in_measurement_order(DRIFT, 2, table)
    d = criticism_dict(criticize(cells, table, seed=2, settings=dataclasses.replace(
        SETTINGS, effects=("drift", "turgor_spread", "pressure_error", "discrepancy"))))
    assert d["selected_effect"] == "drift", d["verdict"]["text"]
    est = next(c for c in d["candidates"] if c["effect"] == "drift")["estimate"]["beta_drift"]
    assert est["q05"] <= DRIFT <= est["q95"], est
    assert "drift with measurement order" in d["verdict"]["text"]
