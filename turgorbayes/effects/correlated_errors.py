r"""``correlated_errors``: a cell's R_c and k_c errors are correlated, by one unknown ``rho``.

Cause (docs/effects.md, correlated_errors): one contact point sets both readings when the
radius comes from contact heights (a force map's cross-section, a height image taken with the
same tip): a contact found late lowers the heights and shortens the indentation, so the
radius reads small and the stiffness high together. The reported errors say nothing of it.
``turgorbayes curves`` writes the correlation it computes for the cells whose radius it fitted
(the ``rho_R_c_k_c`` column, :mod:`turgorbayes.cells.correlation`); this effect is the
description for the cells without a known one.

Model: the readings of every cell whose correlation is not known are bivariate normal about the
model with the reported errors and one correlation ``rho_e``
(:mod:`turgorbayes.inference.reading_correlation`; through
:attr:`turgorbayes.inference.context.LikelihoodContext.reading_rho`, so it composes with any
effect that keeps the Gaussian radius density).

Prior: ``rho_e`` uniform on [-0.9, 0.9]: the sign is not known beforehand (a shared contact
point gives a negative correlation, a radius error that moves the reading depth ``R_c/20`` a
small positive one), and 0.9 keeps either reading informative beyond the other (it leaves 44 %
of the conditional sd).
"""

import numpy as np

from turgorbayes.cells.correlation import ERROR_CORRELATION, error_correlation
from turgorbayes.effects.base import Effect, Injection
from turgorbayes.effects.registry import register_effect
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.priors import Uniform

__all__ = ["RHO_PRIOR", "CorrelatedErrors", "CorrelatedErrorsInjection"]

#: Prior of the correlation of a cell's R_c and k_c errors.
RHO_PRIOR = Uniform(-0.9, 0.9)


class CorrelatedErrors(Effect):
    """One correlation ``rho_e`` of every cell's R_c and k_c errors where not known (module
    docstring)."""

    name = "correlated_errors"
    parameters = (Parameter("rho_e", RHO_PRIOR, "rho_e", 1.0, r"$\rho_e$"),)
    size_parameter = "rho_e"
    null_value = 0.0
    realistic_size = -0.3
    realistic_size_reason = (
        "-0.3: the correlation of a force map's R_c and k_c errors from the crest curves' "
        "contact points, -0.31 [-0.47, -0.14] over 120 simulated maps "
        "(docs/curves.md, Correlated readings)")
    start = {"rho_e": 0.0}
    cause = ("A cell's R_c and k_c errors are correlated (rho {size:+.2f}): one contact point "
             "sets both readings, so a cell read too narrow also reads too stiff.")

    def not_applicable_reason(self, cells):
        if np.all(np.isfinite(error_correlation(cells))):
            return (f"every cell's error correlation is given (column {ERROR_CORRELATION}): "
                    "nothing left to estimate")
        return None

    def apply(self, ctx, v):
        rho = self.reading_correlation(v)
        ctx.reading_rho = rho if np.any(rho) else None  # 0 for every walker: the baseline

    def reading_correlation(self, v):
        return np.asarray(v["rho_e"], float)

    def injection(self, size):
        return CorrelatedErrorsInjection(self, float(size))


class CorrelatedErrorsInjection(Injection):
    """Correlated errors at a fixed ``rho_e`` for :func:`turgorbayes.simulation.cells.simulate_cells`:
    every cell's R_c and k_c noise is drawn with correlation :attr:`error_correlation` (the
    data carry no column: the correlation is the effect's to find)."""

    @property
    def error_correlation(self):
        return self.size


register_effect(CorrelatedErrors())
