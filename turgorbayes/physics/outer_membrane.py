r"""Cell radius and wall anisotropy when the outer membrane bears load beside the peptidoglycan.

Both 2D moduli of the envelope get a pressure-independent outer-membrane modulus ``Y_om`` [N/m]
on top of the stress-stiffening peptidoglycan (PG) of :mod:`turgorbayes.physics.wall` (Rojas et al.,
Nature 559, 617 (2018)). The pressure stays explicit in the radius,
:math:`P(R_c) = P_{wall}(R_c) + (Y_{om}/R_c)\ln(R_c/R_0)`; ``Y_om = 0`` gives
:mod:`turgorbayes.physics.wall` (derivation and domain: ``docs/outer_membrane.md``).
"""

import numpy as np
from scipy.optimize import elementwise

from turgorbayes.physics import wall
from turgorbayes.physics.parameters import P0 as P0_DEFAULT

__all__ = [
    "anisotropy",
    "envelope_at_pressure",
    "max_pressure",
    "outer_membrane_tension_fraction",
    "perp_modulus_times_thickness",
    "pressure_at_radius",
    "radius_at_pressure",
]

_SCAN_POINTS = 65  # grid for the (rare) search of a pressure maximum beyond the PG's own one
_TOL = {"xatol": 1e-15, "xrtol": 4e-16}


def _check(gamma, E0t, R0, Y_om, P0):
    gamma, E0t, R0, P0 = wall.check_parameters(gamma, E0t, R0, P0)
    Y_om = np.asarray(Y_om, dtype=float)
    if np.any(~(Y_om >= 0)) or np.any(~np.isfinite(Y_om)):
        bad = float(Y_om[~((Y_om >= 0) & np.isfinite(Y_om))].ravel()[0])
        raise ValueError(f"Y_om (outer-membrane 2D modulus) must be finite and >= 0 N/m, got {bad!r}")
    return gamma, E0t, R0, Y_om, P0


def _check_positive(name, x, unit):
    x = np.asarray(x, dtype=float)
    if np.any(~(x > 0)) or np.any(~np.isfinite(x)):
        bad = float(x[~((x > 0) & np.isfinite(x))].ravel()[0])
        raise ValueError(f"{name} must be finite and > 0 {unit}, got {bad!r}")
    return x


def _reduced_pg_modulus(log_tau, strain, gamma):
    r""":math:`\hat E = \tau^\gamma e^{-\gamma S(\tau)}` (the paper's :math:`\hat E(\tau)`)."""
    return np.exp(gamma * (log_tau - strain))


