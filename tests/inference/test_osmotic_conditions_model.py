"""Several conditions measured as osmotic series: the likelihood, the variables, the refusals.

References: the single-condition :class:`~turgorbayes.inference.osmotic.OsmoticModel` on each
condition's cells alone (its own tests check it against the osmotic balance), and the
simulation's truths (turgorbayes.simulation.conditions with a series).
"""

import numpy as np
import pytest

from turgorbayes.errors import DataError
from turgorbayes.inference.engine import Settings, fit_posterior
from turgorbayes.inference.osmotic import OsmoticModel, osmotic_design
from turgorbayes.inference.osmotic_conditions import (
    OsmoticConditionsModel,
    series_condition_set,
    series_designs,
)
from turgorbayes.inference.posterior import weighted_stats
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation.conditions import simulate_conditions

TRUTH = synthetic.PAPER_TRUTH


def two_series(table, added=(0.0, 100.0), n_intact=16, n_bulged=None, seed=4):
    """wt (the paper's wall) and treated (E0t x 0.7), both at 29 kPa, each a series."""
    return simulate_conditions({"wt": 29e3, "treated": 29e3}, n_intact=n_intact,
                               n_bulged=n_bulged or {}, truth=TRUTH, seed=seed, surrogate=table,
                               walls={"treated": {"E0t": 0.7 * TRUTH.E0t}},
                               series={"added": added})


def model_of(cells, table, per_condition=()):
    cs = series_condition_set(cells, per_condition=per_condition)
    return OsmoticConditionsModel(cells, table, cs, series_designs(cells, cs))


def test_likelihood_is_the_sum_of_each_conditions_own_series_model(table):
    # reference: each condition's cells fitted alone by OsmoticModel at that condition's
    # values; treated's E0t differs from wt's, so a swapped or shared mapping fails
    cells, _ = two_series(table, n_bulged={"wt": 6})
    model = model_of(cells, table)
    v = {"gamma": np.array([1.1, 1.3, 1.22]), "b": np.array([0.25, 0.3, 0.35]),
         "P_phys__0": np.array([27e3, 29e3, 31e3]), "E0t__0": np.array([0.022, 0.026, 0.03]),
         "R0__0": np.array([450e-9, 464e-9, 470e-9]), "P_phys__1": np.array([30e3, 28e3, 26e3]),
         "E0t__1": np.array([0.015, 0.018, 0.021]), "R0__1": np.array([455e-9, 460e-9, 480e-9])}
    joint = model.pointwise_log_likelihood(model.to_u(v))
    labels = np.asarray(cells.extra["condition"])
    total = 0.0
    for c, name in enumerate(("wt", "treated")):
        idx = np.flatnonzero(labels == name)
        sub = cells.take(idx)
        single = OsmoticModel(sub, table, osmotic_design(sub, reference_medium=300.0))
        own = {"gamma": v["gamma"], "b": v["b"], "P_phys": v[f"P_phys__{c}"],
               "E0t": v[f"E0t__{c}"], "R0": v[f"R0__{c}"]}
        ll = single.pointwise_log_likelihood(single.to_u(own))
        np.testing.assert_allclose(joint[:, idx], ll, rtol=1e-12)
        total = total + ll.sum(axis=1)
    assert np.all(np.isfinite(total))
    np.testing.assert_allclose(joint.sum(axis=1), total, rtol=1e-12)


def test_variables_follow_the_conditions_naming(table):
    cells, _ = two_series(table)
    assert model_of(cells, table).names == ("gamma", "P_phys__0", "E0t__0", "R0__0",
                                            "P_phys__1", "E0t__1", "R0__1", "b")
    freed = model_of(cells, table, per_condition=["gamma"])
    assert freed.names == ("P_phys__0", "gamma__0", "E0t__0", "R0__0", "P_phys__1",
                           "gamma__1", "E0t__1", "R0__1", "b")
    cs = freed.conditions
    assert cs.assumptions(1) == (["b shared", "same reference medium"], True)
    assert model_of(cells, table).conditions.assumptions(1) == (
        ["gamma shared", "b shared", "same reference medium"], True)


def test_a_condition_without_a_series_or_bulges_is_refused(table):
    cells, _ = two_series(table)
    labels = np.asarray(cells.extra["condition"])
    medium = np.asarray(cells.extra["medium_mOsm"], float)
    one_level = cells.take(np.flatnonzero((labels == "wt") | (medium == 300.0)))
    cs = series_condition_set(one_level)
    assert cs.series == (True, False)
    with pytest.raises(DataError, match="condition 'treated'.*wall is not identified") as err:
        series_designs(one_level, cs)
    assert err.value.column == "condition"
    cells, _ = two_series(table, added=(0.0, 50.0, 100.0), n_intact=18)
    labels = np.asarray(cells.extra["condition"])
    medium = np.asarray(cells.extra["medium_mOsm"], float)
    no_reference = cells.take(np.flatnonzero((labels == "wt") | (medium > 300.0)))
    with pytest.raises(DataError, match="'treated' has no intact cells at the reference medium "
                                        "300 mOsm"):
        series_designs(no_reference, series_condition_set(no_reference))
    with pytest.raises(DataError, match="only gamma can be freed"):
        series_condition_set(cells, per_condition=["R0"])


@pytest.mark.slow  # 5-25 s, with the load of the machine
def test_one_simulated_experiment_recovers_the_wall_ratio_and_equal_turgor(table):
    # simulated truth: treated's E0t 0.7 x wt's, the same turgor 29 kPa; the study's design
    # (0, 50, 100, 150 mOsm added x 30 intact cells, no bulged cell); data seed 1, the first
    # of studies/osmotic_conditions.py (not chosen)
    from turgorbayes.inference.osmotic import B_PRIOR

    b = float(B_PRIOR.sample(np.random.default_rng([1, 52])))
    cells, _ = simulate_conditions({"wt": 29e3, "treated": 29e3}, n_intact=120, n_bulged={},
                                   truth=TRUTH, seed=1, surrogate=table,
                                   walls={"treated": {"E0t": 0.7 * TRUTH.E0t}},
                                   series={"added": (0.0, 50.0, 100.0, 150.0), "b": b})
    model = model_of(cells, table)
    guess = model.start_values(model.least_squares().fit().estimate)
    post = fit_posterior(model, guess, 1, Settings(engine="importance", progress=False),
                         pointwise=False)
    assert post.converged
    x = post.physical(np.random.default_rng(1))
    ratio = weighted_stats(x["E0t__1"] / x["E0t__0"], post.weights)
    dP = weighted_stats(x["P_phys__1"] - x["P_phys__0"], post.weights)
    assert ratio["q05"] <= 0.7 <= ratio["q95"], ratio
    assert dP["q05"] <= 0.0 <= dP["q95"], dP
    assert ratio["q95"] < 1.0  # the wall change is seen, not read as turgor
    assert dP["q95"] - dP["q05"] < 3e3  # the paper's +-3 kPa of one P_phys, on a difference
