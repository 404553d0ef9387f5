r"""Forward model: radius and indentation stiffness of a pressurized, stress-stiffening cell.

``R_c(P)`` inverts the wall law of :mod:`turgorbayes.physics.wall`, then
``k_c = f(P R_c/E_perp t, E_par/E_perp) P R_c`` with ``f`` the finite-element surrogate
(``docs/physics.md``, "Forward model"). Everything broadcasts; where the model is undefined the
outputs are NaN and :func:`explain_nan` says why. The radius is found by a safeguarded Newton
iteration (about 100x faster than :func:`turgorbayes.physics.wall.radius_at_pressure`, same answer).
"""

import numpy as np

from turgorbayes import surrogate as surrogate_module
from turgorbayes.physics import parameters, wall

__all__ = [
    "BUCKLED",
    "DEFINED",
    "INVALID_INPUT",
    "OUTSIDE_SURROGATE",
    "REASONS",
    "UNDEFINED_ANISOTROPY",
    "UNREACHABLE_PRESSURE",
    "branch_end",
    "cell_radius_and_stiffness",
    "cell_terms",
    "explain_nan",
    "fe_settings",
    "pressure_on_branch",
    "radius_at_pressure",
    "stiffness_at_radius",
    "stiffness_from_wall",
]

P0_DEFAULT = parameters.P0  # Pa

DEFINED = 0
INVALID_INPUT = 1
UNREACHABLE_PRESSURE = 2
UNDEFINED_ANISOTROPY = 3
OUTSIDE_SURROGATE = 4
BUCKLED = 5

#: Reason codes returned by :func:`explain_nan`.
REASONS = {
    DEFINED: "defined",
    INVALID_INPUT: "invalid input (a pressure, E0t, R0 or P0 not finite and > 0, or gamma < 0)",
    UNREACHABLE_PRESSURE: "pressure at or beyond the largest pressure the wall model can bear "
    "(wall.max_pressure): no radius on the physical branch",
    UNDEFINED_ANISOTROPY: "stress-stiffening modulus not positive at the axial or "
    "circumferential tension (E_par/E_perp undefined)",
    OUTSIDE_SURROGATE: "inflation number P R_c/(E_perp t) or anisotropy E_par/E_perp outside "
    "the finite-element surrogate table",
    BUCKLED: "the wall buckles under the tip before h = R/20 in the finite-element model "
    "(Surrogate.buckled): k_c has no unique value there",
}

_S_FAR = 10.0  # |ln(R_c/R0)| bracket when the branch has no finite end (R_c/R0 = e^+-10)


def _newton_log_radius(target, p, gamma, s_end, n_iter=60, tol=1e-13):
    """Solve ``ln P(s)/P0 = target`` for ``s`` on the branch (safeguarded Newton)."""
    lo = np.full(target.shape, -_S_FAR)
    hi = np.where(np.isfinite(s_end), s_end, _S_FAR)
    slope0 = 1 / p - 1  # d ln P/ds at s = 0: a linear first guess
    s = np.where(slope0 > 0, target / np.where(slope0 > 0, slope0, 1.0), 0.5 * (lo + hi))
    s = np.clip(s, lo + 0.5 * (hi - lo) * 1e-6, hi - 0.5 * (hi - lo) * 1e-6)
    for _ in range(n_iter):
        f, df = wall.log_pressure_and_slope(s, p, gamma)
        # NaN below the zero-pressure radius (gamma < 1) counts as "too low", NaN beyond the
        # saturation radius (gamma > 1) as "too high"
        too_low = np.where(np.isnan(f), s < 0, f < target)
        lo = np.where(too_low, s, lo)
        hi = np.where(too_low, hi, s)
        with np.errstate(invalid="ignore", divide="ignore"):
            new = s + (target - f) / df
        bad = ~np.isfinite(new) | (new < lo) | (new > hi)
        new = np.where(bad, 0.5 * (lo + hi), new)
        done = np.abs(new - s) < tol
        s = new
        if done.all():
            break
    return s


def _valid(P, gamma, E0t, R0, P0):
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(P) & (P > 0) & np.isfinite(E0t) & (E0t > 0)
        ok &= np.isfinite(R0) & (R0 > 0) & np.isfinite(P0) & (P0 > 0)
        ok &= np.isfinite(gamma) & (gamma >= 0)
    return ok


