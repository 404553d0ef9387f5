"""Tests of the ``calibration`` effect and measurement sessions (docs/effects.md, calibration).

References: scipy.stats normal densities in closed form (intact cells), a brute-force
trapezoid over the latent apparent pressure with the exact forward model (bulged cells), the
baseline likelihood at unit factors, and the simulator's own recorded factors (every stiffness
of a session scaled by the same factor, nothing else changed).
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import integrate, stats

from turgorbayes import criticism, effects, forward, synthetic
from turgorbayes.effects import ExtendedModel
from turgorbayes.errors import DataError
from turgorbayes.inference.likelihood import observations_from_cells

TRUE = {"gamma": 1.22, "E0t": 0.026, "R0": 464.2e-9, "P_phys": 29e3}
Z = (0.8, -1.3, 0.4)  # standardized log factors of the three sessions
SIGMA = 0.2


@pytest.fixture(scope="module")
def cells(table):
    return synthetic.simulate_cells(seed=21, surrogate=table, n_sessions=3)[0]


def _values(model):
    return model.to_u(dict(TRUE, sigma_cal=SIGMA, **{f"z_cal_{j + 1}": z
                                                     for j, z in enumerate(Z)}))


def _pooled(value, err, groups):
    rel = err / value
    for g in groups:
        rel = np.where(g, np.sqrt(np.mean(rel[g] ** 2)), rel)
    return rel * value


def _log_c(cells, i):
    # sessions sorted by label: s1, s2, s3 <-> z_cal_1, z_cal_2, z_cal_3; the geometric-mean
    # factor is 1 and each ln c_s has prior sd sigma: sigma sqrt(S/(S-1)) (z_s - mean z)
    z = np.asarray(Z)
    return SIGMA * np.sqrt(3 / 2) * (z - z.mean())[int(cells.extra["session"][i][1:]) - 1]


def test_calibration_likelihood_against_closed_form_and_brute_force(table, cells):
    model = ExtendedModel(cells, table, ["calibration"])
    ll = model.pointwise_log_likelihood(_values(model))[0]
    groups = (cells.is_bulged, ~cells.is_bulged)
    k_err = _pooled(cells.k_c, cells.k_c_err, groups)
    R, k = forward.cell_radius_and_stiffness(TRUE["P_phys"], TRUE["gamma"], TRUE["E0t"],
                                             TRUE["R0"], 5e3, table)
    for i in np.flatnonzero(~cells.is_bulged)[:10]:
        c = np.exp(_log_c(cells, i))  # intact: R at P_phys, the k_c reading scaled by c
        ref = (stats.norm.logpdf(cells.R_c[i], R, cells.R_c_err[i])
               + stats.norm.logpdf(cells.k_c[i], c * k, k_err[i] / cells.k_c[i] * c * k))
        assert_allclose(ll[i], ref, rtol=1e-10)
    obs = observations_from_cells(cells)
    for b in (0, 17, 50):
        j = int(np.flatnonzero(obs.bulged == b)[0])
        lc = _log_c(cells, b)
        x = np.linspace(*obs.population.support, 40001)  # apparent ln P
        Rb, kb = forward.cell_radius_and_stiffness(np.exp(x - lc), TRUE["gamma"], TRUE["E0t"],
                                                   TRUE["R0"], 5e3, table)
        f = (np.exp(obs.population.log_pdf(x))
             * stats.norm.pdf(obs.log_P_bulge[j], x, obs.sd_log_P_bulge[j])
             * stats.norm.pdf(cells.R_c[b], Rb, cells.R_c_err[b])
             * stats.norm.pdf(cells.k_c[b], np.exp(lc) * kb,
                              k_err[b] / cells.k_c[b] * np.exp(lc) * kb))
        assert_allclose(ll[b], np.log(integrate.trapezoid(f, x)), atol=1e-4)


def test_unit_factors_give_the_baseline(table, cells):
    # reference: the baseline likelihood (no effect); the context path agrees with the baseline's
    # own quadrature to ~1e-5 (tests/effects/test_effects.py)
    model = ExtendedModel(cells, table, ["calibration"])
    u = model.to_u(dict(TRUE, sigma_cal=1e-12, z_cal_1=0.0, z_cal_2=0.0, z_cal_3=0.0))
    base = ExtendedModel(cells, table, [])
    assert_allclose(model.pointwise_log_likelihood(u),
                    base.pointwise_log_likelihood(base.to_u(TRUE)), atol=2e-5)


def test_simulated_sessions_share_one_factor(table):
    # reference: the same seed without the effect; every k_c, k_b (and error) of a session is
    # multiplied by exp(the recorded log factor), R_c and R_b unchanged; sessions balanced
    inj = effects.get_effect("calibration").injection(0.15)
    dirty, truths = synthetic.simulate_cells(seed=3, surrogate=table, effects=[inj], n_sessions=5)
    clean = synthetic.simulate_cells(seed=3, surrogate=table, n_sessions=5)[0]
    labels = np.array(dirty.extra["session"])
    assert sorted(np.unique(labels, return_counts=True)[1]) == [22, 23, 23, 23, 23]
    factors = truths["effects"][0]["log_factors"]
    c = np.exp([factors[s] for s in labels])
    for name in ("k_c", "k_c_err"):
        assert_allclose(getattr(dirty, name), c * getattr(clean, name), rtol=1e-12)
    b = dirty.is_bulged
    assert_allclose(dirty.k_b[b], c[b] * clean.k_b[b], rtol=1e-12)
    assert_allclose(dirty.R_c, clean.R_c, rtol=0)
    with pytest.raises(ValueError, match="needs sessions"):
        synthetic.simulate_cells(seed=3, surrogate=table, effects=[inj])


def test_calibration_is_a_candidate_only_with_sessions(table, cells):
    calib = effects.get_effect("calibration")
    plain = synthetic.simulate_cells(seed=21, surrogate=table)[0]
    assert calib.applicable(cells) and not calib.applicable(plain)
    with pytest.raises(DataError, match="needs a 'session' column"):
        criticism.criticize(plain, table, settings=criticism.CriticismSettings(
            effects=("calibration",)))
