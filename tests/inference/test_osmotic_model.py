"""The osmotic model (turgorbayes.inference.osmotic): intact cells at their medium level's
turgor, bulged cells as the baseline's, b sampled only with several levels.

References: each level's turgor from the physics balance and the cells' Gaussian densities
evaluated with scipy at the forward model's radius and stiffness of that turgor (the
radius found by the wall law's own inversion, not the balance's strain); the baseline's
likelihood for the bulged cells.
"""

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from turgorbayes.errors import DataError
from turgorbayes.inference.models import BaselineModel
from turgorbayes.inference.osmotic import OsmoticModel, level_variable, osmotic_design
from turgorbayes.physics import forward, osmotic
from turgorbayes.simulation.cells import PAPER_TRUTH
from turgorbayes.simulation.osmotic import simulate_osmotic_series

V = {"gamma": np.array([1.22, 1.1]), "E0t": np.array([0.026, 0.03]),
     "R0": np.array([464.2e-9, 470e-9]), "P_phys": np.array([29e3, 27e3]),
     "b": np.array([0.3, 0.25])}


@pytest.fixture(scope="module")
def series(table):
    cells, truths = simulate_osmotic_series((0, 50, 100), n_intact=12, n_bulged=6, seed=4,
                                            surrogate=table)
    return cells, truths


def test_intact_cells_sit_at_their_levels_turgor(series, table):
    cells, _ = series
    model = OsmoticModel(cells, table, osmotic_design(cells))
    assert model.names == ("gamma", "E0t", "R0", "P_phys", "b")
    ll = model.pointwise_log_likelihood(model.to_u(V))
    d = model.design
    intact = np.flatnonzero(~cells.is_bulged)
    for w in range(2):
        st = osmotic.turgor_after_shift(V["P_phys"][w], V["gamma"][w], V["E0t"][w], V["R0"][w],
                                        c_ref=300.0, c_out=d.levels, b=V["b"][w])
        P = st["P"][d.level_of]
        R, k = forward.cell_radius_and_stiffness(P, V["gamma"][w], V["E0t"][w], V["R0"][w],
                                                 surrogate=table)
        o = model.obs
        expected = (stats.norm.logpdf(o.R_c[intact], R, o.R_c_err[intact])
                    + stats.norm.logpdf(o.k_c[intact], k, o.k_c_err[intact] / o.k_c[intact] * k))
        assert_allclose(ll[w, intact], expected, rtol=1e-9)
    # the bulged cells are the baseline's, level for level
    one = cells.take(np.flatnonzero(cells.is_bulged).tolist() + [int(intact[0])])
    base = BaselineModel(dataclasses.replace(one, extra={}), table)
    v4 = {k: V[k] for k in ("gamma", "E0t", "R0", "P_phys")}
    assert_allclose(ll[:, cells.is_bulged],
                    base.pointwise_log_likelihood(base.to_u(v4))[:, :cells.n_bulged],
                    rtol=1e-12)


def test_derived_level_turgors_and_buffering(series, table):
    cells, truths = series
    model = OsmoticModel(cells, table, osmotic_design(cells))
    t = PAPER_TRUTH
    v = {"gamma": np.array([t.gamma]), "E0t": np.array([t.E0t]), "R0": np.array([t.R0]),
         "P_phys": np.array([t.P_phys]), "b": np.array([0.3])}
    out = model.derived(model.to_u(v), np.random.default_rng(0))
    # the simulation's truths come from the same balance at the same values (independently
    # called through simulate_osmotic_series)
    for k, lv in enumerate(truths["osmotic"]["levels"]):
        assert_allclose(out[level_variable(k)] / 1e3, lv["P_kPa"], rtol=1e-9)
    assert_allclose(out["buffering"], truths["osmotic"]["buffering"], rtol=1e-9)
    assert_allclose(out[level_variable(0)], t.P_phys, rtol=1e-12)  # the reference level


def test_design_reference_and_refusals(series, table):
    cells, _ = series
    assert osmotic_design(cells, reference_medium=400).ref == 2
    with pytest.raises(DataError, match=r"--reference-medium 320 mOsm is not a level.*300, 350, 400"):
        osmotic_design(cells, reference_medium=320)
    with pytest.raises(DataError, match="no medium_mOsm column"):
        osmotic_design(dataclasses.replace(cells, extra={}))
    one = cells.take(np.flatnonzero(~cells.is_bulged)[:4])  # the growth medium only, no bulges
    with pytest.raises(DataError, match="one medium level cannot tell the wall from the turgor"):
        OsmoticModel(one, table, osmotic_design(one))
    # one level with bulged cells: no b to sample (the balance never enters)
    mixed = cells.take(np.flatnonzero(cells.is_bulged).tolist() + [6, 7])
    assert OsmoticModel(mixed, table, osmotic_design(mixed)).names == (
        "gamma", "E0t", "R0", "P_phys")


def test_a_plasmolysed_level_has_no_likelihood(table):
    # a linear wall plasmolyses the cells of a strong step (turgor 0: no stiffness in the FE
    # model), so a turgid reading there has zero density
    cells, _ = simulate_osmotic_series((0, 20), n_intact=6, seed=2, surrogate=table)
    model = OsmoticModel(cells, table, osmotic_design(cells))
    v = {"gamma": np.array([0.0]), "E0t": np.array([0.1]), "R0": np.array([464.2e-9]),
         "P_phys": np.array([2e3]), "b": np.array([0.3])}
    st = model.level_states(v)
    assert st["plasmolysed"][0].tolist() == [False, True]
    ll = model.pointwise_log_likelihood(model.to_u(v))
    level = model.design.level_of
    assert np.all(np.isneginf(ll[0, ~cells.is_bulged][level == 1]))
    assert np.all(np.isfinite(ll[0, ~cells.is_bulged][level == 0]))
