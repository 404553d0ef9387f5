"""Tests of the model-agnostic posterior predictive checks (turgorbayes.criticism.checks).

The checks are exercised on a linear-Gaussian toy that needs none of the package's physics:
per observable o, y_o = a_o + b_o (x - x_ref) + sigma_o eps, with x the log pressure (bulged
cells log-uniform over 1-25 kPa, intact cells at 29 kPa), known slopes b_o, per-cell reported
errors sigma_o and a shared intercept a_o. "Known theta" uses the true a_o in every draw (the
p-values are then exactly uniform); "posterior" draws a_o from its conjugate posterior under a
flat prior, N(weighted mean, 1/sum(w)) (p-values conservative). Defects are planted in y only.
"""

import warnings

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from turgorbayes.criticism import checks

N_B, N_I = 72, 42
OBS = ("R_c", "k_c")
A = {"R_c": 500.0, "k_c": 0.02}  # intercepts (nm, N/m)
B = {"R_c": 40.0, "k_c": 0.004}  # known slopes per ln Pa


def simulate(rng, n_draws=600, known=True, defect=None, size=0.0):
    """One toy data set with its draws: the keyword arguments of ``run_checks``."""
    n = N_B + N_I
    group = np.array(["bulged"] * N_B + ["intact"] * N_I)
    x = np.concatenate([rng.uniform(np.log(1e3), np.log(25e3), N_B), np.full(N_I, np.log(29e3))])
    xc = x - np.log(8e3)
    sig = {"R_c": 10.0 * rng.uniform(0.7, 1.3, n), "k_c": 0.002 * rng.uniform(0.7, 1.3, n)}
    eps = rng.standard_normal((2, n))
    if defect == "correlation":  # a shared per-cell cause: corr(eps_R, eps_k) = size
        eps[1] = size * eps[0] + np.sqrt(1 - size**2) * eps[1]
    elif defect == "tails":  # a fraction `size` of measurements with 5x the reported noise
        eps[rng.random((2, n)) < size] *= 5.0
    elif defect == "outlier":  # one k_c far too low (tip slipped off the crest)
        eps[1, 0] -= size
    elif defect == "scatter":  # bulged-cell k_c errors `size` times larger than reported
        eps[1, :N_B] *= size
    elif defect == "scatter_all":
        eps *= size
    y = {o: A[o] + B[o] * xc + sig[o] * eps[j] for j, o in enumerate(OBS)}
    if defect == "trend":  # R_c of bulged cells drifts by `size` sigma per unit ln P
        y["R_c"][:N_B] += size * sig["R_c"][:N_B] * (xc[:N_B] - xc[:N_B].mean())
    elif defect == "offset":  # intact cells differ from the bulged ones' curve
        y["R_c"][N_B:] += size * sig["R_c"][N_B:]
        y["k_c"][N_B:] -= size * sig["k_c"][N_B:]
    mu, y_rep, log_lik = {}, {}, np.zeros((n_draws, n))
    for o in OBS:
        w = 1 / sig[o] ** 2
        if known:
            a_d = np.full(n_draws, A[o])
        else:
            a_hat = np.sum(w * (y[o] - B[o] * xc)) / w.sum()
            a_d = a_hat + rng.standard_normal(n_draws) / np.sqrt(w.sum())
        mu[o] = a_d[:, None] + B[o] * xc
        y_rep[o] = mu[o] + sig[o] * rng.standard_normal((n_draws, n))
        log_lik += stats.norm.logpdf(y[o], mu[o], sig[o])
    return {"y": y, "sigma": sig, "y_rep": y_rep, "mu": mu, "group": group, "log_pressure": x, "log_lik": log_lik}


def _without_loo(d):
    return {k: v for k, v in d.items() if k != "log_lik"}


# --- the statistics against independent references ------------------------------------------


