"""The conditions of a data set: the ``condition`` column's labels and the design
(:class:`ConditionSet`: the reference, which wall quantities each condition has of its own or
tied to the reference's by :data:`WALL_PRIOR`); docs/statistics.md, "Several conditions".
The model on this design is :mod:`turgorbayes.inference.conditions`.
"""

import dataclasses

import numpy as np

from turgorbayes.cells.columns import CONDITION_COLUMN
from turgorbayes.errors import DataError

__all__ = [
    "CONDITION_COLUMN",
    "FREEABLE",
    "MIN_BULGED",
    "PER_CONDITION",
    "SEP",
    "WALL_DIFFERENCE",
    "WALL_PRIOR",
    "ConditionSet",
    "condition_labels",
    "condition_set",
]

#: Parameters that are per condition in every condition model.
PER_CONDITION = ("P_phys", "R0")
#: Wall parameters ``per_condition`` may free (shared otherwise).
FREEABLE = ("gamma", "E0t")
#: Posterior-variable separator: ``P_phys__1`` is P_phys of the condition with index 1.
SEP = "__"
#: The default prior on how far a condition's wall may differ from the reference's: the sd
#: of ``ln(E0t[c] / E0t[ref])`` and of ``gamma[c] - gamma[ref]`` (docs/statistics.md, "A wall
#: that may differ"): treatments and mutants change the E. coli envelope's stiffness by tens
#: of percent, rarely by more than a factor of two, so an E0t ratio of 0.7 or 1.4 is one sd
#: and 0.5 or 2 two sd; gamma has no published treatment series, 0.2 is 1.7 times the
#: paper's own uncertainty of gamma (1.22 +- 0.12).
WALL_PRIOR = {"E0t": 0.35, "gamma": 0.2}
#: Bulged cells a condition needs for its own wall to be checked (the ``conditions_R_c_k_c``
#: check) or estimated as a criticism candidate (:mod:`turgorbayes.effects.own_wall`).
MIN_BULGED = 4
#: The sampled wall difference of each prior-tied quantity, quantity -> its variable's name:
#: ``E0t[c] = E0t[ref] exp(ln_E0t_ratio)``, ``gamma[c] = gamma[ref] + gamma_difference``.
WALL_DIFFERENCE = {"E0t": "ln_E0t_ratio", "gamma": "gamma_difference"}


def condition_labels(cells):
    """Each cell's condition label (tuple of str), or None without a ``condition`` column.

    Raises
    ------
    DataError
        A cell with an empty label (file, column and the cells named).
    """
    labels = cells.extra.get(CONDITION_COLUMN)
    if labels is None:
        return None
    empty = [cid for cid, lab in zip(cells.cell_id, labels, strict=True) if not lab.strip()]
    if empty:
        raise DataError(
            f"empty condition for cell_id {', '.join(map(repr, empty[:5]))}"
            f"{f' and {len(empty) - 5} more' if len(empty) > 5 else ''}; every row needs its "
            "condition (any non-empty text, e.g. wt or treated)",
            path=cells.path, column=CONDITION_COLUMN, value="")
    return tuple(lab.strip() for lab in labels)


@dataclasses.dataclass(frozen=True)
class ConditionSet:
    """The conditions of a data set and which parameters each one has of its own.

    Attributes
    ----------
    names : tuple of str
        Conditions in file order (of their first row).
    index : ndarray of int (n_cells,)
        Each cell's condition, an index into ``names``.
    reference : str
        The condition every contrast is taken against.
    freed : dict
        Quantity in :data:`FREEABLE` -> tuple of the conditions that have their own (flat
        prior).
    wall_prior : dict
        Quantity in :data:`FREEABLE` -> sd of its difference from the reference condition's
        (:data:`WALL_PRIOR`); every other condition's, unless freed, is tied to the
        reference's by that prior. Empty: the wall is shared.
    bulged : tuple of bool
        Whether each condition has bulged cells (only they measure its pressure directly).
    series : tuple of bool
        Whether each condition's intact cells were measured in media of several
        osmolarities (an osmotic series, which measures its wall without bulged cells:
        :mod:`turgorbayes.inference.osmotic_conditions`); empty: none was.
    shared : tuple of str
        What else the conditions share, in words, for :meth:`assumptions` (e.g. the
        osmotically inactive fraction of a series).
    """

    names: tuple
    index: np.ndarray
    reference: str
    freed: dict
    wall_prior: dict = dataclasses.field(default_factory=dict)
    bulged: tuple = ()
    series: tuple = ()
    shared: tuple = ()

    @property
    def ref(self):
        """Index of the reference condition."""
        return self.names.index(self.reference)

    def own(self, quantity, c):
        """Whether condition index ``c`` has its own ``quantity`` (else the shared one)."""
        return (quantity in PER_CONDITION or self.names[c] in self.freed.get(quantity, ())
                or self.tied(quantity, c) or self.released(quantity, c))

    def _prior_wall(self, quantity, c):
        return (quantity in self.wall_prior and c != self.ref
                and self.names[c] not in self.freed.get(quantity, ()))

    def tied(self, quantity, c):
        """Whether condition index ``c``'s ``quantity`` is sampled as the reference's times
        (E0t) or plus (gamma) a difference under :attr:`wall_prior`: a condition with bulged
        cells, whose data inform its wall."""
        return self._prior_wall(quantity, c) and self.has_bulged(c)

    def released(self, quantity, c):
        """Whether condition index ``c``'s ``quantity`` differs from the reference's under
        :attr:`wall_prior` although its data cannot tell (no bulged cells): sampled shared,
        then released by :mod:`turgorbayes.inference.wall_release`."""
        return self._prior_wall(quantity, c) and not self.has_bulged(c)

    def has_bulged(self, c):
        """Whether condition index ``c`` has bulged cells (True when not recorded)."""
        return bool(self.bulged[c]) if self.bulged else True

    def measures_wall(self, c):
        """Whether condition index ``c``'s own data measure its wall: bulged cells, or an
        osmotic series of intact cells."""
        return self.has_bulged(c) or bool(self.series and self.series[c])

    def difference_variable(self, quantity, c):
        """The sampled difference of a tied ``quantity`` of condition index ``c``."""
        return f"{WALL_DIFFERENCE[quantity]}{SEP}{c}"

    def assumptions(self, c):
        """What the contrast of condition index ``c`` against the reference assumes about
        the wall (list of phrases, then :attr:`shared`) and whether the data check it
        (bool): bulged cells or an osmotic series in both conditions measure each one's
        wall."""
        out = []
        for q in FREEABLE:
            if self._prior_wall(q, c):
                sd = self.wall_prior[q]
                out.append(f"ln({q} ratio) ~ N(0, {sd:g})" if q == "E0t"
                           else f"{q} difference ~ N(0, {sd:g})")
            elif not self.own(q, c) and not self.own(q, self.ref):
                out.append(f"{q} shared")
        return out + list(self.shared), self.measures_wall(c) and self.measures_wall(self.ref)

    def variable(self, quantity, c):
        """Posterior variable of ``quantity`` in condition index ``c``."""
        return f"{quantity}{SEP}{c}" if self.own(quantity, c) else quantity

    def quantities(self, c):
        """The quantities condition index ``c`` has of its own, in (P, gamma, E0t, R0) order."""
        return tuple(q for q in ("P_phys", "gamma", "E0t", "R0") if self.own(q, c))

    def modulus_variable(self, name, c):
        """Posterior variable of the wall modulus ``name`` (``"E_perp"``, ``"E_par"``) at
        condition index ``c``'s own turgor: the baseline name for the reference condition."""
        return name if c == self.ref else f"{name}{SEP}{c}"


