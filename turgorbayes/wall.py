r"""Cell radius and wall anisotropy under pressure, with power-law stress stiffening.

Deng, Sun & Shaevitz, PRL 107, 158101 (2011), supplement sections "Radial expansion of an
inflated cylinder with stress-stiffening" and "Anisotropy of the elastic modulus"
(SCIENCE.md sections 3-4). Circumferential tension ``sigma = P R_c`` (true tension),
natural strain ``dR_c/R_c``, Poisson ratio 0 and a tangent modulus that stiffens with
pressure, ``E_perp t = E0t (P/P0)^gamma``; ``R0`` is the radius at ``P0``. With
``p = P0 R0/(E0 t)``, ``rho = R0/R_c`` and ``c = (gamma - 1)/(gamma p)``:

.. math::

    \frac{P}{P_0} = \rho \left[c(\rho^\gamma - 1) + 1\right]^{1/(1-\gamma)}
    \;\xrightarrow{\gamma\to1}\; \rho\,\exp\!\left[\frac{1-\rho}{p}\right].

The pressure is explicit in the radius; the radius at a pressure is found by a vectorized
bracketed root search on the branch where ``P`` rises with ``R_c``.

Domain (why a pressure can be unreachable)
------------------------------------------
Along ``s = ln(R_c/R0)``, ``d ln P/ds = -1 + rho^gamma/(p B)`` with ``B`` the bracket above.
The physical branch starts at ``P = 0`` and rises until either

* the bracket ``B`` reaches 0 (possible only for ``gamma > 1`` with ``gamma p < gamma - 1``):
  ``P -> infinity`` while ``R_c`` approaches a finite maximum
  ``R_max = R0 (1 - gamma p/(gamma - 1))^(-1/gamma)``: the radius *saturates*, every pressure is
  reachable but no radius beyond ``R_max`` is; or
* ``d ln P/ds = 0`` at ``rho^gamma = gamma p - gamma + 1`` (all other cases, including
  ``gamma <= 1``): the pressure has a maximum ``P_max`` the wall can bear (beyond it the model
  wall would inflate without bound). Pressures ``>= P_max`` are unreachable and give NaN.

:func:`radius_at_pressure` returns NaN for unreachable pressures (or raises with
``errors="raise"``); :func:`max_pressure` and :func:`max_radius` give the limits.
"""

import numpy as np
from scipy.optimize import elementwise

__all__ = [
    "P0_DEFAULT",
    "anisotropy",
    "max_pressure",
    "max_radius",
    "perp_modulus_times_thickness",
    "pressure_at_radius",
    "radius_at_pressure",
]

P0_DEFAULT = 5e3  # Pa, the paper's reference pressure


def _log1p_ratio(z):
    """``log1p(z)/z``, exact at z = 0 (no 0/0 at gamma = 1)."""
    z = np.asarray(z, dtype=float)
    small = np.abs(z) < 1e-8
    safe = np.where(small, 1.0, z)
    return np.where(small, 1.0 - z / 2 + z * z / 3, np.log1p(safe) / safe)


def _expm1_ratio(z):
    """``expm1(z)/z``, exact at z = 0."""
    z = np.asarray(z, dtype=float)
    small = np.abs(z) < 1e-8
    safe = np.where(small, 1.0, z)
    return np.where(small, 1.0 + z / 2 + z * z / 6, np.expm1(safe) / safe)


def _check(E0t, gamma, R0, P0):
    E0t, gamma, R0, P0 = (np.asarray(v, dtype=float) for v in (E0t, gamma, R0, P0))
    for name, v, unit in (("E0t", E0t, "N/m"), ("R0", R0, "m"), ("P0", P0, "Pa")):
        if np.any(~(v > 0)) or np.any(~np.isfinite(v)):
            bad = v[~((v > 0) & np.isfinite(v))].ravel()[0]
            raise ValueError(f"{name} must be finite and > 0 {unit}, got {bad!r}")
    if np.any(~(gamma >= 0)) or np.any(~np.isfinite(gamma)):
        bad = gamma[~((gamma >= 0) & np.isfinite(gamma))].ravel()[0]
        raise ValueError(f"gamma (stiffening exponent) must be finite and >= 0, got {bad!r}")
    return E0t, gamma, R0, P0


