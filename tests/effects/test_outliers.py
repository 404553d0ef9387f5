"""Tests of the ``outliers`` effect and the flagged cells (docs/effects.md, outliers).

References: scipy.stats normal and lognormal densities in closed form (intact cells), a
brute-force trapezoid over the latent ln P with the exact forward model (bulged cells, both
bulge branches), Bayes' rule in closed form for an intact cell's reading, binomial counts of
injected gross errors, and simulated truth (planted outliers must be named, and only they).
"""

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import integrate, stats

from turgorbayes import effects
from turgorbayes.effects import ExtendedModel
from turgorbayes.effects.outliers import OUTLIER_LOG_SD, flagged_cells, outlier_probabilities
from turgorbayes.inference.observations import observations_from_cells
from turgorbayes.physics import forward
from turgorbayes.simulation import cells as synthetic

TRUE = {"gamma": 1.22, "E0t": 0.026, "R0": 464.2e-9, "P_phys": 29e3}


@pytest.fixture(scope="module")
def cells(table):
    return synthetic.simulate_cells(seed=21, surrogate=table)[0]


def _pooled(value, err, groups):
    rel = err / value
    for g in groups:
        rel = np.where(g, np.sqrt(np.mean(rel[g] ** 2)), rel)
    return rel * value


def _mix(f, good, y, m):
    # (1 - f) good + f lognormal(ln m, 1): the effect's definition, from scipy.stats
    return (1 - f) * good + f * stats.lognorm.pdf(y, OUTLIER_LOG_SD, scale=m)


def _brute_bulged(cells, table, i, f, n=40001):
    """log of (1-f) int g N(lnP_hat; x, s) mR mk dx + f int g N(lnP_hat; x, 1) mR mk dx."""
    obs = observations_from_cells(cells)
    j = int(np.flatnonzero(obs.bulged == i)[0])
    lo, hi = obs.population.support
    x = np.linspace(lo, hi, n)
    R, k = forward.cell_radius_and_stiffness(np.exp(x), TRUE["gamma"], TRUE["E0t"], TRUE["R0"],
                                             5e3, table)
    g = (cells.is_bulged, ~cells.is_bulged)
    k_err = _pooled(cells.k_c, cells.k_c_err, g)[i]
    mR = _mix(f, stats.norm.pdf(cells.R_c[i], R, cells.R_c_err[i]), cells.R_c[i], R)
    mk = _mix(f, stats.norm.pdf(cells.k_c[i], k, k_err / cells.k_c[i] * k), cells.k_c[i], k)
    prior = np.exp(obs.population.log_pdf(x))
    lp, s = obs.log_P_bulge[j], obs.sd_log_P_bulge[j]
    good = integrate.trapezoid(prior * stats.norm.pdf(lp, x, s) * mR * mk, x)
    bad = integrate.trapezoid(prior * stats.norm.pdf(lp, x, OUTLIER_LOG_SD) * mR * mk, x)
    return np.log((1 - f) * good + f * bad)


def test_outliers_likelihood_against_closed_form_and_brute_force(table, cells):
    f = 0.1
    model = ExtendedModel(cells, table, ["outliers"])
    ll = model.pointwise_log_likelihood(model.to_u(dict(TRUE, f_out=f)))[0]
    # intact cells: both readings' mixtures in closed form at P_phys
    R, k = forward.cell_radius_and_stiffness(TRUE["P_phys"], TRUE["gamma"], TRUE["E0t"],
                                             TRUE["R0"], 5e3, table)
    i = ~cells.is_bulged
    k_err = _pooled(cells.k_c, cells.k_c_err, (cells.is_bulged, i))[i]
    ref = np.log(_mix(f, stats.norm.pdf(cells.R_c[i], R, cells.R_c_err[i]), cells.R_c[i], R)
                 * _mix(f, stats.norm.pdf(cells.k_c[i], k, k_err / cells.k_c[i] * k),
                        cells.k_c[i], k))
    assert_allclose(ll[i], ref, rtol=1e-10)
    # bulged cells: the engine's adaptive rule plus the dense gross-error branch against a
    # 40001-point trapezoid over the whole population support
    for b in (0, 17, 50):
        assert_allclose(ll[b], _brute_bulged(cells, table, b, f), atol=1e-4)