def radius_at_pressure(P, gamma, E0t, R0, P0=P0_DEFAULT):
    r"""Cell radius ``R_c`` at pressure ``P`` (fast vectorized inverse of the wall law).

    Solves

    .. math:: \frac{P}{P_0} = \frac{R_0}{R_c}\left[\frac{(\gamma-1)E_0t}{\gamma P_0R_0}
              \left(\left(\frac{R_0}{R_c}\right)^\gamma-1\right)+1\right]^{1/(1-\gamma)}

    (``docs/physics.md``, "Wall law") on the physical branch; same answer as
    :func:`turgorbayes.physics.wall.radius_at_pressure`, but ~100x faster on large arrays.

    Parameters
    ----------
    P : array_like [Pa]
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    P0 : array_like [Pa]

    Returns
    -------
    ndarray [m]
        NaN where the input is invalid or the pressure unreachable (:func:`explain_nan`).
    """
    return _radius_terms(P, gamma, E0t, R0, P0)["R_c"]


def _radius_terms(P, gamma, E0t, R0, P0):
    P, gamma, E0t, R0, P0 = np.broadcast_arrays(*(np.asarray(v, dtype=float)
                                                  for v in (P, gamma, E0t, R0, P0)))
    valid = _valid(P, gamma, E0t, R0, P0)
    # harmless stand-ins where invalid, so no warnings leak out; masked to NaN below
    P_, E0t_, R0_, P0_ = (np.where(valid, v, 1.0) for v in (P, E0t, R0, P0))
    gamma_ = np.where(valid, gamma, 1.0)
    p = P0_ * R0_ / E0t_
    target = np.log(P_ / P0_)
    s_end, log_p_max = wall.reduced_branch_end(p, gamma_)
    reachable = valid & (target < log_p_max)
    s = _newton_log_radius(np.where(reachable, target, 0.0), p, gamma_,
                           np.where(reachable, s_end, np.inf))
    R_c = np.where(reachable, R0_ * np.exp(s), np.nan)
    reason = np.where(valid, np.where(reachable, DEFINED, UNREACHABLE_PRESSURE), INVALID_INPUT)
    return dict(P=P_, gamma=gamma_, E0t=E0t_, R0=R0_, P0=P0_, p=p, R_c=R_c,
                reason=reason.astype(np.int8))


