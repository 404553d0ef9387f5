"""Posterior mode and Laplace covariance in sampler coordinates (one implementation).

Used by :meth:`turgorbayes.inference.models.BaselineModel.start` (emcee's starting walkers) and
by the criticism's importance proposals (:mod:`turgorbayes.inference.engine`). A *model* is
any object with a vectorized ``log_posterior(u (W, ndim)) -> (W,)``. See ``docs/statistics.md``.
"""

import logging
import warnings
from dataclasses import dataclass

import numpy as np
from scipy import optimize

__all__ = [
    "CLIP_FLOOR",
    "HESSIAN_REL_STEP",
    "Clipping",
    "LaplaceFit",
    "ModeSearchWarning",
    "ModeSearch",
    "clipped_inverse",
    "find_mode",
    "hessian",
    "hessian_cov",
    "inverse_hessian",
    "laplace",
    "laplace_fit",
    "mode_search",
    "value_and_gradient",
]

logger = logging.getLogger(__name__)

#: Relative finite-difference step of the Hessian stencil (times ``max(|u|, 1)``).
HESSIAN_REL_STEP = 1e-3
#: Eigenvalue floor of the unit-diagonal-scaled Hessian (:func:`clipped_inverse`).
CLIP_FLOOR = 1e-3
#: Gradient norm (sampler coordinates) below which a start the search cannot improve counts
#: as the mode (the BFGS tolerance).
_GTOL = 1e-3


class ModeSearchWarning(UserWarning):
    """The mode search could not improve on its start and the gradient there is not small."""


@dataclass
class ModeSearch:
    """Outcome of :func:`mode_search`.

    Attributes
    ----------
    u : ndarray (ndim,)
        The mode found, or the start when the search failed.
    log_post : float
        Log posterior at ``u``.
    success : bool
        False when the search ended no better than its start while the gradient there has
        norm above the tolerance (the start is returned, and is not a mode).
    message : str
        Why not (empty on success).
    """

    u: np.ndarray
    log_post: float
    success: bool
    message: str = ""