def test_trend_is_the_regression_t_statistic(rng):
    # scipy.stats.linregress: slope / stderr is the same studentized slope.
    x = rng.uniform(0, 3, 50)
    z = 0.3 * x + rng.standard_normal(50)
    ref = stats.linregress(x, z)
    assert_allclose(checks.residual_trend(z[None, :], x), ref.slope / ref.stderr, rtol=1e-12)


def test_group_offset_is_welch_t(rng):
    # scipy.stats.ttest_ind(equal_var=False) on intact cells vs the top quarter of bulged ones.
    group = np.array(["bulged"] * 40 + ["intact"] * 12)
    x = np.concatenate([rng.permutation(np.linspace(7, 10, 40)), np.full(12, 10.3)])
    z = rng.standard_normal(52) + np.where(group == "intact", 0.8, 0.0)
    high = (group == "bulged") & (x >= np.sort(x[:40])[-10])
    ref = stats.ttest_ind(z[group == "intact"], z[high], equal_var=False).statistic
    assert_allclose(checks.group_offset(z[None, :], x, group, 0.25), ref, rtol=1e-12)


def test_correlation_and_kurtosis_match_numpy_and_scipy(rng):
    group = np.array(["bulged"] * 30 + ["intact"] * 20)
    z1, z2 = rng.standard_normal((2, 50))
    z1[30:] += 3.0  # a group offset must not count as correlation (centred within groups)
    c1 = np.concatenate([z1[:30] - z1[:30].mean(), z1[30:] - z1[30:].mean()])
    c2 = np.concatenate([z2[:30] - z2[:30].mean(), z2[30:] - z2[30:].mean()])
    assert_allclose(checks.residual_correlation(z1[None], z2[None], group), np.corrcoef(c1, c2)[0, 1], rtol=1e-12)
    one = np.array(["bulged"] * 50)
    assert_allclose(checks.kurtosis(z1[None], one), stats.kurtosis(z1, fisher=True, bias=True), rtol=1e-12)


def test_session_offset_is_the_anova_f_statistic(rng):
    # scipy.stats.f_oneway per group; each group's F enters times its K - 1 (a group with one
    # session adds nothing)
    group = np.array(["bulged"] * 30 + ["intact"] * 20)
    session = np.array(list("abc") * 10 + list("ab") * 10)
    z = rng.standard_normal(50) + np.where(session == "a", 0.7, 0.0)
    ref = sum((len(set(session[group == g])) - 1) * stats.f_oneway(
        *[z[(group == g) & (session == s)] for s in sorted(set(session[group == g]))]).statistic
        for g in ("bulged", "intact"))
    assert_allclose(checks.session_offset(z[None], session, group), ref, rtol=1e-12)
    one = np.where(group == "intact", "a", session)  # the intact cells in one session
    ref_b = 2 * stats.f_oneway(*[z[:30][session[:30] == s] for s in "abc"]).statistic
    assert_allclose(checks.session_offset(z[None], one, group), ref_b, rtol=1e-12)


def test_session_checks_only_with_sessions_and_they_see_a_session_offset(rng):
    # toy null with six sessions (known theta): the session checks' p-values are uniform; a
    # shared offset per session in k_c of 0.6 x (-1.5, -0.9, ..., 1.5) reported sigma (sd 0.6)
    # is flagged by session_k_c in most data sets (noncentrality ~43 against a chi^2_10
    # critical value of ~28 at the level 0.05/15: power ~0.97; 0.955 measured over 400 toy
    # data sets), so in at least 34 of 40 (P(fewer) = 0.002 at 0.955), and the battery
    # without sessions (or with one) has no session check
    d = _without_loo(simulate(rng, known=True))
    names = [r["name"] for r in checks.run_checks(**d)]
    assert not any(n.startswith("session_") for n in names)
    one = [r["name"] for r in checks.run_checks(**d, session=np.zeros(N_B + N_I, int))]
    assert one == names
    sessions = np.arange(N_B + N_I) % 6
    p = [{r["name"]: r["p_value"] for r in checks.run_checks(
        **_without_loo(simulate(rng, known=True)), session=sessions)}["session_k_c"]
        for _ in range(100)]
    assert stats.kstest(p, "uniform").pvalue > 1e-3
    hits = []
    for _ in range(40):
        d = _without_loo(simulate(rng, known=True))
        off = 0.6 * np.linspace(-1.5, 1.5, 6)[sessions]
        d["y"]["k_c"] = d["y"]["k_c"] + off * d["sigma"]["k_c"]
        res = {r["name"]: r["flagged"] for r in checks.run_checks(**d, session=sessions)}
        hits.append(res["session_k_c"])
    assert sum(hits) >= 34


