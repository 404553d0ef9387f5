r"""Secant stiffness ``F(h)/h`` of a reduced curve, at a given depth or at its deepest point.

Force is fitted locally against the piezo travel ``z`` (exact, so the fit is not biased by
noise on both axes) and converted to indentation :math:`h = (z - z_0) - F/k`.
"""

from dataclasses import dataclass

import numpy as np

from turgorbayes.curves.qc import CurveRejected

__all__ = ["Secant", "deep_secant", "indentation", "secant_at_depth", "secant_at_end"]


@dataclass(frozen=True)
class Secant:
    """A secant stiffness and where it was read.

    Attributes
    ----------
    k, k_err : float [N/m]
        ``F(h)/h`` and its standard error (local-fit scatter and contact error).
    depth, depth_err : float [m]
        Indentation ``h`` at which it was read, and its error (0 for a prescribed depth).
    window : (float, float) [m]
        Indentation range of the local fit.
    dk_dz0 : float [N/m^2]
        Change of ``k`` per unit of contact travel ``z_0`` (a later contact, a larger ``k``):
        the contact error's share of ``k_err`` is ``|dk_dz0| z0_err`` (docs/curves.md,
        Correlated readings).
    """

    k: float
    k_err: float
    depth: float
    depth_err: float
    window: tuple
    dk_dz0: float = float("nan")


def indentation(z, force, k, z0):
    """Tip-sample indentation ``h = (z - z0) - F/k`` [m] (piezo travel past contact minus the
    cantilever's deflection)."""
    return (z - z0) - force / k


def deep_secant(z, force, k, z0, share=0.1):
    """Secant ``F/h`` over the deepest ``share`` of the indentation [N/m].

    The yardstick of the ``stiffness_undetermined`` check (``reduce._check_precision``): on a
    soft cell the deep part of the curve has several times the force at the reading depth, so
    this secant's noise is small and nearly independent of the reading's.
    """
    h = indentation(z, force, k, z0)
    deep = h >= (1 - share) * h.max()
    return float(np.mean(force[deep]) / np.mean(h[deep]))


def _local_fit(z, force, use, degree, min_points):
    """Polynomial of ``degree`` in ``z`` over the points ``use`` (the stiffness window, which
    the curve reaches past: the callers check depth first), its covariance and centre.

    Raises ``coarse_sampling`` when the window holds fewer than ``min_points`` points."""
    if use.sum() < min_points:
        step = float(np.median(np.abs(np.diff(z)))) if z.size > 1 else float("nan")
        raise CurveRejected("coarse_sampling", f"{use.sum()} points in the stiffness window, "
                            f"need >= {min_points} (piezo step {step * 1e9:.2g} nm)")
    zm = float(np.mean(z[use]))
    X = np.vander(z[use] - zm, degree + 1, increasing=True)
    beta, *_ = np.linalg.lstsq(X, force[use], rcond=None)
    resid = force[use] - X @ beta
    s2 = resid @ resid / max(use.sum() - degree - 1, 1)
    return beta, np.linalg.inv(X.T @ X) * s2, zm


def _depth_solve(beta, zm, z0, k, h_target, z_start):
    """Piezo travel where ``(z - z0) - F(z)/k = h_target``, by Newton steps."""
    poly = np.polynomial.Polynomial(beta)
    z = z_start
    for _ in range(20):
        g = (z - z0) - poly(z - zm) / k - h_target
        step = g / (1.0 - poly.deriv()(z - zm) / k)
        z -= step
        if abs(step) < 1e-15:
            break
    return z


def _gradient(fun, x, steps):
    """Central-difference gradient of scalar ``fun`` at ``x``."""
    grad = np.empty(x.size)
    for i, s in enumerate(steps):
        e = np.zeros(x.size)
        e[i] = s
        grad[i] = (fun(x + e) - fun(x - e)) / (2 * s)
    return grad


