"""Posterior bands of the model curves R_c(P), k_c(P), their JSON files, and binned data means."""

import json
from dataclasses import dataclass

import numpy as np

from turgorbayes.physics import forward
from turgorbayes.workflows.fit_data import bulged_pressures, flat_draws, posterior_tree, surrogate_of

__all__ = [
    "QUANTILES",
    "CurveBands",
    "baseline_bands",
    "binned_means",
    "curve_bands",
    "extended_bands",
    "pressure_grid",
    "read_bands",
    "write_bands",
    "write_extended_bands",
]

#: Quantiles of a band: 95 % (2.5-97.5), 68 % (16-84) and the median.
QUANTILES = (0.025, 0.16, 0.5, 0.84, 0.975)


@dataclass
class CurveBands:
    """Quantiles of the model curves ``R_c(P)``, ``k_c(P)`` over posterior draws.

    Attributes
    ----------
    P : ndarray (n,) [Pa]
    R : ndarray (5, n) [m]
        Quantiles :data:`QUANTILES` of ``R_c`` at each ``P``.
    k : ndarray (5, n) [N/m]
        The same for ``k_c``.
    label : str
    """

    P: np.ndarray
    R: np.ndarray
    k: np.ndarray
    label: str


def curve_bands(P, R_curves, k_curves, label):
    """Pointwise quantiles :data:`QUANTILES` of curves drawn from a posterior.

    Parameters
    ----------
    P : array_like (n,) [Pa]
    R_curves : array_like (draws, n) [m]
    k_curves : array_like (draws, n) [N/m]
    label : str

    Returns
    -------
    CurveBands
        NaN curves (pressures a draw's wall cannot reach) are left out of the quantiles.
    """
    q = np.asarray(QUANTILES)
    return CurveBands(np.asarray(P, float), np.nanquantile(R_curves, q, axis=0),
                      np.nanquantile(k_curves, q, axis=0), label)


def pressure_grid(fit, n=120):
    """Log-spaced pressures [Pa] spanning the bulge pressures and ``P_phys`` with margins (and,
    for an osmotic series, every medium level's turgor)."""
    dt = posterior_tree(fit)
    P = bulged_pressures(dt)
    if "osmotic" in dt.attrs:  # intact cells at their levels' turgors (P_cell)
        b = np.asarray(dt["constant_data"]["is_bulged"].values, bool)
        cells = np.asarray(dt["posterior"]["P_cell"].values).reshape(-1, b.size)
        P = np.concatenate([np.asarray(P, float).ravel(), cells[:, ~b].mean(axis=0)])
    return _grid(P, flat_draws(dt, "P_phys"), n)


def _grid(P_bulge, P_phys, n):
    hi = max(np.nanmax(P_bulge), np.quantile(P_phys, 0.99))
    return np.geomspace(np.nanmin(P_bulge) / 1.5, hi * 1.5, n)


def _draw_indices(n_total, n, seed):
    rng = np.random.default_rng(seed)
    return rng.choice(n_total, size=min(n, n_total), replace=False)


def baseline_bands(fit, P=None, surrogate=None, n_curves=300, seed=0, label=None):
    """Bands of the baseline (or ``paper_wls``) curves from a fit's ``gamma, E0t, R0`` draws.

    Parameters
    ----------
    fit : FitResult or DataTree
    P : array_like [Pa], optional
        Default :func:`pressure_grid`.
    surrogate : turgorbayes.surrogate.Surrogate, optional
        Default the fit's own (FitResult) or the shipped table, checked by sha256.
    n_curves : int
        Posterior draws used (drawn without replacement with ``seed``).
    label : str, optional

    Returns
    -------
    CurveBands
    """
    dt = posterior_tree(fit)
    table = surrogate_of(fit, surrogate)
    P = pressure_grid(dt) if P is None else np.asarray(P, float)
    draws = {n: flat_draws(dt, n) for n in ("gamma", "E0t", "R0")}
    idx = _draw_indices(draws["gamma"].size, n_curves, seed)
    R, k = forward.cell_radius_and_stiffness(P[None, :], *(draws[n][idx, None] for n in draws),
                                             surrogate=table)
    return curve_bands(P, R, k, label or str(dt.attrs.get("model", "baseline")))


