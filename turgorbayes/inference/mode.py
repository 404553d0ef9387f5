"""Posterior mode and Laplace covariance in sampler coordinates (one implementation).

Used by :meth:`turgorbayes.inference.models.BaselineModel.start` (emcee's starting walkers) and
by the criticism's importance proposals (:mod:`turgorbayes.criticism.posterior`). A *model* is
any object with a vectorized ``log_posterior(u (W, ndim)) -> (W,)``. See ``docs/statistics.md``.
"""

import logging

import numpy as np
from scipy import optimize

__all__ = [
    "HESSIAN_REL_STEP",
    "clipped_inverse",
    "find_mode",
    "hessian",
    "hessian_cov",
    "inverse_hessian",
    "laplace",
]

logger = logging.getLogger(__name__)

#: Relative finite-difference step of the Hessian stencil (times ``max(|u|, 1)``).
HESSIAN_REL_STEP = 1e-3


def _default_steps(u, rel_step=HESSIAN_REL_STEP):
    return rel_step * np.maximum(np.abs(u), 1.0)


def find_mode(model, u0, maxiter=None, method="BFGS"):
    """Posterior mode in sampler coordinates.

    Parameters
    ----------
    model : object
        With a vectorized ``log_posterior(u (W, ndim)) -> (W,)``.
    u0 : ndarray (ndim,)
        Start.
    maxiter : int, optional
        Iterations at most (200 for BFGS, 4000 for Nelder-Mead).
    method : {"BFGS", "Nelder-Mead"}
        ``"BFGS"`` with vectorized central-difference gradients (gtol 1e-3; ``u0`` must have a
        finite log posterior, and ``u0`` is returned if the search ends worse than it started),
        used by the criticism; ``"Nelder-Mead"`` (xatol 1e-6, fatol 1e-8), used by
        :meth:`~turgorbayes.inference.models.BaselineModel.start`.

    Returns
    -------
    ndarray (ndim,)
    """
    u0 = np.asarray(u0, float)
    if method == "BFGS":
        return _mode_bfgs(model, u0, 200 if maxiter is None else maxiter)
    if method == "Nelder-Mead":
        return _mode_nelder_mead(model, u0, 4000 if maxiter is None else maxiter)
    raise ValueError(f"method must be 'BFGS' or 'Nelder-Mead', got {method!r}")


def _mode_nelder_mead(model, u0, maxiter):
    def neg(u):
        return -float(model.log_posterior(u[None])[0])

    res = optimize.minimize(neg, u0, method="Nelder-Mead",
                            options={"xatol": 1e-6, "fatol": 1e-8, "maxiter": maxiter})
    return res.x


def _mode_bfgs(model, u0, maxiter):
    d = u0.size
    if not np.isfinite(model.log_posterior(u0[None])[0]):
        raise ValueError("the starting point of the mode search has a non-finite log posterior")

    def fg(u):
        h = 1e-4 * np.maximum(np.abs(u), 1.0)
        pts = np.vstack([u, u + np.diag(h), u - np.diag(h)])
        lp = model.log_posterior(pts)
        if not np.isfinite(lp[0]):
            return np.inf, np.zeros(d)
        g = (lp[1:d + 1] - lp[d + 1:]) / (2 * h)
        return -lp[0], np.where(np.isfinite(g), -g, 0.0)

    res = optimize.minimize(fg, u0, jac=True, method="BFGS",
                            options={"maxiter": maxiter, "gtol": 1e-3})
    return res.x if np.isfinite(res.fun) and res.fun <= fg(u0)[0] else u0


