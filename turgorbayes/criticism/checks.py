r"""Posterior predictive checks as pure functions on arrays (model-agnostic).

Each check is a discrepancy statistic :math:`T(y, \theta)` chosen so that one plausible failure
of the turgor model leaves its own fingerprint (:data:`CHECKS`), with the posterior predictive
p-value :math:`p = \frac1D\sum_d \mathbb 1[T(y^{rep}_d, \theta_d) \ge T(y, \theta_d)]` over
``D`` draws (Gelman, Meng & Stern, Stat. Sinica 6, 733, 1996). Residuals are standardized by the
reported errors. The battery is flagged at a Bonferroni family-wise level
(:data:`FAMILY_ALPHA`, :func:`check_level`, :func:`flag`). See ``docs/effects.md``.
"""

import warnings
from dataclasses import dataclass

import numpy as np

from turgorbayes._moved import deprecated_attributes
from turgorbayes.criticism.statistics import (
    GROUPS,
    condition_lines,
    group_offset,
    kurtosis,
    loo_pit_values,
    max_abs_z,
    mean_square,
    order_drift,
    residual_correlation,
    residual_trend,
    session_offset,
    standardized_residuals,
    uniformity_pvalue,
)
from turgorbayes.inference.conditions import MIN_BULGED

__all__ = [
    "CHECKS",
    "CONDITIONS_MIN_BULGED",
    "CONDITIONS_OBSERVABLES",
    "FAMILY_ALPHA",
    "CheckSpec",
    "check_level",
    "check_spec",
    "condition_lines",
    "flag",
    "group_offset",
    "kurtosis",
    "loo_pit_values",
    "max_abs_z",
    "mean_square",
    "order_drift",
    "posterior_predictive_pvalue",
    "replicates",
    "residual_correlation",
    "residual_trend",
    "run_checks",
    "standardized_residuals",
    "uniformity_pvalue",
]

#: Names that moved out of this module (:mod:`turgorbayes._moved`).
__getattr__ = deprecated_attributes(__name__, {"format_p_value": "turgorbayes.formatting"})

#: Chance that a correct model is flagged by at least one check (Bonferroni bound).
FAMILY_ALPHA = 0.05


@dataclass(frozen=True)
class CheckSpec:
    """What a check measures: ``sided`` is ``"two"`` or ``"upper"``; ``fingerprint`` in words;
    ``label`` its short name in figures and tables (mathtext allowed)."""

    kind: str
    sided: str
    fingerprint: str
    label: str


#: The kinds of check, by name prefix (the one table of checks: figures and reports read it).
CHECKS = {
    "trend": CheckSpec("trend", "two", "residuals drift with log pressure (wrong pressure "
                       "dependence)", "trend with pressure"),
    "scatter": CheckSpec("scatter", "two", "scatter differs from the reported errors (chi2/n) "
                         "in one group", "scatter vs. errors"),
    "correlation": CheckSpec("correlation", "two", "R_c and k_c residuals move together (a "
                             "shared hidden cause)", "correlation of $R_c$ and $k_c$ residuals"),
    "max_abs_z": CheckSpec("max_abs_z", "upper", "an outlier (e.g. a corrupted force curve)",
                           "largest outlier"),
    "kurtosis": CheckSpec("kurtosis", "upper", "heavy tails (a mixture of good and bad "
                          "measurements)", "heavy tails (kurtosis)"),
    "bulged_vs_intact": CheckSpec(
        "bulged_vs_intact", "two", "bulged and intact cells disagree near physiological pressure",
        "bulged vs. intact offset"),
    "loo_pit": CheckSpec("loo_pit", "upper", "leave-one-out predictive distributions "
                         "miscalibrated", "LOO-PIT calibration"),
    "order": CheckSpec(
        "order", "upper", "residuals drift with measurement order (a drifting cantilever or "
        "tip, cells changing on the slide): the sum over the groups of their squared "
        "studentized slopes on the order", "drift with measurement order"),
    "session": CheckSpec(
        "session", "upper", "residuals differ between measurement sessions (a cantilever's "
        "calibration, a slide or a culture shared within a session): the sum over the groups "
        "of the one-way analysis-of-variance statistic between sessions",
        "offsets between sessions"),
    "conditions": CheckSpec(
        "conditions", "upper", "bulged cells' residuals differ in level or pressure trend "
        "between conditions (a wall of one condition's own)", "conditions differ (bulged cells)"),
}
#: Observables of the ``conditions`` check (only with several conditions): its statistic is
#: the sum of their :func:`condition_lines` F.
CONDITIONS_OBSERVABLES = ("R_c", "k_c")
#: Bulged cells a condition needs to enter the ``conditions`` check.
CONDITIONS_MIN_BULGED = MIN_BULGED


