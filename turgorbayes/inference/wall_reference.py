r"""Sampler coordinates of a wall at its reference turgor: ``E t`` and ``R_c`` at ``P_phys``.

The wall law is stated at the paper's reference pressure ``P0`` (5 kPa): ``E0t`` and ``R0`` are
the wall's stiffness and radius there. An osmotic series of intact cells measures the wall only
between its levels' turgors (about 11-29 kPa for the paper's cells), so ``R0`` and ``E0t`` are
extrapolations along the law and their posterior lies on a curved ridge with ``gamma`` that
the Laplace approximation misses (docs/statistics.md, "Osmotic series: coordinates").

The law is one trajectory of ``d(P R_c) = E_perp t(P) d ln R_c`` with
``E_perp t = E0t (P/P0)^gamma`` (docs/physics.md, "Wall law"), so it can be stated at any point
of it: at ``P_phys`` with ``E_ref t = E0t (P_phys/P0)^gamma`` and ``R_ref = R_c(P_phys)``,
``pressure_at_radius(R, gamma, E_ref t, R_ref, P0=P_phys)`` is the same function of ``R``
(tests/inference/test_wall_reference.py checks it). A model whose :attr:`wall_references`
names groups ``(gamma, E0t, R0, P_phys)`` is sampled in ``ln E_ref t`` and ``R_ref`` in the
slots of ``E0t`` and ``R0`` (the same coordinate transforms as their priors'); the priors stay
on ``E0t`` and ``R0``, with the Jacobian of the change of coordinates, so the posterior is the
same distribution, only parametrized where the data measure it.
"""

import numpy as np

from turgorbayes.physics import forward, wall

__all__ = ["reference_from_wall", "wall_from_reference"]


def _in_domain(P, gamma, E_t, R):
    """Where the wall's values are finite and in the law's domain (gamma >= 0, the rest > 0)."""
    with np.errstate(invalid="ignore"):
        return (np.isfinite(gamma) & np.isfinite(E_t) & np.isfinite(R) & np.isfinite(P)
                & (gamma >= 0) & (E_t > 0) & (R > 0) & (P > 0))


def _radius(P, gamma, E_t, R, P_ref, ok):
    """``radius_at_pressure(P, gamma, E_t, R, P0=P_ref)`` where ``ok``, NaN elsewhere: the
    vectorized Newton inverse of :mod:`turgorbayes.physics.forward` (the change of coordinates
    runs at every log-posterior call; scipy's bracketed root finder in
    :func:`turgorbayes.physics.wall.radius_at_pressure` gives the same radius at several
    times the cost)."""
    out = np.full(ok.shape, np.nan)
    if ok.any():
        b = np.broadcast_arrays(P, gamma, E_t, R, P_ref)
        out[ok] = forward.radius_at_pressure(*(a[ok] for a in b))
    return out


def reference_from_wall(P, gamma, E0t, R0, P0):
    """The wall at turgor ``P``: ``(E_ref t, R_ref)`` [N/m, m] from its parameters at ``P0``.

    Parameters
    ----------
    P : array_like [Pa]
        The reference turgor (``P_phys``).
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    P0 : float [Pa]

    Returns
    -------
    E_ref_t, R_ref : ndarray
        NaN where the parameters are outside the law's domain or ``P`` is beyond the largest
        pressure the wall bears.
    """
    gamma, E0t, R0, P = np.broadcast_arrays(*(np.asarray(a, float) for a in (gamma, E0t, R0, P)))
    ok = _in_domain(P, gamma, E0t, R0)
    with np.errstate(all="ignore"):
        E_ref = np.where(ok, wall.perp_modulus_times_thickness(P, gamma, E0t, P0), np.nan)
    return E_ref, _radius(P, gamma, E0t, R0, np.full(P.shape, float(P0)), ok)


def wall_from_reference(P, gamma, E_ref_t, R_ref, P0):
    r"""The wall at ``P0`` from its state at turgor ``P``, and the Jacobian of the change.

    Parameters
    ----------
    P : array_like [Pa]
        The reference turgor (``P_phys``).
    gamma : array_like [-]
    E_ref_t : array_like [N/m]
        ``E_perp t`` at ``P``.
    R_ref : array_like [m]
        The radius at ``P``.
    P0 : float [Pa]

    Returns
    -------
    E0t : ndarray [N/m]
    R0 : ndarray [m]
    dR0_dR_ref : ndarray [-]
        ``dR0/dR_ref`` at fixed ``gamma``, ``E_ref t`` and ``P``: with
        ``ln E0t = ln E_ref t - gamma ln(P/P0)`` the change of coordinates is triangular and
        this is its determinant. By the implicit function theorem on the law stated at the
        reference, ``F(s, p) = ln(P0/P)`` with ``s = ln(R0/R_ref)``, ``p = P R_ref/E_ref t``
        (:func:`turgorbayes.physics.wall.log_pressure_and_slope`),

        .. math:: \frac{d\ln R_0}{d\ln R_{ref}} = 1 - \frac{p\,\partial F/\partial p}
                  {\partial F/\partial s} = 1 - \frac{u/B}{-1 + \rho^\gamma/(pB)},\qquad
                  u = \frac{\rho^\gamma - 1}{\gamma p},\ B = 1 + (\gamma - 1) u,\
                  \rho = e^{-s}

        NaN where the state is not on the rising branch of the law (``P R_ref >= E_ref t``:
        a strain of 1 or more) or the parameters are outside its domain.
    """
    gamma, E_ref, R_ref, P = np.broadcast_arrays(
        *(np.asarray(a, float) for a in (gamma, E_ref_t, R_ref, P)))
    ok = _in_domain(P, gamma, E_ref, R_ref)
    with np.errstate(all="ignore"):
        ok &= P * R_ref < E_ref  # d ln P/d ln R_c = E_ref t/(P R_ref) - 1 > 0 at the reference
        E0t = np.where(ok, wall.perp_modulus_times_thickness(P0, gamma, E_ref, P), np.nan)
    R0 = _radius(np.full(P.shape, float(P0)), gamma, E_ref, R_ref, P, ok)
    with np.errstate(all="ignore"):
        s, p = np.log(R0 / R_ref), P * R_ref / E_ref
        u = -s * wall.expm1_ratio(-gamma * s) / p
        B = 1 + (gamma - 1) * u
        _, slope = wall.log_pressure_and_slope(s, p, gamma)
        dR0 = (1 - (u / B) / slope) * R0 / R_ref
    return E0t, R0, dR0