def test_small_statistics_by_hand():
    group = np.array(["bulged", "bulged", "intact", "intact"])
    z = np.array([[1.0, -1.0, 2.0, 4.0]])
    # centred within groups: [1, -1, -1, 1] -> rms 1, max |c| 1
    assert_allclose(checks.max_abs_z(z, group), 1.0)
    assert_allclose(checks.mean_square(z), (1 + 1 + 4 + 16) / 4)
    assert_allclose(checks.standardized_residuals([3.0, 1.0], [2.0, 0.5], [[1.0, 2.0]]), [[1.0, -2.0]])
    # p = fraction of draws with T_rep >= T_obs: 2 of 4
    assert checks.posterior_predictive_pvalue([1.0, 1.0, 2.0, 2.0], [0.5, 1.0, 3.0, 1.0]) == 0.5


def test_flag_rules_and_bonferroni_level():
    alpha = checks.check_level(15)
    assert_allclose(alpha, 0.05 / 15)
    assert checks.flag(alpha / 2 * 0.99, "two", alpha) and checks.flag(1 - alpha / 2 * 0.99, "two", alpha)
    assert not checks.flag(alpha / 2 * 1.01, "two", alpha)
    assert checks.flag(alpha * 0.99, "upper", alpha) and not checks.flag(1.0, "upper", alpha)
    assert not checks.flag(float("nan"), "upper", alpha)
    with pytest.raises(ValueError, match="sided must be 'two' or 'upper', got 'lower'"):
        checks.flag(0.5, "lower", alpha)
    with pytest.raises(ValueError, match=r"family_alpha must lie in \(0, 1\), got 2"):
        checks.check_level(15, 2)


def test_check_spec_by_name():
    assert checks.check_spec("max_abs_z_k_c").sided == "upper"
    assert checks.check_spec("bulged_vs_intact_R_c").kind == "bulged_vs_intact"
    assert checks.check_spec("scatter_k_c_intact").sided == "two"
    with pytest.raises(ValueError, match="unknown check 'slope_R_c'"):
        checks.check_spec("slope_R_c")


def test_loo_pit_matches_exact_leave_one_out(rng):
    # Conjugate intercept model y_i ~ N(a, s_i^2), flat prior: the exact LOO predictive of y_i is
    # N(a_hat_{-i}, s_i^2 + 1/W_{-i}) (a_hat_{-i}, W_{-i}: precision-weighted mean and total
    # weight without cell i), so the exact LOO-PIT is a normal CDF. ArviZ's PSIS version from
    # 8000 posterior draws must agree to Monte Carlo accuracy. With 10 cells of unequal errors
    # (one precise cell 2 sigma out), leaving a cell out matters: the in-sample PIT differs from
    # the LOO one by ~0.11.
    s = np.array([0.3, 0.6, 0.8, 1.0, 1.2, 1.4, 1.5, 1.5, 1.0, 0.7])
    y = 2.0 + s * np.array([2.0, -1.5, 1.0, -0.5, 0.3, -1.0, 1.6, -2.0, 0.6, -0.2])
    n, D = s.size, 8000
    w = 1 / s**2
    a_d = np.sum(w * y) / w.sum() + rng.standard_normal(D) / np.sqrt(w.sum())
    y_rep = a_d[:, None] + s * rng.standard_normal((D, n))
    log_lik = stats.norm.logpdf(y, a_d[:, None], s)
    pit, k = checks.loo_pit_values(y, y_rep, log_lik)
    W_minus = w.sum() - w
    a_minus = (np.sum(w * y) - w * y) / W_minus
    exact = stats.norm.cdf((y - a_minus) / np.sqrt(s**2 + 1 / W_minus))
    in_sample = stats.norm.cdf((y - np.sum(w * y) / w.sum()) / np.sqrt(s**2 + 1 / w.sum()))
    assert k.shape == (n,) and np.all(np.isfinite(k))
    assert_allclose(pit, exact, atol=0.02)
    assert np.max(np.abs(pit - in_sample)) > 0.08


