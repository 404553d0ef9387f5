r"""Inflation of the capsule by its turgor: the wall law's analytic inflated cylinder
(:func:`inflated_radius`, :func:`axial_stretch`, :func:`pressure_for_inflation_number`) and the
FE load steps to P from the membrane prediction (:func:`inflate`); docs/fem.md.
"""

import math

import numpy as np

from turgorbayes.fem.config import check_ratio, checked_config
from turgorbayes.fem.errors import FEConfigError, FEConvergenceError
from turgorbayes.fem.solver import NewtonFailure

__all__ = ["axial_stretch", "inflate", "inflated_radius", "membrane_inflation",
           "pressure_for_inflation_number"]


def _coupling(ratio, cfg):
    """Factor of the hoop strain from the axial stress (sigma_z = sigma_theta / 2), thin wall."""
    return 1.0 - 0.5 * cfg.nu * math.sqrt(1.0 / ratio)


def axial_stretch(P, ratio, cfg=None):
    r"""Axial stretch of the long cylinder inflated by P, from the wall law (thin wall, nu = 0).

    .. math:: \ln\lambda_z = \frac{\sigma_z}{E_\parallel}
              = \frac{P\,(R - t/2)}{2\,\rho\,E_\perp t},\qquad \rho = E_\parallel/E_\perp,

    i.e. exp(x / (2 rho)) in terms of the inflation number: 1.9 at x = 0.445, rho = 0.35 and 2.8
    at x = 0.52, rho = 0.25 (the Poisson coupling, small for the wall, is left out: this sizes
    mesh elements, see :attr:`CapsuleConfig.axial_stretch_mesh`).

    Parameters
    ----------
    P : float [Pa]
    ratio : float [-]
        ``E_par / E_perp``.
    cfg : CapsuleConfig, optional
    """
    cfg = checked_config(cfg)
    R = inflated_radius(P, ratio, cfg)
    return math.exp(P * (R - 0.5 * cfg.thickness) / (2.0 * ratio * cfg.E_perp * cfg.thickness))


def inflated_radius(P, ratio, cfg=None):
    r"""Mid-surface radius of the long cylinder inflated by P, from the wall law (thin wall).

    .. math::

        \ln\frac{R}{R_0} = c_\nu \frac{P\,(R - t/2)}{E_\perp t},
        \qquad c_\nu = 1 - \frac{\nu}{2}\sqrt{E_\perp/E_\parallel},

    the hoop stress being :math:`P R_\mathrm{in}/t` (exact equilibrium) and the axial stress half
    of it. For :math:`\nu = 0` and small P: :math:`R = R_0 (1 + P R_0/(E_\perp t))`.

    Parameters
    ----------
    P : float [Pa]
    ratio : float [-]
        ``E_par / E_perp``.
    cfg : CapsuleConfig, optional
    """
    cfg = checked_config(cfg)
    check_ratio(ratio)
    c = _coupling(ratio, cfg)
    a = c * P / (cfg.E_perp * cfg.thickness)
    R = cfg.R0
    for _ in range(200):
        R_new = cfg.R0 * math.exp(a * (R - 0.5 * cfg.thickness))
        if not math.isfinite(R_new) or R_new > 100 * cfg.R0:
            raise FEConfigError(f"pressure {P!r} Pa is beyond the inflation limit of the wall law "
                                f"(P R / (E_perp t) must stay below about 1)")
        if abs(R_new - R) < 1e-14 * R:
            return R_new
        R = R_new
    raise FEConfigError(f"pressure {P!r} Pa: the inflated radius did not converge (too close to "
                        "the inflation limit P R / (E_perp t) ~ 1)")


def pressure_for_inflation_number(x, ratio, cfg=None):
    r"""Pressure [Pa] that gives the inflation number :math:`x = P R_c/(E_\perp t)`.

    Uses the law's analytic inflation (:func:`inflated_radius`); the FE's own ``R_c`` agrees
    to a fraction of a percent (test ``tests/fem/test_inflation.py``), and the FE result
    reports its exact ``x``.

    Parameters
    ----------
    x : float [-]
        Inflation number, 0 < x < 0.9.
    ratio : float [-]
        ``E_par / E_perp`` (enters only through nu).
    cfg : CapsuleConfig, optional
    """
    cfg = checked_config(cfg)
    check_ratio(ratio)
    if not (isinstance(x, int | float) and 0.0 < x < 0.9):
        raise FEConfigError(f"inflation number x must be in (0, 0.9), got {x!r}")
    c = _coupling(ratio, cfg)
    R = cfg.R0
    for _ in range(200):
        R = cfg.R0 * math.exp(c * x * (1.0 - 0.5 * cfg.thickness / R))
    return x * cfg.E_perp * cfg.thickness / R


def membrane_inflation(X, P, ratio, cfg):
    """Displacement predicted by membrane theory with the wall law (Newton's starting point).

    Cylinder: hoop stretch from :func:`inflated_radius`, axial log-strain
    ``P R / (2 E_par t)``; caps: the axial shift of the cylinder's end plus a radial
    expansion with log-strain ``P R / (2 E_perp t)``.
    """
    half = 0.5 * cfg.length
    lam_hoop = inflated_radius(P, ratio, cfg) / cfg.R0
    lam_axial = math.exp(P * cfg.R0 / (2.0 * ratio * cfg.E_perp * cfg.thickness))
    lam_cap = math.exp(P * cfg.R0 / (2.0 * cfg.E_perp * cfg.thickness))
    u = np.zeros_like(X)
    cyl = X[:, 0] <= half
    u[cyl, 0] = (lam_axial - 1.0) * X[cyl, 0]
    u[cyl, 1:] = (lam_hoop - 1.0) * X[cyl, 1:]
    cap = ~cyl
    rel = X[cap] - [half, 0.0, 0.0]
    u[cap] = (lam_cap - 1.0) * rel
    u[cap, 0] += (lam_axial - 1.0) * half
    return u


def inflate(model, P, ratio, D, cfg):
    """Load-step the pressure to P from the membrane prediction; return u and iterations.

    A pressure step whose Newton iterations fail is cut in half (down to 1/64 of the
    nominal step) before :class:`FEConvergenceError` is raised.
    """
    x_est = P * cfg.R0 / (cfg.E_perp * cfg.thickness)
    n = cfg.n_inflate_steps or max(1, math.ceil(x_est / 0.2))
    targets = list(P * np.arange(1, n + 1) / n)
    u, iters, P_done, step = np.zeros((model.mesh.n_nodes, 3)), 0, 0.0, 0
    X = model.mesh.X
    while targets:
        Pi = targets[0]
        guess = u + membrane_inflation(X, Pi, ratio, cfg) - membrane_inflation(X, P_done, ratio, cfg)
        try:
            u_new, info = model.problem.newton(guess, D, model.fixed["inflate"], P=Pi,
                                               rtol=cfg.newton_rtol, max_iter=cfg.newton_max_iter,
                                               stall_window=cfg.newton_stall_window)
        except NewtonFailure as err:
            if Pi - P_done < P / (64 * n):
                raise FEConvergenceError("inflation", step, Pi, err.residual, err.detail) from None
            targets.insert(0, 0.5 * (Pi + P_done))
            continue
        targets.pop(0)
        u, P_done, step = u_new, Pi, step + 1
        iters += info["iterations"]
    return u, iters
