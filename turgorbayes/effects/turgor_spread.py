r"""``turgor_spread``: the intact cells' turgor varies from cell to cell.

Cause (docs/effects.md, turgor_spread): the baseline puts every intact cell at one pressure
``P_phys``, yet each cell sets its own turgor by the osmolytes it holds, so living cells of one
culture need not share one pressure.

Model: intact cell ``i`` has :math:`\ln P_i = \ln P_{phys} + \tau_P\eta_i`,
:math:`\eta_i\sim N(0, 1)` (lognormal, spread ``tau_P`` fitted, dimensionless: the sd of
``ln P``). ``P_phys`` is then the **median** intact cell's turgor (the mean is
:math:`P_{phys}e^{\tau_P^2/2}`). Bulged cells are unchanged: their pressure is already latent
per cell, seen through the bulge.

Likelihood: each intact cell's density is integrated over its own ``eta_i`` by the engine
(:meth:`turgorbayes.inference.likelihood.CellLikelihood._context_intact`, through
:attr:`turgorbayes.inference.context.LikelihoodContext.intact_log_sd`): a composite 6-point
Gauss-Legendre rule in ``eta`` over [-6, 6] with nodes shared by all walkers and cells (the
wall model is evaluated at ``W x K`` pressures) and panels narrower than 3 widths of the
narrowest cell's likelihood in ``eta`` (an intact cell's ``k_c`` pins its ``ln P`` to about its
relative error, 5-20 %, far narrower than ``tau_P``: a Gauss-Hermite rule with a few fixed nodes
is not accurate). Against ``scipy.integrate.quad`` with the exact forward model the per-cell
log-likelihood is right to 1e-10 or better for ``tau_P`` 0.05-0.5 (tests).

Prior: ``tau_P ~ HalfNormal(0.15)`` (:data:`TAU_P_PRIOR`), sampled as ``sqrt(tau_P)``. No
precise published cell-to-cell sd of bacterial turgor was found; the scale rests on two
numbers (docs/effects.md, turgor_spread): AFM turgor estimates of single *Magnetospirillum*
cells spanning 85-150 kPa (Arnoldi et al., Phys. Rev. E 62, 1034, 2000: a log-range of 0.57),
and the paper's own intact *E. coli* cells, whose stiffness scatter (12 %, measurement error
included) bounds ``tau_P`` by about 0.11. The prior's median is 0.10 and 95 % of its mass lies
below 0.29.
"""

import numpy as np

from turgorbayes.effects.base import Effect, SqrtCoordinate
from turgorbayes.effects.registry import OWN_STIFFNESS_FACTOR, register_effect
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.priors import HalfNormal

__all__ = ["TAU_P_PRIOR", "TurgorSpread"]

#: Prior on the sd ``tau_P`` of the intact cells' ``ln P`` (module docstring).
TAU_P_PRIOR = HalfNormal(0.15)


class TurgorSpread(Effect):
    """Lognormal cell-to-cell spread ``tau_P`` of the intact cells' turgor (module docstring)."""

    family = OWN_STIFFNESS_FACTOR
    name = "turgor_spread"
    parameters = (Parameter("tau_P", SqrtCoordinate(TAU_P_PRIOR), "tau_P", 1.0, r"$\tau_P$"),)
    size_parameter = "tau_P"
    null_value = 0.0
    realistic_size = 0.2
    realistic_size_reason = (
        "tau_P = 0.2: single-cell AFM turgor estimates of Magnetospirillum span 85-150 kPa "
        "(Arnoldi et al. 2000), a log-range of 0.57, about +-1.4 sd of 0.2 for a handful of "
        "cells; it spreads the intact cells' k_c by about 22 % (d ln k_c/d ln P = 1.11 at "
        "29 kPa), more than the paper's E. coli intact cells show (12 % with measurement "
        "error, tau_P <= 0.11), so it is a size at which the effect is clearly present")
    start = {"tau_P": 0.05}
    cause = ("Cells differ in turgor: each intact cell has its own pressure (spread about "
             "{size:.0%} from cell to cell around the median P_phys), which the baseline's "
             "single pressure for all intact cells cannot describe.")

    def apply(self, ctx, v):
        ctx.intact_log_sd = np.asarray(v["tau_P"], float)

    def intact_log_pressure_offsets(self, v, n, rng):
        """``tau_P eta`` per intact cell: ``(n,)`` for a scalar ``tau_P``, ``(W, n)`` for a
        column ``(W, 1)`` (one value per posterior draw)."""
        tau = np.asarray(v["tau_P"], float)
        return tau * rng.standard_normal(np.broadcast_shapes(tau.shape, (n,)))


register_effect(TurgorSpread())