def test_uniformity_pvalue_separates_uniform_from_u_shaped(rng):
    assert checks.uniformity_pvalue(rng.uniform(size=200)) > 0.01
    assert checks.uniformity_pvalue(rng.beta(0.5, 0.5, size=200)) < 1e-4


# --- calibration under the null -------------------------------------------------------------


def test_pvalues_uniform_and_flag_rate_nominal_when_theta_known(rng):
    # 200 null data sets with known theta: each posterior predictive p-value is a Monte Carlo
    # p-value, uniform on {0, 1/600, ..., 1}; the flag rate per check is the Bonferroni level and
    # the chance of any flag at most family_alpha = 0.05.
    n_rep = 200
    P, F = [], []
    for _ in range(n_rep):
        res = checks.run_checks(**_without_loo(simulate(rng, known=True)))
        P.append([r["p_value"] for r in res])
        F.append([r["flagged"] for r in res])
    P, F = np.array(P), np.array(F)
    n_checks = P.shape[1]
    assert n_checks == 13
    for j in range(n_checks):
        assert stats.kstest(P[:, j], "uniform").pvalue > 1e-3, res[j]["name"]
    # all check evaluations together: Binomial(200 * 13, 0.05/13), mean 10, sd 3.2
    assert 2 <= F.sum() <= 20
    any_rate = F.any(axis=1).mean()
    assert any_rate <= 0.05 + 3 * np.sqrt(0.05 * 0.95 / n_rep)


def test_flag_rate_at_most_nominal_with_posterior_draws(rng):
    # Fitted intercepts: posterior predictive p-values are conservative, so a correct model is
    # flagged anywhere in at most ~5 % of data sets.
    n_rep = 100
    flagged = [
        any(r["flagged"] for r in checks.run_checks(**_without_loo(simulate(rng, known=False)))) for _ in range(n_rep)
    ]
    assert np.mean(flagged) <= 0.05 + 3 * np.sqrt(0.05 * 0.95 / n_rep)


def test_loo_pit_does_not_flag_a_correct_model(rng):
    # 12 null data sets x 2 observables with posterior draws: LOO-PIT stays quiet (POT-C p-values
    # of LOO-PIT are conservative: none below the 1/300 level expected, most well above).
    p = []
    for _ in range(12):
        d = simulate(rng, n_draws=300, known=False)
        for o in OBS:
            pit, _ = checks.loo_pit_values(d["y"][o], d["y_rep"][o], d["log_lik"])
            p.append(checks.uniformity_pvalue(pit))
    assert min(p) > checks.check_level(15)
    assert np.median(p) > 0.2


def test_run_checks_includes_loo_pit_with_log_lik(rng):
    res = checks.run_checks(**simulate(rng, n_draws=600, known=False))
    names = [r["name"] for r in res]
    assert len(names) == 15 and names[-2:] == ["loo_pit_R_c", "loo_pit_k_c"]
    assert all(set(r) == {"name", "statistic", "p_value", "flagged"} for r in res)
    # the reported LOO-PIT statistic is the Kolmogorov distance of the PIT values from uniform
    d = simulate(rng, n_draws=600, known=False)
    pit, _ = checks.loo_pit_values(d["y"]["k_c"], d["y_rep"]["k_c"], d["log_lik"])
    got = {r["name"]: r for r in checks.run_checks(**d)}["loo_pit_k_c"]["statistic"]
    assert_allclose(got, stats.kstest(pit, "uniform").statistic, rtol=1e-12)


