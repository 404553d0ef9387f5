r"""Several curves of one cell and target -> one stiffness with an honest error.

Plain (equal-weight) mean of the curves; its error is the larger of the fits' own (internal)
error and the scatter between curves (external, Birge ratio above 1):

.. math::

    \bar k = \frac{1}{n}\sum k_i,\qquad
    \sigma^2 = \max\bigl(1, \chi^2/(n-1)\bigr)\,\frac{\sum \sigma_i^2}{n^2},\;
    \chi^2 = \sum \frac{(k_i - \bar k)^2}{\sigma_i^2} .

Why not inverse-variance weights: a curve's error has a part proportional to its own reading
(the contact point's error moves the secant in proportion to it), so weights ``1/sigma_i^2``
favour the curves that read low. On soft cells (force at ``R_c/20`` a few times the noise),
where the errors are large, that moved a cell's stiffness by tens of percent and could give a
combined error larger than the value (docs/curves.md, Combining curves). The curves of one
cell are taken with the same cantilever and settings, so their true errors are alike and equal
weights lose little. ``weights="inverse_variance"`` keeps the weighted mean for quantities
whose errors do not follow the reading (glass slopes).
"""

import numpy as np

__all__ = ["combine_stiffness"]

WEIGHTS = ("equal", "inverse_variance")


def combine_stiffness(k, k_err, depth=None, weights="equal"):
    """Combine per-curve secant stiffnesses of one cell and target.

    Parameters
    ----------
    k, k_err : array_like [N/m]
        Stiffnesses of the accepted curves and their errors (> 0).
    depth : array_like [m], optional
        Depths they were read at; the same weights average them (bulges: ``h_b``).
    weights : str
        ``"equal"`` (default) or ``"inverse_variance"`` (``1/k_err^2``).

    Returns
    -------
    k : float [N/m]
    k_err : float [N/m]
    depth : float [m] or None
    """
    if weights not in WEIGHTS:
        raise ValueError(f"weights must be one of {', '.join(WEIGHTS)}, got {weights!r}")
    k, var = np.asarray(k, float), np.asarray(k_err, float) ** 2
    w = 1.0 / var if weights == "inverse_variance" else np.ones_like(k)
    w = w / np.sum(w)
    mean = float(np.sum(w * k))
    birge2 = np.sum((k - mean) ** 2 / var) / (k.size - 1) if k.size > 1 else 1.0
    err = float(np.sqrt(max(1.0, birge2) * np.sum(w ** 2 * var)))
    d = None if depth is None else float(np.sum(w * np.asarray(depth, float)))
    return mean, err, d