def check_spec(name):
    """The :class:`CheckSpec` of a check name such as ``"max_abs_z_k_c"`` (by its kind prefix)."""
    kinds = [k for k in CHECKS if name.startswith(k + "_")]
    if not kinds:
        raise ValueError(f"unknown check {name!r}; names start with one of {sorted(CHECKS)}")
    return CHECKS[max(kinds, key=len)]


# --- statistics: each maps (n_draws, n_cells) residuals to (n_draws,) values -------------------


def posterior_predictive_pvalue(T_obs, T_rep):
    r"""Fraction of draws with :math:`T(y^{rep}_d, \theta_d) \ge T(y, \theta_d)` (non-finite pairs skipped)."""
    T_obs, T_rep = np.broadcast_arrays(np.asarray(T_obs, float), np.asarray(T_rep, float))
    ok = np.isfinite(T_obs) & np.isfinite(T_rep)
    if not ok.any():
        return float("nan")
    return float(np.mean(T_rep[ok] >= T_obs[ok]))


def replicates(check_name, n_rep):
    """Replicates a check's p-value was counted from: ``n_rep``, or None for the analytic
    ``loo_pit`` uniformity tests (:func:`turgorbayes.formatting.format_p_value`)."""
    return None if check_spec(check_name).kind == "loo_pit" else n_rep


def check_level(n_checks, family_alpha=FAMILY_ALPHA):
    """Per-check level ``family_alpha / n_checks`` (Bonferroni)."""
    if not 0 < family_alpha < 1:
        raise ValueError(f"family_alpha must lie in (0, 1), got {family_alpha!r}")
    if n_checks < 1:
        raise ValueError(f"n_checks must be >= 1, got {n_checks!r}")
    return family_alpha / n_checks


def flag(p_value, sided, alpha):
    """Whether ``p_value`` fails a check of the given sidedness at per-check level ``alpha``."""
    if not np.isfinite(p_value):
        return False
    if sided == "two":
        return bool(p_value < alpha / 2 or p_value > 1 - alpha / 2)
    if sided == "upper":
        return bool(p_value < alpha)
    raise ValueError(f"sided must be 'two' or 'upper', got {sided!r}")


# --- the battery ----------------------------------------------------------------------------


def _as_2d(name, a, n_draws, n_cells):
    a = np.asarray(a, dtype=float)
    if a.shape != (n_draws, n_cells):
        raise ValueError(f"{name} must have shape (n_draws, n_cells) = ({n_draws}, {n_cells}), got {a.shape}")
    return a


def _validate(y, sigma, y_rep, mu, group, log_pressure, log_lik):
    names = list(y)
    if not names or set(names) != set(sigma) or set(names) != set(y_rep) or set(names) != set(mu):
        raise ValueError(
            f"y, sigma, y_rep and mu must have the same observable keys, got {list(y)}, {list(sigma)}, "
            f"{list(y_rep)}, {list(mu)}"
        )
    group = np.asarray(group).astype(str)
    n_cells = group.size
    unknown = sorted(str(g) for g in set(group) - set(GROUPS))
    if unknown:
        raise ValueError(f"group labels must be 'bulged' or 'intact', got {unknown}")
    n_bulged = (group == "bulged").sum()
    if n_bulged in (1, 2) or (group == "intact").sum() < 1:
        raise ValueError(
            f"need >= 3 (or no) bulged and >= 1 intact cells, got {n_bulged} and {(group == 'intact').sum()}"
        )
    n_draws = np.asarray(y_rep[names[0]]).shape[0]
    if n_draws < 2:
        raise ValueError(f"need >= 2 posterior draws, got {n_draws}")
    out = {}
    for o in names:
        yo, so = np.asarray(y[o], float), np.asarray(sigma[o], float)
        if yo.shape != (n_cells,) or so.shape not in ((n_cells,), (n_draws, n_cells)):
            raise ValueError(f"y[{o!r}] must have shape ({n_cells},) and sigma[{o!r}] ({n_cells},) "
                             f"or ({n_draws}, {n_cells}), got {yo.shape} and {so.shape}")
        if not np.all(np.isfinite(yo)) or not np.all((so > 0) & np.isfinite(so)):
            raise ValueError(f"y[{o!r}] must be finite and sigma[{o!r}] finite and > 0")
        out[o] = (
            yo,
            so,
            _as_2d(f"y_rep[{o!r}]", y_rep[o], n_draws, n_cells),
            _as_2d(f"mu[{o!r}]", mu[o], n_draws, n_cells),
        )
    x = np.asarray(log_pressure, float)
    if x.shape not in ((n_cells,), (n_draws, n_cells)):
        raise ValueError(f"log_pressure must have shape ({n_cells},) or ({n_draws}, {n_cells}), got {x.shape}")
    if log_lik is not None:
        log_lik = _as_2d("log_lik", log_lik, n_draws, n_cells)
    return out, group, x, log_lik, n_draws


