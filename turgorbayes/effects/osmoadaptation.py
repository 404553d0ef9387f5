r"""``osmoadaptation``: after a shift of the medium the cells regain part of their turgor.

Cause (docs/effects.md, osmoadaptation): the osmotic series assumes that a cell's osmolytes are
conserved over the shift (Boyle-van 't Hoff), so the turgor at a level is the balance's
``P_k``. Living *E. coli* adapt: within minutes of a hyperosmotic shock they take up K+ (and
glutamate), then accumulate compatible solutes, and their volume, hence their turgor, recovers.
Pilizota & Shaevitz (PLoS ONE 7, e35205, 2012) followed single cells' volume after sucrose and
NaCl shocks: the first, fast phase of recovery takes 15-20 min with little cell-to-cell
variation (a slower phase of hours adds to it after large sucrose shocks). Cells measured by AFM
minutes after the transfer have therefore regained an unknown part of their turgor.

Model: the turgor of an intact cell at a level moves from ``P_k`` back toward ``P_phys``,

.. math:: P_i = P_k + f_i\,(P_{phys} - P_k),

so ``f = 0`` is the series model and ``f = 1`` puts every level at ``P_phys``; the cell's radius
and stiffness at ``P_i`` are the wall law's (the cell re-expands along its wall). Without a
``minutes_after_shift`` column one fraction ``f_rec`` is shared by every level (the reference
level's cells are at ``P_phys`` whatever ``f``). With the column (minutes between the cell's
transfer into its medium and its measurement; any number >= 0 on the growth medium's cells, whose
turgor it does not change) each cell has :math:`f_i = 1 - e^{-t_i/\tau}` with the time
constant ``tau_rec`` fitted.

Priors: ``f_rec ~ Beta(1, 2)`` (sampled as its square root, the null value 0 on the boundary):
mean 1/3, 95 % below 0.78, an experimenter measures soon after the transfer and without K+ in
the medium recovery is slow, while a level measured over 10-20 min with K+ present may have
recovered most of its turgor. ``tau_rec ~ LogNormal(median 6 min, log-sd 0.6)`` [s]: a first
phase complete in 15-20 min is about three time constants of 5-7 min (Pilizota & Shaevitz
2012); the log-sd covers 2-20 min at 95 %.
"""

import copy

import numpy as np

from turgorbayes.cells.medium import MINUTES_COLUMN, medium_levels, minutes_after_shift
from turgorbayes.effects.base import Effect, Injection, SqrtCoordinate
from turgorbayes.effects.registry import register_effect
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.priors import Beta, LogNormal

__all__ = ["F_REC_PRIOR", "REFERENCE_TURGOR", "TAU_REC_PRIOR", "Osmoadaptation",
           "adapted_log_turgor"]

#: Prior of the shared recovery fraction ``f_rec`` (module docstring).
F_REC_PRIOR = Beta(1.0, 2.0)
#: Prior of the recovery time constant ``tau_rec`` [s] (module docstring).
TAU_REC_PRIOR = LogNormal(360.0, 0.6)
#: Key of a simulated design's ``extra`` holding the turgor in the growth medium [Pa]
#: (written by :class:`turgorbayes.simulation.osmotic.OsmoticSeries`).
REFERENCE_TURGOR = "P_reference"


def adapted_log_turgor(log_P_level, P_phys, f):
    """``ln`` of the turgor after a recovery fraction ``f`` of the way back to ``P_phys``.

    .. math:: \\ln\\bigl(P_k + f\\,(P_{phys} - P_k)\\bigr)

    Parameters
    ----------
    log_P_level : array_like [ln Pa]
        The balance's turgor ``ln P_k`` (NaN: no state, kept NaN).
    P_phys : array_like [Pa]
    f : array_like [-]
        In [0, 1], broadcast against the others.

    Returns
    -------
    ndarray [ln Pa]
    """
    P_k = np.exp(np.asarray(log_P_level, float))
    return np.log(P_k + np.asarray(f, float) * (np.asarray(P_phys, float) - P_k))


