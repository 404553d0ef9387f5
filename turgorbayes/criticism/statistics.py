r"""The discrepancy statistics of the posterior predictive checks, as pure functions on
arrays: each maps standardized residuals ``(n_draws, n_cells)`` to one value per draw
(:mod:`turgorbayes.criticism.checks` runs them as a battery; docs/effects.md, "Posterior
predictive checks").
"""

import numpy as np
from arviz_stats.base import array_stats

__all__ = ["condition_lines", "group_offset", "kurtosis", "loo_pit_values", "max_abs_z",
           "mean_square", "order_drift", "residual_correlation", "residual_trend",
           "session_offset", "standardized_residuals", "uniformity_pvalue"]

#: The two groups of cells.
GROUPS = ("bulged", "intact")


def standardized_residuals(y, sigma, mu):
    r"""Residuals in units of the reported errors, :math:`z = (y - \mu)/\sigma`.

    Parameters
    ----------
    y : array_like, (n_cells,) or (n_draws, n_cells)
        Observed or replicated values (any unit).
    sigma : array_like, (n_cells,)
        Reported standard errors (same unit).
    mu : array_like, (n_draws, n_cells)
        Predicted means per draw (same unit).

    Returns
    -------
    ndarray, (n_draws, n_cells)
    """
    return (np.asarray(y, float) - np.asarray(mu, float)) / np.asarray(sigma, float)


def residual_trend(z, x):
    r"""Studentized least-squares slope of ``z`` against ``x``, per draw.

    .. math::

        t = \frac{b\sqrt{S_{xx}}}{s}, \quad b = \frac{\sum(x-\bar x)(z-\bar z)}{S_{xx}}, \quad
        S_{xx} = \sum(x-\bar x)^2, \quad s^2 = \frac{\sum[(z-\bar z) - b(x-\bar x)]^2}{n-2}

    Studentized by the residuals' own scatter so that misreported errors (the ``scatter``
    check's business) do not make it fire.

    Parameters
    ----------
    z : ndarray, (n_draws, n)
        Standardized residuals.
    x : ndarray, (n,) or (n_draws, n)
        Covariate (log pressure [ln Pa]).

    Returns
    -------
    ndarray, (n_draws,) [-]
    """
    x = np.broadcast_to(x, z.shape)
    dx = x - x.mean(axis=-1, keepdims=True)
    dz = z - z.mean(axis=-1, keepdims=True)
    s_xx = (dx * dx).sum(axis=-1)
    b = (dx * dz).sum(axis=-1) / s_xx
    s2 = ((dz - b[..., None] * dx) ** 2).sum(axis=-1) / (z.shape[-1] - 2)
    return b * np.sqrt(s_xx / s2)


def mean_square(z):
    r""":math:`\chi^2/n = \overline{z^2}` per draw (1 on average when errors are as reported)."""
    return np.mean(z * z, axis=-1)


def _centred(z, group):
    """``z`` minus its per-draw mean within each group (any labels: the two groups, or groups
    refined by an osmotic series' medium levels)."""
    out = np.array(z, dtype=float)
    for g in np.unique(group):
        m = group == g
        if m.any():
            out[..., m] -= out[..., m].mean(axis=-1, keepdims=True)
    return out


def residual_correlation(z1, z2, group):
    r"""Pooled within-group Pearson correlation of two observables' residuals, per draw.

    .. math:: r = \frac{\sum_i c_{1,i} c_{2,i}}{\sqrt{\sum_i c_{1,i}^2 \sum_i c_{2,i}^2}}

    with :math:`c` the residuals centred within each group (so a group-level offset, the
    ``bulged_vs_intact`` check's business, does not count as correlation).
    """
    c1, c2 = _centred(z1, group), _centred(z2, group)
    return (c1 * c2).sum(axis=-1) / np.sqrt((c1 * c1).sum(axis=-1) * (c2 * c2).sum(axis=-1))


def max_abs_z(z, group):
    r"""Largest group-centred ``|z|`` over the rms of the centred ``z``, per draw (scale-free).

    Uniformly inflated errors leave it unchanged (that is the ``scatter`` check's job); one
    outlier raises it.
    """
    c = _centred(z, group)
    return np.max(np.abs(c), axis=-1) / np.sqrt(np.mean(c * c, axis=-1))


def kurtosis(z, group):
    r"""Excess kurtosis :math:`\overline{c^4}/(\overline{c^2})^2 - 3` of the group-centred ``z``."""
    c = _centred(z, group)
    m2 = np.mean(c * c, axis=-1)
    c2 = c * c
    return np.mean(c2 * c2, axis=-1) / (m2 * m2) - 3.0