# --- power: each check flags its own planted defect ------------------------------------------


@pytest.mark.parametrize(
    ("defect", "size", "check"),
    [
        ("trend", 0.6, "trend_R_c"),  # 0.6 sigma per ln P across 1-25 kPa
        ("scatter", 1.6, "scatter_k_c_bulged"),  # bulged k_c errors 1.6x the reported ones
        ("correlation", 0.6, "correlation_R_c_k_c"),  # a shared cause with correlation 0.6
        ("tails", 0.1, "kurtosis_k_c"),  # 10 % of measurements with 5x the noise
        ("outlier", 8.0, "max_abs_z_k_c"),  # one k_c 8 sigma low
        ("offset", 1.6, "bulged_vs_intact_k_c"),  # intact cells 1.6 sigma off the curve
    ],
)
def test_each_check_flags_its_planted_defect(rng, defect, size, check):
    n_rep = 20
    hits = []
    for _ in range(n_rep):
        res = checks.run_checks(**_without_loo(simulate(rng, known=False, defect=defect, size=size)))
        hits.append({r["name"]: r["flagged"] for r in res}[check])
    assert np.mean(hits) >= 0.9


def test_loo_pit_flags_errors_underreported_everywhere(rng):
    # every measurement's true error 1.8x the reported one: the LOO predictive is too narrow and
    # the LOO-PIT values pile up at 0 and 1.
    hits = []
    for _ in range(8):
        d = simulate(rng, n_draws=300, known=False, defect="scatter_all", size=1.8)
        pit, _ = checks.loo_pit_values(d["y"]["k_c"], d["y_rep"]["k_c"], d["log_lik"])
        hits.append(checks.flag(checks.uniformity_pvalue(pit), "upper", checks.check_level(15)))
    assert np.mean(hits) >= 0.85


# --- input validation ------------------------------------------------------------------------


def test_bad_inputs_are_reported(rng):
    d = _without_loo(simulate(rng, n_draws=600))
    bad = dict(d, group=np.where(d["group"] == "intact", "whole", d["group"]))
    with pytest.raises(ValueError, match=r"group labels must be 'bulged' or 'intact', got \['whole'\]"):
        checks.run_checks(**bad)
    bad = dict(d, mu={"R_c": d["mu"]["R_c"][:, :10], "k_c": d["mu"]["k_c"]})
    with pytest.raises(
        ValueError, match=r"mu\['R_c'\] must have shape \(n_draws, n_cells\) = \(600, 114\), got \(600, 10\)"
    ):
        checks.run_checks(**bad)
    bad = dict(d, sigma={"R_c": -d["sigma"]["R_c"], "k_c": d["sigma"]["k_c"]})
    with pytest.raises(ValueError, match=r"sigma\['R_c'\] finite and > 0"):
        checks.run_checks(**bad)
    with pytest.raises(ValueError, match="same observable keys"):
        checks.run_checks(**dict(d, y={"R_c": d["y"]["R_c"]}))
    with pytest.raises(ValueError, match=r"log_pressure must have shape \(114,\) or \(600, 114\), got \(3,\)"):
        checks.run_checks(**dict(d, log_pressure=np.ones(3)))


def test_too_few_draws_warns(rng):
    d = _without_loo(simulate(rng, n_draws=100))
    with pytest.warns(UserWarning, match=r"100 draws cannot resolve the per-check level 0.0038 \(need >= 520\)"):
        checks.run_checks(**d)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        checks.run_checks(**_without_loo(simulate(rng, n_draws=600)))
