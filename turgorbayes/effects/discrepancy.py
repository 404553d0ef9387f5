r"""``discrepancy``: a generic description of misfit that names no physical cause.

Why (docs/effects.md, discrepancy): the library of effects is never complete. When the data
hold a cause no effect describes, the model comparison would otherwise pick whichever named
effect bends furthest towards the data and report it as the cause. This candidate gives the
model average and the verdict somewhere honest to go: it absorbs misfit as extra scatter and
says where the scatter is, without claiming why.

Model: a cell's true ``ln R_c`` and ``ln k_c`` deviate from the model's by
:math:`(a_i, b_i) \sim N\!\left(0, \begin{pmatrix} s_R^2 & \rho s_R s_k \\ \rho s_R s_k & s_k^2
\end{pmatrix}\right)`, with ``s_R``, ``s_k`` separate for the bulged and the intact cells
(four sds) and one correlation ``rho`` (a hidden cause shared by a cell's two readings, such as
a pressure or a width of its own, moves both). To first order the readings are then jointly
Gaussian about the model with covariance

.. math::

    \Sigma_i = \begin{pmatrix} \sigma_{R,i}^2 + R^2 s_R^2 & \rho R k s_R s_k \\
    \rho R k s_R s_k & \sigma_{k,i}^2 + k^2 s_k^2 \end{pmatrix},

``sigma`` the reported errors (the baseline's relative stiffness error). Priors: each sd
``HalfNormal(0.1)`` (sampled as sqrt), ``rho`` uniform on [-0.9, 0.9]. It never becomes a
named cause (:attr:`names_cause` is False) and describes misfit only on its own: it is not
combined with other effects.
"""

import numpy as np

from turgorbayes.effects.base import Effect, SqrtCoordinate
from turgorbayes.effects.registry import register_effect
from turgorbayes.inference.context import average_variants, walker_column
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.observations import LOG_2PI, stiffness_sd
from turgorbayes.inference.priors import HalfNormal, Uniform
from turgorbayes.inference.reading_correlation import known_rho, readings

__all__ = ["SCATTER_PRIOR", "Discrepancy", "bivariate_logpdf"]

#: Prior of each extra log-scatter sd.
SCATTER_PRIOR = HalfNormal(0.1)
#: Groups and observables of the four sds, in parameter order.
_SDS = (("bulged", "R_c"), ("bulged", "k_c"), ("intact", "R_c"), ("intact", "k_c"))
#: A described extra scatter is named when its median exceeds this (log units).
NAMED_SCATTER = 0.02


def _sd_name(group, quantity):
    return f"s_{quantity[0]}_{group}"


def bivariate_logpdf(R_obs, R, R_err, k_obs, k, k_err, s_R, s_k, rho, rho_obs=0.0):
    r"""Log density of a cell's two readings with the extra correlated scatter (module docstring).

    Parameters
    ----------
    R_obs, R_err : array_like [m]
    R : array_like [m]
        Model radius.
    k_obs, k_err : array_like [N/m]
    k : array_like [N/m]
        Model stiffness.
    s_R, s_k : array_like
        Extra sd of ``ln R_c`` and ``ln k_c``.
    rho : array_like
        Correlation of the two extra deviations.
    rho_obs : array_like
        Correlation of the two readings' measurement errors (the ``rho_R_c_k_c`` column,
        docs/statistics.md, "Correlated readings"; 0: independent).

    Returns
    -------
    ndarray
        :math:`\ln N_2((R_{obs}, k_{obs}); (R, k), \Sigma)`; NaN where ``R`` or ``k`` is.
    """
    sd_k = stiffness_sd(k, k_obs, k_err)
    vR = R_err**2 + (R * s_R) ** 2
    vk = sd_k**2 + (k * s_k) ** 2
    c = rho * R * s_R * k * s_k + rho_obs * R_err * sd_k
    det = vR * vk - c * c
    dR, dk = R_obs - R, k_obs - k
    quad = (vk * dR * dR - 2 * c * dR * dk + vR * dk * dk) / det
    return -0.5 * quad - 0.5 * np.log(det) - LOG_2PI


