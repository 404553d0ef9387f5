r"""Non-contact baseline of an approach curve: a first contact guess and the tilted line.

The first guess is the best two-piece fit ``F = b_0 + b_1 z + c\,\max(z - z_c, 0)`` over
every sample ``z_c`` (one vectorized least-squares solve per candidate, from suffix sums).
"""

from dataclasses import dataclass

import numpy as np

from turgorbayes.curves.qc import CurveRejected

__all__ = ["Baseline", "fit_baseline", "hinge_contact"]


@dataclass(frozen=True)
class Baseline:
    """A straight baseline fitted to the non-contact part of an approach.

    Attributes
    ----------
    offset, slope : float [N], [N/m]
        ``F_baseline(z) = offset + slope z``.
    noise_sd : float [N]
        Residual standard deviation of the baseline points.
    n_points : int
        Points used (those with ``z <= z_end``).
    z_end : float [m]
        Last piezo travel of the baseline.
    hinge : float [m]
        The two-piece fit's contact guess.
    """

    offset: float
    slope: float
    noise_sd: float
    n_points: int
    z_end: float
    hinge: float

    def __call__(self, z):
        return self.offset + self.slope * np.asarray(z, float)


def hinge_contact(z, force, min_points=10):
    r"""Contact guess: the ``z_c`` [m] minimizing the squared residuals of
    :math:`F = b_0 + b_1 z + c\max(z - z_c, 0)`, over the samples ``z_c = z_j``.

    Parameters
    ----------
    z : ndarray [m]
        Increasing piezo travel.
    force : ndarray [N]
    min_points : int
        Candidates leave at least this many points on each side.

    Returns
    -------
    index : int
        ``j`` of the best ``z_c``.
    slope : float [N/m]
        ``c``, the contact slope of the best fit.
    """
    n = z.size
    x = (z - z.mean()) / np.ptp(z)  # conditioning: x is O(1)
    y = (force - force.mean()) / (np.std(force) or 1.0)
    suffix = [np.cumsum(v[::-1])[::-1] for v in (np.ones(n), x, x * x, y, x * y)]
    S0, Sx, Sxx, Sy, Sxy = suffix
    j = np.arange(min_points, n - min_points)
    c = x[j]
    su, suu = Sx[j] - c * S0[j], Sxx[j] - 2 * c * Sx[j] + c * c * S0[j]
    sux, suy = Sxx[j] - c * Sx[j], Sxy[j] - c * Sy[j]
    A = np.empty((j.size, 3, 3))
    A[:, 0, 0], A[:, 0, 1], A[:, 1, 1] = n, Sx[0], Sxx[0]
    A[:, 0, 2] = A[:, 2, 0] = su
    A[:, 1, 2] = A[:, 2, 1] = sux
    A[:, 1, 0] = Sx[0]
    A[:, 2, 2] = suu
    b = np.stack([np.full(j.size, Sy[0]), np.full(j.size, Sxy[0]), suy], axis=1)
    beta = np.linalg.solve(A, b[..., None])[..., 0]
    sse = np.sum(y * y) - np.sum(beta * b, axis=1)
    best = int(np.argmin(sse))
    slope = beta[best, 2] * (np.std(force) or 1.0) / np.ptp(z)
    return int(j[best]), float(slope)


def fit_baseline(z, force, min_points=50, margin=0.25, max_noise_ratio=0.2, z_contact=None):
    """Fit the tilted baseline to the points well before the contact guess.

    Without ``z_contact`` the baseline is the first half of the travel before the two-piece
    contact guess (:func:`hinge_contact`); with it, it ends ``margin`` x (contact length) or
    10 points, whichever is longer, before ``z_contact``. Either way a soft onset does not
    leak into it.

    Parameters
    ----------
    z : ndarray [m]
        Increasing piezo travel.
    force : ndarray [N]
    min_points : int
        Fewest baseline points accepted.
    margin : float [-]
        Gap before the contact guess, as a fraction of the travel past it.
    max_noise_ratio : float [-]
        Largest accepted ratio of the baseline scatter to the force rise past the contact.
    z_contact : float [m], optional
        A better contact estimate to end the baseline before (instead of the two-piece guess).

    Returns
    -------
    Baseline

    Raises
    ------
    CurveRejected
        ``no_contact``, ``baseline_too_short`` or ``baseline_too_noisy``.
    """
    if z_contact is None:
        j, slope = hinge_contact(z, force)
        if slope <= 0:
            raise CurveRejected("no_contact", "the force does not rise past any contact guess")
        z_c = float(z[j])
        # a convex onset puts the two-piece guess late: keep only the first half before it
        z_end = z[0] + 0.5 * (z_c - z[0])
    else:
        z_c = float(z_contact)
        z_end = z_c - max(margin * (z[-1] - z_c), 10 * np.median(np.diff(z)))
    use = z <= z_end
    if use.sum() < min_points:
        raise CurveRejected("baseline_too_short", f"{use.sum()} baseline points before the "
                            f"contact guess, need >= {min_points}")
    coef = np.polynomial.polynomial.polyfit(z[use], force[use], 1)
    resid = force[use] - np.polynomial.polynomial.polyval(z[use], coef)
    noise = float(np.std(resid, ddof=2))
    rise = float(np.median(force[-5:]) - np.polynomial.polynomial.polyval(z[-1], coef))
    if rise < 3 * noise:
        raise CurveRejected("no_contact", f"force rises {rise * 1e12:.3g} pN above the baseline, "
                            f"less than 3 x its scatter {noise * 1e12:.3g} pN")
    if noise > max_noise_ratio * rise:
        raise CurveRejected("baseline_too_noisy", f"baseline scatter {noise * 1e12:.3g} pN is "
                            f"{noise / rise:.2g} of the force rise, limit {max_noise_ratio:g}")
    return Baseline(offset=float(coef[0]), slope=float(coef[1]), noise_sd=noise,
                    n_points=int(use.sum()), z_end=float(z_end), hinge=float(z_c))