def _log_pressure_ratio(s, p, gamma):
    """``ln(P/P0)`` at ``s = ln(R_c/R0)``; NaN where the bracket is not positive."""
    u = -s * _expm1_ratio(-gamma * s) / p  # (rho^gamma - 1)/(gamma p), finite at gamma = 0
    z = (gamma - 1) * u  # bracket B = 1 + z
    with np.errstate(invalid="ignore", divide="ignore"):
        out = -s - u * _log1p_ratio(z)
    return np.where(z > -1, out, np.nan)


def pressure_at_radius(R_c, E0t, gamma, R0, P0=P0_DEFAULT):
    r"""Pressure at which the stress-stiffening wall has radius ``R_c`` (explicit).

    .. math::

        \frac{P}{P_0} = \frac{R_0}{R_c}\left[\frac{(\gamma-1)E_0t}{\gamma P_0R_0}
        \left(\left(\frac{R_0}{R_c}\right)^\gamma-1\right)+1\right]^{1/(1-\gamma)}

    (SCIENCE.md section 3), evaluated through ``log1p`` so that it is continuous through
    ``gamma = 1``, where it becomes :math:`(R_0/R_c)\exp[(E_0t/P_0R_0)(1-R_0/R_c)]`.

    Parameters
    ----------
    R_c : array_like [m]
        Cell radius, > 0.
    E0t : array_like [N/m]
        Circumferential modulus times wall thickness at ``P0`` (``E_0 t``).
    gamma : array_like [-]
        Stress-stiffening exponent, ``E_perp = E_0 (P/P_0)^gamma``.
    R0 : array_like [m]
        Radius at ``P0``.
    P0 : array_like [Pa]
        Reference pressure (5 kPa in the paper).

    Returns
    -------
    ndarray [Pa]
        NaN where the radius lies beyond the saturation radius ``R_max`` (``gamma > 1``).
        Radii past the pressure maximum return the (falling) pressure of the formula; use
        :func:`max_radius` for the end of the physical branch.
    """
    E0t, gamma, R0, P0 = _check(E0t, gamma, R0, P0)
    R_c = np.asarray(R_c, dtype=float)
    if np.any(~(R_c > 0)):
        raise ValueError(f"R_c must be > 0 m, got {R_c[~(R_c > 0)].ravel()[0]!r}")
    p = P0 * R0 / E0t
    return P0 * np.exp(_log_pressure_ratio(np.log(R_c / R0), p, gamma))