def group_offset(z, log_pressure, group, high_fraction=0.25):
    r"""Welch t of the mean ``z`` of intact cells against the highest-pressure bulged cells, per draw.

    .. math:: t = \frac{\bar z_{intact} - \bar z_{high}}{\sqrt{s^2_{intact}/n_{intact} + s^2_{high}/n_{high}}}

    The bulged cells compared are those whose log pressure (per draw) is in the top
    ``high_fraction`` of the bulged cells (at least two): the ones closest to the intact cells'
    physiological pressure, where one curve must pass through both groups. Studentized by the
    groups' own scatter, so misreported errors do not make it fire.

    Parameters
    ----------
    z : ndarray, (n_draws, n_cells)
    log_pressure : ndarray, (n_cells,) or (n_draws, n_cells) [ln Pa]
    group : ndarray of str, (n_cells,)
    high_fraction : float
        Fraction of the bulged cells counted as "high pressure", in (0, 1].

    Returns
    -------
    ndarray, (n_draws,) [-]
    """
    bulged, intact = group == "bulged", group == "intact"
    n_high = max(2, int(round(high_fraction * bulged.sum())))
    x = np.asarray(log_pressure, float)
    if x.ndim == 1:  # the same cells in every draw
        top = np.argsort(x[bulged])[-n_high:]
        z_high = z[:, bulged][:, top]
    else:
        top = np.argsort(x[:, bulged], axis=-1)[:, -n_high:]
        z_high = np.take_along_axis(z[:, bulged], top, axis=-1)
    z_int = z[:, intact]
    var_i = z_int.var(axis=-1, ddof=1) / z_int.shape[-1] if z_int.shape[-1] > 1 else 0.0
    se = np.sqrt(var_i + z_high.var(axis=-1, ddof=1) / n_high)
    return (z_int.mean(axis=-1) - z_high.mean(axis=-1)) / se


def _line_rss(z, x):
    """Residual sum of squares of the least-squares line of ``z`` on ``x`` per draw
    (``(n_draws, n)`` each)."""
    dx = x - x.mean(axis=-1, keepdims=True)
    dz = z - z.mean(axis=-1, keepdims=True)
    b = (dx * dz).sum(axis=-1) / (dx * dx).sum(axis=-1)
    return ((dz - b[..., None] * dx) ** 2).sum(axis=-1)


def condition_lines(z, x, condition):
    r"""F of separate residual lines per condition against one common line, per draw.

    Each condition's residuals ``z`` get their own line in log pressure ``x`` (intercept and
    slope); the extra-sum-of-squares F compares them with one line for all:

    .. math:: F = \frac{(RSS_1 - RSS_C) / (2(C - 1))}{RSS_C / (N - 2C)}

    (``RSS_1``: one line, ``RSS_C``: a line per condition, ``N`` cells, ``C`` conditions). A
    wall of its own in one condition gives its cells residuals of their own level and trend
    with pressure, which the shared wall cannot follow (each condition's own ``R0`` absorbs
    part of the level). Studentized by the residuals' own scatter, so misreported errors do
    not make it fire.

    Parameters
    ----------
    z : ndarray, (n_draws, n)
        Standardized residuals of the cells compared (the bulged cells).
    x : ndarray, (n,) or (n_draws, n)
        Their log pressure [ln Pa].
    condition : ndarray of int, (n,)
        Each cell's condition; at least two conditions with three cells each.

    Returns
    -------
    ndarray, (n_draws,) [-]
    """
    condition = np.asarray(condition)
    x = np.broadcast_to(np.asarray(x, float), z.shape)
    labels, n_c = np.unique(condition, return_counts=True)
    if labels.size < 2 or np.any(n_c < 3):
        raise ValueError(f"need >= 2 conditions with >= 3 cells each, got sizes {n_c.tolist()}")
    rss_c = sum(_line_rss(z[:, condition == c], x[:, condition == c]) for c in labels)
    rss_1 = _line_rss(z, x)
    C, n = labels.size, z.shape[-1]
    return ((rss_1 - rss_c) / (2 * (C - 1))) / (rss_c / (n - 2 * C))