def hessian(model, u, steps=None, strict=True):
    """Central finite-difference Hessian of ``-log_posterior`` at ``u`` (one vectorized call).

    Parameters
    ----------
    model : object
        With a vectorized ``log_posterior``.
    u : ndarray (ndim,)
    steps : ndarray (ndim,), optional
        Step per coordinate (default ``1e-3 max(|u|, 1)``).
    strict : bool
        Raise ``ValueError`` when a stencil point has a non-finite log posterior (the stencil
        leaves the model's domain); otherwise the non-finite entries are returned as they are.

    Returns
    -------
    ndarray (ndim, ndim)
    """
    u = np.asarray(u, float)
    k = u.size
    h = _default_steps(u) if steps is None else np.asarray(steps, float)
    pts, idx = [u], {}
    for i in range(k):
        for si in (1, -1):
            idx[(i, si)] = len(pts)
            pts.append(u + si * h[i] * np.eye(k)[i])
    for i in range(k):
        for j in range(i + 1, k):
            for si in (1, -1):
                for sj in (1, -1):
                    idx[(i, j, si, sj)] = len(pts)
                    pts.append(u + si * h[i] * np.eye(k)[i] + sj * h[j] * np.eye(k)[j])
    f = -model.log_posterior(np.array(pts))
    if strict and not np.all(np.isfinite(f)):
        raise ValueError("the Hessian stencil leaves the region where the model is defined")
    H = np.empty((k, k))
    for i in range(k):
        H[i, i] = (f[idx[(i, 1)]] - 2 * f[0] + f[idx[(i, -1)]]) / h[i] ** 2
        for j in range(i + 1, k):
            H[i, j] = H[j, i] = (f[idx[(i, j, 1, 1)]] - f[idx[(i, j, 1, -1)]]
                                 - f[idx[(i, j, -1, 1)]] + f[idx[(i, j, -1, -1)]]) / (4 * h[i] * h[j])
    return H


def inverse_hessian(H):
    """``H^-1`` if it is positive definite, else ``1/diag(H)`` (0.01 where ``diag(H) <= 0``)."""
    try:
        cov = np.linalg.inv(H)
        np.linalg.cholesky(cov)
        return cov
    except np.linalg.LinAlgError:
        diag = np.diag(H)
        return np.diag(np.where(diag > 0, 1 / np.where(diag > 0, diag, 1), 1e-2))


def clipped_inverse(H, floor=1e-3):
    """Inverse of ``H`` with its eigenvalues clipped at ``floor`` after scaling to unit diagonal.

    A direction in which the log posterior is flat or not concave gets a large but finite
    variance instead of a negative or infinite one; the clipping is done scale-free because
    the coordinates differ by orders of magnitude in scale.
    """
    D = np.sqrt(np.maximum(np.abs(np.diag(H)), 1e-12))
    vals, vecs = np.linalg.eigh(0.5 * (H + H.T) / np.outer(D, D))
    vals = np.maximum(vals, floor)
    return ((vecs / vals) @ vecs.T) / np.outer(D, D)


def hessian_cov(model, u, steps=None):
    """:func:`clipped_inverse` of the strict :func:`hessian` of ``-log_posterior`` at ``u``.

    Returns
    -------
    ndarray (ndim, ndim)
    """
    return clipped_inverse(hessian(model, u, steps))


def laplace(model, guess):
    """Mode (BFGS) and covariance (two Hessian passes, the second with steps of 0.2 sd).

    A stencil that leaves the model's domain is retried with steps ten times smaller. If no
    finite Hessian exists (the mode sits on the edge of the region where the model is defined,
    e.g. where the radius saturates), a diagonal covariance of 1 % of each coordinate (at
    least 0.01) is returned with a warning: the samplers then explore from there and their own
    diagnostics (Pareto k, R-hat, ESS) decide whether the posterior is usable.

    Parameters
    ----------
    model : object
        With ``log_posterior``, ``to_u(dict) -> (1, ndim)`` and ``name``.
    guess : dict
        Physical starting values (SI).

    Returns
    -------
    u_map : ndarray (ndim,)
    cov : ndarray (ndim, ndim)
    """
    u_map = find_mode(model, model.to_u(guess)[0])
    steps = _default_steps(u_map)
    cov = None
    for _ in range(4):
        try:
            cov = hessian_cov(model, u_map, steps)
            break
        except ValueError:
            steps = steps / 10
    if cov is None:
        logger.warning("%s: no finite Hessian at the posterior mode (the mode is on the edge of "
                       "the model's domain); using a diagonal proposal covariance", model.name)
        return u_map, np.diag((1e-2 * np.maximum(np.abs(u_map), 1.0)) ** 2)
    try:
        cov = hessian_cov(model, u_map, steps=0.2 * np.sqrt(np.diag(cov)))
    except ValueError:
        pass
    return u_map, cov
