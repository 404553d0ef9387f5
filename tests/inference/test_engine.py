"""The one posterior engine of fit, criticism and SBC (turgorbayes.inference.engine).

Every expected value is a closed form (the mean and covariance of a Gaussian target, the
spread of the starting walkers by the engine's documented rule, systematic resampling of a
one-hot weight vector) or the definition the engine replaced (the fit's former seed scheme).
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from turgorbayes.inference import engine

from helpers import GAUSSIAN_COV, GAUSSIAN_MEAN, GaussianModel

MEAN, COV = GAUSSIAN_MEAN, GAUSSIAN_COV


def test_settings_per_layer():
    # the engine's settings in inference, the fit's and the criticism's in workflows, each a
    # dataclass that adds its own fields to the engine's (reference: their docstrings)
    import dataclasses

    from turgorbayes.effects import outliers
    from turgorbayes.inference.likelihood import DEFAULT_NODES
    from turgorbayes.workflows.criticize import CriticismSettings
    from turgorbayes.workflows.fit import FitSettings

    engine_fields = {f.name for f in dataclasses.fields(engine.Settings)}
    assert not engine_fields & {"n_rep", "max_refits", "effects", "flag_draws", "per_condition",
                                "population_noise", "population_noise_bootstrap"}
    assert {f.name for f in dataclasses.fields(FitSettings)} - engine_fields == {
        "population_noise", "population_noise_bootstrap"}
    assert {f.name for f in dataclasses.fields(CriticismSettings)} - engine_fields == {
        "n_rep", "max_refits", "effects", "flag_draws", "per_condition", "workers", "scheduler",
        "reference_medium", "temperature", "length_model"}
    fit = FitSettings()
    assert fit.engine == "emcee" and fit.n_nodes == DEFAULT_NODES and fit.population_noise
    crit = CriticismSettings(n_walkers=12, max_steps=400)
    assert isinstance(crit, engine.Settings)
    assert (crit.engine, crit.n_walkers, crit.max_steps, crit.progress) == (
        "importance", 12, 400, False)
    assert crit.flag_draws == outliers.FLAG_DRAWS  # the screen's own constant, not a copy
    with pytest.raises(ValueError, match="engine must be 'importance' or 'emcee'"):
        CriticismSettings(engine="laplace")  # the criticism needs a convergence check
    with pytest.raises(ValueError, match="n_rep must be an integer >= 2"):
        CriticismSettings(n_rep=1)
    with pytest.raises(ValueError, match="engine must be one of"):
        engine.Settings(engine="mcmc")


def test_stream_rng_is_the_fits_former_seed_scheme():
    # reference: the fit's former _rng(seed, s) = default_rng(SeedSequence([seed, 1000 + s]));
    # the fit now calls stream_rng(seed, 1000 + s), so its draws are unchanged
    for seed, s in ((1, 0), (7, 3)):
        old = np.random.default_rng(np.random.SeedSequence([seed, 1000 + s])).random(5)
        assert_allclose(engine.stream_rng(seed, 1000 + s).random(5), old, rtol=0, atol=0)
    assert not np.allclose(engine.stream_rng(1, 1000).random(5), engine.stream_rng(1, 1003).random(5))



def test_a_name_enters_a_stream_as_the_sha256_of_the_name():
    # reference: hashlib's SHA-256 of the name, first 4 bytes big-endian (by hand): the same
    # integer in every process, unlike Python's salted hash()
    import hashlib

    key = int.from_bytes(hashlib.sha256(b"bad_curves").digest()[:4], "big")
    assert engine.stable_key("bad_curves") == key < 2**32
    assert engine.stable_key("bad_curves") != engine.stable_key("pressure_error")
    # the name is one word of the seed sequence after the stream number; the integer seed is
    # the uint32 that sequence generates first
    seq = np.random.SeedSequence([7, 18, key])
    assert engine.stream_seed(7, 18, "bad_curves") == int(seq.generate_state(1, np.uint32)[0])
    assert_allclose(engine.stream_rng(7, 18, "bad_curves").random(3),
                    np.random.default_rng(seq).random(3), rtol=0, atol=0)
    # an integer stream is unchanged by the names: stream_rng(seed, s) as before
    assert_allclose(engine.stream_rng(7, 11).random(3),
                    np.random.default_rng(np.random.SeedSequence([7, 11])).random(3), rtol=0,
                    atol=0)

def test_every_ensemble_starts_at_the_full_spread():
    # reference: the rule of walker_start: 2 Laplace sds, x0.8 per redraw of the same
    # ensemble (same generator); a new ensemble (a new generator) starts again at 2 sds, so
    # R-hat can detect non-mixing. Before, the count ran on across ensembles (the 4th ensemble
    # started at 2 x 0.8^3 = 1.02 sd)
    cov = np.diag([1.0, 4.0])
    init = engine.walker_start(np.zeros(2), cov, 20000)
    first = np.random.default_rng(0)
    for k in range(3):
        p = init(first)  # redraws of one ensemble: 2, 1.6, 1.28 sds
        assert_allclose(p.std(axis=0), 2 * 0.8**k * np.sqrt(np.diag(cov)), rtol=0.03)
    p = init(np.random.default_rng(1))
    assert_allclose(p.std(axis=0), 2 * np.sqrt(np.diag(cov)), rtol=0.03)


def test_importance_datatree_carries_the_weights():
    # reference: the target's exact mean. The first proposal is centred 0.5 off and too
    # narrow, so the draws do not count equally; weighted by the DataTree's log_weight they
    # give the exact mean within 4 standard errors
    model = GaussianModel(MEAN, COV)
    settings = engine.Settings(engine="importance", n_draws=4000, progress=False)
    post = engine.importance_posterior(model, MEAN + 0.5, 0.3 * COV, 1, settings)
    assert post.converged
    dt = post.datatree(np.random.default_rng(0))
    w = np.exp(dt["sample_stats"]["log_weight"].values.ravel())
    assert_allclose(w.sum(), 1.0, rtol=1e-9)
    se = np.sqrt(np.diag(COV) / post.ess)
    for i, name in enumerate(model.names):
        x = dt["posterior"][name].values.ravel()
        assert abs(w @ x - MEAN[i]) < 4 * se[i]
    assert w.max() > 5 * w.min()  # unequal weights: draws do not count equally here
    assert dt["log_likelihood"]["cells"].shape == (1, len(post.u), model.n)


def test_emcee_datatree_has_no_weights_and_one_chain_per_ensemble():
    # reference: emcee draws count equally (no log_weight); the ensembles are the chains.
    # The engine's rule (converged) and the draws' mean against the exact one (4 MC errors)
    model = GaussianModel(MEAN, COV)
    settings = engine.Settings(engine="emcee", progress=False, n_walkers=12, tol=25,
                               max_draws_per_chain=300)
    post = engine.fit_posterior(model, dict(zip(model.names, MEAN + 0.3, strict=True)), 2,
                                settings)
    assert post.engine == "emcee" and post.converged, post.reasons
    dt = post.datatree(np.random.default_rng(0))
    assert "log_weight" not in dt["sample_stats"]
    assert dt["posterior"]["x0"].shape[0] == settings.n_ensembles == post.n_chains
    assert post.log_lik.shape == (len(post.u), model.n)  # filled in by fit_posterior
    for i, name in enumerate(model.names):
        ess = post.diagnostics["chain"][name]["ess_bulk"]
        assert abs(post.u[:, i].mean() - MEAN[i]) < 4 * np.sqrt(COV[i, i] / ess)


def test_laplace_engine_draws_the_normal_approximation():
    # reference: for a Gaussian posterior the Laplace approximation is exact: the draws' mean
    # and covariance are MEAN and COV within Monte Carlo error (n = 20000)
    model = GaussianModel(MEAN, COV)
    settings = engine.Settings(engine="laplace", n_draws=20000)
    post = engine.fit_posterior(model, dict(zip(model.names, MEAN + 0.3, strict=True)), 3,
                                settings, pointwise=False)
    assert post.engine == "laplace" and post.log_lik is None
    assert_allclose(post.u_map, MEAN, atol=1e-3)
    assert_allclose(post.u.mean(axis=0), MEAN, atol=4 * np.sqrt(np.diag(COV).max() / 20000))
    assert_allclose(np.cov(post.u.T), COV, atol=0.05)


def test_one_flag_cells_screens_draws_resampled_by_weight(monkeypatch):
    # the criticism's screen is the fit's function; with weights, the draws screened are
    # resampled by weight: all weight on draw 3 gives draw 3 every time (reference: systematic
    # resampling of a one-hot weight vector); without weights, evenly spaced draws
    from turgorbayes.effects import outliers
    from turgorbayes.workflows import criticism_screens, fit

    # one screen, workflows.flags (the criticism screens in criticism_screens.flag_adopted)
    assert criticism_screens.flag_cells is fit.flag_cells
    seen = []
    monkeypatch.setattr(outliers, "flagged_cells",
                        lambda model, v, ids, gross=False, workers=1: seen.append(v) or [])
    model = GaussianModel(MEAN, COV)
    draws = {n: np.arange(10.0) + i for i, n in enumerate(model.names)}
    w = np.zeros(10)
    w[3] = 1.0
    fit.flag_cells(model, draws, ["a"], n_draws=4, weights=w, rng=np.random.default_rng(0))
    assert_allclose(seen[-1]["x0"], [3.0] * 4)
    fit.flag_cells(model, draws, ["a"], n_draws=4)
    assert_allclose(seen[-1]["x0"], [0.0, 3.0, 6.0, 9.0])
