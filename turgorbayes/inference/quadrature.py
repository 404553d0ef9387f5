"""Quadrature rules of the cells' likelihood: Gauss-Hermite for expectations under a normal,
composite Gauss-Legendre on an interval, and the weighted mean of the nodes (docs/statistics.md,
"Quadrature")."""

import functools

import numpy as np

from turgorbayes.inference.population import logsumexp

__all__ = ["composite_legendre", "hermite_rule", "weighted_mean_pressure"]


def hermite_rule(n):
    """Gauss-Hermite rule for expectations under a standard normal.

    Returns
    -------
    z : ndarray (n,)
        Nodes ``sqrt(2) x_j``.
    log_w : ndarray (n,)
        ``ln(w_j / sqrt(pi))`` (the weights sum to 1).
    """
    if int(n) != n or n < 1:
        raise ValueError(f"number of quadrature nodes must be a positive integer, got {n!r}")
    return _hermite_rule(int(n))


@functools.lru_cache(maxsize=32)
def _hermite_rule(n):
    """:func:`hermite_rule`, computed once per ``n`` (read-only arrays: the likelihood asks for
    the same few rules at every evaluation)."""
    x, w = np.polynomial.hermite.hermgauss(n)
    return _read_only(np.sqrt(2.0) * x), _read_only(np.log(w) - 0.5 * np.log(np.pi))


def _read_only(a):
    a.flags.writeable = False
    return a


@functools.lru_cache(maxsize=512)
def composite_legendre(panels, order):
    """Composite Gauss-Legendre rule on [0, 1]: ``panels`` equal panels of ``order`` points;
    nodes and weights ``(panels * order,)``, the weights summing to 1 (computed once per
    ``(panels, order)``; read-only arrays)."""
    t, w = np.polynomial.legendre.leggauss(order)
    t = ((np.arange(panels)[:, None] + 0.5 * (t + 1)) / panels).ravel()
    return _read_only(t), _read_only(np.tile(w, panels) / (2 * panels))


def weighted_mean_pressure(log_P, f):
    """``sum exp(f) P / sum exp(f)`` over the last axis (nodes)."""
    return np.exp(logsumexp(f + log_P, axis=-1) - logsumexp(f, axis=-1))
