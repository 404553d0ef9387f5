r"""``heavy_tails``: the cell-stiffness errors have heavier tails than a Gaussian.

Cause (docs/effects.md, heavy_tails): the slope of a force curve is read after a contact point
and a baseline have been fitted (docs/curves.md); a contact point picked a little early or
late, a baseline tilted by drift, a curve that is not quite linear over the fitted range each
move the slope by an amount that is usually small and now and then large. The reported error
then describes the spread of most readings, not the shape of their tails. Unlike
``bad_curves`` (readings too soft by a factor) or ``outliers`` (gross errors, off by a factor
up to ~10), the readings stay centred on the true stiffness with the reported variance.

Model: each ``k_c`` reading is Student-t around the model stiffness, with ``nu`` degrees of
freedom and the scale that gives it the reported variance,

.. math::

    k_{obs} = k\,(1 + r\,\epsilon), \qquad
    \epsilon \sim \sqrt{(\nu - 2)/\nu}\; t_\nu \quad (\mathrm{Var}\,\epsilon = 1),

with ``r`` the relative error of the baseline (:func:`turgorbayes.inference.observations.\
stiffness_sd`). The parameter is ``q = 2/nu`` in ``[0, 1)``: ``q = 0`` is the baseline's
Gaussian, ``q = 2/3`` is ``t_3``. ``R_c`` keeps its Gaussian error: radii come from the height
profile, not from a slope (a gross radius error is the ``outliers`` effect's).

Prior: ``q ~ Beta(1, 2)`` (density largest at the Gaussian, mean ``nu`` = 6, ``nu < 3`` with
probability 0.11).

Simulation: the Gaussian error of each reading is rescaled to a Student-t one: ``k_obs - k``
times ``sqrt((nu - 2)/W)`` with ``W ~ chi^2_nu``, a normal scale mixture that is exactly the
variance-matched ``t_nu``.
"""

import numpy as np
from scipy import special

from turgorbayes.effects.base import Effect, SqrtCoordinate
from turgorbayes.effects.registry import register_effect
from turgorbayes.inference.context import gaussian_k_logpdf, walker_column
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.observations import LOG_2PI, in_place, stiffness_sd
from turgorbayes.inference.priors import Beta

__all__ = ["HeavyTails", "Q_PRIOR", "SERIES_NU", "student_k_logpdf"]

#: Prior on ``q = 2/nu``.
Q_PRIOR = Beta(1.0, 2.0)
#: Above this ``nu`` the log-gamma ratio comes from its asymptotic series (error below 1e-20)
#: instead of a difference of two large log-gammas.
SERIES_NU = 1e4


def _log_gamma_ratio(nu):
    """``ln Gamma((nu+1)/2) - ln Gamma(nu/2) - ln(nu/2)/2``, accurate for any ``nu`` > 2 (the
    series ``-1/(8x) + 1/(192 x^3)``, ``x = nu/2``, above :data:`SERIES_NU`)."""
    x = 0.5 * nu
    big = nu > SERIES_NU
    xs = np.where(big, 1.0, x)
    direct = special.gammaln(xs + 0.5) - special.gammaln(xs) - 0.5 * np.log(xs)
    with np.errstate(divide="ignore", over="ignore"):
        series = -1.0 / (8.0 * x) + 1.0 / (192.0 * x**3)
    return np.where(big, series, direct)


def student_k_logpdf(k_obs, k, k_err, q):
    r"""Log density of a reading ``k_obs`` with a variance-matched Student-t error.

    Parameters
    ----------
    k_obs, k_err : array_like [N/m]
        Reading and its reported error.
    k : array_like [N/m]
        Model stiffness.
    q : array_like
        ``2/nu``, broadcastable to ``k``; in ``[0, 1)``.

    Returns
    -------
    ndarray [ln(m/N)]
        ``ln t_nu((k_obs - k)/s) - ln s`` with ``s = sd sqrt(1 - q)``, ``sd`` the baseline's
        sd of the reading; the Gaussian where ``q = 0`` (continuous there).
    """
    q = np.asarray(q, float)
    zero = q == 0
    qs = np.where(zero, 0.5, q)
    nu = 2.0 / qs
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = stiffness_sd(k, k_obs, k_err) * np.sqrt(1.0 - qs)
        # z = (k_obs - k)/scale and t = lgr - ln sqrt(2 pi) - ln scale - (nu + 1)/2 ln(1 +
        # z^2/nu), term by term in place (the same operations in the same order)
        z = in_place(np.divide, np.asarray(np.subtract(k_obs, k, dtype=float)), scale)
        np.multiply(z, z, out=z)
        z = in_place(np.divide, z, nu)
        np.log1p(z, out=z)
        t = in_place(np.subtract, np.subtract(_log_gamma_ratio(nu) - 0.5 * LOG_2PI, np.log(scale)),
                     in_place(np.multiply, z, 0.5 * (nu + 1)))
    # the Gaussian only where some q is 0 (else np.where would return t as it is)
    return np.where(zero, gaussian_k_logpdf(k_obs, k, k_err), t) if np.any(zero) else t


class HeavyTails(Effect):
    """Student-t stiffness errors with ``q = 2/nu`` fitted (module docstring)."""

    name = "heavy_tails"
    parameters = (Parameter("q_t", SqrtCoordinate(Q_PRIOR), "q_t", 1.0, r"$2/\nu$"),)
    size_parameter = "q_t"
    null_value = 0.0
    realistic_size = 0.5
    realistic_size_reason = (
        "q = 2/nu = 0.5 (nu = 4): the value Lange, Little & Taylor (JASA 84, 881, 1989) found "
        "to serve as a robust default over many data sets with heavy-tailed errors; it puts "
        "1.3 % of the readings beyond 3 reported sds, where a Gaussian puts 0.27 %")
    start = {"q_t": 0.05}
    replaces_k_density = True
    cause = ("The stiffness errors have heavy tails: most readings scatter as reported, but "
             "large deviations are more common than a Gaussian allows (Student-t errors, "
             "2/nu = {size:.2f}).")

    def apply(self, ctx, v):
        q = np.asarray(v["q_t"], float)

        def density(k_obs, k, k_err):
            return student_k_logpdf(k_obs, k, k_err, walker_column(q, np.ndim(k)))

        ctx.k_logpdf = density

    def observe_k(self, k_obs, k_true, v, is_cell, rng):
        # v["q_t"]: a scalar (simulation) or one value per draw, broadcastable to k_obs
        # (posterior predictive); q = 0 leaves the Gaussian error as it is
        k_obs = np.asarray(k_obs, float)
        q = np.broadcast_to(np.asarray(v["q_t"], float), k_obs.shape)
        nu = 2.0 / np.where(q > 0, q, 1.0)
        factor = np.where(q > 0, np.sqrt((nu - 2.0) / rng.chisquare(nu)), 1.0)
        return np.where(is_cell, k_true + (k_obs - k_true) * factor, k_obs)


register_effect(HeavyTails())