def _anisotropy_at_radius(P, R_c, p, gamma, P0, R0):
    """``E_par/E_perp`` at a known radius (:func:`turgorbayes.physics.wall.anisotropy_at_tension`)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        log_s = np.log(P * R_c / (P0 * R0))
    return wall.anisotropy_at_tension(log_s, p, gamma)


def cell_terms(P, gamma, E0t, R0, P0=P0_DEFAULT, surrogate=None, axes=None):
    """All intermediate quantities of the forward model, with a reason code per point.

    Parameters
    ----------
    P : array_like [Pa]
        Pressure.
    gamma : array_like [-]
        Stress-stiffening exponent.
    E0t : array_like [N/m]
        Circumferential modulus times wall thickness at ``P0``.
    R0 : array_like [m]
        Radius at ``P0``.
    P0 : array_like [Pa]
        Reference pressure (5 kPa).
    surrogate : Surrogate, None or False
        The k/(PR) table; None loads the shipped one; False skips the stiffness (no
        ``k_over_PR``, ``k_c`` keys; reasons then stop at the wall model).
    axes : dict, optional
        Per-point FE settings (:func:`stiffness_from_wall`).

    Returns
    -------
    dict of ndarray
        ``R_c`` [m], ``E_perp_t`` [N/m], ``ratio`` (E_par/E_perp), ``x`` (P R_c/E_perp t),
        ``k_over_PR``, ``k_c`` [N/m] and ``reason`` (int8 codes of :data:`REASONS`), all of
        the broadcast shape. ``R_c`` is NaN where the wall model has no radius (invalid
        input, unreachable pressure); the others wherever ``reason != DEFINED``.
    """
    t = _radius_terms(P, gamma, E0t, R0, P0)
    return _stiffness_terms(t["P"], t["R_c"], t["gamma"], t["E0t"], t["R0"], t["P0"],
                            t["reason"], surrogate, axes)


def _stiffness_terms(P, R_c, gamma, E0t, R0, P0, reason, surrogate, axes=None):
    """Stiffness side of :func:`cell_terms` at known radii (arrays already broadcast)."""
    p = P0 * R0 / E0t
    E_perp_t = E0t * (P / P0) ** gamma
    ratio = _anisotropy_at_radius(P, R_c, p, gamma, P0, R0)
    reason = reason.copy()
    reason[(reason == DEFINED) & ~np.isfinite(ratio)] = UNDEFINED_ANISOTROPY
    if surrogate is False:
        x = P * R_c / E_perp_t
        bad = reason != DEFINED
        return {"R_c": R_c, "E_perp_t": np.where(bad, np.nan, E_perp_t),
                "ratio": np.where(bad, np.nan, ratio), "x": np.where(bad, np.nan, x),
                "reason": reason}
    t = stiffness_from_wall(P, R_c, E_perp_t, ratio, surrogate, reason, axes)
    bad = t["reason"] != DEFINED
    return {
        "R_c": R_c, "E_perp_t": np.where(bad, np.nan, E_perp_t),
        "ratio": np.where(bad, np.nan, ratio), "x": np.where(bad, np.nan, t["x"]),
        "k_over_PR": t["k_over_PR"], "k_c": t["k_c"], "reason": t["reason"],
    }


def stiffness_from_wall(P, R_c, E_perp_t, ratio, surrogate=None, reason=None, axes=None):
    r"""Indentation stiffness from the wall's state: the surrogate at ``x = P R_c/(E_perp t)``.

    .. math:: k_c = f\!\left(\frac{P R_c}{E_\perp t}, \frac{E_\parallel}{E_\perp}\right) P R_c

    Parameters
    ----------
    P : ndarray [Pa]
        Pressure.
    R_c : ndarray [m]
        Cell radius at ``P``.
    E_perp_t : ndarray [N/m]
        Circumferential 2D modulus at ``P``.
    ratio : ndarray [-]
        Anisotropy ``E_par/E_perp`` at ``P``.
    surrogate : Surrogate, optional
        The k/(PR) table; the shipped one (:func:`turgorbayes.surrogate.load`) if None.
    reason : ndarray of int8, optional
        Reason codes so far (:data:`REASONS`); the surrogate is evaluated where they are
        ``DEFINED``. Default: ``DEFINED`` where ``x`` and ``ratio`` are finite, else
        ``INVALID_INPUT``. All arrays of one shape.
    axes : dict, optional
        Per-point FE settings by name (``tip_radius``, ``thickness`` [m]), broadcastable to
        ``P``: the table's value times the FE correction to these settings
        (:func:`turgorbayes.surrogate.correction_factor`).

    Returns
    -------
    dict of ndarray
        ``x`` [-], ``k_over_PR`` [-], ``k_c`` [N/m] (NaN where not defined) and ``reason``:
        the codes with ``BUCKLED`` where the wall buckles under the tip
        (:meth:`turgorbayes.surrogate.Surrogate.buckled`) and ``OUTSIDE_SURROGATE`` where else
        the table has no value.
    """
    x = P * R_c / E_perp_t
    if reason is None:
        defined = np.isfinite(x) & np.isfinite(ratio)
        reason = np.where(defined, DEFINED, INVALID_INPUT).astype(np.int8)
    if surrogate is None:
        surrogate = surrogate_module.load()
    reason = reason.copy()
    ok = reason == DEFINED
    k_over_PR = np.full(x.shape, np.nan)
    if ok.any():
        k_over_PR[ok] = surrogate(x[ok], ratio[ok], warn=False)
        if axes:
            k_over_PR[ok] *= surrogate_module.correction_factor(
                surrogate, x[ok], ratio[ok],
                **{k: np.broadcast_to(v, x.shape)[ok] for k, v in axes.items()})
    missing = ok & ~np.isfinite(k_over_PR)
    reason[missing] = OUTSIDE_SURROGATE
    if missing.any() and getattr(surrogate, "buckled_boxes", None):
        reason[missing & surrogate.buckled(x, ratio)] = BUCKLED
    return {"x": x, "k_over_PR": k_over_PR, "k_c": k_over_PR * P * R_c, "reason": reason}


def pressure_on_branch(s, gamma, E0t, R0, P0=P0_DEFAULT):
    r"""Explicit pressure law along the radius: ``ln P`` and ``d ln P/d s`` at ``s = ln(R_c/R0)``.

    .. math:: \ln\frac{P}{P_0} = -s + \frac{\ln B}{1-\gamma},\quad
              B = 1 + \frac{(\gamma-1)(\rho^\gamma - 1)}{\gamma p},\quad
              \frac{d\ln P}{ds} = -1 + \frac{\rho^\gamma}{pB}

    (``rho = e^-s``, ``p = P0 R0/E0t``; ``docs/physics.md``, "Wall law"). No root finding: used by
    the likelihood to tabulate a walker's wall on a grid in radius.

    Parameters
    ----------
    s : array_like [-]
        ``ln(R_c/R0)``.
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    P0 : float [Pa]

    Returns
    -------
    log_P : ndarray [ln Pa]
        NaN where the bracket B is not positive.
    slope : ndarray [-]
        ``d ln P / d s``.
    """
    p = P0 * np.asarray(R0, float) / np.asarray(E0t, float)
    log_ratio, slope = wall.log_pressure_and_slope(np.asarray(s, float), p, np.asarray(gamma, float))
    return log_ratio + np.log(P0), slope


def branch_end(gamma, E0t, R0, P0=P0_DEFAULT):
    """End of the physical branch: ``(s_end, ln P_max)`` with ``s = ln(R_c/R0)``.

    ``ln P_max`` is ``inf`` where the radius saturates (P diverges at ``s_end``) or the
    branch has no end (``s_end`` then ``inf``); see :mod:`turgorbayes.physics.wall`.
    """
    p = P0 * np.asarray(R0, float) / np.asarray(E0t, float)
    s_end, log_p_max = wall.reduced_branch_end(p, np.asarray(gamma, float))
    return s_end, log_p_max + np.log(P0)


def stiffness_at_radius(P, R_c, gamma, E0t, R0, P0=P0_DEFAULT, surrogate=None):
    """Indentation stiffness ``k_c`` [N/m] of a cell whose radius at ``P`` is already known.

    Same as :func:`cell_radius_and_stiffness` without the radius inversion (``R_c`` must
    lie on the wall's branch, e.g. from :func:`pressure_on_branch`); NaN where the
    anisotropy is undefined or outside the surrogate table.
    """
    P, R_c, gamma, E0t, R0, P0 = np.broadcast_arrays(*(np.asarray(v, float) for v in
                                                       (P, R_c, gamma, E0t, R0, P0)))
    reason = np.where(np.isfinite(R_c) & np.isfinite(P), DEFINED, INVALID_INPUT).astype(np.int8)
    return _stiffness_terms(P, R_c, gamma, E0t, R0, P0, reason, surrogate)["k_c"]


def fe_settings(params):
    """The per-cell FE settings among wall parameters ``params`` (keys of
    :data:`turgorbayes.surrogate.AXES`: ``thickness``, ``tip_radius`` [m]), or None if none."""
    return {k: params[k] for k in surrogate_module.AXES if k in params} or None


def cell_radius_and_stiffness(P, gamma, E0t, R0, P0=P0_DEFAULT, surrogate=None, axes=None):
    r"""Radius ``R_c`` and indentation stiffness ``k_c`` of a cell at pressure ``P``.

    .. math::

        R_c = R_c(P; \gamma, E_0t, R_0), \qquad E_\perp t = E_0t\,(P/P_0)^\gamma,

        k_c = f\!\left(\frac{P R_c}{E_\perp t}, \frac{E_\parallel}{E_\perp}(P)\right) P R_c

    with ``f = k/(PR)`` the finite-element surrogate at indentation ``R/20``
    (``docs/physics.md``, "Forward model").

    Parameters
    ----------
    P : array_like [Pa]
        Pressure, > 0.
    gamma : array_like [-]
        Stress-stiffening exponent, >= 0.
    E0t : array_like [N/m]
        ``E_perp t`` at ``P0``.
    R0 : array_like [m]
        Radius at ``P0``.
    P0 : array_like [Pa], default 5e3
        Reference pressure.
    surrogate : turgorbayes.surrogate.Surrogate, optional
        The k/(PR) table; the shipped one (:func:`turgorbayes.surrogate.load`) if None; a table
        at other FE settings: ``turgorbayes.surrogate.load(tip_radius_nm=..., thickness_nm=...)``.
    axes : dict, optional
        Per-point FE settings (``tip_radius``, ``thickness`` [m], broadcasting with ``P``) that
        replace the table's (:func:`stiffness_from_wall`).

    Returns
    -------
    R_c : ndarray [m]
        NaN where the wall model has no radius (invalid input, unreachable pressure).
    k_c : ndarray [N/m]
        NaN wherever the model is undefined (also outside the surrogate table).
        Broadcast shape of the inputs; :func:`explain_nan` gives the reason.
    """
    t = cell_terms(P, gamma, E0t, R0, P0, surrogate, axes)
    return t["R_c"], t["k_c"]


def explain_nan(P, gamma, E0t, R0, P0=P0_DEFAULT, surrogate=None, axes=None):
    """Why :func:`cell_radius_and_stiffness` is NaN at each point.

    Parameters
    ----------
    Same as :func:`cell_radius_and_stiffness`.

    Returns
    -------
    codes : ndarray of int8
        Reason code per point (0 = defined), broadcast shape of the inputs.
    messages : dict
        :data:`REASONS` (code -> sentence).
    """
    return cell_terms(P, gamma, E0t, R0, P0, surrogate, axes)["reason"], dict(REASONS)
