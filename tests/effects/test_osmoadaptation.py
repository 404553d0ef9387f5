"""Tests of the ``osmoadaptation`` effect (the series' level turgors recover toward P_phys).

References: the series model without effects (f_rec = 0 is the null); closed form at
f_rec = 1 (every intact cell at P_phys: Gaussian densities of its readings about the forward
model's radius and stiffness at P_phys, turgorbayes.physics.forward); the exponential
recovery 1 - exp(-t/tau) evaluated by hand for the per-cell times; the simulated truth of an
injection; the data format's refusal of a bad entry.
"""

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from turgorbayes import effects
from turgorbayes.cells.table import read_cells, write_cells
from turgorbayes.effects.series import SeriesModel
from turgorbayes.errors import DataError
from turgorbayes.inference.observations import stiffness_sd
from turgorbayes.physics import forward
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation.osmotic import simulate_osmotic_series

TRUE = {"gamma": 1.22, "E0t": 0.026, "R0": 464.2e-9, "P_phys": 29e3, "b": 0.3}
OSMO = effects.get_effect("osmoadaptation")


@pytest.fixture(scope="module")
def series(table):
    return simulate_osmotic_series(n_intact=40, n_bulged=0, seed=5, surrogate=table)[0]


def _with_minutes(cells, column):
    return dataclasses.replace(cells, extra=dict(cells.extra, minutes_after_shift=column))


def _u(model, **extra):
    return model.to_u(dict(TRUE, **extra))


def test_at_zero_it_is_the_series_model(table, series):
    # reference: SeriesModel without effects (the effect's null value f_rec = 0)
    model, base = SeriesModel(series, table, ["osmoadaptation"]), SeriesModel(series, table)
    with np.errstate(divide="ignore"):
        ll = model.pointwise_log_likelihood(_u(model, f_rec=0.0))
    assert_allclose(ll, base.pointwise_log_likelihood(_u(base)), rtol=0, atol=1e-12)


def test_at_one_every_level_is_at_p_phys(table, series):
    # reference: closed form, each intact cell's Gaussian densities at the forward model's
    # R_c, k_c at P_phys (the likelihood's pooled relative stiffness error: the group's RMS)
    model = SeriesModel(series, table, ["osmoadaptation"])
    ll = model.pointwise_log_likelihood(_u(model, f_rec=1.0 - 1e-15))[0]
    R, k = forward.cell_radius_and_stiffness(TRUE["P_phys"], TRUE["gamma"], TRUE["E0t"],
                                             TRUE["R0"], 5e3, table)
    rel = np.sqrt(np.mean((series.k_c_err / series.k_c) ** 2))
    ref = (stats.norm.logpdf(series.R_c, R, series.R_c_err)
           + stats.norm.logpdf(series.k_c, k, stiffness_sd(k, series.k_c, rel * series.k_c)))
    assert_allclose(ll, ref, rtol=0, atol=1e-8)
    # and the levels really differ from P_phys without the effect (the test can fail)
    assert np.ptp(model.cell_pressures(_u(model, f_rec=1e-9))) > 5e3


def test_minutes_give_each_cell_its_own_recovery(table, series, tmp_path):
    # reference: P_i = P_k + (1 - exp(-t_i/tau)) (P_phys - P_k) by hand, P_k the series
    # model's level turgor (cell_pressures without the effect)
    minutes = np.round(np.linspace(0.0, 30.0, len(series)), 3)  # as written below
    data = _with_minutes(series, tuple(f"{m:g}" for m in minutes))
    model = SeriesModel(data, table, ["osmoadaptation"])
    assert model.names[-1] == "tau_rec"
    tau = 400.0
    P = model.cell_pressures(_u(model, tau_rec=tau))[0]
    P_k = SeriesModel(series, table).cell_pressures(_u(SeriesModel(series, table)))[0]
    f = 1 - np.exp(-60 * minutes / tau)
    assert_allclose(P, P_k + f * (TRUE["P_phys"] - P_k), rtol=1e-12)


def test_a_bad_minutes_entry_is_refused_with_its_line(table, series, tmp_path):
    # reference: the data format (docs/data_format.md): a number >= 0 on every intact row
    data = _with_minutes(series, ("3",) * (len(series) - 1) + ("-2",))
    path = tmp_path / "bad.csv"
    write_cells(data, path)
    with pytest.raises(DataError) as err:
        read_cells(path)
    assert err.value.column == "minutes_after_shift" and err.value.value == "-2"
    assert err.value.line is not None


def test_only_a_series_can_have_it(table):
    # reference: the effect's declaration (not_applicable_reason), one medium
    plain = synthetic.simulate_cells(seed=1, surrogate=table)[0]
    assert "osmotic series" in OSMO.not_applicable_reason(plain)


def test_the_injection_moves_the_simulated_levels(table):
    # reference: the simulated truth, P_k + f (P_phys - P_k) per level with f = 0.5
    _, truths = simulate_osmotic_series(n_intact=8, n_bulged=0, seed=1, surrogate=table,
                                        effects=(OSMO.injection(0.5),))
    levels = truths["osmotic"]["levels"]  # the balance's turgors, before the recovery
    P = np.array(truths["cells"]["P_kPa"])
    P_k = np.repeat([lv["P_kPa"] for lv in levels], 2)
    assert_allclose(P, P_k + 0.5 * (29.0 - P_k), rtol=1e-9)
