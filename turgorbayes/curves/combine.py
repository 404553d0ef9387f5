r"""Several curves of one cell and target -> one stiffness with an honest error.

Inverse-variance weighted mean; its error is the larger of the fits' own (internal) error
and the scatter between curves (external, Birge ratio above 1):

.. math::

    \bar k = \frac{\sum w_i k_i}{\sum w_i},\; w_i = \sigma_i^{-2},\qquad
    \sigma^2 = \frac{\max\bigl(1, \chi^2/(n-1)\bigr)}{\sum w_i},\;
    \chi^2 = \sum w_i (k_i - \bar k)^2 .
"""

import numpy as np

__all__ = ["combine_stiffness"]


def combine_stiffness(k, k_err, depth=None):
    """Combine per-curve secant stiffnesses of one cell and target.

    Parameters
    ----------
    k, k_err : array_like [N/m]
        Stiffnesses of the accepted curves and their errors (> 0).
    depth : array_like [m], optional
        Depths they were read at; the same weights average them (bulges: ``h_b``).

    Returns
    -------
    k : float [N/m]
    k_err : float [N/m]
    depth : float [m] or None
    """
    k = np.asarray(k, float)
    w = 1.0 / np.asarray(k_err, float) ** 2
    mean = float(np.sum(w * k) / np.sum(w))
    birge2 = np.sum(w * (k - mean) ** 2) / (k.size - 1) if k.size > 1 else 1.0
    err = float(np.sqrt(max(1.0, birge2) / np.sum(w)))
    d = None if depth is None else float(np.sum(w * np.asarray(depth, float)) / np.sum(w))
    return mean, err, d
