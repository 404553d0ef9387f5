r"""Turgor from the medium's osmolarity: the osmotic balance of a cell whose wall obeys the wall law.

Turgor is the osmotic difference across the membrane, :math:`P = RT(c_{in} - c_{out})`; over a
quick shift of the medium the cytoplasm's osmolytes are conserved (Boyle-van 't Hoff,
:math:`c_{in} = n/(V - V_b)`), and the volume follows the wall law of
:mod:`turgorbayes.physics.wall` with a stated length model. The balance is solved along the
wall's strain ``s = ln(R_c/R0)``, where every term is explicit (docs/physics.md, "Osmotic
shifts of the medium"). Concentrations are osmolarities in mOsm (mmol/L = mol/m^3).
"""

import numpy as np

from turgorbayes.physics import wall
from turgorbayes.physics.parameters import P0 as P0_DEFAULT

__all__ = [
    "LENGTH_MODELS",
    "R_GAS",
    "T_DEFAULT",
    "buffering_factor",
    "log_volume_and_slope",
    "medium_at_strain",
    "osmotic_pressure",
    "turgor_after_shift",
]

#: Molar gas constant [J/(mol K)] (CODATA 2018, exact).
R_GAS = 8.314462618
#: Default temperature [K] (25 C, AFM at room temperature).
T_DEFAULT = 298.15
#: How the cell's length follows a change of turgor (docs/physics.md, "Osmotic shifts of the
#: medium"): ``"wall"``, the axial strain of the same wall law at the axial tension
#: ``P R_c/2``; ``"fixed"``, the length unchanged.
LENGTH_MODELS = ("wall", "fixed")


def osmotic_pressure(c, temperature=T_DEFAULT):
    r"""Van 't Hoff osmotic pressure of an osmolarity.

    .. math:: \Pi = R T c

    Parameters
    ----------
    c : array_like [mOsm]
        Osmolarity (1 mOsm = 1 mmol/L = 1 mol/m^3).
    temperature : array_like [K]

    Returns
    -------
    ndarray [Pa]
        2.479 kPa per mOsm at 298.15 K.
    """
    return R_GAS * np.asarray(temperature, float) * np.asarray(c, float)


def _check_length_model(length_model):
    if length_model not in LENGTH_MODELS:
        raise ValueError(f"length model must be one of {', '.join(LENGTH_MODELS)}, "
                         f"got {length_model!r}")


def log_volume_and_slope(s, gamma, E0t, R0, P0=P0_DEFAULT, length_model="wall"):
    r"""Log volume (relative to the cell at ``R0``) and its slope along the wall's strain.

    The cell is a cylinder of radius ``R_c`` and length ``L``, :math:`V \propto R_c^2 L`. With
    ``length_model="wall"`` the axial natural strain follows the wall's law at the axial
    tension :math:`\tau/2` (the material law of docs/physics.md, "Anisotropy"):

    .. math:: \ln\frac{V}{V_0} = 2s + S(\tau/2) - S(1/2),\qquad
              \frac{d\ln V}{ds} = 2 + \frac{p\,(\tau/2)^{1-\gamma}}{\beta(\tau/2)}
              \Bigl(1 + \frac{d\ln P}{ds}\Bigr)

    with ``S`` the strain at a tension (:func:`turgorbayes.physics.wall.strain_at_tension`),
    :math:`\beta(\sigma) = \hat E(\sigma)/\sigma^\gamma` the modulus bracket and
    :math:`\tau = PR_c/(P_0R_0)`; with ``"fixed"``, :math:`\ln V/V_0 = 2s` and slope 2.

    Parameters
    ----------
    s : array_like [-]
        ``ln(R_c/R0)`` on the wall's branch.
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    P0 : float [Pa]
    length_model : str
        One of :data:`LENGTH_MODELS`.

    Returns
    -------
    log_v, slope : ndarray [-]
        NaN where the wall law is undefined at ``s``.
    """
    _check_length_model(length_model)
    s, gamma = np.asarray(s, float), np.asarray(gamma, float)
    p = P0 * np.asarray(R0, float) / np.asarray(E0t, float)
    log_p, dlogp = wall.log_pressure_and_slope(s, p, gamma)
    if length_model == "fixed":
        return np.where(np.isfinite(log_p), 2 * s, np.nan), np.where(np.isfinite(log_p), 2.0, np.nan)
    log_half = log_p + s - np.log(2.0)  # ln(tau/2), tau = exp(ln P/P0 + s)
    with np.errstate(over="ignore", invalid="ignore"):
        axial = (wall.strain_at_tension(np.exp(log_half), p, gamma)
                 - wall.strain_at_tension(0.5, p, gamma))
        dS = p * np.exp((1 - gamma) * log_half - wall.log_modulus_bracket(log_half, p, gamma))
    return 2 * s + axial, 2 + dS * (1 + dlogp)


def _reference_state(P_ref, gamma, E0t, R0, P0, length_model):
    """``(s_ref, ln V_ref)`` of the cell at ``P_ref`` (NaN where unreachable)."""
    from turgorbayes.physics import forward  # forward imports the surrogate; only here

    R_ref = forward.radius_at_pressure(P_ref, gamma, E0t, R0, P0)
    s_ref = np.log(R_ref / R0)
    return s_ref, log_volume_and_slope(s_ref, gamma, E0t, R0, P0, length_model)[0]


