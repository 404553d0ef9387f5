r"""``pressure_range``: the bulged cells' pressures fill a range with edges, sampled with the wall.

Why: each bulged cell's true ``ln P_i`` is latent and seen through its bulge; the likelihood
integrates it against a population density ``g`` (:mod:`turgorbayes.inference.population`).
The baseline estimates ``g`` from the bulge estimates once (a plug-in spline, Efron's
deconvolution). An experiment that sets its pressures over a range (bulges induced at
1-25 kPa) has a population with hard edges, which a smooth spline rounds off; the error is the
same in every cell, so it grows against the posterior's width as the cells grow
(docs/validation.md, "Calibration as experiments grow"). Here ``g`` is a family with free
edges whose parameters are sampled with the wall parameters (a hierarchical population):

.. math::

    g(x) = \frac{\sigma\big((x - a)/w\big)\,\sigma\big((b - x)/w\big)}{Z},\qquad
    Z = \frac{w D}{1 - e^{-D}},\quad D = \frac{b - a}{w},

with ``sigma`` the logistic function, ``a = ln P_lo``, ``b = a + span`` and edge width ``w``
(``Z`` in closed form: the integral of a product of two logistic functions). A small ``w``
is a box with sharp edges (the log-uniform design), a ``w`` of the order of the span a
bell-shaped density (a logistic density for ``span -> 0``).

Priors: ``P_lo`` log-uniform on 10 Pa - 1 MPa, ``span`` log-uniform on 0.01-20 (in ln P),
``w`` lognormal with median 0.1 and log-sd 1.5 (95 % within 0.005-1.9). The data cannot tell
edges sharper than the bulge errors (0.08-0.17 in ln P) apart, so for a box the likelihood is
flat towards ``w -> 0``; a flat prior in ``ln w`` would put the mode on the prior's bound,
where no Laplace approximation holds. The lognormal gives it an interior mode.

The plug-in population still centres each cell's quadrature (the engine's Newton steps then
move the nodes onto the integrand, and a dense rule takes over where Gauss-Hermite is not to
be trusted: :meth:`turgorbayes.inference.likelihood.CellLikelihood._context_bulged`), and
replicated data (:meth:`turgorbayes.effects.ExtendedModel.posterior_predictive`) still draw
the latent pressures from it.

Status: a library model for the calibration studies, not a registered effect (``criticize``
does not try it; use ``ExtendedModel(cells, table, [PressureRange()])``). Measured
(docs/validation.md, "Over designs and truths"): on the hard-edged design at 10x the paper's
cells it gives the plug-in's z-scores (``gamma``: +0.01 +- 0.05 from them over 12 data sets)
at 10-20x the plug-in's time, so the plug-in stays the default.
"""

import numpy as np
from scipy import special

from turgorbayes.effects.base import Effect
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.observations import observations_from_cells
from turgorbayes.inference.priors import LogNormal, LogUniform

__all__ = ["PressureRange", "log_density"]


def log_density(x, lo, span, w):
    """``ln g(x)`` [per unit ln P] of the module docstring's family.

    Parameters
    ----------
    x : array_like [ln Pa]
    lo : array_like [ln Pa]
        Lower edge ``a``.
    span, w : array_like [-]
        ``b - a`` (> 0) and the edge width (> 0).
    """
    x, lo, span, w = (np.asarray(v, float) for v in (x, lo, span, w))
    D = span / w
    log_Z = np.log(w) + np.log(D) - np.log(-np.expm1(-D))
    return special.log_expit((x - lo) / w) + special.log_expit((lo + span - x) / w) - log_Z


class PressureRange(Effect):
    """A hierarchical population of the bulged cells' pressures with free edges (module
    docstring)."""

    name = "pressure_range"
    parameters = (
        Parameter("P_lo", LogUniform(10.0, 1e6), "P_lo_kPa", 1e3, r"$P_{lo}$ (kPa)"),
        Parameter("span", LogUniform(0.01, 20.0), "span", 1.0, r"span of $\ln P$"),
        Parameter("w_edge", LogNormal(0.1, 1.5), "w_edge", 1.0, r"edge width $w$"),
    )
    size_parameter = "w_edge"
    null_value = np.nan
    start = {"P_lo": 1e3, "span": 3.2, "w_edge": 0.05}
    cause = ("The bulged cells' pressures fill a range with sharp edges, which the smooth "
             "population estimated from the bulges rounds off.")

    def bind(self, cells):
        """The effect with starting values from the bulge estimates: edges one bulge sd
        inside the smallest and largest estimate."""
        obs = observations_from_cells(cells, latent="flat")  # the estimates; no deconvolution
        x, s = obs.log_P_bulge, obs.sd_log_P_bulge
        lo, hi = np.min(x) + np.median(s), np.max(x) - np.median(s)
        bound = PressureRange()
        bound.start = {"P_lo": float(np.exp(lo)), "span": float(max(hi - lo, 0.1)),
                       "w_edge": 0.05}
        return bound

    def apply(self, ctx, v):
        lo = np.log(np.asarray(v["P_lo"], float))[:, None, None]
        span = np.asarray(v["span"], float)[:, None, None]
        w = np.asarray(v["w_edge"], float)[:, None, None]
        ctx.latent_log_pdf = lambda log_P: log_density(log_P, lo, span, w)