class Discrepancy(Effect):
    """Extra correlated scatter of ``ln R_c`` and ``ln k_c`` per group (module docstring)."""

    name = "discrepancy"
    parameters = tuple(
        Parameter(_sd_name(g, q), SqrtCoordinate(SCATTER_PRIOR), _sd_name(g, q), 1.0,
                  rf"$s_{{{q[0]},{g[0]}}}$") for g, q in _SDS) + (
        Parameter("rho_d", Uniform(-0.9, 0.9), "rho_d", 1.0, r"$\rho_d$"),)
    size_parameter = "s_k_intact"
    null_value = 0.0
    realistic_size = 0.15
    realistic_size_reason = (
        "0.15: extra scatter comparable to the reported k_c errors (10-20 %), the size at which "
        "misfit of unknown origin matters for P_phys")
    start = {"s_R_bulged": 0.01, "s_k_bulged": 0.02, "s_R_intact": 0.01, "s_k_intact": 0.02,
             "rho_d": 0.0}
    cause = ("The data scatter more than the model and the reported errors allow (extra "
             "scatter of about {size:.0%} in the intact cells' stiffness); no effect in the "
             "library names why.")
    names_cause = False
    is_bulged = None  # per cell, once bound to a data set

    def bind(self, cells):
        bound = Discrepancy()
        bound.is_bulged = np.asarray(cells.is_bulged, bool)
        return bound

    def restrict(self, idx):
        if self.is_bulged is None:
            return self
        out = Discrepancy()
        out.is_bulged = self.is_bulged[np.asarray(idx, int)]
        return out

    def apply(self, ctx, v):
        if not ctx.gaussian() or ctx.cell_logpdf_by_group:
            raise ValueError("the discrepancy effect describes misfit on its own; it does not "
                             "combine with effects that change the cells' density")
        rho = np.asarray(v["rho_d"], float)
        for group in ("bulged", "intact"):
            s_R = np.asarray(v[_sd_name(group, "R_c")], float)
            s_k = np.asarray(v[_sd_name(group, "k_c")], float)
            ctx.cell_logpdf_by_group[group] = _group_logpdf(s_R, s_k, rho)

    def values_for_size(self, size):
        return {n: float(size) if n.startswith("s_") else 0.0 for n in self.start}

    def observe_k(self, k_obs, k_true, v, is_cell, rng):
        a, b = self._draw(np.shape(k_obs), v, rng)
        self._pending_R = a  # the same cells' radius deviations (observe_R is called next)
        return np.where(is_cell, k_obs * np.exp(b), k_obs)

    def observe_R(self, R_obs, v, is_cell, rng):
        a = getattr(self, "_pending_R", None)
        self._pending_R = None
        if a is None or np.shape(a) != np.shape(R_obs):
            a, _ = self._draw(np.shape(R_obs), v, rng)
        return np.where(is_cell, R_obs * np.exp(a), R_obs)

    def _draw(self, shape, v, rng):
        """Correlated extra deviations ``(a, b)`` of ``ln R_c``, ``ln k_c``, each ``shape``."""
        bulged = (np.ones(shape[-1], bool) if self.is_bulged is None
                  or self.is_bulged.size != shape[-1] else self.is_bulged)
        s_R = np.where(bulged, v["s_R_bulged"], v["s_R_intact"])
        s_k = np.where(bulged, v["s_k_bulged"], v["s_k_intact"])
        z = rng.standard_normal((2,) + tuple(shape))
        rho = np.asarray(v["rho_d"], float)
        a = s_R * z[0]
        b = s_k * (rho * z[0] + np.sqrt(1 - rho**2) * z[1])
        return a, b

    def channel_scales(self, summary):
        """``{observable: s}``: for ``R_c`` and ``k_c``, the larger of the two groups' median
        extra log-scatter in a posterior ``summary`` of this effect
        (:mod:`turgorbayes.criticism.misfit_band`)."""
        return {q: max(float(summary[_sd_name(g, q)]["q50"]) for g in ("bulged", "intact"))
                for q in ("R_c", "k_c")}

    def describe(self, summary):
        """What the fitted scatter absorbed, as one phrase (``summary``: parameter summaries
        keyed as in ``summary.json``)."""
        parts = []
        for g, q in _SDS:
            s = summary[_sd_name(g, q)]
            if s["q50"] > NAMED_SCATTER:
                parts.append(f"{s['q50']:.0%} [{s['q05']:.0%}, {s['q95']:.0%}] in {q} of the "
                             f"{g} cells")
        what = "; ".join(parts) if parts else "little extra scatter anywhere"
        r = summary["rho_d"]
        if r["q05"] > 0 or r["q95"] < 0:
            what += (f"; a cell's R_c and k_c deviations are correlated (rho {r['q50']:.2f} "
                     f"[{r['q05']:.2f}, {r['q95']:.2f}])")
        return "extra scatter of " + what


def _group_logpdf(s_R, s_k, rho):
    """The cell density of one group: :func:`bivariate_logpdf` averaged over wall variants."""
    def cell_logpdf(ctx, lnR, lnk, obs, log_w):
        R_obs, R_err, k_obs, k_err, rho_obs = readings(obs)
        rho_obs = known_rho(rho_obs)
        nd = lnR.ndim
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            f = bivariate_logpdf(R_obs, np.exp(lnR), R_err, k_obs, np.exp(lnk), k_err,
                                 walker_column(s_R, nd), walker_column(s_k, nd),
                                 walker_column(rho, nd), 0.0 if rho_obs is None else rho_obs)
        return average_variants(f, log_w)
    return cell_logpdf


register_effect(Discrepancy())