def medium_at_strain(s, P_ref, gamma, E0t, R0, *, c_ref, b, P0=P0_DEFAULT,
                     temperature=T_DEFAULT, length_model="wall"):
    r"""The medium osmolarity at which a turgid cell sits at strain ``s`` (explicit inverse of
    :func:`turgor_after_shift`).

    .. math:: c_{out} = c_{in,ref}\,\frac{1-b}{v - b} - \frac{P_{wall}(s)}{RT},\qquad
              c_{in,ref} = c_{ref} + \frac{P_{ref}}{RT},\quad v = \frac{V(s)}{V(s_{ref})}

    Parameters
    ----------
    s : array_like [-]
        ``ln(R_c/R0)``.
    P_ref : array_like [Pa]
        Turgor in the reference medium ``c_ref``.
    gamma, E0t, R0 : array_like [-, N/m, m]
    c_ref : array_like [mOsm]
    b : array_like [-]
        Osmotically inactive volume as a fraction of the volume at ``P_ref``.
    P0, temperature, length_model
        As in :func:`turgor_after_shift`.

    Returns
    -------
    c_out : ndarray [mOsm]
        NaN where ``v <= b`` or the wall law is undefined at ``s``.
    """
    RT = osmotic_pressure(1.0, temperature)
    s_ref, lv_ref = _reference_state(P_ref, gamma, E0t, R0, P0, length_model)
    lv, _ = log_volume_and_slope(s, gamma, E0t, R0, P0, length_model)
    v = np.exp(lv - lv_ref)
    log_p, _ = wall.log_pressure_and_slope(np.asarray(s, float),
                                           P0 * np.asarray(R0, float) / np.asarray(E0t, float),
                                           np.asarray(gamma, float))
    c_in = (np.asarray(c_ref, float) + np.asarray(P_ref, float) / RT) * (1 - b)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = c_in / (v - b) - P0 * np.exp(log_p) / RT
    return np.where(v > b, out, np.nan)


