"""Tests of the criticism workflow (turgorbayes.criticism, report_criticism, cli.criticize).

The point are the hidden-effect tests: data simulated with one effect at a realistic size
(turgorbayes.effects, ``realistic_size`` and its reason), criticized blind; the workflow must name
the effect, the effect size's and P_phys's 90 % intervals must cover the truth and the gain must
pass the selection rule. Null control: data from the baseline (3 seeds) select nothing.
The engine parts are checked against closed forms: PSIS-LOO against the exact leave-one-out
predictive of a conjugate normal model, importance sampling against a known Gaussian posterior,
the Bayesian-bootstrap probability against its normal limit, the importance-sampling posterior
against the package's emcee sampler. Tests that need the finite-element table skip until it
is built. Runs share fits through module-scoped caches.
"""

import functools
import json

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from turgorbayes import criticism, effects, results, surrogate, synthetic
from turgorbayes.inference import models
from turgorbayes.io import read_cells, write_cells

#: Small-but-converged settings (convergence is still checked: k <= 0.7, ESS >= 400, emcee's
#: fallback still runs to its autocorrelation rule).
SETTINGS = criticism.CriticismSettings(
    n_draws=1000, n_rep=700, max_refits=3,
    mcmc=results.FitSettings(n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                             max_steps=4000, progress=False))
#: Data seeds of the hidden-effect data sets and of the null controls. A single data set per
#: effect cannot measure how often the effect is found: that is the power study
#: (benchmarks/criticism_power.py, table in the README). For four effects (power 0.95-1.00)
#: almost any seed passes; outer_membrane is found in only 7 of 20 data sets (power 0.35),
#: and seed 6 is one of them, so its test shows that the workflow *can* name a membrane and
#: recover its size, not that it usually does.
HIDDEN = {"radius_spread": 6, "pressure_error": 5, "bad_curves": 5, "wall_softening": 3,
          "outer_membrane": 6}
NULL_SEEDS = (5, 11, 12)
TRUE_P_PHYS_KPA = 29.0


@functools.cache
def _data(name, seed):
    inj = [] if name is None else [effects.get_effect(name).injection(
        effects.get_effect(name).realistic_size)]
    return synthetic.simulate_cells(seed=seed, surrogate=surrogate.load(), effects=inj)


@functools.cache
def _criticized(name, seed):
    cells, truths = _data(name, seed)
    return criticism.criticize(cells, surrogate.load(), seed=1, settings=SETTINGS), truths


@pytest.fixture(scope="module")
def cli_run(table, tmp_path_factory):
    """wall_softening data through the command's code path (files written and read back)."""
    from turgorbayes.cli.criticize import run_criticize_command

    tmp = tmp_path_factory.mktemp("criticize")
    cells, truths = _data("wall_softening", HIDDEN["wall_softening"])
    write_cells(cells, tmp / "data.csv")
    out = tmp / "out"
    messages = []
    run_criticize_command(tmp / "data.csv", out, 1, None, SETTINGS, echo=messages.append)
    return out, truths, messages


# ----------------------------------------------------------------------------- hidden effects
def _check_found(d, name, size, result):
    e = effects.get_effect(name)
    key = next(p.key for p in e.parameters if p.name == e.size_parameter)
    assert d["selected_effect"] == name, [(c["effect"], round(c["delta_elpd"], 1))
                                          for c in d["candidates"]]
    cand = next(c for c in d["candidates"] if c["effect"] == name)
    est = cand["estimate"][key]
    # the size's 90 % interval covers the simulated truth
    assert est["q05"] <= size <= est["q95"], (est, size)
    # the gain passes the stated rule
    assert d["gain"]["delta_elpd"] > criticism.DELTA_ELPD_MIN
    assert d["gain"]["delta_elpd"] == cand["delta_elpd"]
    p_gain = next(c["p_gain"] for c in result.candidates if c["effect"] == name)
    assert p_gain >= criticism.P_GAIN_MIN
    # the extended model's 90 % interval for P_phys covers the true value
    P = d["parameters"]["extended"]["P_phys_kPa"]
    assert P["q05"] <= TRUE_P_PHYS_KPA <= P["q95"], P
    assert d["misfit_detected"] is True


@pytest.mark.parametrize("name", [n for n in HIDDEN if n != "wall_softening"])
def test_hidden_effect_is_found(table, name):
    result, truths = _criticized(name, HIDDEN[name])
    assert truths["effects"][0]["effect"] == name
    assert all(p.converged for p in result.posteriors.values()), {
        n: p.reasons for n, p in result.posteriors.items()}
    _check_found(criticism.criticism_dict(result), name, effects.get_effect(name).realistic_size,
                 result)