def extended_bands(posterior, P, n_curves=300, seed=0, label=None):
    """Bands of an extended model's curves (median intact-cell wall) from criticism draws.

    Parameters
    ----------
    posterior : turgorbayes.criticism.Posterior
        Weighted draws of one model (``CriticismResult.posteriors[name]``).
    P : array_like [Pa]
    n_curves : int
        Draws resampled by weight with ``seed``.
    label : str, optional
        Default the model's name and "(intact-cell wall)".

    Returns
    -------
    CurveBands
    """
    P = np.asarray(P, float)
    idx = posterior.resample(n_curves, np.random.default_rng(seed))
    R, k = posterior.model.curves(posterior.u[idx], P)
    return curve_bands(P, R, k, label or f"{posterior.model.name} (intact-cell wall)")


def write_extended_bands(criticism_result, path, n_curves=300, seed=0):
    """Write the adopted extension's bands (``extended_bands.json``) of a criticism, if any.

    The pressure grid spans the cells' bulge pressures and the extension's ``P_phys`` like
    :func:`pressure_grid`; ``turgorbayes report`` draws these bands in Fig. 3.

    Parameters
    ----------
    criticism_result : turgorbayes.workflows.criticize.CriticismResult
    path : path-like
    n_curves, seed : int

    Returns
    -------
    CurveBands or None
        None (and no file) when no extension was adopted.
    """
    if not criticism_result.selected:
        return None
    post = criticism_result.posteriors[criticism_result.selected]
    P_phys = post.model.to_physical(post.u)["P_phys"]
    P = _grid(np.exp(post.model.obs.log_P_bulge), P_phys, 120)
    bands = extended_bands(post, P, n_curves, seed)
    write_bands(bands, path)
    return bands


def write_bands(bands, path):
    """Write :class:`CurveBands` as JSON (SI), for :func:`read_bands` and ``turgorbayes report``."""
    d = {"label": bands.label, "quantiles": list(QUANTILES), "P_Pa": bands.P.tolist(),
         "R_c_m": np.asarray(bands.R).tolist(), "k_c_N_per_m": np.asarray(bands.k).tolist()}
    with open(path, "w", encoding="utf-8") as fh:
        json.dump(d, fh)


def read_bands(path):
    """Read :class:`CurveBands` written by :func:`write_bands`."""
    with open(path, encoding="utf-8") as fh:
        d = json.load(fh)
    if tuple(d["quantiles"]) != QUANTILES:
        raise ValueError(f"{path}: bands at quantiles {d['quantiles']}, expected {QUANTILES}")
    return CurveBands(np.asarray(d["P_Pa"]), np.asarray(d["R_c_m"], float),
                      np.asarray(d["k_c_N_per_m"], float), d["label"])


def binned_means(P, y, y_err, log_P_err=None, n_bins=10):
    r"""Error-weighted means of ``y`` in ``n_bins`` log-spaced pressure bins (paper Fig. 3).

    In bin :math:`b`, with weights :math:`w_i = 1/\sigma_{y,i}^2` and
    :math:`v_i = 1/\sigma_{\ln P,i}^2`:

    .. math::

        \bar y_b = \frac{\sum w_i y_i}{\sum w_i},\quad
        \sigma_{\bar y_b} = \Big(\sum w_i\Big)^{-1/2},\quad
        \bar P_b = \exp\frac{\sum v_i \ln P_i}{\sum v_i}.

    Parameters
    ----------
    P : array_like [Pa]
        Pressure of each cell.
    y : array_like
        Observable (any unit).
    y_err : array_like
        Its standard errors (same unit, > 0).
    log_P_err : array_like, optional
        Standard errors of ``ln P`` (equal weights if None).
    n_bins : int
        Bins between the smallest and largest ``P`` (both included).

    Returns
    -------
    ndarray (n_filled, 4)
        Rows ``(P_b [Pa], y_b, se_b, n_b)`` of the non-empty bins, in order of pressure.
    """
    P, y, y_err = (np.asarray(a, float) for a in (P, y, y_err))
    v = np.ones_like(P) if log_P_err is None else 1.0 / np.asarray(log_P_err, float) ** 2
    edges = np.geomspace(P.min(), P.max(), n_bins + 1)
    which = np.clip(np.searchsorted(edges, P, side="right") - 1, 0, n_bins - 1)
    rows = []
    for b in range(n_bins):
        m = which == b
        if m.any():
            w = 1.0 / y_err[m] ** 2
            rows.append((np.exp(np.average(np.log(P[m]), weights=v[m])),
                         np.average(y[m], weights=w), w.sum() ** -0.5, m.sum()))
    return np.array(rows)
