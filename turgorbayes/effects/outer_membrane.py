r"""``outer_membrane``: a load-bearing outer membrane in parallel with the peptidoglycan.

Cause: the outer membrane of *E. coli* bears load (Rojas et al., Nature 559, 617 (2018)); the
baseline puts all stiffness in the peptidoglycan (PG). Model: a pressure-independent 2D modulus
``Y_om`` [N/m] beside the PG (:mod:`turgorbayes.physics.outer_membrane`), the same surrogate with the
envelope's total moduli; reported ``E_perp``, ``E_par`` are the PG's own. Prior
``Y_om ~ HalfNormal(0.05 N/m)``. ``Y_om = 0`` is the baseline (``docs/effects.md``, "outer_membrane").
"""

import numpy as np

from turgorbayes.effects.base import Effect, SqrtCoordinate
from turgorbayes.effects.registry import register_effect
from turgorbayes.inference.context import baseline_radius_and_stiffness
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.priors import HalfNormal
from turgorbayes.physics import forward
from turgorbayes.physics import outer_membrane as om

__all__ = ["OuterMembrane", "Y_OM_PRIOR", "envelope_radius_and_stiffness"]

#: Prior on the outer-membrane 2D modulus [N/m].
Y_OM_PRIOR = HalfNormal(0.05)


def envelope_radius_and_stiffness(P, gamma, E0t, R0, Y_om, P0, surrogate, axes=None):
    r"""``R_c`` and ``k_c`` of the PG + outer-membrane envelope (broadcasting; NaN where undefined).

    .. math:: k_c = f\!\left(\frac{P R_c}{E_\perp t},\ \frac{E_\parallel}{E_\perp}\right) P R_c

    Parameters
    ----------
    P : array_like [Pa]
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    Y_om : array_like [N/m]
    P0 : float [Pa]
    surrogate : turgorbayes.surrogate.Surrogate
    axes : dict, optional
        Per-point FE settings (:func:`turgorbayes.physics.forward.stiffness_from_wall`).

    Returns
    -------
    R_c : ndarray [m]
    k_c : ndarray [N/m]
    """
    arrays = np.broadcast_arrays(*(np.asarray(a, float) for a in (P, gamma, E0t, R0, Y_om)))
    P, gamma, E0t, R0, Y_om = arrays
    axes = {k: np.broadcast_to(v, P.shape) for k, v in (axes or {}).items()}
    ok = (P > 0) & (gamma >= 0) & (E0t > 0) & (R0 > 0) & (Y_om >= 0)
    ok &= np.isfinite(P) & np.isfinite(gamma) & np.isfinite(E0t) & np.isfinite(R0) & np.isfinite(Y_om)
    R = np.full(P.shape, np.nan)
    k = np.full(P.shape, np.nan)
    if ok.any():
        with np.errstate(all="ignore"):
            R_ok, Et, ratio = om.envelope_at_pressure(P[ok], gamma[ok], E0t[ok], R0[ok], Y_om[ok], P0)
            k_ok = forward.stiffness_from_wall(P[ok], R_ok, Et, ratio, surrogate,
                                               axes={k: v[ok] for k, v in axes.items()})["k_c"]
        R[ok] = R_ok
        k[ok] = k_ok
    return R, k


class OuterMembrane(Effect):
    """PG + outer membrane with fitted ``Y_om`` (module docstring)."""

    name = "outer_membrane"
    changes_wall = True
    tension_parameters = ("Y_om",)
    parameters = (Parameter("Y_om", SqrtCoordinate(Y_OM_PRIOR), "Y_om_N_per_m", 1.0, r"$Y_{om}$ [N/m]"),)
    size_parameter = "Y_om"
    null_value = 0.0
    realistic_size = 0.026
    realistic_size_reason = (
        "Y_om = 0.026 N/m, the PG's own E0t at 5 kPa: Rojas et al. found the OM's stiffness "
        "comparable to the cell wall's; the OM then carries 22 % of the circumferential tension "
        "at 29 kPa (docs/outer_membrane.md), while the stiffened PG is 8x stiffer there")
    start = {"Y_om": 0.002}
    series_reason = ("the envelope's own law changes how the cell's volume follows its turgor, "
                     "while the series model solves each level's osmotic balance with the wall "
                     "law alone")
    cause = ("The outer membrane carries part of the load: besides the peptidoglycan wall, a "
             "membrane layer of stiffness about {size:.2g} N/m resists the turgor, which the "
             "baseline wall-only model misses.")

    def apply(self, ctx, v):
        Y = np.asarray(v["Y_om"], float)[:, None]
        for group in ("bulged", "intact"):
            wall = ctx.walls[group]
            wall["Y_om"] = np.broadcast_to(Y, wall["R0"].shape)
        ctx.radius_and_stiffness = self.radius_and_stiffness

    def cell_walls(self, walls, v, is_bulged, rng):
        walls = dict(walls)
        walls["Y_om"] = np.broadcast_to(np.asarray(v["Y_om"], float), np.shape(walls["R0"]))
        return walls

    def radius_and_stiffness(self, P, walls, P0, surrogate):
        if "Y_om" not in walls:
            return baseline_radius_and_stiffness(P, walls, P0, surrogate)
        return envelope_radius_and_stiffness(P, walls["gamma"], walls["E0t"], walls["R0"],
                                             walls["Y_om"], P0, surrogate,
                                             forward.fe_settings(walls))

    def wall_moduli(self, v, P0):
        """PG's own ``E_perp t``, ``E_par t`` [N/m] at ``P_phys`` (per walker)."""
        Y = np.asarray(v["Y_om"], float)
        with np.errstate(all="ignore"):
            _, Et, ratio = om.envelope_at_pressure(v["P_phys"], v["gamma"], v["E0t"], v["R0"], Y, P0)
        return Et - Y, ratio * Et - Y


register_effect(OuterMembrane())
