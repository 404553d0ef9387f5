r"""Contact point of a baseline-corrected approach, by two methods (docs/curves.md).

``powerlaw`` (default): least-squares fit of
:math:`F = c + A\,\max(\delta - \delta_0, 0)^n` over the baseline's end and the contact part,
in tip-sample separation :math:`\delta = z - F/k`; its covariance gives the contact error.
``threshold``: the first point of the final run of forces above 3 baseline sd (biased late).
"""

from dataclasses import dataclass

import numpy as np
from scipy import optimize

from turgorbayes.curves.qc import CurveRejected

__all__ = ["METHODS", "Contact", "contact_point"]


@dataclass(frozen=True)
class Contact:
    """A contact point in piezo travel, and the force offset left at contact.

    Attributes
    ----------
    z0 : float [m]
        Piezo travel at contact. Indentation is ``h = (z - z0) - (F - offset)/k``.
    z0_err : float [m]
        Its standard error.
    offset : float [N]
        Baseline-corrected force at contact (``c``; 0 for ``threshold``).
    exponent : float [-]
        Power-law exponent ``n`` (NaN for ``threshold``).
    method : str
    """

    z0: float
    z0_err: float
    offset: float
    exponent: float
    method: str


def _power_model(p, u):
    c, a, d0, n = p
    t = np.maximum(u - d0, 0.0)
    return c + a * t**n


def _power_jac(p, u):
    c, a, d0, n = p
    t = np.maximum(u - d0, 0.0)
    tn = t**n
    logt = np.log(np.where(t > 0, t, 1.0))
    tn1 = np.where(t > 0, t ** np.maximum(n - 1, 0.0), 0.0)
    return np.column_stack([np.ones_like(u), tn, -a * n * tn1, a * tn * logt])


def _fit(u, y, p0, w):
    lower, upper = [-np.inf, 0.0, -1.0, 0.8], [np.inf, np.inf, 0.9, 4.0]
    try:
        fit = optimize.least_squares(lambda p: w * (_power_model(p, u) - y), p0,
                                     jac=lambda p: w[:, None] * _power_jac(p, u),
                                     bounds=(lower, upper), x_scale="jac")
    except (ValueError, np.linalg.LinAlgError) as err:
        raise CurveRejected("fit_failed", f"power-law contact fit: {err}") from None
    if not fit.success or not np.all(np.isfinite(fit.x)):
        raise CurveRejected("fit_failed", f"power-law contact fit: {fit.message}")
    return fit


def _fit_window(delta, force, k, guess, past, noise_sd):
    """One weighted power-law fit over ``delta`` in [guess - pre, guess + past]; returns the
    fit, the scales and the misfit (weighted residual sd / baseline sd)."""
    pre = max(past, 20 * np.median(np.abs(np.diff(delta))))
    use = (delta >= guess - pre) & (delta <= guess + past)
    h_s, F_s = past, max(float(np.max(force[use])), noise_sd)
    u, y = (delta[use] - guess) / h_s, force[use] / F_s
    fit = _fit(u, y, np.array([0.0, max(y[-1], 1e-3), 0.0, 1.2]), np.ones_like(u))
    # Noise moves a point along the cantilever's line (F up, delta down by F/k): its residual
    # grows by 1 + F'/k past contact. Refit with those weights for honest errors.
    c, a, d0, n = fit.x
    t = np.maximum(u - d0, 0.0)
    slope = np.where(t > 0, a * n * np.where(t > 0, t, 1.0) ** (n - 1), 0.0) * (F_s / h_s)
    fit = _fit(u, y, fit.x, 1.0 / (1.0 + slope / k))
    dof = max(u.size - 4, 1)
    misfit = np.sqrt(2 * fit.cost / dof) * F_s / noise_sd
    n_in = int(np.count_nonzero(u > fit.x[2]))
    return fit, h_s, F_s, dof, misfit, n_in


def powerlaw_contact(z, force, k, guess, noise_sd, max_depth=None, max_misfit=1.5, min_points=30):
    """Contact by a power-law fit in separation ``delta = z - F/k`` (module docstring).

    Where the power law does not describe the whole window (weighted residual sd above
    ``max_misfit`` x the baseline sd, e.g. a deep vesicle indentation), the window past
    contact is halved, from the new contact estimate, until it does or until fewer than
    ``2 min_points`` points are left past contact.

    Parameters
    ----------
    z : ndarray [m]
        Piezo travel.
    force : ndarray [N]
        Baseline-corrected force.
    k : float [N/m]
        Cantilever spring constant.
    guess : float [m]
        First contact guess (piezo travel).
    noise_sd : float [N]
        Baseline scatter (scales the fit's variables).
    max_depth : float [m], optional
        Fit only up to this separation past ``guess``.
    max_misfit : float [-]
    min_points : int

    Returns
    -------
    Contact
    """
    delta = z - force / k
    past = (delta[-1] - guess) if max_depth is None else max_depth
    for _ in range(10):
        fit, h_s, F_s, dof, misfit, n_in = _fit_window(delta, force, k, guess, past, noise_sd)
        delta0 = guess + fit.x[2] * h_s
        if misfit <= max_misfit or n_in < 4 * min_points:
            break
        guess, past = delta0, 0.5 * (guess + past - delta0)
    c, _, d0, n = fit.x
    cov = np.linalg.pinv(fit.jac.T @ fit.jac) * (2 * fit.cost / dof)
    offset = c * F_s
    return Contact(z0=float(delta0 + offset / k), z0_err=float(h_s * np.sqrt(cov[2, 2])),
                   offset=float(offset), exponent=float(n), method="powerlaw")


def threshold_contact(z, force, k, guess, noise_sd, max_depth=None):
    """Contact as the first point of the last run of forces above ``3 noise_sd``.

    Same parameters as :func:`powerlaw_contact` (``guess`` and ``max_depth`` unused). The
    reported error is the depth over which the force climbs to the threshold.
    """
    above = force > 3 * noise_sd
    below = np.flatnonzero(~above)
    i0 = below[-1] + 1 if below.size else 0
    if i0 >= z.size - 1:
        raise CurveRejected("no_contact", "no force above 3 baseline sd at the end of the curve")
    delta = z - force / k
    mean_slope = force[-1] / max(delta[-1] - delta[i0], np.finfo(float).tiny)
    return Contact(z0=float(z[i0]), z0_err=float(3 * noise_sd / mean_slope), offset=0.0,
                   exponent=float("nan"), method="threshold")


#: name -> function(z, force, k, guess, noise_sd, max_depth) -> Contact
METHODS = {"powerlaw": powerlaw_contact, "threshold": threshold_contact}


def contact_point(method, z, force, k, guess, noise_sd, max_depth=None):
    """Dispatch to a contact method of :data:`METHODS` (see there for the arguments)."""
    if method not in METHODS:
        raise ValueError(f"contact method must be one of {sorted(METHODS)}, got {method!r}")
    return METHODS[method](z, force, k, guess, noise_sd, max_depth)