def _both(f, pair, *args):
    """``f`` on the observed and on the replicated residuals."""
    return f(pair[0], *args), f(pair[1], *args)


def _strata(group, stratum):
    """``group`` refined by ``stratum`` (``"intact:2"``; None: ``group`` itself)."""
    if stratum is None:
        return group
    stratum = np.asarray(stratum)
    if stratum.shape != group.shape:
        raise ValueError(f"stratum must have shape {group.shape}, got {stratum.shape}")
    return np.array([f"{g}:{s}" for g, s in zip(group, stratum, strict=True)])


def _stat_pairs(res, group, x, high_fraction, condition=None, order=None, stratum=None,
                session=None):
    """``{name: (kind, T_obs per draw, T_rep per draw)}`` for every posterior predictive check
    (``conditions_R_c_k_c`` only with ``condition``: :func:`_compared_conditions`; ``order_*``
    only with ``order``; ``session_*`` only with two sessions or more; the checks of the
    bulged cells only with bulged cells; the centred checks centre within ``stratum`` inside
    each group where it is given)."""
    out = {}
    bulged = group == "bulged"
    strata = _strata(group, stratum)
    xb = np.broadcast_to(x, (next(iter(res.values()))[0].shape[0], group.size))[:, bulged]
    for o, pair in res.items():
        if bulged.any():
            out[f"trend_{o}"] = ("trend", *_both(residual_trend, (pair[0][:, bulged], pair[1][:, bulged]), xb))
    for o, pair in res.items():
        for g in GROUPS:
            m = group == g
            if m.any():
                out[f"scatter_{o}_{g}"] = ("scatter", *_both(mean_square, (pair[0][:, m], pair[1][:, m])))
    names = list(res)
    for i, o1 in enumerate(names):
        for o2 in names[i + 1 :]:
            T_obs = residual_correlation(res[o1][0], res[o2][0], strata)
            T_rep = residual_correlation(res[o1][1], res[o2][1], strata)
            out[f"correlation_{o1}_{o2}"] = ("correlation", T_obs, T_rep)
    for o, pair in res.items():
        out[f"max_abs_z_{o}"] = ("max_abs_z", *_both(max_abs_z, pair, strata))
    for o, pair in res.items():
        out[f"kurtosis_{o}"] = ("kurtosis", *_both(kurtosis, pair, strata))
    for o, pair in res.items():
        if bulged.any():
            out[f"bulged_vs_intact_{o}"] = ("bulged_vs_intact", *_both(group_offset, pair, x, group, high_fraction))
    if order is not None:
        order = np.asarray(order, float)
        for o, pair in res.items():
            out[f"order_{o}"] = ("order", *_both(order_drift, pair, order, strata))
    if session is not None and np.unique(np.asarray(session)).size >= 2:
        session = np.asarray(session)
        if session.shape != group.shape:
            raise ValueError(f"session must have shape {group.shape}, got {session.shape}")
        for o, pair in res.items():
            out[f"session_{o}"] = ("session", *_both(session_offset, pair, session, strata))
    cells = _compared_conditions(group, condition)
    if cells is not None and set(CONDITIONS_OBSERVABLES) <= set(res):
        cond, xc = np.asarray(condition)[cells], np.broadcast_to(x, res[names[0]][0].shape)[:, cells]
        T = [sum(condition_lines(res[o][k][:, cells], xc, cond) for o in CONDITIONS_OBSERVABLES) for k in (0, 1)]
        out["conditions_" + "_".join(CONDITIONS_OBSERVABLES)] = ("conditions", *T)
    return out


def _compared_conditions(group, condition):
    """Indices of the bulged cells of the conditions with at least
    :data:`CONDITIONS_MIN_BULGED` bulged cells, or None unless there are two such conditions
    (a condition's intact cells fit its own ``P_phys`` and ``R0`` whatever its wall: only its
    bulged cells, at their measured pressures, can show a wall of its own)."""
    if condition is None:
        return None
    condition = np.asarray(condition)
    if condition.shape != group.shape:
        raise ValueError(f"condition must have shape {group.shape}, got {condition.shape}")
    bulged = group == "bulged"
    labels, counts = np.unique(condition[bulged], return_counts=True)
    kept = labels[counts >= CONDITIONS_MIN_BULGED]
    if kept.size < 2:
        return None
    return np.flatnonzero(bulged & np.isin(condition, kept))


