r"""``pressure_error``: bulge-derived pressures scatter more than their reported errors say.

Cause (docs/effects.md, pressure_error): each bulged cell's pressure comes from the liquid-membrane model
of its bulge (docs/physics.md, Bulge model). A bulge that is not a tension-free sphere (a neck, a
membrane under extra tension, a pyramidal rather than conical tip, an indentation off the bulge
apex) gives a pressure that is off by a factor the reported ``k_b`` and ``R_b`` errors do not
contain, differently from cell to cell.

Model: the bulge-derived log pressure of bulged cell ``i`` scatters around the true one with
the reported sd ``s_i`` plus an extra scatter ``sigma_P`` (fitted, the same for all cells):

.. math:: \ln\hat P_i \sim N\!\left(\ln P_i,\; s_i^2 + \sigma_P^2\right).

Likelihood: the latent-pressure integral of :mod:`turgorbayes.effects` with the wider bulge
sd (:meth:`PressureError.apply` widens ``ctx.extra_log_sd``) and the latent population taken at
``sigma_P``. The population is estimated from the ``ln P_hat_i`` themselves, so one
deconvolved with ``s_i`` alone already holds the extra scatter; widening the bulge as well
would count ``sigma_P`` twice (the model's marginal of ``ln P_hat`` would be the true
population smeared by ``s_i^2 + 2 sigma_P^2``). The deconvolved population is therefore a
family in the extra scatter (:class:`turgorbayes.inference.population.DeconvolvedPopulation`:
deconvolved with noise ``sqrt(s_i^2 + sigma^2)`` at ``sigma = 0, 0.05, ..., 1``, a mixture of
the two neighbouring members in between); the normal population's ``tau^2`` loses
``sigma_P^2`` (floored at 0.1^2); the flat prior does not change. This is done at the level of
``extra_log_sd``, so any effect that widens ``ln P_hat`` gets it. Measured on 40 simulated
data sets of the paper's size at ``sigma_P = 0.3`` (studies/pressure_error_double_counting.py,
against the population held at ``sigma = 0``): the double counting was small, since each cell's
own ``R_c``, ``k_c`` pin its pressure far more tightly than the population does; the posterior
mode of ``sigma_P`` moves by +0.0006 +- 0.0028 (its posterior sd is ~0.03), that of ``P_phys``
by -0.085 +- 0.027 kPa (0.12 posterior sd, towards the truth).

Simulation: ``k_b`` (and its reported error) of every bulged cell is multiplied by
:math:`e^{\sigma_P\epsilon_i}`, which shifts :math:`\ln\hat P_i` by :math:`\sigma_P\epsilon_i`.

Prior: ``sigma_P ~ HalfNormal(0.25)`` (95 % below 0.49, i.e. a factor 1.6): larger systematic
errors of a force-curve slope model would be visible by eye in the paper's Fig. 2.
"""

import numpy as np

from turgorbayes.effects.base import Effect, SqrtCoordinate
from turgorbayes.effects.registry import register_effect
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.priors import HalfNormal

__all__ = ["PressureError", "SIGMA_P_PRIOR"]

#: Prior on the extra log-pressure scatter.
SIGMA_P_PRIOR = HalfNormal(0.25)


class PressureError(Effect):
    """Extra scatter ``sigma_P`` of bulge-derived log pressures (module docstring)."""

    name = "pressure_error"
    parameters = (Parameter("sigma_P", SqrtCoordinate(SIGMA_P_PRIOR), "sigma_P", 1.0, r"$\sigma_P$"),)
    size_parameter = "sigma_P"
    null_value = 0.0
    realistic_size = 0.3
    realistic_size_reason = (
        "sigma_P = 0.3 (pressures off by a factor ~1.35 per cell): about twice the reported "
        "bulge errors (s_i = 0.08-0.17), the size of the bulge-model idealizations of "
        "docs/physics.md, Limits (cone vs pyramid, bulge tension, off-apex indentation)")
    start = {"sigma_P": 0.05}
    cause = ("The pressures read from the bulges are less precise than their error bars say: "
             "each bulge gives its cell's turgor only to within about {size:.0%}, so the "
             "pressure axis of the bulged cells is noisier than reported.")

    def apply(self, ctx, v):
        ctx.extra_log_sd = np.hypot(ctx.extra_log_sd, np.asarray(v["sigma_P"], float))

    def log_pressure_sd(self, v):
        return np.asarray(v["sigma_P"], float)


register_effect(PressureError())
