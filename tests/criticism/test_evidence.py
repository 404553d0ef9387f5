"""The marginal likelihood of a fitted model and the Bayes factor that credits a named cause
(turgorbayes.criticism.evidence, docs/statistics.md "Naming a cause the generic description
also fits"). References: closed forms of Gaussian integrals."""

from types import SimpleNamespace

import numpy as np
import pytest
from scipy import stats

from turgorbayes.criticism.evidence import LOG_BF_MIN, bayes_factor, log_evidence
from turgorbayes.inference.engines import importance_log_evidence

#: A Gaussian joint density: ln p(y, u) = C - (u - m)' P (u - m) / 2, so that
#: Z = exp(C) (2 pi)^(d/2) det(P)^(-1/2) exactly (the closed form of the Gaussian integral).
M = np.array([0.3, -1.2])
COV = np.array([[0.5, 0.2], [0.2, 0.8]])
C = 1234.5


def _log_joint(u, c=C):
    d = np.atleast_2d(u) - M
    return c - 0.5 * np.einsum("si,ij,sj->s", d, np.linalg.inv(COV), d)


def _exact(c=C):
    return c + np.log(2 * np.pi) + 0.5 * np.log(np.linalg.det(COV))


def test_importance_estimate_of_the_evidence_matches_the_gaussian_integral():
    rng = np.random.default_rng(3)
    q = stats.multivariate_t(M + 0.2, 2.0 * COV, df=5)  # a wider, shifted proposal
    u = q.rvs(size=20000, random_state=rng)
    raw = _log_joint(u) - q.logpdf(u)
    est = importance_log_evidence(raw)
    assert est["log_evidence"] == pytest.approx(_exact(), abs=4 * est["log_evidence_se"])
    assert 0 < est["log_evidence_se"] < 0.02
    # draws outside the support (raw -inf) count as weight zero, not as missing draws: half
    # the draws with zero weight halve Z (ln 2 less)
    half = importance_log_evidence(np.concatenate([raw, np.full(raw.size, -np.inf)]))
    assert half["log_evidence"] == pytest.approx(est["log_evidence"] - np.log(2), abs=1e-12)


def _post(engine="laplace", c=C, k_hat=0.2, log_z=None):
    model = SimpleNamespace(log_posterior=lambda u: _log_joint(u, c))
    diag = {} if log_z is None else {"k_hat": k_hat, "log_evidence": log_z,
                                     "log_evidence_se": 0.05}
    return SimpleNamespace(engine=engine, diagnostics=diag, u_map=M, cov=COV, model=model)


def test_laplace_evidence_is_exact_for_a_gaussian_posterior():
    ev = log_evidence(_post())
    assert ev["method"] == "laplace" and ev["se"] is None
    assert ev["value"] == pytest.approx(_exact(), abs=1e-9)


def test_importance_evidence_is_used_only_where_its_weights_are_trusted():
    assert log_evidence(_post("importance", log_z=5.0))["value"] == 5.0
    # Pareto k above 0.7: the importance estimate is not trusted, the Laplace one is used
    untrusted = log_evidence(_post("importance", k_hat=0.9, log_z=5.0))
    assert untrusted["method"] == "laplace"
    assert untrusted["value"] == pytest.approx(_exact(), abs=1e-9)


def test_the_bayes_factor_credits_a_cause_only_beyond_ln_20_and_two_errors():
    generic = _post("importance", log_z=100.0)
    # ln BF = 3.2 with se hypot(0.05, 0.05) = 0.071: 3.2 - 0.14 = 3.06 >= ln 20 = 2.996
    assert bayes_factor(_post("importance", log_z=103.2), generic)["credits"]
    # ln BF = 3.05: inside two errors of the bar
    bf = bayes_factor(_post("importance", log_z=103.05), generic)
    assert bf["log_bf"] == pytest.approx(3.05) and not bf["credits"]
    assert LOG_BF_MIN == pytest.approx(np.log(20))
    # a Laplace evidence has no error: taken at face value
    lap = bayes_factor(_post(c=100.0 - _exact(0.0) + 3.1), generic)
    assert lap["methods"] == ["laplace", "importance"] and lap["se"] is None
    assert lap["log_bf"] == pytest.approx(3.1) and lap["credits"]


def _elpd(total, n=100, spread=0.1, seed=0):
    """Pointwise elpd summing to ``total`` with a small spread (a clear gain or loss)."""
    e = np.random.default_rng(seed).normal(0.0, spread, n)
    return {"elpd_i": e - e.mean() + total / n}


@pytest.mark.parametrize("named_gain, log_bf, by", [
    (10.0, 0.0, "loo"),            # it beats the generic description by the rule itself
    (1.0, 3.6, "bayes_factor"),    # LOO cannot tell them apart; the marginal likelihood can
    (1.0, 2.0, None),              # ... but not by enough
    (-10.0, 8.0, None),            # the generic description wins by the rule: never credited
])
def test_the_named_effect_is_identified_by_loo_or_else_by_the_bayes_factor(named_gain, log_bf, by):
    # reference: the rule of docs/statistics.md ("Naming a cause the generic description also
    # fits"): LOO first (gain > 4 nats, probability >= 0.975), then ln BF - 2 se >= ln 20 unless
    # the generic description beats the named effect by the rule
    from turgorbayes.workflows.criticize import _compare_generic

    posts = {"radius_spread": _post("importance", log_z=100.0 + log_bf),
             "discrepancy": _post("importance", log_z=100.0)}
    loos = {"radius_spread": _elpd(named_gain), "discrepancy": _elpd(0.0, seed=1)}
    generic = {"effect": "discrepancy"}
    _compare_generic(generic, "radius_spread", posts, loos, seed=0)
    assert generic["identified_by"] == by and generic["selected_identified"] == (by is not None)
    assert generic["vs_selected"]["delta_elpd"] == pytest.approx(-named_gain, abs=1e-9)
    assert generic["vs_selected"]["bayes_factor"]["log_bf"] == pytest.approx(log_bf)
