"""The osmotic series as an ExtendedModel (turgorbayes.effects.series.SeriesModel): each intact
cell's turgor carried by the likelihood context.

References: OsmoticModel's own intact likelihood (the balance's radius and
``stiffness_at_radius``, a separate code path) for the series without effects;
``scipy.integrate.quad`` over a cell's ln P about its level's turgor, the level's turgor from
``turgorbayes.physics.osmotic.turgor_after_shift`` and the exact forward model, for
``turgor_spread`` on a series; the baseline for ``intact_log_P`` None.
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import integrate, stats

from turgorbayes import effects
from turgorbayes.effects import ExtendedModel
from turgorbayes.effects.series import SeriesModel
from turgorbayes.inference.observations import stiffness_sd
from turgorbayes.inference.osmotic import OsmoticModel, osmotic_design
from turgorbayes.physics import forward, osmotic
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation.osmotic import simulate_osmotic_series

TRUE = {"gamma": 1.22, "E0t": 0.026, "R0": 464.2e-9, "P_phys": 29e3, "b": 0.3}


@pytest.fixture(scope="module")
def series(table):
    return simulate_osmotic_series(n_intact=40, n_bulged=0, seed=3, surrogate=table)[0]


@pytest.fixture(scope="module")
def series_bulged(table):
    return simulate_osmotic_series(n_intact=40, n_bulged=20, seed=4, surrogate=table)[0]


def _walkers(model, rng, n=5):
    u = model.to_u(TRUE)[0]
    return u + np.r_[0.05, 0.05, 3.0, 0.03, 0.1] * rng.standard_normal((n, 5))


@pytest.mark.parametrize("which", ["series", "series_bulged"])
def test_without_effects_it_is_the_osmotic_model(table, rng, which, request):
    # reference: OsmoticModel.pointwise_log_likelihood (the balance's radius, the stiffness at
    # that radius and its own Gaussian densities): measured agreement 5e-15 relative
    cells = request.getfixturevalue(which)
    ref = OsmoticModel(cells, table, osmotic_design(cells))
    model = SeriesModel(cells, table)
    assert model.names == ref.names
    U = _walkers(ref, rng)
    assert_allclose(model.pointwise_log_likelihood(U), ref.pointwise_log_likelihood(U),
                    rtol=1e-10)
    # the intact cells' pressures are their levels' turgors (reference: OsmoticModel's)
    assert_allclose(model.cell_pressures(U), ref.cell_pressures(U), rtol=1e-10)


def test_without_per_cell_turgors_the_context_is_the_baselines(table, rng):
    # reference: ExtendedModel's pointwise likelihood with intact_log_P None equals the one
    # with every intact cell's ln P set to ln P_phys explicitly (the per-cell path), to
    # the forward model's rounding
    cells = synthetic.simulate_cells(seed=21, surrogate=table)[0]
    model = ExtendedModel(cells, table, ["turgor_spread"])
    U = model.to_u(dict(TRUE, tau_P=0.2))
    v = model.to_physical(U)
    ctx = model.context(v)
    plain = model.lik.pointwise_context(ctx, v["P_phys"])
    ctx.intact_log_P = np.full((1, cells.n_intact), np.log(v["P_phys"][0]))
    assert_allclose(model.lik.pointwise_context(ctx, v["P_phys"]), plain, rtol=0, atol=1e-10)


def _quad_cell(table, walls, log_centre, tau, R_o, R_e, k_o, k_e):
    """ln of int N(x; log_centre, tau) N(R_o; R_c(e^x), R_e) N(k_o; k_c(e^x), sd) dx by
    scipy.integrate.quad, the exact forward model, scaled by the integrand's peak."""
    def log_f(x):
        R, k = forward.cell_radius_and_stiffness(np.exp(x), walls["gamma"], walls["E0t"],
                                                 walls["R0"], 5e3, table)
        return (stats.norm.logpdf(x, log_centre, tau) + stats.norm.logpdf(R_o, R, R_e)
                + stats.norm.logpdf(k_o, k, stiffness_sd(k, k_o, k_e)))

    grid = log_centre + tau * np.linspace(-8, 8, 1601)
    values = np.array([log_f(x) for x in grid])
    peak, mode = values.max(), grid[values.argmax()]
    total, _ = integrate.quad(lambda x: np.exp(log_f(x) - peak), grid[0], grid[-1],
                              points=[mode], epsabs=0, epsrel=1e-11, limit=500)
    return np.log(total) + peak


def test_turgor_spread_spreads_each_cell_about_its_levels_turgor(table, series):
    # reference: scipy.integrate.quad over ln P (module docstring), the level's turgor from
    # turgor_after_shift directly; the stiffness error is the likelihood's pooled relative one
    # (the intact group's RMS relative error times the reading)
    model = SeriesModel(series, table, ["turgor_spread"])
    tau = 0.2
    u = model.to_u(dict(TRUE, tau_P=tau))
    ll = model.pointwise_log_likelihood(u)[0]
    d = osmotic_design(series)
    intact = np.flatnonzero(~series.is_bulged)
    rel = np.sqrt(np.mean((series.k_c_err[intact] / series.k_c[intact]) ** 2))
    for j in (0, len(intact) - 1):  # a cell of the growth medium and one at 150 mOsm added
        level = d.levels[d.level_of[j]]
        P_k = osmotic.turgor_after_shift(TRUE["P_phys"], TRUE["gamma"], TRUE["E0t"],
                                         TRUE["R0"], c_ref=d.reference, c_out=level,
                                         b=TRUE["b"])["P"]
        i = intact[j]
        ref = _quad_cell(table, TRUE, np.log(P_k), tau, series.R_c[i], series.R_c_err[i],
                         series.k_c[i], rel * series.k_c[i])
        assert_allclose(ll[i], ref, rtol=0, atol=1e-7, err_msg=f"cell {i} at {level:g} mOsm")


def test_every_registered_effect_composes_with_a_series_or_says_why(table, series, rng):
    # reference: the effects' declarations (Effect.series_reason / not_applicable_reason); an
    # effect that applies evaluates a finite likelihood on the series at its start values
    for name in effects.effect_names():
        e = effects.get_effect(name)
        if not e.applicable(series):
            assert e.not_applicable_reason(series) or e.series_refusal(series)
            continue
        model = SeriesModel(series, table, [name])
        u = model.to_u(model.start_values(TRUE))
        assert np.isfinite(model.pointwise_log_likelihood(u)).all(), name
    assert "osmotic series" in effects.get_effect("outer_membrane").not_applicable_reason(series)
    with pytest.raises(ValueError, match="osmotic series"):
        SeriesModel(series, table, ["outer_membrane"])
