"""Log-uniform populations of the latent ``ln P`` with smooth edges: given edges
(:func:`ramped_box`) or edges fitted to the bulge estimates (:func:`fitted_box`)."""

import numpy as np
from scipy import optimize, special

from turgorbayes.inference.population_densities import GridPopulation

__all__ = ["BOX_STEP", "RAMP", "fitted_box", "ramped_box"]

#: Width [ln P] of the logistic ramps of :func:`ramped_box`'s edges.
RAMP = 0.03
#: Grid step [ln P] of :func:`ramped_box`.
BOX_STEP = 0.02


def ramped_box(cover, lo, hi, edge=RAMP):
    """Log-uniform population on ``[lo, hi]`` [ln Pa] with logistic edges of width ``edge``.

    A known population for the latent quadrature (smooth, so the Gauss-Hermite rule sees no
    kinks), on a :data:`BOX_STEP` grid covering ``cover``'s support and ``[lo - 1, hi + 1]``.

    Parameters
    ----------
    cover : population
        Any population with a ``support`` (e.g. the plug-in it replaces).
    lo, hi : float
        Edges [ln Pa].
    edge : float
        Ramp width [ln P].

    Returns
    -------
    GridPopulation
    """
    grid = np.arange(min(cover.support[0], lo - 1), max(cover.support[1], hi + 1), BOX_STEP)
    ln_g = special.log_expit((grid - lo) / edge) + special.log_expit((hi - grid) / edge)
    return GridPopulation(grid, ln_g - special.logsumexp(ln_g))


def fitted_box(log_P_hat, sd, cover):
    """Log-uniform population whose edges maximize the marginal likelihood of the estimates.

    ``ln P_hat_i ~ N(ln P_i, sd_i)`` with ``ln P_i`` uniform on ``[lo, hi]``; Nelder-Mead from
    the smallest and largest estimate.

    Returns
    -------
    (GridPopulation, (lo, hi))
        :func:`ramped_box` at the fitted edges, and the edges [ln Pa].
    """
    x, s = np.asarray(log_P_hat, float), np.asarray(sd, float)

    def nll(e):
        lo, hi = e
        if hi <= lo + 0.01:
            return np.inf
        p = special.ndtr((hi - x) / s) - special.ndtr((lo - x) / s)
        return -np.sum(np.log(np.maximum(p, 1e-300))) + x.size * np.log(hi - lo)

    lo, hi = optimize.minimize(nll, [np.min(x), np.max(x)], method="Nelder-Mead",
                               options={"xatol": 1e-6, "fatol": 1e-9}).x
    return ramped_box(cover, lo, hi), (lo, hi)