def run_checks(
    y,
    sigma,
    y_rep,
    mu,
    group,
    log_pressure,
    log_lik=None,
    *,
    family_alpha=FAMILY_ALPHA,
    high_pressure_fraction=0.25,
    condition=None,
    order=None,
    stratum=None,
    session=None,
):
    """Run the whole battery of posterior predictive checks.

    Parameters
    ----------
    y, sigma : mapping of str to array_like (n_cells,)
        Observed values and the errors the residuals are standardized by, per observable (e.g.
        ``{"R_c": ..., "k_c": ...}``, any consistent unit per observable); an error may be
        given per draw, ``(n_draws, n_cells)``, where it scales with the predicted value.
    y_rep, mu : mapping of str to array_like (n_draws, n_cells)
        Replicated data and the predicted means they were drawn around, draw by draw.
    group : array_like of str, (n_cells,)
        ``"bulged"`` or ``"intact"``.
    log_pressure : array_like, (n_cells,) or (n_draws, n_cells) [ln Pa]
        Log pressure of each cell (posterior mean, or per draw).
    log_lik : array_like, (n_draws, n_cells), optional
        Per-cell log-likelihood; without it the ``loo_pit`` checks are skipped.
    family_alpha : float
        Chance of flagging a correct model anywhere (Bonferroni over the checks run).
    high_pressure_fraction : float
        Fraction of bulged cells compared with intact ones by ``bulged_vs_intact``.
    condition : array_like (n_cells,), optional
        Each cell's condition (several conditions): adds the ``conditions_R_c_k_c`` check of the
        bulged cells' residuals (the sum over ``R_c`` and ``k_c`` of :func:`condition_lines`)
        when at least two conditions have :data:`CONDITIONS_MIN_BULGED` bulged cells. None (or
        one condition): the battery without it, unchanged.
    order : array_like (n_cells,), optional
        Each cell's measurement order scaled to [-0.5, 0.5]
        (:func:`turgorbayes.cells.order.measurement_order`): adds the ``order_*`` checks
        (:func:`order_drift`). None: the battery without them.
    stratum : array_like (n_cells,), optional
        Each cell's stratum within its group (an osmotic series: the intact cells' medium
        levels): the centred checks (``correlation``, ``max_abs_z``, ``kurtosis``, ``order``)
        centre, and ``order`` fits its slopes, within each stratum of each group. None: within
        the groups. Without bulged cells the checks of the bulged cells (``trend``, their
        ``scatter``, ``bulged_vs_intact``) are not run.
    session : array_like (n_cells,), optional
        Each cell's measurement session (the ``session`` column): with two sessions or more
        adds the ``session_*`` checks (:func:`session_offset`, within each stratum of each
        group). None (or one session): the battery without them.

    Returns
    -------
    list of dict
        One ``{"name", "statistic", "p_value", "flagged"}`` per check, in the order of
        :data:`CHECKS` (``statistic`` is :math:`T(y, \\theta)` averaged over the draws; for
        ``loo_pit`` the Kolmogorov distance of the LOO-PIT values from uniform).
    """
    if not 0 < high_pressure_fraction <= 1:
        raise ValueError(f"high_pressure_fraction must lie in (0, 1], got {high_pressure_fraction!r}")
    data, group, x, log_lik, n_draws = _validate(y, sigma, y_rep, mu, group, log_pressure, log_lik)
    res = {
        o: (standardized_residuals(yo, so, mo), standardized_residuals(ro, so, mo))
        for o, (yo, so, ro, mo) in data.items()
    }
    pairs = _stat_pairs(res, group, x, high_pressure_fraction, condition, order, stratum,
                        session)
    n_checks = len(pairs) + (len(data) if log_lik is not None else 0)
    alpha = check_level(n_checks, family_alpha)
    if n_draws < 2 / alpha:
        warnings.warn(
            f"{n_draws} draws cannot resolve the per-check level {alpha:.2g} (need >= {int(np.ceil(2 / alpha))})",
            stacklevel=2,
        )
    results = []
    for name, (kind, T_obs, T_rep) in pairs.items():
        p = posterior_predictive_pvalue(T_obs, T_rep)
        results.append(_entry(name, np.nanmean(T_obs), p, flag(p, CHECKS[kind].sided, alpha)))
    if log_lik is not None:
        results.extend(_loo_pit_checks(data, log_lik, alpha))
    return results


def _loo_pit_checks(data, log_lik, alpha):
    out = []
    for o, (yo, _, ro, _) in data.items():
        pit, k = loo_pit_values(yo, ro, log_lik)
        if np.any(k > 0.7):
            warnings.warn(
                f"LOO-PIT of {o}: {int(np.sum(k > 0.7))} cells with Pareto k > 0.7 (unreliable)", stacklevel=3
            )
        u = np.sort(pit)
        n = u.size
        ks = max(np.max(np.arange(1, n + 1) / n - u), np.max(u - np.arange(n) / n))
        p = uniformity_pvalue(pit)
        out.append(_entry(f"loo_pit_{o}", ks, p, flag(p, "upper", alpha)))
    return out


def _entry(name, statistic, p_value, flagged):
    return {"name": name, "statistic": float(statistic), "p_value": float(p_value), "flagged": bool(flagged)}
