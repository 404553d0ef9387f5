"""Package pieces the population studies share (known and fitted box populations, a model with
its population replaced, a posterior against its truth)."""

from types import SimpleNamespace

import numpy as np

from turgorbayes.inference import models, population
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows import sbc


def _cover(lo, hi):
    """A plug-in stand-in: a flat grid population on ``[lo, hi]``."""
    grid = np.linspace(lo, hi, 50)
    return population.GridPopulation(grid, np.full(50, -np.log(50)))


def test_ramped_box_is_flat_inside_and_empty_outside():
    cover = _cover(5.0, 11.5)
    lo, hi = np.log(1e3), np.log(25e3)
    box = population.ramped_box(cover, lo, hi)
    assert np.isclose(np.exp(box.log_mass).sum(), 1.0)
    inside = box.grid[(box.grid > lo + 0.3) & (box.grid < hi - 0.3)]
    dens = np.exp(box.log_pdf(inside))
    # uniform density 1/(hi - lo) on [lo, hi]
    assert np.allclose(dens, 1 / (hi - lo), rtol=1e-3)
    assert np.exp(box.log_pdf(lo - 0.5)) < 1e-6 * dens[0]
    # the grid covers the cover's support and one unit beyond each edge (to a grid step)
    assert box.support[0] <= min(cover.support[0], lo - 1) + 1e-12
    assert box.support[1] > max(cover.support[1], hi + 1) - 1.01 * population.BOX_STEP


def test_fitted_box_recovers_the_edges_of_uniform_estimates():
    rng = np.random.default_rng(3)
    lo, hi = 7.0, 10.0
    true = rng.uniform(lo, hi, 4000)
    sd = np.full(true.size, 0.1)
    est = true + sd * rng.standard_normal(true.size)
    cover = _cover(6.0, 11.0)
    box, (f_lo, f_hi) = population.fitted_box(est, sd, cover)
    assert abs(f_lo - lo) < 0.02 and abs(f_hi - hi) < 0.02
    # the naive edges (the extreme estimates) lie about 3 sd outside: the fit deconvolves
    assert est.min() < lo - 0.2 and est.max() > hi + 0.2
    assert np.isclose(np.exp(box.log_mass).sum(), 1.0)


def test_with_population_rebuilds_the_likelihood_on_it(table):
    cells, _ = synthetic.simulate_cells(seed=11, surrogate=table)
    model = models.BaselineModel(cells, table)
    before = model.lik
    box = population.ramped_box(model.obs.population, *np.log(synthetic.DEFAULT_P_RANGE))
    out = models.with_population(model, box)
    assert out is model and model.obs.population is box
    assert model.lik is not before and model.lik.obs is model.obs
    assert model.lik.n_nodes == before.n_nodes and model.lik.surrogate is before.surrogate


class _Identity:
    @staticmethod
    def to_physical(u):
        return {"gamma": u[:, 0], "R0": u[:, 1]}


def test_truth_summary_scores_the_weighted_posterior():
    rng = np.random.default_rng(5)
    u = np.column_stack([rng.normal(1.0, 2.0, 20000), rng.normal(0.0, 1.0, 20000)])
    post = SimpleNamespace(u=u, weights=np.full(len(u), 1 / len(u)), converged=True)
    truth = SimpleNamespace(gamma=1.0 + 2.0 * 1.0, R0=0.5)  # gamma one sd above the mean
    out = sbc.truth_summary(_Identity(), post, truth, ("gamma", "R0"))
    assert out["converged"] is True
    assert np.isclose(out["gamma"]["z"], -1.0, atol=0.03)
    assert np.isclose(out["gamma"]["sd"], 2.0, rtol=0.02)
    assert out["gamma"]["cover90"] and out["R0"]["cover90"]
    far = sbc.truth_summary(_Identity(), post, SimpleNamespace(gamma=10.0, R0=0.5), ("gamma",))
    assert not far["gamma"]["cover90"]