def _propagate(fun, beta, cov, z0, z0_err):
    """Value of ``fun(beta, z0)``, its sd from the local-fit covariance and the contact
    error (independent; summed in quadrature), and its derivative in ``z0``."""
    x = np.append(beta, z0)
    full = np.zeros((x.size, x.size))
    full[:-1, :-1] = cov
    full[-1, -1] = z0_err**2
    sd = np.sqrt(np.diag(full))
    steps = np.where(sd > 0, sd, 1e-6 * np.abs(x) + 1e-20)  # near-linear: a 1-sd step is fine
    g = _gradient(lambda v: fun(v[:-1], v[-1]), x, steps)
    return fun(beta, z0), float(np.sqrt(g @ full @ g)), float(g[-1])


def secant_at_depth(z, force, k, contact, h_target, window=0.3, min_points=10):
    """Secant ``F(h)/h`` at indentation ``h_target`` (cells: ``R_c/20``).

    A quadratic in ``z`` is fitted to the points with ``h`` within ``h_target (1 +- window)``.

    Parameters
    ----------
    z : ndarray [m]
        Piezo travel.
    force : ndarray [N]
        Force with baseline and contact offset removed.
    k : float [N/m]
        Cantilever spring constant.
    contact : turgorbayes.curves.contact_point.Contact
    h_target : float [m]
    window : float [-]
    min_points : int

    Returns
    -------
    Secant

    Raises
    ------
    CurveRejected
        ``too_shallow`` when the curve never reaches ``h_target``.
    """
    h = indentation(z, force, k, contact.z0)
    if h.max() < h_target:
        raise CurveRejected("too_shallow", f"deepest indentation {h.max() * 1e9:.3g} nm < "
                            f"{h_target * 1e9:.3g} nm")
    lo, hi = h_target * (1 - window), h_target * (1 + window)
    use = (h >= lo) & (h <= hi)
    beta, cov, zm = _local_fit(z, force, use, 2, min_points)
    z_start = float(z[use][np.argmin(np.abs(h[use] - h_target))])

    def stiffness(b, z0):
        zs = _depth_solve(b, zm, z0, k, h_target, z_start)
        return np.polynomial.Polynomial(b)(zs - zm) / h_target

    value, err, slope = _propagate(stiffness, beta, cov, contact.z0, contact.z0_err)
    return Secant(k=float(value), k_err=err, depth=float(h_target), depth_err=0.0,
                  window=(float(lo), float(min(hi, h.max()))), dk_dz0=slope)


def secant_at_end(z, force, k, contact, window=0.15, min_points=10):
    """Secant ``F(h_b)/h_b`` at the deepest point of the approach (bulges).

    A line in ``z`` is fitted to the points deeper than ``(1 - window)`` x the deepest
    indentation and evaluated at the last piezo travel: ``F_b = F(z_end)``,
    ``h_b = (z_end - z0) - F_b/k``.

    Parameters
    ----------
    z, force, k, contact, window, min_points
        As in :func:`secant_at_depth`.

    Returns
    -------
    Secant
        ``depth`` is ``h_b``, with its error.
    """
    h = indentation(z, force, k, contact.z0)
    h_end = float(np.max(h))
    if h_end <= 0:
        raise CurveRejected("contact_too_close_to_end", "no indentation past the contact point")
    use = h >= (1 - window) * h_end
    beta, cov, zm = _local_fit(z, force, use, 1, min_points)
    z_end = float(z[-1])

    def end_force(b):
        return b[0] + b[1] * (z_end - zm)

    def depth(b, z0):
        return (z_end - z0) - end_force(b) / k

    def stiffness(b, z0):
        return end_force(b) / depth(b, z0)

    value, err, slope = _propagate(stiffness, beta, cov, contact.z0, contact.z0_err)
    h_b, h_err, _ = _propagate(depth, beta, cov, contact.z0, contact.z0_err)
    return Secant(k=float(value), k_err=err, depth=float(h_b), depth_err=h_err,
                  window=(float((1 - window) * h_end), float(h_b)), dk_dz0=slope)
