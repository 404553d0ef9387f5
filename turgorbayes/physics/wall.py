r"""Cell radius and wall anisotropy under pressure, with power-law stress stiffening.

The wall law of Deng, Sun & Shaevitz, PRL 107, 158101 (2011): circumferential tension
``P R_c``, tangent modulus ``E_perp t = E0t (P/P0)^gamma``, ``R0`` the radius at ``P0``; the
pressure is explicit in the radius and the radius is found on the branch where ``P`` rises
with ``R_c`` (``docs/physics.md``, "Wall law" and "Domain of the wall law"). The low-level
kernel in reduced variables is used by :mod:`turgorbayes.physics.forward` and
:mod:`turgorbayes.physics.outer_membrane` too.
"""

import numpy as np
from scipy.optimize import elementwise

from turgorbayes.physics import parameters

__all__ = [
    "P0_DEFAULT",
    "anisotropy",
    "anisotropy_at_tension",
    "check_parameters",
    "expm1_ratio",
    "log1p_ratio",
    "log_modulus_bracket",
    "log_pressure_and_slope",
    "log_pressure_ratio",
    "log_tension_ratio",
    "max_pressure",
    "max_radius",
    "perp_modulus_times_thickness",
    "pressure_at_radius",
    "radius_at_pressure",
    "reduced_branch_end",
    "strain_at_tension",
]

P0_DEFAULT = parameters.P0  # Pa, the paper's reference pressure


# ---------------------------------------------------------------------------------------------
# Kernel: the wall law in reduced variables s = ln(R_c/R0), p = P0 R0/E0t, tension tau in P0 R0.
# Everything broadcasts; NaN (never a warning) where the law is undefined.
# ---------------------------------------------------------------------------------------------


def log1p_ratio(z):
    """``log1p(z)/z``, exact at ``z = 0`` (no 0/0 at ``gamma = 1``).

    Parameters
    ----------
    z : array_like [-]

    Returns
    -------
    ndarray [-]
    """
    z = np.asarray(z, dtype=float)
    small = np.abs(z) < 1e-8
    safe = np.where(small, 1.0, z)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(small, 1.0 - z / 2 + z * z / 3, np.log1p(safe) / safe)


def expm1_ratio(z):
    """``expm1(z)/z``, exact at ``z = 0``.

    Parameters
    ----------
    z : array_like [-]

    Returns
    -------
    ndarray [-]
    """
    z = np.asarray(z, dtype=float)
    small = np.abs(z) < 1e-8
    safe = np.where(small, 1.0, z)
    with np.errstate(over="ignore"):
        return np.where(small, 1.0 + z / 2 + z * z / 6, np.expm1(safe) / safe)


def _tension_and_bracket(s, p, gamma):
    """``(ln tau, B)`` at strain ``s``; ``ln tau`` is NaN where the bracket ``B <= 0``."""
    with np.errstate(over="ignore", invalid="ignore"):
        u = -s * expm1_ratio(-gamma * s) / p  # (rho^gamma - 1)/(gamma p), finite at gamma = 0
        z = (gamma - 1) * u
        bracket = 1 + z
        ok = bracket > 0
        log_tau = np.where(ok, -u * log1p_ratio(np.where(ok, z, 0.0)), np.nan)
    return log_tau, bracket


def log_tension_ratio(s, p, gamma):
    r"""``ln tau``: log wall tension ``P R_c/(P_0 R_0)`` at strain ``s = ln(R_c/R_0)``.

    .. math:: \tau = B^{1/(1-\gamma)},\quad
              B = 1 + \frac{(\gamma-1)(\rho^\gamma - 1)}{\gamma p},\quad \rho = e^{-s}

    written with :func:`log1p_ratio` and :func:`expm1_ratio` so that it is finite at
    ``gamma = 0`` and continuous through ``gamma = 1`` (where :math:`\ln\tau = (1-\rho)/p`).

    Parameters
    ----------
    s : array_like [-]
        ``ln(R_c/R0)``.
    p : array_like [-]
        ``P0 R0/E0t``.
    gamma : array_like [-]
        Stress-stiffening exponent, >= 0.

    Returns
    -------
    ndarray [-]
        NaN where ``B <= 0`` (beyond the saturation radius, or a slack wall for ``gamma < 1``).
    """
    return _tension_and_bracket(s, p, gamma)[0]