@dataclass
class Clipping:
    """Eigenvalues of the scaled Hessian raised to the floor by :func:`clipped_inverse`.

    Attributes
    ----------
    n_clipped : int
        How many eigenvalues were below ``floor`` (0: the inverse is exact).
    smallest : float
        The smallest eigenvalue before clipping (negative: not positive definite).
    floor : float
    """

    n_clipped: int
    smallest: float
    floor: float

    def describe(self):
        """A sentence for reports and warnings."""
        return (f"{self.n_clipped} eigenvalue(s) of the unit-diagonal-scaled Hessian below "
                f"{self.floor:g} clipped (smallest {self.smallest:.3g}): the Laplace "
                "covariance is not the inverse Hessian in those directions")


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
        With a :class:`ModeSearchWarning` when the search failed (:func:`mode_search`).
    """
    res = mode_search(model, u0, maxiter, method)
    if not res.success:
        warnings.warn(f"{getattr(model, 'name', 'model')}: {res.message}", ModeSearchWarning,
                      stacklevel=2)
    return res.u


def mode_search(model, u0, maxiter=None, method="BFGS"):
    """:func:`find_mode` with its outcome: a :class:`ModeSearch` instead of a warning.

    A BFGS search that does not improve on ``u0`` returns ``u0``; that is a success only if
    the central-difference gradient at ``u0`` has norm below 1e-3 (``u0`` already is the mode).
    """
    u0 = np.asarray(u0, float)
    if method == "BFGS":
        return _mode_bfgs(model, u0, 200 if maxiter is None else maxiter)
    if method == "Nelder-Mead":
        u = _mode_nelder_mead(model, u0, 4000 if maxiter is None else maxiter)
        return ModeSearch(u, float(model.log_posterior(u[None])[0]), True)
    raise ValueError(f"method must be 'BFGS' or 'Nelder-Mead', got {method!r}")


def _mode_nelder_mead(model, u0, maxiter):
    def neg(u):
        return -float(model.log_posterior(u[None])[0])

    res = optimize.minimize(neg, u0, method="Nelder-Mead",
                            options={"xatol": 1e-6, "fatol": 1e-8, "maxiter": maxiter})
    return res.x


def value_and_gradient(model, u):
    """``model.log_posterior`` at ``u (ndim,)`` and its central-difference gradient (steps
    ``1e-4 max(|u|, 1)``; one vectorized call of ``2 ndim + 1`` points). A coordinate whose
    two stencil points are both outside the support (-inf) gets a NaN derivative, which the
    callers treat as unknown (the mode search sets it to 0)."""
    d = u.size
    h = 1e-4 * np.maximum(np.abs(u), 1.0)
    lp = model.log_posterior(np.vstack([u, u + np.diag(h), u - np.diag(h)]))
    with np.errstate(invalid="ignore"):  # -inf - (-inf): unknown, not an error
        return lp[0], (lp[1:d + 1] - lp[d + 1:]) / (2 * h)


def _mode_bfgs(model, u0, maxiter):
    d = u0.size
    if not np.isfinite(model.log_posterior(u0[None])[0]):
        raise ValueError("the starting point of the mode search has a non-finite log posterior")

    start = []  # fg at u0: BFGS evaluates it first, and the outcome is judged against it

    def fg(u):
        lp, g = value_and_gradient(model, u)
        out = ((np.inf, np.zeros(d)) if not np.isfinite(lp)
               else (-lp, np.where(np.isfinite(g), -g, 0.0)))
        if not start and np.array_equal(u, u0):
            start.append((out[0], out[1].copy()))
        return out

    res = optimize.minimize(fg, u0, jac=True, method="BFGS",
                            options={"maxiter": maxiter, "gtol": _GTOL})
    f0, g0 = start[0] if start else fg(u0)
    if np.isfinite(res.fun) and res.fun < f0:
        return ModeSearch(res.x, -float(res.fun), True)
    gnorm = float(np.linalg.norm(g0))
    if gnorm < _GTOL:
        return ModeSearch(u0, -float(f0), True)
    return ModeSearch(u0, -float(f0), False,
                      f"the mode search (BFGS) did not improve on its start (ended at log "
                      f"posterior {-res.fun:.6g} against {-f0:.6g} at the start, where the "
                      f"gradient norm is {gnorm:.3g}; scipy: {res.message}); the start is used")


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


def clipped_inverse(H, floor=CLIP_FLOOR, return_clipping=False):
    """Inverse of ``H`` with its eigenvalues clipped at ``floor`` after scaling to unit diagonal.

    A direction in which the log posterior is flat or not concave gets a large but finite
    variance instead of a negative or infinite one; the clipping is done scale-free because
    the coordinates differ by orders of magnitude in scale.

    Returns
    -------
    cov : ndarray (ndim, ndim)
    clipping : Clipping
        Only with ``return_clipping``: how many eigenvalues were raised, and from what.
    """
    D = np.sqrt(np.maximum(np.abs(np.diag(H)), 1e-12))
    vals, vecs = np.linalg.eigh(0.5 * (H + H.T) / np.outer(D, D))
    clip = Clipping(int(np.count_nonzero(vals < floor)), float(vals.min()), float(floor))
    cov = ((vecs / np.maximum(vals, floor)) @ vecs.T) / np.outer(D, D)
    return (cov, clip) if return_clipping else cov


def hessian_cov(model, u, steps=None, return_clipping=False):
    """:func:`clipped_inverse` of the strict :func:`hessian` of ``-log_posterior`` at ``u``.

    Clipping is reported: with ``return_clipping`` as a :class:`Clipping`, otherwise by a
    ``RuntimeWarning`` naming how many eigenvalues were raised and the smallest one.

    Returns
    -------
    cov : ndarray (ndim, ndim)
    clipping : Clipping
        Only with ``return_clipping``.
    """
    cov, clip = clipped_inverse(hessian(model, u, steps), return_clipping=True)
    if return_clipping:
        return cov, clip
    if clip.n_clipped:
        warnings.warn(f"{getattr(model, 'name', 'model')}: {clip.describe()}", RuntimeWarning,
                      stacklevel=2)
    return cov


@dataclass
class LaplaceFit:
    """Mode and covariance of :func:`laplace_fit`, with what went wrong on the way.

    Attributes
    ----------
    u_map : ndarray (ndim,)
    cov : ndarray (ndim, ndim)
    mode : ModeSearch
    clipping : Clipping or None
        Of the final Hessian pass (None when no finite Hessian exists).
    notes : list of str
        Sentences for reports: a failed mode search, clipped eigenvalues, no finite Hessian.
    """

    u_map: np.ndarray
    cov: np.ndarray
    mode: ModeSearch
    clipping: object
    notes: list

    def record(self):
        """JSON-ready summary (``mode_found``, ``log_post``, ``hessian_clipped``, ``notes``)."""
        clip = self.clipping
        return {"mode_found": bool(self.mode.success), "log_post": float(self.mode.log_post),
                "hessian_clipped": None if clip is None else {
                    "n_eigenvalues": clip.n_clipped, "smallest": clip.smallest,
                    "floor": clip.floor},
                "notes": list(self.notes)}


def laplace_fit(model, u0):
    """Mode (BFGS from ``u0``) and covariance (two Hessian passes, the second with steps of
    0.2 sd), with the failures recorded instead of hidden (:class:`LaplaceFit`).

    A stencil that leaves the model's domain is retried with steps ten times smaller (up to 4
    times). If no finite Hessian exists (the mode sits on the edge of the region where the
    model is defined, e.g. where the radius saturates), the covariance is diagonal, 1 % of each
    coordinate (at least 0.01): the samplers then explore from there and their own diagnostics
    (Pareto k, R-hat, ESS) decide whether the posterior is usable.

    Parameters
    ----------
    model : object
        With a vectorized ``log_posterior`` and ``name``.
    u0 : ndarray (ndim,)
        Start of the mode search (sampler coordinates; finite log posterior).

    Returns
    -------
    LaplaceFit
    """
    name = getattr(model, "name", "model")
    mode = mode_search(model, u0)
    notes = [] if mode.success else [mode.message]
    u_map = mode.u
    steps = _default_steps(u_map)
    first = None
    for _ in range(4):
        try:
            first = hessian_cov(model, u_map, steps, return_clipping=True)
            break
        except ValueError:
            steps = steps / 10
    if first is None:
        notes.append("no finite Hessian at the posterior mode (the mode is on the edge of the "
                     "model's domain); a diagonal covariance is used")
        logger.warning("%s: %s", name, notes[-1])
        cov = np.diag((1e-2 * np.maximum(np.abs(u_map), 1.0)) ** 2)
        return LaplaceFit(u_map, cov, mode, None, notes)
    cov, clip = first
    try:
        cov, clip = hessian_cov(model, u_map, 0.2 * np.sqrt(np.diag(cov)), return_clipping=True)
    except ValueError:
        pass
    if clip.n_clipped:
        notes.append(clip.describe())
        logger.warning("%s: %s", name, notes[-1])
    return LaplaceFit(u_map, cov, mode, clip, notes)


def laplace(model, guess):
    """Mode and covariance of :func:`laplace_fit` from physical starting values.

    A failed mode search gives a :class:`ModeSearchWarning`; clipped eigenvalues and a missing
    Hessian are logged (:func:`laplace_fit` records them).

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
    fit = laplace_fit(model, model.to_u(guess)[0])
    if not fit.mode.success:
        warnings.warn(f"{getattr(model, 'name', 'model')}: {fit.mode.message}",
                      ModeSearchWarning, stacklevel=2)
    return fit.u_map, fit.cov
