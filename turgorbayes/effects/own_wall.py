r"""``own_wall``: a condition's wall stiffness differs from the reference condition's.

Cause (docs/effects.md, own_wall): a treatment that acts on the envelope (an antibiotic
against wall synthesis, a mutant of a wall enzyme, another growth medium) changes the wall,
not (only) the turgor. The baseline with several conditions shares the wall (``gamma``,
``E0t``) between them, so such a change is read as a change of ``P_phys``; the check
``conditions_R_c_k_c`` flags it where bulged cells of two conditions show it.

Model: each condition ``c`` other than the reference that has at least
:data:`~turgorbayes.inference.conditions.MIN_BULGED` bulged cells (whose bulges measure its
cells' pressures, so that its wall is identified) has its own
``E0t[c] = E0t[ref] exp(r_c)``, for its bulged and intact cells alike; ``gamma`` stays shared
(its difference is second order and weakly identified at tens of bulged cells per
condition; ``criticize --per-condition gamma`` frees it too).

Prior: ``r_c ~ N(0, 0.35)``, the fit's wall prior
(:data:`turgorbayes.inference.conditions.WALL_PRIOR`, justified in docs/statistics.md, "A wall
that may differ"): an E0t ratio of 0.7 or 1.4 is one sd. The reported ``E0t`` of condition
``c`` (posterior variable ``E0t__c``, :meth:`OwnWall.wall_ratios`) is the derived product.

Not a candidate for data of one condition, or where fewer than two conditions (the reference
among them) have enough bulged cells: there the data cannot tell a condition's wall from its
turgor (docs/statistics.md).
"""

import copy

import numpy as np

from turgorbayes.effects.base import Effect
from turgorbayes.effects.registry import register_effect
from turgorbayes.errors import DataError
from turgorbayes.inference.conditions import (
    CONDITION_COLUMN,
    MIN_BULGED,
    SEP,
    WALL_PRIOR,
    condition_set,
)
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.priors import Normal

__all__ = ["OwnWall", "RATIO_PRIOR"]

#: Prior on each condition's ``ln(E0t[c] / E0t[ref])``: the fit's wall prior.
RATIO_PRIOR = Normal(0.0, WALL_PRIOR["E0t"])
#: The sampled log ratio (its name; a bound instance appends ``__c``).
_RATIO = "ln_E0t_ratio"


def _own_conditions(cells):
    """The condition set of ``cells`` and the indices of the conditions other than the
    reference with enough bulged cells for a wall of their own (empty when the reference
    lacks them)."""
    cs = condition_set(cells)
    counts = [int(np.sum(cells.is_bulged[cs.index == c])) for c in range(len(cs.names))]
    if len(cs.names) < 2 or counts[cs.ref] < MIN_BULGED:
        return cs, ()
    return cs, tuple(c for c in range(len(cs.names))
                     if c != cs.ref and counts[c] >= MIN_BULGED)