def test_hidden_wall_softening_is_found_by_the_command(cli_run):
    out, truths, messages = cli_run
    d = json.loads((out / "criticism.json").read_text())
    # criticism.json holds exactly the documented keys (docs/effects.md)
    assert list(d) == list(criticism.CRITICISM_KEYS)
    for key, sub in criticism.CRITICISM_KEYS.items():
        if key in ("checks", "candidates"):
            assert all(list(entry) == list(sub) for entry in d[key])
        elif sub:
            assert list(d[key]) == list(sub)
    fields = list(results.PARAMETER_FIELDS)
    assert all(list(v) == fields for v in d["parameters"]["baseline"].values())
    assert set(results.SUMMARY_KEYS["parameters"]) <= set(d["parameters"]["extended"])
    e = effects.get_effect("wall_softening")
    assert d["selected_effect"] == "wall_softening"
    est = next(c for c in d["candidates"] if c["effect"] == "wall_softening")["estimate"]["s_wall"]
    assert est["q05"] <= e.realistic_size <= est["q95"]
    assert d["gain"]["delta_elpd"] > criticism.DELTA_ELPD_MIN
    diag = json.loads((out / "criticism_diagnostics.json").read_text())
    assert next(c["p_gain"] for c in diag["candidates"]
                if c["effect"] == "wall_softening") >= criticism.P_GAIN_MIN
    P = d["parameters"]["extended"]["P_phys_kPa"]
    assert P["q05"] <= TRUE_P_PHYS_KPA <= P["q95"]
    report = (out / "report.md").read_text()
    assert "SIMULATED DATA" in report and "![misfit](misfit.png)" in report
    assert (out / "misfit.png").stat().st_size > 10_000
    assert any("selected effect: wall_softening" in m for m in messages)
    # the adopted extension's curve bands for the report's Fig. 3: the intact-cell wall is the
    # paper's, whose R_c(29 kPa) = 540.7 nm (docs/physics.md) lies inside the 95 % band
    from turgorbayes import plots

    bands = plots.read_bands(out / "extended_bands.json")
    lo, hi = (np.interp(np.log(29e3), np.log(bands.P), bands.R[i]) for i in (0, -1))
    assert lo < 540.7e-9 < hi and hi - lo < 20e-9
    assert diag["seed"] == 1 and diag["data_sha256"] == read_cells(out.parent / "data.csv").sha256


@pytest.mark.parametrize("seed", NULL_SEEDS)
def test_null_data_select_nothing(table, seed):
    result, _ = _criticized(None, seed)
    d = criticism.criticism_dict(result)
    assert d["selected_effect"] is None
    assert d["gain"] == {"delta_elpd": 0.0, "se": 0.0}
    assert d["parameters"]["extended"] is None
    assert len(d["candidates"]) == len(effects.EFFECTS)  # no pair is tried
    P = d["parameters"]["baseline"]["P_phys_kPa"]
    assert P["q05"] <= TRUE_P_PHYS_KPA <= P["q95"]


def test_model_average_leans_on_the_hidden_membrane(table):
    # Reference: simulated truth (outer membrane at its realistic size, P_phys = 29 kPa). The
    # stacking weights of the models that contain the membrane must carry most of the mass,
    # and the model average's 90 % interval of P_phys must cover the truth.
    result, _ = _criticized("outer_membrane", HIDDEN["outer_membrane"])
    w = result.stacking["weights"]
    assert set(w) == set(result.posteriors)
    assert_allclose(sum(w.values()), 1.0, atol=1e-9)
    assert sum(v for k, v in w.items() if "outer_membrane" in k) > 0.5, w
    avg = result.stacking["parameters"]["P_phys_kPa"]
    assert avg["q05"] <= TRUE_P_PHYS_KPA <= avg["q95"]
    from turgorbayes.report import criticism as report_criticism

    assert "model average (stacking)" in report_criticism.render_report(result)


