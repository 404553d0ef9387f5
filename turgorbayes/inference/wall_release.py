"""A condition's wall released from the reference's where its data cannot tell it: the
posterior under the wall prior, from the shared-wall posterior by a change of variables.

A condition ``c`` without bulged cells is seen only through its intact cells, which all sit at
its turgor ``P_c`` with its radius parameter ``R0_c``: its data enter the likelihood through
two numbers, the model's radius and stiffness there, ``m = F(P_c, R0_c; gamma_c, E0t_c)``
(:func:`turgorbayes.physics.forward.cell_radius_and_stiffness`). For any wall of its own there
is one ``(P_c, R0_c)`` that predicts the same ``m``, so the data cannot tell that wall from the
reference's, and the posterior under the wall prior ``ln(E0t_c/E0t_ref) ~ N(0, s_E)``,
``gamma_c - gamma_ref ~ N(0, s_g)`` is, in the coordinates ``(theta, m, d)``,

    p(theta, m, d | data) = p_shared(theta, m | data) pi(d) w(theta, m, d),

with ``p_shared`` the posterior of the model whose wall is shared and
``w = pi(P'_c) pi(R0'_c) |det dm/du'|^-1 / (pi(P_c) pi(R0_c) |det dm/du|^-1)``, ``u = (ln P_c,
R0_c)``, the primed values the solution of ``F(u'; wall_ref + d) = m``. :func:`release`
draws one ``d`` from the prior for each shared-wall draw, solves for ``u'`` by Newton's method,
weights by ``w`` and resamples: exact importance sampling with the shared-wall posterior as
proposal (docs/statistics.md, "A wall that may differ"). A draw whose wall cannot produce ``m``
(outside the FE table, beyond the pressure the wall bears, outside the priors) gets weight 0.
"""

import numpy as np

from turgorbayes.inference.priors import BASELINE_PRIORS
from turgorbayes.physics import forward

__all__ = ["NEWTON_STEPS", "PRIOR_BOUNDS", "release"]

#: Supports of the baseline's priors of a condition's turgor and radius parameter [Pa, m]:
#: flat in ln P and in R0 (:data:`turgorbayes.inference.priors.BASELINE_PRIORS`).
PRIOR_BOUNDS = {"P": (BASELINE_PRIORS["P_phys"].lower, BASELINE_PRIORS["P_phys"].upper),
                "R0": (BASELINE_PRIORS["R0"].lower, BASELINE_PRIORS["R0"].upper)}

#: Newton iterations of the solve (quadratic convergence from the shared-wall draw; converged
#: draws change by < 1e-10 relative in the last step, :func:`release` checks the residual).
NEWTON_STEPS = 30
#: Relative residual of ``ln R`` and ``ln k`` below which a solve counts as converged.
TOLERANCE = 1e-9
#: Relative step of the finite-difference Jacobian.
_H = 1e-6


def _m(u, g, e, P0, surrogate):
    """``(ln R_c, ln k_c)`` ``(N, 2)`` at ``u = (ln P, R0 [nm])``."""
    R, k = forward.cell_radius_and_stiffness(np.exp(u[:, 0]), g, e, u[:, 1] * 1e-9, P0, surrogate)
    return np.column_stack([np.log(R), np.log(k)])


def _jacobian(u, g, e, P0, surrogate, m0=None):
    """``dm/du`` ``(N, 2, 2)`` by central differences, and ``m`` at ``u``."""
    m0 = _m(u, g, e, P0, surrogate) if m0 is None else m0
    J = np.empty(u.shape + (2,))
    for j, h in enumerate((_H, _H * 500.0)):  # ln P; R0 in nm (~500)
        step = np.zeros(2)
        step[j] = h
        J[:, :, j] = (_m(u + step, g, e, P0, surrogate) - _m(u - step, g, e, P0, surrogate)) / (2 * h)
    return J, m0