def test_a_gross_bulge_error_is_integrated_over_the_whole_support(table, cells):
    # a bulge read 20x too high: the gross-error branch (placed by the cell's own R_c, k_c)
    # carries the cell; the reference is the brute-force integral of that branch
    bad = dataclasses.replace(cells, k_b=np.where(np.arange(cells.k_b.size) == 5, 20.0, 1.0)
                              * cells.k_b)
    model = ExtendedModel(bad, table, ["outliers"])
    ll = model.pointwise_log_likelihood(model.to_u(dict(TRUE, f_out=0.02)))[0]
    assert np.isfinite(ll[5])
    assert_allclose(ll[5], _brute_bulged(bad, table, 5, 0.02), atol=1e-4)


def test_intact_cell_probability_is_bayes_rule(table, cells):
    # reference: for an intact cell the readings are independent given P_phys, so
    # P(R_c bad | data) = f B_R / ((1-f) N_R + f B_R) exactly (the k_c factor cancels)
    f = 0.05
    model = ExtendedModel(cells, table, ["outliers"])
    v = dict((k, np.array([x])) for k, x in dict(TRUE, f_out=f).items())
    p = outlier_probabilities(model, v)
    R, k = forward.cell_radius_and_stiffness(TRUE["P_phys"], TRUE["gamma"], TRUE["E0t"],
                                             TRUE["R0"], 5e3, table)
    i = ~cells.is_bulged
    good = (1 - f) * stats.norm.pdf(cells.R_c[i], R, cells.R_c_err[i])
    broad = f * stats.lognorm.pdf(cells.R_c[i], OUTLIER_LOG_SD, scale=R)
    assert_allclose(p["R_c"][0, i], broad / (good + broad), rtol=1e-8)
    assert np.all(p["k_b/R_b"][0, i] == 0)


def test_planted_gross_errors_are_named_and_nothing_else(table):
    # simulated truth: clean data (seed 21) with b004's k_b x5 and i009's R_c x1.4; at the true
    # parameters both readings must be flagged and no other (20 clean data sets gave 1 false
    # flag in 6840 readings, docs/effects.md, outliers)
    clean = synthetic.simulate_cells(seed=21, surrogate=table)[0]
    ids = list(clean.cell_id)
    k_b, R_c = clean.k_b.copy(), clean.R_c.copy()
    k_b[ids.index("b004")] *= 5
    R_c[ids.index("i009")] *= 1.4
    dirty = dataclasses.replace(clean, k_b=k_b, R_c=R_c)
    model = ExtendedModel(dirty, table, [])
    v = {k: np.full(8, x) for k, x in TRUE.items()}
    flags = flagged_cells(model, v, dirty.cell_id)
    assert {(f["cell_id"], f["quantity"]) for f in flags} == {("b004", "k_b/R_b"),
                                                            ("i009", "R_c")}
    assert all(f["score"] > 0.95 for f in flags), flags
    assert flagged_cells(ExtendedModel(clean, table, []), v, clean.cell_id) == []


def test_injected_outliers_hit_the_requested_fraction(table):
    # reference: binomial counts; with f = 0.3 each reading is replaced with probability 0.3
    # by a lognormal(1) factor, so it changes by more than 1e-12 in relative terms
    f, n = 0.3, 800
    inj = effects.get_effect("outliers").injection(f)
    dirty = synthetic.simulate_cells(n, n, seed=8, surrogate=table, effects=[inj])[0]
    clean = synthetic.simulate_cells(n, n, seed=8, surrogate=table)[0]
    b = clean.is_bulged
    for name, mask in (("R_c", np.ones(2 * n, bool)), ("k_c", np.ones(2 * n, bool)), ("k_b", b)):
        changed = ~np.isclose(getattr(dirty, name)[mask], getattr(clean, name)[mask],
                              rtol=1e-12)
        sd = np.sqrt(f * (1 - f) / mask.sum())
        assert abs(changed.mean() - f) < 4 * sd, name
    # and the factor is lognormal with log-sd 1 (sd of ln ratio within 4 standard errors)
    r = np.log(dirty.R_c / clean.R_c)
    r = r[np.abs(r) > 1e-12]
    assert_allclose(np.std(r), OUTLIER_LOG_SD, atol=4 / np.sqrt(2 * r.size))
