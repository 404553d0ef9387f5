"""Tests of the hierarchical population with free edges (turgorbayes.effects.pressure_range).

References: adaptive quadrature (scipy.integrate.quad) of the family's density, its box limit
in closed form, and each bulged cell's latent-pressure integral by a dense trapezoid rule
written out here (4001 points over +-8 bulge sds), independent of the engine's Gauss-Hermite
and composite Gauss-Legendre rules.
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import integrate

from turgorbayes.effects import ExtendedModel
from turgorbayes.effects.pressure_range import PressureRange, log_density
from turgorbayes.inference.observations import gaussian_logpdf, stiffness_sd
from turgorbayes.simulation import cells as synthetic

TRUE = synthetic.TRUTHS["paper"]


@pytest.mark.parametrize("lo, span, w", [(6.9, 3.2, 0.02), (6.9, 3.2, 0.5), (9.0, 0.05, 0.4),
                                         (9.0, 1.0, 3.0)])
def test_density_integrates_to_one(lo, span, w):
    # reference: adaptive quadrature of exp(log_density), breakpoints at both edges
    f = lambda x: np.exp(log_density(x, lo, span, w))  # noqa: E731
    total, err = integrate.quad(f, lo - 60 * w - 5, lo + span + 60 * w + 5,
                                points=[lo, lo + span], limit=400)
    assert_allclose(total, 1.0, rtol=1e-8)


def test_sharp_edges_give_the_uniform_density_of_the_box():
    # reference: uniform on [a, b] has density 1/(b - a) inside and 0 outside; with w = 0.01
    # and points 0.2 inside/outside (20 w) the logistic edges differ from it by ~e^-20
    lo, span, w = np.log(1e3), np.log(25.0), 0.01
    inside = lo + np.array([0.2, 1.0, span - 0.2])
    assert_allclose(np.exp(log_density(inside, lo, span, w)), 1 / span, rtol=1e-8)
    outside = np.array([lo - 0.2, lo + span + 0.2])
    assert np.all(np.exp(log_density(outside, lo, span, w)) < 1e-8 / span)


@pytest.fixture(scope="module")
def cells(table):
    return synthetic.simulate_cells(seed=3, surrogate=table)[0]


def _dense_bulged(model, v):
    """Each bulged cell's log-likelihood by a 4001-point trapezoid in ln P over its bulge
    estimate +- 8 sds: N(R_c) N(k_c) N(ln P_hat; x, s) g(x), g the family at ``v``."""
    obs, lik = model.obs, model.lik
    mu, s = obs.log_P_bulge, obs.sd_log_P_bulge
    t = np.linspace(-8.0, 8.0, 4001)
    x = mu[:, None] + s[:, None] * t
    R, k = lik.forward(x[None], *(np.array([v[p]]) for p in ("gamma", "E0t", "R0")),
                       walker_axis=True)
    b = obs.bulged
    Ro, Re, ko, ke = (a[b][:, None] for a in (obs.R_c, obs.R_c_err, obs.k_c, obs.k_c_err))
    f = (gaussian_logpdf(Ro, R[0], Re) + gaussian_logpdf(ko, k[0], stiffness_sd(k[0], ko, ke))
         + gaussian_logpdf(mu[:, None], x, s[:, None])
         + log_density(x, np.log(v["P_lo"]), v["span"], v["w_edge"]))
    top = f.max(axis=1, keepdims=True)
    return np.log(integrate.trapezoid(np.exp(f - top), x, axis=1)) + top[:, 0]


@pytest.mark.parametrize("w", [0.03, 0.3])
def test_bulged_cells_integrate_the_sampled_population(table, cells, w):
    # the engine's latent integral with the family as each walker's population must match
    # the dense trapezoid (the plug-in population only centres the nodes); edges at the
    # simulator's design range (1-25 kPa), sharp (w = 0.03) and soft (w = 0.3)
    model = ExtendedModel(cells, table, [PressureRange()])
    v = {"gamma": TRUE.gamma, "E0t": TRUE.E0t, "R0": TRUE.R0, "P_phys": TRUE.P_phys,
         "P_lo": 1e3, "span": np.log(25.0), "w_edge": w}
    u = model.to_u(v)
    got = model.pointwise_log_likelihood(u)[0, model.obs.bulged]
    assert_allclose(got, _dense_bulged(model, v), atol=2e-4)


def test_starting_edges_come_from_the_bulges(table, cells):
    # reference: the simulator's design range 1-25 kPa; the start sits one bulge sd inside
    # the extreme estimates, so within 0.3 in ln P of the true edges at 72 cells
    bound = PressureRange().bind(cells)
    assert abs(np.log(bound.start["P_lo"]) - np.log(1e3)) < 0.3
    assert abs(bound.start["span"] - np.log(25.0)) < 0.5