def log_pressure_ratio(s, p, gamma):
    r"""``ln(P/P_0) = ln tau - s`` at strain ``s = ln(R_c/R_0)`` (see :func:`log_tension_ratio`).

    Parameters
    ----------
    s, p, gamma : array_like [-]
        As in :func:`log_tension_ratio`.

    Returns
    -------
    ndarray [-]
        NaN where the bracket is not positive.
    """
    return -s + log_tension_ratio(s, p, gamma)


def log_pressure_and_slope(s, p, gamma):
    r"""``ln(P/P_0)`` and ``d ln P/d s`` at ``s = ln(R_c/R_0)``.

    .. math:: \ln\frac{P}{P_0} = -s + \frac{\ln B}{1-\gamma},\qquad
              \frac{d\ln P}{ds} = -1 + \frac{\rho^\gamma}{pB}

    Parameters
    ----------
    s, p, gamma : array_like [-]
        As in :func:`log_tension_ratio`.

    Returns
    -------
    log_p : ndarray [-]
    slope : ndarray [-]
        Both NaN where the bracket ``B`` is not positive.
    """
    log_tau, bracket = _tension_and_bracket(s, p, gamma)
    ok = bracket > 0
    with np.errstate(over="ignore", invalid="ignore"):
        slope = np.where(ok, -1 + np.exp(-gamma * s) / (p * np.where(ok, bracket, 1.0)), np.nan)
    return -s + log_tau, slope


def reduced_branch_end(p, gamma):
    r"""End of the rising branch: ``(s_end, ln(P_max/P_0))``.

    The branch ends where the bracket vanishes (``gamma > 1`` and ``gamma p < gamma - 1``:
    :math:`\rho^\gamma = 1 - \gamma p/(\gamma-1)`, the radius saturates, ``ln P_max = inf``)
    or else at the pressure maximum :math:`\rho^\gamma = 1 + \gamma(p-1)` (``s_end = 1 - p``
    at ``gamma = 0``). ``s_end = inf`` (and ``ln P_max = inf``) where the branch has no end.

    Parameters
    ----------
    p, gamma : array_like [-]
        ``P0 R0/E0t`` and the stiffening exponent.

    Returns
    -------
    s_end : ndarray [-]
    log_p_max : ndarray [-]
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        gm1 = np.where(gamma > 1, gamma - 1, 1.0)
        y_zero = np.where(gamma > 1, 1 - gamma * p / gm1, -1.0)
        diverges = y_zero > 0
        # peak where rho^gamma = 1 + gamma (p - 1); ln of it over gamma, continuous at gamma = 0
        log_y_peak = gamma * (p - 1) * log1p_ratio(gamma * (p - 1))
        log_y_end = np.where(diverges, np.log(np.where(diverges, y_zero, 1.0)), log_y_peak)
        has_end = diverges | (1 + gamma * (p - 1) > 0)
        s_end = np.where(has_end, -np.where(gamma > 0, log_y_end / np.where(gamma > 0, gamma, 1),
                                            p - 1), np.inf)
        log_p_end, _ = log_pressure_and_slope(np.where(np.isfinite(s_end), s_end, 0.0), p, gamma)
        log_p_max = np.where(diverges | ~np.isfinite(s_end), np.inf, log_p_end)
    return s_end, log_p_max


def strain_at_tension(tau, p, gamma):
    r"""Strain ``S(tau) = ln(R_c/R_0)`` at which the wall tension reaches ``tau`` [P0 R0].

    The inverse of :func:`log_tension_ratio`:

    .. math:: S = -\frac{1}{\gamma}\ln\left[1 - \frac{p\gamma}{1-\gamma}(\tau^{1-\gamma}-1)\right]

    finite at ``gamma = 0`` (``S = p ln tau``) and ``gamma = 1``.

    Parameters
    ----------
    tau : array_like [-]
        Tension in units of ``P0 R0``.
    p, gamma : array_like [-]

    Returns
    -------
    ndarray [-]
        NaN where the bracket is not positive (a tension the wall never reaches).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        log_tau = np.log(tau)
        v = log_tau * expm1_ratio((1 - gamma) * log_tau)  # (tau^(1-gamma) - 1)/(1 - gamma)
        q = -p * gamma * v
        out = p * v * log1p_ratio(q)
    return np.where((q > -1) & (tau > 0), out, np.nan)