# ----------------------------------------------------------------------------- engine
def test_importance_sampling_agrees_with_emcee(table):
    # reference: the package's emcee sampler (independent ensembles, autocorrelation rule) on
    # the same baseline posterior; means within 4 Monte Carlo standard errors, sds within 15 %
    cells, _ = _data(None, NULL_SEEDS[0])
    model = effects.ExtendedModel(cells, table)
    guess = models.PaperWLS(cells, table).fit().estimate
    u_map, cov = criticism.laplace(model, guess)
    post_is = criticism.importance_posterior(model, u_map, cov, 3, SETTINGS)
    post_mc = criticism.mcmc_posterior(model, u_map, cov, 4, SETTINGS)
    assert post_is.converged and post_mc.converged, (post_is.reasons, post_mc.reasons)
    for i in range(model.ndim):
        m1, m2 = post_is.weights @ post_is.u[:, i], np.mean(post_mc.u[:, i])
        s1 = np.sqrt(post_is.weights @ (post_is.u[:, i] - m1) ** 2)
        s2 = np.std(post_mc.u[:, i])
        ess_mc = post_mc.diagnostics["chain"][model.names[i]]["ess_bulk"]
        assert abs(m1 - m2) < 4 * np.sqrt(s1**2 / post_is.ess + s2**2 / ess_mc)
        assert_allclose(s1, s2, rtol=0.15)


class _GaussianModel:
    """A toy 'model': posterior N(mean, cov) split into n equal pointwise terms."""

    name = "toy"

    def __init__(self, mean, cov, n=5):
        self.mean, self.prec, self.n = np.asarray(mean), np.linalg.inv(cov), n
        self.obs = type("obs", (), {"n_cells": n})()

    def log_prior(self, u):
        return np.zeros(len(np.atleast_2d(u)))

    def pointwise_log_likelihood(self, u):
        d = np.atleast_2d(u) - self.mean
        q = -0.5 * np.einsum("ij,jk,ik->i", d, self.prec, d)
        return np.repeat(q[:, None] / self.n, self.n, axis=1)

    def log_posterior(self, u):
        return self.pointwise_log_likelihood(u).sum(axis=1)


def test_importance_sampling_recovers_a_known_gaussian():
    # reference: the exact mean and covariance; the proposal starts off-centre and too narrow,
    # so the moment-matching round is exercised
    mean = np.array([1.0, -2.0, 0.5])
    cov = np.array([[1.0, 0.8, 0.0], [0.8, 1.0, 0.3], [0.0, 0.3, 0.5]])
    model = _GaussianModel(mean, cov)
    settings = criticism.CriticismSettings(n_draws=4000)
    post = criticism.importance_posterior(model, mean + 0.5, 0.3 * cov, 1, settings)
    assert post.converged and post.diagnostics["k_hat"] < 0.7
    w = post.weights
    m = w @ post.u
    c = (post.u - m).T @ ((post.u - m) * w[:, None])
    se = np.sqrt(np.diag(cov) / post.ess)
    assert np.all(np.abs(m - mean) < 4 * se)
    assert_allclose(c, cov, atol=0.12)


def _conjugate(rng, n=30, S=16000):
    y = rng.normal(0.0, 1.0, n)
    y[0] = 3.5  # a mild outlier: the LOO ratios of that point have the heaviest tail
    theta = rng.normal(y.mean(), np.sqrt(1 / n), S)
    ll = stats.norm.logpdf(y[None, :], theta[:, None], 1.0)
    y_rest = (y.sum() - y) / (n - 1)
    exact = stats.norm.logpdf(y, y_rest, np.sqrt(1 + 1 / (n - 1)))
    return y, theta, ll, exact


def test_psis_loo_matches_the_exact_conjugate_loo(rng):
    # reference: y_i ~ N(theta, 1), flat prior: p(y_i | y_-i) = N(y_i; mean(y_-i), 1 + 1/(n-1))
    y, theta, ll, exact = _conjugate(rng)
    loo = criticism.psis_loo(ll, np.full(ll.shape[0], -np.log(ll.shape[0])))
    assert_allclose(loo["elpd_i"], exact, atol=0.01)
    assert loo["n_bad"] == 0 and loo["good_k"] == pytest.approx(min(1 - 1 / np.log10(16000), 0.7))
    # the same from importance-weighted draws of a wider t proposal
    q = stats.t(df=5, loc=y.mean(), scale=2 / np.sqrt(y.size))
    th = q.rvs(size=8000, random_state=rng)
    log_post = stats.norm.logpdf(th, y.mean(), np.sqrt(1 / y.size))
    log_w = log_post - q.logpdf(th)
    log_w -= np.log(np.sum(np.exp(log_w - log_w.max()))) + log_w.max()
    ll_w = stats.norm.logpdf(y[None, :], th[:, None], 1.0)
    assert_allclose(criticism.psis_loo(ll_w, log_w)["elpd_i"], exact, atol=0.02)