def turgor_after_shift(P_ref, gamma, E0t, R0, *, c_ref, c_out, b, P0=P0_DEFAULT,
                       temperature=T_DEFAULT, length_model="wall", n_iter=80, tol=1e-13):
    r"""Turgor and radius of a cell after the medium's osmolarity moved from ``c_ref`` to ``c_out``.

    The osmolytes ``n`` are conserved and the volume follows the wall law; the balance

    .. math:: \frac{P_{wall}(s)}{RT} + c_{out} = c_{in,ref}\,\frac{1-b}{v(s) - b},\qquad
              c_{in,ref} = c_{ref} + \frac{P_{ref}}{RT}

    is solved for the strain ``s = ln(R_c/R0)`` (``v = V(s)/V(s_ref)``, :func:`log_volume_and_slope`)
    by a safeguarded Newton iteration on
    :math:`h(s) = (P_{wall}/RT + c_{out})(v - b) - c_{in,ref}(1 - b)`, which rises with ``s``
    wherever ``v > b`` and is negative elsewhere, so the root is unique (docs/physics.md,
    "Osmotic shifts of the medium"). Where the wall has a zero-pressure radius
    (``gamma < 1``) and the protoplast would shrink below it, the cell is **plasmolysed**: turgor
    0, the wall at its rest radius.

    Parameters
    ----------
    P_ref : array_like [Pa]
        Turgor in the reference medium (the growth medium's ``P_phys``), > 0.
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    c_ref : array_like [mOsm]
        Osmolarity of the reference medium.
    c_out : array_like [mOsm]
        Osmolarity of the medium after the shift.
    b : array_like [-]
        Osmotically inactive volume ``V_b`` as a fraction of the volume at ``P_ref``, in [0, 1).
    P0 : float [Pa]
    temperature : array_like [K]
    length_model : str
        One of :data:`LENGTH_MODELS`.
    n_iter : int
        Newton iterations at most.
    tol : float
        Step in ``s`` below which an iteration has converged.

    Returns
    -------
    dict of ndarray (broadcast shape of the inputs)
        ``P`` [Pa] (0 where plasmolysed, NaN where no state exists: past the wall's largest
        pressure, or invalid input), ``R_c`` [m], ``s`` [-] (the balance's root, the
        protoplast's strain where plasmolysed), ``plasmolysed`` (bool).
    """
    _check_length_model(length_model)
    RT = osmotic_pressure(1.0, temperature)
    P_ref, gamma, E0t, R0, c_ref, c_out, b = np.broadcast_arrays(
        *(np.asarray(v, float) for v in (P_ref, gamma, E0t, R0, c_ref, c_out, b)))
    p = P0 * R0 / E0t
    s_ref, lv_ref = _reference_state(P_ref, gamma, E0t, R0, P0, length_model)
    c_in = (c_ref + P_ref / RT) * (1 - b)
    # a slack wall (below its zero-pressure radius, gamma < 1) keeps its rest length while the
    # protoplast shrinks in radius: ln V continues from the wall's rest state
    s_rest = _rest_strain(p, gamma)
    lv_rest = (2 * s_rest if length_model == "fixed"
               else 3 * s_rest - wall.strain_at_tension(0.5, p, gamma))

    def h_and_slope(s):
        log_p, dlogp = wall.log_pressure_and_slope(s, p, gamma)
        lv, dlv = log_volume_and_slope(s, gamma, E0t, R0, P0, length_model)
        slack = np.isnan(log_p) & (s < s_ref)  # below the zero-pressure radius (gamma < 1)
        with np.errstate(over="ignore", invalid="ignore"):
            P_w = np.where(slack, 0.0, P0 * np.exp(log_p))
            lv = np.where(slack, lv_rest + 2 * (s - s_rest), lv)
            dlv = np.where(slack, 2.0, dlv)
            v = np.exp(lv - lv_ref)
            A = P_w / RT + c_out
            h = A * (v - b) - c_in
            dh = np.where(slack, 0.0, P_w * dlogp / RT) * (v - b) + A * v * dlv
        return h, dh, slack

    # h < 0 where v <= b; v <= exp(2 (s - s_ref)) left of s_ref for either length model
    lo = s_ref + 0.5 * np.log(np.maximum(b, 1e-16)) - 1e-3
    s_end, _ = wall.reduced_branch_end(p, gamma)
    hypo = c_out < c_ref
    hi = np.where(hypo, np.where(np.isfinite(s_end), s_end, s_ref + 2.0), s_ref)
    s = np.where(hypo, 0.5 * (s_ref + hi), s_ref)
    for _ in range(n_iter):
        h, dh, _ = h_and_slope(s)
        too_low = np.where(np.isnan(h), s < s_ref, h < 0)
        lo, hi = np.where(too_low, s, lo), np.where(too_low, hi, s)
        with np.errstate(invalid="ignore", divide="ignore"):
            step = -h / dh
        done = np.abs(step) < tol  # converged: a step below the tolerance is not taken
        new = s + step
        new = np.where(~np.isfinite(new) | (new <= lo) | (new >= hi), 0.5 * (lo + hi), new)
        s = np.where(done, s, new)
        if np.all(done | np.isnan(s)):
            break
    h, _, slack = h_and_slope(s)
    # a root must have been bracketed: no state where h stays negative up to the branch end
    found = np.isfinite(s) & (np.abs(h) <= 1e-9 * np.maximum(c_in, 1.0)) & np.isfinite(s_ref)
    log_p, _ = wall.log_pressure_and_slope(s, p, gamma)
    P = np.where(slack, 0.0, P0 * np.exp(log_p))
    s_wall = np.where(slack, s_rest, s)
    return {"P": np.where(found, P, np.nan), "R_c": np.where(found, R0 * np.exp(s_wall), np.nan),
            "s": np.where(found, s, np.nan), "plasmolysed": found & slack}


def _rest_strain(p, gamma):
    """Strain of the wall's zero-pressure radius (``gamma < 1``): bracket ``B = 0``."""
    with np.errstate(divide="ignore", invalid="ignore"):
        z = gamma * p / (1 - gamma)
        return np.where(gamma > 0, -np.log1p(z) / np.where(gamma > 0, gamma, 1.0), -p)


def buffering_factor(P, gamma, E0t, R0, *, c_out, b, P0=P0_DEFAULT, temperature=T_DEFAULT,
                     length_model="wall"):
    r"""The share of a small step of the medium's osmotic pressure that turgor takes up.

    .. math:: \beta = -\frac{dP}{d(RT c_{out})}
              = \Bigl[1 + \frac{P + RTc_{out}}{1 - b}\,\frac{d\ln V}{dP}\Bigr]^{-1},
              \qquad \frac{d\ln V}{dP} = \frac{d\ln V/ds}{P\,d\ln P/ds}

    the rest of the step is taken up by the volume (docs/physics.md, "Osmotic shifts of the
    medium").

    Parameters
    ----------
    P : array_like [Pa]
        Turgor of the cell in the medium ``c_out``.
    gamma, E0t, R0 : array_like [-, N/m, m]
    c_out : array_like [mOsm]
    b : array_like [-]
        Osmotically inactive fraction of the volume at ``P``.
    P0, temperature, length_model
        As in :func:`turgor_after_shift`.

    Returns
    -------
    ndarray [-]
        In (0, 1).
    """
    from turgorbayes.physics import forward

    P = np.asarray(P, float)
    s = np.log(forward.radius_at_pressure(P, gamma, E0t, R0, P0) / np.asarray(R0, float))
    p = P0 * np.asarray(R0, float) / np.asarray(E0t, float)
    _, dlogp = wall.log_pressure_and_slope(s, p, np.asarray(gamma, float))
    _, dlv = log_volume_and_slope(s, gamma, E0t, R0, P0, length_model)
    pi_in = P + osmotic_pressure(c_out, temperature)
    return 1.0 / (1.0 + pi_in / (1 - np.asarray(b, float)) * dlv / (P * dlogp))