class OwnWall(Effect):
    """Each condition with enough bulged cells has its own ``E0t`` (module docstring).

    The registered instance has one log ratio; :meth:`bind` gives the instance for one data
    set, with ``ln_E0t_ratio__c`` for each condition ``c`` of its own (key
    ``ln_E0t_ratio[NAME]``), and :meth:`restrict` the instance of one condition's cells.
    """

    name = "own_wall"
    parameters = (Parameter(_RATIO, RATIO_PRIOR, _RATIO, 1.0, r"$\ln(E_0t_c/E_0t_{ref})$"),)
    size_parameter = _RATIO
    null_value = 0.0
    realistic_size = float(np.log(0.7))
    realistic_size_reason = (
        "ln(0.7): a wall 30 % softer, the size of the stiffness changes measured under "
        "treatments that act on the envelope (docs/statistics.md, 'A wall that may differ')")
    start = {_RATIO: 0.0}
    cause = ("The wall differs between conditions: the wall stiffness E0t of a condition is "
             "its own (ln ratio to the reference {size:+.2f}), so part of what the shared wall "
             "reads as a change of turgor is a change of the wall.")
    #: The wall quantities whose ratio to the reference the effect samples, per condition
    #: (what it touches: :class:`turgorbayes.effects.conditions.ConditionsExtendedModel`
    #: reports each condition's value).
    wall_quantities = ("E0t",)
    names = ()
    reference = None
    own = ()
    index = None
    condition = None

    def not_applicable_reason(self, cells):
        cs, own = _own_conditions(cells)
        if len(cs.names) < 2:
            return (f"a wall of a condition's own needs a {CONDITION_COLUMN!r} column naming "
                    "two or more conditions")
        if not own:
            return (f"a wall of a condition's own needs bulged cells (at least {MIN_BULGED}) in "
                    f"the reference condition {cs.reference!r} and in another: without them "
                    "the data cannot tell a condition's wall from its turgor")
        return None

    def bind(self, cells):
        reason = self.not_applicable_reason(cells)
        if reason:
            raise DataError(reason, path=cells.path, column=CONDITION_COLUMN)
        cs, own = _own_conditions(cells)
        bound = OwnWall()
        bound.names, bound.own, bound.index = cs.names, own, cs.index
        bound.reference = cs.reference
        bound.parameters = tuple(
            Parameter(f"{_RATIO}{SEP}{c}", RATIO_PRIOR, f"{_RATIO}[{cs.names[c]}]", 1.0,
                      rf"$\ln(E_0t/E_0t_{{ref}})$ {cs.names[c]}") for c in own)
        bound.size_parameter = bound.parameters[0].name
        bound.start = {p.name: 0.0 for p in bound.parameters}
        return bound

    def restrict(self, idx):
        """The effect on the cells ``idx`` of one condition: the same parameters, acting on
        that condition's wall only."""
        if not self.own:
            return self
        conditions = np.unique(self.index[np.asarray(idx, int)])
        if conditions.size != 1:
            raise ValueError("own_wall is restricted to the cells of one condition")
        out = copy.copy(self)
        out.condition = int(conditions[0])
        return out

    def wall_ratios(self):
        """``{(quantity, condition index): parameter name}`` of the log ratios."""
        return {(q, c): f"{_RATIO}{SEP}{c}" for q in self.wall_quantities for c in self.own}

    def _log_ratio(self, v):
        """This condition's log ratio (walkers' values as given), or None for the reference
        and for a condition that shares the wall."""
        if self.condition is None or self.condition not in self.own:
            return None
        return np.asarray(v[f"{_RATIO}{SEP}{self.condition}"], float)

    def apply(self, ctx, v):
        r = self._log_ratio(v)
        if r is None:
            return
        for group in ("bulged", "intact"):
            wall = ctx.walls[group]
            wall["E0t"] = wall["E0t"] * np.exp(r.reshape(-1))[:, None]

    def cell_walls(self, walls, v, is_bulged, rng):
        r = self._log_ratio(v)
        if r is None:
            return walls
        walls = dict(walls)
        walls["E0t"] = walls["E0t"] * np.exp(r)
        return walls

    def cause_text(self, summary):
        """The cause with each condition's fitted ratio (median of ``exp(r_c)``)."""
        ratios = [f"{self.names[c]} is {np.exp(summary[p.key]['q50']):.2f} times "
                  f"{self.reference}'s" for c, p in zip(self.own, self.parameters, strict=True)]
        return ("The wall differs between conditions: the wall stiffness E0t of "
                + "; of ".join(ratios) + " (median ratio), so part of what a shared wall "
                "reads as a change of turgor is a change of the wall.")

    def injection(self, size):
        raise ValueError("own_wall is planted per condition: simulate two conditions with "
                         "`turgorbayes simulate --conditions NAME:kPa,... --condition-wall NAME:E0t=F` "
                         "(docs/effects.md, own_wall)")


register_effect(OwnWall())