def log_modulus_bracket(log_sigma, p, gamma):
    r"""``ln`` of the bracket of the reduced tangent modulus, :math:`\ln[\hat E(\sigma)/\sigma^\gamma]`.

    .. math:: \hat E(\sigma) = \sigma^\gamma\left[1 - \frac{p\gamma}{1-\gamma}
              (\sigma^{1-\gamma}-1)\right]

    the modulus (in ``E0t``) at tension ``sigma`` [P0 R0].

    Parameters
    ----------
    log_sigma : array_like [-]
        ``ln sigma``.
    p, gamma : array_like [-]

    Returns
    -------
    ndarray [-]
        NaN where the bracket is not positive.
    """
    bracket = 1 - p * gamma * log_sigma * expm1_ratio((1 - gamma) * log_sigma)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(bracket > 0, np.log(np.where(bracket > 0, bracket, 1.0)), np.nan)


def anisotropy_at_tension(log_sigma_c, p, gamma):
    r"""``E_par/E_perp`` at circumferential tension ``sigma_c`` [P0 R0] (axial tension is half).

    .. math:: \frac{E_\parallel}{E_\perp} = \frac{\hat E(\sigma_c/2)}{\hat E(\sigma_c)}

    Parameters
    ----------
    log_sigma_c : array_like [-]
        ``ln(P R_c/(P0 R0))``.
    p, gamma : array_like [-]

    Returns
    -------
    ndarray [-]
        NaN where either modulus is not positive.
    """
    log_ratio = (-gamma * np.log(2.0) + log_modulus_bracket(log_sigma_c - np.log(2.0), p, gamma)
                 - log_modulus_bracket(log_sigma_c, p, gamma))
    return np.exp(log_ratio)


# ---------------------------------------------------------------------------------------------
# Physical API
# ---------------------------------------------------------------------------------------------


def check_parameters(gamma, E0t, R0, P0):
    """Validate wall parameters; return them as float arrays.

    Parameters
    ----------
    gamma : array_like [-]
        Finite and >= 0.
    E0t : array_like [N/m]
        Finite and > 0.
    R0 : array_like [m]
        Finite and > 0.
    P0 : array_like [Pa]
        Finite and > 0.

    Returns
    -------
    tuple of ndarray
        ``(gamma, E0t, R0, P0)``, in the order of the arguments.

    Raises
    ------
    ValueError
        Naming the first offending value.
    """
    E0t, gamma, R0, P0 = (np.asarray(v, dtype=float) for v in (E0t, gamma, R0, P0))
    for name, v, unit in (("E0t", E0t, "N/m"), ("R0", R0, "m"), ("P0", P0, "Pa")):
        if np.any(~(v > 0)) or np.any(~np.isfinite(v)):
            bad = v[~((v > 0) & np.isfinite(v))].ravel()[0]
            raise ValueError(f"{name} must be finite and > 0 {unit}, got {bad!r}")
    if np.any(~(gamma >= 0)) or np.any(~np.isfinite(gamma)):
        bad = gamma[~((gamma >= 0) & np.isfinite(gamma))].ravel()[0]
        raise ValueError(f"gamma (stiffening exponent) must be finite and >= 0, got {bad!r}")
    return gamma, E0t, R0, P0