def condition_set(cells, reference=None, per_condition=(), wall_prior=None):
    """The :class:`ConditionSet` of ``cells`` (one condition ``"all"`` without the column).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
    reference : str, optional
        The reference condition; the first in file order if None.
    per_condition : sequence of str
        ``"E0t"`` / ``"gamma"`` (every condition has its own) or ``"E0t:NAME"`` (condition
        NAME only).
    wall_prior : dict, optional
        ``{"E0t": sd, "gamma": sd}`` (a subset): each other condition's wall may differ from
        the reference's under that prior (:data:`WALL_PRIOR`); None or empty: one wall.

    Raises
    ------
    DataError
        Unknown reference or condition; a freed parameter in a condition without bulged
        cells (its data cannot identify it).
    """
    labels = condition_labels(cells) or ("all",) * len(cells)
    names = tuple(dict.fromkeys(labels))
    index = np.array([names.index(lab) for lab in labels], dtype=int)
    if reference is None:
        reference = names[0]
    if reference not in names:
        raise DataError(f"reference condition {reference!r} is not in the data (conditions: "
                        f"{', '.join(map(repr, names))})", path=cells.path,
                        column=CONDITION_COLUMN, value=reference)
    freed = _freed(cells, names, index, per_condition)
    prior = _wall_prior(wall_prior)
    bulged = tuple(bool(np.any(cells.is_bulged[index == c])) for c in range(len(names)))
    return ConditionSet(names=names, index=index, reference=reference, freed=freed,
                        wall_prior=prior if len(names) > 1 else {}, bulged=bulged)


def _wall_prior(wall_prior):
    prior = dict(wall_prior or {})
    for q, sd in prior.items():
        if q not in FREEABLE:
            raise DataError(f"wall prior: {q!r} is not a wall parameter (only "
                            f"{' and '.join(FREEABLE)} may differ between conditions)", value=q)
        if not np.isfinite(sd) or sd <= 0:
            raise DataError(f"wall prior: the sd of {q}'s difference must be a positive number, "
                            f"got {sd!r} (use --assume-shared-wall for one wall)", value=sd)
    return {q: float(prior[q]) for q in FREEABLE if q in prior}


def _freed(cells, names, index, per_condition):
    freed = {}
    for spec in per_condition:
        quantity, _, which = str(spec).partition(":")
        if quantity not in FREEABLE:
            raise DataError(f"--per-condition {spec!r}: only {' and '.join(FREEABLE)} can be "
                            "freed per condition (P_phys and R0 always are)", value=spec)
        chosen = names if not which else (which,)
        for name in chosen:
            if name not in names:
                raise DataError(f"--per-condition {spec!r}: no condition {name!r} in the data "
                                f"(conditions: {', '.join(map(repr, names))})", path=cells.path,
                                column=CONDITION_COLUMN, value=name)
            c = names.index(name)
            if not np.any(cells.is_bulged[index == c]):
                raise DataError(
                    f"--per-condition {spec!r} refused: condition {name!r} has no bulged cells, "
                    f"and without them its data cannot tell its own {quantity} from its turgor "
                    "(only bulges measure a cell's pressure)", path=cells.path,
                    column=CONDITION_COLUMN, value=name)
            freed[quantity] = tuple(dict.fromkeys(freed.get(quantity, ()) + (name,)))
    return freed
