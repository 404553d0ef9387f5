r"""``bad_curves``: a fraction of the cell-stiffness readings is corrupted.

Cause (docs/effects.md, bad_curves): some force curves in any AFM data set are bad; on a cylinder the
usual failure is the tip slipping off the crest of the cell, so the cantilever meets a flank
at an angle, part of the motion is sliding, and the slope read as ``k_c`` is too low and
erratic.

Model: each cell's ``k_c`` reading (either group) is, with probability ``f`` (fitted), a
corrupted one; a mixture likelihood

.. math::

    p(k_{obs}\mid k) = (1-f)\,N(k_{obs}; k, \delta k) + f\,
    \frac{1}{k_{obs}}N\!\left(\ln k_{obs};\ \ln k + \ln r_{bad},\ \sigma_{bad}\right),

whose corrupted component is a fixed definition: a reading ``r_bad`` = 0.5 times the true
stiffness (median) with a log-sd ``sigma_bad`` = 0.4 (a factor 1.5) between curves
(:data:`BAD_MEDIAN_RATIO`, :data:`BAD_LOG_SD`). ``R_c`` is unaffected (it comes from the
contact point). Fixing the component's shape keeps ``f`` identifiable with 114 cells.

Prior: ``f ~ Beta(1, 9)`` (mean 0.1, density largest at ``f = 0``).
"""

import numpy as np

from turgorbayes.effects.base import Effect, SqrtCoordinate
from turgorbayes.effects.registry import FAULTY_READINGS, register_effect
from turgorbayes.inference.context import walker_column
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.observations import gaussian_logpdf, in_place
from turgorbayes.inference.priors import Beta

__all__ = ["BAD_LOG_SD", "BAD_MEDIAN_RATIO", "BadCurves", "F_PRIOR", "corrupted_logpdf"]

#: Median of (corrupted reading)/(true stiffness).
BAD_MEDIAN_RATIO = 0.5
#: Log-sd of corrupted readings around that median.
BAD_LOG_SD = 0.4
#: Prior on the corrupted fraction.
F_PRIOR = Beta(1.0, 9.0)


def corrupted_logpdf(k_obs, k):
    r"""Log density of a corrupted reading: lognormal around ``r_bad k`` with log-sd ``sigma_bad``.

    Parameters
    ----------
    k_obs : array_like [N/m]
        Reading, > 0.
    k : array_like [N/m]
        Model stiffness.

    Returns
    -------
    ndarray [ln(m/N)]
    """
    k_obs = np.asarray(k_obs, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        mu = in_place(np.add, np.asarray(np.log(k)), np.log(BAD_MEDIAN_RATIO))
        log_k_obs = np.log(k_obs)
        return in_place(np.subtract, gaussian_logpdf(log_k_obs, mu, BAD_LOG_SD), log_k_obs)


class BadCurves(Effect):
    """Mixture of good and corrupted ``k_c`` readings with fitted fraction ``f`` (module docstring)."""

    gross_errors = True
    family = FAULTY_READINGS
    name = "bad_curves"
    parameters = (Parameter("f_bad", SqrtCoordinate(F_PRIOR), "f_bad", 1.0, r"$f_{bad}$"),)
    size_parameter = "f_bad"
    null_value = 0.0
    realistic_size = 0.1
    realistic_size_reason = (
        "f = 0.1 (about 11 of 114 curves): AFM studies of live bacteria typically discard "
        "5-20 % of force curves as slipped or otherwise bad")
    start = {"f_bad": 0.02}
    cause = ("Some stiffness measurements are bad: about {size:.0%} of the force curves read a "
             "stiffness that is too low, as when the AFM tip slips off the top of the cell.")

    def apply(self, ctx, v):
        good = ctx.k_logpdf
        f = np.asarray(v["f_bad"], float)

        def good_branch(k_obs, k, k_err):  # the curve read correctly: ln((1-f) good)
            return good(k_obs, k, k_err) + np.log1p(-walker_column(f, np.ndim(k)))

        def mixture(k_obs, k, k_err):
            fw = walker_column(f, np.ndim(k))
            a = good(k_obs, k, k_err) + np.log1p(-fw)
            b = in_place(np.add, corrupted_logpdf(k_obs, k), np.log(fw))
            return in_place(np.logaddexp, a, b, into=b)

        # correlated readings condition the good branch only (inference.context.reading_logpdf)
        mixture.good, mixture.good_branch = good, good_branch
        ctx.k_logpdf = mixture

    def observe_k(self, k_obs, k_true, v, is_cell, rng):
        k_obs = np.asarray(k_obs, float)
        bad = (rng.random(k_obs.shape) < v["f_bad"]) & is_cell
        corrupted = k_true * BAD_MEDIAN_RATIO * np.exp(BAD_LOG_SD * rng.standard_normal(k_obs.shape))
        return np.where(bad, corrupted, k_obs)


register_effect(BadCurves())