def test_gain_probability_is_the_normal_limit(rng):
    # reference: for normal pointwise differences P(sum > 0) -> Phi(delta / se)
    for mu in (0.0, 0.02, 0.05):
        d = rng.normal(mu, 0.25, 114)
        se = np.sqrt(d.size * np.var(d))
        p = criticism.gain_probability(d, np.random.default_rng(1), n_boot=20000)
        assert_allclose(p, stats.norm.cdf(d.sum() / se), atol=0.02)
    # gains concentrated in a few cells: the normal approximation says unclear, the bootstrap
    # says clear (3 cells gain 10 nats, the rest lose 0.02; P(Gamma(3) < 0.22) ~ 0.002)
    d = np.r_[np.full(3, 10.0), np.full(111, -0.02)]
    assert d.sum() < 2 * np.sqrt(d.size * np.var(d))
    assert criticism.gain_probability(d, np.random.default_rng(2)) > 0.99


def test_selection_rule():
    c = [{"effect": "a", "delta_elpd": 10.0, "delta_se": 2.0, "p_gain": 0.999},
         {"effect": "b", "delta_elpd": 3.0, "delta_se": 1.0, "p_gain": 0.999}]
    best, runner = criticism.select(c)
    assert best["effect"] == "a" and runner["effect"] == "b"
    assert criticism.select([dict(c[0], p_gain=0.97), c[1]])[0] is None  # not clear
    assert criticism.select([dict(c[0], delta_elpd=3.9), c[1]])[0] is None  # too small
    assert criticism.select([]) == (None, None)


def test_cause_names_weak_evidence_only_above_two_nats():
    # the rule: nothing selected; a best gain of 3 nats is named as weak evidence, 1.5 is not
    from types import SimpleNamespace

    def cands(d):
        return [{"effect": "outer_membrane", "delta_elpd": d, "delta_se": 1.8},
                {"effect": "bad_curves", "delta_elpd": -0.5, "delta_se": 0.3}]
    weak = criticism.cause_sentence(SimpleNamespace(selected=None, candidates=cands(3.0)))
    none = criticism.cause_sentence(SimpleNamespace(selected=None, candidates=cands(1.5)))
    assert weak.startswith("No cause found") and "Weak evidence for outer_membrane" in weak
    assert "3.0 +- 1.8" in weak
    assert "Weak evidence" not in none


def test_exact_refit_agrees_with_psis_where_psis_is_reliable(table):
    # reference: PSIS-LOO is accurate for cells with small Pareto k (the conjugate test above),
    # so the exact refit of such a cell must give the same elpd within Monte Carlo error
    result, _ = _criticized(None, NULL_SEEDS[0])
    post = result.posteriors["baseline"]
    cells, _ = _data(None, NULL_SEEDS[0])
    loo = criticism.exact_loo(post, cells, table, 5, SETTINGS, force=(0, 80))
    assert loo["refitted"][:2] == [0, 80]
    psis = criticism.psis_loo(post.log_lik, post.log_w)
    assert psis["pareto_k"][[0, 80]].max() < 0.5
    assert_allclose(loo["elpd_i"][[0, 80]], psis["elpd_i"][[0, 80]], atol=0.03)


def test_settings_are_validated():
    with pytest.raises(ValueError, match="engine must be 'importance' or 'emcee', got 'mcmc'"):
        criticism.CriticismSettings(engine="mcmc")
    with pytest.raises(ValueError, match="n_draws must be an integer >= 2, got 1"):
        criticism.CriticismSettings(n_draws=1)


def test_criticize_command_refuses_unknown_effects(tmp_path, capsys):
    from turgorbayes.cli import main

    with pytest.raises(SystemExit) as exit_info:
        main(["criticize", "--effects", "radius_spread,nope", "--out", str(tmp_path)])
    assert exit_info.value.code == 2
    assert "unknown effect(s) nope" in capsys.readouterr().err


def test_laplace_at_the_edge_of_the_domain_falls_back_to_a_diagonal_covariance(caplog):
    # a half-Gaussian: log density -u^2/2 for u >= 0, undefined (-inf) below; the mode u = 0
    # sits on the edge, so no central-difference Hessian is finite at any step size. The
    # documented fallback: the mode and a diagonal covariance of (0.01 max(|u|, 1))^2
    class Edge:
        name = "edge"

        @staticmethod
        def to_u(values):
            return np.array([[values["a"]]])

        @staticmethod
        def log_posterior(u):
            u = np.atleast_2d(u)[:, 0]
            return np.where(u >= 0, -0.5 * u * u, -np.inf)

    u_map, cov = criticism.laplace(Edge(), {"a": 0.0})
    assert_allclose(u_map, [0.0], atol=1e-12)
    assert_allclose(cov, [[1e-4]], rtol=1e-12)
    assert "no finite Hessian" in caplog.text