def _reduced_pressure(s, p, gamma, y):
    """``P/P0`` of the composite at strain ``s`` (may be < 0 below the zero-tension radius)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return (np.exp(wall.log_tension_ratio(s, p, gamma)) + y * s) * np.exp(-s)


def _stability_margin(s, p, gamma, y):
    """``(E_perp t_tot - P R)/(P0 R0)``: positive while the pressure still rises with the radius."""
    log_tau = wall.log_tension_ratio(s, p, gamma)
    with np.errstate(over="ignore", invalid="ignore"):
        modulus = _reduced_pg_modulus(log_tau, s, gamma) / p + y
        return modulus - np.exp(log_tau) - y * s


def _first_safe_end(p, gamma, E0t, R0, y, P0):
    """Strain up to which the composite surely rises: ``min(s_pg_end, 1)`` (PG and OM both rise).

    Returns ``(a, b, pg_diverges)`` with ``b = max(s_pg_end, 1)``.
    """
    s_pg = np.log(wall.max_radius(gamma, E0t, R0, P0) / R0)
    pg_diverges = np.isinf(wall.max_pressure(gamma, E0t, R0, P0))
    om = y > 0
    a = np.where(om, np.minimum(s_pg, 1.0), s_pg)  # the OM term y s e^{-s} peaks at s = 1
    # past a saturation radius below s = 1 there is nothing left to search
    b = np.where(om & ~(pg_diverges & (s_pg <= 1.0)), np.maximum(s_pg, 1.0), a)
    return a, b, pg_diverges


def _scan_end(a, b, p, gamma, y, pg_diverges):
    """First zero of the stability margin in ``[a, b]`` (1-D arrays); ``(s_end, diverges)``."""
    frac = np.linspace(0.0, 1.0, _SCAN_POINTS)
    grid = a[:, None] + (b - a)[:, None] * frac
    grid[:, -1] = np.where(pg_diverges, b - 1e-12 * np.maximum(1.0, np.abs(b)), b)
    with np.errstate(invalid="ignore"):
        margin = _stability_margin(grid, p[:, None], gamma[:, None], y[:, None])
    negative = margin <= 0
    found = negative.any(axis=1)
    j = np.where(found, np.argmax(negative, axis=1), 1)
    rows = np.arange(a.size)
    lo, hi = grid[rows, np.maximum(j - 1, 0)], grid[rows, j]
    s_end = b.copy()  # not found: the PG saturates at b (a sign change at b is otherwise certain)
    if found.any():
        res = elementwise.find_root(
            _stability_margin, (lo[found], hi[found]), args=(p[found], gamma[found], y[found]), tolerances=_TOL
        )
        s_end[found] = res.x
    return s_end, ~found & pg_diverges


def _branch_end(gamma, E0t, R0, Y_om, P0):
    """End of the rising branch ``(s_end, diverges)`` on the (broadcast) parameter arrays."""
    shape = np.broadcast_shapes(*(np.shape(v) for v in (E0t, gamma, R0, Y_om, P0)))
    E0t, gamma, R0, Y_om, P0 = (v.ravel() for v in np.broadcast_arrays(E0t, gamma, R0, Y_om, P0))
    p, y = P0 * R0 / E0t, Y_om / (P0 * R0)
    a, b, pg_diverges = _first_safe_end(p, gamma, E0t, R0, y, P0)
    s_end, diverges = a.copy(), pg_diverges.copy()
    scan = (y > 0) & (b > a)
    if scan.any():
        s_scan, div_scan = _scan_end(a[scan], b[scan], p[scan], gamma[scan], y[scan], pg_diverges[scan])
        s_end[scan], diverges[scan] = s_scan, div_scan
    return s_end.reshape(shape), diverges.reshape(shape)


def pressure_at_radius(R_c, gamma, E0t, R0, Y_om, P0=P0_DEFAULT):
    r"""Pressure at which the PG + outer-membrane envelope has radius ``R_c`` (explicit).

    .. math::

        P(R_c) = P_{wall}(R_c; E_0t, \gamma, R_0) + \frac{Y_{om}}{R_c}\ln\frac{R_c}{R_0}

    with :math:`P_{wall}` the stress-stiffening PG of :func:`turgorbayes.physics.wall.pressure_at_radius`
    (module docstring; ``docs/outer_membrane.md``).

    Parameters
    ----------
    R_c : array_like [m]
        Cell radius, > 0.
    gamma : array_like [-]
        PG stress-stiffening exponent.
    E0t : array_like [N/m]
        PG modulus times thickness at PG tension ``P0 R0`` (``E_0 t``).
    R0 : array_like [m]
        Radius at ``P0`` (the OM is stress-free there).
    Y_om : array_like [N/m]
        Outer-membrane 2D modulus (``Y_om``), >= 0, pressure-independent.
    P0 : array_like [Pa]
        Reference pressure.

    Returns
    -------
    ndarray [Pa]
        Negative below the zero-tension radius; NaN where the PG closed form is undefined:
        beyond its saturation radius (``gamma > 1``) or where the PG would be slack
        (``gamma < 1``, far below ``R0``, where the pressure would be negative anyway). Radii
        past the pressure maximum return the falling pressure of the formula;
        :func:`max_pressure` marks the end of the physical branch.
    """
    gamma, E0t, R0, Y_om, P0 = _check(gamma, E0t, R0, Y_om, P0)
    R_c = _check_positive("R_c", R_c, "m")
    s = np.log(R_c / R0)
    return P0 * _reduced_pressure(s, P0 * R0 / E0t, gamma, Y_om / (P0 * R0))


def max_pressure(gamma, E0t, R0, Y_om, P0=P0_DEFAULT):
    """Largest pressure on the physical branch [Pa]; ``inf`` where the radius saturates.

    Parameters
    ----------
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    Y_om : array_like [N/m]
    P0 : array_like [Pa]

    Returns
    -------
    ndarray [Pa]
    """
    gamma, E0t, R0, Y_om, P0 = _check(gamma, E0t, R0, Y_om, P0)
    s_end, diverges = _branch_end(gamma, E0t, R0, Y_om, P0)
    E0t, gamma, R0, Y_om, P0 = np.broadcast_arrays(E0t, gamma, R0, Y_om, P0)
    finite = np.isfinite(s_end) & ~diverges
    peak = _reduced_pressure(np.where(finite, s_end, 0.0), P0 * R0 / E0t, gamma, Y_om / (P0 * R0))
    return np.where(finite, P0 * peak, np.inf)


def _lower_bracket(target, s_hi, p, gamma, y):
    """A strain below the root: the composite pressure there is below ``target`` (or NaN/negative)."""
    lo = np.minimum(np.log(target), 0.0) - 1.0
    lo = np.minimum(lo, np.where(np.isfinite(s_hi), s_hi - 1e-12, lo))
    for _ in range(200):
        low_enough = ~(_reduced_pressure(lo, p, gamma, y) >= target)  # NaN: PG slack, counts as low
        if low_enough.all():
            break
        lo = np.where(low_enough, lo, 2 * lo - 1)
    return lo


def _solve_strain(target, lo, hi, p, gamma, y):
    """Strain ``s`` in ``[lo, hi]`` with composite ``P/P0 = target`` (flat arrays)."""

    def residual(s, t, p_, g_, y_):
        val = _reduced_pressure(s, p_, g_, y_) / t - 1.0
        # NaN left of R0 is the slack PG (gamma < 1): below any target; NaN on the right is past
        # the saturation radius: above any target.
        return np.where(np.isnan(val), np.where(s < 0, -np.inf, np.inf), val)

    res = elementwise.find_root(residual, (lo, hi), args=(target, p, gamma, y), tolerances=_TOL)
    return res.x


def _strain_at_pressure(P, gamma, E0t, R0, Y_om, P0, errors):
    """Flat solve of the composite strain ``ln(R_c/R0)`` at ``P`` (all arrays broadcast)."""
    P, E0t, gamma, R0, Y_om, P0 = (a.ravel() for a in np.broadcast_arrays(P, E0t, gamma, R0, Y_om, P0))
    p, y, target = P0 * R0 / E0t, Y_om / (P0 * R0), P / P0
    a, _, pg_diverges = _first_safe_end(p, gamma, E0t, R0, y, P0)
    top = _reduced_pressure(a, p, gamma, y)
    top = np.where(np.isnan(top), np.inf, top)  # a at the saturation radius: P -> infinity
    s_hi = a.copy()
    beyond = ~(target < top)  # only these need the search beyond the PG's own branch end
    reachable = ~beyond
    if beyond.any():
        s_end, diverges = _branch_end(gamma[beyond], E0t[beyond], R0[beyond], Y_om[beyond], P0[beyond])
        peak = _reduced_pressure(np.where(diverges, 0.0, s_end), p[beyond], gamma[beyond], y[beyond])
        reachable[beyond] = diverges | (target[beyond] < peak)
        s_hi[beyond] = s_end
    if errors == "raise" and not reachable.all():
        i = np.flatnonzero(~reachable)[0]
        P_max = max_pressure(gamma[i], E0t[i], R0[i], Y_om[i], P0[i])
        raise ValueError(
            f"P = {P[i]:.6g} Pa exceeds the largest pressure the PG + outer-membrane model can bear "
            f"({P_max:.6g} Pa for E0t = {E0t[i]:.4g} N/m, gamma = {gamma[i]:.4g}, R0 = {R0[i]:.4g} m, "
            f"Y_om = {Y_om[i]:.4g} N/m)"
        )
    s = np.full(P.shape, np.nan)
    if reachable.any():
        args = (target[reachable], p[reachable], gamma[reachable], y[reachable])
        lo = _lower_bracket(args[0], s_hi[reachable], *args[1:])
        s[reachable] = _solve_strain(args[0], lo, s_hi[reachable], *args[1:])
    return s


def radius_at_pressure(P, gamma, E0t, R0, Y_om, P0=P0_DEFAULT, errors="nan"):
    r"""Radius of the PG + outer-membrane envelope at pressure ``P`` (inverse of :func:`pressure_at_radius`).

    Solves :math:`P_{wall}(R_c) + (Y_{om}/R_c)\ln(R_c/R_0) = P` on the rising branch with scipy's
    vectorized bracketed root finder, to about 1e-14 relative in ``R_c``. The branch end beyond
    the PG's own one is searched only for pressures that need it. ``Y_om = 0`` gives
    :func:`turgorbayes.physics.wall.radius_at_pressure`; ``gamma = 0`` gives the Lambert-W closed form
    :math:`R_c = -\frac{B}{P}W_0\!\left(-\frac{PR_0}{B}e^{-P_0R_0/B}\right)`, :math:`B = E_0t + Y_{om}`.

    Parameters
    ----------
    P : array_like [Pa]
        Pressure, > 0.
    gamma : array_like [-]
        PG stress-stiffening exponent.
    E0t : array_like [N/m]
        PG ``E_0 t`` at PG tension ``P0 R0``.
    R0 : array_like [m]
        Radius at ``P0``.
    Y_om : array_like [N/m]
        Outer-membrane 2D modulus, >= 0.
    P0 : array_like [Pa]
        Reference pressure.
    errors : {"nan", "raise"}
        What to do with a pressure at or above :func:`max_pressure` (past the inflation
        instability): NaN there (default) or ``ValueError``.

    Returns
    -------
    ndarray [m]
        Shape: the broadcast of all arguments.
    """
    if errors not in ("nan", "raise"):
        raise ValueError(f"errors must be 'nan' or 'raise', got {errors!r}")
    gamma, E0t, R0, Y_om, P0 = _check(gamma, E0t, R0, Y_om, P0)
    P = _check_positive("P", P, "Pa")
    shape = np.broadcast_shapes(P.shape, E0t.shape, gamma.shape, R0.shape, Y_om.shape, P0.shape)
    s = _strain_at_pressure(P, gamma, E0t, R0, Y_om, P0, errors).reshape(shape)
    return R0 * np.exp(s)


def _state_at_pressure(P, gamma, E0t, R0, Y_om, P0):
    """``(s, log_tau_perp, p, y, sigma_c)`` at pressure P; ``sigma_c = P R_c/(P0 R0)``."""
    gamma, E0t, R0, Y_om, P0 = _check(gamma, E0t, R0, Y_om, P0)
    P = _check_positive("P", P, "Pa")
    shape = np.broadcast_shapes(P.shape, E0t.shape, gamma.shape, R0.shape, Y_om.shape, P0.shape)
    s = _strain_at_pressure(P, gamma, E0t, R0, Y_om, P0, "nan").reshape(shape)
    p, y = P0 * R0 / E0t, Y_om / (P0 * R0)
    return s, wall.log_tension_ratio(s, p, gamma), p, y, P / P0 * np.exp(s)


def perp_modulus_times_thickness(P, gamma, E0t, R0, Y_om, P0=P0_DEFAULT):
    r"""Total circumferential 2D modulus ``E_perp t`` of the envelope at pressure ``P`` [N/m].

    .. math::

        E_\perp t = E_0t\left(\frac{P_{wall}(R_c)}{P_0}\right)^\gamma + Y_{om},
        \qquad P_{wall}(R_c) = T_{pg,\perp}/R_c

    -- the PG stiffens with the share of the pressure it carries; ``Y_om = 0`` gives
    :math:`E_0t(P/P_0)^\gamma` (:func:`turgorbayes.physics.wall.perp_modulus_times_thickness`).

    Parameters
    ----------
    P : array_like [Pa]
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    Y_om : array_like [N/m]
    P0 : array_like [Pa]

    Returns
    -------
    ndarray [N/m]
        NaN where the pressure is unreachable (see :func:`radius_at_pressure`).
    """
    s, log_tau, p, y, _ = _state_at_pressure(P, gamma, E0t, R0, Y_om, P0)
    return np.asarray(E0t, float) * _reduced_pg_modulus(log_tau, s, np.asarray(gamma, float)) + np.asarray(Y_om, float)


def _axial_pg_tension(sigma_c, p, gamma, y):
    r"""Axial PG tension :math:`\tau_\parallel` [P0 R0]: root of
    :math:`\tau + y[S(\tau) - S(1/2)] = \hat\sigma_c/2`, bracketed by 1/2 and ``sigma_c/2``."""
    sigma_c, p, gamma, y = (a.ravel() for a in np.broadcast_arrays(sigma_c, p, gamma, y))
    out = np.full(sigma_c.shape, np.nan)
    ok = np.isfinite(sigma_c)
    if not ok.any():
        return out
    sigma_c, p, gamma, y = sigma_c[ok], p[ok], gamma[ok], y[ok]
    half = wall.strain_at_tension(np.full(sigma_c.shape, 0.5), p, gamma)

    def residual(tau, target, p_, g_, y_, s_half):
        val = tau + y_ * (wall.strain_at_tension(tau, p_, g_) - s_half) - target
        return np.where(np.isnan(val), np.inf, val)  # a tension the PG never reaches: too high

    lo, hi = np.minimum(0.5, sigma_c / 2), np.maximum(0.5, sigma_c / 2)
    res = elementwise.find_root(residual, (lo, hi), args=(sigma_c / 2, p, gamma, y, half), tolerances=_TOL)
    out[ok] = res.x
    return out


def anisotropy(P, gamma, E0t, R0, Y_om, P0=P0_DEFAULT):
    r"""Total axial over circumferential modulus ``E_par/E_perp`` of the PG + OM envelope.

    .. math::

        \frac{E_\parallel}{E_\perp} = \frac{E_0t\,\hat E(\tau_\parallel) + Y_{om}}
        {E_0t\,\hat E(\tau_\perp) + Y_{om}}

    with :math:`\tau_\perp` the circumferential PG tension and :math:`\tau_\parallel` the root of
    :math:`\tau + y[S(\tau) - S(1/2)] = PR_c/(2P_0R_0)` (module docstring; the axial strain is
    shared by both layers, the OM is stress-free at ``R0``, ``P0``). ``Y_om = 0`` gives the
    paper's :math:`\hat E(\hat\sigma_c/2)/\hat E(\hat\sigma_c)`
    (:func:`turgorbayes.physics.wall.anisotropy`); ``gamma = 0`` gives 1.

    Parameters
    ----------
    P : array_like [Pa]
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    Y_om : array_like [N/m]
    P0 : array_like [Pa]

    Returns
    -------
    ndarray [-]
        NaN where the pressure is unreachable (see :func:`radius_at_pressure`).
    """
    return envelope_at_pressure(P, gamma, E0t, R0, Y_om, P0)[2]


def envelope_at_pressure(P, gamma, E0t, R0, Y_om, P0=P0_DEFAULT):
    """Radius, total ``E_perp t`` and ``E_par/E_perp`` at ``P`` from one radius solve.

    The same values as :func:`radius_at_pressure`, :func:`perp_modulus_times_thickness` and
    :func:`anisotropy` (see those for the equations), for a forward model that needs all three:
    the radius root search runs once instead of three times.

    Parameters
    ----------
    P : array_like [Pa]
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    Y_om : array_like [N/m]
    P0 : array_like [Pa]

    Returns
    -------
    R_c : ndarray [m]
    E_perp_t : ndarray [N/m]
    ratio : ndarray [-]
        NaN where the pressure is unreachable.
    """
    s, log_tau, p, y, sigma_c = _state_at_pressure(P, gamma, E0t, R0, Y_om, P0)
    gamma, E0t, Y_om, R0 = (np.broadcast_to(np.asarray(v, float), s.shape) for v in (gamma, E0t, Y_om, R0))
    p, y = np.broadcast_to(p, s.shape), np.broadcast_to(y, s.shape)
    E_perp = E0t * _reduced_pg_modulus(log_tau, s, gamma) + Y_om
    tau_par = _axial_pg_tension(sigma_c, p, gamma, y).reshape(s.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        E_par = E0t * _reduced_pg_modulus(np.log(tau_par), wall.strain_at_tension(tau_par, p, gamma), gamma) + Y_om
    return R0 * np.exp(s), E_perp, E_par / E_perp


def outer_membrane_tension_fraction(P, gamma, E0t, R0, Y_om, P0=P0_DEFAULT):
    r"""Fraction of the circumferential tension ``P R_c`` carried by the outer membrane [-].

    .. math:: f_{om} = \frac{Y_{om}\ln(R_c/R_0)}{P R_c}

    Zero at ``P0`` (the OM is stress-free at the reference state), negative below it.

    Parameters
    ----------
    P : array_like [Pa]
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    Y_om : array_like [N/m]
    P0 : array_like [Pa]

    Returns
    -------
    ndarray [-]
    """
    s, _, _, y, sigma_c = _state_at_pressure(P, gamma, E0t, R0, Y_om, P0)
    return y * s / sigma_c
