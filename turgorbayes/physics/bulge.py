r"""Liquid-membrane bulge indented by a cone: force, depth, stiffness and pressure.

A membrane bulge pushed out through a wall fracture is a liquid vesicle of uniform tension under
pressure ``P``; a cone's indentation gives its pressure (Deng, Sun & Shaevitz, PRL 107, 158101
(2011), supplement "Bulge stiffness under conical indenter"; ``docs/physics.md``, "Bulge model").
``k_b/(P R_b)`` depends on ``h/R_b`` and the cone angle alone.
"""

import functools

import numpy as np
from scipy import interpolate, special

__all__ = [
    "bulge_integral",
    "indentation_depth",
    "max_reduced_depth",
    "pressure_from_bulge",
    "reduced_depth",
    "reduced_force",
    "reduced_stiffness",
]

DEFAULT_ALPHA = np.pi / 12


def _check_alpha(alpha):
    alpha = np.asarray(alpha, dtype=float)
    bad = ~((alpha > 0) & (alpha < np.pi / 2))
    if np.any(bad):
        raise ValueError(
            f"alpha (cone half-angle) must lie in (0, pi/2) rad, got {alpha[bad].ravel()[0]!r}"
        )
    return alpha


def _check_positive(name, value, unit, allow_zero=False):
    value = np.asarray(value, dtype=float)
    bad = ~(value >= 0) if allow_zero else ~(value > 0)
    if np.any(bad):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be finite and {bound} {unit}, got {value[bad].ravel()[0]!r}")
    if np.any(~np.isfinite(value)):
        raise ValueError(f"{name} must be finite, got {value[~np.isfinite(value)].ravel()[0]!r}")
    return value


def bulge_integral(xi, a):
    r"""The bulge-shape integral :math:`I(\xi, a)` in closed form.

    .. math::

        I(\xi, a) = \int_0^\xi \frac{\sin^2\zeta}{\sqrt{\sin^2\zeta + a}} d\zeta
                  = \sqrt{a}\,[E(\xi\mid m) - F(\xi\mid m)], \quad m = -1/a,

    with the incomplete elliptic integrals of the second and first kind (scipy's
    ``ellipeinc``/``ellipkinc`` accept negative parameter ``m``).

    Parameters
    ----------
    xi : array_like [rad]
        Upper limit, in [0, pi/2].
    a : array_like [-]
        Reduced force ``P F / (pi sigma_b^2)``, > 0. At ``a = 0`` the limit ``1 - cos(xi)``
        is returned.

    Returns
    -------
    ndarray [-]
    """
    xi, a = np.broadcast_arrays(np.asarray(xi, float), np.asarray(a, float))
    out = np.empty(xi.shape)
    pos = a > 0
    m = -1.0 / a[pos]
    out[pos] = np.sqrt(a[pos]) * (special.ellipeinc(xi[pos], m) - special.ellipkinc(xi[pos], m))
    out[~pos] = 1.0 - np.cos(xi[~pos])
    return out


def max_reduced_depth(alpha=DEFAULT_ALPHA):
    r"""Supremum of ``h/R_b``, reached as ``F -> pi P R_b^2`` (bulge tension -> 0).

    .. math:: \lim_{f\to\pi} h/R_b = 1 + \cot\alpha
    """
    alpha = _check_alpha(alpha)
    return 1.0 + 1.0 / np.tan(alpha)