def _branch_end(p, gamma):
    """End of the rising branch in ``s = ln(R_c/R0)`` and whether P diverges there.

    Returns ``(s_end, diverges)``: ``diverges`` is True where the bracket vanishes first
    (radius saturation, P -> inf), else ``s_end`` is the pressure maximum.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        # bracket zero (gamma > 1): rho^gamma = 1 - gamma p/(gamma - 1)
        y_zero = np.where(gamma > 1, 1 - gamma * p / np.where(gamma > 1, gamma - 1, 1), -1.0)
        diverges = y_zero > 0
        s_zero = -np.log(np.where(diverges, y_zero, 1.0)) / np.where(gamma > 0, gamma, 1.0)
        # pressure maximum: rho^gamma = 1 + gamma (p - 1), i.e. s = -log1p(gamma (p-1))/gamma,
        # written so that it stays finite at gamma = 0 (s = 1 - p)
        q = gamma * (p - 1)
        s_peak = np.where(q > -1, -(p - 1) * _log1p_ratio(q), np.inf)
        s_end = np.where(diverges, s_zero, s_peak)
    return s_end, diverges


def max_radius(E0t, gamma, R0, P0=P0_DEFAULT):
    """Largest radius on the physical branch [m].

    For ``gamma > 1`` and ``gamma p < gamma - 1`` this is the saturation radius ``R_max``
    approached as ``P -> infinity``; otherwise it is the radius at the pressure maximum.

    Parameters
    ----------
    E0t : array_like [N/m]
    gamma : array_like [-]
    R0 : array_like [m]
    P0 : array_like [Pa]

    Returns
    -------
    ndarray [m]
    """
    E0t, gamma, R0, P0 = _check(E0t, gamma, R0, P0)
    s_end, _ = _branch_end(P0 * R0 / E0t, gamma)
    return R0 * np.exp(s_end)


def max_pressure(E0t, gamma, R0, P0=P0_DEFAULT):
    """Largest pressure the wall model can reach [Pa]; ``inf`` where the radius saturates.

    Parameters
    ----------
    E0t : array_like [N/m]
    gamma : array_like [-]
    R0 : array_like [m]
    P0 : array_like [Pa]

    Returns
    -------
    ndarray [Pa]
    """
    E0t, gamma, R0, P0 = _check(E0t, gamma, R0, P0)
    p = P0 * R0 / E0t
    s_end, diverges = _branch_end(p, gamma)
    finite = np.isfinite(s_end) & ~diverges
    log_peak = _log_pressure_ratio(np.where(finite, s_end, 0.0), p, gamma)
    return np.where(finite, P0 * np.exp(log_peak), np.inf)


def _bracket(log_target, p, gamma, s_end):
    """A bracket ``[lo, hi]`` in ``s`` with ``ln P(lo) < target < ln P(hi)`` on the branch."""
    # ln P/P0 = -s + ... is below any target far enough to the left (P -> 0 as s -> -inf or at
    # the zero-pressure radius), and the branch end is above every reachable target.
    lo = np.minimum(log_target, 0.0) - 1.0
    lo = np.where(np.isfinite(s_end), np.minimum(lo, s_end - 1e-12), lo)
    for _ in range(200):
        val = _log_pressure_ratio(lo, p, gamma)
        low_enough = ~(val >= log_target)  # NaN (zero-pressure side, gamma < 1) counts as low
        if low_enough.all():
            break
        lo = np.where(low_enough, lo, 2 * lo - 1)
    hi = np.where(np.isfinite(s_end), s_end, np.maximum(log_target, 0.0) + 1.0)
    for _ in range(200):
        val = _log_pressure_ratio(hi, p, gamma)
        grow = ~(val >= log_target) & ~np.isfinite(s_end)
        if not grow.any():
            break
        hi = np.where(grow, 2 * hi + 1, hi)
    return lo, hi


def radius_at_pressure(P, E0t, gamma, R0, P0=P0_DEFAULT, errors="nan"):
    r"""Radius of the stress-stiffening wall at pressure ``P`` (inverse of :func:`pressure_at_radius`).

    Solves ``pressure_at_radius(R_c) = P`` on the rising branch (module docstring) with
    scipy's vectorized bracketed root finder (``scipy.optimize.elementwise.find_root``), to
    about 1e-14 relative in ``R_c``. Continuous through ``gamma = 1``.

    Parameters
    ----------
    P : array_like [Pa]
        Pressure, > 0.
    E0t : array_like [N/m]
        ``E_0 t`` at ``P0``.
    gamma : array_like [-]
        Stress-stiffening exponent.
    R0 : array_like [m]
        Radius at ``P0``.
    P0 : array_like [Pa]
        Reference pressure.
    errors : {"nan", "raise"}
        What to do with a pressure the model cannot reach (``P >= max_pressure``):
        return NaN there (default) or raise ``ValueError``.

    Returns
    -------
    ndarray [m]
    """
    E0t, gamma, R0, P0 = _check(E0t, gamma, R0, P0)
    P = np.asarray(P, dtype=float)
    if np.any(~(P > 0)) or np.any(~np.isfinite(P)):
        raise ValueError(f"P must be finite and > 0 Pa, got {P[~((P > 0) & np.isfinite(P))].ravel()[0]!r}")
    P, E0t, gamma, R0, P0 = np.broadcast_arrays(P, E0t, gamma, R0, P0)
    p = P0 * R0 / E0t
    log_target = np.log(P / P0)
    s_end, _ = _branch_end(p, gamma)
    reachable = P < max_pressure(E0t, gamma, R0, P0)
    if errors == "raise" and not reachable.all():
        i = np.flatnonzero(~reachable.ravel())[0]
        raise ValueError(
            f"P = {P.ravel()[i]:.6g} Pa exceeds the largest pressure the wall model can bear "
            f"({max_pressure(E0t.ravel()[i], gamma.ravel()[i], R0.ravel()[i], P0.ravel()[i]):.6g} Pa "
            f"for E0t = {E0t.ravel()[i]:.4g} N/m, gamma = {gamma.ravel()[i]:.4g}, R0 = {R0.ravel()[i]:.4g} m)"
        )
    out = np.full(P.shape, np.nan)
    if reachable.any():
        args = (log_target[reachable], p[reachable], gamma[reachable])
        lo, hi = _bracket(*args, s_end[reachable])

        def residual(s, target, p_, g_):
            # NaN left of R0 is the zero-pressure side (gamma < 1): below any target; NaN
            # right of R0 is beyond the saturation radius (gamma > 1): above any target.
            val = _log_pressure_ratio(s, p_, g_)
            return np.where(np.isnan(val), np.where(s < 0, -np.inf, np.inf), val - target)

        res = elementwise.find_root(residual, (lo, hi), args=args, tolerances={"xatol": 1e-15, "xrtol": 4e-16})
        out[reachable] = R0[reachable] * np.exp(res.x)
    return out


def perp_modulus_times_thickness(P, E0t, gamma, P0=P0_DEFAULT):
    r"""Circumferential 2D modulus ``E_perp t`` at pressure ``P`` [N/m].

    .. math:: E_\perp t = E_0 t \,(P/P_0)^\gamma
    """
    P = np.asarray(P, dtype=float)
    return np.asarray(E0t, float) * (P / np.asarray(P0, float)) ** np.asarray(gamma, float)


def _reduced_modulus(sigma_hat, p, gamma):
    r""":math:`\hat E(\hat\sigma) = \hat\sigma^\gamma[1 - p\gamma(\hat\sigma^{1-\gamma}-1)/(1-\gamma)]`."""
    log_s = np.log(sigma_hat)
    # (s^(1-g) - 1)/(1-g) = ln(s) * expm1(z)/z with z = (1-g) ln s: no 0/0 at gamma = 1
    ratio = log_s * _expm1_ratio((1 - gamma) * log_s)
    return sigma_hat**gamma * (1 - p * gamma * ratio)


def anisotropy(P, E0t, gamma, R0, P0=P0_DEFAULT):
    r"""Axial over circumferential modulus ``E_par/E_perp`` of a stress-stiffening cylinder.

    Axial tension is half the circumferential one, so with
    :math:`\hat E(\hat\sigma) = \hat\sigma^\gamma[1 - \frac{p\gamma}{1-\gamma}(\hat\sigma^{1-\gamma}-1)]`:

    .. math::

        \frac{E_\parallel}{E_\perp}(P) = \frac{\hat E(\hat\sigma_c/2)}{\hat E(\hat\sigma_c)},
        \qquad \hat\sigma_c = \frac{P R_c(P)}{P_0 R_0}

    (SCIENCE.md section 4). Equals 1 at ``gamma = 0``.

    Parameters
    ----------
    P : array_like [Pa]
    E0t : array_like [N/m]
    gamma : array_like [-]
    R0 : array_like [m]
    P0 : array_like [Pa]

    Returns
    -------
    ndarray [-]
        NaN where the pressure is unreachable (see :func:`radius_at_pressure`).
    """
    R_c = radius_at_pressure(P, E0t, gamma, R0, P0)
    E0t, gamma, R0, P0 = _check(E0t, gamma, R0, P0)
    p = P0 * R0 / E0t
    s_c = np.asarray(P, float) * R_c / (P0 * R0)
    return _reduced_modulus(s_c / 2, p, gamma) / _reduced_modulus(s_c, p, gamma)
