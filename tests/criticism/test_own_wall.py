"""The ``own_wall`` effect: a condition's own wall stiffness, a candidate of the criticism on
data with several conditions (docs/effects.md, own_wall).

References: the baseline with conditions of :mod:`turgorbayes.inference.conditions` with
treated's E0t freed (an independent implementation of each cell's log-likelihood: with
``E0t__1 = E0t exp(r)`` it is the same model), the simulated truths (treated's wall planted
30 % softer, both conditions' turgors 29 and 22 kPa), and the rule of which conditions can
have a wall of their own (at least MIN_BULGED = 4 bulged cells in the reference and in the
condition, docs/statistics.md).
"""

import dataclasses

import numpy as np
import pytest
from test_conditions_criticism import SETTINGS, SOFTER, TRUTH, two_conditions

from turgorbayes import effects
from turgorbayes.effects.conditions import ConditionsExtendedModel
from turgorbayes.errors import DataError
from turgorbayes.inference import conditions as ic
from turgorbayes.simulation import conditions as synthetic_conditions
from turgorbayes.workflows.criticize import criticism_dict, criticize

_CACHE = {}


def _criticized(table):
    """criticize() of treated's softer wall with own_wall and turgor_spread as candidates."""
    if "softer" not in _CACHE:
        cells = two_conditions(table, seed=1, E0t_ratio=SOFTER)
        settings = dataclasses.replace(SETTINGS, effects=("turgor_spread", "own_wall"))
        result = criticize(cells, table, seed=1, settings=settings)
        _CACHE["softer"] = (result, criticism_dict(result))
    return _CACHE["softer"]


def test_own_wall_is_the_conditions_model_with_the_wall_freed(table):
    # reference: ConditionsModel with E0t of treated freed, at E0t__1 = E0t exp(r)
    cells = two_conditions(table, n_bulged=12, n_intact=8, E0t_ratio=SOFTER)
    model = ConditionsExtendedModel(cells, table, ["own_wall"])
    assert model.names[-1] == "ln_E0t_ratio__1"
    assert model.parameters[-1].key == "ln_E0t_ratio[treated]"
    r = np.log(SOFTER)
    v = {"gamma": TRUTH.gamma, "E0t": TRUTH.E0t, "R0": TRUTH.R0, "P_phys": 29e3,
         "P_phys__1": 22e3, "R0__1": TRUTH.R0, "ln_E0t_ratio__1": r}
    cs = ic.condition_set(cells, None, ["E0t:treated"])
    base = ic.ConditionsModel(cells, table, cs)
    vb = {"gamma": v["gamma"], "E0t": v["E0t"], "E0t__1": v["E0t"] * np.exp(r),
          "R0__0": v["R0"], "P_phys__0": 29e3, "P_phys__1": 22e3, "R0__1": v["R0"]}
    np.testing.assert_allclose(model.pointwise_log_likelihood(model.to_u(v)),
                               base.pointwise_log_likelihood(base.to_u(vb)), rtol=1e-12)
    # the derived E0t of treated is the product, named as a freed wall would be
    d = model.derived(model.to_u(v), np.random.default_rng(0))
    assert model.variable("E0t", 1) == "E0t__1" and model.variable("E0t", 0) == "E0t"
    np.testing.assert_allclose(d["E0t__1"], TRUTH.E0t * SOFTER, rtol=1e-12)
    # the FE-table check sees treated's own wall
    phys = model.to_physical(model.to_u(v))
    (idx0, wt), (idx1, treated) = model.condition_values(phys)
    np.testing.assert_array_equal(idx1, model.idx[1])
    np.testing.assert_allclose(treated["E0t"], TRUTH.E0t * SOFTER, rtol=1e-12)
    assert wt["E0t"] == pytest.approx(TRUTH.E0t, rel=1e-12)


def test_own_wall_needs_bulged_cells_in_two_conditions(table):
    # reference: the rule (docs/statistics.md): bulged cells (>= 4) in the reference and in
    # another condition; with one condition the effect is no candidate
    e = effects.get_effect("own_wall")
    wt_only, _ = synthetic_conditions.simulate_conditions(
        {"wt": 29e3, "treated": 22e3}, n_intact=6, n_bulged={"wt": 8, "treated": 3}, seed=1,
        surrogate=table)
    reason = e.not_applicable_reason(wt_only)
    assert "bulged cells (at least 4) in the reference condition 'wt' and in another" in reason
    single = wt_only.take(np.array(wt_only.extra["condition"]) == "wt")
    assert "naming two or more conditions" in e.not_applicable_reason(single)
    with pytest.raises(DataError, match="naming two or more conditions"):
        e.bind(single)
    three, _ = synthetic_conditions.simulate_conditions(
        {"wt": 29e3, "treated": 22e3, "drug": 25e3}, n_intact=4,
        n_bulged={"wt": 5, "treated": 1, "drug": 6}, seed=1, surrogate=table)
    bound = e.bind(three)
    assert [p.key for p in bound.parameters] == ["ln_E0t_ratio[drug]"]
    assert bound.wall_ratios() == {("E0t", 2): "ln_E0t_ratio__2"}


def test_own_wall_is_no_candidate_when_per_condition_frees_the_wall(table):
    # reference: one wall quantity cannot be both freed and a ratio (one model, two names)
    from turgorbayes.effects.conditions import conditions_reason

    cells = two_conditions(table, n_bulged=6, n_intact=4)
    cs = ic.condition_set(cells, None, ["E0t"])
    assert conditions_reason("own_wall", cells, cs) == "--per-condition already frees E0t of treated"
    assert conditions_reason("own_wall", cells, ic.condition_set(cells)) is None
    with pytest.raises(ValueError, match="both freed"):
        ConditionsExtendedModel(cells, table, ["own_wall"], conditions=cs)


@pytest.mark.slow
def test_verdict_adopts_own_wall_and_carries_its_contrasts(table):
    # simulated truth: treated's E0t 0.7 x wt's, turgors 29 and 22 kPa, 36 bulged + 20 intact
    # cells each (seed 1 of the block of docs/effects.md: the check flags it)
    result, d = _criticized(table)
    assert d["selected_effect"] == "own_wall" and d["verdict"]["status"] == "explained"
    cond = d["verdict"]["conditions"]
    assert cond["check"]["flagged"] is True  # the baseline's check points at it
    assert cond["adopted"] == "own_wall" and cond["adopted_walls"] == {"E0t": ["treated"]}
    assert cond["suggestion"] is None  # nothing left to free
    text = d["verdict"]["text"]
    for words in ("The wall differs between conditions: the wall stiffness E0t of treated is 0.",
                  "The criticism adopts own_wall, which gives E0t of treated a value of its own",
                  "do not assume that wall shared"):
        assert words in text, words
    # the contrasts of the adopted model and of the model average cover the truths
    for which in ("adopted", "model_average"):
        e0t = next(c for c in cond["contrasts"][which] if c["quantity"] == "E0t_N_per_m")
        assert e0t["ratio"]["q05"] < SOFTER < e0t["ratio"]["q95"], (which, e0t["ratio"])
        P = next(c for c in cond["contrasts"][which] if c["quantity"] == "P_phys_kPa")
        assert P["difference"]["q05"] < -7.0 < P["difference"]["q95"], (which, P)
    # the candidate's estimate is the log ratio, ln 0.7 = -0.357 inside its interval
    cand = next(c for c in d["candidates"] if c["effect"] == "own_wall")
    est = cand["estimate"]["ln_E0t_ratio[treated]"]
    assert est["q05"] < np.log(SOFTER) < est["q95"], est