class Osmoadaptation(Effect):
    """Recovery of the turgor at the series' levels toward ``P_phys`` (module docstring).

    The registered instance has one shared fraction ``f_rec``; bound to data with a
    ``minutes_after_shift`` column (:meth:`bind`) it has the time constant ``tau_rec`` instead.
    """

    name = "osmoadaptation"
    parameters = (Parameter("f_rec", SqrtCoordinate(F_REC_PRIOR), "f_rec", 1.0, r"$f_{rec}$"),)
    size_parameter = "f_rec"
    null_value = 0.0
    realistic_size = 0.5
    realistic_size_reason = (
        "f_rec = 0.5: half of the turgor lost at a level regained when it is measured, a level "
        "measured a few minutes after the transfer while the first phase of recovery (15-20 "
        "min with K+, Pilizota & Shaevitz 2012) is under way")
    start = {"f_rec": 0.1}
    cause = ("The cells regained turgor after the shifts of the medium (osmoadaptation: K+ "
             "uptake, then compatible solutes): at each level the turgor has moved about "
             "{size:.0%} of the way back to P_phys, which the series' conserved osmolytes "
             "cannot describe.")
    #: Minutes after the shift of every cell (NaN: bulged), when bound to data with the column.
    minutes = None

    def not_applicable_reason(self, cells):
        if medium_levels(cells).size < 2:
            return ("osmoadaptation needs an osmotic series: intact cells measured in media of "
                    "two or more osmolarities (the medium_mOsm column)")
        return None

    def bind(self, cells):
        minutes = minutes_after_shift(cells)
        if minutes is None:
            return self
        bound = _Timed()
        bound.minutes = minutes
        bound.intact = ~np.asarray(cells.is_bulged, bool)
        return bound

    def fractions(self, v):
        """Recovery fraction per walker ``(W, 1)`` (shared by every intact cell)."""
        return np.asarray(v["f_rec"], float).reshape(-1, 1)

    def apply(self, ctx, v):
        if ctx.intact_log_P is None:
            raise ValueError("osmoadaptation acts on an osmotic series: the intact cells need "
                             "their levels' turgors (turgorbayes.effects.series.SeriesModel)")
        P_phys = np.asarray(ctx.values["P_phys"], float)[:, None]
        ctx.intact_log_P = adapted_log_turgor(ctx.intact_log_P, P_phys, self.fractions(v))

    def injection(self, size):
        """Cells of a simulated osmotic series recovered by ``f_rec = size``."""
        return _Recovery(self, float(size))

    def timed_injection(self, tau_s, minutes=(5.0, 20.0)):
        """Cells of a simulated series recovered by :math:`1 - e^{-t/\\tau}`, ``t`` drawn
        uniformly in ``minutes`` per intact cell and written as the ``minutes_after_shift``
        column (``tau_s`` [s])."""
        inj = _TimedRecovery(_Timed(), float(tau_s))
        inj.span = tuple(float(m) for m in minutes)
        return inj


class _Timed(Osmoadaptation):
    """Bound to data with ``minutes_after_shift``: ``f_i = 1 - exp(-t_i/tau_rec)``."""

    parameters = (Parameter("tau_rec", TAU_REC_PRIOR, "tau_rec_s", 1.0, r"$\tau_{rec}$ [s]"),)
    size_parameter = "tau_rec"
    null_value = np.inf
    realistic_size = 360.0
    start = {"tau_rec": 1800.0}
    cause = ("The cells regained turgor after the shifts of the medium (osmoadaptation: K+ "
             "uptake, then compatible solutes) with a time constant of about {size:.0f} s, "
             "which the series' conserved osmolytes cannot describe.")
    intact = None

    def bind(self, cells):
        return Osmoadaptation.bind(self, cells)

    def restrict(self, idx):
        out = copy.copy(self)
        idx = np.asarray(idx, int)
        out.minutes, out.intact = self.minutes[idx], self.intact[idx]
        return out

    def fractions(self, v):
        t = 60.0 * self.minutes[self.intact]
        return -np.expm1(-t / np.asarray(v["tau_rec"], float).reshape(-1, 1))

    def values_for_size(self, size):
        return {"tau_rec": float(size)}


class _Recovery(Injection):
    """:class:`Injection` of a simulated series: its intact cells' turgors moved toward the
    growth medium's (the series' ``design.extra[REFERENCE_TURGOR]``)."""

    def _fractions(self, n, rng):
        return np.full(n, self.values["f_rec"])

    def pressures(self, design, rng):
        if REFERENCE_TURGOR not in design.extra:
            raise ValueError("osmoadaptation is simulated on an osmotic series only "
                             "(simulate --osmotic-series)")
        intact = ~np.asarray(design.is_bulged)
        P = np.array(design.P, float)
        f = self._fractions(int(intact.sum()), rng)
        P[intact] = np.exp(adapted_log_turgor(np.log(P[intact]),
                                              design.extra[REFERENCE_TURGOR], f))
        design.P[:] = P
        return design


class _TimedRecovery(_Recovery):
    """Per-cell times after the shift, written as the ``minutes_after_shift`` column."""

    span = (5.0, 20.0)
    drawn = None

    def _fractions(self, n, rng):
        self.drawn = rng.uniform(*self.span, n)
        return -np.expm1(-60.0 * self.drawn / self.values["tau_rec"])

    def observations(self, obs, design, rng):
        obs = super().observations(obs, design, rng)
        column = np.full(design.P.size, "", dtype=object)
        column[~np.asarray(design.is_bulged)] = [f"{t:.2f}" for t in self.drawn]
        obs.setdefault("extra", {})[MINUTES_COLUMN] = list(column)
        return obs


register_effect(Osmoadaptation())
