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

from turgorbayes import effects
from turgorbayes.effects import ExtendedModel
from turgorbayes.errors import DataError
from turgorbayes.inference.observations import observations_from_cells
from turgorbayes.physics import forward, wall
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows.criticize import CriticismSettings, criticize

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
    # sessions sorted by label: s1, s2, s3 <-> z_cal_1, z_cal_2, z_cal_3; the likelihood sees
    # the factors relative to their geometric mean: sigma (z_s - mean z)
    z = np.asarray(Z)
    return SIGMA * (z - z.mean())[int(cells.extra["session"][i][1:]) - 1]


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


def test_forward_model_is_invariant_under_the_common_scale(table):
    # reference: the wall law E_perp t = E0t (P/P0)^gamma with tension P R, R0 the radius at P0
    # (docs/physics.md), and k_c = f(P R/(E t), ratio) P R: scaling every pressure by g, E0t by
    # g^(1 - gamma) and taking R0 at the pressure that maps to P0 scales every modulus by g, so
    # R_c is unchanged and k_c scales by g. This is why a factor common to every stiffness
    # reading cannot be seen in the data.
    P = np.array([2e3, 9e3, 29e3])
    gamma, E0t, R0 = TRUE["gamma"], TRUE["E0t"], TRUE["R0"]
    for g in (0.8, 1.25):
        R1, k1 = forward.cell_radius_and_stiffness(P, gamma, E0t, R0, 5e3, table)
        R0_g = wall.radius_at_pressure(5e3 / g, gamma, E0t, R0, 5e3)
        R2, k2 = forward.cell_radius_and_stiffness(g * P, gamma, g ** (1 - gamma) * E0t, R0_g,
                                                   5e3, table)
        assert_allclose(R2, R1, rtol=1e-9)
        assert_allclose(k2, g * k1, rtol=1e-6)


def test_likelihood_ignores_the_sessions_common_factor(table, cells):
    # reference: the invariance above; a shift of every z_cal by the same amount changes only the
    # sessions' common factor, so the likelihood must not move (to rounding)
    model = ExtendedModel(cells, table, ["calibration"])
    u = _values(model)
    shifted = model.to_u(dict(TRUE, sigma_cal=SIGMA, **{f"z_cal_{j + 1}": z + 0.7
                                                       for j, z in enumerate(Z)}))
    assert_allclose(model.pointwise_log_likelihood(shifted), model.pointwise_log_likelihood(u),
                    rtol=1e-12, atol=1e-12)


def test_reported_pressure_carries_the_common_factor(table, cells):
    # reference: the common log factor sigma mean(z) with z ~ N(0, 1) i.i.d. has sd
    # sigma/sqrt(S) (closed form); the reported ln P_phys is the apparent one minus it, and
    # ln E0t moves by (1 - gamma) times it (the invariance above)
    model = ExtendedModel(cells, table, ["calibration"])
    rng = np.random.default_rng(4)
    n = 20000
    z = rng.standard_normal((n, 3))
    full = {k: np.full(n, x) for k, x in dict(TRUE, sigma_cal=SIGMA).items()}
    u = model.to_u(dict(full, **{f"z_cal_{j + 1}": z[:, j] for j in range(3)}))
    out = model.derived(u, rng)
    delta = np.log(TRUE["P_phys"]) - np.log(out["P_phys"])
    assert_allclose(np.std(delta), SIGMA / np.sqrt(3), rtol=0.03)  # se of an sd: 1/sqrt(2n)
    assert_allclose(delta, SIGMA * z.mean(axis=1), rtol=1e-9)
    assert_allclose(np.log(out["E0t"] / TRUE["E0t"]), -(1 - TRUE["gamma"]) * delta, rtol=1e-9)
    # R0 is the radius at P0 in true units, i.e. at the apparent P0 exp(delta)
    assert_allclose(out["R0"], wall.radius_at_pressure(5e3 * np.exp(delta), TRUE["gamma"],
                                                       TRUE["E0t"], TRUE["R0"], 5e3), rtol=1e-9)


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
        criticize(plain, table, settings=CriticismSettings(
            effects=("calibration",)))