def reduced_depth(f, alpha=DEFAULT_ALPHA):
    r"""Reduced indentation depth ``h/R_b`` as a function of reduced force ``f = F/(P R_b^2)``.

    With the bulge tension :math:`\sigma_b = P R_b/2 - F/(2\pi R_b)`,
    :math:`a = P F/(\pi\sigma_b^2)` and :func:`bulge_integral` ``I``:

    .. math::

        h = R_b - \frac{\sigma_b}{P}[1 + I(\tfrac{\pi}{2}, a)]
            + \frac{\sigma_b}{P}[1 - \sin\alpha - I(\tfrac{\pi}{2} - \alpha, a)]
            + \frac{\sigma_b}{P}(\sqrt{\cos^2\alpha + a} - \cos\alpha)\cot\alpha

    (global bulge deflection, dent under the tip, cone flank), divided by ``R_b``.

    Parameters
    ----------
    f : array_like [-]
        ``F / (P R_b^2)``, in [0, pi). ``f >= pi`` makes the bulge tension non-positive.
    alpha : array_like [rad]
        Cone half-angle, in (0, pi/2).

    Returns
    -------
    ndarray [-]
        ``h / R_b``.

    Raises
    ------
    ValueError
        If ``f`` is negative or ``>= pi``, or ``alpha`` is outside (0, pi/2).
    """
    alpha = _check_alpha(alpha)
    f = _check_positive("F/(P R_b^2)", f, "", allow_zero=True)
    if np.any(f >= np.pi):
        raise ValueError(
            "F must be < pi P R_b^2 (else the bulge tension sigma_b = P R_b/2 - F/(2 pi R_b) "
            f"is not positive), got F/(P R_b^2) = {f[f >= np.pi].ravel()[0]!r}"
        )
    s = 0.5 - f / (2 * np.pi)  # sigma_b / (P R_b)
    a = f / (np.pi * s**2)
    h_global = 1.0 - s * (1.0 + bulge_integral(np.pi / 2, a))
    h_dent = s * (1.0 - np.sin(alpha) - bulge_integral(np.pi / 2 - alpha, a))
    h_cone = s * (np.sqrt(np.cos(alpha) ** 2 + a) - np.cos(alpha)) / np.tan(alpha)
    return h_global + h_dent + h_cone


def indentation_depth(F, P, R_b, alpha=DEFAULT_ALPHA):
    r"""Depth ``h`` a cone of half-angle ``alpha`` pushes into a liquid-membrane bulge.

    .. math:: h = R_b \, \hat h\!\left(\frac{F}{P R_b^2}, \alpha\right)

    (module docstring for :math:`\hat h`; Deng et al. 2011, supplement).

    Parameters
    ----------
    F : array_like [N]
        Indentation force, ``0 <= F < pi P R_b^2``.
    P : array_like [Pa]
        Bulge (= cell) pressure, > 0.
    R_b : array_like [m]
        Bulge radius, > 0.
    alpha : array_like [rad]
        Cone half-angle, default pi/12.

    Returns
    -------
    ndarray [m]

    Raises
    ------
    ValueError
        For non-positive ``P`` or ``R_b``, negative ``F``, ``F >= pi P R_b^2`` (non-positive
        bulge tension) or ``alpha`` outside (0, pi/2).
    """
    P = _check_positive("P (pressure)", P, "Pa")
    R_b = _check_positive("R_b (bulge radius)", R_b, "m")
    F = _check_positive("F (force)", F, "N", allow_zero=True)
    return R_b * reduced_depth(F / (P * R_b**2), alpha)


def _clip_f(f):
    return np.minimum(f, np.pi * (1 - 1e-15))


@functools.lru_cache(maxsize=8)
def _initial_log_force(alpha):
    # Cubic spline of log f against log(h/R_b) on a dense table: a starting guess good to
    # ~1e-7, so Newton needs one or two steps.
    f = np.pi * np.concatenate([np.logspace(-10, -1, 1200), 1 - np.logspace(-1, -8, 800)[1:]])
    return interpolate.CubicSpline(np.log(reduced_depth(f, alpha)), np.log(f), extrapolate=True)