def loo_pit_values(y, y_rep, log_lik):
    """Pareto-smoothed LOO-PIT values with ArviZ (``arviz_stats``, PSIS weights from ``log_lik``).

    Parameters
    ----------
    y : ndarray, (n_cells,)
    y_rep : ndarray, (n_draws, n_cells)
    log_lik : ndarray, (n_draws, n_cells)
        Per-cell log-likelihood of each draw (the cell's joint likelihood: leaving a cell out
        removes both of its observables).

    Returns
    -------
    pit : ndarray, (n_cells,)
        In (0, 1).
    pareto_k : ndarray, (n_cells,)
        PSIS diagnostics (above 0.7 the importance weights for that cell are unreliable).
    """
    ll = np.asarray(log_lik, float).T
    n_cells, n_draws = ll.shape
    # A cell whose likelihood is the same in every draw has uniform LOO weights (PSIS cannot fit
    # a tail to constant ratios); the others get PSIS weights, the draws treated as one chain of
    # independent draws (r_eff = 1: thinned emcee output).
    log_w = np.full((n_cells, n_draws), -np.log(n_draws))
    k = np.full(n_cells, -np.inf)
    varies = np.ptp(ll, axis=-1) > 0
    if varies.any():
        log_w[varies], k[varies] = array_stats.psislw(ll[varies], r_eff=1.0, axis=-1)
    y_rep = np.asarray(y_rep, float).T[:, None, :]
    pit = array_stats.loo_pit(y_rep, np.asarray(y, float), log_w[:, None, :], pareto_pit=True)
    return np.asarray(pit, float), k


def uniformity_pvalue(pit):
    """p-value of ArviZ's POT-C test that ``pit`` values are uniform on (0, 1) (small: not uniform)."""
    return float(array_stats.uniformity_test(np.asarray(pit, float), method="pot_c")[0])


# --- p-values and flags ---------------------------------------------------------------------



def order_drift(z, order, group):
    r"""Sum over the groups of the squared studentized slope of ``z`` on the measurement
    order, per draw: :math:`T = \sum_g t_g^2` (:func:`residual_trend` within each group with
    at least 3 cells; a drift moves the intact cells' residuals, the bulged cells' less, since a
    drifting calibration also moves their bulge pressures).

    Parameters
    ----------
    z : ndarray (n_draws, n_cells)
    order : ndarray (n_cells,)
        :func:`turgorbayes.cells.order.measurement_order`.
    group : ndarray of str (n_cells,)

    Returns
    -------
    ndarray (n_draws,) [-]
    """
    def squared_t(zg, m):
        if np.sum(m) >= 3 and np.ptp(order[m]) > 0:
            return residual_trend(zg, order[m]) ** 2
        return None

    return _summed_over_groups(z, group, squared_t)


def session_offset(z, session, group):
    r"""Sum over the groups of the one-way analysis-of-variance statistic of ``z`` between
    measurement sessions, per draw: :math:`T = \sum_g (K_g - 1) F_g`, with

    .. math::

        F_g = \frac{\sum_s n_s (\bar z_s - \bar z)^2 / (K_g - 1)}
                   {\sum_s \sum_{i \in s} (z_i - \bar z_s)^2 / (n_g - K_g)}

    over the :math:`K_g` sessions holding cells of group :math:`g` (:math:`n_g` cells; a group
    with fewer than two sessions, or no more cells than sessions, adds nothing). Readings that
    share something per session (a cantilever's calibration, a slide, a culture) move together
    within it; each :math:`(K_g - 1) F_g` is about :math:`\chi^2_{K_g - 1}` without such a
    shared part. Studentized by the within-session scatter, so that misreported errors (the
    ``scatter`` check's business) do not make it fire.

    Parameters
    ----------
    z : ndarray (n_draws, n_cells)
    session : ndarray (n_cells,)
        Each cell's session label.
    group : ndarray of str (n_cells,)

    Returns
    -------
    ndarray (n_draws,) [-]
    """
    return _summed_over_groups(z, group, lambda zg, m: _between_sessions(zg, session[m]))


def _between_sessions(z, session):
    """:math:`(K - 1) F` of :func:`session_offset` for one group's residuals ``z``
    (n_draws, n), or None with fewer than two sessions or no more cells than sessions."""
    labels = np.unique(session)
    n, k = z.shape[1], labels.size
    if k < 2 or n <= k:
        return None
    between, within = np.zeros(z.shape[0]), np.zeros(z.shape[0])
    mean = z.mean(axis=-1)
    for lab in labels:
        zs = z[:, session == lab]
        ms = zs.mean(axis=-1)
        between += zs.shape[1] * (ms - mean) ** 2
        within += ((zs - ms[:, None]) ** 2).sum(axis=-1)
    return between / (within / (n - k))


def _summed_over_groups(z, group, per_group):
    """Per draw, the sum over the groups of ``per_group(z[:, m], m)`` (``m`` the group's
    mask); a group for which it returns None adds nothing."""
    total = np.zeros(z.shape[0])
    for g in np.unique(group):
        m = group == g
        value = per_group(z[:, m], m)
        if value is not None:
            total += value
    return total