def _solve(target, u, g, e, P0, surrogate):
    """Newton's method for ``m(u) = target``, per draw; ``(u, J, ok)``."""
    ok = np.ones(u.shape[0], bool)
    for _ in range(NEWTON_STEPS):
        J, m = _jacobian(u, g, e, P0, surrogate)
        r = m - target
        ok = np.all(np.isfinite(r), axis=1) & np.all(np.isfinite(J), axis=(1, 2))
        if np.all(~ok | (np.max(np.abs(r), axis=1) < TOLERANCE)):
            break
        det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
        ok &= np.abs(det) > 0
        inv = np.empty_like(J)
        inv[:, 0, 0], inv[:, 1, 1] = J[:, 1, 1], J[:, 0, 0]
        inv[:, 0, 1], inv[:, 1, 0] = -J[:, 0, 1], -J[:, 1, 0]
        inv /= np.where(ok, det, 1.0)[:, None, None]
        step = np.einsum("nij,nj->ni", inv, np.where(ok[:, None], r, 0.0))
        # damped: never more than a factor e in P or 50 nm in R0 at once
        scale = np.maximum(1.0, np.max(np.abs(step) / [1.0, 50.0], axis=1))
        u = u - step / scale[:, None]
    J, m = _jacobian(u, g, e, P0, surrogate)
    ok = np.all(np.isfinite(J), axis=(1, 2)) & (np.max(np.abs(m - target), axis=1) < 1e3 * TOLERANCE)
    return u, J, ok


def _log_abs_det(J):
    return np.log(np.abs(J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]))


def release(values, wall_prior, rng, P0, surrogate, prior_bounds=PRIOR_BOUNDS):
    """Release one condition's wall from the reference's (module docstring).

    Parameters
    ----------
    values : dict
        Shared-wall draws ``(N,)`` (SI): ``P`` and ``R0`` of the condition, ``gamma`` and
        ``E0t`` of the reference (the shared wall).
    wall_prior : dict
        ``{"E0t": sd of ln ratio, "gamma": sd of difference}`` (a subset; a missing one
        stays shared).
    rng : numpy.random.Generator
    P0 : float [Pa]
    surrogate : turgorbayes.surrogate.Surrogate
    prior_bounds : dict
        ``{"P": (lo, hi), "R0": (lo, hi)}`` [Pa, m]: the supports of the (flat in ln P and in
        R0) priors of the condition's turgor and radius parameter (default the baseline's,
        :data:`PRIOR_BOUNDS`).

    Returns
    -------
    dict
        ``P``, ``R0``, ``gamma``, ``E0t`` of the condition under its own wall ``(N,)`` and
        ``log_weight`` ``(N,)`` (``-inf`` where the wall cannot produce the draw's
        prediction), ``failed`` (the number of such draws).
    """
    P, R0 = (np.asarray(values[k], float) for k in ("P", "R0"))
    g0, e0 = (np.asarray(values[k], float) for k in ("gamma", "E0t"))
    n = P.size
    d_e = rng.normal(0.0, wall_prior["E0t"], n) if "E0t" in wall_prior else np.zeros(n)
    d_g = rng.normal(0.0, wall_prior["gamma"], n) if "gamma" in wall_prior else np.zeros(n)
    g1, e1 = g0 + d_g, e0 * np.exp(d_e)
    u0 = np.column_stack([np.log(P), R0 * 1e9])
    J0, target = _jacobian(u0, g0, e0, P0, surrogate)
    u1, J1, ok = _solve(target, u0.copy(), g1, e1, P0, surrogate)
    P1, R1 = np.exp(u1[:, 0]), u1[:, 1] * 1e-9
    inside = ((P1 >= prior_bounds["P"][0]) & (P1 <= prior_bounds["P"][1])
              & (R1 >= prior_bounds["R0"][0]) & (R1 <= prior_bounds["R0"][1]) & (g1 >= 0))
    ok &= inside & np.all(np.isfinite(target), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        log_w = np.where(ok, _log_abs_det(J0) - _log_abs_det(J1), -np.inf)
    log_w = np.where(np.isfinite(log_w), log_w, -np.inf)
    return {"P": np.where(ok, P1, P), "R0": np.where(ok, R1, R0), "gamma": g1, "E0t": e1,
            "log_weight": log_w, "failed": int(np.sum(~np.isfinite(log_w)))}