def reduced_force(h_over_Rb, alpha=DEFAULT_ALPHA):
    r"""Invert :func:`reduced_depth`: the reduced force ``f = F/(P R_b^2)`` at depth ``h/R_b``.

    Vectorized Newton iteration in ``log f`` from a tabulated start (monotone, no loop over
    elements); converges to machine precision in a few steps.

    Parameters
    ----------
    h_over_Rb : array_like [-]
        ``h / R_b`` in [0, 1 + cot(alpha)).
    alpha : float [rad]
        Cone half-angle (a scalar for the inversion).

    Returns
    -------
    ndarray [-]
    """
    alpha = float(_check_alpha(alpha))
    y = _check_positive("h/R_b (reduced bulge indentation)", h_over_Rb, "", allow_zero=True)
    y_max = max_reduced_depth(alpha)
    if np.any(y >= y_max):
        raise ValueError(
            f"h/R_b must be < 1 + cot(alpha) = {y_max:.4g} (the depth reached as the bulge "
            f"tension vanishes), got {y[y >= y_max].ravel()[0]!r}"
        )
    out = np.zeros(y.shape)
    pos = y > 0
    log_y = np.log(y[pos])
    spline = _initial_log_force(alpha)
    slope = spline.derivative()
    log_f = spline(log_y)
    active = np.ones(log_y.shape, dtype=bool)
    for _ in range(20):
        # Newton on log h(log f) = log y with the spline's slope (good to ~1e-7): each step
        # multiplies the error by ~1e-7, so one or two evaluations per element suffice.
        lf, ly = log_f[active], log_y[active]
        g = np.log(reduced_depth(_clip_f(np.exp(lf)), alpha))
        delta = (ly - g) * slope(g)
        log_f[active] = np.minimum(lf + delta, np.log(np.pi) - 1e-15)
        idx = np.flatnonzero(active)
        active[idx[np.abs(delta) < 1e-9]] = False
        if not active.any():
            break
    out[pos] = np.exp(log_f)
    return out


def reduced_stiffness(h_over_Rb, alpha=DEFAULT_ALPHA):
    r"""Reduced secant bulge stiffness ``k_b/(P R_b)`` at reduced depth ``h/R_b``.

    .. math:: \frac{k_b}{P R_b} = \frac{F/h}{P R_b} = \frac{f(h/R_b)}{h/R_b}

    with ``f`` from :func:`reduced_force`. Between 0.35 and 0.38 for ``h/R_b`` from about
    0.17 to 0.27 at ``alpha = pi/12`` (the paper's range); vanishes like
    ``pi / ln(P R_b^2/F)`` as ``h -> 0``.

    Parameters
    ----------
    h_over_Rb : array_like [-]
        ``h / R_b``, in (0, 1 + cot(alpha)).
    alpha : float [rad]

    Returns
    -------
    ndarray [-]
    """
    y = np.asarray(h_over_Rb, dtype=float)
    if np.any(~(y > 0)):
        raise ValueError(f"h/R_b must be > 0 for a secant stiffness, got {y[~(y > 0)].ravel()[0]!r}")
    return reduced_force(y, alpha) / y


def pressure_from_bulge(k_b, R_b, h_b, alpha=DEFAULT_ALPHA):
    r"""Pressure of a cell from its bulge's secant stiffness, radius and indentation depth.

    .. math:: P = \frac{k_b}{R_b \, \hat k(h_b/R_b)}, \qquad \hat k = k_b/(P R_b)

    (:func:`reduced_stiffness`; ``docs/physics.md``, "Bulge model").

    Parameters
    ----------
    k_b : array_like [N/m]
        Secant stiffness ``F/h`` of the bulge at depth ``h_b``, > 0.
    R_b : array_like [m]
        Bulge radius, > 0.
    h_b : array_like [m]
        Indentation depth at which ``k_b`` was read, ``0 < h_b < (1 + cot alpha) R_b``.
    alpha : float [rad]

    Returns
    -------
    ndarray [Pa]
    """
    k_b = _check_positive("k_b (bulge stiffness)", k_b, "N/m")
    R_b = _check_positive("R_b (bulge radius)", R_b, "m")
    h_b = _check_positive("h_b (bulge indentation depth)", h_b, "m")
    return k_b / (R_b * reduced_stiffness(h_b / R_b, alpha))