def pressure_at_radius(R_c, gamma, E0t, R0, P0=P0_DEFAULT):
    r"""Pressure at which the stress-stiffening wall has radius ``R_c`` (explicit).

    .. math::

        \frac{P}{P_0} = \frac{R_0}{R_c}\left[\frac{(\gamma-1)E_0t}{\gamma P_0R_0}
        \left(\left(\frac{R_0}{R_c}\right)^\gamma-1\right)+1\right]^{1/(1-\gamma)}

    (``docs/physics.md``, "Wall law"), evaluated through ``log1p`` so that it is continuous through
    ``gamma = 1``, where it becomes :math:`(R_0/R_c)\exp[(E_0t/P_0R_0)(1-R_0/R_c)]`.

    Parameters
    ----------
    R_c : array_like [m]
        Cell radius, > 0.
    gamma : array_like [-]
        Stress-stiffening exponent, ``E_perp = E_0 (P/P_0)^gamma``.
    E0t : array_like [N/m]
        Circumferential modulus times wall thickness at ``P0`` (``E_0 t``).
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
    gamma, E0t, R0, P0 = check_parameters(gamma, E0t, R0, P0)
    R_c = np.asarray(R_c, dtype=float)
    if np.any(~(R_c > 0)):
        raise ValueError(f"R_c must be > 0 m, got {R_c[~(R_c > 0)].ravel()[0]!r}")
    p = P0 * R0 / E0t
    return P0 * np.exp(log_pressure_ratio(np.log(R_c / R0), p, gamma))


def max_radius(gamma, E0t, R0, P0=P0_DEFAULT):
    """Largest radius on the physical branch [m].

    For ``gamma > 1`` and ``gamma p < gamma - 1`` this is the saturation radius ``R_max``
    approached as ``P -> infinity``; otherwise it is the radius at the pressure maximum.

    Parameters
    ----------
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    P0 : array_like [Pa]

    Returns
    -------
    ndarray [m]
    """
    gamma, E0t, R0, P0 = check_parameters(gamma, E0t, R0, P0)
    s_end, _ = reduced_branch_end(P0 * R0 / E0t, gamma)
    return R0 * np.exp(s_end)


def max_pressure(gamma, E0t, R0, P0=P0_DEFAULT):
    """Largest pressure the wall model can reach [Pa]; ``inf`` where the radius saturates.

    Parameters
    ----------
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    P0 : array_like [Pa]

    Returns
    -------
    ndarray [Pa]
    """
    gamma, E0t, R0, P0 = check_parameters(gamma, E0t, R0, P0)
    _, log_p_max = reduced_branch_end(P0 * R0 / E0t, gamma)
    return P0 * np.exp(log_p_max)


def _bracket(log_target, p, gamma, s_end):
    """A bracket ``[lo, hi]`` in ``s`` with ``ln P(lo) < target < ln P(hi)`` on the branch."""
    # ln P/P0 = -s + ... is below any target far enough to the left (P -> 0 as s -> -inf or at
    # the zero-pressure radius), and the branch end is above every reachable target.
    lo = np.minimum(log_target, 0.0) - 1.0
    lo = np.where(np.isfinite(s_end), np.minimum(lo, s_end - 1e-12), lo)
    for _ in range(200):
        val = log_pressure_ratio(lo, p, gamma)
        low_enough = ~(val >= log_target)  # NaN (zero-pressure side, gamma < 1) counts as low
        if low_enough.all():
            break
        lo = np.where(low_enough, lo, 2 * lo - 1)
    hi = np.where(np.isfinite(s_end), s_end, np.maximum(log_target, 0.0) + 1.0)
    for _ in range(200):
        val = log_pressure_ratio(hi, p, gamma)
        grow = ~(val >= log_target) & ~np.isfinite(s_end)
        if not grow.any():
            break
        hi = np.where(grow, 2 * hi + 1, hi)
    return lo, hi


def radius_at_pressure(P, gamma, E0t, R0, P0=P0_DEFAULT, errors="nan"):
    r"""Radius of the stress-stiffening wall at pressure ``P`` (inverse of :func:`pressure_at_radius`).

    Solves ``pressure_at_radius(R_c) = P`` on the rising branch (``docs/physics.md``, "Domain
    of the wall law") with scipy's vectorized bracketed root finder
    (``scipy.optimize.elementwise.find_root``), to about 1e-14 relative in ``R_c``. Continuous through ``gamma = 1``.

    Parameters
    ----------
    P : array_like [Pa]
        Pressure, > 0.
    gamma : array_like [-]
        Stress-stiffening exponent.
    E0t : array_like [N/m]
        ``E_0 t`` at ``P0``.
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
    gamma, E0t, R0, P0 = check_parameters(gamma, E0t, R0, P0)
    P = np.asarray(P, dtype=float)
    if np.any(~(P > 0)) or np.any(~np.isfinite(P)):
        raise ValueError(f"P must be finite and > 0 Pa, got {P[~((P > 0) & np.isfinite(P))].ravel()[0]!r}")
    P, E0t, gamma, R0, P0 = np.broadcast_arrays(P, E0t, gamma, R0, P0)
    p = P0 * R0 / E0t
    log_target = np.log(P / P0)
    s_end, _ = reduced_branch_end(p, gamma)
    reachable = P < max_pressure(gamma, E0t, R0, P0)
    if errors == "raise" and not reachable.all():
        i = np.flatnonzero(~reachable.ravel())[0]
        raise ValueError(
            f"P = {P.ravel()[i]:.6g} Pa exceeds the largest pressure the wall model can bear "
            f"({max_pressure(gamma.ravel()[i], E0t.ravel()[i], R0.ravel()[i], P0.ravel()[i]):.6g} Pa "
            f"for E0t = {E0t.ravel()[i]:.4g} N/m, gamma = {gamma.ravel()[i]:.4g}, R0 = {R0.ravel()[i]:.4g} m)"
        )
    out = np.full(P.shape, np.nan)
    if reachable.any():
        args = (log_target[reachable], p[reachable], gamma[reachable])
        lo, hi = _bracket(*args, s_end[reachable])

        def residual(s, target, p_, g_):
            # NaN left of R0 is the zero-pressure side (gamma < 1): below any target; NaN
            # right of R0 is beyond the saturation radius (gamma > 1): above any target.
            val = log_pressure_ratio(s, p_, g_)
            return np.where(np.isnan(val), np.where(s < 0, -np.inf, np.inf), val - target)

        res = elementwise.find_root(residual, (lo, hi), args=args, tolerances={"xatol": 1e-15, "xrtol": 4e-16})
        out[reachable] = R0[reachable] * np.exp(res.x)
    return out


def perp_modulus_times_thickness(P, gamma, E0t, P0=P0_DEFAULT):
    r"""Circumferential 2D modulus ``E_perp t`` at pressure ``P`` [N/m].

    .. math:: E_\perp t = E_0 t \,(P/P_0)^\gamma
    """
    P = np.asarray(P, dtype=float)
    return np.asarray(E0t, float) * (P / np.asarray(P0, float)) ** np.asarray(gamma, float)


def anisotropy(P, gamma, E0t, R0, P0=P0_DEFAULT):
    r"""Axial over circumferential modulus ``E_par/E_perp`` of a stress-stiffening cylinder.

    Axial tension is half the circumferential one, so with
    :math:`\hat E(\hat\sigma) = \hat\sigma^\gamma[1 - \frac{p\gamma}{1-\gamma}(\hat\sigma^{1-\gamma}-1)]`:

    .. math::

        \frac{E_\parallel}{E_\perp}(P) = \frac{\hat E(\hat\sigma_c/2)}{\hat E(\hat\sigma_c)},
        \qquad \hat\sigma_c = \frac{P R_c(P)}{P_0 R_0}

    (``docs/physics.md``, "Anisotropy"). Equals 1 at ``gamma = 0``.

    Parameters
    ----------
    P : array_like [Pa]
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    P0 : array_like [Pa]

    Returns
    -------
    ndarray [-]
        NaN where the pressure is unreachable (see :func:`radius_at_pressure`).
    """
    R_c = radius_at_pressure(P, gamma, E0t, R0, P0)
    gamma, E0t, R0, P0 = check_parameters(gamma, E0t, R0, P0)
    p = P0 * R0 / E0t
    s_c = np.asarray(P, float) * R_c / (P0 * R0)
    return anisotropy_at_tension(np.log(s_c), p, gamma)
